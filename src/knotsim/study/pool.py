"""A local pool of worker processes in which a dead worker costs only its own case.

:class:`concurrent.futures.ProcessPoolExecutor` marks the whole pool broken when one worker dies
(an out-of-memory kill, a segfault, ``kill -9``): every pending case fails with it. Here every
worker process has its own pipe and runs one case at a time, so the parent knows which case each
worker holds. When a worker dies, that case's future fails with :class:`WorkerLost` (naming the
process and the signal or exit code) and a fresh worker takes the next cases.

>>> pool = CasePool(2)
>>> fut = pool.submit(execute_case, payload, study_dir, base_dir)    # a concurrent.futures.Future
>>> pool.shutdown()

Workers are ``spawn``ed, start with :func:`knotsim.study._worker.init_worker` (one BLAS thread,
die with the parent on Linux) and are replaced after ``max_cases_per_worker`` cases when given.
A background thread starts the workers, hands out the cases and collects the results.
"""

from __future__ import annotations

import collections
import multiprocessing
import os
import signal
import threading
import traceback
from concurrent.futures import Future
from multiprocessing.connection import wait

__all__ = ["CasePool", "WorkerLost"]

_THREAD_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
_ENV_LOCK = threading.Lock()


class WorkerLost(RuntimeError):
    """The worker process running a case died (``exitcode``: negative signal number or exit code)."""

    def __init__(self, pid: int, exitcode: int | None):
        self.pid, self.exitcode = pid, exitcode
        if exitcode is not None and exitcode < 0:
            try:
                how = f"was killed by signal {signal.Signals(-exitcode).name}"
            except ValueError:
                how = f"was killed by signal {-exitcode}"
        else:
            how = f"exited with code {exitcode}"
        super().__init__(f"the worker process (pid {pid}) {how} while running this case")


class RemoteError(RuntimeError):
    """An exception raised inside a worker by the function it ran (its traceback in the message)."""


class _Worker:
    def __init__(self, process, conn):
        self.process, self.conn = process, conn
        self.future: Future | None = None
        self.cases = 0


class CasePool:
    """``n`` worker processes (see the module docstring); :meth:`submit` returns a
    :class:`~concurrent.futures.Future`."""

    def __init__(self, n: int, max_cases_per_worker: int | None = None):
        self._n = int(n)
        self._max = max_cases_per_worker
        self._ctx = multiprocessing.get_context("spawn")
        self._queue: collections.deque = collections.deque()
        self._workers: list[_Worker] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._kill = False
        self._thread = threading.Thread(target=self._manage, name="knotsim-case-pool", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ public
    def submit(self, fn, *args) -> Future:
        """Run ``fn(*args)`` in a worker (``fn`` and ``args`` must pickle)."""
        fut: Future = Future()
        with self._lock:
            if self._stop.is_set():
                raise RuntimeError("the case pool is shut down")
            self._queue.append((fut, fn, args))
        return fut

    def shutdown(self, wait: bool = True, cancel_futures: bool = False) -> None:
        """Stop the pool: with ``wait`` after the submitted cases finished, else at once (running
        workers are killed; their futures and, with ``cancel_futures``, the queued ones cancelled)."""
        if wait and not cancel_futures:
            with self._lock:
                pending = [f for f, _, _ in self._queue] + [w.future for w in self._workers if w.future]
            for f in pending:
                try:
                    f.exception()
                except BaseException:
                    pass
        with self._lock:
            if cancel_futures or not wait:
                while self._queue:
                    self._queue.popleft()[0].cancel()
            self._kill = not wait
            self._stop.set()
        self._thread.join()

    # ------------------------------------------------------------------ manager thread
    def _start_worker(self) -> None:
        parent, child = self._ctx.Pipe(duplex=True)
        proc = self._ctx.Process(target=worker_main, args=(child, os.getpid()), daemon=True)
        with _ENV_LOCK:  # inherited by the spawned worker before it imports numpy
            old = {v: os.environ.get(v) for v in _THREAD_ENV}
            os.environ.update({v: "1" for v in _THREAD_ENV})
            try:
                proc.start()
            finally:
                for v, val in old.items():
                    if val is None:
                        os.environ.pop(v, None)
                    else:
                        os.environ[v] = val
        child.close()
        self._workers.append(_Worker(proc, parent))

    def _manage(self) -> None:
        try:
            while not self._stop.is_set():
                self._round()
        except BaseException as exc:  # never leave futures hanging
            with self._lock:
                items = [f for f, _, _ in self._queue] + [w.future for w in self._workers if w.future]
                self._queue.clear()
            for f in items:
                if not f.done():
                    f.set_exception(RuntimeError(f"case pool failed: {type(exc).__name__}: {exc}"))
        finally:
            self._close_workers()

    def _round(self) -> None:
        with self._lock:
            queued = len(self._queue)
        busy = sum(w.future is not None for w in self._workers)
        while len(self._workers) < min(self._n, busy + queued):
            self._start_worker()
        for w in self._workers:
            if w.future is not None:
                continue
            with self._lock:
                if not self._queue:
                    break
                fut, fn, args = self._queue.popleft()
            if not fut.set_running_or_notify_cancel():
                continue
            w.conn.send((fn, args))
            w.future = fut
        handles = [w.conn for w in self._workers] + [w.process.sentinel for w in self._workers]
        if handles:
            wait(handles, timeout=0.05)
        else:
            self._stop.wait(0.05)
        for w in list(self._workers):
            self._collect(w)

    def _collect(self, w: _Worker) -> None:
        """Take a finished result from ``w``; detect its death."""
        try:
            if w.conn.poll():
                status, value = w.conn.recv()
                fut, w.future = w.future, None
                w.cases += 1
                if fut is not None:
                    if status == "ok":
                        fut.set_result(value)
                    else:
                        fut.set_exception(RemoteError(value))
                if self._max is not None and w.cases >= self._max:
                    self._retire(w)
                return
        except (EOFError, OSError):
            pass
        if not w.process.is_alive():
            w.process.join()
            if w.future is not None:
                w.future.set_exception(WorkerLost(w.process.pid, w.process.exitcode))
                w.future = None
            w.conn.close()
            self._workers.remove(w)

    def _retire(self, w: _Worker) -> None:
        try:
            w.conn.send(None)
        except OSError:
            pass
        w.process.join(timeout=10)
        if w.process.is_alive():
            w.process.kill()
            w.process.join()
        w.conn.close()
        self._workers.remove(w)

    def _close_workers(self) -> None:
        for w in list(self._workers):
            if self._kill:
                w.process.kill()
                if w.future is not None:
                    w.future.cancel() or w.future.set_exception(RuntimeError("the study was stopped"))
            else:
                try:
                    w.conn.send(None)
                except OSError:
                    pass
        for w in list(self._workers):
            w.process.join(timeout=None if not self._kill else 5)
            w.conn.close()
        self._workers.clear()


def run_in_worker(conn, fn, args) -> None:
    """Run ``fn(*args)`` and send ``("ok", result)`` or ``("error", traceback text)`` on ``conn``."""
    try:
        result = ("ok", fn(*args))
    except BaseException as exc:  # reported to the parent as the case's error
        result = ("error", "".join(traceback.format_exception(exc)))
    conn.send(result)


def worker_main(conn, parent_pid: int) -> None:
    """Main loop of a :class:`CasePool` worker process: receive ``(fn, args)`` on ``conn``, send back
    the outcome, until ``None`` arrives or the pipe closes."""
    from knotsim.study._worker import init_worker

    init_worker(parent_pid)
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        run_in_worker(conn, *msg)
