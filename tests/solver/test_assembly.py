"""Sparse pattern assembly: the fast merge equals scipy's union of blocks."""

from __future__ import annotations

import numpy as np

from knotsim.solver import assembly as asm


def test_merge_pattern_matches_scipy_union():
    rng = np.random.default_rng(0)
    n = 60
    base = [np.stack([np.arange(i, i + 5) for i in range(0, n - 5, 3)])]
    indptr_e, indices_e = asm.csc_pattern(n, base)
    extra = rng.integers(0, n, size=(7, 6))
    indptr, indices, remap = asm.merge_pattern(n, indptr_e, indices_e, extra)
    ref_ptr, ref_idx = asm.csc_pattern(n, base + [extra])
    np.testing.assert_array_equal(indptr, ref_ptr)
    np.testing.assert_array_equal(indices, ref_idx)
    # every old slot maps to the same (row, col) in the merged pattern
    cols_e = np.repeat(np.arange(n), np.diff(indptr_e))
    cols = np.repeat(np.arange(n), np.diff(indptr))
    np.testing.assert_array_equal(indices[remap], indices_e)
    np.testing.assert_array_equal(cols[remap], cols_e)
