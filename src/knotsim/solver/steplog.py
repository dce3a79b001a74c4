"""The per-step log of a run, stored by columns: a list of dicts to its users, a few hundred bytes
a step in memory.

:class:`StepLog` is what :attr:`knotsim.simulation.Simulation.rows` holds: one row (a dict of
numbers and strings) per accepted step. The newest rows stay plain dicts, so that a callback can
still add entries to ``rows[-1]``; older rows are packed into one numpy array per column and
chunk (8 bytes a number instead of the 2-3 kB of a dict of Python floats, so that a long run's
memory does not grow with its log). Reading an old row gives a new dict (changing it does not
change the log). :meth:`StepLog.to_frame` gives the table that ``pandas.DataFrame(list_of_rows)``
would give: columns in order of first appearance, a missing entry as NaN, integer columns as
integers.
"""

from __future__ import annotations

import operator
from collections.abc import Iterator, Sequence
from itertools import repeat

import numpy as np

__all__ = ["StepLog"]

#: Rows kept as dicts: at least ``HOT_ROWS``, at most ``2 * HOT_ROWS`` (the oldest ``HOT_ROWS``
#: are packed together when there are more).
HOT_ROWS = 256

_MISSING = object()


_BOOL = (bool, np.bool_)
_NUMBER = (int, float, np.integer, np.floating)


def _column(values: list, complete: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """``(array, present)`` of one column of a chunk: ``values`` may contain ``_MISSING``
    (``present`` is then a bool mask, else ``None``; ``complete``: the caller knows it does not).
    Numbers (and numpy scalars) give a numeric array, anything else an object array."""
    present = None
    if not complete and any(map(operator.is_, values, repeat(_MISSING))):
        present = np.array([v is not _MISSING for v in values])
        fill = next(v for v in values if v is not _MISSING)
        values = [fill if v is _MISSING else v for v in values]
    # decided by the types present (a few), not value by value
    types = set(map(type, values))
    if all(issubclass(t, _BOOL) for t in types):
        arr = np.array(values, dtype=bool)
    elif all(issubclass(t, _NUMBER) and not issubclass(t, _BOOL) for t in types):
        arr = np.array(values)
        if arr.dtype.kind not in "if":
            arr = np.array(values, dtype=object)
    else:
        arr = np.empty(len(values), dtype=object)
        arr[:] = values
    return arr, present


def _columns(rows: list[dict]) -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
    """``{key: _column(...)}`` of ``rows``, keys in order of first appearance."""
    keys = list(rows[0])
    if len(keys) > 1 and all(r.keys() == rows[0].keys() for r in rows):
        # the usual case, every row with the same keys: one pass over the rows, columns by transposing
        cols = zip(*map(operator.itemgetter(*keys), rows), strict=True)
        return {key: _column(list(col), complete=True) for key, col in zip(keys, cols, strict=True)}
    order: dict[str, None] = {}
    for r in rows:
        for key in r:
            order.setdefault(key)
    return {key: _column([r.get(key, _MISSING) for r in rows]) for key in order}


def _value(arr: np.ndarray, i: int):
    """Entry ``i`` of a packed column as the Python value it was stored as."""
    v = arr[i]
    return v.item() if isinstance(v, np.generic) else v


class StepLog(Sequence):
    """Rows of the per-step log (see the module docstring). ``append(row)``, ``len``, indexing
    and slicing (rows as dicts), iteration, :meth:`to_frame`."""

    def __init__(self, rows=()):
        self._hot: list[dict] = []
        #: packed chunks: ``(n_rows, {key: (array, present mask or None)})``
        self._chunks: list[tuple[int, dict]] = []
        self._n_cold = 0
        self._order: dict[str, None] = {}  # keys of the packed rows in order of first appearance
        for r in rows:
            self.append(r)

    def append(self, row: dict) -> None:
        """Add the row of a step (a dict; it stays a live dict while it is among the newest)."""
        self._hot.append(row)
        if len(self._hot) > 2 * HOT_ROWS:
            self._pack(HOT_ROWS)

    def _pack(self, k: int) -> None:
        rows, self._hot = self._hot[:k], self._hot[k:]
        cols = _columns(rows)
        for key in cols:
            self._order.setdefault(key)
        self._chunks.append((len(rows), cols))
        self._n_cold += len(rows)

    def __len__(self) -> int:
        return self._n_cold + len(self._hot)

    def _cold_row(self, i: int) -> dict:
        for n, cols in self._chunks:
            if i < n:
                out = {}
                for key, (arr, present) in cols.items():
                    if present is None or present[i]:
                        out[key] = _value(arr, i)
                return out
            i -= n
        raise IndexError(i)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        n = len(self)
        i = int(index)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError(f"step log index {index} out of range ({n} rows)")
        if i >= self._n_cold:
            return self._hot[i - self._n_cold]
        return self._cold_row(i)

    def __iter__(self) -> Iterator[dict]:
        for i in range(self._n_cold):
            yield self._cold_row(i)
        yield from self._hot

    def to_frame(self):
        """The log as a ``pandas.DataFrame``, one row per step (as ``pandas.DataFrame(list(self))``)."""
        import pandas as pd

        chunks = list(self._chunks)
        order = dict(self._order)
        if self._hot:
            cols = _columns(self._hot)
            chunks.append((len(self._hot), cols))
            for key in cols:
                order.setdefault(key)
        if not chunks:
            return pd.DataFrame([])
        data = {}
        for key in order:
            parts, masks, missing = [], [], False
            for n, cols in chunks:
                if key in cols:
                    arr, present = cols[key]
                    parts.append(arr)
                    masks.append(present if present is not None else np.ones(n, bool))
                    missing = missing or present is not None
                else:
                    parts.append(np.zeros(n))
                    masks.append(np.zeros(n, bool))
                    missing = True
            kinds = {p.dtype.kind for p, m in zip(parts, masks, strict=True) if m.any()}
            if kinds == {"b"} and not missing:
                col = np.concatenate(parts)
            elif kinds <= {"i", "f"} and kinds:
                col = np.concatenate([p if m.any() else np.zeros(p.shape[0], p.dtype if kinds == {"i"} else float)
                                      for p, m in zip(parts, masks, strict=True)])
                if missing:
                    col = col.astype(float)
                    col[~np.concatenate(masks)] = np.nan
            else:
                col = np.concatenate([p.astype(object) for p in parts])
                if missing:
                    col[~np.concatenate(masks)] = np.nan
            data[key] = col
        return pd.DataFrame(data)
