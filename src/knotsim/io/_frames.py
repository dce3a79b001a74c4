"""Helpers of :mod:`knotsim.io.trajectory`: the rod layout check, frame selection and lazy frame views."""

from __future__ import annotations

from typing import Any

import h5py
import numpy as np

from knotsim.errors import ConfigError


def _validate_layout(
    rod_node_start: Any, rod_edge_start: Any, rod_closed: Any, rod_radius: Any, rod_names: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """Check and normalise the rod layout arrays; raise :class:`ConfigError` when inconsistent."""
    node_start = np.asarray(rod_node_start, dtype=np.int64).reshape(-1)
    edge_start = np.asarray(rod_edge_start, dtype=np.int64).reshape(-1)
    closed = np.asarray(rod_closed, dtype=bool).reshape(-1)
    radius = np.asarray(rod_radius, dtype=np.float64).reshape(-1)
    n_rods = node_start.size - 1
    if n_rods < 1:
        raise ConfigError("rod_node_start", f"needs n_rods+1 >= 2 entries, got {node_start.size}")
    if node_start[0] != 0 or np.any(np.diff(node_start) < 2):
        raise ConfigError(
            "rod_node_start",
            f"must start at 0 and increase by at least 2 nodes per rod, got {node_start.tolist()}",
        )
    if edge_start.shape != node_start.shape or edge_start[0] != 0:
        raise ConfigError(
            "rod_edge_start", f"must have {n_rods + 1} entries starting at 0, got {edge_start.tolist()}"
        )
    if closed.shape != (n_rods,):
        raise ConfigError("rod_closed", f"must have {n_rods} entries, got {closed.size}")
    if radius.shape != (n_rods,) or not np.all(np.isfinite(radius)) or np.any(radius <= 0):
        raise ConfigError("rod_radius", f"must be {n_rods} positive finite radii (m), got {radius.tolist()}")
    n_nodes = np.diff(node_start)
    expected_edges = np.where(closed, n_nodes, n_nodes - 1)
    if not np.array_equal(np.diff(edge_start), expected_edges):
        raise ConfigError(
            "rod_edge_start",
            f"edge counts {np.diff(edge_start).tolist()} do not match node counts {n_nodes.tolist()} "
            f"(an open rod with N nodes has N-1 edges, a closed one N)",
        )
    if rod_names is None:
        names = [f"rod{r}" for r in range(n_rods)]
    else:
        names = [str(s) for s in rod_names]
        if len(names) != n_rods:
            raise ConfigError("rod_names", f"must have {n_rods} names, got {len(names)}")
    return node_start, edge_start, closed, radius, names


class _LazyFrames:
    """Read-only view of a frame-major HDF5 dataset restricted to selected frames.

    Indexing with ``[i]``, ``[i, ...]``, slices or integer arrays on the first axis reads only
    the requested frames from disk; ``np.asarray(view)`` reads all selected frames.
    """

    def __init__(self, dataset: h5py.Dataset, frame_indices: np.ndarray):
        self._ds = dataset
        self._idx = frame_indices

    @property
    def shape(self) -> tuple[int, ...]:
        return (self._idx.size, *self._ds.shape[1:])

    @property
    def dtype(self) -> np.dtype:
        return self._ds.dtype

    @property
    def ndim(self) -> int:
        return self._ds.ndim

    def __len__(self) -> int:
        return int(self._idx.size)

    def __getitem__(self, key: Any) -> np.ndarray:
        first, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        sel = self._idx[first]
        if np.ndim(sel) == 0:
            return self._ds[(int(sel), *rest)]
        sel = np.asarray(sel, dtype=np.int64)
        if sel.size == 0:
            return np.empty((0, *self._ds.shape[1:]), dtype=self._ds.dtype)[(slice(None), *rest)]
        # h5py fancy indexing needs increasing, unique indices
        uniq, inverse = np.unique(sel, return_inverse=True)
        if uniq[-1] - uniq[0] + 1 == uniq.size:  # contiguous: one hyperslab read
            data = self._ds[int(uniq[0]) : int(uniq[-1]) + 1]
        else:
            data = self._ds[uniq.tolist()]
        return data[inverse][(slice(None), *rest)]

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        out = self[:]
        return out if dtype is None else out.astype(dtype)


def _select_frames(frames: Any, n: int) -> np.ndarray:
    """File frame indices selected by ``frames`` (None, int, slice or sequence of ints)."""
    if frames is None:
        return np.arange(n, dtype=np.int64)
    if isinstance(frames, slice):
        return np.arange(n, dtype=np.int64)[frames]
    if isinstance(frames, str):
        raise ConfigError("frames", f"must be None, an int, a slice or a sequence of ints, got {frames!r}")
    sel = np.asarray(frames)
    if sel.dtype == bool or (sel.size and not np.issubdtype(sel.dtype, np.integer)):
        raise ConfigError("frames", f"must be None, an int, a slice or a sequence of ints, got {frames!r}")
    sel = sel.astype(np.int64).reshape(-1)
    bad = (sel < -n) | (sel >= n)
    if np.any(bad):
        raise ConfigError("frames", f"indices {sel[bad].tolist()} out of range for {n} frames in the file")
    return sel % n if n else sel
