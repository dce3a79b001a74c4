"""Topology of knotted rods: closure, knot diagrams, linking numbers and knot invariants.

Input everywhere is a list of rope centrelines, each an ``(N_k, 3)`` float array of node positions
in metres, plus a flag per rope saying whether it is closed (a ring: the last node connects back to
the first) or open.  The pipeline is

1. **Closure** (:func:`close_curves`): knot theory only speaks about closed curves, so each open
   rope is closed far away from the tangle.  Every free end ``p`` is joined by a straight segment to
   a point on a large sphere around the tangle (radially from the centroid ``c`` of all nodes,
   ``method="radial"``, or along the end tangent, ``method="tangent"``), and the two far points of a
   pair of ends are joined by a great-circle arc sampled on that sphere.  The sphere radius is
   ``radius_factor`` times the radius of the tangle (default 20), and every closure arc gets its own
   sphere radius, so arcs never meet each other.  Seen along almost every direction the far arcs
   project outside the tangle and add no crossing with it.  Which ends are joined is given by
   ``pairing`` (default: the two ends of each open rope together).  For a *bend* (two ropes tied
   together) knot theory closes the two standing (pulled) ends together and the two tails together,
   which makes one closed curve: see :func:`bend_pairing`.  The closure of an open rope is a choice,
   not a fact: when an end finishes deep inside the tangle, different reasonable closures can give
   different knots.  Rods in knotsim normally have long tails that leave the knot, and then the
   closure is unambiguous.

2. **Projection** (:func:`project`): the closed polygons are projected along a direction ``d``
   (random but seeded; several are tried, degenerate ones are rejected and the one with the fewest
   crossings is kept).  The viewer sits at ``+infinity * d`` and looks along ``-d``; a strand is *over*
   when its height ``x . d`` is larger.  Crossings are found with a numba sweep over the projected
   segments (a few milliseconds for 3000 segments).

3. **Invariants**: writhe, linking numbers, the Alexander polynomial and knot determinant (Fox
   calculus on the Wirtinger presentation), and the Jones polynomial from the Kauffman bracket,
   evaluated on the diagram after Reidemeister I and II simplifications with a planar contraction
   algorithm (crossing after crossing, keeping one Laurent polynomial per planar matching of the
   open ends), which handles tens of crossings.

Conventions (chirality)
-----------------------
* **Crossing sign** (right-hand rule): with ``o`` and ``u`` the projected directions of the over and
  the under strand, the sign is ``sign((o x u) . d)``, ``d`` pointing at the viewer.  Equivalently:
  both strands pointing up the page, the crossing is positive when the over strand goes from lower
  left to upper right.  With this sign, ``writhe`` is the sum of the signs and the linking number is
  half the sum over crossings between two components; it agrees with the Gauss linking integral
  (:func:`gauss_linking_number`) and with the algebraic intersection of one component with a
  Seifert surface of the other (right-hand-rule normal).
* **Right-handed trefoil** = the trefoil whose minimal diagrams have three positive crossings
  (writhe +3).  Its Jones polynomial is ``V(t) = t + t^3 - t^4`` (the left-handed one has
  ``t -> 1/t``).  The Jones polynomial is ``V(t) = (-A^3)^(-w) <D>`` at ``A = t^(-1/4)``, with the
  Kauffman bracket ``<X> = A <A-smoothing> + A^-1 <B-smoothing>``, ``<O> = 1``.  The positive Hopf
  link (linking number +1) has ``V = -t^(1/2) - t^(5/2)``.
* For other chiral knots of the table, ``"_right"`` names the mirror image whose Jones polynomial
  has its exponents centred on a positive value (for 5_1, 5_2, 7_x these are the positive knots,
  all crossings positive in a minimal diagram), ``"_left"`` the other one.
* **Alexander polynomial** is returned symmetric and normalised (``Delta(t) = Delta(1/t)``,
  ``Delta(1) = 1``) as the coefficient list of ``t^-m, ..., t^m``: trefoil ``[1, -1, 1]``,
  figure-eight ``[-1, 3, -1]``.
* **PD code** follows the KnotTheory / SnapPy convention: each crossing is ``(i, j, k, l)``, edges
  listed counterclockwise (seen by the viewer) starting with the incoming under edge ``i``; ``k`` is
  the outgoing under edge.  The crossing is positive when the over strand runs ``l -> j``.  Edge labels
  are 0-based and increase along each component in its direction.
* **Gauss code**: one list per component of ``+(c+1)`` (passes over crossing ``c``) or ``-(c+1)``
  (passes under), in the order met along the component; the signs are in ``Diagram.signs``.

The knot table (:data:`KNOT_TABLE`) holds the prime knots up to seven crossings (both mirror images),
the torus knot 9_1 (the closure of the open overhand knot with n = 4, from the closed forms of
:func:`_torus_2q`) and the composites granny (``3_1#3_1``, both chiralities), reef (the square knot ``3_1#3_1*``,
amphichiral) and ``3_1#4_1``.  A knot is named when both its Alexander and Jones
polynomials match an entry; the names are a guess from these two invariants (a few knots with more
crossings share both polynomials with a table entry), ``"unknown"`` otherwise.  For a certified
identification use :func:`identify_with_spherogram` (needs the optional ``spherogram`` package).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
from numba import njit

from knotsim.errors import GeometryError

__all__ = [
    "KNOT_TABLE",
    "Diagram",
    "KnotEntry",
    "TopologyError",
    "TopologyResult",
    "alexander_polynomial",
    "analyze",
    "bend_pairing",
    "close_curves",
    "gauss_linking_number",
    "identify_knot",
    "identify_with_spherogram",
    "jones_polynomial",
    "kauffman_bracket",
    "knot_determinant",
    "project",
    "simplify_pd",
    "spherogram_link",
    "writhe_3d",
]


class TopologyError(GeometryError):
    """Curves whose topology cannot be computed (too few points, NaN, self-intersecting, ...)."""


# ----------------------------------------------------------------------------------------------
# input checks and closure
# ----------------------------------------------------------------------------------------------

End = tuple[int, int]  # (rope index, 0 = first node | 1 = last node)


def _as_curve_list(curves) -> list[np.ndarray]:
    if isinstance(curves, np.ndarray):
        if curves.ndim == 2:
            curves = [curves]
        elif curves.ndim != 3:
            raise TopologyError(
                f"curves: expected a list of (N, 3) arrays, got an array of shape {curves.shape}"
            )
    out = []
    for k, c in enumerate(curves):
        a = np.asarray(c, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != 3:
            raise TopologyError(f"curves[{k}]: expected shape (N, 3), got {a.shape}")
        if a.shape[0] < 2:
            raise TopologyError(f"curves[{k}]: a rope needs at least 2 points, got {a.shape[0]}")
        if not np.all(np.isfinite(a)):
            raise TopologyError(f"curves[{k}]: contains NaN or infinite coordinates")
        out.append(a)
    if not out:
        raise TopologyError("curves: empty list, give at least one (N, 3) centreline")
    return out


def _as_closed_flags(closed, n: int) -> list[bool]:
    if closed is None:
        return [False] * n
    if isinstance(closed, bool | np.bool_):
        return [bool(closed)] * n
    flags = [bool(f) for f in closed]
    if len(flags) != n:
        raise TopologyError(f"closed: expected {n} flags (one per rope), got {len(flags)}")
    return flags


def _dedupe(a: np.ndarray, closed: bool, tol: float) -> np.ndarray:
    """Remove consecutive duplicate nodes (and the repeated first node of a closed curve)."""
    keep = np.ones(len(a), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(a, axis=0), axis=1) > tol
    a = a[keep]
    if closed and len(a) > 1 and np.linalg.norm(a[-1] - a[0]) <= tol:
        a = a[:-1]
    return a


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


def _close(
    curves,
    closed=None,
    pairing=None,
    method: str = "radial",
    radius_factor: float = 20.0,
    arc_step_deg: float = 10.0,
    tangent_points: int = 3,
) -> tuple[list[np.ndarray], list[list[int]]]:
    ropes = _as_curve_list(curves)
    flags = _as_closed_flags(closed, len(ropes))
    if method not in ("radial", "tangent"):
        raise TopologyError(f"method: must be 'radial' or 'tangent', got {method!r}")
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


def close_curves(
    curves,
    closed=None,
    *,
    pairing=None,
    method: str = "radial",
    radius_factor: float = 20.0,
    arc_step_deg: float = 10.0,
) -> list[np.ndarray]:
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
        ``"radial"``: each end goes straight out to the far sphere along the ray from the centroid of
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


# ----------------------------------------------------------------------------------------------
# projection and crossings
# ----------------------------------------------------------------------------------------------

_DEGENERACY = {
    1: "a crossing lies at a polygon vertex",
    2: "a crossing is nearly tangent",
    3: "two projected segments overlap",
    4: "two strands nearly intersect in 3D",
    5: "a segment is parallel to the projection direction",
}


@njit(cache=True)
def _crossings_kernel(x, y, h, nxt, eps_param, eps_sin, eps_len, eps_h, cap):
    """All proper crossings between the projected segments ``i -> nxt[i]``.

    Returns ``(seg_a, s_a, seg_b, s_b, count, flag)``; ``count > cap`` means the buffers were too
    small; ``flag != 0`` flags a degeneracy (see ``_DEGENERACY``).
    """
    n = x.shape[0]
    xmin = np.empty(n)
    xmax = np.empty(n)
    ymin = np.empty(n)
    ymax = np.empty(n)
    flag = 0
    for i in range(n):
        j = nxt[i]
        xmin[i] = min(x[i], x[j])
        xmax[i] = max(x[i], x[j])
        ymin[i] = min(y[i], y[j])
        ymax[i] = max(y[i], y[j])
        if math.hypot(x[j] - x[i], y[j] - y[i]) <= eps_len:
            flag = 5
    order = np.argsort(xmin)
    seg_a = np.empty(cap, dtype=np.int64)
    seg_b = np.empty(cap, dtype=np.int64)
    s_a = np.empty(cap)
    s_b = np.empty(cap)
    count = 0
    if flag != 0:
        return seg_a, s_a, seg_b, s_b, count, flag
    for ia in range(n):
        a = order[ia]
        na = nxt[a]
        ax0 = x[a]
        ay0 = y[a]
        rx = x[na] - ax0
        ry = y[na] - ay0
        lr = math.hypot(rx, ry)
        for ib in range(ia + 1, n):
            b = order[ib]
            if xmin[b] > xmax[a]:
                break
            if ymin[b] > ymax[a] or ymax[b] < ymin[a]:
                continue
            nb = nxt[b]
            if nb == a or na == b:
                continue
            ux = x[nb] - x[b]
            uy = y[nb] - y[b]
            lu = math.hypot(ux, uy)
            qx = x[b] - ax0
            qy = y[b] - ay0
            den = rx * uy - ry * ux
            if abs(den) <= 1e-12 * lr * lu:
                if abs(qx * ry - qy * rx) / lr <= eps_len:
                    flag = 3
                continue
            s = (qx * uy - qy * ux) / den
            t = (qx * ry - qy * rx) / den
            if s < -eps_param or s > 1.0 + eps_param or t < -eps_param or t > 1.0 + eps_param:
                continue
            if s < eps_param or s > 1.0 - eps_param or t < eps_param or t > 1.0 - eps_param:
                flag = 1
                continue
            if abs(den) < eps_sin * lr * lu:
                flag = 2
            ha = h[a] + s * (h[na] - h[a])
            hb = h[b] + t * (h[nb] - h[b])
            if abs(ha - hb) <= eps_h:
                flag = 4
            if count < cap:
                seg_a[count] = a
                s_a[count] = s
                seg_b[count] = b
                s_b[count] = t
            count += 1
    return seg_a, s_a, seg_b, s_b, count, flag


def _basis(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    d = d / np.linalg.norm(d)
    a = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = a - (a @ d) * d
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    return e1, e2, d


@dataclass
class Diagram:
    """A knot/link diagram: the projection of closed polygons along ``direction``.

    Attributes
    ----------
    direction:
        ``(3,)`` unit vector pointing at the viewer.
    n_components:
        Number of closed components.
    signs:
        ``(n,)`` int array, crossing signs (+1 / -1, right-hand rule, see module docstring).
    over_component, under_component:
        ``(n,)`` int arrays, component of the over / under strand of each crossing.
    positions:
        ``(n, 3)`` float array (m), the point of the over strand at each crossing.
    events:
        Per component, the crossings met along it in order, as ``(crossing, is_over)`` pairs.
    """

    direction: np.ndarray
    n_components: int
    signs: np.ndarray
    over_component: np.ndarray
    under_component: np.ndarray
    positions: np.ndarray
    events: list[list[tuple[int, bool]]]

    @property
    def n_crossings(self) -> int:
        return int(len(self.signs))

    @property
    def writhe(self) -> int:
        """Sum of all crossing signs (including crossings between different components)."""
        return int(np.sum(self.signs))

    @property
    def gauss_code(self) -> list[list[int]]:
        """Per component: ``+(c+1)`` over crossing ``c``, ``-(c+1)`` under it, in order along the component."""
        return [[(c + 1) if o else -(c + 1) for c, o in ev] for ev in self.events]

    def component_writhe(self) -> np.ndarray:
        """``(n_components,)`` int: sum of signs of the self-crossings of each component."""
        w = np.zeros(self.n_components, dtype=np.int64)
        same = self.over_component == self.under_component
        np.add.at(w, self.over_component[same], self.signs[same])
        return w

    def linking_matrix(self) -> np.ndarray:
        """``(k, k)`` int array of pairwise linking numbers (diagonal 0)."""
        k = self.n_components
        L = np.zeros((k, k), dtype=np.int64)
        diff = self.over_component != self.under_component
        np.add.at(L, (self.over_component[diff], self.under_component[diff]), self.signs[diff])
        L = L + L.T
        if np.any(L % 2):
            raise TopologyError("linking_matrix: odd sum of inter-component crossing signs (corrupt diagram)")
        return L // 2

    def pd_code(
        self, components: Sequence[int] | None = None
    ) -> tuple[list[tuple[int, int, int, int]], np.ndarray, int]:
        """PD code of the diagram, or of the sub-diagram made of the given components.

        Returns ``(pd, signs, free_loops)``: ``pd`` is a list of ``(i, j, k, l)`` tuples (KnotTheory
        convention, module docstring), ``signs`` the ``(len(pd),)`` crossing signs and
        ``free_loops`` the number of components without any crossing (not representable in PD).
        """
        comps = set(range(self.n_components)) if components is None else {int(c) for c in components}
        keep = np.array(
            [
                (int(o) in comps and int(u) in comps)
                for o, u in zip(self.over_component, self.under_component, strict=True)
            ],
            dtype=bool,
        )
        out_edge: dict[tuple[int, bool], int] = {}
        in_edge: dict[tuple[int, bool], int] = {}
        label = 0
        free = 0
        for ci, ev in enumerate(self.events):
            if ci not in comps:
                continue
            ev = [(c, o) for c, o in ev if keep[c]]
            if not ev:
                free += 1
                continue
            m = len(ev)
            for k, (c, o) in enumerate(ev):
                out_edge[(c, o)] = label + k
                in_edge[(c, o)] = label + (k - 1) % m
            label += m
        pd = []
        signs = []
        for c in np.flatnonzero(keep):
            c = int(c)
            i, kk = in_edge[(c, False)], out_edge[(c, False)]
            a, b = in_edge[(c, True)], out_edge[(c, True)]
            pd.append((i, b, kk, a) if self.signs[c] > 0 else (i, a, kk, b))
            signs.append(int(self.signs[c]))
        return pd, np.array(signs, dtype=np.int64), free


def _project_once(comps: list[np.ndarray], d: np.ndarray, scale: float):
    e1, e2, d = _basis(np.asarray(d, dtype=np.float64))
    P = np.concatenate(comps)
    x, y, h = P @ e1, P @ e2, P @ d
    starts = np.cumsum([0] + [len(c) for c in comps])
    nxt = np.arange(1, len(P) + 1, dtype=np.int64)
    for k in range(len(comps)):
        nxt[starts[k + 1] - 1] = starts[k]
    cap = 4 * len(P) + 64
    while True:
        res = _crossings_kernel(x, y, h, nxt, 1e-9, 1e-7, 1e-12 * scale, 1e-12 * scale, cap)
        if res[4] <= cap:
            break
        cap = res[4] + 16
    seg_a, s_a, seg_b, s_b, count, flag = res
    return (
        (e1, e2, d),
        P,
        (x, y, h),
        starts,
        nxt,
        seg_a[:count],
        s_a[:count],
        seg_b[:count],
        s_b[:count],
        flag,
    )


def _diagram_from(comps, proj) -> Diagram:
    (e1, e2, d), P, (x, y, h), starts, nxt, sa, ta, sb, tb, _ = proj
    n = len(sa)
    comp_of = np.searchsorted(starts, np.arange(len(P)), side="right") - 1
    ha = h[sa] + ta * (h[nxt[sa]] - h[sa])
    hb = h[sb] + tb * (h[nxt[sb]] - h[sb])
    a_over = ha > hb
    so = np.where(a_over, sa, sb)
    to = np.where(a_over, ta, tb)
    su = np.where(a_over, sb, sa)
    tu = np.where(a_over, tb, ta)
    ox, oy = x[nxt[so]] - x[so], y[nxt[so]] - y[so]
    ux, uy = x[nxt[su]] - x[su], y[nxt[su]] - y[su]
    signs = np.where(ox * uy - oy * ux > 0, 1, -1).astype(np.int64)
    positions = P[so] + to[:, None] * (P[nxt[so]] - P[so])
    # events along each component, ordered by segment index then parameter
    key = np.concatenate([so + to, su + tu])
    cid = np.concatenate([np.arange(n), np.arange(n)])
    is_over = np.concatenate([np.ones(n, bool), np.zeros(n, bool)])
    seg = np.concatenate([so, su])
    order = np.argsort(key, kind="stable")
    events: list[list[tuple[int, bool]]] = [[] for _ in comps]
    for idx in order:
        events[comp_of[seg[idx]]].append((int(cid[idx]), bool(is_over[idx])))
    return Diagram(
        direction=d,
        n_components=len(comps),
        signs=signs,
        over_component=comp_of[so].astype(np.int64),
        under_component=comp_of[su].astype(np.int64),
        positions=positions,
        events=events,
    )


def _random_direction(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def project(
    closed_curves,
    direction=None,
    *,
    seed: int = 0,
    n_directions: int = 6,
    max_tries: int = 50,
) -> Diagram:
    """Project closed polygons to a generic knot/link diagram.

    Parameters
    ----------
    closed_curves:
        List of ``(M_k, 3)`` arrays (m), each a closed polygon (last node joins the first; see
        :func:`close_curves` for open ropes).
    direction:
        ``(3,)`` projection direction (towards the viewer).  ``None``: random directions drawn from
        ``numpy.random.default_rng(seed)``; ``n_directions`` non-degenerate ones are tried and the one
        with the fewest crossings is kept.  A given direction that turns out degenerate raises
        :class:`TopologyError`.
    seed, n_directions, max_tries:
        Random generator seed, number of good directions compared, and maximum number of directions
        drawn in total.

    Returns
    -------
    :class:`Diagram`
    """
    comps = []
    for k, c in enumerate(_as_curve_list(closed_curves)):
        if len(c) < 3:
            raise TopologyError(f"closed_curves[{k}]: a closed polygon needs at least 3 points, got {len(c)}")
        comps.append(c)
    allp = np.concatenate(comps)
    scale = float(np.max(np.linalg.norm(allp - allp.mean(axis=0), axis=1)))
    if not scale > 0:
        raise TopologyError("closed_curves: all points coincide")
    comps = [_dedupe(c, True, 1e-12 * scale) for c in comps]
    if direction is not None:
        d = np.asarray(direction, dtype=np.float64).reshape(3)
        if not np.linalg.norm(d) > 0:
            raise TopologyError("direction: must be a non-zero 3-vector")
        proj = _project_once(comps, d, scale)
        if proj[-1]:
            raise TopologyError(
                f"direction {d.tolist()} is not generic ({_DEGENERACY[proj[-1]]}); pass direction=None"
            )
        return _diagram_from(comps, proj)
    rng = np.random.default_rng(seed)
    best = None
    good = 0
    last_flag = 0
    for _ in range(max_tries):
        proj = _project_once(comps, _random_direction(rng), scale)
        if proj[-1]:
            last_flag = proj[-1]
            continue
        good += 1
        if best is None or len(proj[5]) < len(best[5]):
            best = proj
        if good >= n_directions:
            break
    if best is None:
        raise TopologyError(
            f"no generic projection found in {max_tries} random directions ({_DEGENERACY[last_flag]}); "
            "the curves probably intersect themselves or each other"
        )
    return _diagram_from(comps, best)


# ----------------------------------------------------------------------------------------------
# Reidemeister simplification of PD codes
# ----------------------------------------------------------------------------------------------


def _faces(X: list[list[int]]) -> list[list[tuple[int, int]]]:
    """Faces of a planar 4-valent diagram, as lists of corners ``(crossing, slot)``.

    Corner ``(x, p)`` is the angle between slots ``p`` and ``p+1`` (counterclockwise) of crossing
    ``x``; the next corner of the face is at the other end of the edge in slot ``p+1``.
    """
    occ: dict[int, list[tuple[int, int]]] = {}
    for i, x in enumerate(X):
        for s in range(4):
            occ.setdefault(x[s], []).append((i, s))
    seen = set()
    faces = []
    for i in range(len(X)):
        for p in range(4):
            if (i, p) in seen:
                continue
            face = []
            cur = (i, p)
            while cur not in seen:
                seen.add(cur)
                face.append(cur)
                ci, cp = cur
                s = (cp + 1) % 4
                o = occ[X[ci][s]]
                cur = o[1] if o[0] == (ci, s) else o[0]
            faces.append(face)
    return faces


def _relabel(X: list[list[int]], old: int, new: int) -> None:
    for x in X:
        for s in range(4):
            if x[s] == old:
                x[s] = new


def simplify_pd(pd, signs, free_loops: int = 0) -> tuple[list[tuple[int, int, int, int]], np.ndarray, int]:
    """Remove Reidemeister I kinks and Reidemeister II bigons until none is left.

    Parameters
    ----------
    pd:
        PD code (list of 4-tuples, KnotTheory convention).
    signs:
        ``(n,)`` crossing signs (kept for the surviving crossings).
    free_loops:
        Number of crossing-free components already present.

    Returns
    -------
    ``(pd, signs, free_loops)`` of the simplified diagram; components that lose all their crossings
    are counted in ``free_loops``.  The link type is unchanged; the writhe changes by the signs of
    the removed kinks.
    """
    X = [list(x) for x in pd]
    S = [int(s) for s in signs]
    if len(X) != len(S):
        raise TopologyError(f"simplify_pd: {len(X)} crossings but {len(S)} signs")
    free = int(free_loops)
    while True:
        done = False
        # Reidemeister I: an edge joining two adjacent slots of the same crossing
        for idx, x in enumerate(X):
            for p in range(4):
                if x[p] == x[(p + 1) % 4]:
                    u, v = x[(p + 2) % 4], x[(p + 3) % 4]
                    del X[idx]
                    del S[idx]
                    if u == v:
                        free += 1
                    else:
                        _relabel(X, v, u)
                    done = True
                    break
            if done:
                break
        if done:
            continue
        # Reidemeister II: a bigon face whose first edge is over (or under) at both ends
        for face in _faces(X):
            if len(face) != 2:
                continue
            (xa, p), (xb, q) = face
            if xa == xb or (p + 1) % 2 != q % 2:
                continue
            A, B = X[xa], X[xb]
            m1 = (A[(p + 3) % 4], B[(q + 2) % 4])
            m2 = (A[(p + 2) % 4], B[(q + 3) % 4])
            for i in sorted((xa, xb), reverse=True):
                del X[i]
                del S[i]
            u1, v1 = m1
            if u1 == v1:
                free += 1
            else:
                _relabel(X, v1, u1)
            u2, v2 = (u1 if m2[0] == v1 else m2[0]), (u1 if m2[1] == v1 else m2[1])
            if u2 == v2:
                free += 1
            else:
                _relabel(X, v2, u2)
            done = True
            break
        if not done:
            break
    return [tuple(x) for x in X], np.array(S, dtype=np.int64), free


# ----------------------------------------------------------------------------------------------
# Laurent polynomials (dict exponent -> int coefficient)
# ----------------------------------------------------------------------------------------------


def _pmul(p: dict[int, int], q: dict[int, int]) -> dict[int, int]:
    r: dict[int, int] = {}
    for e1, c1 in p.items():
        for e2, c2 in q.items():
            r[e1 + e2] = r.get(e1 + e2, 0) + c1 * c2
    return {e: c for e, c in r.items() if c}


def _padd_into(r: dict[int, int], p: dict[int, int], shift: int = 0) -> None:
    for e, c in p.items():
        r[e + shift] = r.get(e + shift, 0) + c


_DELTA = {2: -1, -2: -1}  # -A^2 - A^-2


def _ppow(p: dict[int, int], k: int) -> dict[int, int]:
    r = {0: 1}
    for _ in range(k):
        r = _pmul(r, p)
    return r


def _pdiv_delta(p: dict[int, int]) -> dict[int, int]:
    """Exact division by delta = -A^2 - A^-2 = -A^-2 (1 + A^4)."""
    p = {e: c for e, c in p.items() if c}
    if not p:
        return {}
    q: dict[int, int] = {}
    rem = dict(p)
    # divide by (1 + A^4) from the lowest exponent up
    while rem:
        e = min(rem)
        c = rem.pop(e)
        if c == 0:
            continue
        q[e] = c
        rem[e + 4] = rem.get(e + 4, 0) - c
        if rem[e + 4] == 0:
            del rem[e + 4]
        if len(q) > 4 * (max(p) - min(p) + 8):
            raise TopologyError("Kauffman bracket is not divisible by delta (internal error)")
    # multiply by -A^2
    return {e + 2: -c for e, c in q.items() if c}


# ----------------------------------------------------------------------------------------------
# Kauffman bracket and Jones polynomial
# ----------------------------------------------------------------------------------------------


def _join(key: tuple[tuple[int, int], ...], pairs) -> tuple[tuple[tuple[int, int], ...], int]:
    """Glue a planar matching with two new arcs; return the new matching and the closed loops."""
    adj: dict[int, list[int]] = {}
    loops = 0
    for u, v in (*key, *pairs):
        if u == v:
            loops += 1
            continue
        adj.setdefault(u, []).append(v)
        adj.setdefault(v, []).append(u)
    visited = set()
    new = []
    for s, nb in adj.items():
        if len(nb) != 1 or s in visited:
            continue
        visited.add(s)
        prev, cur = s, nb[0]
        while len(adj[cur]) == 2:
            visited.add(cur)
            n0, n1 = adj[cur]
            prev, cur = cur, (n1 if n0 == prev else n0)
        visited.add(cur)
        new.append((s, cur) if s < cur else (cur, s))
    for s in adj:
        if s in visited:
            continue
        loops += 1
        prev, cur = None, s
        while cur not in visited:
            visited.add(cur)
            n0, n1 = adj[cur]
            prev, cur = cur, (n1 if n0 == prev else n0)
    new.sort()
    return tuple(new), loops


def _contraction_order(X: list[tuple[int, int, int, int]]) -> list[int]:
    n = len(X)
    remaining = set(range(n))
    open_labels: set[int] = set()
    order = []
    while remaining:
        best, best_key = None, None
        for i in remaining:
            labs = X[i]
            shared = sum(1 for lab in labs if lab in open_labels)
            k = (shared, -len(set(labs)))
            if best_key is None or k > best_key:
                best, best_key = i, k
        remaining.discard(best)
        order.append(best)
        for lab in X[best]:
            if lab in open_labels:
                open_labels.discard(lab)
            else:
                open_labels.add(lab)
        # a label appearing twice in one crossing is closed at once
        for lab in set(X[best]):
            if list(X[best]).count(lab) == 2:
                open_labels.discard(lab)
    return order


def kauffman_bracket(pd, free_loops: int = 0) -> dict[int, int]:
    """Kauffman bracket ``<D>`` of a PD code, as ``{exponent of A: coefficient}``.

    Normalised by ``<O> = 1``; ``free_loops`` extra crossing-free circles each multiply it by
    ``delta = -A^2 - A^-2``.  The A-smoothing of crossing ``(i, j, k, l)`` joins ``i`` with ``j`` and
    ``k`` with ``l``.  Crossings are contracted one at a time in a greedy order, keeping one polynomial
    per planar matching of the open edges, so the cost grows with the width of the diagram rather
    than as ``2^n``.
    """
    X = [tuple(int(v) for v in x) for x in pd]
    if not X:
        return _ppow(_DELTA, free_loops - 1) if free_loops >= 1 else {0: 1}
    states: dict[tuple, dict[int, int]] = {(): {0: 1}}
    delta_pows = [{0: 1}]
    for ci in _contraction_order(X):
        a, b, c, d = X[ci]
        smoothings = ((1, ((a, b), (c, d))), (-1, ((a, d), (b, c))))
        new_states: dict[tuple, dict[int, int]] = {}
        for key, poly in states.items():
            for aexp, pairs in smoothings:
                nkey, loops = _join(key, pairs)
                while len(delta_pows) <= loops:
                    delta_pows.append(_pmul(delta_pows[-1], _DELTA))
                term = _pmul(poly, delta_pows[loops]) if loops else poly
                tgt = new_states.setdefault(nkey, {})
                _padd_into(tgt, term, aexp)
        states = {k: {e: c for e, c in p.items() if c} for k, p in new_states.items()}
    total = states.get((), {})
    if free_loops >= 1:
        return {e: c for e, c in _pmul(total, _ppow(_DELTA, free_loops - 1)).items() if c}
    return _pdiv_delta(total)


def _jones_from_bracket(bracket: dict[int, int], writhe: int) -> dict:
    """``V(t) = (-A^3)^-w <D>`` at ``A = t^(-1/4)``; exponents are int or ``Fraction`` (half-integers)."""
    sgn = -1 if writhe % 2 else 1
    out = {}
    for e, c in bracket.items():
        ea = e - 3 * writhe
        te = Fraction(-ea, 4)
        if te.denominator not in (1, 2):
            raise TopologyError("Jones polynomial has quarter-integer exponents (internal error)")
        out[int(te) if te.denominator == 1 else te] = sgn * c
    return dict(sorted((k, v) for k, v in out.items() if v))


def jones_polynomial(pd, signs, free_loops: int = 0, *, simplify: bool = True) -> dict:
    """Jones polynomial ``V(t)`` of an oriented diagram given by its PD code and crossing signs.

    Returns ``{exponent: coefficient}`` sorted by exponent; exponents are ints for knots (and links
    with an odd number of components), ``fractions.Fraction`` halves otherwise.  The right-handed
    trefoil gives ``{1: 1, 3: 1, 4: -1}``.
    """
    if simplify:
        pd, signs, free_loops = simplify_pd(pd, signs, free_loops)
    return _jones_from_bracket(kauffman_bracket(pd, free_loops), int(np.sum(signs)))


# ----------------------------------------------------------------------------------------------
# Alexander polynomial and determinant
# ----------------------------------------------------------------------------------------------


def _bareiss_det(M: list[list[int]]) -> int:
    """Exact determinant of an integer matrix (fraction-free Gaussian elimination)."""
    n = len(M)
    if n == 0:
        return 1
    A = [row[:] for row in M]
    sign = 1
    prev = 1
    for k in range(n - 1):
        if A[k][k] == 0:
            for r in range(k + 1, n):
                if A[r][k] != 0:
                    A[k], A[r] = A[r], A[k]
                    sign = -sign
                    break
            else:
                return 0
        for i in range(k + 1, n):
            for j in range(k + 1, n):
                A[i][j] = (A[i][j] * A[k][k] - A[i][k] * A[k][j]) // prev
        prev = A[k][k]
    return sign * A[n - 1][n - 1]


def _wirtinger(pd, signs):
    """Over-arcs of the diagram and, per crossing, (over arc, incoming under arc, outgoing under arc, sign)."""
    parent: dict[int, int] = {}

    def find(a):
        parent.setdefault(a, a)
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for i, j, k, l in pd:
        for lab in (i, j, k, l):
            find(lab)
        ra, rb = find(j), find(l)
        if ra != rb:
            parent[ra] = rb
    roots = sorted({find(lab) for lab in parent})
    arc = {r: n for n, r in enumerate(roots)}
    rows = [
        (arc[find(j)], arc[find(i)], arc[find(k)], int(s)) for (i, j, k, l), s in zip(pd, signs, strict=True)
    ]
    return len(roots), rows


def _fox_matrices(n_arcs: int, rows) -> tuple[np.ndarray, np.ndarray]:
    """Alexander matrix ``M0 + t M1`` (crossings x arcs), first row and column removed."""
    n = len(rows)
    M0 = np.zeros((n, n_arcs), dtype=np.int64)
    M1 = np.zeros((n, n_arcs), dtype=np.int64)
    for r, (k, i, j, s) in enumerate(rows):
        M0[r, k] += 1
        M1[r, k] -= 1
        if s > 0:
            M1[r, i] += 1
            M0[r, j] -= 1
        else:
            M0[r, i] -= 1
            M1[r, j] += 1
    return M0[1:, 1:], M1[1:, 1:]


def _is_prime(n: int) -> bool:
    if n < 2:
        return False
    for q in (2, 3, 5, 7, 11, 13):
        if n % q == 0:
            return n == q
    d, r = n - 1, 0
    while d % 2 == 0:
        d //= 2
        r += 1
    for a in (2, 3, 5, 7, 11, 13, 17):  # deterministic for n < 3.4e14
        x = pow(a, d, n)
        if x in (1, n - 1):
            continue
        for _ in range(r - 1):
            x = x * x % n
            if x == n - 1:
                break
        else:
            return False
    return True


_PRIMES: list[int] = []


def _primes(k: int) -> list[int]:
    """The ``k`` largest primes below 2^31 (products of two residues fit in int64)."""
    c = (_PRIMES[-1] - 2) if _PRIMES else (1 << 31) - 1
    while len(_PRIMES) < k:
        if _is_prime(c):
            _PRIMES.append(c)
        c -= 2
    return _PRIMES[:k]


@njit(cache=True)
def _powmod(a, e, p):
    r = 1
    a %= p
    while e > 0:
        if e & 1:
            r = r * a % p
        a = a * a % p
        e >>= 1
    return r


@njit(cache=True)
def _det_mod_batch(A0, p):
    """Determinants modulo ``p`` of a batch ``(B, m, m)`` of int64 matrices with entries in ``[0, p)``."""
    B, m, _ = A0.shape
    out = np.empty(B, dtype=np.int64)
    A = np.empty((m, m), dtype=np.int64)
    for b in range(B):
        A[:, :] = A0[b]
        det = 1
        for k in range(m):
            piv = -1
            for r in range(k, m):
                if A[r, k] != 0:
                    piv = r
                    break
            if piv < 0:
                det = 0
                break
            if piv != k:
                for c in range(k, m):
                    tmp = A[k, c]
                    A[k, c] = A[piv, c]
                    A[piv, c] = tmp
                det = (p - det) % p
            det = det * A[k, k] % p
            inv = _powmod(A[k, k], p - 2, p)
            for r in range(k + 1, m):
                if A[r, k] == 0:
                    continue
                f = A[r, k] * inv % p
                for c in range(k, m):
                    A[r, c] = (A[r, c] - f * A[k, c]) % p
        out[b] = det
    return out


def _crt_signed(residues: list[list[int]], primes: list[int]) -> list[int]:
    """Chinese remainder per entry, mapped to the symmetric range."""
    out = []
    mod = 1
    for p in primes:
        mod *= p
    for vals in zip(*residues, strict=True):
        x, m = 0, 1
        for v, p in zip(vals, primes, strict=True):
            # x = x (mod m), x = v (mod p)
            tt = ((v - x) * pow(m, -1, p)) % p
            x += m * tt
            m *= p
        out.append(x - mod if x > mod // 2 else x)
    return out


def _minor_poly(M0: np.ndarray, M1: np.ndarray) -> list[int]:
    """Exact integer coefficients (lowest degree first) of ``det(M0 + t M1)``.

    Evaluated modulo several primes at ``deg + 1`` points, interpolated modulo each prime, and
    reconstructed with the Chinese remainder theorem; every coefficient is bounded by ``4^m``
    (each row of the Fox matrix has absolute coefficient sum <= 4), which fixes the number of primes.
    """
    m = M0.shape[0]
    if m == 0:
        return [1]
    pts = np.arange(1, m + 2, dtype=np.int64)  # degree <= m
    n_pr = (2 * m + 2) // 30 + 2
    residues = []
    primes = _primes(n_pr)
    for p in primes:
        batch = (M0[None] % p + (pts[:, None, None] * (M1[None] % p)) % p) % p
        vals = [int(v) for v in _det_mod_batch(batch, p)]
        xs = [int(x) for x in pts]
        # Newton divided differences mod p
        coef = vals[:]
        for lvl in range(1, len(xs)):
            for i in range(len(xs) - 1, lvl - 1, -1):
                coef[i] = (coef[i] - coef[i - 1]) * pow(xs[i] - xs[i - lvl], p - 2, p) % p
        poly = [0] * len(xs)
        for i in range(len(xs) - 1, -1, -1):
            new = [0] * len(xs)
            for e in range(len(xs) - 1):
                new[e + 1] = poly[e]
            for e in range(len(xs)):
                new[e] = (new[e] - xs[i] * poly[e]) % p
            new[0] = (new[0] + coef[i]) % p
            poly = new
        residues.append(poly)
    return _crt_signed(residues, primes)


def _det_exact(M: np.ndarray) -> int:
    """Exact integer determinant of a square int64 matrix (modular, entries' row sums <= 4)."""
    m = M.shape[0]
    if m == 0:
        return 1
    primes = _primes((2 * m + 2) // 30 + 2)
    res = [[int(_det_mod_batch((M % p)[None], p)[0])] for p in primes]
    return _crt_signed(res, primes)[0]


def alexander_polynomial(pd, signs, free_loops: int = 0, *, simplify: bool = True) -> list[int]:
    """Alexander polynomial of a knot diagram (one component), normalised.

    Returns the coefficients of ``t^-m, ..., t^m`` of the symmetric representative with
    ``Delta(1) = 1`` (trefoil ``[1, -1, 1]``, figure-eight ``[-1, 3, -1]``, unknot ``[1]``).
    Computed from the Fox-calculus matrix of the Wirtinger presentation: the first minor is a
    polynomial evaluated exactly (modular arithmetic) at integer points and interpolated.
    """
    if simplify:
        pd, signs, free_loops = simplify_pd(pd, signs, free_loops)
    n = len(pd)
    if free_loops > (1 if n == 0 else 0):
        raise TopologyError("alexander_polynomial: the diagram has several components (a link)")
    if n == 0:
        return [1]
    n_arcs, rows = _wirtinger(pd, signs)
    if n_arcs != n:
        raise TopologyError("alexander_polynomial: the diagram is not a knot diagram (a link)")
    ints = _minor_poly(*_fox_matrices(n_arcs, rows))
    while ints and ints[-1] == 0:
        ints.pop()
    while ints and ints[0] == 0:
        ints.pop(0)
    if not ints:
        return [0]
    if sum(ints) < 0:
        ints = [-c for c in ints]
    return ints


def knot_determinant(pd, signs, free_loops: int = 0) -> int:
    """Determinant ``|Delta(-1)|`` of a knot or link diagram (0 for split links).

    Computed as the absolute value of a first minor of the colouring matrix (valid for links too).
    """
    pd, signs, free_loops = simplify_pd(pd, signs, free_loops)
    if not pd:
        return 1 if free_loops <= 1 else 0
    if free_loops:
        return 0
    n_arcs, rows = _wirtinger(pd, signs)
    if n_arcs != len(pd):
        return 0
    M0, M1 = _fox_matrices(n_arcs, rows)
    return abs(_det_exact(M0 - M1))


# ----------------------------------------------------------------------------------------------
# 3D Gauss integrals (exact for polygons)
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _solid_angle(p1, p2, p3, p4):
    """Signed solid-angle term of segments p1->p2 and p3->p4 (Klenin & Langowski 2000), /(4 pi) later."""
    r13 = p3 - p1
    r14 = p4 - p1
    r23 = p3 - p2
    r24 = p4 - p2
    n1 = np.cross(r13, r14)
    n2 = np.cross(r14, r24)
    n3 = np.cross(r24, r23)
    n4 = np.cross(r23, r13)
    l1 = math.sqrt(n1 @ n1)
    l2 = math.sqrt(n2 @ n2)
    l3 = math.sqrt(n3 @ n3)
    l4 = math.sqrt(n4 @ n4)
    if l1 == 0.0 or l2 == 0.0 or l3 == 0.0 or l4 == 0.0:
        return 0.0
    n1 = n1 / l1
    n2 = n2 / l2
    n3 = n3 / l3
    n4 = n4 / l4
    om = (
        math.asin(min(1.0, max(-1.0, n1 @ n2)))
        + math.asin(min(1.0, max(-1.0, n2 @ n3)))
        + math.asin(min(1.0, max(-1.0, n3 @ n4)))
        + math.asin(min(1.0, max(-1.0, n4 @ n1)))
    )
    s = np.cross(p4 - p3, p2 - p1) @ r13
    if s > 0:
        return om
    if s < 0:
        return -om
    return 0.0


@njit(cache=True)
def _gauss_sum(A, B, same):
    na = A.shape[0]
    nb = B.shape[0]
    tot = 0.0
    for i in range(na):
        i1 = (i + 1) % na
        j0 = i + 1 if same else 0
        for j in range(j0, nb):
            j1 = (j + 1) % nb
            if same and (j == i1 or j1 == i):
                continue
            tot += _solid_angle(A[i], A[i1], B[j], B[j1])
    return tot / (4.0 * math.pi)


def gauss_linking_number(curve_a, curve_b) -> float:
    """Gauss linking integral of two closed polygons (``(N, 3)`` and ``(M, 3)`` arrays, m).

    Exact for polygons up to rounding, so the result is within ~1e-9 of an integer for disjoint
    curves.  Same sign convention as :meth:`Diagram.linking_matrix`.
    """
    a, b = _as_curve_list([curve_a, curve_b])
    return float(_gauss_sum(a, b, False))


def writhe_3d(curve) -> float:
    """3D writhe (Gauss double integral) of a closed polygon ``(N, 3)`` (m); dimensionless.

    Equals the average of the diagram writhe over all projection directions.
    """
    (a,) = _as_curve_list([curve])
    return 2.0 * float(_gauss_sum(a, a, True))


# ----------------------------------------------------------------------------------------------
# knot table and identification
# ----------------------------------------------------------------------------------------------


def _mirror(v: dict) -> dict:
    return dict(sorted((-e, c) for e, c in v.items()))


def _jones_key(v: dict) -> tuple:
    return tuple(sorted((Fraction(e), int(c)) for e, c in v.items() if c))


def _pmul_jones(p: dict, q: dict) -> dict:
    r: dict = {}
    for e1, c1 in p.items():
        for e2, c2 in q.items():
            r[e1 + e2] = r.get(e1 + e2, 0) + c1 * c2
    return dict(sorted((e, c) for e, c in r.items() if c))


def _alex_mul(a: list[int], b: list[int]) -> list[int]:
    r = [0] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            r[i + j] += x * y
    return r


# Prime knots up to 7 crossings: (name, alias, Alexander, Jones of one mirror image as
# {exponent: coefficient}).  The Jones polynomials were computed with this module from the PD codes of
# the Rolfsen table (as shipped with spherogram); the Alexander polynomials computed the same way match
# the Rolfsen table.
_PRIME = [
    ("3_1", "trefoil", [1, -1, 1], {1: 1, 3: 1, 4: -1}),
    ("4_1", "figure_eight", [-1, 3, -1], {-2: 1, -1: -1, 0: 1, 1: -1, 2: 1}),
    ("5_1", None, [1, -1, 1, -1, 1], {2: 1, 4: 1, 5: -1, 6: 1, 7: -1}),
    ("5_2", None, [2, -3, 2], {1: 1, 2: -1, 3: 2, 4: -1, 5: 1, 6: -1}),
    ("6_1", None, [-2, 5, -2], {-4: 1, -3: -1, -2: 1, -1: -2, 0: 2, 1: -1, 2: 1}),
    ("6_2", None, [-1, 3, -3, 3, -1], {-1: 1, 0: -1, 1: 2, 2: -2, 3: 2, 4: -2, 5: 1}),
    ("6_3", None, [1, -3, 5, -3, 1], {-3: -1, -2: 2, -1: -2, 0: 3, 1: -2, 2: 2, 3: -1}),
    ("7_1", None, [1, -1, 1, -1, 1, -1, 1], {3: 1, 5: 1, 6: -1, 7: 1, 8: -1, 9: 1, 10: -1}),
    ("7_2", None, [3, -5, 3], {1: 1, 2: -1, 3: 2, 4: -2, 5: 2, 6: -1, 7: 1, 8: -1}),
    ("7_3", None, [2, -3, 3, -3, 2], {2: 1, 3: -1, 4: 2, 5: -2, 6: 3, 7: -2, 8: 1, 9: -1}),
    ("7_4", None, [4, -7, 4], {1: 1, 2: -2, 3: 3, 4: -2, 5: 3, 6: -2, 7: 1, 8: -1}),
    ("7_5", None, [2, -4, 5, -4, 2], {2: 1, 3: -1, 4: 3, 5: -3, 6: 3, 7: -3, 8: 2, 9: -1}),
    ("7_6", None, [-1, 5, -7, 5, -1], {-6: -1, -5: 2, -4: -3, -3: 4, -2: -3, -1: 3, 0: -2, 1: 1}),
    ("7_7", None, [1, -5, 9, -5, 1], {-4: 1, -3: -2, -2: 3, -1: -4, 0: 4, 1: -3, 2: 3, 3: -1}),
]


def _torus_2q(q: int) -> tuple[list[int], dict[int, int]]:
    """Alexander coefficients and Jones polynomial of the torus knot ``T(2, q)`` (``q`` odd >= 3).

    Closed forms: ``Delta(t) = (t^q + 1)/(t + 1)`` (alternating ones) and Jones' formula
    ``V(t) = t^((q-1)/2) (1 - t^3 - t^(q+1) + t^(q+2)) / (1 - t^2)`` for the positive knot. They
    reproduce the table's 3_1, 5_1 and 7_1 (tested) and supply 9_1 (the open overhand with n = 4).
    """
    num = {0: 1, 3: -1, q + 1: -1, q + 2: 1}
    quotient = {}
    rem = dict(num)
    # divide by (1 - t^2) from the lowest power up: c_k = r_k + c_{k-2}
    for k in range(q + 1):
        c = rem.get(k, 0) + quotient.get(k - 2, 0)
        if c:
            quotient[k] = c
    shift = (q - 1) // 2
    jones = {k + shift: c for k, c in quotient.items()}
    alexander = [(-1) ** i for i in range(q)]
    return alexander, jones


@dataclass(frozen=True)
class KnotEntry:
    """One entry of :data:`KNOT_TABLE`."""

    knot_type: str  # e.g. "trefoil_right", "figure_eight", "reef", "5_2_left"
    rolfsen: str  # e.g. "3_1", "3_1#3_1", "3_1#3_1*"
    chirality: str  # "right", "left" or "achiral"
    alexander: tuple[int, ...]
    jones: tuple  # ((exponent, coefficient), ...)


def _chirality(v: dict) -> str:
    """Chirality label: achiral when ``V(t) = V(1/t)``, else right when the exponents centre above 0."""
    if _jones_key(v) == _jones_key(_mirror(v)):
        return "achiral"
    for key in (min(v) + max(v), sum(e * c for e, c in v.items()), sum(e * c * c for e, c in v.items())):
        if key != 0:
            return "right" if key > 0 else "left"
    return "right"  # pragma: no cover - no such knot in the table


def _build_table() -> list[KnotEntry]:
    entries = [KnotEntry("unknot", "0_1", "achiral", (1,), ((0, 1),))]

    def add(rolf: str, alias: str | None, alex: list[int], v: dict, mirror_rolf: str | None = None):
        base = alias or rolf
        ch = _chirality(v)
        if ch == "achiral":
            entries.append(KnotEntry(base, rolf, "achiral", tuple(alex), _jones_key(v)))
            return
        for vv in (v, _mirror(v)):
            c = _chirality(vv)
            entries.append(KnotEntry(f"{base}_{c}", rolf, c, tuple(alex), _jones_key(vv)))

    prime = {}
    for rolf, alias, alex, v in _PRIME:
        add(rolf, alias, alex, v)
        prime[rolf] = (alex, v)
    a9, v9 = _torus_2q(9)
    add("9_1", None, a9, v9)
    a3, v3 = prime["3_1"]
    a4, v4 = prime["4_1"]
    add("3_1#3_1", "granny", _alex_mul(a3, a3), _pmul_jones(v3, v3))
    add("3_1#3_1*", "reef", _alex_mul(a3, a3), _pmul_jones(v3, _mirror(v3)))
    add("3_1#4_1", None, _alex_mul(a3, a4), _pmul_jones(v3, v4))
    return entries


KNOT_TABLE: list[KnotEntry] = _build_table()
"""Knots recognised by :func:`identify_knot` (prime knots up to 7 crossings, 9_1, granny, reef, 3_1#4_1)."""
_BY_JONES = {e.jones: e for e in KNOT_TABLE}


def identify_knot(alexander: Sequence[int] | None, jones: dict | None) -> KnotEntry | None:
    """Look a knot up in :data:`KNOT_TABLE` from its Alexander coefficient list and Jones polynomial.

    Both invariants must match when both are given; with ``jones=None`` only knots whose Alexander
    polynomial is unique in the table (and amphichiral, so no chirality is claimed) are returned.
    Returns ``None`` when nothing matches.
    """
    if jones is not None:
        e = _BY_JONES.get(_jones_key(jones))
        if e is None:
            return None
        if alexander is not None and tuple(alexander) != e.alexander:
            return None
        return e
    if alexander is None:
        return None
    cands = [x for x in KNOT_TABLE if x.alexander == tuple(alexander)]
    return cands[0] if len(cands) == 1 else None


# ----------------------------------------------------------------------------------------------
# the one-call analysis
# ----------------------------------------------------------------------------------------------


@dataclass
class TopologyResult:
    """Topological description of a set of (closed) ropes.

    Attributes
    ----------
    n_components:
        Closed components after closure.
    component_ropes:
        Rope indices making up each component.
    n_crossings:
        Crossings of the chosen projection (before simplification).
    n_crossings_reduced:
        Crossings left after Reidemeister I/II simplification.
    writhe:
        Diagram writhe (sum of crossing signs of the projection, all components).
    writhe_reduced:
        Writhe of the simplified diagram.
    linking:
        ``(k, k)`` int array of pairwise linking numbers.
    alexander:
        Normalised Alexander coefficient list (``t^-m..t^m``) for a knot, ``None`` for a link.
    determinant:
        Knot/link determinant ``|Delta(-1)|``.
    jones:
        Jones polynomial ``{exponent: coefficient}`` (``None`` if skipped, see ``max_jones_crossings``).
    knot_type:
        Name from :data:`KNOT_TABLE` (``"unknot"``, ``"trefoil_right"``, ``"figure_eight"``,
        ``"granny_left"``, ``"reef"``, ``"5_2_right"``, ...), for links ``"unlink"``,
        ``"hopf_positive"``/``"hopf_negative"``, else ``"unknown"``.
    rolfsen, chirality:
        Rolfsen name (``"3_1"``, ``"3_1#3_1*"``) and ``"right"``/``"left"``/``"achiral"`` or ``None``.
    component_types:
        ``knot_type`` of each component taken alone.
    diagram:
        The projection (:class:`Diagram`).
    pd_code, signs, free_loops:
        Simplified PD code, its crossing signs and number of crossing-free circles.
    closed_curves:
        The closed polygons ``(M_k, 3)`` (m) that were analysed.
    """

    n_components: int
    component_ropes: list[list[int]]
    n_crossings: int
    n_crossings_reduced: int
    writhe: int
    writhe_reduced: int
    linking: np.ndarray
    alexander: list[int] | None
    determinant: int
    jones: dict | None
    knot_type: str
    rolfsen: str | None
    chirality: str | None
    component_types: list[str]
    diagram: Diagram
    pd_code: list[tuple[int, int, int, int]]
    signs: np.ndarray
    free_loops: int
    closed_curves: list[np.ndarray] = field(repr=False)

    @property
    def gauss_code(self) -> list[list[int]]:
        """Gauss code of the (unsimplified) projection, see :attr:`Diagram.gauss_code`."""
        return self.diagram.gauss_code


def _name_knot(pd, signs, free, compute_jones: bool, max_jones: int):
    alex = alexander_polynomial(pd, signs, free, simplify=False)
    jones = None
    if compute_jones and len(pd) <= max_jones:
        jones = _jones_from_bracket(kauffman_bracket(pd, free), int(np.sum(signs)))
    entry = identify_knot(alex, jones)
    return alex, jones, entry


def _name_link(k: int, jones: dict | None, linking: np.ndarray, det: int):
    if jones is None:
        return "unknown", None
    unlink = {0: 1}
    d = {Fraction(1, 2): -1, Fraction(-1, 2): -1}
    for _ in range(k - 1):
        unlink = _pmul_jones(unlink, d)
    if _jones_key(jones) == _jones_key(unlink) and not np.any(linking):
        return "unlink", "achiral"
    hopf = {Fraction(1, 2): -1, Fraction(5, 2): -1}
    if k == 2 and _jones_key(jones) == _jones_key(hopf):
        return "hopf_positive", "right"
    if k == 2 and _jones_key(jones) == _jones_key(_mirror(hopf)):
        return "hopf_negative", "left"
    return "unknown", None


def analyze(
    curves,
    closed=None,
    *,
    pairing=None,
    closure: str = "radial",
    radius_factor: float = 20.0,
    direction=None,
    seed: int = 0,
    n_directions: int = 6,
    compute_jones: bool = True,
    max_jones_crossings: int = 80,
) -> TopologyResult:
    """Close, project and identify knotted ropes.

    Parameters
    ----------
    curves:
        List of ``(N_k, 3)`` centrelines (m), or one ``(N, 3)`` array.
    closed:
        One bool per rope (``None``: all open).
    pairing, closure, radius_factor:
        Closure of open ropes (:func:`close_curves`; ``closure`` is its ``method``).
    direction, seed, n_directions:
        Projection (:func:`project`).
    compute_jones:
        Compute the Jones polynomial (needed to tell chirality and granny from reef).
    max_jones_crossings:
        Skip the Jones polynomial when more crossings than this survive simplification.

    Returns
    -------
    :class:`TopologyResult`
    """
    comps, comp_ropes = _close(curves, closed, pairing, closure, radius_factor)
    dia = project(comps, direction, seed=seed, n_directions=n_directions)
    pd0, s0, f0 = dia.pd_code()
    pd, signs, free = simplify_pd(pd0, s0, f0)
    linking = dia.linking_matrix()
    k = dia.n_components
    det = knot_determinant(pd, signs, free)
    if k == 1:
        alex, jones, entry = _name_knot(pd, signs, free, compute_jones, max_jones_crossings)
        knot_type = entry.knot_type if entry else "unknown"
        rolfsen = entry.rolfsen if entry else None
        chir = entry.chirality if entry else None
        comp_types = [knot_type]
    else:
        alex = None
        jones = None
        if compute_jones and len(pd) <= max_jones_crossings:
            jones = _jones_from_bracket(kauffman_bracket(pd, free), int(np.sum(signs)))
        knot_type, chir = _name_link(k, jones, linking, det)
        rolfsen = None
        comp_types = []
        for c in range(k):
            cpd, cs, cf = simplify_pd(*dia.pd_code([c]))
            _, _, e = _name_knot(cpd, cs, cf, compute_jones, max_jones_crossings)
            comp_types.append(e.knot_type if e else "unknown")
    return TopologyResult(
        n_components=k,
        component_ropes=comp_ropes,
        n_crossings=dia.n_crossings,
        n_crossings_reduced=len(pd),
        writhe=dia.writhe,
        writhe_reduced=int(np.sum(signs)),
        linking=linking,
        alexander=alex,
        determinant=det,
        jones=jones,
        knot_type=knot_type,
        rolfsen=rolfsen,
        chirality=chir,
        component_types=comp_types,
        diagram=dia,
        pd_code=pd,
        signs=signs,
        free_loops=free,
        closed_curves=comps,
    )


# ----------------------------------------------------------------------------------------------
# optional: spherogram
# ----------------------------------------------------------------------------------------------


def spherogram_link(pd):
    """Build a ``spherogram.Link`` from a PD code (needs the optional ``spherogram`` package).

    spherogram uses the same PD convention as this module (checked: same crossing signs).
    Crossing-free components cannot be given in a PD code; a diagram without crossings raises
    :class:`TopologyError`.  Raises :class:`ImportError` with an install hint when spherogram is missing.
    """
    try:
        import spherogram
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("spherogram is not installed: pip install 'knotsim[topology]'") from exc
    if len(pd) == 0:
        raise TopologyError(
            "spherogram_link: the diagram has no crossing (unknot or unlink), nothing to build"
        )
    return spherogram.Link([[int(v) for v in x] for x in pd])


def identify_with_spherogram(result_or_pd) -> dict:
    """Independent identification with spherogram (optional dependency, imported only here).

    Parameters
    ----------
    result_or_pd:
        A :class:`TopologyResult` or a PD code (list of 4-tuples).

    Returns
    -------
    dict with

    * ``"crossings"``: crossings left after spherogram's global simplification;
    * ``"knot_floer_homology"``: the dict of ``Link.knot_floer_homology()`` for a knot
      (``seifert_genus``, ``fibered``, ``tau``, ...; ``tau > 0`` for right-handed = positive knots
      such as the right trefoil), ``None`` for links or when ``knot_floer_homology`` is missing;
    * ``"identify"``: names from ``Link.exterior().identify()`` (e.g. ``["K3a1"]``) when SnapPy is
      installed and the complement is recognised, else ``None``.

    A diagram without crossings gives ``{"crossings": 0, "knot_floer_homology": None, "identify": ["unknot"]}``
    (or ``"unlink"``).
    """
    if isinstance(result_or_pd, TopologyResult):
        pd, free = result_or_pd.pd_code, result_or_pd.free_loops
    else:
        pd, free = list(result_or_pd), 0
    if len(pd) == 0:
        return {
            "crossings": 0,
            "knot_floer_homology": None,
            "identify": ["unknot" if free <= 1 else "unlink"],
        }
    L = spherogram_link(pd)
    L.simplify("global")
    out: dict = {"crossings": len(L.crossings), "knot_floer_homology": None, "identify": None}
    if len(L.link_components) == 1 and free == 0:
        try:
            out["knot_floer_homology"] = dict(L.knot_floer_homology())
        except ImportError:  # pragma: no cover - depends on the environment
            pass
    try:
        out["identify"] = [str(m) for m in L.exterior().identify()]
    except (ImportError, RuntimeError):
        pass
    return out
