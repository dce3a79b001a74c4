"""Capsizing: a set bend whose tail is pulled against its own standing end.

The reef bend is known to capsize when one rope's standing end and tail are pulled apart: that rope
straightens and the other turns into two lark's heads round it, which then slide off its end (the
practitioners' objection to the reef as a bend, docs/results/atlas.md). This script loads the bends of the
security study that way and reports what ``knot-security``'s capsize rule
(:data:`knotsim.protocols.knot_security.CAPSIZE_STRAIGHT`) saw: each bend is set as in
``docs/studies/security_critical`` (N = 201, dt = 2.5 ms, 10 mN on three ends for 3 s, relaxed to
1 mN, μ = 0.3), then rope A's standing end stays clamped and its *tail* (instead of rope B's standing
end) is pulled by a force growing at 2 mN/s for 10 s; rope B's ends are free. The run goes through
the protocol through the public API (``ks.run_protocol``); the pictures are trajectory frames.

Run: ``python validation/capsize_tail_pull.py [KNOT ...]`` (default: reef, granny, thief and grief
bends). Writes ``validation/reports/capsize_tail_pull.md`` (a table: the capsize onset, the outcome,
each rope's turning in the knot when the load began and at the end, the rope gap at the end) and
``capsize_tail_pull.png`` (the ropes at four moments of the load).
"""

from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OVERRIDES = {"mu": 0.3, "n_nodes": 201, "dt": 2.5e-3, "set_tension": 0.01, "set_ramp": 1.0, "set_hold": 3.0,
             "hold_tension": 0.001, "relax_time": 0.5, "load": "ramp", "load_rate": 0.002, "load_time": 10.0,
             "output_interval": 0.1,  # (frames for the picture; output only)
             # the protocol's defaults when this report was recorded (they changed since: CHANGELOG)
             "set_until_still": False, "stop_at_decision": False, "slip_rule": "loaded_end", "detect_after": 1.0}
KNOTS = ["reef_bend", "granny_bend", "thief_bend", "grief_bend"]
#: s into the load at which the picture shows the ropes
SNAPSHOTS = (0.0, 3.0, 4.2, 4.8)


def picture(rows: list[dict], path: Path) -> None:
    """The ropes (A blue, B red) seen along z at :data:`SNAPSHOTS`, framed on their closest approach."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.spatial import cKDTree

    fig, axs = plt.subplots(len(rows), len(SNAPSHOTS), figsize=(3.2 * len(SNAPSHOTS), 2.6 * len(rows)),
                            squeeze=False)
    for row, r in zip(axs, rows, strict=True):
        for ax, t in zip(row, SNAPSHOTS, strict=True):
            x = r["snapshots"].get(t)
            if x is None:
                ax.set_axis_off()
                continue
            a, b = x[:r["split"]], x[r["split"]:]
            ax.plot(a[:, 0] * 1e3, a[:, 1] * 1e3, color="tab:blue", lw=2)
            ax.plot(b[:, 0] * 1e3, b[:, 1] * 1e3, color="tab:red", lw=2)
            c = a[int(np.argmin(cKDTree(b).query(a)[0]))] * 1e3
            ax.set_xlim(c[0] - 50, c[0] + 50)
            ax.set_ylim(c[1] - 30, c[1] + 30)
            ax.set_aspect("equal")
            ax.set_title(f"{r['knot']}, {t:.1f} s into the load", fontsize=9)
            ax.set_xlabel("x (mm)", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def tail_pull(knot: str) -> dict:
    """One bend set, then its rope A's tail pulled against its clamped standing end
    (``knot-security`` with ``load_end = "tail"``)."""
    import tempfile

    import knotsim as ks

    wall0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        res = ks.run_protocol("knot-security", knot, out_dir=tmp, overrides={**OVERRIDES, "load_end": "tail"})
        t_load = next(st["start"] for st in res["timeline"]["stages"] if st["name"] == "load")
        traj = ks.read_trajectory(Path(tmp) / "trajectory.h5")
        snapshots = {t: np.asarray(traj.positions[traj.frame_at_time(t_load + t)], float).copy()
                     for t in SNAPSHOTS if t_load + t <= traj.time[-1] + 1e-9}
    metrics, log = res["metrics"], res.log
    capsize = metrics["capsize_onset"]
    if capsize is not None:  # s into the load, as this report gives it
        capsize = {**capsize, "time": capsize["load_stage_time"]}
    return {"knot": knot, "outcome": res["knot_status"], "run_status": res["run_status"], "capsize_onset": capsize,
            "slip_onset": metrics.get("slip_onset"), "turn_load": metrics["turn_load"],
            "turn_end": [float(log["turn_a"].iloc[-1]), float(log["turn_b"].iloc[-1])],
            "rope_gap_final": metrics.get("rope_gap_final"), "set_creep": metrics.get("set_creep"),
            "wall_time_s": time.perf_counter() - wall0, "snapshots": snapshots,
            "split": len(ks.get_knot(knot, n_nodes=OVERRIDES["n_nodes"]).ropes[0])}


def main() -> None:
    knots = sys.argv[1:] or KNOTS
    rows = []
    for knot in knots:
        r = tail_pull(knot)
        rows.append(r)
        print({k: v for k, v in r.items() if k != "snapshots"}, flush=True)
    lines = ["# Capsizing under a tail pull", "",
             "Generated by `python validation/capsize_tail_pull.py` (set-up in its docstring): each bend set at "
             "10 mN and relaxed to 1 mN (μ = 0.3, N = 201), then rope A's tail pulled against its own clamped "
             "standing end by a force growing from 1 mN at 2 mN/s; the capsize rule of `knot-security` (one "
             "rope straighter than π/4 in the knot while the other still turns π/2 or more round it, the ropes "
             "touching, for 0.25 s). Turning: each rope's total turning angle inside the knot, in units of π.", "",
             "| bend | outcome | capsized at (mN; s into the load; rope) | turning A, B at the load (π) | "
             "at the end (π) | rope gap at the end (mm) | wall time (min) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        c = r["capsize_onset"]
        cap = "—" if c is None else f"{1e3 * c['force']:.1f}; {c['time']:.2f}; {c['rope']}"
        tl = "—" if r["turn_load"] is None else ", ".join(f"{v / math.pi:.2f}" for v in r["turn_load"])
        te = ", ".join(f"{v / math.pi:.2f}" for v in r["turn_end"])
        gap = "—" if r["rope_gap_final"] is None else f"{1e3 * r['rope_gap_final']:.1f}"
        lines.append(f"| {r['knot']} | {r['outcome']} | {cap} | {tl} | {te} | {gap} | {r['wall_time_s'] / 60:.1f} |")
    picture(rows, ROOT / "validation" / "reports" / "capsize_tail_pull.png")
    lines += ["", "Rope A (blue, its tail pulled) and rope B (red) seen along z, framed on where they come "
              "closest, at 0, 3.0, 4.2 and 4.8 s into the load: the reef's rope A pulled straight with rope B "
              "folded round it (4.2 s) and sliding off (4.8 s).", "",
              "![the bends under a tail pull](capsize_tail_pull.png)"]
    out = ROOT / "validation" / "reports" / "capsize_tail_pull.md"
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
