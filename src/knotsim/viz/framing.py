"""Where the knot is: the box a picture of a run is framed on.

The *contacts* of a frame (:func:`contact_mask`) are the nodes within the contact distance
``(r_i + r_j) (1 + tol) + edge / 2`` (m; ``r`` the radii, ``edge`` the longer median edge length
of the two ropes: two edges touching between their nodes have nodes that far apart) of a node of
another rope, or of a node of their own rope that is not their neighbour along it (more than
``max(2, ceil(4 r / edge))`` nodes apart). The *knot* (:func:`knot_mask`) is the part of the
contacts where the strands cross (their tangents more than :data:`CROSSING_ANGLE` apart): a bend
or a loop lays long legs side by side (a standing part along its own tail, in contact all along),
which are not the knot; when no contact crosses, all of them. The picture frames the knot plus a
margin (:data:`MARGIN` rope diameters) on every side, and leaves the rest of the ropes (long
tails, ends that were pulled far away) to be clipped.

When a frame has no contact (the knot came apart, a straight rope) the box falls back, in order
(:func:`trajectory_knot_region`):

1. ``"earlier"``: the contact region of the latest earlier frame with contact, when the ropes of
   the frame still pass through it (the knot only just came apart: the frame at the decision);
2. ``"closest"``: the region of closest approach between ropes (the nodes within the closest
   distance between two ropes plus the contact distance of another rope), with two or more ropes;
3. ``"whole"``: the whole scene.

All functions are vectorised over the nodes (a k-d tree finds the close pairs); positions in m.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from knotsim.errors import ConfigError

__all__ = ["CONTACT_TOL", "CROSSING_ANGLE", "MARGIN", "KnotRegion", "contact_mask", "knot_mask", "knot_region",
           "trajectory_knot_region", "union_box"]

#: Contact tolerance: nodes closer than ``2 r (1 + CONTACT_TOL)`` are in contact (dimensionless).
CONTACT_TOL = 0.25
#: Margin around the knot, in rope diameters.
MARGIN = 3.0
#: Strands in contact whose tangents are more than this far apart (degrees) cross: the knot.
CROSSING_ANGLE = 30.0


@dataclass(frozen=True)
class KnotRegion:
    """The box a picture is framed on.

    Attributes
    ----------
    box:
        ``(3, 2)`` axis-aligned box ``((xmin, xmax), (ymin, ymax), (zmin, zmax))`` in m, margin included.
    source:
        What it frames: ``"contact"`` (the nodes in contact in this frame), ``"earlier"`` (those of
        an earlier frame, ``frame``), ``"closest"`` (the closest approach between ropes) or
        ``"whole"`` (every node).
    frame:
        Loaded frame whose contacts gave the box (``"contact"``, ``"earlier"``), else None.
    """

    box: np.ndarray
    source: str
    frame: int | None = None


def _prepare(centerlines: Sequence[np.ndarray], radius: Any, closed: Any) -> dict[str, Any]:
    """The ropes stacked: ``x`` ``(N, 3)`` nodes (m), per node its ``rope``, ``index`` along it, radius
    ``r`` (m), median edge length ``edge`` of its rope (m) and unit tangent ``t`` ``(N, 3)``; per
    rope ``counts`` (nodes), ``closed`` and neighbour ``window`` (nodes)."""
    lines = [np.asarray(c, dtype=np.float64).reshape(-1, 3) for c in centerlines]
    n = len(lines)
    if n == 0 or any(c.shape[0] == 0 for c in lines):
        raise ConfigError("centerlines", "need at least one rope with nodes")
    rad = np.broadcast_to(np.asarray(radius, dtype=np.float64), (n,)).copy()
    if np.any(~np.isfinite(rad)) or np.any(rad <= 0):
        raise ConfigError("radius", f"must be positive (m), got {rad.tolist()}")
    cl = np.zeros(n, bool) if closed is None else np.broadcast_to(np.asarray(closed, dtype=bool), (n,)).copy()
    counts = np.array([c.shape[0] for c in lines])
    x = np.concatenate(lines)
    if not np.all(np.isfinite(x)):
        raise ConfigError("centerlines", "node positions must be finite")
    rope = np.repeat(np.arange(n), counts)
    index = np.arange(x.shape[0]) - np.repeat(np.cumsum(counts) - counts, counts)
    # per rope (a loop over ropes, not nodes): median edge length and tangents by central differences
    edge = np.array([float(np.median(np.linalg.norm(np.diff(c, axis=0), axis=1))) if c.shape[0] > 1 else 0.0
                     for c in lines])
    tangents = []
    for c, is_closed in zip(lines, cl, strict=True):
        if c.shape[0] < 2:
            tangents.append(np.zeros_like(c))
            continue
        nxt = np.roll(c, -1, axis=0) if is_closed else np.vstack([c[1:], c[-1:]])
        prv = np.roll(c, 1, axis=0) if is_closed else np.vstack([c[:1], c[:-1]])
        d = nxt - prv
        tangents.append(d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300))
    window = np.maximum(2, np.ceil(4.0 * rad / np.maximum(edge, 1e-300))).astype(np.int64)
    return {"x": x, "rope": rope, "index": index, "r": rad[rope], "edge": edge[rope], "t": np.concatenate(tangents),
            "counts": counts, "closed": cl, "window": window}


def _contact_pairs(g: dict[str, Any], tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Node pairs ``(i, j)`` in contact (module docstring)."""
    from scipy.spatial import cKDTree

    x, r, edge = g["x"], g["r"], g["edge"]
    reach = 2.0 * float(r.max()) * (1.0 + tol) + 0.5 * float(edge.max())
    pairs = cKDTree(x).query_pairs(reach, output_type="ndarray")
    if not pairs.size:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    i, j = pairs[:, 0], pairs[:, 1]
    d = np.linalg.norm(x[i] - x[j], axis=1)
    near = d < (r[i] + r[j]) * (1.0 + tol) + 0.5 * np.maximum(edge[i], edge[j])
    rope, counts, window = g["rope"], g["counts"], g["window"]
    ri = rope[i]
    apart = np.abs(g["index"][i] - g["index"][j])
    apart = np.where(g["closed"][ri], np.minimum(apart, counts[ri] - apart), apart)
    ok = near & ((ri != rope[j]) | (apart > window[ri]))
    return i[ok], j[ok]


