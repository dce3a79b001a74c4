"""Where strands roll and where they slide in the knots of the surface-friction studies.

Run: ``python validation/rolling_in_knots.py [STUDY_DIR ...]`` (default: the surface studies under
``docs/studies``: ``granny_vs_reef_mu_tied_surface`` and ``bends_surface``, whose case directories
hold the trajectories; the committed study folders keep only their tables, so run the studies
first, see ``docs/studies.md``). Writes ``validation/reports/rolling_in_knots.md`` and, for the
cases at μ = 0.3, pictures of the knot at the middle of the pull coloured by the slip speed and by
the rolling speed (``rolling_in_knots_<case>_{slip,rolling}.png``).

Per case, over the frames of the pull (the second half of the run, when the knot is loaded), from
the per-node ``slip_speed`` and ``rolling_speed`` of ``trajectory.h5`` (docs/physics.md §3.3: at
each node in contact, the slip of the surfaces and the part of their velocity difference that
comes from the cross-sections' rotation):

- ``contact nodes``: mean number of nodes in contact per frame;
- ``slip`` and ``rolling``: medians over contact nodes and frames (m/s);
- ``rolling share``: the mean over frames of ``Σ rolling / Σ (rolling + slip)`` over the contact
  nodes: 1 where the strands only roll, 0 where they only slide. The rolling speed includes the
  turning of a strand's tangent (the lever-arm term): a strand sliding along its own curved path
  with radius of curvature ``R`` has rolling ``v h/(R + h)`` and slip ``v R/(R + h)``, so in the
  tightest parts of a knot (``R`` near ``h``) sliding alone already gives a share near one half.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "validation" / "reports"
DEFAULT = [ROOT / "docs" / "studies" / "granny_vs_reef_mu_tied_surface", ROOT / "docs" / "studies" / "bends_surface"]


def case_rows(study: Path) -> list[dict]:
    from knotsim.io.trajectory import read_trajectory

    rows = []
    for case in sorted((study / "cases").glob("[0-9a-f]*")):
        info = json.loads((case / "case.json").read_text())
        result = json.loads((case / "result.json").read_text())
        if result.get("outcome") != "completed" or not (case / "trajectory.h5").is_file():
            continue
        params = info["params"]
        knot = Path(params.get("geometry", params.get("knot", "?"))).name.replace("tied_", "")
        mu = params.get("overrides.mu")
        with read_trajectory(case / "trajectory.h5") as tr:
            if "slip_speed" not in tr.fields:
                continue
            slip = np.asarray(tr.fields["slip_speed"], float)
            rolling = np.asarray(tr.fields["rolling_speed"], float)
            t = np.asarray(tr.time, float)
        frames = np.flatnonzero(t >= 0.5 * t[-1])
        shares, n_live = [], []
        s_all, r_all = [], []
        for i in frames:
            live = np.isfinite(slip[i])
            if not live.any():
                continue
            s, r = slip[i][live], rolling[i][live]
            n_live.append(live.sum())
            shares.append(float(r.sum() / (r.sum() + s.sum())) if (r.sum() + s.sum()) > 0 else np.nan)
            s_all.append(s)
            r_all.append(r)
        if not shares:
            continue
        rows.append({"study": study.name, "case": case.name, "knot": knot, "mu": mu,
                     # the studies' own strength figure: the holding load of a bend, the window mean of a
                     # single-rod pull
                     "F_norm": result["metrics"].get("F_norm_hold", result["metrics"].get("F_norm_mean")),
                     "outcome": result["metrics"].get("protocol_outcome"),
                     "contact_nodes": float(np.mean(n_live)), "slip": float(np.median(np.concatenate(s_all))),
                     "rolling": float(np.median(np.concatenate(r_all))), "share": float(np.nanmean(shares)),
                     "dir": case})
    return rows


def picture(row: dict) -> list[str]:
    """PNG files of the middle frame of the pull, coloured by slip and by rolling speed."""
    from knotsim.io.trajectory import read_trajectory
    from knotsim.viz.render import render_frame

    names = []
    with read_trajectory(row["dir"] / "trajectory.h5") as tr:
        t = np.asarray(tr.time, float)
        i = int(np.argmin(np.abs(t - 0.75 * t[-1])))
        lines = tr.centerlines(i)
        starts = tr.rod_node_start
        x = np.concatenate(lines)
        live = np.isfinite(np.asarray(tr.fields["slip_speed"][i], float))
        pad = 15.0 * float(np.max(tr.rod_radius))
        lo, hi = x[live].min(axis=0) - pad, x[live].max(axis=0) + pad  # the knot, not the tails
        bounds = tuple((float(a), float(b)) for a, b in zip(lo, hi, strict=True))
        for field in ("slip", "rolling"):
            v = np.nan_to_num(np.asarray(tr.fields[f"{field}_speed"][i], float), nan=0.0)
            scalars = [v[starts[r]:starts[r + 1]] for r in range(len(lines))]
            name = f"rolling_in_knots_{row['study']}_{row['knot']}_mu{row['mu']:g}_{field}.png"
            render_frame(lines, tr.rod_radius, OUT / name, closed=tr.rod_closed, color_by=f"{field} speed (m/s)",
                         scalars=scalars, view="iso", size=(900, 650), backend="matplotlib", bounds=bounds,
                         title=f"{row['knot']}, mu = {row['mu']:g}, t = {t[i]:.2f} s: {field} speed (m/s)")
            names.append(name)
    return names


def main(argv: list[str]) -> None:
    studies = [Path(a) for a in argv] or DEFAULT
    rows = [r for s in studies if (s / "cases").is_dir() for r in case_rows(s)]
    lines = ["# Where strands roll and where they slide (surface friction)", "",
             "Generated by `python validation/rolling_in_knots.py` from the case directories of "
             + ", ".join(f"`{s.relative_to(ROOT)}`" for s in studies) + " (see the script's docstring for the "
             "definitions). Over the second half of each run.", "",
             "| study | knot | μ | F h²/EI (bends: holding load; single rod: window mean) | outcome | contact nodes | median slip (m/s) | median rolling (m/s) | "
             "rolling share |", "|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (r["study"], r["knot"], r["mu"])):
        f = r["F_norm"]
        lines.append(f"| {r['study']} | {r['knot']} | {r['mu']:g} | {f:.4g} | {r['outcome']} | {r['contact_nodes']:.0f} | "
                     f"{r['slip']:.3g} | {r['rolling']:.3g} | {r['share']:.2f} |")
    lines.append("")
    OUT.mkdir(parents=True, exist_ok=True)
    for r in rows:
        if r["mu"] == 0.3:
            for name in picture(r):
                lines += [f"![{name}]({name})", ""]
    (OUT / "rolling_in_knots.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main(sys.argv[1:])
