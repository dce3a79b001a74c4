"""Table of the numerical checks of the tied-knot headline numbers (issue 12, item 4; with
``--surface``, those of the friction at the rods' surfaces, issue 27, item 7).

Reads ``validation/studies/convergence_tied/results.parquet`` (one numerical setting changed per
case: dt halved, contact stiffness scaler x0.5 / x2, delta x0.5 / x2, the tied slack ±20 % and
the resolution N, the last two by tying again: ``validation/tie_convergence_variants.py``) and the
base cases of the tied mu-study run with the tie at N = 209 (``convergence_tied/base_n209.parquet``;
the shipped tie is at N = 601 since), and writes
``validation/studies/convergence_tied/convergence.md``: per set-up the mean F h^2/EI over the 13 s
window of the granny and the reef and their ratio at mu = 0.1 and 0.5, the band of the ratio
(min-max over every set-up, base included) and whether reef > granny (or granny > reef) holds
beyond it, and the spread of the means with and without the resolution rows.

With ``--surface``: ``validation/studies/convergence_tied_surface`` (dt halved, contact stiffness
and delta x0.5 / x2 at mu = 0.1 and 0.3, ``contact.friction_model = "surface"``) against the base
cases of ``docs/studies/granny_vs_reef_mu_tied_surface`` (the shipped tie, N = 601), into
``convergence_tied_surface/convergence.md``.

    python validation/convergence_tied_table.py
    python validation/convergence_tied_table.py --surface
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "validation" / "studies" / "convergence_tied"
#: the base cases (mu 0.1, 0.5) of the tied mu-study as it was run with the tie at N = 209, before
#: the shipped tie went to N = 601 (docs/studies/granny_vs_reef_mu_tied now holds the N = 601 study)
BASE = STUDY / "base_n209.parquet"
MUS = (0.1, 0.5)
#: Base values of the changed settings (single-rod-bend defaults; the shipped tie).
DEFAULTS = {"overrides.dt": 2.5e-3, "overrides.contact.stiffness_scaler": 500.0, "overrides.contact.delta": 5e-4}
TAGS = {"slack_m20": "tie end pull −20 % (0.176 m: more slack)", "slack_p20": "tie end pull +20 % (0.264 m: less slack)",
        "n201": "N = 201 (tied again)", "n301": "N = 301 (tied again)", "n401": "N = 401 (tied again)",
        "n601": "N = 601 (tied again)"}
ORDER = ["base (tie at N = 209)", "dt × 0.5", "contact stiffness × 0.5", "contact stiffness × 2",
         "δ × 0.5", "δ × 2", *TAGS.values()]
_NAMES = {"overrides.dt": "dt", "overrides.contact.stiffness_scaler": "contact stiffness",
          "overrides.contact.delta": "δ"}


#: ``--surface``: the band of the surface-friction law (study, base cases, friction coefficients,
#: label of the base row, the sentence on where the base comes from)
SURFACE = (ROOT / "validation" / "studies" / "convergence_tied_surface",
           ROOT / "docs" / "studies" / "granny_vs_reef_mu_tied_surface" / "results.parquet", (0.1, 0.3),
           "base (shipped tie, N = 601)",
           "the base cases of the tied μ-study with friction at the rods' surfaces\n"
           "(`docs/studies/granny_vs_reef_mu_tied_surface`: the shipped ties, N = 601, "
           "`contact.friction_model = \"surface\"`). Mean")
CENTRELINE_SOURCE = ("the base cases of\ntied μ-study run with the tie at N = 209 (`base_n209.parquet`; end pull "
                     "0.22 m per end; the shipped\ntie is at N = 601 since, `docs/studies/granny_vs_reef_mu_tied`). Mean")


def _use_surface() -> None:
    """Switch the module's settings to the surface-friction band (``--surface``)."""
    global STUDY, BASE, MUS, CENTRELINE_SOURCE
    STUDY, BASE, MUS, base_label, CENTRELINE_SOURCE = SURFACE
    ORDER[0] = base_label


def _label(row) -> tuple[str, str]:
    """(set-up label, knot) of a results row."""
    geo = Path(str(row["geometry"])).name  # tied_granny, tied_reef_n401, ...
    parts = geo.split("_")
    knot = parts[1]
    tag = "_".join(parts[2:])
    if tag and tag != "n209":  # n209: the base tie (the numerical checks of dt, stiffness, delta)
        return TAGS[tag], knot
    for key, default in DEFAULTS.items():
        v = row.get(key)
        if v is not None and not (isinstance(v, float) and math.isnan(v)):
            return f"{_NAMES[key]} × {float(v) / default:g}", knot
    return ORDER[0], knot


