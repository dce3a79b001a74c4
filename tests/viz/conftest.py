"""Small protocol runs shared by the picture tests (each made once per session, a few seconds)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def reef_run(tmp_path_factory):
    """knot-security on reef_bend, quick, a short set (no preliminary run) and 1 s of load: its
    timeline has the set's end, the slow slip's onset and the decision (about 9 s)."""
    from knotsim.protocols import run_protocol

    out = tmp_path_factory.mktemp("pictures") / "reef"
    run_protocol("knot-security", "reef_bend", out_dir=out, quick=True,
                 overrides={"load_time": 1.0, "set_until_still": False})
    return out


@pytest.fixture(scope="session")
def overhand_run(tmp_path_factory):
    """overhand-pull on overhand_n1, quick: one rope, no key events in its timeline (about 6 s)."""
    from knotsim.protocols import run_protocol

    out = tmp_path_factory.mktemp("pictures") / "overhand"
    run_protocol("overhand-pull", "overhand_n1", out_dir=out, quick=True)
    return out
