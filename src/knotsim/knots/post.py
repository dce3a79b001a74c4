"""Knots tied round a rigid post: the post of a drawing, and drawings made on the post's surface.

A drawing's ``[post]`` table (:class:`~knotsim.knots.spec.PostSpec`) declares a rigid cylinder the
ropes are tied round. Two ways to draw with it:

* ``drawn_on = "plane"``: an ordinary planar drawing with the post through it along ``z`` at
  ``center`` (drawing units): a pin through a loop's eye. The builder checks that every node keeps
  the contact distance ``R + h`` from the pin's axis (:func:`plane_post`).
* ``drawn_on = "surface"`` (a hitch): each rope is drawn on the post's surface as points
  ``(turns, along, height)``: the angle round the post in turns (unwrapped, so two full turns run
  from 0 to 2), the position along the axis and the height above the surface in rope diameters
  ``d = 2h``. The over/under letters are those of the surface seen from outside, walking the rope:
  ``O`` = this strand is the one farther from the axis. :func:`build_on_post` turns it into 3D
  (post axis along ``z`` through the origin):

  1. the points are put on the cylinder of radius ``R_c = R + h (1 + margin)`` (the centre line of a
     rope lying on the post, with the clearance margin), raised by their height, and smoothed by a
     centripetal cubic spline in the unrolled surface (arc round the post, along, height);
  2. the ends leave the last drawn points straight along their tangents (the standing part and the
     tail hanging off the post), the rope's remaining length shared between them by ``split``;
  3. the crossings are found on the surface, where they are: the curves are projected on the post
     (angle, position along it), and the post's surface is mapped one-to-one onto an annulus
     (angle, radius growing with the position along the axis), so crossings of strands a whole turn
     apart are found like any other, and matched with the letters;
  4. at each crossing the over strand is lifted away from the post by ``lift * d (1 + margin)`` with a
     smooth compact bump (the under strand stays on the post);
  5. resampled to ``n_nodes`` equal edges and relaxed (close pairs pushed apart, nodes kept outside
     ``R + h (1 + margin / 2)``);
  6. checked: rope pairs at least ``2h`` apart, every node at least ``h`` off the post, and the
     crossing diagram on the surface the declared one.

Lengths in metres; node arrays ``(N, 3)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from knotsim.errors import ConfigError, GeometryError
from knotsim.knots.clearance import ClosestPair, RopeEdges, closest_edge_pair, same_rope_min_gap
from knotsim.knots.crossings import PlanarCrossing
from knotsim.knots.diagram import check_diagram, crossing_lifts, match_letters
from knotsim.knots.polyline import (
    _arc,
    _fix_edge_lengths,
    _interp_at,
    _resample_polyline,
    _smooth_planar,
)
from knotsim.knots.relax import _relax
from knotsim.knots.spec import KnotSpec, PostSpec

__all__ = ["Post", "build_on_post", "plane_post", "surface_projection"]

#: Default post length in rope diameters (at least the knot's extent along the axis plus this much).
POST_LENGTH_DIAMETERS = 40.0


@dataclass(frozen=True)
class Post:
    """A built post: a capsule of radius ``radius`` (m) round the segment of length ``length`` (m)
    centred on ``center`` ``(3,)`` (m) along the unit ``axis`` ``(3,)``; ``spin_inertia`` (kg m^2)
    ``None`` for a fixed post, else free to spin about its axis."""

    center: np.ndarray
    axis: np.ndarray
    radius: float
    length: float
    spin_inertia: float | None = None

    @property
    def ends(self) -> tuple[np.ndarray, np.ndarray]:
        """The two end points ``(3,)`` of the post's axis segment (m)."""
        half = 0.5 * self.length * self.axis
        return self.center - half, self.center + half

    def axis_distance(self, x: np.ndarray) -> np.ndarray:
        """Distance (m) of points ``x`` ``(K, 3)`` from the post's axis line, ``(K,)``."""
        rel = np.asarray(x, float) - self.center
        return np.linalg.norm(rel - np.outer(rel @ self.axis, self.axis), axis=1)

    def obstacle_table(self, name: str = "post", **options: Any) -> dict[str, Any]:
        """The run-file ``[[obstacles]]`` table of this post (a capsule; ``options``: ``mu``,
        ``friction_model``, ``stick_distance``, ... as in ``docs/run-files.md``)."""
        a, b = self.ends
        table: dict[str, Any] = {"type": "capsule", "name": name, "a": a.tolist(), "b": b.tolist(),
                                 "radius": float(self.radius)}
        if self.spin_inertia is not None:
            table["spin_inertia"] = float(self.spin_inertia)
        table.update({k: v for k, v in options.items() if v is not None})
        return table


