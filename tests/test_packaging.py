"""Packaging: a wheel of the project installs into a fresh virtual environment and runs there without
any file of the repository.

The wheel is built offline from a copy of the project's files (no build isolation: the environment's
setuptools, see the ``dev`` extra), installed with ``pip install --no-deps --no-index`` into a new
environment that sees the current one's packages (``--system-site-packages``, and the running
environment's site-packages when it is itself a virtual environment) but not the source tree, and
run from an empty temporary directory: ``knotsim --version``, ``knotsim tie --list`` (package data)
and ``knotsim validate helix --quick`` (a validation case, numerical kernels compiled afresh).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(cmd, cwd, env=None, timeout=600):
    proc = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{cmd} failed ({proc.returncode}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc.stdout


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(bin directory of the fresh environment, its environment variables, an empty working directory)."""
    pytest.importorskip("setuptools")
    pytest.importorskip("wheel")
    tmp = tmp_path_factory.mktemp("packaging")
    src = tmp / "project"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, src / name)
    shutil.copytree(ROOT / "src", src / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info", "*.nbi",
                                                                           "*.nbc"))
    dist = tmp / "dist"
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-index", "--no-build-isolation", "-q",
          "-w", dist, src], cwd=tmp)
    (wheel,) = dist.glob("knotsim-*.whl")
    env_dir = tmp / "env"
    _run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", env_dir], cwd=tmp)
    py = env_dir / "bin" / "python"
    site = Path(_run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], cwd=tmp).strip())
    if sys.prefix != sys.base_prefix:  # the running environment is a venv: its packages (numpy, ...) too
        paths = dict.fromkeys([sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]])
        (site / "_running_env.pth").write_text("".join(f"{p}\n" for p in paths))
    _run([sys.executable, "-m", "pip", "--python", py, "install", "--no-deps", "--no-index", "-q", wheel], cwd=tmp)
    work = tmp / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "NUMBA_CACHE_DIR")}
    env.update(PATH=f"{env_dir / 'bin'}{os.pathsep}{env.get('PATH', '')}", OPENBLAS_NUM_THREADS="1",
               OMP_NUM_THREADS="1", MPLBACKEND="Agg")
    return env_dir / "bin", env, work


def test_wheel_imports_from_its_own_install(installed):
    bindir, env, work = installed
    where = _run([bindir / "python", "-c", "import knotsim, knotsim.cli; print(knotsim.__file__)"], work, env)
    assert Path(where.strip()).is_relative_to(bindir.parent), where  # the wheel, not the source tree
    assert not Path(where.strip()).is_relative_to(ROOT)
    from knotsim import __version__

    assert __version__ in _run([bindir / "knotsim", "--version"], work, env)


def test_wheel_runs_a_validation_case(installed):
    bindir, env, work = installed
    assert sorted(_run([bindir / "knotsim", "tie", "--list"], work, env).split()) == ["granny", "overhand", "reef"]
    out = json.loads(_run([bindir / "knotsim", "validate", "helix", "--quick", "--json-only"], work, env))
    assert out["passed"] and {c["case"] for c in out["cases"]} == {"helix"}
    assert list(work.iterdir()) == []  # nothing written into the working directory
