"""Knot/link diagrams: projection of closed polygons, crossings, signs, Gauss and PD codes.

The viewer sits at ``+infinity * d`` and looks along ``-d``; a strand is *over* when its height
``x . d`` is larger. Crossings are found with the numba sweep of :mod:`knotsim.geometry.planar`.
Conventions (crossing sign, PD and Gauss codes): package docstring of :mod:`knotsim.knots.topology`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from knotsim.geometry.planar import DEGENERACY as _DEGENERACY
from knotsim.geometry.planar import segment_crossings
from knotsim.knots.topology.curves import TopologyError, _as_curve_list, _dedupe


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
    seg_a, s_a, seg_b, s_b, flag = segment_crossings(
        x, y, np.arange(len(P), dtype=np.int64), nxt, h=h, half_open=False, eps_parallel=1e-12,
        eps_param=1e-9, eps_sin=1e-7, eps_len=1e-12 * scale, eps_h=1e-12 * scale)
    return (e1, e2, d), P, (x, y, h), starts, nxt, seg_a, s_a, seg_b, s_b, flag


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


def project(closed_curves, direction=None, *, seed: int = 0, n_directions: int = 6,
            max_tries: int = 50) -> Diagram:
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
