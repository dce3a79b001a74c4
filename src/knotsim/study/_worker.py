"""Code that runs inside a worker process (local pool or Dask worker).

Kept free of heavy imports at module level so that :func:`init_worker` can pin the BLAS thread
count before numpy is imported in a freshly spawned process.

Fault injection for tests: when the environment variable ``KNOTSIM_TEST_KILL_CASE`` holds a
comma-separated list of case ids, the worker that starts one of those cases kills itself with
SIGKILL once the case's temporary directory exists (:func:`knotsim.study.store.run_case_atomically`) (what an out-of-memory kill or ``kill -9`` does), so that the tests can check that a dead
worker costs only its own case.
"""

from __future__ import annotations

import os

#: Environment variable of the fault injection (see the module docstring).
KILL_CASE_VAR = "KNOTSIM_TEST_KILL_CASE"

_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS",
                "VECLIB_MAXIMUM_THREADS", "NUMBA_NUM_THREADS")


def pin_threads() -> None:
    """One BLAS / OpenMP / numba thread in this process (env vars, plus threadpoolctl when installed)."""
    for var in _THREAD_VARS:
        os.environ[var] = "1"
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return
    threadpool_limits(1)


def init_worker(parent_pid: int | None = None) -> None:
    """Initializer of local pool workers: pin threads; on Linux die with the parent process, so that
    killing a study (even with SIGKILL) also stops its workers."""
    pin_threads()
    if parent_pid is None:
        return
    try:
        import ctypes
        import signal
        import sys

        if sys.platform.startswith("linux"):
            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except Exception:  # best effort only
        pass
    if os.getppid() != parent_pid:  # parent died before prctl took effect
        os._exit(1)


def execute_case(case: dict, study_dir: str, base_dir: str) -> dict:
    """Run one case (a :meth:`knotsim.study.spec.Case.to_dict`) and store it in
    ``study_dir/cases/<case_id>/``; returns its record (the content of its ``result.json``).

    Never raises for a failing case: the error and traceback are recorded with outcome
    ``"failed"``.
    """
    pin_threads()
    from knotsim.study.store import run_case_atomically

    return run_case_atomically(case, study_dir, base_dir)


def worker_main(conn, parent_pid: int) -> None:
    """Main loop of a :class:`knotsim.study.pool.CasePool` worker: receive ``(fn, args)`` on
    ``conn``, send back the outcome, until ``None`` arrives or the pipe closes."""
    init_worker(parent_pid)
    from knotsim.study.pool import run_in_worker

    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        run_in_worker(conn, *msg)


def fault_injection(case_id: str) -> None:
    """Kill this process with SIGKILL when ``case_id`` is listed in ``KNOTSIM_TEST_KILL_CASE``."""
    kill = os.environ.get(KILL_CASE_VAR)
    if kill and case_id in kill.split(","):
        import signal

        os.kill(os.getpid(), signal.SIGKILL)
