"""Benchmark: the IMC paper's knot-tightening job, end to end, through the public API.

Run: ``python benchmarks/bench_knot.py [--geometry PATH] [--n-nodes N] [--wait 2] [--duration 62]
[--dt 2.5e-3] [--mu 0.3] [--friction-model centreline|surface] [--no-spin-relaxation]``. Default job: imc-der's own ``n1`` overhand (301 nodes, read from
``../shared/data/foreign/imc-der/n1`` beside the checkout, else the library's ``overhand_n1``),
L = 1 m, h = 1.6 mm, E = 0.18 MPa, rho = 1180 kg/m^3, eta = 0.01 Pa s, both end pairs clamped, held
for ``--wait`` s, then pulled apart along the end-to-end axis at 6 mm/s each, 62 s simulated in all at
dt = 2.5 ms, mu = 0.3, default contact settings but the IMC paper's friction law,
``friction_model = "centreline"`` (24,800 steps at the defaults; ``--friction-model surface`` runs the
same job with friction at the rods' surfaces, knotsim's default). ``--n-nodes``
resamples the start shape by arc length.

Prints one JSON line: ``cpu_s``, ``wall_s``, ``steps``, ``ms_per_step``, ``iterations_per_step``,
``ms_per_iteration``, ``factorizations_per_step``, ``contacts_per_step`` (pairs within delta, mean),
``peak_rss_mib``, the time split in s (``elastic`` and ``contact_and_friction`` residual and
Jacobian evaluation, ``assembly``, ``factorization`` (with the symbolic analyses of new sparsity
patterns), ``solve``, ``broad_phase``,
``python_other`` = the rest of the wall time) and the final pull force (N). The first-run compile
time is kept out by a short warm-up run. Wall-clock figures need a quiet machine: compare
``cpu_s`` with ``wall_s``.

The job runs with ``Simulation.advance`` and reads its log from ``Simulation.rows`` (dicts), so
that pandas is not loaded; ``--dataframe`` runs it with ``Simulation.run``, which also returns the
log as a pandas DataFrame (pandas with pyarrow add about 70 MiB to the peak memory). ``dataframe``
and ``pandas_loaded`` in the JSON line say which.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import knotsim as ks  # noqa: E402

IMC_N1 = Path(__file__).resolve().parents[2] / "shared" / "data" / "foreign" / "imc-der" / "n1"


def resample(x: np.ndarray, n: int) -> np.ndarray:
    """``(n, 3)`` points equally spaced by arc length along the polyline ``x`` (m)."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
    t = np.linspace(0.0, s[-1], n)
    return np.column_stack([np.interp(t, s, x[:, k]) for k in range(3)])


def start_shape(geometry: str | None, n_nodes: int | None) -> tuple[np.ndarray, str]:
    if geometry is None and IMC_N1.is_file():
        geometry = str(IMC_N1)
    if geometry is not None:
        try:
            from knotsim.io.geometry import read_node_file
        except ImportError:  # an older knotsim (see build_old): a text file of x y z [more] per line
            x = np.loadtxt(geometry, ndmin=2)[:, :3]
        else:
            x = read_node_file(geometry)[0]
        name = Path(geometry).name
    else:
        from knotsim.knots.library import get_knot

        x, name = np.array(get_knot("overhand_n1").ropes[0], float), "overhand_n1"
    if n_nodes is not None and n_nodes != len(x):
        x = resample(x, n_nodes)
    return x, name


