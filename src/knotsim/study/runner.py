"""Running the cases of a study: local worker processes or a Dask distributed cluster.

>>> df = run_study("examples/studies/bends.toml", "studies/bends", workers=2)
>>> df = run_study("study.toml", "studies/x", scheduler="tcp://10.0.0.1:8786", resume=True)

Local runs use a :class:`knotsim.study.pool.CasePool` of ``spawn``ed worker processes, each
running one case at a time with one BLAS thread; the workers die with the study process, and a
worker that dies (``kill -9``, out of memory, segfault) costs only the case it was running
(recorded ``worker lost``; a fresh worker takes the next cases). On a Dask cluster every worker must be able to import knotsim and to write into
``STUDY_DIR`` (a shared file system).
"""

from __future__ import annotations

import os
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass

from knotsim.errors import ConfigError
from knotsim.study.spec import Case, Study, load_study_spec
from knotsim.study.store import StudyLock, StudyStore

__all__ = ["Progress", "plan_study", "run_study"]


@dataclass
class Progress:
    """State of a running study, passed to the ``progress`` callback of :func:`run_study`.

    ``total``: cases of the study; ``reused``: finished before this session (resume);
    ``done`` / ``failed``: finished in this session (``failed`` included in ``done``);
    ``running``: cases being run (estimate: busy worker slots); ``elapsed`` and ``eta`` in s
    (``eta`` is ``None`` until a case finished); ``last``: record of the case that just finished,
    if any.
    """

    total: int
    todo: int
    reused: int = 0
    done: int = 0
    failed: int = 0
    running: int = 0
    elapsed: float = 0.0
    eta: float | None = None
    last: dict | None = None


def plan_study(study, study_dir, *, resume: bool = False, retry_failed: bool = False):
    """Expand ``study`` and find what is left to run in ``study_dir``.

    Returns ``(spec, cases, reused_records, todo)``.
    """
    spec = study if isinstance(study, Study) else load_study_spec(study)
    cases = spec.expand()
    store = StudyStore(study_dir)
    if store.exists() and not resume:
        raise ConfigError("study_dir", f"{str(study_dir)!r} already holds a study; pass --resume (resume=True) "
                          "to run only its missing cases, or choose a new directory")
    finished = store.finished() if resume else {}
    ids = {c.case_id for c in cases}
    reused = {cid: rec for cid, rec in finished.items() if cid in ids}
    if retry_failed:
        reused = {cid: rec for cid, rec in reused.items() if rec.get("outcome") != "failed"}
    todo = [c for c in cases if c.case_id not in reused]
    return spec, cases, reused, todo


