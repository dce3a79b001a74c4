"""Code that runs inside a worker process (local pool or Dask worker): :func:`execute_case`, the
case a worker runs, and the set-up of a worker process (:func:`init_worker`; the local pool's
main loop is :func:`knotsim.study.pool.worker_main`).

Kept free of heavy imports at module level so that :func:`init_worker` can pin the BLAS thread
count before numpy is imported in a freshly spawned process.
"""

from __future__ import annotations

import os

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
