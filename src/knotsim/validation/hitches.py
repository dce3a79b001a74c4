"""Hitch validation case for ``knotsim validate`` (rows in the format of :mod:`knotsim.validation.cases`):
the library's clove hitch against the string theory of hitches (docs/physics.md §4.5,
:mod:`knotsim.validation.hitch_theory`).

The theory says a clove hitch of perfectly flexible rope on a fixed post holds any pull with its tail
free if and only if ``2 μ p e^(2πμ) ≥ 1``, with ``p`` the crossing's pinch from the rope's thickness:
``μ_c = 0.149`` for the library's geometry (rope radius h = 2 mm, post radius R = 10 mm) with the rider
flat on the post, ``0.187`` with the rider at its drawn pitch (57°). A real rod is not a string: its
bending number ``T R_c²/EI`` (``R_c = R + h``) says how far it is from one. ``hitch_theory(quick)``
holds 10 mN on the standing part (``knot-security`` hold, its other defaults) with the solid cord's
stiffness (EI = 2.26e-6 N m², ``T R_c²/EI = 0.64``) and with EI lowered 1000 times (640):

* ``quick``: two hold runs at μ = 0.1 and 0.3 of the soft rope and one at 0.3 of the solid cord (the
  protocol's quick settings, about 30 s): the soft rope must slip at 0.1 (below the theory's band)
  and hold at 0.3 (above it), the solid cord must not hold at 0.3 (its stiffness, not the string
  mechanism, decides it);
* full: the critical μ by bisection (bracket 0.02: about 0.012 wide at the end) at EI / 1, / 10, / 100,
  / 1000 (about 20 minutes on two cores): it must come down towards the theory and level off, compared
  as the bisection's brackets ``[slips, holds]``: each softer rope's bracket starts no higher than the
  stiffer one's ends, the two softest touch or overlap, the stiffest lies wholly above them; the row
  of the softest rope reports its distance to the theory's band (measured 2026-12-05, brackets
  [0.378, 0.390], [0.343, 0.355], [0.214, 0.226], [0.226, 0.238] against 0.149–0.187; on thicker posts
  the gap closes, docs/results/hitches.md).
"""

from __future__ import annotations

import math
import time

#: N held on the standing part
LOAD = 0.01
#: N m^2: the solid cord's EI (E = 0.18 MPa, h = 2 mm)
EI_SOLID = 2.2619e-6
#: the rider's pitch in the library's drawing (rad)
RIDER_PITCH = math.radians(57.0)


def theory_band() -> tuple[float, float]:
    """The string theory's critical μ of the library's clove hitch: rider flat, rider at its pitch."""
    from knotsim.validation import hitch_theory as ht

    return (ht.clove_hitch_critical_mu(pinch=ht.pinch_factor(0.002, 0.01)),
            ht.clove_hitch_critical_mu(pinch=ht.pinch_factor(0.002, 0.01, pitch_angle=RIDER_PITCH)))


def _row(quantity, value, reference, error, tolerance, passed, wall) -> dict:
    return {"case": "hitch_theory", "quantity": quantity, "value": float(value), "reference": float(reference),
            "error": float(error), "tolerance": float(tolerance), "passed": bool(passed), "wall_time": float(wall)}


def _holds(mu: float, ei: float, quick: bool) -> tuple[bool, str]:
    from knotsim.protocols import run_protocol
    from knotsim.study.critical import holds

    res = run_protocol("knot-security", "clove_hitch", quick=quick,
                       overrides={"load": "hold", "hold_load": LOAD, "mu": mu, "bending_stiffness": ei})
    return holds(res, 1e-3), str(res["outcome"])


def hitch_theory(quick: bool = False) -> list[dict]:
    """Rows of the clove hitch against the string theory (see the module docstring)."""
    lo, hi = theory_band()
    rows = []
    if quick:
        for mu, ei, want, what in ((0.1, EI_SOLID / 1000, False, "soft rope (T R_c^2/EI = 640) at mu = 0.1, below "
                                    "the theory's band: slips"),
                                   (0.3, EI_SOLID / 1000, True, "soft rope at mu = 0.3, above the theory's band: "
                                    "holds"),
                                   (0.3, EI_SOLID, False, "solid cord (T R_c^2/EI = 0.64) at mu = 0.3: does not "
                                    "hold (stiffness decides)")):
            t0 = time.perf_counter()
            ok, outcome = _holds(mu, ei, quick=True)
            row = _row(f"{what} [{outcome}]", float(ok), float(want), float(ok != want), 0.0, ok == want,
                       time.perf_counter() - t0)
            rows.append(row)
        return rows
    from knotsim.study.critical import critical_friction

    mids, brackets = [], []
    for factor in (1, 10, 100, 1000):
        t0 = time.perf_counter()
        res = critical_friction("clove_hitch", LOAD, mu_low=0.05, mu_high=0.8, tol=0.02,
                                overrides={"bending_stiffness": EI_SOLID / factor})
        mid = res.mu_c if res.mu_c is not None else math.nan
        mids.append(mid)
        brackets.append((res.mu_slip if res.mu_slip is not None else math.nan,
                         res.mu_hold if res.mu_hold is not None else math.nan))
        rows.append(_row(f"critical mu, EI/{factor} (T R_c^2/EI = {LOAD * 0.012 ** 2 / (EI_SOLID / factor):.3g}), "
                         f"bracket [{res.mu_slip}, {res.mu_hold}]", mid, hi, mid - hi, math.inf, math.isfinite(mid),
                         time.perf_counter() - t0))
    # compared as brackets [slips, holds], the bisection's resolution: a softer rope's bracket starts no
    # higher than the stiffer one's ends, the two softest touch or overlap, the stiffest lies above both
    down = all(soft[0] <= stiff[1] for stiff, soft in zip(brackets, brackets[1:], strict=False))
    level = max(brackets[2][0], brackets[3][0]) <= min(brackets[2][1], brackets[3][1])
    apart = brackets[0][0] > max(brackets[2][1], brackets[3][1])
    ok = down and level and apart
    rows.append(_row("critical mu comes down as EI drops and levels off (brackets compared)", float(ok), 1.0,
                     float(not ok), 0.0, ok, 0.0))
    gap = mids[-1] - hi if mids[-1] > hi else (0.0 if mids[-1] >= lo else mids[-1] - lo)
    rows.append(_row(f"softest rope's distance to the theory's band [{lo:.3f}, {hi:.3f}] (reported)", mids[-1],
                     hi, gap, math.inf, math.isfinite(gap), 0.0))
    return rows
