"""Tube surface meshes around rod centerlines (the geometry both rendering backends draw).

The tube around a centerline is built on a rotation-minimising frame (double-reflection method);
for a closed rod the frame's holonomy is spread evenly along the loop, so rings have no seam.
Open rods get flat end caps. Centerlines are first refined with a Catmull-Rom spline through the
nodes (``subdivisions`` points per segment) so that coarse rods still look round.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from knotsim.errors import ConfigError

__all__ = ["TubeMesh", "tube_mesh", "unit"]


def _subdivide(points: np.ndarray, closed: bool, n_sub: int, values: np.ndarray | None):
    """Catmull-Rom refinement: ``n_sub`` points per segment (the nodes are kept).

    ``values`` (``(N,)`` scalars at the nodes, or None) are interpolated linearly.
    """
    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    if n_sub <= 1 or n < 2:
        return p.copy(), (None if values is None else np.asarray(values, dtype=np.float64).copy())
    if closed:
        ext = np.concatenate([p[-1:], p, p[:2]])
        n_seg = n
    else:
        ext = np.concatenate([2 * p[:1] - p[1:2], p, 2 * p[-1:] - p[-2:-1]])
        n_seg = n - 1
    s = np.arange(n_sub) / n_sub  # (n_sub,)
    p0, p1, p2, p3 = (ext[i : i + n_seg][:, None, :] for i in range(4))
    s2, s3 = (s**2)[None, :, None], (s**3)[None, :, None]
    s1 = s[None, :, None]
    pts = 0.5 * (
        2 * p1 + (-p0 + p2) * s1 + (2 * p0 - 5 * p1 + 4 * p2 - p3) * s2 + (-p0 + 3 * p1 - 3 * p2 + p3) * s3
    ).reshape(-1, 3)
    vals = None
    if values is not None:
        v = np.asarray(values, dtype=np.float64).reshape(-1)
        v_next = np.roll(v, -1) if closed else v[1:]
        v_cur = v if closed else v[:-1]
        vals = (v_cur[:, None] * (1 - s[None, :]) + v_next[:, None] * s[None, :]).reshape(-1)
    if not closed:
        pts = np.concatenate([pts, p[-1:]])
        if vals is not None:
            vals = np.append(vals, v[-1])
    return pts, vals


def unit(v: np.ndarray) -> np.ndarray:
    """``v`` ``(..., 3)`` scaled to unit length along its last axis (zero vectors stay zero)."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def _node_tangents(p: np.ndarray, closed: bool) -> np.ndarray:
    e = unit((np.roll(p, -1, axis=0) - p) if closed else np.diff(p, axis=0))
    if closed:
        t = e + np.roll(e, 1, axis=0)
    else:
        t = np.empty_like(p)
        t[0], t[-1] = e[0], e[-1]
        t[1:-1] = e[:-1] + e[1:]
    bad = np.linalg.norm(t, axis=1) < 1e-12  # hairpin: fall back to the outgoing edge
    if np.any(bad):
        t[bad] = (e if closed else np.vstack([e, e[-1:]]))[bad]
    return unit(t)


