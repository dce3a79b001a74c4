"""Tables and renders of the bend atlas from a finished study directory (with its ``cases/``).

    python docs/studies/bend_atlas/make_atlas.py STUDY_DIR [OUT_DIR]

Writes to OUT_DIR (default: this folder): ``ranking.md`` (the tables docs/results/atlas.md quotes),
``atlas.csv`` (one row per bend and mu, main table) and ``renders/<bend>.png`` (start | peak | slip
of the mu = 0.3 displacement case, seen from above, framed on the knot). Nothing here is fitted:
the numbers are the study's metrics, the orderings are sorted holding loads.
"""

from __future__ import annotations

import sys
from itertools import combinations
from pathlib import Path

import numpy as np
import pandas as pd

BENDS = ["reef", "granny", "thief", "grief", "sheet", "double_sheet", "carrick", "hunters", "zeppelin", "ashley",
         "alpine_butterfly", "double_fishermans"]
LABEL = {"reef": "reef", "granny": "granny", "thief": "thief", "grief": "grief", "sheet": "sheet",
         "double_sheet": "double sheet", "carrick": "carrick", "hunters": "hunter's", "zeppelin": "zeppelin",
         "ashley": "Ashley's", "alpine_butterfly": "alpine butterfly", "double_fishermans": "double fisherman's"}
MUS = [0.1, 0.2, 0.3, 0.5]
#: practitioners' grouping (knot books and climbing/sailing practice, coarse): 0 = not a safe bend
#: (spills or slips), 1 = the everyday bend, 2 = secure bends, 3 = the climbers' standard
PRACTICE = {"reef": 0, "granny": 0, "thief": 0, "grief": 0, "sheet": 1, "double_sheet": 2, "carrick": 2,
            "hunters": 2, "zeppelin": 2, "ashley": 2, "alpine_butterfly": 2, "double_fishermans": 3}
#: Patil et al. 2020 (docs/physics.md §5.4): firm pairwise orderings, stronger first
PUBLISHED = [("reef", "granny"), ("reef", "thief"), ("granny", "grief"), ("thief", "grief")]
#: F = F_norm EI / h^2 for the simulated rope (E = 0.18 MPa, h = 2 mm: EI = 2.26e-6 N m^2)


def _bend(knot: str) -> str:
    return knot.removesuffix("_bend")


def load(study: Path) -> pd.DataFrame:
    import knotsim as ks

    df = ks.load_study(study)
    df["bend"] = df["knot"].map(_bend)
    return df


def main_table(df: pd.DataFrame) -> pd.DataFrame:
    """Displacement cases at the base settings (N = 151, 40 mm/s, no cinching stage)."""
    m = df[(df["overrides.mode"] == "displacement") & (df["overrides.n_nodes"] == 151)
           & (df["overrides.pull_speed"] == 0.04) & (df["overrides.pre_tighten"] == 0.0)]
    return m


def uncertainty(df: pd.DataFrame, base: pd.DataFrame) -> tuple[pd.DataFrame, float]:
    """Relative change of F_norm_hold when N, the pull speed or the slack changes (mu = 0.3)."""
    rows = []
    for _, r in df[(df["overrides.mode"] == "displacement") & (df["overrides.mu"] == 0.3)].iterrows():
        what = ("N = 301" if r["overrides.n_nodes"] == 301 else "20 mm/s" if r["overrides.pull_speed"] == 0.02
                else "pre_tighten 50 mm" if r["overrides.pre_tighten"] > 0 else None)
        if what is None:
            continue
        b = base[(base["bend"] == r["bend"]) & (base["overrides.mu"] == 0.3)]
        if b.empty or not np.isfinite(r["F_norm_hold"]):
            continue
        f0 = float(b["F_norm_hold"].iloc[0])
        rows.append({"bend": r["bend"], "change": what, "F_norm_hold": r["F_norm_hold"], "base": f0,
                     "rel": r["F_norm_hold"] / f0 - 1.0, "outcome": r["protocol_outcome"],
                     "base_outcome": b["protocol_outcome"].iloc[0]})
    u = pd.DataFrame(rows)
    num = u[u["change"] != "pre_tighten 50 mm"] if len(u) else u  # the measurement: resolution and speed
    band = float(np.max(np.abs(num["rel"]))) if len(num) else float("nan")
    return u, band


def order_text(values: dict[str, float], band: float) -> str:
    """Bends sorted by holding load, strongest first; ``>`` between neighbours that differ by more
    than the relative uncertainty ``band``, ``≈`` otherwise."""
    order = sorted(values, key=lambda k: -values[k])
    out = LABEL[order[0]]
    for a, b in zip(order, order[1:], strict=False):
        out += (" > " if values[a] > values[b] * (1.0 + band) else " ≈ ") + LABEL[b]
    return out


