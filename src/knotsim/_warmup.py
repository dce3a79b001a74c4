"""Compiling the numerical kernels ahead of a run (``knotsim warmup``; the first run of a command).

The kernels are numba ``@njit(cache=True)`` functions: each compiles on its first call and is
stored in numba's cache (``__pycache__`` next to the source, or ``NUMBA_CACHE_DIR``); later
processes load it in milliseconds. A cold start of ``knotsim pull overhand_n1 --quick`` spends
most of its time compiling, about 45 s of CPU on an idle machine
(``python benchmarks/bench_cold_start.py --split`` lists the kernels): the contact loop, the broad
phase, the sparse LU and the elastic energies take about half of it, the rest is many small kernels.

:data:`knotsim._kernel_manifest.KERNELS` lists every kernel a run calls from Python, with the
argument types of its calls and its compile time: :func:`warm_up` compiles them from those types
(``Dispatcher.compile``), without building a model, split by compile time into two halves of
about equal CPU time, one in a second process (forked where the platform allows, so that it starts
without importing anything), so that a run afterwards loads everything from the cache. Kernels are
grouped by what needs them (:data:`GROUPS`): a run compiles only the groups of its own settings
(:func:`run_groups`). :func:`kernels_cached` tells, from numba's cache index files, whether a run
would start by compiling. ``python -m knotsim._warmup --record`` rewrites the manifest (after a
kernel's arguments change; a stale entry costs only time: the run compiles what it calls). Library
code: nothing here prints.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import time

__all__ = ["GROUPS", "kernels_cached", "run_groups", "spare_cores", "uncached_kernels", "warm_up"]

#: Kernel groups of the manifest and what needs them. ``core``: the rods, time stepper, boundary
#: conditions and both linear solvers; ``topology``: the knot-type check; ``contact``: rod-rod
#: contact with friction at the surfaces (the default law) and the regularized distance; the other
#: contact loops: ``centreline`` (the centre-line law, also every run with mu = 0), ``exact`` and
#: ``exact_centreline`` (``parallel_smoothing = 0``); ``obstacles``: rigid obstacles.
GROUPS = ("core", "topology", "contact", "centreline", "exact", "exact_centreline", "obstacles")


def _dispatcher(module: str, name: str):
    return getattr(importlib.import_module(module), name)


def _manifest(groups) -> list[tuple]:
    """The manifest's entries ``(group, module, function, argument types, cpu_s)`` of ``groups``."""
    from knotsim._kernel_manifest import KERNELS

    return [k for k in KERNELS if k[0] in groups]


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
    """Names (``module.function``) of the kernels of ``groups`` that are not cached."""
    out = []
    for _, module, name, _, _ in _manifest(groups):
        if f"{module}.{name}" not in out and _is_cached(_dispatcher(module, name)) is False:
            out.append(f"{module}.{name}")
    return out


def run_groups(contact=True, topology: bool = True, obstacles: bool = False) -> tuple[str, ...]:
    """The kernel groups a run needs. ``contact``: ``False`` or ``None`` (no rod-rod contact),
    ``True`` (friction at the surfaces, regularized distance: the protocols' settings) or the run's
    ``[contact]`` table (``friction_model``, ``mu``, ``parallel_smoothing``; missing keys take the
    defaults of :class:`knotsim.contact.options.ContactOptions`: mu = 0 runs the centre-line loop)."""
    groups = ["core"] + (["topology"] if topology else [])
    if contact is not None and contact is not False:
        groups.append("contact")  # broad phase, checks, swept tests (and the surface loop)
        if isinstance(contact, dict):
            mu = contact.get("mu", 0.0)
            mus = list(mu.values()) if isinstance(mu, dict) else [mu]
            friction = any(isinstance(m, int | float) and m > 0 for m in mus)
            law = contact.get("friction_model", "surface")
            centreline = str(getattr(law, "value", law)) != "surface" or not friction
            exact = float(contact.get("parallel_smoothing", 2e-6)) == 0.0
            if exact:
                groups.append("exact_centreline" if centreline else "exact")
            elif centreline:
                groups.append("centreline")
    if obstacles:
        groups.append("obstacles")
    return tuple(groups)


