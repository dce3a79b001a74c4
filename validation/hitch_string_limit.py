"""The clove hitch's critical friction as the rope approaches a string: knotsim against the string
theory of docs/physics.md §4.5 (after Bayman 1977).

Run: ``python validation/hitch_string_limit.py [--out DIR] [--jobs 2]`` (default ``--out
docs/studies/hitch_string_limit``), then ``--table`` writes ``string_limit.md``. Each case is one
bisection of :func:`knotsim.critical_friction` (μ from 0.05 to 0.8, bracket 0.02, the
``knot-security`` hold at 10 mN, its other defaults) on the library's ``clove_hitch`` with one change
of rope or post:

* the bending stiffness EI lowered from the solid rod's (E = 0.18 MPa, h = 2 mm: 2.26e-6 N m²) by
  10, 100 and 1000 at h/R = 0.2 (R = 10 mm), so that the load's bending number T R_c²/EI grows from
  0.64 to 640 while the geometry stays;
* at the smallest EI per T R_c², a thicker post (R = 20 and 40 mm: h/R = 0.1 and 0.05; rope length
  and nodes grown with it, 2.5 mm edges), where the string theory's pinch factor changes.

The theory's critical μ for each geometry is printed beside it: the pinch of a point crossing with
the rider flat on the post (``pitch 0``) and with the rider at the drawing's pitch (about 57°). Each
case is written as soon as it is done (``<case>.json``), so a cut session keeps what finished.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
LOAD = 0.01  # N
H, R0 = 0.002, 0.01  # m: the library clove hitch's rope radius and post radius
EI_SOLID = 2.2619e-6  # N m^2: E pi h^4 / 4 with E = 0.18 MPa, h = 2 mm
RIDER_PITCH = math.radians(57.0)  # the drawing's rider: 6 rope diameters along the post over 0.2 turn
#: case name -> (post radius m, EI N m^2, extra overrides)
CASES = {
    "R10_EI1": (0.01, EI_SOLID, {}),
    "R10_EI10": (0.01, EI_SOLID / 10, {}),
    "R10_EI100": (0.01, EI_SOLID / 100, {}),
    "R10_EI1000": (0.01, EI_SOLID / 1000, {}),
    "R20_EI1000": (0.02, EI_SOLID / 1000 * (0.022 / 0.012) ** 2, {"length": 0.8, "n_nodes": 321}),
    "R40_EI1000": (0.04, EI_SOLID / 1000 * (0.042 / 0.012) ** 2, {"length": 1.2, "n_nodes": 481}),
}


def theory(post_radius: float) -> dict:
    """The string theory's critical μ of the clove hitch on a post of ``post_radius`` (m)."""
    from knotsim.validation import hitch_theory as ht

    flat = ht.clove_hitch_critical_mu(pinch=ht.pinch_factor(H, post_radius))
    steep = ht.clove_hitch_critical_mu(pinch=ht.pinch_factor(H, post_radius, pitch_angle=RIDER_PITCH))
    return {"mu_theory_flat": flat, "mu_theory_pitched": steep}


def one(case: str, out: str) -> str:
    import knotsim as ks

    path = Path(out) / f"{case}.json"
    if path.is_file():
        return f"{case}: kept"
    post_radius, ei, extra = CASES[case]
    overrides = {"post_radius": post_radius, "bending_stiffness": ei, **extra}
    t0 = time.time()
    res = ks.critical_friction("clove_hitch", LOAD, mu_low=0.05, mu_high=0.8, tol=0.02, overrides=overrides)
    rc = post_radius + H
    rec = {"case": case, "knot": "clove_hitch", "load": LOAD, "post_radius": post_radius, "rope_radius": H,
           "bending_stiffness": ei, "bending_number": LOAD * rc * rc / ei, "h_over_R": H / post_radius,
           "mu_slip": res.mu_slip, "mu_hold": res.mu_hold, "mu_c": res.mu_c, "runs": res.runs,
           "overrides": overrides, **theory(post_radius), "knotsim_version": ks.__version__,
           "wall_time_s": round(time.time() - t0, 1)}
    path.write_text(json.dumps(rec, indent=1))
    return f"{case}: mu_c in [{res.mu_slip}, {res.mu_hold}] ({time.time() - t0:.0f} s)"


def table(out: Path) -> str:
    rows = [json.loads((out / f"{c}.json").read_text()) for c in CASES if (out / f"{c}.json").is_file()]
    lines = ["# Clove hitch: critical friction towards the string limit", "",
             f"Hold of {LOAD * 1e3:g} mN on the standing part (knot-security defaults), bisection to 0.02. "
             "T R_c²/EI: the load's bending number; theory: docs/physics.md §4.5 (point crossing, rider flat / "
             "at the drawing's pitch of 57°). Regenerate: `python validation/hitch_string_limit.py --table`.", "",
             "| case | h/R | T R_c²/EI | μ slips | μ holds | theory (flat) | theory (pitched) | runs |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['h_over_R']:.2f} | {r['bending_number']:.3g} | {r['mu_slip']:.3f} | "
                     f"{r['mu_hold']:.3f} | {r['mu_theory_flat']:.3f} | {r['mu_theory_pitched']:.3f} | "
                     f"{len(r['runs'])} |")
    text = "\n".join(lines) + "\n"
    (out / "string_limit.md").write_text(text)
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="*", help=f"cases (default all: {', '.join(CASES)})")
    ap.add_argument("--out", default=str(ROOT / "docs" / "studies" / "hitch_string_limit"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--table", action="store_true")
    a = ap.parse_args(argv)
    out = Path(a.out)
    if a.table:
        sys.stdout.write(table(out))
        return 0
    out.mkdir(parents=True, exist_ok=True)
    cases = a.cases or list(CASES)
    with ProcessPoolExecutor(max_workers=a.jobs) as pool:
        for line in pool.map(one, cases, [str(out)] * len(cases)):
            sys.stdout.write(line + "\n")
            sys.stdout.flush()
    table(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
