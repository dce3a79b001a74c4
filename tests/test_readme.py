"""The README's Python quickstart runs as written (with shortened durations and a temporary output)."""

from __future__ import annotations

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_blocks_run(tmp_path, monkeypatch):
    text = README.read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 2
    code = "\n".join(blocks)
    # shorten every run(...) to 20 ms and send outputs to tmp_path
    code, n = re.subn(r"\.run\(([0-9.]+), output_dir=\"[^\"]+\"\)", r'.run(0.02, output_dir=OUT)', code)
    assert n >= 2, "the README's runs changed shape; update this test"
    monkeypatch.chdir(tmp_path)
    namespace = {"OUT": str(tmp_path / "out")}
    exec(compile(code, str(README), "exec"), namespace)  # noqa: S102 - our own documentation
    assert (tmp_path / "out" / "log.parquet").exists()
