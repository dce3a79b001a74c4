"""The ``bends`` validate case (reef holds, grief slips): rows and pass/fail logic on synthetic runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd


def _fake_run(draw_rate: dict, force: dict, pen: float = 0.0, status: str = "held", calls=None):
    def fake(name, knot, out_dir=None, overrides=None, **kw):
        if calls is not None:
            calls.append((name, knot, dict(overrides)))
        ov = overrides
        t = np.linspace(0.0, ov["duration"], 81)
        tails = 0.6 - draw_rate[knot] * ov["pull_speed"] * t
        log = pd.DataFrame({"time": t, "tail_a": tails / 2, "tail_b": tails / 2,
                            "F_norm": np.full_like(t, force[knot])})
        log.to_parquet(Path(out_dir) / "log.parquet")
        return {"run_status": "completed", "knot_status": status, "contact": {"worst_penetration_ratio": pen}}

    return fake


def test_bends_case_registered_and_rows(monkeypatch):
    import knotsim.protocols as P
    from knotsim.validation.bends import bends
    from knotsim.validation.cases import CASES

    assert CASES["bends"] is bends
    calls = []
    monkeypatch.setattr(P, "run_protocol", _fake_run({"reef_bend": 0.0, "grief_bend": 1.0},
                                                     {"reef_bend": 3e-3, "grief_bend": 4e-4}, calls=calls))
    rows = bends(quick=True)
    assert [c[1] for c in calls] == ["reef_bend", "grief_bend"]
    assert all(c[0] == "two-rope-bend" and c[2]["mode"] == "displacement" and c[2]["mu"] == 0.3 for c in calls)
    assert len(rows) == 7 and all(r["passed"] for r in rows), rows
    assert {"case", "quantity", "value", "reference", "error", "tolerance", "passed", "wall_time"} <= set(rows[0])
    assert abs(rows[1]["value"] - 1.0) < 1e-9  # grief draw-in rate = pull speed
    assert abs(rows[2]["value"] - 7.5) < 1e-9  # force ratio


def test_bends_case_failures(monkeypatch):
    import knotsim.protocols as P
    from knotsim.validation.bends import bends

    # reef slips, grief holds, grief carries more, deep penetration, untied
    monkeypatch.setattr(P, "run_protocol", _fake_run({"reef_bend": 1.0, "grief_bend": 0.0},
                                                     {"reef_bend": 1e-3, "grief_bend": 4e-3}, pen=0.5, status="untied"))
    rows = bends(quick=True)
    assert not any(r["passed"] for r in rows), rows
