"""The single-rod protocol's pre-tightening knob (``pre_pull``) and the ``single_rod`` validate case."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from tests.processes import map_in_processes

from knotsim.errors import ConfigError
from knotsim.protocols import run_protocol
from knotsim.protocols.single_rod_bend import SingleRodBend, pre_pull_time


def test_pre_pull_default_is_off():
    assert SingleRodBend.defaults["pre_pull"] == 0.0
    assert SingleRodBend.defaults["pre_pull_speed"] is None
    assert pre_pull_time({"pre_pull": 0.0, "pre_pull_speed": None, "pull_speed": 0.01}) == 0.0
    assert pre_pull_time({"pre_pull": 0.42, "pre_pull_speed": None, "pull_speed": 0.01}) == pytest.approx(21.0)
    assert pre_pull_time({"pre_pull": 0.3, "pre_pull_speed": 0.05, "pull_speed": 0.01}) == pytest.approx(3.0)
    with pytest.raises(ConfigError, match="pre_pull"):
        pre_pull_time({"pre_pull": -0.1, "pre_pull_speed": None, "pull_speed": 0.01})
    with pytest.raises(ConfigError, match="pre_pull_speed"):
        pre_pull_time({"pre_pull": 0.1, "pre_pull_speed": 0.0, "pull_speed": 0.01})


def test_pre_pull_moves_the_ends_then_measures_the_window(tmp_path):
    out = tmp_path / "pre"
    s = run_protocol("single-rod-bend", "single_rod_reef", out_dir=out, quick=True,
                     overrides={"pre_pull": 0.1, "pre_pull_speed": 0.025, "mean_window": 0.5, "duration": None,
                                "settle_time": 0.0})  # (the pre-pull's own timing: no settling first)
    # (at 50 mm/s per end this N = 101 knot sits on the edge of untying: whether it holds then
    # depends on round-off in the linear solver, so the test pre-pulls at 25 mm/s)
    assert s["run_status"] == "completed"
    m = s["metrics"]
    assert m["pre_pull_time"] == pytest.approx(2.0)
    assert s["parameters"]["duration"] == pytest.approx(2.5)  # t_pre + mean_window
    log = pd.read_parquet(out / "log.parquet")
    t, tp, e2e = (log[c].to_numpy() for c in ("time", "t_pull", "end_to_end"))
    np.testing.assert_allclose(tp, t - 2.0)
    e0 = e2e[0] - 2 * 0.025 * t[0]
    # the ends separate at 2 x 25 mm/s for 2 s, then at 2 x 10 mm/s (the published pull speed, which
    # --quick keeps)
    expect = e0 + np.where(t <= 2.0, 0.05 * t, 0.1 + 0.02 * (t - 2.0))
    np.testing.assert_allclose(e2e, expect, atol=1e-9)
    assert m["end_to_end_at_window_start"] == pytest.approx(e0 + 0.1, abs=1e-3)
    assert math.isfinite(m["F_norm_mean"]) and m["mean_window"] == 0.5
    assert s["topology"]["end"]["knot_type"] == s["topology"]["start"]["knot_type"]


def _fake_summary(knot_type, f_final, pen=0.01, status="completed"):
    topo = {"knot_type": knot_type, "signature": knot_type}
    return {"run_status": status, "topology": {"start": topo, "end": dict(topo)},
            "contact": {"worst_penetration_ratio": pen},
            "metrics": {"F_norm_final": f_final, "end_to_end_at_window_start": 0.787, "mean_window": 3.0}}


def test_single_rod_validate_case_rows(monkeypatch):
    import knotsim.protocols as P
    from knotsim.validation.cases import CASES
    from knotsim.validation.single_rod import JAMMED_REFERENCE, QUICK, single_rod_bend

    assert CASES["single_rod_bend"] is single_rod_bend
    calls = []

    def fake(name, knot, overrides=None, quick=False, **kw):
        calls.append((name, knot, dict(overrides)))
        k = knot.split("_")[-1]
        return _fake_summary(k, JAMMED_REFERENCE[(k, True)] * 1.3)

    monkeypatch.setattr(P, "run_protocol", fake)
    rows = single_rod_bend(quick=True)
    assert [c[1] for c in calls] == ["single_rod_reef", "single_rod_granny"]
    assert all(c[2]["n_nodes"] == QUICK["n_nodes"] and c[2]["mu"] == 0.1 for c in calls)
    assert len(rows) == 6 and all(r["passed"] for r in rows), rows
    assert {"case", "quantity", "value", "reference", "error", "tolerance", "passed", "wall_time"} <= set(rows[0])

    # failures: knot type changed, deep penetration, no load / non-finite force
    def bad(name, knot, overrides=None, quick=False, **kw):
        s = _fake_summary("reef", float("nan") if "granny" in knot else 1e-4, pen=0.5)
        s["topology"]["end"] = {"knot_type": "unknot", "signature": "unknot"}
        return s

    monkeypatch.setattr(P, "run_protocol", bad)
    rows = single_rod_bend(quick=True)
    assert not any(r["passed"] for r in rows)


def _pull(job: tuple[str, float]) -> dict:
    """One full single-rod pull in a worker process: its summary."""
    kind, pre_pull = job
    res = run_protocol("single-rod-bend", f"single_rod_{kind}",
                       overrides={"mu": 0.1, "pre_pull": pre_pull, "contact.friction_model": "centreline"})
    return {k: res[k] for k in ("run_status", "knot_status", "contact", "metrics")}


@pytest.mark.slow
def test_reef_above_granny_with_each_knots_slack():
    """The headline MAE259B comparison at full size (N = 301, mu = 0.1; about 60 s, the two side by side): with each knot's
    slack fixed by the published coincidence at 5 s (reef 0.42 m, granny 0.36 m of pre-pull, both
    at F h^2/EI ~ 0.05 there), the curves part after 5 s with the reef above the granny and the
    reef's 13 s mean is higher (measured 0.144 / 0.0959 = 1.50; published 1.39)."""
    # the published comparison is of the IMC friction law (docs/physics.md §3.1)
    res = dict(zip(("reef", "granny"), map_in_processes(_pull, [("reef", 0.42), ("granny", 0.36)]), strict=True))
    for s in res.values():
        assert s["run_status"] == "completed" and s["knot_status"] == "held"
        assert s["contact"]["worst_penetration_ratio"] <= 0.01
        assert 0.035 <= s["metrics"]["F_norm_at_5s"] <= 0.07
    reef, granny = (res[k]["metrics"] for k in ("reef", "granny"))
    for t in ("7.5s", "10s", "12.5s"):
        assert reef[f"F_norm_at_{t}"] > 1.2 * granny[f"F_norm_at_{t}"], t
    assert reef["F_norm_mean"] > 1.2 * granny["F_norm_mean"]
