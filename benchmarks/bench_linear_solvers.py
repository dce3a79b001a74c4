"""Benchmark of sparse direct solvers on rod Jacobians (band + contact chords).

Run with ``python benchmarks/bench_linear_solvers.py`` (``--quick`` for fewer cases). Set
``OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1`` first (the script does it if they are unset).

Matrices: one open rod of ``N`` nodes (``n = 4N - 1`` unknowns, DOF layout of
``docs/architecture.md``); the band part is the sum of random symmetric ``11 x 11`` stencil blocks over
DOFs ``4(i-1) .. 4(i+1)+2`` plus a mass/dt^2 diagonal; each contact pair of edges ``(a, a+1)``,
``(b, b+1)`` adds a dense ``12 x 12`` block on the 4 nodes' positions (symmetric stiffness plus a
non-symmetric friction part). Two contact layouts: ``random`` (pairs of random distant edges, the
worst case for fill) and ``knot`` (runs of neighbouring pairs between strands inside a region of 90
nodes, as in a tight knot).

Timed per case (best of many runs after warm-up, in ms):

* ``splu_mmd``: ``splu(A, permc_spec="MMD_AT_PLUS_A")`` + solve;
* ``splu_colamd``: ``splu(A, permc_spec="COLAMD")`` + solve;
* ``splu_rcm``: values permuted by a precomputed RCM map, ``splu(.., "NATURAL")`` + solve;
* ``solve_banded`` (no contacts only): ``scipy.linalg.solve_banded`` on a prebuilt band array;
* ``fplu``: :class:`knotsim.solver.lu.FixedPatternLU` ``factorize`` + ``solve`` (the
  analyse time, done once per pattern, is reported separately as ``analyse_ms``);
* ``fplu_up``: the same with the tests' reference up-looking LU
  (``tests/solver/reference_lu.py``: scalar, no dense blocks).

Prints a table and ends with one JSON line ``{"results": [...]}``.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
from scipy.linalg import solve_banded  # noqa: E402
from scipy.sparse.csgraph import reverse_cuthill_mckee  # noqa: E402
from scipy.sparse.linalg import splu  # noqa: E402

from knotsim.solver.lu import FixedPatternLU  # noqa: E402

# the tests' reference LU, under the module name pytest gives it (numba's cache records that name)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from solver.reference_lu import UpLookingLU  # noqa: E402

HALF_BW = 10


def contact_pairs(
    n_nodes: int, n_contacts: int, layout: str, rng: np.random.Generator
) -> list[tuple[int, int]]:
    """Pairs ``(a, b)`` of edge indices (``a < b``, ``b - a >= 4``) in contact."""
    n_edges = n_nodes - 1
    pairs: set[tuple[int, int]] = set()
    if layout == "random":
        while len(pairs) < n_contacts:
            a, b = sorted(int(v) for v in rng.integers(0, n_edges, 2))
            if b - a >= 4:
                pairs.add((a, b))
        return sorted(pairs)
    region = min(90, n_edges)
    s0 = (n_edges - region) // 2
    while len(pairs) < n_contacts:
        a0 = s0 + int(rng.integers(0, region - 6))
        b0 = s0 + int(rng.integers(0, region - 6))
        sgn = int(rng.choice([-1, 1]))
        if abs(a0 - b0) < 8:
            continue
        for t in range(int(rng.integers(3, 7))):
            a, b = a0 + t, b0 + sgn * t
            if s0 <= b < s0 + region and len(pairs) < n_contacts:
                pairs.add((min(a, b), max(a, b)))
    return sorted(pairs)


def rod_jacobian(n_nodes: int, n_contacts: int, layout: str = "random", seed: int = 0) -> sp.csc_matrix:
    """Synthetic Newton Jacobian ``(4N-1, 4N-1)`` CSC with sorted indices, no duplicates."""
    rng = np.random.default_rng(seed)
    n = 4 * n_nodes - 1
    rows, cols, vals = [], [], []

    def add(dofs: np.ndarray, block: np.ndarray) -> None:
        r, c = np.meshgrid(dofs, dofs, indexing="ij")
        rows.append(r.ravel())
        cols.append(c.ravel())
        vals.append(block.ravel())

    for i in range(1, n_nodes - 1):
        dofs = np.arange(4 * (i - 1), 4 * (i + 1) + 3)
        g = rng.standard_normal((11, 11))
        add(dofs, g + g.T)
    for a, b in contact_pairs(n_nodes, n_contacts, layout, rng):
        dofs = np.concatenate([np.arange(4 * k, 4 * k + 3) for k in (a, a + 1, b, b + 1)])
        g = rng.standard_normal((12, 12))
        add(dofs, g + g.T + 0.3 * rng.standard_normal((12, 12)))
    rows.append(np.arange(n))
    cols.append(np.arange(n))
    vals.append(np.full(n, 30.0) + 5.0 * rng.random(n))  # mass / dt^2
    A = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    A = A.tocsc()
    A.sum_duplicates()
    A.sort_indices()
    return A


def best_time(fn, min_reps: int = 5, budget: float = 0.25) -> float:
    """Best wall time of ``fn()`` in ms after one warm-up call (at most ``budget`` s of repeats)."""
    fn()
    best = np.inf
    t_start = time.perf_counter()
    reps = 0
    while reps < min_reps or (time.perf_counter() - t_start < budget and reps < 2000):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
        reps += 1
    return best * 1e3


def residual(A, x, b) -> float:
    return float(np.linalg.norm(A @ x - b) / np.linalg.norm(b))


def bench_case(n_nodes: int, n_contacts: int, layout: str, budget: float) -> list[dict]:
    A = rod_jacobian(n_nodes, n_contacts, layout)
    n = A.shape[0]
    b = np.random.default_rng(1).standard_normal(n)
    out: list[dict] = []

    def record(method, fn, analyse_ms=None):
        x = fn()
        res = residual(A, x, b)
        ms = best_time(fn, budget=budget)
        out.append(
            dict(
                n_nodes=n_nodes,
                n=n,
                contacts=n_contacts,
                layout=layout,
                method=method,
                ms=round(ms, 4),
                analyse_ms=None if analyse_ms is None else round(analyse_ms, 4),
                residual=res,
            )
        )

    record("splu_mmd", lambda: splu(A, permc_spec="MMD_AT_PLUS_A").solve(b))
    record("splu_colamd", lambda: splu(A, permc_spec="COLAMD").solve(b))

    # RCM computed once; per iteration only the values are permuted through a precomputed map
    p = reverse_cuthill_mckee(A + A.T, symmetric_mode=True)
    idx = sp.csc_matrix((np.arange(1, A.nnz + 1, dtype=np.float64), A.indices, A.indptr), shape=A.shape)
    P = idx[p][:, p].tocsc()
    P.sort_indices()
    vmap = P.data.astype(np.int64) - 1

    def rcm_solve():
        B = sp.csc_matrix((A.data[vmap], P.indices, P.indptr), shape=A.shape)
        y = splu(B, permc_spec="NATURAL").solve(b[p])
        x = np.empty_like(y)
        x[p] = y
        return x

    record("splu_rcm", rcm_solve)

    if n_contacts == 0:
        ab = np.zeros((2 * HALF_BW + 1, n))
        Acoo = A.tocoo()
        ab[HALF_BW + Acoo.row - Acoo.col, Acoo.col] = Acoo.data
        record("solve_banded", lambda: solve_banded((HALF_BW, HALF_BW), ab, b, check_finite=False))

    for cls, name in ((FixedPatternLU, "fplu"), (UpLookingLU, "fplu_up")):
        cls(n, A.indptr, A.indices)  # compile / warm caches
        analyse_ms = best_time(lambda c=cls: c(n, A.indptr, A.indices), min_reps=3, budget=budget / 2)
        lu = cls(n, A.indptr, A.indices)
        xo = np.empty(n)
        record(name, lambda lu=lu, xo=xo: lu.factorize_solve(A.data, b, out=xo), analyse_ms)
    return out


def main(argv: list[str]) -> int:
    quick = "--quick" in argv
    sizes = (101, 301) if quick else (101, 301, 1001)
    contacts = (0, 50) if quick else (0, 20, 50, 100)
    budget = 0.1 if quick else 0.3
    results: list[dict] = []
    methods = ["splu_mmd", "splu_colamd", "splu_rcm", "solve_banded", "fplu", "fplu_up"]
    header = f"{'N':>5} {'n':>5} {'cont':>4} {'layout':>6} | " + " ".join(f"{m:>12}" for m in methods)
    header += f" | {'fplu_an':>8} {'max_res':>8}"
    print(
        "times in ms (best of many): factorize + solve; fplu_an = FixedPatternLU analyse (once per pattern)"
    )
    print(header)
    print("-" * len(header))
    for n_nodes in sizes:
        for nc in contacts:
            for layout in ("random", "knot") if nc else ("none",):
                if layout == "knot" and nc > 4 * min(90, n_nodes - 1):
                    continue
                rows = bench_case(n_nodes, nc, "random" if layout == "none" else layout, budget)
                for r in rows:
                    r["layout"] = layout
                results.extend(rows)
                by = {r["method"]: r for r in rows}
                cells = " ".join(f"{by[m]['ms']:12.3f}" if m in by else f"{'-':>12}" for m in methods)
                worst = max(r["residual"] for r in rows)
                print(
                    f"{n_nodes:5d} {rows[0]['n']:5d} {nc:4d} {layout:>6} | {cells} | "
                    f"{by['fplu']['analyse_ms']:8.3f} {worst:8.1e}"
                )
    bad = [r for r in results if not r["residual"] < 1e-10]
    if bad:
        print(f"RESIDUAL CHECK FAILED for {len(bad)} runs", file=sys.stderr)
    print(json.dumps({"results": results}))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
