"""Views, camera axes and framing of a rendered picture.

View convention (degrees, as matplotlib's ``view_init``): ``"iso"`` = (30, -60),
``"top"`` = (90, -90) looking down -z with x to the right and y up, ``"front"`` = (0, -90)
looking along +y with x to the right and z up, or any ``(elev, azim)`` tuple.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from knotsim.errors import ConfigError

__all__ = ["VIEWS", "camera_basis", "plot_area", "scene_bounds", "view_angles"]

VIEWS: dict[str, tuple[float, float]] = {"iso": (30.0, -60.0), "top": (90.0, -90.0), "front": (0.0, -90.0)}


def view_angles(view: Any) -> tuple[float, float]:
    """``(elev, azim)`` in degrees of a view name of :data:`VIEWS` or of an ``(elev, azim)`` pair."""
    message = f"must be one of {sorted(VIEWS)} or (elev, azim), got {view!r}"
    if isinstance(view, str):
        if view not in VIEWS:
            raise ConfigError("view", message)
        return VIEWS[view]
    try:
        elev, azim = (float(v) for v in view)
    except (TypeError, ValueError):
        raise ConfigError("view", message) from None
    return elev, azim


def camera_basis(elev: float, azim: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors ``(3,)`` (towards viewer, screen right, screen up) for matplotlib-style angles (deg)."""
    e, a = np.radians(elev), np.radians(azim)
    towards = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    right = np.array([-np.sin(a), np.cos(a), 0.0])
    up = np.cross(towards, right)
    return towards, right, up


def plot_area(size: tuple[int, int], colorbar: bool, title: bool) -> tuple[float, float]:
    """Fractions ``(width, height)`` of a ``(w, h)`` pixel image left for the tubes.

    The colour bar (if any) takes a strip on the right, the title (if any) one at the top.
    """
    w, h = size
    return (
        1.0 - (min(0.3, 95.0 / w) if colorbar else 0.0),
        1.0 - (min(0.12, 36.0 / h) if title else 0.0),
    )


def scene_bounds(lines: list[np.ndarray], rad: np.ndarray, bounds: Any) -> np.ndarray:
    """``(3, 2)`` axis-aligned box (m) around all tubes, or the given one (validated).

    ``lines``: one ``(N_k, 3)`` centerline (m) per rod; ``rad``: ``(n_rods,)`` tube radii (m);
    ``bounds``: ``None`` or ``((xmin, xmax), (ymin, ymax), (zmin, zmax))`` in m.
    """
    if bounds is not None:
        b = np.asarray(bounds, dtype=np.float64)
        if b.shape != (3, 2) or not np.all(np.isfinite(b)) or np.any(b[:, 1] < b[:, 0]):
            raise ConfigError("bounds", f"must be ((xmin, xmax), (ymin, ymax), (zmin, zmax)), got {bounds!r}")
        return b
    lo = np.min([c.min(axis=0) - r for c, r in zip(lines, rad, strict=True)], axis=0)
    hi = np.max([c.max(axis=0) + r for c, r in zip(lines, rad, strict=True)], axis=0)
    return np.stack([lo, hi], axis=1)
