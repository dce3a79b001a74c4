"""Critical friction by bisection (:func:`knotsim.critical_friction`): the bracket logic on a known
threshold, the hold decision from the rope's motion, the inputs, and the command line."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import knotsim as ks
from knotsim.errors import ConfigError
from knotsim.study.critical import holds


def fake_runner(mu_c, calls):
    """A knot that holds exactly when μ >= mu_c (slips by running away below)."""

    def run(mu):
        calls.append(mu)
        ok = mu >= mu_c
        return {"outcome": "held" if ok else "slipped",
                "metrics": {"slip_onset": None if ok else {"time": 1.0}, "decidable": True,
                            "drift_pull": 1e-6 if ok else 0.3, "drift_pull_late": 1e-6 if ok else 0.2,
                            "drift_through_late": 1e-6 if ok else 0.2}}

    return run


@pytest.mark.parametrize("mu_c", [0.137, 0.05001, 0.7999])
def test_bisection_brackets_the_threshold(mu_c):
    calls = []
    res = ks.critical_friction("reef_bend", 0.004, mu_low=0.05, mu_high=0.8, tol=0.01,
                               runner=fake_runner(mu_c, calls))
    assert res.mu_slip < mu_c <= res.mu_hold and res.width <= 0.01
    assert abs(res.mu_c - mu_c) <= 0.005
    assert [r["mu"] for r in res.runs] == calls and calls[:2] == [0.8, 0.05]
    assert len(calls) <= 2 + 7  # log2(0.75 / 0.01) < 7 halvings


def test_open_brackets():
    res = ks.critical_friction("reef_bend", 0.004, runner=fake_runner(0.9, []))
    assert res.mu_hold is None and res.mu_slip is None and res.mu_c is None and len(res.runs) == 1
    res = ks.critical_friction("reef_bend", 0.004, runner=fake_runner(0.01, []))
    assert res.mu_hold == 0.05 and res.mu_slip is None and res.mu_c is None and len(res.runs) == 2


def test_hold_is_decided_by_motion():
    base = {"outcome": "held", "metrics": {"slip_onset": None, "decidable": True, "drift_pull": 3e-3,
                                           "drift_pull_late": 2e-4, "drift_through_late": 2e-4}}

    def with_(**metrics):
        return {**base, "metrics": {**base["metrics"], **metrics}}

    assert holds(base, 1e-3)  # the take-up in the first half of the hold does not count
    assert not holds(with_(drift_pull_late=2e-3, drift_through_late=2e-3), 1e-3)  # rope let through
    # the loaded end out while the tails stay (the knot changing shape): no rope passed through
    assert holds(with_(drift_pull_late=2e-3, drift_tails_late=0.0, drift_through_late=0.0), 1e-3)
    assert not holds(with_(drift_through_late=None), 1e-3)  # not measured
    assert holds(with_(drift_pull_late=-5e-3, drift_through_late=-5e-3), 1e-3)  # drawn in: settling
    assert not holds({**base, "outcome": "untied"}, 1e-3)
    assert not holds({**base, "outcome": "capsized"}, 1e-3)
    assert not holds(with_(capsize_onset={"time": 2.0, "force": 0.004, "rope": "a"}), 1e-3)
    assert not holds(with_(slip_onset={"time": 3.0, "criterion": "runaway"}), 1e-3)
    with pytest.raises(ConfigError, match="load_time"):
        holds(with_(decidable=False), 1e-3)


@pytest.mark.parametrize("kw, field", [({"load": 0.0}, "load"), ({"load": 1.0, "tol": -1}, "tol"),
                                       ({"load": 1.0, "mu_low": 0.9}, "mu_low")])
def test_bad_inputs(kw, field):
    with pytest.raises(ConfigError, match=rf"^{field}:"):
        ks.critical_friction("reef_bend", runner=fake_runner(0.2, []), **kw)


def test_command_line(monkeypatch):
    import knotsim.study.critical as critical

    real = critical.critical_friction

    def fake(knot, load, **kw):
        kw.pop("overrides")
        kw.pop("quick")
        return real(knot, load, runner=fake_runner(0.3, []), **kw)

    monkeypatch.setattr(critical, "critical_friction", fake)
    from knotsim.cli import main

    out = CliRunner().invoke(main, ["critical-mu", "reef_bend", "--load", "0.004", "--tol", "0.05", "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.output)
    assert data["mu_slip"] < 0.3 <= data["mu_hold"]
    out = CliRunner().invoke(main, ["critical-mu", "reef_bend", "--load", "0.004", "--tol", "0.05"])
    assert "mu_c = " in out.output and "holds" in out.output
