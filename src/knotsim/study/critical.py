"""The critical friction of a set knot: the least μ at which it holds a given load (bisection over runs).

:func:`critical_friction` runs the ``knot-security`` protocol in its ``"hold"`` mode (the knot set,
relaxed, then the standing end loaded by ``load`` N and held) at friction coefficients chosen by
bisection, and decides each run from the motion of the rope, never from the force alone: a run
*holds* when the loaded end never ran away, the knot did not capsize, the ropes did not come apart
and less than ``drift_limit`` (m) of rope passed through the knot over the second half of the hold
(the protocol's own ``hold_drift`` rule on ``drift_through_late``: the smaller of the loaded end's
outward drift and the tails' draw-in; the first half is the knot taking up the load; an end drawn in
against the load is a knot still settling, tails drawn in while the loaded end stays a knot drawing
up). The answer is an interval ``[mu_slip, mu_hold]``: the largest μ tried that did not hold and the smallest that did, narrower than ``tol``. Monotonicity in
μ is assumed (more friction holds at least as well), and checked at the ends of the bracket.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from knotsim.errors import ConfigError

__all__ = ["CriticalFriction", "critical_friction", "holds"]


@dataclass
class CriticalFriction:
    """Outcome of :func:`critical_friction`.

    ``mu_slip`` and ``mu_hold`` bracket the critical μ (``mu_slip`` ``None`` when even the lowest μ
    held, ``mu_hold`` ``None`` when even the highest slipped); ``mu_c`` is their midpoint (``None``
    when the bracket is open) and ``width`` their distance; ``runs`` lists every run as
    ``{"mu", "holds", "outcome", "drift_pull", "drift_pull_late", "drift_tails", "drift_tails_late",
    "drift_through_late", "set_hold", "set_creep", "set_still", "in_knot_set", "slip_load"}`` (m, m,
    m, m, m, s, m/s, bool, m, N) in the order they were made.
    """

    knot: str
    load: float
    mu_slip: float | None
    mu_hold: float | None
    runs: list[dict] = field(default_factory=list)

    @property
    def mu_c(self) -> float | None:
        if self.mu_slip is None or self.mu_hold is None:
            return None
        return 0.5 * (self.mu_slip + self.mu_hold)

    @property
    def width(self) -> float | None:
        if self.mu_slip is None or self.mu_hold is None:
            return None
        return self.mu_hold - self.mu_slip


def holds(result: Any, drift_limit: float) -> bool:
    """Whether a ``knot-security`` hold run (its summary) held: no run-away, not capsized, not untied,
    and less than ``drift_limit`` (m) of rope passed through the knot over the second half of the hold
    (``drift_through_late``: the smaller of the loaded end's outward drift and the tails' draw-in;
    the loaded end's drift for a one-rope knot. The first half is the knot taking up the load: a reef
    bend set at 10 mN moves about 3 mm there under 2 mN even at μ = 0.6. An end drawn in, against the
    load, is the knot still settling and holds; so are tails drawn in while the loaded end stays)."""
    m = result["metrics"]
    if (result["outcome"] in ("untied", "slipped", "capsized") or m.get("slip_onset") is not None
            or m.get("capsize_onset") is not None):
        return False
    if not m.get("decidable", False):
        raise ConfigError("load_time", "the hold was too short to tell whether the knot holds; give a longer "
                                       "load_time")
    through = m.get("drift_through_late")
    return through is not None and float(through) < drift_limit


def critical_friction(knot: str, load: float, *, mu_low: float = 0.05, mu_high: float = 0.8, tol: float = 0.02,
                      drift_limit: float = 1e-3, overrides: dict | None = None, quick: bool = False,
                      runner: Callable[..., Any] | None = None) -> CriticalFriction:
    """The least friction coefficient at which ``knot``, set by ``knot-security``, holds ``load`` (N).

    Parameters
    ----------
    knot : a two-rope bend or an anchored one-rope knot of the library (or a drawing path).
    load : the load held on the standing end (on each end of a one-rope knot), N (the protocol's
        ``hold_load``).
    mu_low, mu_high : the bracket searched; the knot must slip at ``mu_low`` and hold at ``mu_high``
        (else the answer says so with an open bracket).
    tol : width of the final bracket in μ.
    drift_limit : m; a hold that let this much rope through the knot over its second half counts as
        slipping (passed to the protocol as ``hold_drift``).
    overrides : further ``knot-security`` parameters (``set_tension``, ``load_time``, ``n_nodes``, ...).
    quick : the protocol's quick settings.
    runner : ``runner(mu) -> summary`` instead of running the protocol (for tests and other set-ups).

    Returns
    -------
    :class:`CriticalFriction`.
    """
    for name, value in (("load", load), ("mu_high", mu_high), ("tol", tol), ("drift_limit", drift_limit)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise ConfigError(name, f"must be a positive number, got {value!r}")
    if not (isinstance(mu_low, int | float) and 0 <= mu_low < mu_high):
        raise ConfigError("mu_low", f"must be a number in [0, mu_high = {mu_high!r}), got {mu_low!r}")
    if runner is None:
        from knotsim.protocols import run_protocol

        base = dict(overrides or {})
        base.update({"load": "hold", "hold_load": float(load), "hold_drift": float(drift_limit)})

        def runner(mu):
            return run_protocol("knot-security", knot, overrides={**base, "mu": mu}, quick=quick)

    out = CriticalFriction(str(knot), float(load), None, None)

    def trial(mu: float) -> bool:
        res = runner(mu)
        ok = holds(res, drift_limit)
        m = res["metrics"]
        out.runs.append({"mu": mu, "holds": ok, "outcome": res["outcome"], "drift_pull": m.get("drift_pull"),
                         "drift_pull_late": m.get("drift_pull_late"), "drift_tails": m.get("drift_tails"),
                         "drift_tails_late": m.get("drift_tails_late"),
                         "drift_through_late": m.get("drift_through_late"),
                         "set_hold": m.get("set_hold"), "set_creep": m.get("set_creep"),
                         "set_still": m.get("set_still"),
                         "in_knot_set": m.get("in_knot_set"),
                         "slip_load": m.get("slip_load")})
        return ok

    if trial(mu_high):
        out.mu_hold = mu_high
    else:
        return out  # slips even at the top of the bracket
    if trial(mu_low):
        out.mu_hold = mu_low  # holds at the bottom: the critical μ is below the bracket
        return out
    out.mu_slip = mu_low
    while out.mu_hold - out.mu_slip > tol:
        mid = 0.5 * (out.mu_slip + out.mu_hold)
        if trial(mid):
            out.mu_hold = mid
        else:
            out.mu_slip = mid
    return out
