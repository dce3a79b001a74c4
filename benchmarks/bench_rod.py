"""Benchmark: one rod bent and twisted dynamically, no contact.

Run: ``python benchmarks/bench_rod.py [--steps 300]``. For N = 101, 301, 1001 nodes (L = 1 m,
h = 1.6 mm, E = 0.18 MPa, rho = 1180 kg/m^3, gravity, eta = 0.01 Pa s, dt = 1 ms): the left end is
clamped; the right end moves on a curved path towards the left end (the rod buckles and bends) while
being twisted at 2 pi rad/s. Prints ms per Newton iteration, iterations per step, ms per step and
the share of time in force evaluation (energy kernels), assembly, linear solve and the rest
(Python), then one JSON line.
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
from knotsim.rods import Model, RodSpec  # noqa: E402
from knotsim.simulation import Simulation  # noqa: E402
from knotsim.solver.stepper import SolverOptions  # noqa: E402


def build(n_nodes: int, dt: float):
    x = np.zeros((n_nodes, 3))
    x[:, 0] = np.linspace(0.0, 1.0, n_nodes)
    rod = RodSpec(x, radius=1.6e-3, youngs_modulus=0.18e6, density=1180.0, poisson_ratio=0.5)
    m = Model([rod], gravity=(0.0, 0.0, -9.81), damping=0.01)
    bcs = BoundaryConditions(m)
    bcs.clamp("left", nodes=[0, 1])

    def path(t):
        return [-0.3 * np.sin(0.5 * np.pi * min(t, 1.0)), 0.2 * np.sin(np.pi * t), 0.1 * t]

    bcs.move("right", nodes=[-2, -1], path=path)
    # twist the right end too: a separate rotate would overlap the moving group, so twist through
    # the edge angle of the moving group's edge with a moment instead
    bcs.moment("twist", edges=[-1], moment=2e-6)
    return Simulation(m, bcs, SolverOptions(dt=dt))


def run(n_nodes: int, steps: int, dt: float = 1e-3) -> dict:
    sim = build(n_nodes, dt)
    for _ in range(20):  # warm-up (JIT is cached, but caches and the first steps are special)
        sim.step()
    st = sim.stepper
    for k in st.timers:
        st.timers[k] = 0.0
    rows0 = len(sim.rows)
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    wall = time.perf_counter() - t0
    log = sim.log().iloc[rows0:]
    iters = int(log["iterations"].sum())
    # every iteration also evaluates the residual once (plus line-search trials)
    shares = {k: v / wall for k, v in st.timers.items()}
    # "factorization" is the factorisations' part of "linear_solve": not counted twice
    shares["python_other"] = 1.0 - sum(v for k, v in shares.items() if k != "factorization")
    return {"n_nodes": n_nodes, "unknowns": sim.model.n_dofs, "steps": steps,
            "ms_per_iteration": 1e3 * wall / max(iters, 1), "iterations_per_step": iters / steps,
            "ms_per_step": 1e3 * wall / steps, "steps_per_second": steps / wall,
            "solver": st.last_solver, "share": shares}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--sizes", type=int, nargs="*", default=[101, 301, 1001])
    args = ap.parse_args()
    results = [run(n, args.steps) for n in args.sizes]
    print(f"{'N':>6} {'unknowns':>8} {'ms/iter':>8} {'iter/step':>9} {'ms/step':>8} {'steps/s':>8}  "
          f"{'forces':>6} {'assembly':>8} {'solve':>6} {'python':>6}")
    for r in results:
        s = r["share"]
        print(f"{r['n_nodes']:>6} {r['unknowns']:>8} {r['ms_per_iteration']:>8.3f} {r['iterations_per_step']:>9.2f} "
              f"{r['ms_per_step']:>8.3f} {r['steps_per_second']:>8.0f}  {s['forces']:>6.0%} {s['assembly']:>8.0%} "
              f"{s['linear_solve']:>6.0%} {s['python_other']:>6.0%}")
    print(json.dumps({"results": results}))


if __name__ == "__main__":
    main()
