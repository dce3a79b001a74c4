"""StepLog: the packed per-step log reads back as the list of dicts it was given."""

import numpy as np
import pandas as pd
import pytest

from knotsim.solver.steplog import HOT_ROWS, StepLog


def _rows(n: int) -> list[dict]:
    rng = np.random.default_rng(1)
    rows = []
    for i in range(n):
        r = {"time": i * 0.1, "iterations": int(rng.integers(1, 5)), "residual": float(rng.random()),
             "k_c": np.float64(2.5)}
        if i > 300:
            r["stage"] = "pull" if i % 2 else "hold"
        if i % 7 == 0:
            r["sparse_int"] = i
        if i > 600:
            r["flag"] = bool(i % 3)
        if i > 700:
            r["always_bool"] = True
        rows.append(r)
    return rows


def test_rows_and_frame_match_a_list_of_dicts():
    rows = _rows(3 * HOT_ROWS + 17)
    log = StepLog()
    for r in rows:
        log.append(dict(r))
    log[-1].update({"late": 3.0})  # the newest row is live (protocol callbacks add entries)
    rows[-1]["late"] = 3.0
    assert len(log) == len(rows)
    assert log._n_cold >= HOT_ROWS  # rows were packed
    assert list(log) == rows
    assert log[0] == rows[0] and log[-1] == rows[-1] and log[5] == rows[5]
    assert log[10:13] == rows[10:13] and log[-3:] == rows[-3:]
    assert type(log[0]["iterations"]) is int and type(log[0]["time"]) is float
    pd.testing.assert_frame_equal(log.to_frame(), pd.DataFrame(rows))
    with pytest.raises(IndexError):
        log[len(rows)]


def test_empty_and_short_logs():
    assert StepLog().to_frame().empty
    rows = _rows(5)
    pd.testing.assert_frame_equal(StepLog(rows).to_frame(), pd.DataFrame(rows))


def test_packed_log_is_small():
    """A packed row of 8 numbers costs well under the ~1 kB of a dict of Python floats."""
    log = StepLog()
    for i in range(20 * HOT_ROWS):
        log.append({f"c{k}": float(i + k) for k in range(8)})
    packed = sum(a.nbytes + (m.nbytes if m is not None else 0) for _, cols in log._chunks for a, m in cols.values())
    assert packed / log._n_cold <= 8 * 8 + 1


def test_uniform_rows_of_every_kind_of_value():
    """Rows with the same keys (packed by transposing): each column keeps its kind, as in pandas."""
    rows = []
    for i in range(2 * HOT_ROWS + 40):
        rows.append({"time": i * 0.1, "n": i, "np_float": np.float64(i) / 3, "np_int": np.int64(i),
                     "flag": bool(i % 2), "np_flag": np.bool_(i % 3 == 0), "stage": "pull" if i % 5 else "hold",
                     "mixed": 1 if i % 4 else 2.5,
                     "bool_and_int": True if i % 2 else 7})
    log = StepLog()
    for r in rows:
        log.append(dict(r))
    assert log._n_cold >= HOT_ROWS and log._chunks
    assert list(log) == rows
    assert type(log[0]["n"]) is int and type(log[0]["flag"]) is bool and type(log[0]["stage"]) is str
    frame = log.to_frame()
    pd.testing.assert_frame_equal(frame, pd.DataFrame(rows))
    assert frame["flag"].dtype == bool and frame["n"].dtype == np.int64 and frame["mixed"].dtype == float


def test_one_column_and_empty_rows():
    rows = [{"time": 0.1 * i} for i in range(2 * HOT_ROWS + 3)] + [{} for _ in range(2 * HOT_ROWS + 3)]
    log = StepLog(rows)
    assert list(log) == rows
    pd.testing.assert_frame_equal(log.to_frame(), pd.DataFrame(rows))
