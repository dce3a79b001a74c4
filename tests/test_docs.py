"""The documentation is executed and checked against the code.

- Every ```python and ```bash block of README.md and docs/*.md runs, document by document, in
  one temporary working directory per document (with ``examples/`` linked in), blocks in order, so
  a later block can use what an earlier one wrote. A block preceded by ``<!-- not-run: reason -->``
  is skipped (a long job); such exceptions are counted and kept few.
- Python blocks are exec'd with simulated durations shortened to 20 ms (``.run(T, ...)``,
  ``duration=T``).
- Bash blocks: each ``knotsim ...`` command goes through click's CliRunner. ``run`` commands run
  for real with ``--duration 0.02``; commands that only read (``knots``, ``--help``, ``--list``,
  ``--show-params``, and ``view``/``export-vtk``/``render`` on a run directory that exists) run for
  real; the long ones (``pull``, ``tie``, ``study``, ``validate``, ...) are checked against their
  ``--help``: the command exists and accepts every option the document gives it. Lines that are
  not knotsim commands (``pip``, ``python -m pytest``, scripts) are not run.
- docs/run-files.md names every key the run-file schema accepts.
"""

from __future__ import annotations

import dataclasses
import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"(?:<!--\s*not-run:(?P<why>[^>]*)-->\s*\n)?```(?P<lang>python|bash)\n(?P<code>.*?)```", re.S)
#: most blocks skipped, over all documents (today: 5 long jobs or cluster set-ups, 3 fragments of
#: docs/boundary-conditions.md, 1 block of docs/run-files.md waiting for a fix of ``ks.run``)
MAX_NOT_RUN = 9
SHORT = "0.02"
#: commands run for real whatever their arguments
READ_ONLY = {"knots"}
#: commands run for real when their first argument (a run directory) exists
ON_RUN_DIR = {"view", "export-vtk", "render"}


def _blocks(path: Path) -> list[tuple[str, str, str | None]]:
    return [(m["lang"], m["code"], m["why"]) for m in BLOCK.finditer(path.read_text())]


def test_few_blocks_are_skipped():
    skipped = [(p.name, why.strip()) for p in DOCS for _, _, why in _blocks(p) if why is not None]
    assert all(why for _, why in skipped), f"a not-run comment without a reason: {skipped}"
    assert len(skipped) <= MAX_NOT_RUN, skipped


def _shorten_python(code: str) -> str:
    code = re.sub(r"\.run\(\s*[0-9.eE+-]+", f".run({SHORT}", code)
    return re.sub(r"\bduration\s*=\s*[0-9.eE+-]+", f"duration={SHORT}", code)


def _commands(code: str) -> list[list[str]]:
    """The knotsim command lines of a bash block (comments dropped, ``\\`` continuations joined)."""
    out = []
    for line in code.replace("\\\n", " ").splitlines():
        words = shlex.split(line, comments=True)
        if words and words[0] == "knotsim":
            out.append(words[1:])
    return out


def _options(words: list[str]) -> list[str]:
    return [w.split("=")[0] for w in words if w.startswith("-") and not re.fullmatch(r"-[0-9.]+", w)]


def _inputs_exist(words: list[str]) -> bool:
    """Whether the run file and the ``--from`` directory of a ``knotsim run`` command exist (they
    may come from a command of the document that is only checked against its ``--help``)."""
    inputs = [w for w in words[1:2] if not w.startswith("-")]
    if "--from" in words:
        inputs.append(words[words.index("--from") + 1])
    return all(Path(w).exists() for w in inputs)


def _run_command(runner: CliRunner, words: list[str], where: str) -> None:
    from knotsim.cli import main

    sub = words[0] if words else ""
    real = (sub in READ_ONLY or {"--help", "-h", "--list", "--show-params"} & set(words)
            or (sub == "run" and _inputs_exist(words))
            or (sub in ON_RUN_DIR and len(words) > 1 and Path(words[1]).is_dir()))
    if sub == "run" and real:
        if "--duration" in words:
            i = words.index("--duration")
            words = words[: i + 1] + [SHORT] + words[i + 2 :]
        else:
            words = [*words, "--duration", SHORT]
        words = [*words, "--quiet"]
    if real:
        res = runner.invoke(main, words, catch_exceptions=False)
        assert res.exit_code == 0, f"{where}: knotsim {shlex.join(words)} failed:\n{res.output}"
        return
    res = runner.invoke(main, [sub, "--help"], catch_exceptions=False)
    assert res.exit_code == 0, f"{where}: knotsim {sub} is not a command:\n{res.output}"
    for opt in _options(words[1:]):
        assert re.search(rf"(^|[\s,/]){re.escape(opt)}\b", res.output), \
            f"{where}: knotsim {sub} has no option {opt}:\n{res.output}"