def run_study(
    study: str | os.PathLike | dict | Study,
    study_dir: str | os.PathLike,
    *,
    workers: int | None = None,
    scheduler=None,
    resume: bool = False,
    retry_failed: bool = False,
    max_cases_per_worker: int | None = None,
    progress: Callable[[Progress], None] | None = None,
    session: dict | None = None,
    worker_timeout: float = 300.0,
):
    """Run every case of ``study`` into ``study_dir``; returns the results table (pandas DataFrame).

    Parameters
    ----------
    study:
        Study file (TOML path), dict, or :class:`~knotsim.study.spec.Study`.
    study_dir:
        Results directory (see :mod:`knotsim.study.store`).
    workers:
        Local worker processes (default: the number of CPUs, at most the number of cases).
    scheduler:
        Address of a Dask scheduler (``"tcp://host:8786"``), or a ``distributed.Client`` or
        cluster object: run there instead of locally.
    resume:
        Continue an existing study directory: only cases without a finished case directory run.
        Without it an existing study directory is an error.
    retry_failed:
        With ``resume``, run failed cases again too.
    max_cases_per_worker:
        Local pool only: replace a worker process after this many cases (``1``: a fresh process per
        case; default: never).
    progress:
        Called with a :class:`Progress` about every 0.2 s and after each finished case.
    session:
        Extra information recorded in this session's entry of ``provenance.json``.
    worker_timeout:
        Dask only: when the cluster has had no worker for this long (s), the cases still pending
        are recorded ``worker lost`` and the study ends instead of waiting for ever. A case whose
        worker leaves the cluster while running it (killed, with or without a nanny) is recorded
        ``worker lost`` at once (within about a second); the other cases go on. A finished case
        whose result stays unfetchable for this long (its worker left before the result was
        fetched) is recorded ``worker lost`` too.

    A failing case (any exception) is recorded with outcome ``"failed"``, its error and traceback;
    the other cases go on. A worker process that dies takes only its case with it: the case is
    reported failed (``worker lost: ...``) in the table but has no case directory, so ``resume``
    runs it again. With ``resume``, case directories whose ``result.json`` is missing, truncated
    or not a case record are discarded and run again (listed under ``corrupt_cases_rerun`` in the
    session's provenance entry). The session holds ``STUDY_DIR/.lock``
    (:class:`~knotsim.study.store.StudyLock`): a second session on the same directory is refused.
    """
    spec, cases, reused, todo = plan_study(study, study_dir, resume=resume, retry_failed=retry_failed)
    with StudyLock(study_dir):
        # planned again under the lock: another session may have finished cases meanwhile
        spec, cases, reused, todo = plan_study(spec, study_dir, resume=resume, retry_failed=retry_failed)
        return _run_locked(spec, cases, reused, todo, study_dir, workers, scheduler, resume, retry_failed,
                           max_cases_per_worker, progress, session, worker_timeout)


def _run_locked(spec, cases, reused, todo, study_dir, workers, scheduler, resume, retry_failed,
                max_cases_per_worker, progress, session, worker_timeout):
    store = StudyStore(study_dir)
    store.cleanup()
    corrupt = store.corrupt() if resume else {}
    ids = {c.case_id for c in cases}
    for cid in corrupt:  # truncated or invalid result.json: run the case again
        if cid in ids:
            store.discard(cid)
    if retry_failed:
        todo_ids = {c.case_id for c in todo}
        for cid, rec in store.finished().items():
            if cid in todo_ids and rec.get("outcome") == "failed":
                store.discard(cid)
    backend = "dask" if scheduler is not None else "local"
    store.prepare(spec, session={"backend": backend, "scheduler": _address(scheduler), "workers": workers,
                                 "resume": resume, "cases": len(cases), "to_run": len(todo),
                                 **({"corrupt_cases_rerun": corrupt} if corrupt else {}), **(session or {})})
    records = dict(reused)
    store.write_results(cases, records)
    state = Progress(total=len(cases), todo=len(todo), reused=len(reused))
    t0 = time.perf_counter()
    # the thinned logs of the reused cases: the study's timeseries.parquet, their case directories
    series = {cid: df for cid, df in store.series_by_case([c for c in reused if store.case_dir(c).is_dir()]).items()
              if cid in reused}
    loop = _Loop(store, cases, records, state, progress, t0, series)
    if todo:
        if backend == "local":
            _run_local(todo, loop, spec, workers, max_cases_per_worker)
        else:
            _run_dask(todo, loop, spec, scheduler, worker_timeout)
    df = loop.save()
    store.finish_session(completed=int(state.done - state.failed), failed=int(state.failed),
                         wall_time=time.perf_counter() - t0)
    return df


def _address(scheduler) -> str | None:
    if scheduler is None or isinstance(scheduler, str):
        return scheduler
    return getattr(scheduler, "scheduler_address", None) or str(scheduler)


def _payload(case: Case) -> dict:
    return case.to_dict()


def _lost(case: Case, exc: BaseException) -> dict:
    """Record of a case whose worker failed (no case directory: resume runs it again)."""
    import traceback

    return {"case_id": case.case_id, "kind": case.kind, "params": case.params, "repeat": case.repeat,
            "outcome": "failed", "error": f"worker lost: {type(exc).__name__}: {exc}",
            "traceback": "".join(traceback.format_exception(exc)), "wall_time": None, "metrics": {},
            "host": None}


