"""Compiling the numerical kernels ahead of a run (``knotsim warmup``; the first run of a command).

The kernels are numba ``@njit(cache=True)`` functions: each compiles on its first call and is
stored in numba's cache (``__pycache__`` next to the source, or ``NUMBA_CACHE_DIR``); later
processes load it in milliseconds. A cold start of ``knotsim pull overhand_n1 --quick`` spends
most of its time compiling, about 45 s of CPU (one specialisation per kernel;
``python benchmarks/bench_cold_start.py --split`` lists them): the broad phase and the contact
loop (``contact_evaluate_regularized_surface``: pair energy and surface friction) about 6 s each, the sparse LU
about 8 s, the elastic energies about 7 s, the rest in many small kernels.

:func:`kernels_cached` tells, from numba's cache index files of a few kernels that every run of
that kind compiles, whether a run would start by compiling. :func:`warm_up` compiles the kernels
of a contact run of a small knot: the contact kernels in a second process while this one compiles
the elastic, solver and topology kernels (two cores: the two halves, of about equal CPU time, at the
same time), so that a run afterwards loads everything from the cache. Library code: nothing here
prints.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
import time

__all__ = ["kernels_cached", "spare_cores", "uncached_kernels", "warm_up"]

#: Kernels every run of a kind compiles (module, function): if all are cached, the rest are too.
SENTINELS: dict[str, tuple[tuple[str, str], ...]] = {
    "core": (("knotsim.energies.bending", "bending_twisting_energy"), ("knotsim.solver._kernels", "implicit_residual")),
    "contact": (("knotsim.contact.assembly", "contact_evaluate_regularized_surface"),
                ("knotsim.contact.broadphase", "find_candidate_pairs")),
    "topology": (("knotsim.geometry.planar", "_crossings_kernel"),),
}


def _is_cached(dispatcher) -> bool | None:
    """Whether numba's cache holds a compiled version of ``dispatcher`` for the current source
    (``None`` when this numba does not expose its cache)."""
    cache = getattr(dispatcher, "_cache", None)
    cache_file = getattr(cache, "_cache_file", None)
    if cache_file is None or not hasattr(cache_file, "_load_index"):
        return None
    try:
        return bool(cache_file._load_index())  # empty when missing or when the source changed
    except Exception:  # an unreadable index: numba recompiles, so count it as not cached
        return False


def uncached_kernels(groups=("core", "contact", "topology")) -> list[str]:
    """Names (``module.function``) of the sentinel kernels of ``groups`` that are not cached."""
    out = []
    for g in groups:
        for module, name in SENTINELS[g]:
            if _is_cached(getattr(importlib.import_module(module), name)) is False:
                out.append(f"{module}.{name}")
    return out


def kernels_cached(contact: bool = True, topology: bool = True) -> bool:
    """Whether a run (with contact and a knot-type check, when asked) will find its kernels
    compiled in numba's cache."""
    groups = ["core"] + (["contact"] if contact else []) + (["topology"] if topology else [])
    return not uncached_kernels(groups)


def _idle_fraction(window: float = 0.25) -> float | None:
    """Fraction of the machine's CPU time spent idle over the next ``window`` seconds, from the
    kernel's counters (``/proc/stat``; ``None`` where there is none)."""
    def sample():
        with open("/proc/stat") as f:
            fields = [float(v) for v in f.readline().split()[1:]]
        return fields[3] + fields[4], sum(fields)  # idle + iowait, total
    try:
        idle0, total0 = sample()
        time.sleep(window)
        idle1, total1 = sample()
    except (OSError, ValueError, IndexError):
        return None
    return (idle1 - idle0) / (total1 - total0) if total1 > total0 else None


def spare_cores() -> float:
    """CPUs not busy now: ``os.cpu_count()`` times the idle fraction over a quarter of a second
    (or, where the kernel's counters cannot be read, minus the 1-min load average, which lags a
    machine that has just become idle). A second compiling process only pays off when this is at
    least 1 (on a busy machine it adds CPU time, about 25 %, without shortening the wall time)."""
    n = float(os.cpu_count() or 1)
    idle = _idle_fraction()
    if idle is not None:
        return max(0.0, n * idle)
    try:
        return max(0.0, n - os.getloadavg()[0])
    except (OSError, AttributeError):  # no load average on this platform
        return 0.0


def _small_run_spec(contact: bool, linear_solver: str = "auto"):
    """A few steps of the quick overhand pull (the kernels' argument types are those of any run)."""
    from knotsim.protocols.pipeline import build_protocol_run
    from knotsim.runspec import RunSpec

    _, _, spec, _ = build_protocol_run("overhand-pull", "overhand_n1", quick=True,
                                       overrides={"duration": 0.015, "output_interval": 0.005})
    data = dict(spec.data)
    if not contact:
        data.pop("contact", None)
    data["solver"] = {**data.get("solver", {}), "linear_solver": linear_solver}
    return RunSpec.from_dict(data)


