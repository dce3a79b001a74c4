"""What one picture shows: validated rods, their colours and the scalars they are coloured by.

:func:`prepare_scene` checks and broadcasts the user's arguments of
:func:`knotsim.viz.render.render_frame` (one entry per rod); :func:`color_range` picks the colour
range of the scalars.
"""

from __future__ import annotations

from collections.abc import Sequence
from enum import StrEnum
from typing import Any

import numpy as np

from knotsim.errors import ConfigError

__all__ = ["BACKGROUND", "DEFAULT_COLORS", "NO_VALUE", "SPEED_FIELDS", "color_range", "prepare_scene"]

DEFAULT_COLORS: tuple[str, ...] = (
    "#d62728",  # red
    "#1f77b4",  # blue
    "#e8b90c",  # yellow
    "#2ca02c",  # green
    "#9467bd",  # purple
    "#ff7f0e",  # orange
    "#17becf",  # cyan
    "#8c564b",  # brown
)

BACKGROUND = (1.0, 1.0, 1.0)  # RGB in [0, 1]
#: Colour (RGB in [0, 1]) of the nodes without a value (NaN: a node out of contact when coloured by a speed).
NO_VALUE = (0.74, 0.74, 0.74)


class RenderBackend(StrEnum):
    """What draws the tubes (:func:`knotsim.viz.render.render_frame` ``backend=``)."""

    AUTO = "auto"              #: pyvista when it can be imported, else matplotlib
    PYVISTA = "pyvista"        #: pyvista / VTK (the render extra)
    MATPLOTLIB = "matplotlib"  #: matplotlib's 3D axes (always available)


class ColorBy(StrEnum):
    """A quantity the rods can be coloured by (:func:`knotsim.viz.render.render_frame` ``color_by=``)."""

    BENDING_STRAIN = "bending_strain"  #: curvature times radius at every node
    SLIP_SPEED = "slip_speed"          #: slip speed of the surfaces in contact (trajectory field, m/s; shown in mm/s)
    ROLLING_SPEED = "rolling_speed"    #: rolling part of the surfaces' speed in contact (as slip_speed)


#: The speed fields of a trajectory (``(T, n_nodes)`` m/s, NaN out of contact) and their colour-bar labels.
SPEED_FIELDS: dict[str, str] = {"slip_speed": "slip speed (mm/s)", "rolling_speed": "rolling speed (mm/s)"}


def as_backend(value) -> RenderBackend:
    """``value`` (a :class:`RenderBackend` or its string) as a :class:`RenderBackend`;
    :class:`ConfigError` (field ``backend``) otherwise."""
    try:
        return RenderBackend(value)
    except ValueError:
        raise ConfigError("backend", f"must be 'auto', 'pyvista' or 'matplotlib', got {value!r}") from None


def prepare_scene(
    centerlines: Sequence[np.ndarray],
    radii: Any,
    closed: Any,
    colors: Any,
    color_by: str | None,
    scalars: Any,
):
    """Check and broadcast the per-rod arguments of :func:`knotsim.viz.render.render_frame`.

    Returns ``(lines, rad, cl, rgb, vals, label)``: ``lines`` one ``(N_k, 3)`` float array (m) per
    rod, ``rad`` ``(n_rods,)`` radii (m), ``cl`` list of ``bool`` (closed), ``rgb`` ``(n_rods, 3)``
    colours in [0, 1], ``vals`` one ``(N_k,)`` scalar array per rod or None, ``label`` the colour
    bar's label or None.
    """
    lines = [np.asarray(c, dtype=np.float64).reshape(-1, 3) for c in centerlines]
    n = len(lines)
    if n == 0:
        raise ConfigError("centerlines", "need at least one rod")
    for k, c in enumerate(lines):
        if c.shape[0] < 2 or not np.all(np.isfinite(c)):
            raise ConfigError("centerlines", f"rod {k} needs >= 2 finite points, got shape {c.shape}")
    rad = np.broadcast_to(np.asarray(radii, dtype=np.float64), (n,)).copy()
    if np.any(~np.isfinite(rad)) or np.any(rad <= 0):
        raise ConfigError("radii", f"must be positive (m), got {rad.tolist()}")
    cl = [False] * n if closed is None else [bool(x) for x in np.broadcast_to(np.asarray(closed), (n,))]
    if colors is None:
        cols = [DEFAULT_COLORS[k % len(DEFAULT_COLORS)] for k in range(n)]
    elif isinstance(colors, str) or (len(colors) in (3, 4) and np.isscalar(colors[0])):
        cols = [colors] * n
    else:
        cols = list(colors)
        if len(cols) != n:
            raise ConfigError("colors", f"need {n} colours, got {len(cols)}")
    from matplotlib.colors import to_rgb

    try:
        rgb = np.array([to_rgb(c) for c in cols])
    except ValueError as exc:
        raise ConfigError("colors", str(exc)) from None
    vals = None
    label = None
    if color_by is not None and not (scalars is not None and color_by not in tuple(ColorBy)):
        try:
            color_by = ColorBy(color_by)
        except ValueError:
            raise ConfigError("color_by", f"must be None or one of {[c.value for c in ColorBy]}, "
                                          f"got {color_by!r}") from None
    if scalars is not None:
        vals = [np.asarray(s, dtype=np.float64).reshape(-1) for s in scalars]
        if len(vals) != n or any(v.size != c.shape[0] for v, c in zip(vals, lines, strict=True)):
            raise ConfigError("scalars", "need one (N_k,) array per rod, matching the centerlines")
        label = color_by if isinstance(color_by, str) else "value"
        if color_by in SPEED_FIELDS:  # m/s -> mm/s
            vals = [1e3 * v for v in vals]
            label = SPEED_FIELDS[str(color_by)]
    elif color_by in SPEED_FIELDS:
        raise ConfigError("color_by", f"{color_by!r} needs the node speeds (m/s) as scalars=, one array per "
                                      "rod (render_run and render_key_frames read them from trajectory.h5)")
    elif color_by is not None:
        from knotsim.io.vtk import node_bending_strain

        vals = [node_bending_strain(c, r, is_c) for c, r, is_c in zip(lines, rad, cl, strict=True)]
        label = "bending strain"
    return lines, rad, cl, rgb, vals, label


def color_range(vals: list[np.ndarray], clim: Any, from_zero: bool = False) -> tuple[float, float]:
    """``(lo, hi)`` colour range: ``clim`` if given, else the range of the finite ``vals`` (from 0
    with ``from_zero``; ``(0, 1)`` without a finite value); never empty."""
    if clim is not None:
        lo, hi = (float(x) for x in clim)
    else:
        allv = np.concatenate(vals)
        allv = allv[np.isfinite(allv)]
        lo, hi = (float(allv.min()), float(allv.max())) if allv.size else (0.0, 1.0)
        if from_zero:
            lo = min(0.0, lo)
    if not hi > lo:
        hi = lo + 1e-12 if lo == 0 else lo + abs(lo) * 1e-6
    return lo, hi