class _Loop:
    """Polls futures, records finished cases, writes the table and the time series (the one writer
    of ``results.parquet`` and ``timeseries.parquet``: the workers write only their case
    directories) and reports progress."""

    def __init__(self, store, cases, records, state, progress, t0, series):
        self.store, self.cases, self.records, self.state = store, cases, records, state
        self.progress, self.t0, self.series = progress, t0, series
        self.slots: Callable[[], int] = lambda: 1
        self._last_write = 0.0

    def finish(self, case: Case, record: dict) -> None:
        self.records[case.case_id] = record
        if record.get("outcome") == "completed":
            own = self.store.case_series(case.case_id)
            if own is not None:
                self.series[case.case_id] = own
        self.state.done += 1
        self.state.failed += record.get("outcome") == "failed"
        self.state.last = record

    def save(self):
        """Write ``results.parquet`` and ``timeseries.parquet`` (in study order); returns the table."""
        self.store.write_series({c.case_id: self.series[c.case_id] for c in self.cases if c.case_id in self.series})
        return self.store.write_results(self.cases, self.records)

    def tick(self, pending: int, changed: bool) -> None:
        now = time.perf_counter()
        st = self.state
        st.elapsed = now - self.t0
        st.running = min(self.slots(), pending)
        st.eta = st.elapsed * (st.todo - st.done) / st.done if st.done else None
        if changed and now - self._last_write > 1.0:
            self.save()
            self._last_write = now
        if self.progress is not None:
            self.progress(st)
        st.last = None

    def run(self, futures: dict, result, watch=None) -> None:
        """Wait for ``futures`` (``{future: case}``); ``watch(pending)`` (optional, called every
        round) returns ``{future: exception}`` of cases whose worker was lost."""
        pending = dict(futures)
        self.tick(len(pending), False)
        while pending:
            if watch is not None:
                for f, exc in watch(pending).items():
                    case = pending.pop(f, None)
                    if case is not None:
                        self.finish(case, _lost(case, exc))
                        self.tick(len(pending), True)
            finished = [f for f in pending if f.done()]
            for f in finished:
                case = pending.pop(f)
                try:
                    rec = result(f)
                except Exception as exc:
                    rec = _lost(case, exc)
                self.finish(case, rec)
                self.tick(len(pending), True)
            if not finished:
                time.sleep(0.2)
                self.tick(len(pending), False)


def _run_local(todo, loop, spec, workers, max_cases_per_worker):
    from knotsim.study._worker import execute_case
    from knotsim.study.pool import CasePool

    store = loop.store
    n = workers if workers is not None else (os.cpu_count() or 1)
    if not isinstance(n, int) or n < 1:
        raise ConfigError("workers", f"must be a positive integer, got {workers!r}")
    n = min(n, len(todo))
    if max_cases_per_worker is not None and (not isinstance(max_cases_per_worker, int) or max_cases_per_worker < 1):
        raise ConfigError("max_cases_per_worker", f"must be a positive integer, got {max_cases_per_worker!r}")
    pool = CasePool(n, max_cases_per_worker)
    loop.slots = lambda: n
    try:
        futures = {pool.submit(execute_case, _payload(c), str(store.path.resolve()), str(spec.base_dir)): c
                   for c in todo}
        loop.run(futures, lambda f: f.result())
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        loop.save()
        raise
    pool.shutdown(wait=True)


