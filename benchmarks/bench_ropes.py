"""Benchmark: ten 1 m ropes pressed through each other into a tangle (many rope-rope contacts).

Run: ``python benchmarks/bench_ropes.py [--ropes 10] [--nodes 300] [--steps 300] [--warmup 100]``.
``--ropes`` R ropes of ``--nodes`` nodes each (L = 1 m, h = 1.6 mm, E = 0.18 MPa, rho = 1180 kg/m^3,
eta = 0.01 Pa s), built with the public API only. Rope k (0 ... R - 1) lies flat at height
``z_k = (k - (R - 1)/2) (2h + 1 mm)`` (so no two ropes overlap at the start), along the
direction ``k pi / R`` (plus a random turn of up to 0.1 rad) through a random point within 5 cm
of the origin, waving in its plane with an amplitude of 2 cm and a wavelength of 0.25 m: every
pair of ropes crosses at least once, most several times. No gravity. Both ends of every rope
(two nodes each, clamped) move at constant velocity, in ``(warmup + steps) × dt`` from the rope's
height ``z_k`` to ``-z_k`` and ``--slack`` (default 0.2 m) towards the z axis: the layers are
pressed through each other while the slack ropes buckle onto each other into a tangle. mu = 0.3,
dt = 2.5 ms, default contact settings (``--friction-model centreline`` for the centre-line law); the
seed (``--seed``, default 1) fixes the shapes.

Prints one JSON line: ms per step, Newton iterations per step, rope-rope contacts and candidate
pairs per step (means over the timed steps; ``jacobian_pairs``: the pairs with a Jacobian block),
unknowns, ms per step per contact and per 1000 unknowns, the time split (broad phase, narrow
phase = contact evaluate, elastic forces, assembly, the linear solve as pattern analyses, numeric
factorisations and solves, Python/other) and, as answer
checks, the height of the tangle (m, ``stack_height``) and the total contact force (N) at the end, and
the size of the sparse factorisation of the last pattern (``factorisation``: nonzeros of the matrix
and of ``L``, fill, multiply-adds of one factorisation, supernodes, largest front).
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import knotsim as ks  # noqa: E402

H = 1.6e-3


def rope_shapes(n_ropes: int, n_nodes: int, seed: int) -> list[np.ndarray]:
    """``n_ropes`` arrays ``(n_nodes, 3)`` (m): flat waving ropes of length 1 m, one layer each."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, 4001) - 0.5
    out = []
    for k in range(n_ropes):
        theta = k * np.pi / n_ropes + rng.uniform(-0.1, 0.1)
        centre = rng.uniform(-0.05, 0.05, 2)
        phase = rng.uniform(0.0, 2 * np.pi)
        along = np.array([np.cos(theta), np.sin(theta)])
        across = np.array([-along[1], along[0]])
        xy = centre + s[:, None] * along + (0.02 * np.sin(2 * np.pi * s / 0.25 + phase))[:, None] * across
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
        xy = xy[arc <= 1.0]  # 1 m of rope
        arc = arc[arc <= 1.0]
        si = np.linspace(0.0, arc[-1], n_nodes)
        z = (k - 0.5 * (n_ropes - 1)) * (2 * H + 1e-3)
        out.append(np.stack([np.interp(si, arc, xy[:, 0]), np.interp(si, arc, xy[:, 1]), np.full(n_nodes, z)], 1))
    return out


def build(n_ropes: int, n_nodes: int, seed: int, press_time: float, slack: float, dt: float = 2.5e-3,
          mu: float = 0.3, friction_model: str | None = None):
    """The simulation and its rope-rope contact; at ``press_time`` (s) the grips of every rope have
    moved from its height ``z_k`` to ``-z_k`` and ``slack`` (m) towards the z axis."""
    shapes = rope_shapes(n_ropes, n_nodes, seed)
    rods = [ks.RodSpec(x, radius=H, youngs_modulus=0.18e6, density=1180.0, poisson_ratio=0.5, name=f"rope{k}")
            for k, x in enumerate(shapes)]
    model = ks.Model(rods, damping=0.01)
    bcs = ks.BoundaryConditions(model)
    for k, x in enumerate(shapes):
        for tag, nodes, end in (("a", [0, 1], x[0]), ("b", [-2, -1], x[-1])):
            inward = -end[:2] / np.linalg.norm(end[:2])  # each end towards the axis, to the mirrored height
            v = [slack * inward[0] / press_time, slack * inward[1] / press_time, -2.0 * float(x[0, 2]) / press_time]
            bcs.move(f"rope{k}_{tag}", rod=f"rope{k}", nodes=nodes, path=v)
    options = ks.ContactOptions(mu=mu) if friction_model is None else ks.ContactOptions(mu=mu, friction_model=friction_model)
    contact = ks.Contact(model, options)
    sim = ks.Simulation(model, bcs, ks.SolverOptions(dt=dt), interactions=[contact])
    return sim, contact


