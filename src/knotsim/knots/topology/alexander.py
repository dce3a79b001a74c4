"""Alexander polynomial and knot determinant (Fox calculus on the Wirtinger presentation).

Determinants are exact: evaluated modulo several large primes (numba kernels) and reconstructed with
the Chinese remainder theorem.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from knotsim.knots.topology.curves import TopologyError
from knotsim.knots.topology.simplify import simplify_pd


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
        for r in range(m):  # (a slice assignment costs seconds of first-run compile time)
            for c in range(m):
                A[r, c] = A0[b, r, c]
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