def _pairs_mask(n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    mask = np.zeros(n, bool)
    mask[i] = True
    mask[j] = True
    return mask


def contact_mask(centerlines: Sequence[np.ndarray], radius: float | Sequence[float],
                 closed: bool | Sequence[bool] | None = None, *, tol: float = CONTACT_TOL) -> list[np.ndarray]:
    """Which nodes are in contact (module docstring).

    Parameters
    ----------
    centerlines:
        ``(N_k, 3)`` node positions (m) of each rope.
    radius:
        Rope radius (m), one for all or one per rope.
    closed:
        Per rope (or one value for all): whether it is a ring (its first and last nodes are
        neighbours). ``None``: all open.
    tol:
        Contact tolerance (dimensionless): nodes closer than ``(r_i + r_j) (1 + tol) + edge / 2`` touch.

    Returns
    -------
    list of ndarray
        One ``(N_k,)`` bool mask per rope.
    """
    g = _prepare(centerlines, radius, closed)
    i, j = _contact_pairs(g, float(tol))
    return np.split(_pairs_mask(g["x"].shape[0], i, j), np.cumsum(g["counts"])[:-1])


def _knot(g: dict[str, Any], tol: float) -> np.ndarray:
    i, j = _contact_pairs(g, tol)
    if not i.size:
        return np.zeros(g["x"].shape[0], bool)
    cross = np.abs(np.einsum("ij,ij->i", g["t"][i], g["t"][j])) < np.cos(np.radians(CROSSING_ANGLE))
    if cross.any():
        i, j = i[cross], j[cross]
    return _pairs_mask(g["x"].shape[0], i, j)


def knot_mask(centerlines: Sequence[np.ndarray], radius: float | Sequence[float],
              closed: bool | Sequence[bool] | None = None, *, tol: float = CONTACT_TOL) -> list[np.ndarray]:
    """Which nodes are in the knot: the contacts where strands cross, or all contacts when none
    cross (module docstring); arguments and result as :func:`contact_mask`."""
    g = _prepare(centerlines, radius, closed)
    return np.split(_knot(g, float(tol)), np.cumsum(g["counts"])[:-1])


def _closest_mask(x: np.ndarray, rope: np.ndarray, r_node: np.ndarray, tol: float) -> np.ndarray | None:
    """Nodes within (closest distance between two ropes + contact distance) of another rope; None
    with one rope."""
    from scipy.spatial import cKDTree

    ropes = np.unique(rope)
    if ropes.size < 2:
        return None
    dist = np.full(x.shape[0], np.inf)
    for k in ropes:  # a loop over ropes: each rope's nodes against a tree of the others
        own = rope == k
        d, _ = cKDTree(x[~own]).query(x[own])
        dist[own] = d
    reach = float(dist.min()) + 2.0 * float(r_node.max()) * (1.0 + tol)
    return dist <= reach


def _box(points: np.ndarray, pad: float) -> np.ndarray:
    return np.stack([points.min(axis=0) - pad, points.max(axis=0) + pad], axis=1)


def _margin(r_node: np.ndarray, margin: float | None) -> float:
    return 2.0 * float(r_node.max()) * (MARGIN if margin is None else float(margin)) + float(r_node.max())


def knot_region(centerlines: Sequence[np.ndarray], radius: float | Sequence[float],
                closed: bool | Sequence[bool] | None = None, *, margin: float | None = None,
                tol: float = CONTACT_TOL) -> tuple[np.ndarray, np.ndarray]:
    """The box around the knot of one frame: its nodes in contact, else the closest approach
    between ropes, else everything, plus a margin (module docstring).

    Parameters
    ----------
    centerlines, radius, closed, tol:
        As :func:`contact_mask`.
    margin:
        Margin around the nodes, in rope diameters (default :data:`MARGIN`); the tube radius is
        added to it.

    Returns
    -------
    (lo, hi):
        ``(3,)`` lower and upper corners of the box (m).
    """
    region = _region(centerlines, radius, closed, margin, tol)
    return region.box[:, 0].copy(), region.box[:, 1].copy()


def _region(centerlines, radius, closed, margin, tol) -> KnotRegion:
    g = _prepare(centerlines, radius, closed)
    x, r = g["x"], g["r"]
    pad = _margin(r, margin)
    mask = _knot(g, float(tol))
    if mask.any():
        return KnotRegion(_box(x[mask], pad), "contact")
    near = _closest_mask(x, g["rope"], r, float(tol))
    if near is not None:
        return KnotRegion(_box(x[near], pad), "closest")
    return KnotRegion(_box(x, float(r.max())), "whole")


def union_box(boxes: Sequence[np.ndarray]) -> np.ndarray:
    """The ``(3, 2)`` box (m) enclosing all the ``(3, 2)`` ``boxes``."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 3, 2)
    return np.stack([b[:, :, 0].min(axis=0), b[:, :, 1].max(axis=0)], axis=1)


def trajectory_knot_region(traj: Any, frame: int, *, margin: float | None = None,
                           tol: float = CONTACT_TOL) -> KnotRegion:
    """The box a picture of loaded frame ``frame`` of ``traj`` is framed on, with the fallbacks of
    the module docstring (an earlier frame's contacts when the knot only just came apart).

    Parameters
    ----------
    traj:
        A :class:`knotsim.io.trajectory.Trajectory` (lazy or not).
    frame:
        Loaded frame index (negative counts from the end).
    margin, tol:
        As :func:`knot_region`.
    """
    n = traj.n_frames
    if not -n <= int(frame) < n:
        raise ConfigError("frame", f"index {frame} out of range for {n} frames")
    i = int(frame) % n
    radius, closed = traj.rod_radius, traj.rod_closed
    lines = traj.centerlines(i)
    here = _region(lines, radius, closed, margin, tol)
    if here.source == "contact":
        return KnotRegion(here.box, "contact", i)
    x = np.concatenate(lines)
    for j in range(i - 1, -1, -1):  # back to the latest frame with contact (a loop over frames)
        earlier = traj.centerlines(j)
        mask = np.concatenate(knot_mask(earlier, radius, closed, tol=tol))
        if not mask.any():
            continue
        box = _box(np.concatenate(earlier)[mask], _margin(np.asarray(radius, dtype=np.float64), margin))
        inside = np.all((x >= box[:, 0]) & (x <= box[:, 1]), axis=1)
        rope = np.repeat(np.arange(len(lines)), [len(c) for c in lines])
        was_there = np.unique(np.repeat(np.arange(len(earlier)), [len(c) for c in earlier])[mask])
        if np.isin(was_there, rope[inside]).all():  # every rope of the knot still passes through it
            return KnotRegion(box, "earlier", j)
        break
    return here
