"""Benchmark of the contact broad phase on a tightly packed tangle.

One long open rod (edge length 3.3 mm, radius 1.6 mm) is coiled as a persistent random walk
confined to a ball sized for a rod volume fraction of about 30 %, so almost every edge has many
neighbours within the cut-off (``2 h + extra``, extra = 2.5 mm). For each size the call is timed
(best of several after a warm-up) and a table plus one JSON line are printed.

Run: ``python benchmarks/bench_broadphase.py``
"""

from __future__ import annotations

import json
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from knotsim.contact.broadphase import find_candidate_pairs  # noqa: E402

EDGE = 3.3e-3  # m
RADIUS = 1.6e-3  # m
EXTRA = 2.5e-3  # m (delta + margin)
VOLUME_FRACTION = 0.3
SIZES = (300, 1000, 3000, 10000)
REPEATS = 7


def tangle(n_edges, seed=0):
    """Node positions (n_edges + 1, 3) m of a persistent random walk confined to a ball."""
    rng = np.random.default_rng(seed)
    rod_volume = n_edges * np.pi * RADIUS**2 * EDGE
    ball = (3.0 * rod_volume / (4.0 * np.pi * VOLUME_FRACTION)) ** (1.0 / 3.0)
    pts = np.empty((n_edges + 1, 3))
    pts[0] = 0.0
    d = np.array([1.0, 0.0, 0.0])
    noise = rng.normal(size=(n_edges, 3))
    for k in range(n_edges):
        d = d + 0.6 * noise[k]
        d /= np.linalg.norm(d)
        nxt = pts[k] + EDGE * d
        r = np.linalg.norm(nxt)
        if r > ball:  # reflect the direction off the confining sphere
            nrm = nxt / r
            d = d - 2.0 * np.dot(d, nrm) * nrm
            nxt = pts[k] + EDGE * d
        pts[k + 1] = nxt
    return pts


def model_arrays(pts):
    """Global arrays of one open rod through ``pts`` (layout of docs/architecture.md)."""
    n = len(pts)
    ne = n - 1
    q = np.zeros(4 * n - 1)
    for k in range(3):
        q[k::4] = pts[:, k]
    edge_dofs = np.column_stack([4 * np.arange(ne), 4 * np.arange(1, n)]).astype(np.int64)
    return (
        q,
        edge_dofs,
        np.zeros(ne, dtype=np.int64),
        np.arange(ne, dtype=np.int64),
        np.array([ne], dtype=np.int64),
        np.array([False]),
        np.full(ne, RADIUS),
    )


def main():
    results = []
    print(f"{'n_edges':>8} {'pairs':>9} {'pairs/edge':>10} {'ms':>9} {'us/edge':>8}")
    for ne in SIZES:
        args = model_arrays(tangle(ne))
        pairs = find_candidate_pairs(*args, EXTRA)  # warm-up (compiles or loads the cache)
        best = np.inf
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            pairs = find_candidate_pairs(*args, EXTRA)
            best = min(best, time.perf_counter() - t0)
        ms = best * 1e3
        print(f"{ne:>8} {len(pairs):>9} {len(pairs) / ne:>10.1f} {ms:>9.3f} {1e3 * ms / ne:>8.2f}")
        results.append({"n_edges": ne, "ms": round(ms, 4), "pairs": len(pairs)})
    print(json.dumps({"results": results}))


if __name__ == "__main__":
    main()