def kernels_cached(contact=True, topology: bool = True, obstacles: bool = False) -> bool:
    """Whether a run (with contact and a knot-type check, when asked; ``contact`` as in
    :func:`run_groups`) will find its kernels compiled in numba's cache."""
    return not uncached_kernels(run_groups(contact, topology, obstacles))


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
    least 1 (on a busy machine it adds CPU time without shortening the wall time)."""
    n = float(os.cpu_count() or 1)
    idle = _idle_fraction()
    if idle is not None:
        return max(0.0, n * idle)
    try:
        return max(0.0, n - os.getloadavg()[0])
    except (OSError, AttributeError):  # no load average on this platform
        return 0.0


# --------------------------------------------------------------------------- argument types
_SCALARS = ("float64", "int64", "int32", "uint64", "bool", "float32", "uint8", "int8", "uint32")


def _type_from_text(text: str):
    """A numba type from the manifest's text: ``float64``, ``float64[2C]`` (array: ndim and
    layout, ``ro`` appended when read-only), ``float64*3`` (a tuple of equal items) or
    ``(int64,float64)``."""
    from numba.core import types

    def scalar(name):
        return types.boolean if name == "bool" else getattr(types, name)

    if text.startswith("(") and text.endswith(")"):
        return types.Tuple(tuple(_type_from_text(t) for t in text[1:-1].split(",") if t))
    if "*" in text:
        name, n = text.split("*")
        return types.UniTuple(scalar(name), int(n))
    if text.endswith("]"):
        name, spec = text[:-1].split("[")
        return types.Array(scalar(name), int(spec[0]), spec[1], readonly=spec.endswith("ro"))
    return scalar(text)


def _type_to_text(t) -> str:
    from numba.core import types

    if isinstance(t, types.Array):
        return f"{t.dtype}[{t.ndim}{t.layout}{'ro' if not t.mutable else ''}]"
    if isinstance(t, types.UniTuple):
        return f"{t.dtype}*{t.count}"
    if isinstance(t, types.BaseTuple):
        return "(" + ",".join(_type_to_text(x) for x in t.types) + ")"
    name = str(t)
    if name not in _SCALARS:
        raise TypeError(f"argument type {name} cannot be written to the manifest")
    return name


# --------------------------------------------------------------------------- compiling
def _compile(entries) -> tuple[int, int]:
    """Compile (or load from the cache) every entry; returns (compiled, failed). A failure (an
    entry that no longer matches its kernel) is skipped: the run compiles what it calls."""
    ok = failed = 0
    for _, module, name, args, _ in entries:
        try:
            _dispatcher(module, name).compile(tuple(_type_from_text(a) for a in args))
            ok += 1
        except Exception:
            failed += 1
    return ok, failed


def _ready(entry) -> bool:
    """Whether the kernel of a manifest entry is compiled in this process (for its types) or in
    numba's cache (for any types) already: the halves are split without it."""
    disp = _dispatcher(entry[1], entry[2])
    try:
        if tuple(_type_from_text(a) for a in entry[3]) in disp.overloads:
            return True
    except (AttributeError, TypeError, ValueError):
        return False
    return bool(_is_cached(disp))


def _halves(entries) -> tuple[list, list]:
    """Two lists of about equal compile time (largest first, each to the lighter side); in the
    manifest's order within each."""
    sides: tuple[list, list] = ([], [])
    load = [0.0, 0.0]
    for k in sorted(range(len(entries)), key=lambda i: -entries[i][4]):
        side = 0 if load[0] <= load[1] else 1
        sides[side].append(k)
        load[side] += entries[k][4]
    return [entries[i] for i in sorted(sides[0])], [entries[i] for i in sorted(sides[1])]


def _timed(entries) -> dict[str, float]:
    t, c = time.perf_counter(), time.process_time()
    ok, failed = _compile(entries)
    return {"wall": time.perf_counter() - t, "cpu": time.process_time() - c, "kernels": ok, "failed": failed}


