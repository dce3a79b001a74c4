"""Closure of open ropes far away from the tangle (knot theory only speaks about closed curves).

Every free end ``p`` is joined by a straight segment to a point on a large sphere around the tangle
(radially from the centroid of all nodes, ``method="radial"``, or along the end tangent,
``method="tangent"``), and the two far points of a pair of ends are joined by a great-circle arc
sampled on that sphere; every closure arc gets its own sphere radius, so arcs never meet each other.
A two-rope bend whose standing ends are known is closed into one curve by :func:`close_bend`
(standing ends joined over the knot, tails under it). See the package docstring of :mod:`knotsim.knots.topology`.
"""

from __future__ import annotations

import math
from enum import StrEnum

import numpy as np

from knotsim.knots.topology.curves import TopologyError, _as_closed_flags, _as_curve_list, _dedupe

End = tuple[int, int]  # (rope index, 0 = first node | 1 = last node)


class ClosureMethod(StrEnum):
    """How an open rope's end goes out to the far sphere (:func:`close_curves` ``method=``,
    :func:`~knotsim.knots.topology.analyze` ``closure=``)."""

    RADIAL = "radial"    #: along the ray from the centroid of all nodes through the end
    TANGENT = "tangent"  #: straight on along the end tangent


def bend_pairing(
    rope_a: int = 0, rope_b: int = 1, pull_end_a: int = 1, pull_end_b: int = 1
) -> list[tuple[End, End]]:
    """Closure pairing of a bend: standing (pulled) ends joined together, tails joined together.

    Two ropes tied together by a bend (reef, thief, grief, ...) form one knot in the sense of knot
    theory once the two standing parts are connected to each other far away and the two tails are
    connected to each other: a reef bend becomes the square knot ``3_1 # 3_1*``, a granny bend the
    granny knot ``3_1 # 3_1``.

    Parameters
    ----------
    rope_a, rope_b:
        Indices of the two ropes in the ``curves`` list.
    pull_end_a, pull_end_b:
        Which end of each rope is the standing / pulled end: 0 = first node, 1 = last node.  The
        other end is the tail.

    Returns
    -------
    list of two pairs ``((rope, end), (rope, end))`` usable as ``pairing=`` in :func:`close_curves`
    and :func:`analyze`.
    """
    for name, e in (("pull_end_a", pull_end_a), ("pull_end_b", pull_end_b)):
        if e not in (0, 1):
            raise TopologyError(f"{name}: must be 0 (first node) or 1 (last node), got {e!r}")
    if rope_a == rope_b:
        raise TopologyError("bend_pairing: rope_a and rope_b must be different ropes")
    return [
        ((rope_a, pull_end_a), (rope_b, pull_end_b)),
        ((rope_a, 1 - pull_end_a), (rope_b, 1 - pull_end_b)),
    ]


def _check_pairing(pairing, flags: list[bool]) -> dict[End, End]:
    open_ropes = [k for k, f in enumerate(flags) if not f]
    if pairing is None:
        pairing = [((k, 1), (k, 0)) for k in open_ropes]
    partner: dict[End, End] = {}
    for pair in pairing:
        try:
            (ra, ea), (rb, eb) = pair
            ra, ea, rb, eb = int(ra), int(ea), int(rb), int(eb)
        except (TypeError, ValueError):
            raise TopologyError(
                f"pairing: each item must be ((rope, end), (rope, end)), got {pair!r}"
            ) from None
        for r, e in ((ra, ea), (rb, eb)):
            if not 0 <= r < len(flags):
                raise TopologyError(f"pairing: rope index {r} out of range (there are {len(flags)} ropes)")
            if flags[r]:
                raise TopologyError(f"pairing: rope {r} is closed, only ends of open ropes can be paired")
            if e not in (0, 1):
                raise TopologyError(f"pairing: end must be 0 (first node) or 1 (last node), got {e}")
        a, b = (ra, ea), (rb, eb)
        if a == b:
            raise TopologyError(f"pairing: end {a} is paired with itself")
        for x in (a, b):
            if x in partner:
                raise TopologyError(f"pairing: end {x} appears more than once")
        partner[a] = b
        partner[b] = a
    missing = [(k, e) for k in open_ropes for e in (0, 1) if (k, e) not in partner]
    if missing:
        raise TopologyError(
            f"pairing: open-rope ends {missing} are not paired; every end must be paired once"
        )
    return partner


