"""Where a failed Newton solve went wrong, and why a run whose step stays collapsed cannot
progress, in words for the error message."""

from __future__ import annotations

import re
from collections import Counter

import numpy as np

#: the step counts as collapsed below ``dt_target / STALL_FRACTION`` (2 octaves above the default
#: ``dt_min = dt/1024``)
STALL_FRACTION = 256.0
#: consecutive step attempts (accepted or failed) with a collapsed step after which the run stops
#: (:class:`~knotsim.simulation.Simulation` ``stall_attempts``): at most ``2000/256 ≈ 8`` target
#: steps of simulated time; a healthy run's collapses (an impact, a stick-slip switch) recover
#: within a few hundred
STALL_ATTEMPTS = 2000

_PLACE = re.compile(r"(obstacle '[^']*'(?:: (?:node|edge) \d+ of rod '[^']*')?|node \d+ of rod '[^']*'|edge \d+ of rod '[^']*'|"
                    r"rod '[^']*' (?:node|edge) \d+(?: \(twist\))?)")


def failure_place(message: str) -> str:
    """The place a step failure's message names first (``"rod 'r' node 26"``, ``"obstacle 'post'"``,
    ...), or ``""``."""
    m = _PLACE.search(message)
    return m.group(1) if m else ""


def stall_message(*, attempts: int, failures: int, since: float, since_step: int, time: float, steps: int,
                  dt: float, dt_target: float, places: Counter, last_failure: str, hints: list[str]) -> str:
    """The :class:`~knotsim.errors.SimulationError` text of a run whose step stayed collapsed:
    ``attempts`` consecutive step attempts (``failures`` of them failed) with the step below
    ``dt_target / STALL_FRACTION`` (s) since time ``since`` (s, accepted step ``since_step``), now at
    ``time`` (s, step ``steps``) with step ``dt`` (s); ``places`` counts the places the failures
    named, ``last_failure`` is the last failure's message and ``hints`` what the interactions say
    about their state (e.g. an obstacle's contacts near sticking)."""
    out = (f"the time step stayed collapsed: {attempts} consecutive step attempts ({failures} failed) with "
           f"the step below dt/{STALL_FRACTION:g} = {dt_target / STALL_FRACTION:.3g} s (now {dt:.3g} s) since "
           f"t={since:.6g} s (step {since_step}); the run advanced {time - since:.3g} s since then (now "
           f"t={time:.6g} s, step {steps})")
    if places:
        top = ", ".join(f"{p} ({n})" for p, n in places.most_common(3))
        out += f"; failures at {top}"
    if last_failure:
        out += f"; last failure: {last_failure}"
    for h in hints:
        out += f"; {h}"
    return (out + ". The run stops here instead of crawling; its files hold every step up to the last "
            "good one (exception.last_good_state). Look at the place and quantity named above: a "
            "contact that cannot settle at any step size, a boundary condition that contradicts "
            "another, or a friction law too sharp for the step (see docs/troubleshooting.md, "
            "'The time step collapses')")


def largest_residual_at(model, interactions, system, q: np.ndarray) -> str:
    """Where the residual of a failed solve at ``q`` ``(n_dofs,)`` is largest:
    ``"; largest residual ... at rod R node K"`` (or edge K's twist), and the nearest contact pair
    with the angle between its edges (from each interaction's ``describe_near``), so that a stall
    can be traced. One extra residual evaluation of ``system``, only on failure; ``""`` when the
    residual cannot be evaluated or is not finite (the diagnosis must not hide the failure)."""
    m = model
    try:
        r = system.residual(q, False)
    except Exception:  # the diagnosis must not hide the failure
        return ""
    if not np.all(np.isfinite(r)) or not r.size:
        return ""
    k = int(np.argmax(np.abs(r)))
    if m.theta_mask[k]:
        e = int(np.flatnonzero(m.edge_theta_dof == k)[0])
        rod = int(m.edge_rod[e])
        where = f"edge {int(m.edge_local[e])} (twist)"
        unit = "N m"
        node = None
    else:
        node = int(np.searchsorted(m.node_dof, k, side="right") - 1)
        rod = int(np.searchsorted(m.rod_node_start, node, side="right") - 1)
        where = f"node {node - int(m.rod_node_start[rod])}"
        unit = "N"
    out = f"; largest residual {abs(r[k]):.3g} {unit} at rod {m.rod_names[rod]!r} {where}"
    for inter in interactions:
        if node is not None:
            text = inter.describe_near(q, node)
            if text:
                out += f", {text}"
    return out