def _fork_compile(entries):
    """Compile ``entries`` in a forked copy of this process; returns (pid, read end of a pipe that
    gets its timings as JSON), or ``None`` where fork is not used (the caller starts a fresh
    Python instead)."""
    if not sys.platform.startswith("linux") or not hasattr(os, "fork"):
        return None
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: compile, report, leave without running the parent's exit handlers
        code = 1
        try:
            os.close(r)
            res = _timed(entries)
            os.write(w, json.dumps(res).encode())
            code = 0
        finally:
            os._exit(code)
    os.close(w)
    return pid, r


def warm_up(parallel: bool = True, groups=("core", "contact", "topology")) -> dict[str, float]:
    """Compile every kernel of ``groups`` (:func:`run_groups`; default: a contact run with the
    default settings and its knot-type check) from the manifest's argument types. With
    ``parallel`` half of the compile time goes to a second process (forked on Linux, else a new
    Python) while this one compiles the other half; the compiled code reaches this process through
    numba's cache; kernels compiled or cached already are left out of the halves. Returns wall
    seconds ``total``, ``first`` (this process's half) and ``second``
    (the other half, measured where it ran), their CPU seconds ``cpu.first`` and ``cpu.second``,
    and the numbers of ``kernels`` compiled and of manifest entries that ``failed``."""
    t0 = time.perf_counter()
    entries = [e for e in _manifest(groups) if not _ready(e)]
    first, second = _halves(entries) if parallel else (entries, [])
    child = proc = None
    if second:
        child = _fork_compile(second)
        if child is None:
            env = dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "1"),
                       OPENBLAS_NUM_THREADS=os.environ.get("OPENBLAS_NUM_THREADS", "1"))
            proc = subprocess.Popen([sys.executable, "-m", "knotsim._warmup", "--entries", json.dumps(second)], env=env,
                                    stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    mine = _timed(first)
    theirs = None
    try:
        if child is not None:
            pid, r = child
            with os.fdopen(r, "rb") as f:
                data = f.read()
            _, status = os.waitpid(pid, 0)
            theirs = json.loads(data) if status == 0 and data else None
        elif proc is not None:
            out, _ = proc.communicate()
            theirs = json.loads(out.strip().splitlines()[-1]) if proc.returncode == 0 and out.strip() else None
    except (OSError, ValueError):
        theirs = None
    if second and theirs is None:  # the other process failed: compile (or load) its half here
        theirs = _timed(second)
    theirs = theirs or {"wall": 0.0, "cpu": 0.0, "kernels": 0, "failed": 0}
    return {"total": time.perf_counter() - t0, "first": mine["wall"], "second": theirs["wall"],
            "cpu.first": mine["cpu"], "cpu.second": theirs["cpu"],
            "kernels": mine["kernels"] + theirs["kernels"], "failed": mine["failed"] + theirs["failed"]}


# --------------------------------------------------------------------------- recording the manifest
def _small_run_spec(contact: bool, linear_solver: str = "auto", **contact_settings):
    """A few steps of the quick overhand pull (the kernels' argument types are those of any run)."""
    from knotsim.protocols.pipeline import build_protocol_run
    from knotsim.runspec import RunSpec

    _, _, spec, _ = build_protocol_run("overhand-pull", "overhand_n1", quick=True,
                                       overrides={"duration": 0.015, "output_interval": 0.005})
    data = dict(spec.data)
    if not contact:
        data.pop("contact", None)
    else:
        data["contact"] = {**data["contact"], **contact_settings}
    data["solver"] = {**data.get("solver", {}), "linear_solver": linear_solver}
    return RunSpec.from_dict(data)


def _run(spec) -> None:
    from knotsim.runspec import build_run

    sim, cfg = build_run(spec)
    sim.run(cfg.duration, output_dir=None, progress=False)


def _record_core() -> None:
    for solver in ("auto", "sparse"):
        _run(_small_run_spec(contact=False, linear_solver=solver))


def _record_topology() -> None:
    from knotsim.knots.topology import analyze
    from knotsim.runspec import build_run

    sim, cfg = build_run(_small_run_spec(contact=False))
    model = cfg.model
    analyze([model.rod_positions(sim.state.q, r) for r in range(model.n_rods)], None)


def _record_obstacles() -> None:
    from pathlib import Path

    from knotsim.runspec import RunSpec

    examples = Path(__file__).resolve().parents[2] / "examples"
    for name in ("floor.toml", "capstan.toml"):
        for law in ("surface", "centreline"):
            spec = RunSpec.load(examples / name)
            data = dict(spec.data)
            data["run"] = {**data.get("run", {}), "duration": 0.01}
            data.pop("stages", None)
            for ob in data.get("obstacles", []):
                ob["friction_model"] = law
            if "contact" in data:
                data["contact"] = {**data["contact"], "friction_model": law}
            _run(RunSpec.from_dict(data))


#: What ``--record`` runs for each group, in this order (a kernel belongs to the first group whose
#: run compiles it).
_RECORD = {
    "core": _record_core,
    "topology": _record_topology,
    "contact": lambda: _run(_small_run_spec(contact=True)),
    "centreline": lambda: _run(_small_run_spec(contact=True, friction_model="centreline")),
    "exact": lambda: _run(_small_run_spec(contact=True, parallel_smoothing=0.0)),
    "exact_centreline": lambda: _run(_small_run_spec(contact=True, parallel_smoothing=0.0,
                                                     friction_model="centreline")),
    "obstacles": _record_obstacles,
}


def record(path=None) -> list[tuple]:
    """Run the small runs of every group with numba's compile events on and write the kernels
    they call from Python (argument types, compile CPU seconds) to ``path`` (default: the
    manifest module). Meant for an empty cache (``NUMBA_CACHE_DIR`` set to a new folder)."""
    from numba.core import event

    stack: list[float] = []
    found: list[tuple] = []
    group = [""]

    class _Listener(event.Listener):
        def on_start(self, ev):
            stack.append(time.thread_time())

        def on_end(self, ev):
            t = time.thread_time() - stack.pop()
            if stack:
                return
            f = ev.data["dispatcher"].py_func
            if f.__module__.startswith("knotsim.") and getattr(importlib.import_module(f.__module__),
                                                               f.__name__, None) is ev.data["dispatcher"]:
                args = tuple(_type_to_text(a) for a in ev.data["args"])
                found.append((group[0], f.__module__, f.__name__, args, round(t, 2)))

    listener = _Listener()
    event.register("numba:compile", listener)
    try:
        for g in GROUPS:
            group[0] = g
            _RECORD[g]()
    finally:
        event.unregister("numba:compile", listener)
    from pathlib import Path

    path = Path(path) if path is not None else Path(__file__).with_name("_kernel_manifest.py")
    lines = ['"""The kernels a run calls from Python, with the argument types of those calls (written by',
             "``python -m knotsim._warmup --record`` with an empty numba cache; read by :mod:`knotsim._warmup`).",
             "",
             "Each entry: (group, module, function, argument types, compile CPU seconds on the machine that",
             "recorded it). Types: ``float64``, ``int64[2C]`` (array: dimensions, layout, ``ro`` when read-only),",
             '``float64*3`` (a tuple of equal items), ``(int64,float64)``."""', "",
             "KERNELS = ["]
    for e in found:
        lines.append(f"    {e!r},")
    lines.append("]")
    path.write_text("\n".join(lines) + "\n")
    return found


if __name__ == "__main__":
    # python -m knotsim._warmup [GROUP ...]: compile those groups (default: a contact run's) and
    # print {"wall", "cpu", "kernels", "failed"} as JSON; --entries JSON: compile those manifest
    # entries (the second process of warm_up where fork is not used); --record [PATH]: rewrite the
    # manifest
    _args = sys.argv[1:]
    if _args[:1] == ["--record"]:
        record(_args[1] if len(_args) > 1 else None)
    else:
        if _args[:1] == ["--entries"]:
            _entries = [tuple(e) for e in json.loads(_args[1])]
        else:
            _entries = _manifest(tuple(_args) or ("core", "contact", "topology"))
        sys.stdout.write(json.dumps(_timed(_entries)) + "\n")