def pair_score(pairs, values: dict[str, float], band: float) -> tuple[int, int, int, list[str]]:
    """Of the predicted pairs (stronger, weaker) with both bends in ``values``: how many the
    simulation puts the same way, the other way (by more than ``band`` relative), or level; the
    pairs it puts the other way are listed."""
    agree = other = level = 0
    bad = []
    for a, b in pairs:
        if a not in values or b not in values:
            continue
        if values[a] > values[b] * (1.0 + band):
            agree += 1
        elif values[b] > values[a] * (1.0 + band):
            other += 1
            bad.append(f"{LABEL[a]} > {LABEL[b]}")
        else:
            level += 1
    return agree, other, level, bad


def counting() -> dict[str, dict]:
    from knotsim.knots.library import get_knot
    from knotsim.knots.topology import knot_counting_rules

    return {b: knot_counting_rules(get_knot(f"{b}_bend", n_nodes=151)).as_dict() for b in BENDS}


def counting_pairs(cr: dict[str, dict]) -> list[tuple[str, str]]:
    """(stronger, weaker) by the counting rules: at least as much twist fluctuation and circulation,
    more of one (docs/knots.md: more tau and more Gamma hold better); other pairs undecided."""
    out = []
    for a, b in combinations(BENDS, 2):
        ta, ga, tb, gb = cr[a]["tau"], cr[a]["Gamma"], cr[b]["tau"], cr[b]["Gamma"]
        if ta >= tb and ga >= gb and (ta > tb or ga > gb):
            out.append((a, b))
        elif tb >= ta and gb >= ga and (tb > ta or gb > ga):
            out.append((b, a))
    return out


def practice_pairs() -> list[tuple[str, str]]:
    return [(a, b) if PRACTICE[a] > PRACTICE[b] else (b, a) for a, b in combinations(BENDS, 2)
            if PRACTICE[a] != PRACTICE[b]]


def _fmt(x, digits: int = 3) -> str:
    return "" if x is None or not np.isfinite(x) else f"{x:.{digits}g}"


def short_outcome(text: str) -> str:
    """``changed knot type (unknown (A + B; lk n) -> unknown (C + D; lk m))`` as
    ``changed: A + B, lk n -> C + D, lk m``."""
    import re

    m = re.fullmatch(r"changed knot type \((.*)\)", text)
    if not m:
        return text
    sides = [re.sub(r"^\w+ \((.*)\)$", r"\1", x.strip()).replace(";", ",") for x in m.group(1).split(" -> ")]
    return "changed: " + " → ".join(sides)


def slip_text(r) -> str:
    out = short_outcome(str(r["protocol_outcome"]))
    t = r.get("slip_onset.time")
    if out == "slipped" and t is not None and np.isfinite(t):
        out += f" at {1e3 * 0.04 * t:.0f} mm"
    return out