def build(x: np.ndarray, args):
    """The job as a :class:`knotsim.Simulation` (public API; :func:`build_old` for older versions)."""
    if not hasattr(ks, "RodSpec"):
        return build_old(x, args)
    rope = ks.RodSpec(x, radius=1.6e-3, youngs_modulus=0.18e6, density=1180.0)
    model = ks.Model([rope], damping=0.01)
    axis = (x[-1] - x[0]) / np.linalg.norm(x[-1] - x[0])
    v = 6e-3
    bcs = ks.BoundaryConditions(model)
    for name, nodes, sign in (("left", [0, 1], -1.0), ("right", [-2, -1], 1.0)):
        bcs.move(name, nodes=nodes, path=ks.Waypoints([0.0, args.wait], [[0, 0, 0], [0, 0, 0]],
                                                     then_velocity=sign * v * axis))
    options = ks.ContactOptions(mu=args.mu)
    if hasattr(options, "friction_model"):
        options.friction_model = args.friction_model
    elif args.friction_model != "centreline":
        raise SystemExit("this knotsim has no surface friction (contact.friction_model)")
    contact = ks.Contact(model, options)
    solver = ks.SolverOptions(dt=args.dt, spin_relaxation=args.spin_relaxation)
    for name in ("spin_relaxation_above", "spin_relaxation_after"):
        if getattr(args, name) is not None:
            setattr(solver, name, getattr(args, name))
    return ks.Simulation(model, bcs, solver, interactions=[contact])


def build_old(x: np.ndarray, args):
    """The same job through the module layout of older versions (e.g. b9cf36f, before the public
    API), so that an older checkout can be timed with this script (``PYTHONPATH=CHECKOUT/src``):
    the ends are clamped until ``wait`` and then move at 6 mm/s (a displacement function)."""
    from knotsim.bc import BoundaryConditions
    from knotsim.contact.model import Contact, ContactOptions
    from knotsim.rods import Model, RodSpec
    from knotsim.simulation import Simulation
    from knotsim.solver.stepper import SolverOptions

    model = Model([RodSpec(x, radius=1.6e-3, youngs_modulus=0.18e6, density=1180.0)], damping=0.01)
    axis = (x[-1] - x[0]) / np.linalg.norm(x[-1] - x[0])
    bcs = BoundaryConditions(model)
    for name, nodes, sign in (("left", [0, 1], -1.0), ("right", [-2, -1], 1.0)):
        u = sign * 6e-3 * axis
        bcs.move(name, nodes=nodes, path=lambda t, u=u: max(0.0, t - args.wait) * u)
    contact = Contact(model, ContactOptions(mu=args.mu))
    return Simulation(model, bcs, SolverOptions(dt=args.dt), interactions=[contact])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--geometry", default=None, help="node file (default: imc-der n1, else overhand_n1)")
    ap.add_argument("--n-nodes", type=int, default=None, help="resample the start shape to N nodes")
    ap.add_argument("--wait", type=float, default=2.0, help="s held before the pull")
    ap.add_argument("--duration", type=float, default=62.0, help="s simulated in all")
    ap.add_argument("--dt", type=float, default=2.5e-3)
    ap.add_argument("--mu", type=float, default=0.3)
    ap.add_argument("--friction-model", default="centreline", choices=["centreline", "surface"],
                    help="friction law (default: the IMC paper's, centreline)")
    ap.add_argument("--no-spin-relaxation", dest="spin_relaxation", action="store_false",
                    help="solver.spin_relaxation = false (it acts with surface friction only)")
    ap.add_argument("--spin-relaxation-above", type=float, default=None, metavar="X",
                    help="solver.spin_relaxation_above (moment tolerances; default: the library's; 1: relax "
                         "every iterate, as before the option existed)")
    ap.add_argument("--spin-relaxation-after", type=int, default=None, metavar="N",
                    help="solver.spin_relaxation_after (default: the library's)")
    ap.add_argument("--force-curve", default=None, metavar="CSV",
                    help="write the pull force per step (time s, force N) to this file")
    ap.add_argument("--compare", default=None, metavar="CSV",
                    help="a --force-curve file of an earlier run: report the largest difference from it")
    ap.add_argument("--dataframe", action="store_true",
                    help="run with Simulation.run, which returns the log as a pandas DataFrame (loads pandas "
                         "and pyarrow); default: Simulation.advance, the log read from Simulation.rows")
    args = ap.parse_args()
    x, name = start_shape(args.geometry, args.n_nodes)
    build(x, args).advance(5 * args.dt)  # compile (and load cached kernels) outside the timing
    sim = build(x, args)
    contact = sim.stepper.interactions[0]
    c0, w0 = time.process_time(), time.perf_counter()
    if args.dataframe:
        frame = sim.run(args.duration, progress=False)
    else:
        sim.advance(sim.state.time + args.duration)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    log = frame if args.dataframe else log_columns(sim.rows, LOG_COLUMNS)
    steps = len(log["time"])
    iters = int(log["iterations"].sum())
    tm = sim.stepper.timers
    broad = contact.timers["broad_phase"]
    narrow = contact.timers["narrow_phase"]
    split = {"elastic": tm["forces"] - narrow, "contact_and_friction": narrow, "assembly": tm["assembly"],
             "factorization": tm.get("factorization", 0.0),
             "solve": tm["linear_solve"] - tm.get("factorization", 0.0), "broad_phase": broad,
             "spin_relaxation": tm.get("spin_relaxation", 0.0)}
    split["python_other"] = wall - sum(split.values())
    axis = (x[-1] - x[0]) / np.linalg.norm(x[-1] - x[0])
    force = np.column_stack([np.asarray(log[k], float) for k in ("right_fx", "right_fy", "right_fz")]) @ axis
    f_end = float(force[-1])
    out = {"job": f"{name}, N = {len(x)}, {args.duration:g} s at dt = {args.dt:g} s, mu = {args.mu:g}, "
                  f"{args.friction_model} friction",
           "cpu_s": round(cpu, 3), "wall_s": round(wall, 3), "steps": steps,
           "ms_per_step": round(1e3 * wall / steps, 4), "iterations_per_step": round(iters / steps, 4),
           "ms_per_iteration": round(1e3 * wall / max(iters, 1), 4),
           "factorizations_per_step": round(sim.stepper.factorizations / steps, 4),
           "contacts_per_step": round(float(np.mean(log["n_contacts"])), 2),
           "peak_rss_mib": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1),
           "split_s": {k: round(v, 3) for k, v in split.items()}, "final_pull_force_N": f_end,
           "spin_relaxations": int(getattr(sim.stepper, "spin_relaxations", 0)),
           "failed_attempts": int(sim.n_failures), "dataframe": bool(args.dataframe),
           "pandas_loaded": "pandas" in sys.modules}
    curve = np.column_stack([np.asarray(log["time"], float), force])
    if args.force_curve:
        np.savetxt(args.force_curve, curve, delimiter=",", header="time_s,pull_force_N", fmt="%.17g")
    if args.compare:
        out["compare"] = compare_curves(curve, np.loadtxt(args.compare, delimiter=",", ndmin=2))
    print(json.dumps(out))