def _warm_core() -> None:
    """Elastic energies, time stepper, banded and sparse linear solvers."""
    from knotsim.runspec import build_run

    for solver in ("auto", "sparse"):
        sim, cfg = build_run(_small_run_spec(contact=False, linear_solver=solver))
        sim.run(cfg.duration, output_dir=None, progress=False)


def _warm_topology() -> None:
    """Knot-diagram kernels (crossings, Alexander polynomial) of the knot-type check."""
    from knotsim.knots.topology import analyze
    from knotsim.runspec import build_run

    sim, cfg = build_run(_small_run_spec(contact=False))
    model = cfg.model
    analyze([model.rod_positions(sim.state.q, r) for r in range(model.n_rods)], None)


def _warm_contact() -> None:
    """Broad phase, pair energy, friction and the contact checks, on the small knot (no time step,
    so that a second process running this does not compile the stepper's kernels too)."""
    import numpy as np

    from knotsim.runspec import build_run

    spec = _small_run_spec(contact=True)
    dt = float(spec.data["solver"]["dt"])
    sim, _ = build_run(spec)
    q = sim.state.q
    for inter in sim.stepper.interactions:
        inter.begin_step(sim.state, dt)
        inter.evaluate(q, q.copy(), dt, np.zeros_like(q), True)
        inter.check(q)
        inter.stats()
        inter.node_forces()


def _warm_run() -> None:
    """A few steps of the small contact run: whatever the parts left (mostly loaded from the cache)."""
    from knotsim.runspec import build_run

    sim, cfg = build_run(_small_run_spec(contact=True))
    sim.run(cfg.duration, output_dir=None, progress=False)


_PARTS = {"core": _warm_core, "contact": _warm_contact, "topology": _warm_topology, "run": _warm_run}
#: What the second process compiles (in this order) while the first compiles ``core`` and
#: ``topology``: the contact kernels, then a few steps of the contact run, by when ``core`` is in
#: the cache, so that the steps compile only what is left (contact pattern merging, nodal force
#: summaries).
_SECOND = ("contact", "run")
#: What this process compiles meanwhile (CPU time about equal to the other side's).
_FIRST = ("core", "topology")


def warm_up(parallel: bool = True) -> dict[str, float]:
    """Compile every kernel a contact run needs; returns wall times (s) of the parts ``core``
    (elastic energies, stepper, linear solvers), ``contact``, ``topology`` and ``run`` (a few steps
    of a small contact run, compiling what is left), each measured in the process that ran it,
    their CPU times ``cpu.<part>`` (s) and the wall time ``total``. With ``parallel`` a second
    Python process compiles :data:`_SECOND` while this one compiles :data:`_FIRST` (falling back
    to this process if that one fails); the compiled code reaches this process through numba's
    cache, and a final ``run`` here loads it."""
    t0 = time.perf_counter()
    times: dict[str, float] = {}
    child = None
    if parallel:
        env = dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "1"),
                   OPENBLAS_NUM_THREADS=os.environ.get("OPENBLAS_NUM_THREADS", "1"))
        child = subprocess.Popen([sys.executable, "-m", "knotsim._warmup", *_SECOND], env=env,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for part in _FIRST:
        t, c = time.perf_counter(), time.process_time()
        _PARTS[part]()
        times[part], times[f"cpu.{part}"] = time.perf_counter() - t, time.process_time() - c
    done: dict[str, float] = {}
    if child is not None:
        out, _ = child.communicate()
        if child.returncode == 0:
            for line in out.splitlines():
                part, wall, cpu = (line.split() + ["", "", ""])[:3]
                if part in _PARTS and cpu:
                    done[part], done[f"cpu.{part}"] = float(wall), float(cpu)
    for part in _SECOND:  # what the second process did not do (serial, or it failed)
        if part not in done:
            t, c = time.perf_counter(), time.process_time()
            _PARTS[part]()
            done[part], done[f"cpu.{part}"] = time.perf_counter() - t, time.process_time() - c
        elif part == "run":
            _warm_run()  # loads what the other process compiled
    times.update(done)
    times["total"] = time.perf_counter() - t0
    return times


if __name__ == "__main__":  # python -m knotsim._warmup PART ...: prints "PART wall_s cpu_s" per part
    for _part in sys.argv[1:]:
        _t, _c = time.perf_counter(), time.process_time()
        _PARTS[_part]()
        sys.stdout.write(f"{_part} {time.perf_counter() - _t:.3f} {time.process_time() - _c:.3f}\n")
        sys.stdout.flush()