def write_ranking(df: pd.DataFrame, out: Path, cr: dict) -> dict:
    main = main_table(df)
    unc, band = uncertainty(df, main)
    EI, h = float(main["EI"].iloc[0]), 0.002
    lines = ["# Bend atlas: tables", "",
             "Generated by `make_atlas.py` from the study in this folder (`knotsim report` reopens it).",
             f"Holding load `F_norm_hold` = F h²/EI (the largest 0.5 s average of the pull force after the 2 s "
             f"transient); in newtons for the simulated rope (h = 2 mm, E = 0.18 MPa, EI = {EI:.3g} N m²) "
             f"F = F_norm × {EI / h**2:.3g} N.", ""]
    lines += ["## Holding load F h²/EI and outcome, displacement control (N = 151, 40 mm/s, 300 mm)", "",
              "| bend | N | τ | Γ | " + " | ".join(f"μ = {m}" for m in MUS) + " |",
              "|---|---|---|---|" + "---|" * len(MUS)]
    table = []
    for b in BENDS:
        cells = []
        for mu in MUS:
            r = main[(main["bend"] == b) & (main["overrides.mu"] == mu)]
            if r.empty:
                cells.append("not run")
                continue
            r = r.iloc[0]
            lb = bool(r["F_norm_final"] >= 0.9 * r["F_norm_hold"])  # still carrying its peak at the end
            cells.append(f"{'≥ ' if lb else ''}{_fmt(r['F_norm_hold'])} ({slip_text(r)})")
            table.append({"bend": b, "mu": mu, "F_norm_hold": r["F_norm_hold"],
                          "F_hold_N": r["F_norm_hold"] * EI / h**2, "outcome": r["protocol_outcome"],
                          "slip_onset_pull_mm": (1e3 * 0.04 * r["slip_onset.time"]
                                                 if np.isfinite(r.get("slip_onset.time", np.nan)) else np.nan),
                          "lower_bound": lb, "F_norm_mean": r["F_norm_mean"], "tail_draw_in_m": r["tail_a_draw_in"] + r["tail_b_draw_in"],
                          "worst_penetration_ratio": r["contact.worst_penetration_ratio"],
                          "N": cr[b]["N"], "tau": cr[b]["tau"], "Gamma": cr[b]["Gamma"]})
        c = cr[b]
        lines.append(f"| {LABEL[b]} | {c['N']} | {c['tau']:g} | {c['Gamma']} | " + " | ".join(cells) + " |")
    atlas = pd.DataFrame(table)
    atlas.to_csv(out / "atlas.csv", index=False)
    lines += ["", "`≥`: the force was still at (or within 10 % of) its peak in the last 0.25 s of the 300 mm pull, "
              "so the bend would have carried at least this much; `slipped at X mm`: the slip rule's onset "
              "(tails drawn in together faster than a quarter of the pull speed for 2 s), 80 mm = at the end "
              "of the transient, i.e. sliding from the start; `changed`: a tail slid out through a loop (the "
              "ropes' own knots or their linking number changed: the bend came partly undone); `untied`: the "
              "ropes' link is split.", "", "## Uncertainty (μ = 0.3)", "",
              "| bend | change | F h²/EI | base F h²/EI | relative | outcome (base) |", "|---|---|---|---|---|---|"]
    for _, r in unc[unc["change"] != "pre_tighten 50 mm"].iterrows() if len(unc) else ():
        lines.append(f"| {LABEL[r['bend']]} | {r['change']} | {_fmt(r['F_norm_hold'])} | {_fmt(r['base'])} | "
                     f"{r['rel']:+.0%} | {r['outcome']} ({r['base_outcome']}) |")
    slack = unc[unc["change"] == "pre_tighten 50 mm"] if len(unc) else unc
    lines += ["", f"Largest relative change from the resolution and the pull speed: {band:.0%}; bends whose "
              "holding loads differ by less than this are ranked level below." if np.isfinite(band)
              else "No uncertainty case finished.", ""]
    if not slack.empty:
        lines += ["## Cinched first (μ = 0.3: all four ends drawn out 50 mm at 40 mm/s, then the same pull)", "",
                  "| bend | F h²/EI cinched | outcome | F h²/EI as drawn | outcome | change |", "|---|---|---|---|---|---|"]
        for _, r in slack.iterrows():
            lines.append(f"| {LABEL[r['bend']]} | {_fmt(r['F_norm_hold'])} | {short_outcome(str(r['outcome']))} | "
                         f"{_fmt(r['base'])} | {short_outcome(str(r['base_outcome']))} | {r['rel']:+.0%} |")
        vals = {r["bend"]: float(r["F_norm_hold"]) for _, r in slack.iterrows()}
        bu = band if np.isfinite(band) else 0.0
        lines += ["", "Cinched ranking: " + order_text(vals, bu)]
        for name, pairs in (("counting", counting_pairs(cr)), ("practice", practice_pairs()), ("published", PUBLISHED)):
            a, o, lv, bad = pair_score(pairs, vals, bu)
            lines.append(f"  - {name} pairs: {a} agree, {o} the other way, {lv} level"
                         + (f" (other way: {', '.join(bad)})" if bad else ""))
        lines.append("")
    band_use = band if np.isfinite(band) else 0.0
    lines += [f"## Ranking per μ (strongest first; `≈`: neighbours within the {band_use:.0%} uncertainty; a pair "
              "counts as level when its loads differ by less than that)", ""]
    summary = {"band": band}
    cp, pp = counting_pairs(cr), practice_pairs()
    for mu in MUS:
        sub = atlas[atlas["mu"] == mu]
        vals = {r["bend"]: float(r["F_norm_hold"]) for _, r in sub.iterrows() if np.isfinite(r["F_norm_hold"])}
        if len(vals) < len(BENDS):
            lines.append(f"- μ = {mu}: {len(vals)} of {len(BENDS)} bends ran")
            if len(vals) < 2:
                continue
        sc = {name: pair_score(pairs, vals, band_use)
              for name, pairs in (("counting", cp), ("practice", pp), ("published", PUBLISHED))}
        summary[mu] = {"order": order_text(vals, band_use), **sc}
        lines.append(f"- μ = {mu}: {order_text(vals, band_use)}")
        for name, (a, o, lv, bad) in sc.items():
            lines.append(f"  - {name} pairs: {a} agree, {o} the other way, {lv} level"
                         + (f" (other way: {', '.join(bad)})" if bad else ""))
    lines += ["", "Counting-rule pairs (stronger first; τ and Γ both at least as large, one larger): "
              + ", ".join(f"{LABEL[a]} > {LABEL[b]}" for a, b in cp) + ".", ""]
    f = df[df["overrides.mode"] == "force"]
    lines += ["## Force control (μ = 0.3, ramp 1.5 mN/s for 8 s, transient 0.5 s)", "",
              "| bend | F h²/EI at run-away | N | outcome | pulled-end travel (mm) | displacement-control F h²/EI |",
              "|---|---|---|---|---|---|"]
    for b in BENDS:
        r = f[f["bend"] == b]
        d = main[(main["bend"] == b) & (main["overrides.mu"] == 0.3)]
        if r.empty:
            lines.append(f"| {LABEL[b]} | not run | | | | |")
            continue
        r = r.iloc[0]
        lines.append(f"| {LABEL[b]} | {_fmt(r['F_norm_hold'])} | {_fmt(r['F_norm_hold'] * EI / h**2)} | "
                     f"{short_outcome(str(r['protocol_outcome']))} | {_fmt(1e3 * r['pull_draw_in'])} | "
                     f"{_fmt(d['F_norm_hold'].iloc[0]) if len(d) else ''} |")
    (out / "ranking.md").write_text("\n".join(lines) + "\n")
    return summary