def _great_arc(ua: np.ndarray, ub: np.ndarray, step: float) -> np.ndarray:
    """Unit vectors strictly between ``ua`` and ``ub`` along the shorter great circle, spaced <= step rad."""
    cosang = float(np.clip(ua @ ub, -1.0, 1.0))
    ang = math.acos(cosang)
    if ang < 1e-12:
        return np.zeros((0, 3))
    w = ub - cosang * ua
    nw = np.linalg.norm(w)
    if nw < 1e-9:  # antipodal: any perpendicular direction
        trial = np.array([1.0, 0.0, 0.0]) if abs(ua[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        w = trial - (trial @ ua) * ua
        nw = np.linalg.norm(w)
    w /= nw
    m = max(1, math.ceil(ang / step))
    th = ang * np.arange(1, m) / m
    return np.cos(th)[:, None] * ua[None, :] + np.sin(th)[:, None] * w[None, :]


def _close(curves, closed, pairing, method: str, radius_factor: float, arc_step_deg: float = 10.0,
           tangent_points: int = 3) -> tuple[list[np.ndarray], list[list[int]]]:
    """:func:`close_curves` (arguments there), also returning the rope indices of each component."""
    ropes = _as_curve_list(curves)
    flags = _as_closed_flags(closed, len(ropes))
    try:
        method = ClosureMethod(method)
    except ValueError:
        raise TopologyError(f"method: must be 'radial' or 'tangent', got {method!r}") from None
    if not radius_factor > 2.0:
        raise TopologyError(
            f"radius_factor: must be > 2 (far sphere outside the tangle), got {radius_factor}"
        )
    allp = np.concatenate(ropes)
    c = allp.mean(axis=0)
    R = float(np.max(np.linalg.norm(allp - c, axis=1)))
    if not R > 0.0:
        raise TopologyError("curves: all points coincide, nothing to analyse")
    tol = 1e-12 * R
    ropes = [_dedupe(r, f, tol) for r, f in zip(ropes, flags, strict=True)]
    for k, (r, f) in enumerate(zip(ropes, flags, strict=True)):
        need = 3 if f else 2
        if len(r) < need:
            raise TopologyError(
                f"curves[{k}]: a {'closed' if f else 'open'} rope needs at least {need} distinct points, got {len(r)}"
            )
    partner = _check_pairing(pairing, flags)
    step = math.radians(arc_step_deg)
    if not 0.0 < step < math.pi:
        raise TopologyError(f"arc_step_deg: must be in (0, 180), got {arc_step_deg}")

    def end_point(e: End) -> np.ndarray:
        r = ropes[e[0]]
        return r[0] if e[1] == 0 else r[-1]

    def far_dir(e: End, radius: float) -> np.ndarray:
        r = ropes[e[0]]
        p = end_point(e)
        if method == "tangent":
            m = min(tangent_points, len(r) - 1)
            t = (r[0] - r[m]) if e[1] == 0 else (r[-1] - r[-1 - m])
            nt = np.linalg.norm(t)
            if nt > tol:
                t = t / nt
                # p + s t on the sphere |x - c| = radius, s > 0
                q = p - c
                b = q @ t
                s = -b + math.sqrt(max(b * b - (q @ q - radius * radius), 0.0))
                v = q + s * t
                return v / np.linalg.norm(v)
        v = p - c
        nv = np.linalg.norm(v)
        if nv <= 1e-9 * R:
            raise TopologyError(
                f"closure: end {e} sits at the centroid of the tangle, the radial closure is undefined; "
                "use method='tangent'"
            )
        return v / nv

    n_paths = 0

    def closure_path(e_from: End, e_to: End) -> np.ndarray:
        nonlocal n_paths
        radius = radius_factor * R * (1.0 + 0.125 * n_paths)
        n_paths += 1
        ua, ub = far_dir(e_from, radius), far_dir(e_to, radius)
        mid = _great_arc(ua, ub, step)
        dirs = np.concatenate([ua[None, :], mid, ub[None, :]])
        return c + radius * dirs

    comps: list[np.ndarray] = []
    comp_ropes: list[list[int]] = []
    used = [False] * len(ropes)
    for k in range(len(ropes)):
        if used[k]:
            continue
        used[k] = True
        if flags[k]:
            comps.append(ropes[k])
            comp_ropes.append([k])
            continue
        pieces = [ropes[k]]
        members = [k]
        cur_exit: End = (k, 1)
        while True:
            nxt = partner[cur_exit]
            pieces.append(closure_path(cur_exit, nxt))
            if nxt == (k, 0):
                break
            j = nxt[0]
            used[j] = True
            members.append(j)
            pieces.append(ropes[j] if nxt[1] == 0 else ropes[j][::-1])
            cur_exit = (j, 1 - nxt[1])
        comps.append(_dedupe(np.concatenate(pieces), True, tol))
        comp_ropes.append(members)
    return comps, comp_ropes


def close_curves(curves, closed=None, *, pairing=None, method: ClosureMethod | str = "radial",
                 radius_factor: float = 20.0, arc_step_deg: float = 10.0) -> list[np.ndarray]:
    """Close open ropes far away from the tangle.

    Parameters
    ----------
    curves:
        List of ``(N_k, 3)`` arrays (m), one per rope (a single ``(N, 3)`` array is one rope).
    closed:
        One bool per rope (or one bool for all); ``None`` means all ropes are open.  A closed rope's
        last node connects to its first (do not repeat the first node; a repeated one is dropped).
    pairing:
        Which ends to join: a list of ``((rope, end), (rope, end))`` with ``end`` 0 for the first
        node and 1 for the last; every end of every open rope must appear exactly once.  ``None``
        joins the two ends of each open rope.  See :func:`bend_pairing` for two ropes tied together.
    method:
        A :class:`ClosureMethod` or its string. ``"radial"``: each end goes straight out to the far sphere along the ray from the centroid of
        all nodes through the end.  ``"tangent"``: each end goes straight on along its end tangent
        (averaged over the last 3 edges) until the far sphere.
    radius_factor:
        Far-sphere radius in units of the tangle radius (max distance of a node from the centroid).
    arc_step_deg:
        Angular spacing (degrees) of the nodes on the far arcs.

    Returns
    -------
    list of ``(M, 3)`` arrays (m): the closed components (implicitly closed: last node to first),
    ordered by their lowest rope index.  A component made of several ropes starts with the rope of
    lowest index, in its own direction.
    """
    comps, _ = _close(curves, closed, pairing, method, radius_factor, arc_step_deg)
    return comps


def _core(x: np.ndarray, others: np.ndarray, cutoff: float, pad: int) -> slice:
    """Node range of ``x`` from its first to its last node within ``cutoff`` of ``others``
    (padded by ``pad`` nodes); the whole rope when none is."""
    from scipy.spatial import cKDTree

    idx = np.flatnonzero(cKDTree(others).query(x, distance_upper_bound=cutoff)[0] < np.inf)
    if idx.size == 0:
        return slice(0, len(x))
    return slice(max(0, int(idx[0]) - pad), min(len(x), int(idx[-1]) + 1 + pad))


def close_bend(ropes: list[np.ndarray], axis: np.ndarray, standing_a: tuple[int, int],
               standing_b: tuple[int, int], core_cutoff: float | None = None, pad: int = 3) -> np.ndarray:
    """Close a two-rope bend into one closed polygon (m) for knot identification.

    Knot theory joins the two standing ends together and the two tails together (see
    :func:`knotsim.knots.topology.bend_pairing`). Here the joins are explicit and far from the
    knot: from each end a straight run outwards along ``-axis`` (ends of rope A's side) or
    ``+axis`` (rope B's side) to ``D`` (ten times the size of the tangle), then the standing ends
    are joined at height ``+D`` and the tails at ``-D`` along the normal of the plane of the axis
    and the knot, so one join passes over everything and the other under everything and the two
    joins are unlinked. (The radial closure of :func:`~knotsim.knots.topology.close_curves` finds
    no generic projection for the thief and grief bends, whose standing and tail ends lie on
    opposite corners.) For the reef and granny bends, whose standing ends and tails leave on the
    same sides, this is the planar closure; for the thief and grief bends, whose standing ends and
    tails are interleaved around the knot, one join must cross the other and the knot type is a
    convention (standing join over, tails join under); it is the same at the start and the end.

    Parameters
    ----------
    ropes:
        The two ropes' ``(N, 3)`` node positions.
    axis:
        Unit pull axis, from rope A's standing end towards rope B's standing end.
    standing_a, standing_b:
        ``(rope index, end)`` of the standing ends (end 0 = first node, 1 = last node).
    core_cutoff:
        When given (m), each rope is first cut down to its part between its first and last node
        within ``core_cutoff`` of the other rope (plus ``pad`` nodes), so that loose tails and
        standing parts that flop across each other away from the knot do not change the closure.
    """
    ra, ea = standing_a
    rb, eb = standing_b
    ya, yb = ropes[ra], ropes[rb]
    if core_cutoff is not None:
        ya, yb = ya[_core(ya, yb, core_cutoff, pad)], yb[_core(yb, ya, core_cutoff, pad)]
    a = ya if ea == 1 else ya[::-1]      # tail of A ... standing end of A
    b = yb if eb == 0 else yb[::-1]      # standing end of B ... tail of B
    allp = np.concatenate(ropes)
    c = allp.mean(axis=0)
    size = float(np.max(np.linalg.norm(allp - c, axis=1)))
    D = 10.0 * max(size, 1e-6)
    # normal of the knot plane: the direction of least spread orthogonal to the axis
    rel = allp - c
    rel = rel - np.outer(rel @ axis, axis)
    w, v = np.linalg.eigh(rel.T @ rel)
    nrm = np.cross(axis, v[:, -1])  # v[:, -1]: the in-plane direction of largest spread across the axis
    if np.linalg.norm(nrm) < 1e-9:
        nrm = np.cross(axis, [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0])
    # the sign of an eigenvector is arbitrary: orient the normal consistently (towards +z, else +y, +x),
    # otherwise the over/under joins could swap between the start and the end of a run
    for ref in (2, 1, 0):
        if abs(nrm[ref]) > 1e-3 * np.linalg.norm(nrm):
            nrm = nrm if nrm[ref] > 0 else -nrm
            break
    nrm /= np.linalg.norm(nrm)

    def out(p, sign, dist):
        along = float(np.dot(p - c, axis))
        return p + (sign * dist - along) * axis

    sa, sb, ta, tb = a[-1], b[0], a[0], b[-1]
    s_out_a, s_out_b = out(sa, -1, D), out(sb, +1, D)
    t_out_a, t_out_b = out(ta, -1, 1.1 * D), out(tb, +1, 1.1 * D)
    standing = [s_out_a, s_out_a + D * nrm, s_out_b + D * nrm, s_out_b]
    tails = [t_out_b, t_out_b - D * nrm, t_out_a - D * nrm, t_out_a]
    return np.concatenate([a, np.array(standing), b, np.array(tails)])