def run(n_ropes: int, n_nodes: int, steps: int, warmup: int, seed: int, slack: float = 0.2,
        friction_model: str | None = None) -> dict:
    sim, contact = build(n_ropes, n_nodes, seed, press_time=(warmup + steps) * 2.5e-3, slack=slack,
                         friction_model=friction_model)
    for _ in range(warmup):
        sim.step()
    st = sim.stepper
    for timers in (st.timers, contact.timers):
        for k in timers:
            timers[k] = 0.0
    rows0 = len(sim.rows)
    relaxations0 = st.spin_relaxations
    factorizations0 = st.factorizations
    analysis0 = st.sparse_analysis_seconds
    cands = np.empty(steps)
    blocks = np.empty(steps)
    t0 = time.perf_counter()
    for k in range(steps):
        sim.step()
        cands[k] = contact.pairs.shape[0]
        blocks[k] = contact.block_dofs().shape[0]
    wall = time.perf_counter() - t0
    log = sim.log().iloc[rows0:]
    iters = int(log["iterations"].sum())
    narrow, broad = contact.timers["narrow_phase"], contact.timers["broad_phase"]
    split = {"broad_phase": broad, "narrow_phase": narrow,
             "elastic_forces": st.timers["forces"] - narrow,  # stepper "forces" includes contact
             "assembly": st.timers["assembly"]}
    # the linear solve: pattern analyses (ordering, symbolic), numeric factorisations, solves
    analysis = st.sparse_analysis_seconds - analysis0
    split["pattern_analysis"] = analysis
    split["factorization"] = st.timers["factorization"] - analysis
    split["solves"] = st.timers["linear_solve"] - st.timers["factorization"]
    split["python_other"] = wall - sum(split.values())
    ms = 1e3 * wall / steps
    contacts = float(log["n_contacts"].mean())
    unknowns = int(sim.model.n_dofs)
    x = sim.model.node_positions(sim.state.q)
    return {"ropes": n_ropes, "nodes_per_rope": n_nodes, "nodes": int(sim.model.n_nodes), "unknowns": unknowns,
            "steps": steps, "sim_time": float(sim.state.time), "ms_per_step": ms,
            "iterations_per_step": iters / steps, "ms_per_iteration": 1e3 * wall / max(iters, 1),
            "contacts": contacts, "candidate_pairs": float(cands.mean()), "jacobian_pairs": float(blocks.mean()),
            "ms_per_step_per_contact": ms / max(contacts, 1.0), "ms_per_step_per_1000_unknowns": 1e3 * ms / unknowns,
            "failed_attempts": int(sim.n_failures), "max_penetration_ratio": float(log["max_penetration_ratio"].max()),
            "stack_height": float(np.ptp(x[:, 2])),
            "contact_force_total": float(log["contact_force_total"].iloc[-1]), "solver": st.last_solver,
            "factorisation": st.sparse_factorisation, "friction_model": contact.options.friction_model,
            "spin_relaxations": st.spin_relaxations - relaxations0,
            "factorizations_per_step": (st.factorizations - factorizations0) / steps,
            "share": {k: round(v / wall, 4) for k, v in split.items()}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ropes", type=int, default=10)
    ap.add_argument("--nodes", type=int, default=300, help="nodes per rope")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--warmup", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--slack", type=float, default=0.2, help="m every rope end moves towards the z axis")
    ap.add_argument("--friction-model", choices=("surface", "centreline"), default=None,
                    help="contact.friction_model (default: the library's, surface)")
    args = ap.parse_args()
    print(json.dumps(run(args.ropes, args.nodes, args.steps, args.warmup, args.seed, args.slack, args.friction_model)))


if __name__ == "__main__":
    main()
