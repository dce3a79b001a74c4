"""The README's Python quickstart runs as written (with shortened durations and a temporary output)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)


def test_readme_has_python_blocks_using_only_the_public_api():
    assert len(BLOCKS) >= 2
    for code in BLOCKS:
        imports = re.findall(r"^(?:from|import) (\S+)", code, re.M)
        assert set(imports) <= {"numpy", "knotsim"}, imports


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_python_block_runs_on_its_own(tmp_path, monkeypatch, index):
    """Each block runs as written, alone (shortened to 20 ms, output in a temporary directory)."""
    code, n = re.subn(r"\.run\(([0-9.]+), output_dir=\"[^\"]+\"\)", r'.run(0.02, output_dir=OUT)', BLOCKS[index])
    assert n == 1, "the README's runs changed shape; update this test"
    monkeypatch.chdir(tmp_path)
    namespace = {"OUT": str(tmp_path / "out")}
    exec(compile(code, str(README), "exec"), namespace)  # noqa: S102 - our own documentation
    assert (tmp_path / "out" / "log.parquet").exists()


def test_readme_shell_quickstart_uses_pull_and_tie():
    shell = "\n".join(re.findall(r"```bash\n(.*?)```", README.read_text(), re.S))
    assert "knotsim pull" in shell and "knotsim tie" in shell
