"""The set of ``knot-security`` held until the knot stops moving (``set_until_still``), as a phase of
the run (:class:`~knotsim.protocols.base.Phase`): one simulation, built with the longest set
(``set_hold_max``) and retimed by the pipeline when the knot is still."""

from __future__ import annotations

import math

import numpy as np

from knotsim.errors import ConfigError
from knotsim.protocols.base import Phase

__all__ = ["STILL_CHECK", "SetUntilStill"]

#: s between the checks of the rope in the knot's rate while the set looks for its end
STILL_CHECK = 0.05


class SetUntilStill(Phase):
    """The set held until the knot stops moving. The rope in the knot (the log's ``in_knot``, m) is
    read after every step, and from ``set_hold`` into the hold on, every :data:`STILL_CHECK` s, the
    first time its rate of change over the last ``set_still_window`` s (a least-squares line through
    those samples, the run's own ``set_creep``) and over the window before it are both at most
    ``set_still_rate`` ends the set there (one window alone can catch a turning point of a knot still
    working itself in and out): the run goes on as if built with that ``set_hold`` (the pipeline
    retimes it), which ``run.toml`` and the summary give; :attr:`record` keeps the search (the hold
    found, whether the knot stopped, its last rate). A knot still moving after ``set_hold_max`` is
    loaded then, and :attr:`notes` say so.

    ``sp``: the run's :class:`~knotsim.protocols.knot_security.SecurityParams`; ``t_settle`` (s) the
    settling before the set."""

    def __init__(self, sp, t_settle: float):
        super().__init__()
        self.hold_min, self.hold_max = sp.set_hold, sp.set_hold_max
        self.window, self.rate_limit = sp.set_still_window, sp.set_still_rate
        if self.hold_max < self.hold_min:
            raise ConfigError("set_hold_max", f"must be at least set_hold = {self.hold_min:g} s, got "
                                              f"{self.hold_max:g}")
        self.set_ramp, self.t_settle = sp.set_ramp, t_settle
        self.t_hold = t_settle + self.set_ramp  # s: the set hold begins
        self.t_first = max(0.0, self.t_hold + self.hold_min - 2.0 * self.window)
        self.next_check = self.t_hold + self.hold_min
        self.times: list[float] = []
        self.in_knot: list[float] = []
        self.rate = math.nan
        self.build_overrides = {"set_hold": self.hold_max}
        self.record = {"set_hold": self.hold_max, "still": False, "rate": math.nan, "set_hold_max": self.hold_max}

    def _set_end(self, hold: float) -> float:
        """The run time (s) at which a set held ``hold`` s ends, summed as the run description sums it
        (:func:`~knotsim.protocols.timeline.apply_settle` adds the settling to the set's own end)."""
        end = self.set_ramp + hold
        return end + self.t_settle if self.t_settle else end

    def _rate(self, tt: np.ndarray, ink: np.ndarray, t: float) -> tuple[float, float | None]:
        """The rope in the knot's rate (m/s) over the last window before ``t`` and over the window
        before that (``None`` with too few samples there)."""
        w = min(self.window, t - self.t_hold)
        recent = tt >= t - w - 1e-9
        before = (tt >= t - 2.0 * w - 1e-9) & (tt <= t - w + 1e-9)
        rate = float(np.polyfit(tt[recent], ink[recent], 1)[0])
        earlier = float(np.polyfit(tt[before], ink[before], 1)[0]) if np.count_nonzero(before) >= 3 else None
        return rate, earlier

    def observe(self, t: float, row: dict) -> dict | None:
        if self.done or t < self.t_first - 1e-9:
            return None
        if t > self.t_hold + self.hold_max + 1e-9:  # the cap: loaded before it was set
            self.done = True
            self.notes.append(f"set_until_still: the knot was still moving after set_hold_max = {self.hold_max:g} s "
                              f"of set (the rope in it changing at {1e3 * self.rate:+.3g} mm/s); it is loaded before "
                              "it was set")
            return None
        self.times.append(t)
        self.in_knot.append(float(row["in_knot"]))
        if t < self.next_check - 1e-9:
            return None
        self.next_check = t + STILL_CHECK
        tt = np.asarray(self.times)
        if np.count_nonzero(tt >= t - min(self.window, t - self.t_hold) - 1e-9) < 3:
            return None
        self.rate, earlier = self._rate(tt, np.asarray(self.in_knot), t)
        self.record["rate"] = self.rate
        if not (abs(self.rate) <= self.rate_limit and earlier is not None and abs(earlier) <= self.rate_limit):
            return None
        # still over this window and the one before it: the set ends now, at exactly this step's time
        hold = t - self.t_hold
        for _ in range(64):
            end = self._set_end(hold)
            if end == t:
                break
            hold = math.nextafter(hold, math.inf if end < t else -math.inf)
        self.done = True
        self.record.update(set_hold=hold, still=True)
        return {"set_hold": hold}
