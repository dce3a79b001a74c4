"""Where strands roll and where they slide in the knots of the surface-friction studies.

Run: ``python validation/rolling_in_knots.py [--report NAME] [STUDY_DIR ...]`` (default: the surface studies under
``docs/studies``: ``granny_vs_reef_mu_tied_surface`` and ``bends_surface``, whose case directories
hold the trajectories; the committed study folders keep only their tables, so run the studies
first, see ``docs/studies.md``). Writes ``validation/reports/rolling_in_knots.md`` and, for the
cases at μ = 0.3, pictures of the knot at the middle of the pull coloured by the slip speed and by
the rolling speed (``rolling_in_knots_<case>_{slip,rolling}.png``). ``--report NAME`` writes
``validation/reports/NAME.md`` and names the pictures ``NAME_<case>_...`` instead.

Cases of the ``knot-security`` protocol are measured over two windows of the load stage instead of
the second half of the run: ``held`` from the end of the load's transient to the slip onset (the
loaded knot before it gives), and ``slipping`` the 2 s from the slip onset (the knot running
away); their pictures are drawn 0.5 s after the slip onset (or at the last frame with contact
before it, when the ropes have come apart).

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


def windows(params: dict, metrics: dict, t: np.ndarray) -> dict:
    """The frames measured, ``{window name: frame indices}``, and the picture's frame; ``params``
    the run's resolved protocol parameters."""
    if metrics.get("load") is None:  # not knot-security: the second half of the run
        frames = np.flatnonzero(t >= 0.5 * t[-1])
        return {"pull": frames}, int(np.argmin(np.abs(t - 0.75 * t[-1])))
    t_pre = float(params["set_ramp"]) + float(params["set_hold"]) + float(params["relax_time"])
    onset = metrics.get("slip_onset") or {}
    t_slip = t_pre + float(onset.get("time", t[-1] - t_pre))
    t_start = t_pre + float(params["transient"])
    out = {"held": np.flatnonzero((t >= t_start) & (t < t_slip)),
           "slipping": np.flatnonzero((t >= t_slip) & (t < t_slip + 2.0))}
    return out, int(np.argmin(np.abs(t - min(t_slip + 0.5, t[-1]))))


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
        metrics = result["metrics"]
        summary = case / "summary.json"
        resolved = {}
        if summary.is_file():  # the protocol's own record: nested metrics, every parameter resolved
            record = json.loads(summary.read_text())
            metrics, resolved = record.get("metrics", metrics), record.get("parameters", {})
        with read_trajectory(case / "trajectory.h5") as tr:
            if "slip_speed" not in tr.fields:
                continue
            slip = np.asarray(tr.fields["slip_speed"], float)
            rolling = np.asarray(tr.fields["rolling_speed"], float)
            t = np.asarray(tr.time, float)
        spans, picture_frame = windows(resolved, metrics, t)
        for window, frames in spans.items():
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
            # the studies' own strength figure: the slip load (knot-security), the holding load of a
            # bend, the window mean of a single-rod pull
            strength = metrics.get("slip_load_norm", metrics.get("F_norm_hold", metrics.get("F_norm_mean")))
            if metrics.get("load") is not None:
                strength = (f"{strength:.4g}" if strength is not None else  # held to the end of the ramp
                            f"> {metrics['largest_load_held'] * metrics['set_tension_norm'] / metrics['set_tension']:.4g}")
            else:
                strength = f"{strength:.4g}"
            rows.append({"study": study.name, "case": case.name, "knot": knot, "mu": mu, "window": window,
                         "F_norm": strength, "outcome": (metrics.get("protocol_outcome") if metrics.get("load") is None else
                                     "held" if metrics.get("slip_load") is None else "slipped"),
                         "frames": len(shares), "contact_nodes": float(np.mean(n_live)),
                         "slip": float(np.median(np.concatenate(s_all))),
                         "rolling": float(np.median(np.concatenate(r_all))), "share": float(np.nanmean(shares)),
                         "dir": case, "picture_frame": picture_frame})
    return rows


def picture(row: dict, prefix: str) -> list[str]:
    """PNG files of the row's picture frame, coloured by slip and by rolling speed."""
    from knotsim.io.trajectory import read_trajectory
    from knotsim.viz.render import render_frame

    names = []
    with read_trajectory(row["dir"] / "trajectory.h5") as tr:
        t = np.asarray(tr.time, float)
        i = row["picture_frame"]
        while i > 0 and not np.isfinite(np.asarray(tr.fields["slip_speed"][i], float)).any():
            i -= 1  # the ropes came apart: the last frame with contact
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
            name = f"{prefix}_{row['study']}_{row['knot']}_mu{row['mu']:g}_{field}.png"
            render_frame(lines, tr.rod_radius, OUT / name, closed=tr.rod_closed, color_by=f"{field} speed (m/s)",
                         scalars=scalars, view="iso", size=(900, 650), backend="matplotlib", bounds=bounds,
                         title=f"{row['knot']}, mu = {row['mu']:g}, t = {t[i]:.2f} s: {field} speed (m/s)")
            names.append(name)
    return names


def main(argv: list[str]) -> None:
    report = "rolling_in_knots"
    if argv[:1] == ["--report"]:
        report, argv = argv[1], argv[2:]
    studies = [Path(a).resolve() for a in argv] or DEFAULT
    rows = [r for s in studies if (s / "cases").is_dir() for r in case_rows(s)]
    lines = ["# Where strands roll and where they slide (surface friction)", "",
             f"Generated by `python validation/rolling_in_knots.py{' --report ' + report if argv else ''}"
             + "".join(f" {s.relative_to(ROOT)}" for s in studies if argv) + "` from the case directories of "
             + ", ".join(f"`{s.relative_to(ROOT)}`" for s in studies) + " (see the script's docstring for the "
             "definitions and the windows: `pull` the second half of a run; `held` and `slipping` the load "
             "stage of a knot-security run before and after its slip onset).", "",
             "| study | knot | μ | F h²/EI (knot-security: slip load; bends: holding load; single rod: window mean) "
             "| outcome | window | frames | contact nodes | median slip (m/s) | median rolling (m/s) | "
             "rolling share |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (r["study"], r["knot"], r["mu"], r["window"])):
        f = r["F_norm"]
        lines.append(f"| {r['study']} | {r['knot']} | {r['mu']:g} | {f} | {r['outcome']} | {r['window']} | "
                     f"{r['frames']} | {r['contact_nodes']:.0f} | {r['slip']:.3g} | {r['rolling']:.3g} | "
                     f"{r['share']:.2f} |")
    lines.append("")
    OUT.mkdir(parents=True, exist_ok=True)
    drawn = set()
    for r in rows:
        if r["mu"] == 0.3 and r["dir"] not in drawn:
            drawn.add(r["dir"])
            for name in picture(r, report):
                lines += [f"![{name}]({name})", ""]
    (OUT / f"{report}.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main(sys.argv[1:])