#: the log columns the benchmark reads
LOG_COLUMNS = ("time", "iterations", "n_contacts", "right_fx", "right_fy", "right_fz")


def log_columns(rows, names) -> dict:
    """Columns ``names`` of the per-step log ``rows`` (a sequence of dicts, ``Simulation.rows``) as
    ``(steps,)`` float arrays, without pandas."""
    out = {k: np.empty(len(rows)) for k in names}
    for i, row in enumerate(rows):
        for k in names:
            out[k][i] = row[k]
    return out


def compare_curves(curve: np.ndarray, ref: np.ndarray) -> dict:
    """Difference of two force curves ``(steps, 2)`` (time s, force N): whether the step times are
    the same (within 1e-9 s), the largest absolute difference (N) and that relative to the largest
    force of ``ref``."""
    # the same step times (within 1e-9 s: a version may land the last step exactly on the end time)
    if curve.shape != ref.shape or not np.allclose(curve[:, 0], ref[:, 0], rtol=0.0, atol=1e-9):
        return {"same_steps": False, "steps": [int(curve.shape[0]), int(ref.shape[0])]}
    diff = float(np.max(np.abs(curve[:, 1] - ref[:, 1])))
    scale = float(np.max(np.abs(ref[:, 1])))
    return {"same_steps": True, "max_abs_diff_N": diff, "max_rel_diff": diff / scale if scale > 0 else diff}


if __name__ == "__main__":
    main()