def _post_length(spec: PostSpec, extent: float, d: float) -> float:
    return spec.length if spec.length is not None else max(POST_LENGTH_DIAMETERS * d, extent + 20.0 * d)


def _check_off_post(post: Post, ropes, h: float, where: str, names) -> None:
    for name, r in zip(names, ropes, strict=True):
        gap = post.axis_distance(r) - post.radius - h
        k = int(np.argmin(gap))
        if gap[k] < 0:
            raise GeometryError(f"{where}: node {k} of rope {name!r} is {-gap[k] * 1e3:.3g} mm inside the contact "
                                f"distance of the post (R = {post.radius * 1e3:.3g} mm, h = {h * 1e3:.3g} mm); "
                                f"draw the rope farther from the post")


def plane_post(spec: PostSpec, scale: float, ropes, radius: float, where: str,
               names: tuple[str, ...] | None = None) -> Post:
    """The post of a planar drawing (along ``z`` through ``spec.center`` scaled by ``scale`` m per
    drawing unit), checked: every node at least ``R + h`` from its axis (``GeometryError`` naming
    the node otherwise)."""
    assert spec.center is not None
    zs = np.concatenate([r[:, 2] for r in ropes])
    c = np.array([spec.center[0] * scale, spec.center[1] * scale, 0.5 * (zs.min() + zs.max())])
    post = Post(center=c, axis=np.array([0.0, 0.0, 1.0]), radius=spec.radius,
                length=_post_length(spec, float(np.ptp(zs)), 2.0 * radius), spin_inertia=spec.spin_inertia)
    _check_off_post(post, ropes, radius, where, names or tuple(f"rope {i}" for i in range(len(ropes))))
    return post


def surface_projection(ropes, surface_radius: float, z0: float) -> list[np.ndarray]:
    """Each rope ``(N, 3)`` (post axis along ``z`` through the origin) projected on the post's surface
    and mapped onto an annulus: ``(rho cos theta, rho sin theta, r)`` with ``theta`` the angle round the
    axis, ``rho = 1 + (z - z0) / surface_radius`` (``z0`` at most the lowest ``z``) and ``r`` the distance
    from the axis. The map is one-to-one on the surface, so the ``xy`` crossings of the result are the
    crossings on the surface and ``z`` says which strand is outside."""
    out = []
    for x in ropes:
        x = np.asarray(x, float)
        theta = np.arctan2(x[:, 1], x[:, 0])
        rho = 1.0 + (x[:, 2] - z0) / surface_radius
        out.append(np.column_stack([rho * np.cos(theta), rho * np.sin(theta), np.hypot(x[:, 0], x[:, 1])]))
    return out


def _to_xyz(unrolled: np.ndarray, surface_radius: float) -> np.ndarray:
    """Unrolled surface points ``(arc round the post, along, height)`` (m) to 3D (axis along z)."""
    theta = unrolled[:, 0] / surface_radius
    r = surface_radius + unrolled[:, 2]
    return np.column_stack([r * np.cos(theta), r * np.sin(theta), unrolled[:, 1]])


def _leads(dense: np.ndarray, length: float, split: float, ds: float) -> np.ndarray:
    """The drawn curve ``(K, 3)`` with its ends continued straight off the post to the rope's
    ``length``: along the end tangents made perpendicular to the axis (so a lead stays at its
    position along the post), the missing length shared ``split`` : ``1 - split`` between start and end."""
    missing = length - float(_arc(dense)[-1])
    out = [dense]
    for end, share in ((0, split), (-1, 1.0 - split)):
        inner = dense[1] if end == 0 else dense[-2]
        t = dense[end] - inner
        t[2] = 0.0
        t /= np.linalg.norm(t)
        ext = share * missing
        if ext <= 0:
            continue
        n = max(2, int(math.ceil(ext / ds)) + 1)
        steps = np.linspace(0.0, ext, n)[1:, None] * t
        tail = dense[end] + steps
        out = [tail[::-1], *out] if end == 0 else [*out, tail]
    return np.concatenate(out)


