"""Benchmark: the cold first command (numba compiles every kernel a run needs).

Run: ``python benchmarks/bench_cold_start.py [--repeat 1] [--split]``.

Each repeat runs the README's first command, ``knotsim pull overhand_n1 --quick``, in a fresh
process with an empty numba cache (``NUMBA_CACHE_DIR`` in a new temporary folder, so nothing
compiled before is reused) and reports its wall time, the CPU time of it and its children (the
compiling second process), the time until the compile notice appears on stderr and the wall time
the notice reports for the compile. The time until the first message is also reported
separately (``first_message_s``: the ``--quick`` notes and the compile notice come together).
``--split`` then compiles the kernels of the command's run (``knotsim._warmup``'s manifest, the
groups of a contact run and its knot-type check) once more, in one process and one after the
other, with an empty cache, and lists the CPU seconds of every group and of every kernel compiled
(from numba's compile events; a kernel's time includes the helpers it compiles).

Prints one JSON line ``{"runs": [...], "split": {...}}``. The cold start depends on the machine
being idle: with less than one spare CPU the command compiles in its own process (the notice says
so) and takes about the total CPU time of the split instead.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time


def cold_run() -> dict:
    """One cold run of the first README command; wall and CPU seconds, first-message latency."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, "numba"), OPENBLAS_NUM_THREADS="1",
                   OMP_NUM_THREADS="1", MPLBACKEND="Agg")
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "knotsim.cli", "pull", "overhand_n1", "--quick", "-o",
                                 os.path.join(tmp, "run")], env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, text=True)
        first_message = None
        compiled_in = None
        for line in proc.stderr:
            if first_message is None and line.startswith("note: "):
                first_message = time.perf_counter() - t0
            if line.startswith("note: kernels compiled in"):
                compiled_in = float(line.split()[4])
        proc.wait()
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {"wall_s": round(wall, 2), "cpu_s": round(after.ru_utime + after.ru_stime
                                                      - before.ru_utime - before.ru_stime, 2),
            "first_message_s": None if first_message is None else round(first_message, 2),
            "compile_wall_s": compiled_in, "returncode": proc.returncode,
            "load_average_1min": round(os.getloadavg()[0], 2)}


_SPLIT = r"""
import json, sys, time
from numba.core import event
import knotsim._warmup as w
stack, totals, groups = [], {}, {}
class Listener(event.Listener):
    def on_start(self, ev):
        stack.append(time.thread_time())
    def on_end(self, ev):
        t = time.thread_time() - stack.pop()
        if not stack:
            d = ev.data["dispatcher"].py_func
            name = d.__module__ + "." + d.__qualname__
            totals[name] = totals.get(name, 0.0) + t
event.register("numba:compile", Listener())
for entry in w._manifest(w.run_groups()):
    t = time.thread_time()
    w._compile([entry])
    groups[entry[0]] = groups.get(entry[0], 0.0) + time.thread_time() - t
parts = {g: round(v, 2) for g, v in groups.items()}
top = dict(sorted(((k, round(v, 2)) for k, v in totals.items()), key=lambda kv: -kv[1]))
print(json.dumps({"parts_cpu_s": parts, "total_cpu_s": round(sum(groups.values()), 2), "kernels_cpu_s": top}))
"""


def split() -> dict:
    """CPU seconds of every warm-up part and kernel, compiled serially with an empty cache."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, "numba"), OPENBLAS_NUM_THREADS="1",
                   OMP_NUM_THREADS="1")
        out = subprocess.run([sys.executable, "-c", _SPLIT], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1, help="cold runs of the command")
    ap.add_argument("--split", action="store_true", help="also list the compile CPU time per kernel")
    args = ap.parse_args()
    runs = [cold_run() for _ in range(args.repeat)]
    result = {"command": "knotsim pull overhand_n1 --quick", "cpus": os.cpu_count(), "runs": runs}
    if args.split:
        result["split"] = split()
    print(json.dumps(result))


if __name__ == "__main__":
    main()