def _run_dask(todo, loop, spec, scheduler, worker_timeout):
    try:
        from distributed import Client
    except ImportError as exc:
        raise ConfigError("scheduler", f"running on a Dask cluster needs dask.distributed ({exc}): "
                          "pip install knotsim[dask]") from None
    from knotsim.study._worker import execute_case

    own = False
    if isinstance(scheduler, Client):
        client = scheduler
    else:
        address = getattr(scheduler, "scheduler_address", scheduler)
        try:
            client = Client(address, timeout="20s")
        except (OSError, ValueError, TypeError) as exc:  # unreachable, or a malformed address
            raise ConfigError("scheduler", f"cannot connect to the Dask scheduler at {address!r}: {exc}; give "
                                           "tcp://HOST:PORT") from None
        own = True
    cache = {"t": 0.0, "n": 1}

    def slots() -> int:
        now = time.perf_counter()
        if now - cache["t"] > 5.0:
            try:
                cache["n"] = max(1, sum(client.nthreads().values()))
            except Exception:
                pass
            cache["t"] = now
        return cache["n"]

    token = uuid.uuid4().hex[:8]
    store = loop.store
    loop.slots = slots
    futures = {}
    try:
        for c in todo:
            f = client.submit(execute_case, _payload(c), str(store.path.resolve()), str(spec.base_dir),
                              key=f"knotsim-case-{c.case_id}-{token}", pure=False, retries=0)
            futures[f] = c
        loop.run(futures, lambda f: _dask_result(f, worker_timeout), _DaskWatch(client, worker_timeout, store.started))
    except BaseException:
        client.cancel(list(futures))
        loop.save()
        raise
    finally:
        if own:
            client.close()


class DaskWorkerLost(RuntimeError):
    """The Dask worker running a case left the cluster, or no worker was left to run it."""


def _dask_result(future, timeout: float):
    """The result of a finished Dask ``future``, or :class:`DaskWorkerLost` when it cannot be had
    within ``timeout`` s: a case that finished on a worker that then left the cluster (killed
    before its result was fetched) has its result only on that worker, and fetching it would wait
    for ever for a worker to recompute it."""
    try:
        return future.result(timeout=timeout)
    except TimeoutError as exc:
        raise DaskWorkerLost(f"no Dask worker gave the result of this finished case within {timeout:g} s "
                             "(the worker holding it left the cluster)") from exc


class _DaskWatch:
    """Finds the cases of a Dask study whose worker was lost (see :func:`run_study`).

    Every 0.5 s it asks the scheduler which worker processes which case; a case last seen on a
    worker that has left the cluster (killed, out of memory, restarted by its nanny) and that had
    started there (``started(case)``: its ``cases/.tmp-*`` directory exists) is lost; a case only
    queued there is left to the scheduler. A started case that no worker processes on two looks in
    a row lost its worker between two looks. When
    the cluster has had no worker for ``timeout`` s, every pending case is lost."""

    def __init__(self, client, timeout: float, started):
        self.client, self.timeout, self.started = client, float(timeout), started
        self.on: dict = {}  # key -> worker address where it was last seen processing
        self._next = 0.0
        self._empty_since: float | None = None
        self._orphan: dict = {}

    def __call__(self, pending: dict) -> dict:
        now = time.monotonic()
        if now < self._next:
            return {}
        self._next = now + 0.5
        try:
            processing = self.client.processing()
            workers = set(self.client.scheduler_info().get("workers", {}))
        except Exception:  # scheduler busy or unreachable: try again next round
            return {}
        busy = set()
        for addr, keys in processing.items():
            for key in keys:
                self.on[key] = addr
                busy.add(key)
        lost = {}
        for f, case in pending.items():
            addr = self.on.get(f.key)
            if f.done() or not self.started(case):
                if addr is not None and addr not in workers:  # only queued there: the scheduler reassigns it
                    del self.on[f.key]
                continue
            if addr is not None and addr not in workers:
                lost[f] = DaskWorkerLost(f"the Dask worker {addr} left the cluster while running this case")
            elif f.key not in busy:  # started, yet processed nowhere: its worker died between two looks
                if self._orphan.get(f.key, 0) >= 1 and not f.done():
                    lost[f] = DaskWorkerLost("the Dask worker running this case left the cluster")
                self._orphan[f.key] = self._orphan.get(f.key, 0) + 1
        if workers:
            self._empty_since = None
        elif self._empty_since is None:
            self._empty_since = now
        elif now - self._empty_since >= self.timeout:
            for f in pending:
                lost.setdefault(f, DaskWorkerLost(f"no Dask worker in the cluster for {self.timeout:g} s"))
        if lost:
            self.client.cancel(list(lost))
        return lost