def _knot_box(ropes: list[np.ndarray], reach: float = 0.03, margin: float = 0.012):
    from scipy.spatial import cKDTree

    near = []
    for k, x in enumerate(ropes):
        other = ropes[1 - k]
        d = cKDTree(other).query(x)[0]
        near.append(x[d < reach])
    pts = np.concatenate([p for p in near if len(p)] or ropes)
    lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
    c, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi[:2] - lo[:2]))
    return ((c[0] - half, c[0] + half), (c[1] - half, c[1] + half), (lo[2] - half, hi[2] + half))


def renders(df: pd.DataFrame, study: Path, out: Path) -> None:
    from PIL import Image

    from knotsim.io.trajectory import read_trajectory
    from knotsim.protocols.metrics import moving_average
    from knotsim.viz.render import render_frame

    main = main_table(df)
    (out / "renders").mkdir(parents=True, exist_ok=True)
    for b in BENDS:
        r = main[(main["bend"] == b) & (main["overrides.mu"] == 0.3)]
        if r.empty:
            continue
        r = r.iloc[0]
        case = study / r["case_dir"]
        tr = read_trajectory(case / "trajectory.h5")
        log = pd.read_parquet(case / "log.parquet", columns=["time", "F_norm"])
        t = np.asarray(log["time"])
        f = moving_average(log, "F_norm", 0.5)
        after = t >= 2.0
        t_peak = float(t[after][np.argmax(f[after])]) if after.any() else float(t[-1])
        t_slip = r.get("slip_onset.time")
        marks = [("start", 0.0), ("peak", t_peak),
                 ("slip" if t_slip is not None and np.isfinite(t_slip) else "end",
                  float(t_slip) if t_slip is not None and np.isfinite(t_slip) else float(tr.time[-1]))]
        tiles = []
        for name, when in sorted(marks, key=lambda m: m[1]):
            k = int(np.argmin(np.abs(np.asarray(tr.time) - when)))
            ropes = [np.asarray(c) for c in tr.centerlines(k)]
            png = out / "renders" / f".{b}_{name}.png"
            render_frame(ropes, 0.002, png, view="top", size=(360, 320), backend="matplotlib",
                         title=f"{name}: u = {1e3 * 0.04 * float(tr.time[k]):.0f} mm", bounds=_knot_box(ropes))
            tiles.append(Image.open(png).convert("RGB"))
            png.unlink()
        strip = Image.new("RGB", (sum(i.width for i in tiles), max(i.height for i in tiles)), "white")
        x = 0
        for i in tiles:
            strip.paste(i, (x, 0))
            x += i.width
        strip.save(out / "renders" / f"{b}.png", optimize=True)


def main(argv: list[str]) -> None:
    study = Path(argv[1])
    out = Path(argv[2]) if len(argv) > 2 else Path(__file__).resolve().parent
    df = load(study)
    cr = counting()
    s = write_ranking(df, out, cr)
    if (study / "cases").is_dir():
        renders(df, study, out)
    sys.stdout.write(f"{s}\n")


if __name__ == "__main__":
    main(sys.argv)