@pytest.mark.parametrize("doc", DOCS, ids=[p.name for p in DOCS])
def test_code_blocks_run(doc, tmp_path, monkeypatch):
    blocks = _blocks(doc)
    if not any(lang for lang, _, why in blocks if why is None):
        pytest.skip(f"{doc.name} has no python or bash block")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    runner = CliRunner()
    for k, (lang, code, why) in enumerate(blocks):
        if why is not None:
            continue
        where = f"{doc.name} block {k + 1} ({lang})"
        if lang == "python":
            exec(compile(_shorten_python(code), where, "exec"), {"__name__": "__docs__"})  # noqa: S102
        else:
            for words in _commands(code):
                _run_command(runner, words, where)


# ---------------------------------------------------------------------------- run-file keys
def _schema_keys() -> set[str]:
    from knotsim.contact.model import ContactOptions
    from knotsim.io.config import bc, loader, rods
    from knotsim.solver.stepper import SolverOptions

    keys = set(rods._ROD_COMMON) | set(rods._ROD_SHAPES) | set().union(*rods._ROD_SHAPES.values())
    keys |= set(bc._BC_TYPES) | set().union(*bc._BC_TYPES.values())
    keys |= set(loader._TOP_KEYS)
    keys |= {f.name for f in dataclasses.fields(SolverOptions)} | {f.name for f in dataclasses.fields(ContactOptions)}
    return keys


def test_run_files_doc_names_every_schema_key():
    text = (ROOT / "docs" / "run-files.md").read_text()
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    # a key counts when it is written as inline code: `key`, `key = ...`, `[key]`, `{times, points}`
    words = {w for span in re.findall(r"`([^`]+)`", prose) for w in re.findall(r"[A-Za-z_]+", span)}
    missing = sorted(k for k in _schema_keys() if k not in words)
    assert not missing, f"docs/run-files.md does not name these run-file keys: {missing}"
    assert len(_schema_keys()) > 60  # the schema tuples were found


def test_run_files_key_check_can_fail(monkeypatch):
    from knotsim.io.config import loader

    monkeypatch.setattr(loader, "_TOP_KEYS", (*loader._TOP_KEYS, "no_such_key_anywhere"))
    with pytest.raises(AssertionError, match="no_such_key_anywhere"):
        test_run_files_doc_names_every_schema_key()


# ---------------------------------------------------------------------------- API reference
API_DOC = ROOT / "docs" / "api.md"
API_HEADER = """# Python API reference

`import knotsim as ks` exposes the names below (`knotsim.__all__`; loaded on first use). This page
is generated from their docstrings by `python tests/test_docs.py` and `tests/test_docs.py` checks
that it is current: after changing a public name or its docstring, run that command. Each entry
gives the call signature and the first paragraph of the docstring; `help(ks.NAME)` has the rest.
Units are SI throughout (m, s, N, Pa, rad).
"""


def _summary(obj) -> str:
    import inspect

    doc = inspect.getdoc(obj) or ""
    return doc.split("\n\n")[0].strip()


def api_markdown() -> str:
    """The text of docs/api.md, from ``knotsim.__all__`` and the docstrings."""
    import enum
    import importlib
    import inspect

    import knotsim as ks

    parts = [API_HEADER]
    for name in ks.__all__:
        # through the lazy table: `ks.run` is hidden by the submodule knotsim.runspec once that is imported
        obj = getattr(importlib.import_module(ks._LAZY[name]), name) if name in ks._LAZY else getattr(ks, name)
        if name == "__version__":
            parts.append(f"## `ks.__version__`\n\nThe package version, `{obj}`.\n")
            continue
        if isinstance(obj, type) and issubclass(obj, enum.Enum):
            sig = " | ".join(f'`"{m.value}"`' for m in obj)
            parts.append(f"## `ks.{name}`\n\nOne of {sig}.\n\n{_summary(obj)}\n")
            continue
        try:
            sig = str(inspect.signature(obj))
        except (TypeError, ValueError):
            sig = ""
        kind = "class" if isinstance(obj, type) else "function"
        parts.append(f"## `ks.{name}{sig}`\n\n*{kind}*. {_summary(obj)}\n")
    return "\n".join(parts)


def test_one_version_source():
    """The version is written once, in ``knotsim/_version.py``: pyproject.toml reads it (dynamic),
    ``knotsim.__version__`` re-exports it, and CITATION.cff, which cannot read it, must agree."""
    import re
    import tomllib

    from knotsim._version import __version__

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "knotsim._version.__version__"}
    cff = re.search(r"^version:\s*(\S+)", (ROOT / "CITATION.cff").read_text(), re.M)
    assert cff is not None and cff.group(1) == __version__


def test_api_reference_is_current():
    assert API_DOC.read_text() == api_markdown(), "docs/api.md is out of date: run `python tests/test_docs.py`"


if __name__ == "__main__":
    API_DOC.write_text(api_markdown())
