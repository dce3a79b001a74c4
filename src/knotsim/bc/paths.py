"""Prescribed paths for moving boundary-condition groups.

A path gives the rigid displacement (m, shape ``(3,)``) of a node group as a function of the time
elapsed since the group became active (s). Displacement is zero at elapsed time 0.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from knotsim.errors import ConfigError


class Path:
    """Base class: ``displacement(elapsed) -> (3,)`` m."""

    absolute_start: np.ndarray | None = None

    def displacement(self, elapsed: float) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError

    def bind(self, centroid: np.ndarray) -> None:
        """Called when the group activates, with its centroid (m); most paths ignore it."""

    def bound_state(self) -> np.ndarray | None:
        """What :meth:`bind` stored (``(3,)`` m), for checkpoints; ``None`` for paths that store nothing."""
        return None

    def __call__(self, elapsed: float) -> np.ndarray:
        return self.displacement(elapsed)

    def components(self, elapsed: float) -> tuple[float, float, float] | None:
        """:meth:`displacement` as three floats (m), the same numbers, without an array (the
        per-step path of :class:`~knotsim.bc.BoundaryConditions`); ``None`` when the path does not
        say (then the array is used)."""
        return None


class ConstantVelocity(Path):
    """Translation at a constant velocity ``velocity (3,)`` m/s."""

    def __init__(self, velocity: Sequence[float]):
        v = np.asarray(velocity, dtype=float)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise ConfigError("velocity", f"expected 3 finite components in m/s, got {velocity!r}")
        self.velocity = v

    def displacement(self, elapsed: float) -> np.ndarray:
        return self.velocity * elapsed

    def components(self, elapsed: float) -> tuple[float, float, float]:
        vx, vy, vz = self.velocity.tolist()
        return vx * elapsed, vy * elapsed, vz * elapsed

    def __repr__(self) -> str:
        return f"ConstantVelocity({self.velocity.tolist()})"


class RampedVelocity(Path):
    """A smooth start: the velocity grows linearly from 0 to ``velocity (3,)`` m/s over
    ``ramp_time`` s, then stays (displacement ``v e^2 / (2 T)`` for ``e < T``, ``v (e - T/2)``
    after; continuous in position and velocity)."""

    def __init__(self, velocity: Sequence[float], ramp_time: float):
        v = np.asarray(velocity, dtype=float)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise ConfigError("velocity", f"expected 3 finite components in m/s, got {velocity!r}")
        t = float(ramp_time)
        if not (t > 0 and np.isfinite(t)):
            raise ConfigError("ramp_time", f"must be a positive time in s, got {ramp_time!r}")
        self.velocity = v
        self.ramp_time = t

    def displacement(self, elapsed: float) -> np.ndarray:
        e = max(float(elapsed), 0.0)
        if e < self.ramp_time:
            return self.velocity * (e * e / (2.0 * self.ramp_time))
        return self.velocity * (e - 0.5 * self.ramp_time)

    def components(self, elapsed: float) -> tuple[float, float, float]:
        e = max(float(elapsed), 0.0)
        s = e * e / (2.0 * self.ramp_time) if e < self.ramp_time else e - 0.5 * self.ramp_time
        vx, vy, vz = self.velocity.tolist()
        return vx * s, vy * s, vz * s

    def __repr__(self) -> str:
        return f"RampedVelocity({self.velocity.tolist()}, ramp_time={self.ramp_time})"


class Waypoints(Path):
    """Piecewise-linear motion through waypoints.

    Parameters
    ----------
    times:
        Increasing times (s) measured from the group's activation, first one 0.
    points:
        Shape ``(len(times), 3)``, m. Displacements from the group's position at activation, or, with
        ``absolute=True``, positions of the group's centroid (then the first point must be where
        the centroid is when the group activates).
    from_current:
        With ``absolute=True``: the points are targets for the centroid and the path starts from
        wherever the centroid is when the group activates (a first leg from there to ``points[0]``,
        reached at ``times[0] > 0``). Lets a grip that activates mid-run go to world positions.
    then_velocity:
        ``(3,)`` m/s: after the last time the group goes on at this velocity (default: it stays at
        the last point). A fast approach followed by a steady pull is one path.
    """

    def __init__(self, times: Sequence[float], points, absolute: bool = False, from_current: bool = False,
                 then_velocity: Sequence[float] | None = None):
        t = np.asarray(times, dtype=float)
        p = np.asarray(points, dtype=float)
        self.then_velocity = None
        if then_velocity is not None:
            tv = np.asarray(then_velocity, dtype=float)
            if tv.shape != (3,) or not np.all(np.isfinite(tv)):
                raise ConfigError("then_velocity", f"expected 3 finite components in m/s, got {then_velocity!r}")
            self.then_velocity = tv
        if t.ndim != 1 or t.size < 1:
            raise ConfigError("times", f"expected a list of at least one time, got {times!r}")
        if p.shape != (t.size, 3):
            raise ConfigError("points", f"expected shape ({t.size}, 3) (one 3D point per time), got {p.shape}")
        if from_current and not absolute:
            raise ConfigError("from_current", "from_current needs absolute=true (points are centroid targets)")
        self.from_current = bool(from_current)
        if from_current:
            if not t[0] > 0:
                raise ConfigError("times", f"with from_current the first time must be > 0 (the first leg "
                                           f"starts at the current centroid at 0), got {t[0]}")
            if np.any(np.diff(t) <= 0):
                raise ConfigError("times", f"waypoint times must increase strictly, got {t.tolist()}")
            self.times = np.concatenate([[0.0], t])
            self.points = np.concatenate([np.full((1, 3), np.nan), p])
            self.absolute = True
            return
        if abs(t[0]) > 1e-12:
            raise ConfigError("times", f"waypoint times start at 0 (time since activation), got {t[0]}")
        if np.any(np.diff(t) <= 0):
            raise ConfigError("times", f"waypoint times must increase strictly, got {t.tolist()}")
        self.times = t
        self.points = p
        self.absolute = bool(absolute)
        if absolute:
            self.absolute_start = p[0].copy()
        elif np.linalg.norm(p[0]) > 1e-12:
            raise ConfigError(
                "points",
                f"relative waypoints are displacements and must start at (0, 0, 0), got {p[0].tolist()}; "
                "use absolute=true for centroid positions",
            )

    def bind(self, centroid: np.ndarray) -> None:
        if self.from_current:
            self.points[0] = centroid

    def bound_state(self) -> np.ndarray | None:
        if self.from_current and np.all(np.isfinite(self.points[0])):
            return self.points[0].copy()
        return None

    def displacement(self, elapsed: float) -> np.ndarray:
        if self.from_current and not np.all(np.isfinite(self.points[0])):
            raise ConfigError("path", "a from_current waypoint path was used before its group activated")
        times = self.times
        # outside the waypoints' times np.interp gives the end point: the same numbers without it
        if elapsed >= times[-1]:
            if self.then_velocity is None or not elapsed > times[-1]:
                return self.points[-1] - self.points[0]
            return (self.points[-1] + self.then_velocity * (elapsed - times[-1])) - self.points[0]
        if elapsed <= times[0]:
            return self.points[0] - self.points[0]
        out = np.empty(3)
        for k in range(3):
            out[k] = np.interp(elapsed, self.times, self.points[:, k])
        if self.then_velocity is not None and elapsed > self.times[-1]:
            out += self.then_velocity * (elapsed - self.times[-1])
        return out - self.points[0]

    def components(self, elapsed: float) -> tuple[float, float, float]:
        t_last = float(self.times[-1])
        if self.from_current or not (elapsed >= t_last or elapsed <= self.times[0]):
            return tuple(self.displacement(elapsed).tolist())
        x0, y0, z0 = self.points[0].tolist()
        if not elapsed >= t_last:  # at or before the first time
            return x0 - x0, y0 - y0, z0 - z0
        x, y, z = self.points[-1].tolist()
        if self.then_velocity is None or not elapsed > t_last:
            return x - x0, y - y0, z - z0
        e = elapsed - t_last
        vx, vy, vz = self.then_velocity.tolist()
        return (x + vx * e) - x0, (y + vy * e) - y0, (z + vz * e) - z0


class FunctionPath(Path):
    """Any Python callable ``f(elapsed) -> (3,)`` displacement in m (``f(0)`` is subtracted)."""

    def __init__(self, func: Callable[[float], Sequence[float]]):
        if not callable(func):
            raise ConfigError("path", f"expected a callable of time, got {func!r}")
        self.func = func
        self._origin = self._eval(0.0)

    def _eval(self, t: float) -> np.ndarray:
        try:
            out = np.asarray(self.func(t), dtype=float)
        except Exception as exc:  # user code
            raise ConfigError("path", f"the path function failed at t={t}: {exc}") from exc
        if out.shape != (3,) or not np.all(np.isfinite(out)):
            raise ConfigError("path", f"the path function must return 3 finite numbers, got {out!r} at t={t}")
        return out

    def displacement(self, elapsed: float) -> np.ndarray:
        return self._eval(elapsed) - self._origin

    def components(self, elapsed: float) -> tuple[float, float, float]:
        return tuple(self.displacement(elapsed).tolist())


def as_path(value) -> Path:
    """Coerce a :class:`Path`, a callable, or a velocity 3-vector into a :class:`Path`."""
    if isinstance(value, Path):
        return value
    if callable(value):
        return FunctionPath(value)
    return ConstantVelocity(value)
