"""Type check of src/knotsim: mypy (configured in pyproject.toml, ``[tool.mypy]``) against a recorded
baseline, ``tests/mypy-baseline.txt``, that may only shrink.

Each error is recorded as ``path: message [code]`` (no line number, so that editing a file does not
move its errors); the same error twice in a file is two lines. A new error fails the test; an error
of the baseline that is gone fails it too, asking for the baseline to be rewritten (so that it
cannot come back unnoticed)::

    python tests/test_typecheck.py        # rewrite tests/mypy-baseline.txt from the current errors
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BASELINE = ROOT / "tests" / "mypy-baseline.txt"
_ERROR = re.compile(r"^(?P<path>[^:]+):\d+(?::\d+)?: error: (?P<msg>.*?)(?:  \[(?P<code>[a-z0-9-]+)\])?$")


def mypy_errors() -> Counter:
    """The errors of ``mypy`` on src/knotsim as a multiset of ``path: message [code]`` lines."""
    proc = subprocess.run([sys.executable, "-m", "mypy", "--no-error-summary", "--no-pretty",
                           "--show-error-codes", "--hide-error-context"],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    if proc.returncode not in (0, 1) or proc.stderr.strip():
        raise RuntimeError(f"mypy did not run (exit {proc.returncode}):\n{proc.stderr}{proc.stdout[-2000:]}")
    out: Counter = Counter()
    for line in proc.stdout.splitlines():
        m = _ERROR.match(line)
        if m:
            out[f"{m['path']}: {m['msg']} [{m['code'] or 'misc'}]"] += 1
    return out


def read_baseline() -> Counter:
    lines = BASELINE.read_text(encoding="utf-8").splitlines() if BASELINE.is_file() else []
    return Counter(line for line in lines if line and not line.startswith("#"))


def write_baseline(errors: Counter) -> None:
    head = ("# mypy errors in src/knotsim accepted for now (tests/test_typecheck.py); this list may only shrink.\n"
            "# Rewrite it with: python tests/test_typecheck.py\n")
    BASELINE.write_text(head + "".join(f"{e}\n" for e in sorted(errors.elements())), encoding="utf-8")


def test_no_new_type_errors():
    pytest.importorskip("mypy")
    now, base = mypy_errors(), read_baseline()
    new, gone = now - base, base - now
    assert not new, (f"{sum(new.values())} new mypy error(s) in src/knotsim (fix them; run "
                     "`python -m mypy` for the line numbers):\n" + "\n".join(sorted(new.elements())))
    assert not gone, (f"{sum(gone.values())} mypy error(s) of the baseline are gone: shrink the baseline with "
                      "`python tests/test_typecheck.py`:\n" + "\n".join(sorted(gone.elements())))


if __name__ == "__main__":
    errors = mypy_errors()
    write_baseline(errors)
    print(f"{BASELINE.relative_to(ROOT)}: {sum(errors.values())} errors")  # noqa: T201
