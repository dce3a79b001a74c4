"""Fault injection for tests: when the environment variable ``KNOTSIM_TEST_KILL_CASE`` holds a
comma-separated list of case ids, the worker that starts one of those cases kills itself with
SIGKILL once the case's temporary directory exists (:func:`knotsim.study.store.run_case_atomically`;
what an out-of-memory kill or ``kill -9`` does), so that the tests can check that a dead worker
costs only its own case."""

from __future__ import annotations

import os

#: Environment variable of the fault injection (see the module docstring).
KILL_CASE_VAR = "KNOTSIM_TEST_KILL_CASE"


def fault_injection(case_id: str) -> None:
    """Kill this process with SIGKILL when ``case_id`` is listed in ``KNOTSIM_TEST_KILL_CASE``."""
    kill = os.environ.get(KILL_CASE_VAR)
    if kill and case_id in kill.split(","):
        import signal

        os.kill(os.getpid(), signal.SIGKILL)
