"""Validation cases run by ``knotsim validate``.

Each case returns rows ``{case, quantity, value, reference, error, tolerance, passed, wall_time}``
(``error`` relative unless the quantity says otherwise). ``quick`` selects coarse settings fit for CI.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from knotsim.validation.bends import bends
from knotsim.validation.cantilever import LARGE_DEFLECTION_TIP, tip_position
from knotsim.validation.contact import contact_cases
from knotsim.validation.helix import helix_equilibrium, helix_reference
from knotsim.validation.hitches import hitch_theory
from knotsim.validation.knots import overhand_tightening
from knotsim.validation.obstacles import capstan, euler_pinned, floor_friction, michell
from knotsim.validation.rolling import rolling_cases
from knotsim.validation.single_rod import single_rod_bend
from knotsim.validation.stick import stick_cases


def _row(case, quantity, value, reference, error, tolerance, wall):
    return {"case": case, "quantity": quantity, "value": float(value), "reference": float(reference),
            "error": float(error), "tolerance": float(tolerance), "passed": bool(abs(error) <= tolerance),
            "wall_time": float(wall)}


def cantilever(quick: bool = False) -> list[dict]:
    """Cantilever under its own weight: small-deflection tip drop ``qL^4/(8EI)`` (alpha = 0.1) and
    large-deflection tip positions (alpha = 1, 10, 39.24) at N = 100, within 1 %; and the error
    shrinking with N = 5, 20, 100."""
    rows = []
    n = 100
    t0 = time.perf_counter()
    tip, reaction, model = tip_position(n, 0.1)
    exact = 0.1 / 8.0
    rows.append(_row("cantilever", "tip drop/L, alpha=0.1, N=100", -tip[1], exact, (-tip[1] - exact) / exact, 0.01,
                     time.perf_counter() - t0))
    for alpha, ref in LARGE_DEFLECTION_TIP.items():
        t0 = time.perf_counter()
        tip, _, _ = tip_position(n, alpha)
        ref = np.asarray(ref)
        err = float(np.linalg.norm(tip - ref) / np.linalg.norm(ref))
        rows.append(_row("cantilever", f"tip x/L, alpha={alpha:g}, N=100", tip[0], ref[0], err, 0.01,
                         time.perf_counter() - t0))
        rows.append(_row("cantilever", f"tip z/L, alpha={alpha:g}, N=100", tip[1], ref[1], err, 0.01, 0.0))
    # convergence in N
    t0 = time.perf_counter()
    errs = []
    ref = np.asarray(LARGE_DEFLECTION_TIP[10.0])
    for nn in (5, 20, 100):
        tip, _, _ = tip_position(nn, 10.0)
        errs.append(float(np.linalg.norm(tip - ref) / np.linalg.norm(ref)))
    shrinking = errs[0] > errs[1] > errs[2]
    rows.append({"case": "cantilever", "quantity": "error at N=5,20,100 (alpha=10) decreasing",
                 "value": errs[-1], "reference": 0.0, "error": errs[-1], "tolerance": 0.01,
                 "passed": bool(shrinking and errs[-1] <= 0.01), "wall_time": time.perf_counter() - t0,
                 "detail": errs})
    return rows


def helix(quick: bool = False) -> list[dict]:
    """Natural-curvature helix: radius and pitch within 1 % (N = 200; N = 100 with ``quick``)."""
    kappa, tau = 28.284, 13.333
    n = 100 if quick else 200
    t0 = time.perf_counter()
    radius, pitch, _ = helix_equilibrium(n, kappa, tau, n_ramp=1)
    wall = time.perf_counter() - t0
    R, P = helix_reference(kappa, tau)
    return [_row("helix", f"radius (m), N={n}", radius, R, (radius - R) / R, 0.01, wall),
            _row("helix", f"pitch (m), N={n}", pitch, P, (pitch - P) / P, 0.01, 0.0)]


#: Registered cases: name -> function(quick) -> rows.
CASES: dict[str, Callable[[bool], list[dict]]] = {"cantilever": cantilever, "helix": helix,
                                                  "contact": contact_cases, "rolling": rolling_cases, "stick": stick_cases,
                                                  "overhand_tightening": overhand_tightening,
                                                  "single_rod_bend": single_rod_bend,
                                                  "bends": bends, "capstan": capstan,
                                                  "euler_pinned": euler_pinned, "floor_friction": floor_friction,
                                                  "michell": michell, "hitch_theory": hitch_theory}


def run_cases(names=None, quick: bool = False, progress: bool = False) -> list[dict]:
    """Run the named cases (all when ``names`` is empty) and return all their rows; ``progress``
    shows a progress bar over the cases (tqdm, on stderr, with the case running)."""
    from tqdm.auto import tqdm

    from knotsim.errors import ConfigError

    names = list(names or CASES)
    unknown = [n for n in names if n not in CASES]
    if unknown:
        raise ConfigError("case", f"unknown validation case {unknown[0]!r}; known cases: {sorted(CASES)}")
    rows = []
    with tqdm(names, desc="validate", unit="case", disable=not progress, leave=False) as bar:
        for name in bar:
            bar.set_postfix_str(name)
            rows.extend(CASES[name](quick))
    return rows
