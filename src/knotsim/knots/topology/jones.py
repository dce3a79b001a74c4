"""Kauffman bracket (planar contraction algorithm) and the Jones polynomial."""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from knotsim.knots.topology.curves import TopologyError
from knotsim.knots.topology.polynomials import _DELTA, _padd_into, _pdiv_delta, _pmul, _ppow
from knotsim.knots.topology.simplify import simplify_pd


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