def _rotation_minimizing_frame(p: np.ndarray, t: np.ndarray, closed: bool) -> np.ndarray:
    """``(M, 3)`` unit normals ``n_i`` perpendicular to ``t_i``, transported with minimal rotation.

    Double-reflection method (Wang, Juettler, Zheng & Liu 2008). For closed curves the angle
    mismatch after one loop is removed by a rotation growing linearly with arc length.
    """
    m = p.shape[0]
    a = np.array([1.0, 0.0, 0.0]) if abs(t[0, 0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    r = np.empty_like(p)
    r[0] = unit(a - np.dot(a, t[0]) * t[0])
    n_steps = m if closed else m - 1

    def step(ri, xi, xj, ti, tj):
        v1 = xj - xi
        c1 = v1 @ v1
        if c1 < 1e-300:
            return ri
        rl = ri - (2.0 / c1) * (v1 @ ri) * v1
        tl = ti - (2.0 / c1) * (v1 @ ti) * v1
        v2 = tj - tl
        c2 = v2 @ v2
        rj = rl if c2 < 1e-300 else rl - (2.0 / c2) * (v2 @ rl) * v2
        rj = rj - (rj @ tj) * tj
        return rj / max(np.linalg.norm(rj), 1e-300)

    for i in range(min(n_steps, m - 1)):
        r[i + 1] = step(r[i], p[i], p[i + 1], t[i], t[i + 1])
    if closed and m > 2:
        r_end = step(r[m - 1], p[m - 1], p[0], t[m - 1], t[0])
        b0 = np.cross(t[0], r[0])
        phi = np.arctan2(r_end @ b0, r_end @ r[0])  # angle of r_end from r[0] about t[0]
        seg = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
        s = np.concatenate([[0.0], np.cumsum(seg[:-1])]) / max(seg.sum(), 1e-300)
        ang = -phi * s
        b = np.cross(t, r)
        r = np.cos(ang)[:, None] * r + np.sin(ang)[:, None] * b
    return r


@dataclass
class TubeMesh:
    """Surface of one or more tubes.

    Attributes
    ----------
    vertices:
        ``(V, 3)`` positions (m).
    normals:
        ``(V, 3)`` outward unit normals at the vertices.
    quads:
        ``(Q, 4)`` vertex indices of the side quads (counter-clockwise seen from outside).
    quad_normals:
        ``(Q, 3)`` outward unit normal of each quad.
    tris:
        ``(C, 3)`` vertex indices of end-cap triangles.
    vertex_rod, quad_rod, tri_rod:
        Rod index of each vertex / quad / triangle.
    vertex_values, quad_values, tri_values:
        Scalar per vertex / quad / triangle, or None when no scalars were given.
    """

    vertices: np.ndarray
    normals: np.ndarray
    quads: np.ndarray
    quad_normals: np.ndarray
    tris: np.ndarray
    vertex_rod: np.ndarray
    quad_rod: np.ndarray
    tri_rod: np.ndarray
    vertex_values: np.ndarray | None = None
    quad_values: np.ndarray | None = None
    tri_values: np.ndarray | None = None


def tube_mesh(centerlines: Sequence[np.ndarray], radii: Sequence[float], closed: Sequence[bool],
              scalars: Sequence[np.ndarray] | None = None, subdivisions: int = 3, n_sides: int = 12) -> TubeMesh:
    """Build the tube surfaces around centerlines.

    Parameters
    ----------
    centerlines:
        One ``(N_k, 3)`` array of node positions (m) per rod.
    radii:
        Tube radius (m) of each rod.
    closed:
        Whether each rod is a ring.
    scalars:
        Optional ``(N_k,)`` node values per rod, interpolated onto the surface.
    subdivisions:
        Spline points per centerline segment (1: use the nodes only).
    n_sides:
        Vertices per ring around the tube.
    """
    n_sides = int(n_sides)
    if n_sides < 3:
        raise ConfigError("n_sides", f"must be >= 3, got {n_sides}")
    ang = 2 * np.pi * np.arange(n_sides) / n_sides
    cos_a, sin_a = np.cos(ang), np.sin(ang)
    V, N, Q, QN, T, VR, QR, TR, VV, QV, TV = ([] for _ in range(11))
    offset = 0
    for k, (line, radius, is_closed) in enumerate(zip(centerlines, radii, closed, strict=True)):
        vals_in = None if scalars is None else np.asarray(scalars[k], dtype=np.float64).reshape(-1)
        p, vals = _subdivide(line, bool(is_closed), int(subdivisions), vals_in)
        m = p.shape[0]
        t = _node_tangents(p, bool(is_closed))
        nrm = _rotation_minimizing_frame(p, t, bool(is_closed))
        bin_ = np.cross(t, nrm)
        radial = cos_a[None, :, None] * nrm[:, None, :] + sin_a[None, :, None] * bin_[:, None, :]  # (m,S,3)
        ring = p[:, None, :] + float(radius) * radial
        V.append(ring.reshape(-1, 3))
        N.append(radial.reshape(-1, 3))
        VR.append(np.full(m * n_sides, k))
        if vals is not None:
            VV.append(np.repeat(vals, n_sides))
        n_seg = m if is_closed else m - 1
        i = np.arange(n_seg)[:, None]
        j = np.arange(n_sides)[None, :]
        i1, j1 = (i + 1) % m, (j + 1) % n_sides
        quads = np.stack(
            [i * n_sides + j, i * n_sides + j1, i1 * n_sides + j1, i1 * n_sides + j], axis=-1
        ).reshape(-1, 4)
        radial_flat = radial.reshape(-1, 3)
        Q.append(quads + offset)
        QN.append(unit(radial_flat[quads].sum(axis=1)))
        QR.append(np.full(quads.shape[0], k))
        if vals is not None:
            QV.append(0.5 * (vals[:n_seg, None] + vals[(np.arange(n_seg) + 1) % m, None]).repeat(n_sides))
        offset += m * n_sides
        if not is_closed:  # flat end caps: centre + duplicated ring with axial normals
            for end, sign in ((0, -1.0), (m - 1, 1.0)):
                cap = np.vstack([p[end][None], ring[end]])
                V.append(cap)
                N.append(np.repeat(sign * t[end][None], n_sides + 1, axis=0))
                VR.append(np.full(n_sides + 1, k))
                jj = np.arange(n_sides)
                a_, b_ = 1 + jj, 1 + (jj + 1) % n_sides
                tri = np.stack(
                    [np.zeros_like(jj), a_, b_] if sign > 0 else [np.zeros_like(jj), b_, a_], axis=-1
                )
                T.append(tri + offset)
                TR.append(np.full(n_sides, k))
                if vals is not None:
                    VV.append(np.full(n_sides + 1, vals[end]))
                    TV.append(np.full(n_sides, vals[end]))
                offset += n_sides + 1
    has_vals = scalars is not None

    def cat(lst, shape, dtype=np.float64):
        return np.concatenate(lst) if lst else np.empty(shape, dtype=dtype)

    return TubeMesh(
        vertices=cat(V, (0, 3)),
        normals=cat(N, (0, 3)),
        quads=cat(Q, (0, 4), np.int64).astype(np.int64),
        quad_normals=cat(QN, (0, 3)),
        tris=cat(T, (0, 3), np.int64).astype(np.int64),
        vertex_rod=cat(VR, (0,), np.int64).astype(np.int64),
        quad_rod=cat(QR, (0,), np.int64).astype(np.int64),
        tri_rod=cat(TR, (0,), np.int64).astype(np.int64),
        vertex_values=cat(VV, (0,)) if has_vals else None,
        quad_values=cat(QV, (0,)) if has_vals else None,
        tri_values=cat(TV, (0,)) if has_vals else None,
    )