def build_on_post(spec: KnotSpec, n_nodes: int, radius: float, length: float, *, margin: float = 0.1,
                  lift: float = 1.15, max_iter: int = 3000
                  ) -> tuple[tuple[np.ndarray, ...], ClosestPair, list[PlanarCrossing], int, Post]:
    """Build a drawing made on a post's surface (see the module docstring).

    Returns ``(ropes, closest pair, crossings on the surface, same-rope gap, post)``; ``ConfigError``
    for a drawing longer than the rope or whose crossings do not match its letters, ``GeometryError``
    when the relaxed geometry overlaps, touches the post or lost the declared diagram."""
    ps = spec.post
    assert ps is not None and ps.drawn_on == "surface"
    h, d = radius, 2.0 * radius
    R = ps.radius
    rc = R + h * (1.0 + margin)
    seg = length / (n_nodes - 1)
    names = tuple(r.name for r in spec.ropes)
    where = f"knot {spec.name!r} (N={n_nodes}, h={radius * 1e3:.3g} mm, R={R * 1e3:.3g} mm, L={length:g} m)"
    dense_ds = min(seg / 4.0, length / 2000.0, d / 4.0)

    # 1-2. on the cylinder, smoothed; the ends leave straight along their tangents
    curves = []
    for k, r in enumerate(spec.ropes):
        wp = r.waypoints
        unrolled = np.column_stack([2.0 * math.pi * rc * wp[:, 0], d * wp[:, 1], d * wp[:, 2]])
        extent = float(np.ptp(unrolled, axis=0).max())
        dense = _resample_polyline(_to_xyz(_smooth_planar(unrolled, extent / 4000.0), rc), dense_ds)
        drawn = float(_arc(dense)[-1])
        if drawn > length:
            raise ConfigError(f"{spec.name}: ropes[{k}].waypoints",
                              f"the drawing of rope {r.name!r} round the post is {drawn:.3g} m long, more than the "
                              f"rope's length {length:g} m; give a longer rope or a smaller post")
        curves.append(_leads(dense, length, ps.split, dense_ds))

    # 3. crossings on the surface, matched with the letters
    z0 = min(float(c[:, 2].min()) for c in curves) - d
    arcs = [_arc(c) for c in curves]
    proj = surface_projection(curves, rc, z0)
    passages, visits = match_letters(spec, [p[:, :2] for p in proj], arcs, length)

    # 4. the over strands lifted off the post
    target = d * (1.0 + margin)
    lifts = crossing_lifts(spec, passages, arcs, lift * target, max(10.0 * d, 4.0 * seg), under=0.0)
    lifted = []
    for c, up in zip(curves, lifts, strict=True):
        rr = np.hypot(c[:, 0], c[:, 1])
        f = (rr + up) / rr
        lifted.append(np.column_stack([c[:, 0] * f, c[:, 1] * f, c[:, 2]]))

    # 5. resample, relax outside the post
    nodes = []
    for c in lifted:
        s = _arc(c)
        nodes.append(_interp_at(c, s, np.linspace(0.0, s[-1], n_nodes)))
    edges = RopeEdges([n_nodes] * len(nodes))
    keep = R + h * (1.0 + 0.5 * margin)

    def keep_out(x: np.ndarray) -> np.ndarray:
        rr = np.hypot(x[:, 0], x[:, 1])
        inside = rr < keep
        if inside.any():
            x = x.copy()
            x[inside, :2] *= (keep / np.maximum(rr[inside], 1e-12 * keep))[:, None]
        return x

    min_gap = same_rope_min_gap(seg, d)
    x = _relax(np.concatenate(nodes), edges, np.full(len(edges.i0), seg), target, d * (1.0 + 0.5 * margin),
               max_iter, min_gap, keep_out=keep_out)
    ropes = tuple(_fix_edge_lengths(x[edges.node_offset[r]:edges.node_offset[r + 1]], seg)
                  for r in range(len(nodes)))

    # 6. checks
    cp = closest_edge_pair(ropes, d, names, min_gap)
    if cp.distance < d:
        raise GeometryError(f"{where} still overlaps after relaxation: {cp.describe()}. Use more nodes, a thinner "
                            f"rod, or spread the drawing out")
    zs = np.concatenate([r[:, 2] for r in ropes])
    knot_z = np.concatenate([c[:, 2] for c in nodes])
    post = Post(center=np.array([0.0, 0.0, 0.5 * (float(knot_z.min()) + float(knot_z.max()))]),
                axis=np.array([0.0, 0.0, 1.0]), radius=R,
                length=_post_length(ps, float(np.ptp(zs)), d), spin_inertia=ps.spin_inertia)
    _check_off_post(post, ropes, h, where, names)
    xing = check_diagram(where, surface_projection(ropes, rc, min(z0, float(zs.min()) - d)), spec, visits, cp)
    return ropes, cp, xing, min_gap, post
