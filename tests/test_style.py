"""Style and layout checks that run with the test suite (so CI runs them)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(shutil.which("ruff") is None and subprocess.run(
    [sys.executable, "-m", "ruff", "--version"], capture_output=True).returncode != 0,
    reason="ruff is not installed (it is in the dev extra)")
def test_ruff_is_clean():
    res = subprocess.run([sys.executable, "-m", "ruff", "check", "src", "tests", "benchmarks", "validation"],
                         cwd=ROOT, capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr


def test_package_imports_without_heavy_modules():
    """``import knotsim`` (and so ``knotsim --help``) does not import numba kernels."""
    code = "import sys, knotsim; print('knotsim.simulation' in sys.modules, 'numba' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "False"]


def test_library_code_never_prints_or_exits():
    offenders = []
    for f in (ROOT / "src" / "knotsim").rglob("*.py"):
        if "cli" in f.relative_to(ROOT / "src" / "knotsim").parts[:-1]:  # the command line prints
            continue
        for n, line in enumerate(f.read_text().splitlines(), 1):
            s = line.strip()
            if s.startswith(("print(", "sys.exit(")) or " print(" in s.split("#")[0]:
                offenders.append(f"{f.relative_to(ROOT)}:{n}: {s}")
    assert not offenders, "\n".join(offenders)


def test_protocol_base_does_not_import_its_subclasses():
    """The registry imports the protocols, one way; the base class module imports none of them, nor the
    registry or the pipeline that uses it."""
    import ast

    tree = ast.parse((ROOT / "src" / "knotsim" / "protocols" / "base.py").read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    imported |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    for mod in ("overhand_pull", "single_rod_bend", "two_rope_bend", "registry", "pipeline"):
        assert f"knotsim.protocols.{mod}" not in imported


def test_public_names_are_not_shadowed_by_submodules():
    """``ks.run`` stays the function after ``knotsim.runspec`` (or any submodule) is imported."""
    code = ("import importlib, pkgutil, types, knotsim as ks\n"
            "for m in pkgutil.walk_packages(ks.__path__, 'knotsim.'):\n"
            "    if '.cli' in m.name or m.name.endswith('__main__'):\n        continue\n"
            "    try:\n        importlib.import_module(m.name)\n    except ImportError:\n        pass\n"
            "bad = [n for n in ks._LAZY if isinstance(getattr(ks, n), types.ModuleType)]\n"
            "print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]"