def collect():
    """``{label: {(knot, mu): (mean, outcome)}}`` over the base study and the checks."""
    import pandas as pd

    table: dict[str, dict] = {}
    base = pd.read_parquet(BASE)
    checks = pd.read_parquet(STUDY / "results.parquet")
    for df, is_base in ((base, True), (checks, False)):
        for row in df.to_dict("records"):
            if row["outcome"] != "completed":
                continue
            mu = round(float(row["overrides.mu"]), 6)
            if mu not in MUS:
                continue
            label, knot = (ORDER[0], Path(str(row["geometry"])).name.split("_")[1]) if is_base else _label(row)
            table.setdefault(label, {})[(knot, mu)] = (float(row["F_norm_mean"]), row["knot_status"])
    return table


def _fmt(v) -> str:
    return "—" if v is None else f"{v:.4g}"


def _verdict(lo: float, hi: float) -> str:
    if lo > 1:
        return f"reef > granny holds beyond it (lower end {lo:.3g} > 1)"
    if hi < 1:
        return f"reef > granny does not hold: the granny is above the reef beyond it (upper end {hi:.3g} < 1)"
    return "it contains 1: neither knot is above the other beyond it"


def render(table) -> str:
    rows = [lab for lab in ORDER if lab in table] + [lab for lab in table if lab not in ORDER]
    lines = ["# Tied reef and granny: numerical checks of the headline numbers", "",
             "Generated by `python validation/convergence_tied_table.py"
             + (" --surface" if STUDY == SURFACE[0] else "") + "` from this study and " + CENTRELINE_SOURCE,
             "F h²/EI over the 13 s pull at 10 mm/s per end, one numerical setting changed per row. Outcomes",
             "(`knot_status`): " + ", ".join(sorted({v[1] for r in table.values() for v in r.values()})) + ".", "",
             "| set-up | " + " | ".join(f"granny μ={mu:g} | reef μ={mu:g} | reef/granny μ={mu:g}" for mu in MUS) + " |",
             "|---|---|---|---|---|---|---|"]
    ratios = {mu: {} for mu in MUS}
    for lab in rows:
        cells = [lab]
        for mu in MUS:
            g = table[lab].get(("granny", mu))
            r = table[lab].get(("reef", mu))
            ratio = r[0] / g[0] if g and r else None
            if ratio is not None:
                ratios[mu][lab] = ratio
            cells += [_fmt(g and g[0]), _fmt(r and r[0]), _fmt(ratio)]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    base = table.get(ORDER[0], {})
    for mu in MUS:
        rs = ratios[mu]
        if not rs:
            continue
        lo, hi = min(rs.values()), max(rs.values())
        b = rs.get(ORDER[0])
        verdict = _verdict(lo, hi)
        num = [v for lab, v in rs.items() if not lab.startswith("tie end pull")]
        slack = [v for lab, v in rs.items() if lab.startswith("tie end pull")]
        settings_named = "dt, contact stiffness, δ, N" if any(lab.startswith("N = ") for lab in rs) else \
            "dt, contact stiffness, δ"
        parts = f"numerical settings only ({settings_named}; {len(num)} set-ups): [{min(num):.3g}, " \
                f"{max(num):.3g}], {_verdict(min(num), max(num))}"
        if slack:
            parts += f"; tie end pull ±20 %: {', '.join(f'{v:.3g}' for v in slack)}"
        spread = []
        for knot in ("granny", "reef"):
            ref = base.get((knot, mu))
            vals = {lab: table[lab][(knot, mu)][0] for lab in rows if (knot, mu) in table[lab]}
            if ref is None or not vals:
                continue
            dev = {lab: v / ref[0] - 1 for lab, v in vals.items() if not lab.startswith("base")}
            groups = (("dt, stiffness, δ", [d for lab, d in dev.items() if not lab.startswith(("N = ", "tie end pull"))]),
                      ("end pull −/+20 %", [d for lab, d in dev.items() if lab.startswith("tie end pull")]))
            txt = f"{knot} " + ", ".join(f"{name} {min(g) * 100:+.1f} … {max(g) * 100:+.1f} %" for name, g in groups if g)
            res = {lab: d for lab, d in dev.items() if lab.startswith("N = ")}
            if res:
                txt += ", N " + ", ".join(f"{lab.split(' (')[0][4:]}: {d * 100:+.1f} %" for lab, d in res.items())
            spread.append(txt)
        lines.append(f"- μ = {mu:g}: reef/granny {_fmt(b)} (base), band [{lo:.3g}, {hi:.3g}] over all {len(rs)} "
                     f"set-ups: {verdict}. Band of the {parts}. Means: {'; '.join(spread)}.")
    lines.append("")
    return "\n".join(lines)


def main() -> int:
    if "--surface" in sys.argv[1:]:
        _use_surface()
    text = render(collect())
    (STUDY / "convergence.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
