"""Turning grips: a rigid rotation of a boundary-condition group about an axis.

A :class:`Rotation` turns a ``move`` group about ``axis`` through a pivot (a fixed point, m, or the
group's centroid when it activates) by an angle of the time elapsed since the group's start; the
pivot moves with the group's path. The node positions are rotated rigidly, and the edge angles of
the group's edges are advanced so that their material frames turn with the grip
(:func:`frame_turn`): for an axis along an edge this is twist, for an axis normal to it none.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from knotsim.errors import ConfigError


class Rotation:
    """Rotation of a grip about ``axis (3,)`` (normalised) through ``point``.

    ``rate`` (rad/s) or ``angle(elapsed) -> rad`` (a callable of the time since the group's start,
    s; ``angle(0)`` is subtracted); positive angles turn right-handedly about ``axis``. ``point``:
    a pivot ``(3,)`` m fixed in space (then carried along by the group's path), or ``"centroid"``
    (the group's centroid when it activates).
    """

    def __init__(self, axis, rate: float | None = None, angle: Callable[[float], float] | None = None,
                 point="centroid"):
        try:
            a = np.asarray(axis, dtype=float)
        except (TypeError, ValueError):
            a = np.zeros(0)
        if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0.0:
            raise ConfigError("axis", f"expected a non-zero 3-vector, got {axis!r}")
        self.axis = a / np.linalg.norm(a)
        if (rate is None) == (angle is None):
            raise ConfigError("rate", "give exactly one of rate (rad/s) or angle (a callable of elapsed time)")
        if rate is not None:
            if not math.isfinite(float(rate)):
                raise ConfigError("rate", f"expected a finite rate in rad/s, got {rate!r}")
            self.rate = float(rate)
            self._fn = lambda s, w=self.rate: w * s  # noqa: E731
        else:
            if not callable(angle):
                raise ConfigError("angle", f"expected a callable of time, got {angle!r}")
            self.rate = None
            a0 = float(angle(0.0))
            self._fn = lambda s, f=angle, a0=a0: float(f(s)) - a0  # noqa: E731
        if isinstance(point, str):
            if point != "centroid":
                raise ConfigError("point", f"expected a point [x, y, z] (m) or \"centroid\", got {point!r}")
            self.point = None
        else:
            p = np.asarray(point, dtype=float)
            if p.shape != (3,) or not np.all(np.isfinite(p)):
                raise ConfigError("point", f"expected a point [x, y, z] (m) or \"centroid\", got {point!r}")
            self.point = p

    def angle(self, elapsed: float) -> float:
        """Angle turned (rad) ``elapsed`` s after the group's start."""
        value = self._fn(elapsed)
        if not math.isfinite(value):
            raise ConfigError("angle", f"the angle function returned {value!r} at t={elapsed}")
        return value

    def pivot(self, centroid: np.ndarray) -> np.ndarray:
        """The pivot (m) for a group whose centroid at activation is ``centroid``."""
        return centroid.copy() if self.point is None else self.point.copy()

    def __repr__(self) -> str:
        what = f"rate={self.rate}" if self.rate is not None else "angle=<function>"
        where = "centroid" if self.point is None else self.point.tolist()
        return f"Rotation(axis={self.axis.tolist()}, {what}, point={where!r})"


def as_rotation(value) -> Rotation:
    """A :class:`Rotation`, or a dict ``{axis, rate | angle, point}`` made into one."""
    if isinstance(value, Rotation):
        return value
    if isinstance(value, dict):
        unknown = set(value) - {"axis", "rate", "angle", "point"}
        if unknown:
            raise ConfigError(sorted(unknown)[0], "unknown key; a rotation has axis, rate or angle, point")
        if "axis" not in value:
            raise ConfigError("axis", "missing required field: the rotation axis [x, y, z]")
        return Rotation(value["axis"], value.get("rate"), value.get("angle"), value.get("point", "centroid"))
    raise ConfigError("rotation", f"expected a Rotation or a table {{axis, rate, point}}, got {value!r}")


def rotation_matrix(axis: np.ndarray, angle: float) -> np.ndarray:
    """``(3, 3)`` rotation by ``angle`` (rad) about the unit vector ``axis`` (Rodrigues)."""
    k = np.asarray(axis, float)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)


def frame_turn(t_old: np.ndarray, t_new: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """Edge-angle increments (rad, ``(k,)``) that make material frames turn with a rotation.

    ``t_old``, ``t_new``: ``(k, 3)`` unit tangents before and after (``t_new = rot @ t_old``);
    ``rot``: ``(3, 3)``. The stepper moves reference directors by parallel transport ``P`` from
    ``t_old`` to ``t_new``; ``P⁻¹ rot`` fixes ``t_old``, so it is a rotation about ``t_old`` by the
    returned angle, which turns the transported frame into the rotated one.
    """
    a = np.asarray(t_old, float)
    b = np.asarray(t_new, float)
    # any unit vector normal to a: cross with the coordinate axis least aligned with it
    pick = np.argmin(np.abs(a), axis=1)
    e = np.zeros_like(a)
    e[np.arange(a.shape[0]), pick] = 1.0
    u = np.cross(a, e)
    u /= np.linalg.norm(u, axis=1)[:, None]
    c = np.einsum("ij,ij->i", a, b)
    w = np.cross(a, b)
    k = np.einsum("ij,ij->i", w, u) / np.maximum(1.0 + c, 1e-300)
    pu = u * c[:, None] + np.cross(w, u) + w * k[:, None]   # parallel transport (rods.frames.transport)
    ru = u @ rot.T
    s = np.einsum("ij,ij->i", np.cross(pu, ru), b)
    return np.arctan2(s, np.einsum("ij,ij->i", pu, ru))
