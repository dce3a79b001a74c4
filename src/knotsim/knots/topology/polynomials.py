"""Laurent polynomials as ``dict`` exponent -> int coefficient (Kauffman bracket, Jones, Alexander).

Exponents are ints (powers of ``A`` in the bracket, of ``t`` in Jones and Alexander polynomials) or
``fractions.Fraction`` halves (Jones polynomials of links with an even number of components).
"""

from __future__ import annotations

from fractions import Fraction

from knotsim.knots.topology.curves import TopologyError


def _pmul(p: dict, q: dict) -> dict:
    """Product of two Laurent polynomials (zero coefficients dropped)."""
    r: dict = {}
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


def _mirror(v: dict) -> dict:
    return dict(sorted((-e, c) for e, c in v.items()))


def _jones_key(v: dict) -> tuple:
    return tuple(sorted((Fraction(e), int(c)) for e, c in v.items() if c))


def _pmul_jones(p: dict, q: dict) -> dict:
    """Product of two Jones polynomials (int or ``Fraction`` exponents), sorted by exponent."""
    return dict(sorted(_pmul(p, q).items()))


def _alex_mul(a: list[int], b: list[int]) -> list[int]:
    r = [0] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            r[i + j] += x * y
    return r
