"""Benchmark: contact-rich overhand knot tightening (contact + friction).

Run: ``python benchmarks/bench_contact.py [--steps 300] [--warmup 20] [--repeat 3]``. One rod, N = 301 nodes
(L = 1 m, h = 1.6 mm, E = 0.18 MPa, rho = 1180 kg/m^3, eta = 0.01 Pa s, no gravity) tied in a loose
overhand knot (``knotsim.knots.library.get_knot('overhand_n1')``; a generated loose trefoil-like
open curve if the library is missing), the two end nodes at each end clamped and pulled apart
along the end-to-end axis at 6 mm/s each; mu = 0.3, dt = 2.5 ms, default contact settings.

Prints the end-to-end distance (m) and pull force (N, mean of the two grips) at the end, ms per Newton
iteration, iterations per step, ms per step, contacts per step and the time
split (broad phase, narrow phase = contact evaluate, elastic forces, assembly, linear solve,
Python/other), then one JSON line ``{"results": [...]}``. The run is deterministic, so with
``--repeat R`` it is replayed R times and the figures of the fastest run are printed, plus the mean
over the steps of each step's fastest time (``ms_per_step_best_of_each_step``), which filters out
time stolen by other processes on a shared machine.
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from knotsim.bc import BoundaryConditions  # noqa: E402
from knotsim.contact.model import Contact, ContactOptions  # noqa: E402
from knotsim.rods import Model, RodSpec  # noqa: E402
from knotsim.simulation import Simulation  # noqa: E402
from knotsim.solver.stepper import SolverOptions  # noqa: E402

H = 1.6e-3


def _fallback_curve(n: int) -> np.ndarray:
    """A loose open trefoil-like curve of length 1 m with clearance > 2h (tails along x)."""
    t = np.linspace(-np.pi, np.pi, 4000)
    r = 0.05
    core = np.stack([r * (np.sin(t) + 2 * np.sin(2 * t)), r * (np.cos(t) - 2 * np.cos(2 * t)),
                     -r * np.sin(3 * t)], 1)
    core -= core[0]
    seg = np.linalg.norm(np.diff(core, axis=0), axis=1)
    tail = max(0.0, (1.0 - seg.sum()) / 2)
    a = core[0] + np.outer(np.linspace(-tail, 0, 50), [1.0, 0, 0])
    b = core[-1] + np.outer(np.linspace(0, tail, 50), [1.0, 0, 0])
    pts = np.concatenate([a[:-1], core, b[1:]])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    si = np.linspace(0, s[-1], n)
    return np.stack([np.interp(si, s, pts[:, k]) for k in range(3)], 1)


def knot_curve(n: int) -> tuple[np.ndarray, str]:
    try:
        from knotsim.knots.library import get_knot

        return np.asarray(get_knot("overhand_n1", n_nodes=n, radius=H).ropes[0]), "overhand_n1"
    except Exception:  # library not available in this version
        return _fallback_curve(n), "fallback trefoil"


def build(n_nodes: int, dt: float, mu: float):
    x, source = knot_curve(n_nodes)
    rod = RodSpec(x, radius=H, youngs_modulus=0.18e6, density=1180.0, poisson_ratio=0.5)
    m = Model([rod], damping=0.01)
    axis = x[-1] - x[0]
    axis /= np.linalg.norm(axis)
    bcs = BoundaryConditions(m)
    bcs.move("left", nodes=[0, 1], path=list(-0.006 * axis))
    bcs.move("right", nodes=[-2, -1], path=list(0.006 * axis))
    contact = Contact(m, ContactOptions(mu=mu))
    sim = Simulation(m, bcs, SolverOptions(dt=dt), interactions=[contact])
    return sim, contact, source


def run(n_nodes: int, steps: int, warmup: int, dt: float = 2.5e-3, mu: float = 0.3) -> dict:
    sim, contact, source = build(n_nodes, dt, mu)
    for _ in range(warmup):
        sim.step()
    st = sim.stepper
    for k in st.timers:
        st.timers[k] = 0.0
    for k in contact.timers:
        contact.timers[k] = 0.0
    rows0 = len(sim.rows)
    patterns0 = st._pattern_id
    step_times = np.empty(steps)
    t0 = time.perf_counter()
    for k in range(steps):
        ts = time.perf_counter()
        sim.step()
        step_times[k] = time.perf_counter() - ts
    wall = time.perf_counter() - t0
    log = sim.log().iloc[rows0:]
    iters = int(log["iterations"].sum())
    narrow = contact.timers["narrow_phase"]
    broad = contact.timers["broad_phase"]
    split = {
        "broad_phase": broad,
        "narrow_phase": narrow,
        "elastic_forces": st.timers["forces"] - narrow,  # stepper "forces" includes contact evaluate
        "assembly": st.timers["assembly"],
        "linear_solve": st.timers["linear_solve"],
    }
    split["python_other"] = wall - sum(split.values())
    x = sim.model.node_positions(sim.state.q)
    last = sim.log().iloc[-1]
    return {"n_nodes": n_nodes, "knot": source, "steps": steps, "sim_time": float(sim.state.time),
            "ms_per_iteration": 1e3 * wall / max(iters, 1), "iterations_per_step": iters / steps,
            "ms_per_step": 1e3 * wall / steps, "contacts": float(log["n_contacts"].mean()),
            "candidate_pairs": int(contact.pairs.shape[0]), "jacobian_pairs": int(contact.block_dofs().shape[0]),
            "failed_attempts": int(sim.n_failures),
            "max_penetration_ratio": float(log["max_penetration_ratio"].max()),
            "end_to_end": float(np.linalg.norm(x[-1] - x[0])),
            "force": 0.5 * float(last["left_force"] + last["right_force"]), "newton_iterations": iters,
            "pattern_changes": int(st._pattern_id - patterns0), "solver": st.last_solver,
            "share": {k: v / wall for k, v in split.items()}, "step_times": step_times}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--warmup", type=int, default=20)
    ap.add_argument("--nodes", type=int, default=301)
    ap.add_argument("--repeat", type=int, default=1,
                    help="run the (deterministic) benchmark this many times and also report the mean over steps "
                         "of each step's fastest time: robust against other load on the machine")
    args = ap.parse_args()
    runs = [run(args.nodes, args.steps, args.warmup) for _ in range(max(args.repeat, 1))]
    r = min(runs, key=lambda x: x["ms_per_step"])
    best = np.min(np.array([x.pop("step_times") for x in runs]), axis=0)
    r["ms_per_step_runs"] = [x["ms_per_step"] for x in runs]
    r["ms_per_step_best_of_each_step"] = 1e3 * float(best.mean())
    s = r["share"]
    print(f"knot: {r['knot']}, N = {r['n_nodes']}, {r['steps']} steps to t = {r['sim_time']:.3f} s, "
          f"end-to-end {r['end_to_end']:.4f} m, pull force {r['force']:.6g} N, solver {r['solver']}, failed attempts {r['failed_attempts']}")
    print(f"ms/iteration {r['ms_per_iteration']:.3f}   iterations/step {r['iterations_per_step']:.2f}   "
          f"ms/step {r['ms_per_step']:.3f}   contacts {r['contacts']:.1f} (candidates {r['candidate_pairs']}, with a Jacobian block {r['jacobian_pairs']})   "
          f"max penetration {r['max_penetration_ratio']:.2e} h")
    print("time split: " + "  ".join(f"{k} {v:.0%}" for k, v in s.items()))
    if len(runs) > 1:
        print(f"ms/step of the {len(runs)} runs: " + ", ".join(f"{v:.3f}" for v in r["ms_per_step_runs"])
              + f"; mean over steps of each step's fastest run: {r['ms_per_step_best_of_each_step']:.3f}")
    print(json.dumps({"results": [r]}))


if __name__ == "__main__":
    main()
