"""Results store of a study: one directory, resumable, with provenance.

Layout of ``STUDY_DIR``::

    study.toml          the study as run (base case inlined)
    results.parquet     one row per finished case
    provenance.json     versions, git commit, machine, one entry per session (run / resume)
    timeseries.parquet  each finished case's log thinned to one row per 0.05 s (plus its events):
                        ``case_id``, ``time`` and the protocol's own columns (:mod:`knotsim.study.series`)
    cases/<case_id>/    one directory per finished case:
        case.json       kind, swept parameters, resolved configuration
        result.json     outcome, error, traceback, wall time (s), metrics, host (written last)
        summary.json    a protocol case's summary (metrics, parameters, timeline, ...)
        timeseries.parquet  the case's thinned log (gathered into the study's timeseries.parquet)
        error.txt       traceback of a failed case
        ...             the case's own outputs (trajectory.h5, log.parquet, run.json, ...)
    cases/.tmp-*        cases being run (never read as results)
    cases.parquet       a packed study (:func:`pack_study`): the case.json, result.json and
                        summary.json of every finished case, one row each, in place of cases/
    .lock               held by the session running the study (:class:`StudyLock`)

A case directory is written under a temporary name and renamed when ``result.json`` is in it, so a
directory ``cases/<case_id>`` is always complete; killing a study (even with SIGKILL) loses only
the cases that were running. A packed study reopens (:func:`load_study`, ``knotsim report``) and
resumes like one with case directories: its finished cases are read from ``cases.parquet``, and a
case run again (``--retry-failed``) gets a directory, whose record wins over the packed one.

Columns of ``results.parquet``: ``case_id``, ``kind``, every swept parameter by its dotted key
(lists as JSON text), ``repeat`` (only with repeats), ``outcome`` (``"completed"`` or
``"failed"``), ``error``, ``wall_time`` (s, the whole case), every metric of the case's record (a
metric whose name clashes with one of these columns is prefixed ``metric.``; a protocol case's
``friction_model``, ``"surface"`` or ``"centreline"``, is one of them, and a record written before
knotsim had surface friction reads as ``"centreline"``, the law it ran), ``traceback`` and
``case_dir`` (relative to ``STUDY_DIR``; of a packed case, the directory it had before packing).

Columns of ``cases.parquet``: ``case_id``, ``kind``, ``outcome``, and ``case``, ``record`` and
``summary``, the JSON text of the case's ``case.json``, ``result.json`` and ``summary.json`` (``None``
when the case had none, e.g. a failed or a plain run case).
"""

from __future__ import annotations

import json
import math
import os
import platform
import shutil
import socket
import subprocess
import time
import traceback
import uuid
from pathlib import Path

from knotsim._util.jsonio import json_safe, read_json, write_json
from knotsim._util.toml import write_toml

__all__ = ["StudyLock", "StudyStore", "load_study", "pack_study", "provenance_info", "record_problem",
           "run_case_atomically"]

CASES = "cases"
PACK = "cases.parquet"
SERIES = "timeseries.parquet"
SUMMARY = "summary.json"
TMP_PREFIX = ".tmp-"
RECORD = "result.json"
LOCK = ".lock"
_RESERVED = ("case_id", "kind", "repeat", "outcome", "error", "wall_time", "traceback", "case_dir")
_DEPENDENCIES = ("numpy", "scipy", "numba", "h5py", "pandas", "pyarrow", "click", "matplotlib", "pillow",
                 "dask", "distributed")


# ------------------------------------------------------------------------------------------ helpers
def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# ------------------------------------------------------------------------------------------ one case
def run_case_atomically(case: dict, study_dir: str | os.PathLike, base_dir: str | os.PathLike) -> dict:
    """Run ``case`` into ``cases/.tmp-<id>-<host>-<pid>-<rand>/`` and rename it ``cases/<id>`` once
    ``result.json`` is written. Returns the record (``result.json``'s content).

    If ``cases/<id>`` already exists (another worker finished the same case first), the new
    directory is discarded and the existing record returned.
    """
    from knotsim._version import __version__
    from knotsim.study._faults import fault_injection
    from knotsim.study.executors import get_executor

    cases_dir = Path(study_dir) / CASES
    final = cases_dir / case["case_id"]
    existing = _read_summary(final)
    if existing is not None:
        return existing
    host = socket.gethostname()
    tmp = cases_dir / f"{TMP_PREFIX}{case['case_id']}-{host}-{os.getpid()}-{uuid.uuid4().hex[:6]}"
    tmp.mkdir(parents=True)
    write_json(tmp / "case.json", case)
    fault_injection(case["case_id"])  # tests only (KNOTSIM_TEST_KILL_CASE)
    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    t0 = time.perf_counter()
    metrics: dict = {}
    error = tb = None
    try:
        metrics = get_executor(case["kind"])(case["config"], tmp, Path(base_dir))
        outcome = "completed"
        _write_case_series(tmp, case)
    except Exception as exc:  # a failing case never stops the others
        outcome = "failed"
        error = f"{type(exc).__name__}: {exc}"
        tb = traceback.format_exc()
        (tmp / "error.txt").write_text(tb)
    record = {
        "case_id": case["case_id"],
        "kind": case["kind"],
        "params": case["params"],
        "repeat": case.get("repeat", 0),
        "outcome": outcome,
        "error": error,
        "traceback": tb,
        "wall_time": time.perf_counter() - t0,
        "metrics": metrics,
        "host": host,
        "pid": os.getpid(),
        "knotsim_version": __version__,
        "started": started,
        "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    write_json(tmp / RECORD, record, fsync=True)
    _fsync_dir(tmp)
    try:
        os.rename(tmp, final)
    except OSError:
        done = _read_summary(final)
        if done is None:
            # a corrupt directory of this case (no valid record): replace it by the new one
            StudyStore(study_dir).discard(case["case_id"])
            os.rename(tmp, final)
        else:
            shutil.rmtree(tmp, ignore_errors=True)
            return done
    _fsync_dir(cases_dir)
    return json_safe(record)  # what result.json holds


def _write_case_series(case_dir: Path, case: dict) -> None:
    """The case's thinned log (``timeseries.parquet``, :mod:`knotsim.study.series`) next to its
    ``log.parquet``; a log that cannot be read costs the series, never the case."""
    from knotsim.study.series import write_case_series

    config = case.get("config") or {}
    protocol = config.get("protocol") if isinstance(config, dict) else None
    try:
        summary = read_json(case_dir / SUMMARY) if (case_dir / SUMMARY).is_file() else None
        write_case_series(case_dir, protocol if isinstance(protocol, str) else None, summary)
    except (OSError, ValueError, KeyError):
        (case_dir / SERIES).unlink(missing_ok=True)


_RECORD_KEYS = ("case_id", "outcome", "metrics")
#: The friction law of protocol records that do not name one (written before surface friction).
LEGACY_FRICTION_MODEL = "centreline"


def _read_summary(case_dir: Path) -> dict | None:
    """The record in ``case_dir``, or ``None`` when there is none or it is not a valid record (a
    truncated or empty file, a JSON value that is not a record: see :func:`record_problem`)."""
    try:
        rec = read_json(case_dir / RECORD)
    except (FileNotFoundError, NotADirectoryError, json.JSONDecodeError, UnicodeDecodeError):
        return None
    except OSError:
        return None
    return rec if record_problem(rec, case_dir.name) is None else None


def record_problem(rec, case_id: str | None = None) -> str | None:
    """Why ``rec`` (a parsed ``result.json``) is not a valid case record, or ``None``: it must be a
    table with ``case_id`` (equal to ``case_id`` when given), ``outcome`` ``"completed"`` or
    ``"failed"`` and a ``metrics`` table."""
    if not isinstance(rec, dict):
        return f"not a table but {type(rec).__name__}"
    missing = [k for k in _RECORD_KEYS if k not in rec]
    if missing:
        return f"missing {', '.join(missing)}"
    if case_id is not None and rec["case_id"] != case_id:
        return f"case_id {rec['case_id']!r} does not match its directory {case_id!r}"
    if rec["outcome"] not in ("completed", "failed"):
        return f"outcome {rec['outcome']!r} is neither 'completed' nor 'failed'"
    if not isinstance(rec["metrics"], dict):
        return "metrics is not a table"
    return None


# ------------------------------------------------------------------------------------------ provenance
def _git_commit() -> dict:
    pkg = Path(__file__).resolve().parents[1]
    try:
        head = subprocess.run(["git", "-C", str(pkg), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=5)
        if head.returncode != 0:
            return {"commit": None, "dirty": None}
        dirty = subprocess.run(["git", "-C", str(pkg), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=5)
        return {"commit": head.stdout.strip(), "dirty": bool(dirty.stdout.strip()) if dirty.returncode == 0 else None}
    except (OSError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None}


def provenance_info() -> dict:
    """knotsim version, git commit (when installed from a checkout), Python and dependency versions,
    machine."""
    from importlib import metadata

    from knotsim._version import __version__

    deps = {}
    for name in _DEPENDENCIES:
        try:
            deps[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            deps[name] = None
    git = _git_commit()
    return {
        "knotsim_version": __version__,
        "git_commit": git["commit"],
        "git_dirty": git["dirty"],
        "python": platform.python_version(),
        "python_implementation": platform.python_implementation(),
        "dependencies": deps,
        "machine": {
            "hostname": socket.gethostname(),
            "platform": platform.platform(),
            "machine": platform.machine(),
            "processor": platform.processor(),
            "cpu_count": os.cpu_count(),
        },
    }


# ------------------------------------------------------------------------------------------ store
class StudyStore:
    """The files of one study directory (see the module docstring for the layout)."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.cases_dir = self.path / CASES
        self._pack_cache: tuple[tuple[float, int] | None, dict[str, dict]] = (None, {})

    # --------------------------------------------------------------- paths and state
    @property
    def study_file(self) -> Path:
        return self.path / "study.toml"

    @property
    def results_file(self) -> Path:
        return self.path / "results.parquet"

    @property
    def provenance_file(self) -> Path:
        return self.path / "provenance.json"

    @property
    def pack_file(self) -> Path:
        return self.path / PACK

    @property
    def series_file(self) -> Path:
        return self.path / SERIES

    def exists(self) -> bool:
        """True when the directory already holds a study."""
        return self.study_file.is_file() or self.cases_dir.is_dir() or self.pack_file.is_file()

    def case_dir(self, case_id: str) -> Path:
        return self.cases_dir / case_id

    def packed(self) -> dict[str, dict]:
        """The cases of ``cases.parquet`` (a packed study; empty when there is none), by case id:
        ``{"case", "record", "summary"}`` each, the parsed ``case.json``, ``result.json`` and
        ``summary.json`` (``None`` when the case had none). Records that are not valid (see
        :func:`record_problem`) are left out."""
        key = _mtime(self.pack_file)
        if key is None:
            return {}
        if self._pack_cache[0] != key:
            import pandas as pd

            out = {}
            for row in pd.read_parquet(self.pack_file).to_dict("records"):
                entry = {k: (json.loads(row[k]) if isinstance(row.get(k), str) else None)
                         for k in ("case", "record", "summary")}
                if record_problem(entry["record"], row["case_id"]) is None:
                    out[row["case_id"]] = entry
            self._pack_cache = (key, out)
        return self._pack_cache[1]

    def read_record(self, case_id: str) -> dict | None:
        """The record of a finished case (its directory's, else the packed one), or ``None``."""
        rec = _read_summary(self.case_dir(case_id))
        if rec is None:
            rec = (self.packed().get(case_id) or {}).get("record")
        return rec

    def read_summary(self, case_id: str) -> dict | None:
        """The ``summary.json`` of a finished case (its directory's, else the packed one), or
        ``None`` (a failed case, a plain run case, an unknown id)."""
        try:
            return read_json(self.case_dir(case_id) / SUMMARY)
        except (OSError, json.JSONDecodeError, UnicodeDecodeError):
            return (self.packed().get(case_id) or {}).get("summary")

    def read_series(self, case_id: str | None = None):
        """The thinned time series (:mod:`knotsim.study.series`) of case ``case_id`` (without the
        ``case_id`` column), or of every case (``None``: with it), as a DataFrame; ``None`` when the
        study has none for it (studies run before knotsim kept them)."""
        import pandas as pd

        if case_id is not None:
            own = self.case_dir(case_id) / SERIES
            if own.is_file():
                return pd.read_parquet(own)
        if not self.series_file.is_file():
            return None
        df = pd.read_parquet(self.series_file)
        if case_id is None:
            return df
        rows = df[df["case_id"] == case_id]
        if rows.empty:
            return None
        return rows.drop(columns="case_id").dropna(axis=1, how="all").reset_index(drop=True)

    def case_series(self, case_id: str):
        """The thinned series a finished case directory holds (``cases/<id>/timeseries.parquet``),
        or ``None``."""
        import pandas as pd

        path = self.case_dir(case_id) / SERIES
        try:
            return pd.read_parquet(path) if path.is_file() else None
        except (OSError, ValueError):
            return None

    def series_by_case(self, case_dirs=()) -> dict:
        """``{case_id: DataFrame}``: the series of ``timeseries.parquet`` (every case in it), then
        those of the case directories ``case_dirs`` (ids; theirs win)."""
        out: dict = {}
        old = self.read_series()
        if old is not None:
            for cid, g in old.groupby("case_id", sort=False):
                out[cid] = g.drop(columns="case_id").dropna(axis=1, how="all").reset_index(drop=True)
        for cid in case_dirs:
            own = self.case_series(cid)
            if own is not None:
                out[cid] = own
        return out

    def write_series(self, series: dict) -> None:
        """Write ``timeseries.parquet`` from ``{case_id: DataFrame}`` (``time`` and the case's own
        columns; in the given order), atomically; nothing when ``series`` is empty."""
        import pandas as pd

        frames = [df.assign(case_id=cid) for cid, df in series.items() if df is not None and len(df)]
        if not frames:
            return
        table = pd.concat(frames, ignore_index=True)
        table = table[["case_id", *(c for c in table.columns if c != "case_id")]]
        _replace_parquet(table, self.series_file)

    def finished(self) -> dict[str, dict]:
        """Records of every finished case, by case id: the packed ones (``cases.parquet``), then
        every finished case directory (which wins over a packed record of the same case)."""
        out = {cid: entry["record"] for cid, entry in self.packed().items()}
        if self.cases_dir.is_dir():
            for d in self.cases_dir.iterdir():
                if d.name.startswith("."):
                    continue
                rec = _read_summary(d)
                if rec is not None:
                    out[d.name] = rec
        return out

    def started(self, case) -> bool:
        """True when some worker has started ``case`` (a :class:`~knotsim.study.spec.Case` or its
        id) and not yet finished it: a ``cases/.tmp-<id>-*`` directory exists."""
        cid = case if isinstance(case, str) else case.case_id
        return any(self.cases_dir.glob(f"{TMP_PREFIX}{cid}-*"))

    def corrupt(self) -> dict[str, str]:
        """Case directories with a missing or invalid ``result.json`` (a write cut short, a file
        edited by hand): ``{case_id: problem}``. :func:`~knotsim.study.runner.run_study` with
        ``resume`` discards them and runs those cases again."""
        out = {}
        if self.cases_dir.is_dir():
            for d in self.cases_dir.iterdir():
                if d.name.startswith(".") or not d.is_dir():
                    continue
                try:
                    rec = read_json(d / RECORD)
                except FileNotFoundError:
                    out[d.name] = f"no {RECORD}"
                    continue
                except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                    out[d.name] = f"{RECORD} is not valid JSON ({exc})"
                    continue
                except OSError as exc:
                    out[d.name] = f"{RECORD} cannot be read ({exc})"
                    continue
                problem = record_problem(rec, d.name)
                if problem is not None:
                    out[d.name] = f"{RECORD} is not a case record: {problem}"
        return out

    def discard(self, case_id: str) -> None:
        """Remove a finished case (atomically: renamed away first, then deleted)."""
        d = self.case_dir(case_id)
        if d.exists():
            trash = self.cases_dir / f".trash-{case_id}-{uuid.uuid4().hex[:6]}"
            os.rename(d, trash)
            shutil.rmtree(trash, ignore_errors=True)

    def cleanup(self) -> list[str]:
        """Delete leftovers of killed runs: ``.tmp-*`` directories of dead processes of this host and
        ``.trash-*`` directories. Returns the names removed."""
        removed = []
        if not self.cases_dir.is_dir():
            return removed
        host = socket.gethostname()
        for d in self.cases_dir.iterdir():
            name = d.name
            if name.startswith(".trash-"):
                shutil.rmtree(d, ignore_errors=True)
                removed.append(name)
            elif name.startswith(TMP_PREFIX):
                rest = name[len(TMP_PREFIX):]
                try:
                    _cid, tail = rest.split("-", 1)
                    dhost, spid, _rand = tail.rsplit("-", 2)
                    pid = int(spid)
                except ValueError:
                    continue
                if dhost == host and not _pid_alive(pid):
                    shutil.rmtree(d, ignore_errors=True)
                    removed.append(name)
        return removed

    # --------------------------------------------------------------- writing
    def prepare(self, study, *, session: dict) -> None:
        """Create the directory, write ``study.toml`` and add a session to ``provenance.json``."""
        self.cases_dir.mkdir(parents=True, exist_ok=True)
        doc = {"name": study.name}
        if study.description:
            doc["description"] = study.description
        if study.repeats != 1:
            doc["repeats"] = study.repeats
        doc["base"] = study.base
        for k in ("grid", "zip", "cases"):
            if k in study.raw:
                doc[k] = study.raw[k] if k != "zip" or isinstance(study.raw[k], list) else [study.raw[k]]
        write_toml(self.study_file, doc)
        prov = self.read_provenance()
        info = provenance_info()
        sessions = prov.get("sessions", [])
        sessions.append({**session, **{k: info[k] for k in ("knotsim_version", "git_commit", "git_dirty")},
                         "hostname": info["machine"]["hostname"],
                         "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
        write_json(self.provenance_file, {"study": study.name, **info, "sessions": sessions})

    def read_provenance(self) -> dict:
        try:
            return read_json(self.provenance_file)
        except (FileNotFoundError, json.JSONDecodeError):
            return {}

    def finish_session(self, **info) -> None:
        """Record the end of the current session (counts, wall time) in ``provenance.json``."""
        prov = self.read_provenance()
        if prov.get("sessions"):
            prov["sessions"][-1].update(info, finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"))
            write_json(self.provenance_file, prov)

    def write_results(self, cases: list, records: dict[str, dict]):
        """Write ``results.parquet``: one row per finished case of ``cases`` (in study order).
        Returns the table as read back (so its dtypes are those of :func:`load_study`)."""
        import pandas as pd

        df = results_frame(cases, records)
        _replace_parquet(df, self.results_file)
        return pd.read_parquet(self.results_file)


def _replace_parquet(df, path: Path) -> None:
    """Write ``df`` to ``path`` through a temporary file renamed over it (readers see the old file
    or the new one, never half of one)."""
    tmp = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:6]}.parquet")
    try:
        df.to_parquet(tmp, index=False)
        os.replace(tmp, path)
    except BaseException:  # a full disk must not leave a half-written temporary file behind
        tmp.unlink(missing_ok=True)
        raise


def _mtime(path: Path) -> tuple[float, int] | None:
    try:
        st = path.stat()
    except OSError:
        return None
    return (st.st_mtime, st.st_size)


class StudyLock:
    """Exclusive lock on a study directory, held by the session running it (``STUDY_DIR/.lock``,
    an advisory ``flock``: released by the kernel when the process dies, even by SIGKILL; on NFS
    Linux maps it to a lock over the network). A second session on the same directory is refused
    with a :class:`~knotsim.errors.ConfigError` naming the host and process that hold it: two
    resumes at once would both run every missing case. Where ``fcntl`` is missing (Windows) no
    lock is taken."""

    def __init__(self, study_dir: str | os.PathLike):
        self.path = Path(study_dir) / LOCK
        self._fd: int | None = None

    def acquire(self) -> StudyLock:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not on POSIX
            return self
        from knotsim.errors import ConfigError

        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            try:
                holder = os.read(fd, 4096).decode(errors="replace").strip() or "unknown process"
            finally:
                os.close(fd)
            raise ConfigError("study_dir", f"{str(self.path.parent)!r} is being run by another session "
                              f"({holder}); wait until it has finished (two sessions would both run "
                              f"every missing case), or use another directory") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"host {socket.gethostname()}, pid {os.getpid()}, since "
                     f"{time.strftime('%Y-%m-%dT%H:%M:%S%z')}\n".encode())
        self._fd = fd
        return self

    def release(self) -> None:
        """Release the lock (the file stays: removing it would let a third session lock a new file
        while a second one still holds the old)."""
        if self._fd is None:
            return
        import fcntl

        try:
            fcntl.flock(self._fd, fcntl.LOCK_UN)
        finally:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> StudyLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def _pid_alive(pid: int) -> bool:
    """True when process ``pid`` of this host runs (zombies count as dead)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat") as fh:
            state = fh.read().rsplit(")", 1)[1].split()[0]
        return state not in ("Z", "X")
    except (OSError, IndexError):
        return True


def _cell(v):
    if isinstance(v, list | tuple | dict):
        return json.dumps(v)
    return v


def results_frame(cases: list, records: dict[str, dict]):
    """DataFrame with one row per case of ``cases`` that has a record (see the module docstring)."""
    import pandas as pd

    rows = []
    for case in cases:
        c = case if isinstance(case, dict) else case.to_dict()
        rec = records.get(c["case_id"])
        if rec is None:
            continue
        row = {"case_id": c["case_id"], "kind": c["kind"]}
        for k, v in c["params"].items():
            row[k] = _cell(v)
        row["outcome"] = rec.get("outcome")
        row["error"] = rec.get("error")
        row["wall_time"] = rec.get("wall_time")
        for k, v in (rec.get("metrics") or {}).items():
            name = k if k not in row and k not in _RESERVED else f"metric.{k}"
            row[name] = math.nan if v is None else _cell(v)
        if c["kind"] == "protocol" and rec.get("outcome") == "completed" and "friction_model" not in row:
            # a record from before knotsim had surface friction: the centre-line law ran
            row["friction_model"] = LEGACY_FRICTION_MODEL
        row["traceback"] = rec.get("traceback")
        row["case_dir"] = f"{CASES}/{c['case_id']}" if rec.get("host") is not None else None
        rows.append(row)
    df = pd.DataFrame(rows)
    if df.empty:
        df = pd.DataFrame(columns=["case_id", "kind", "outcome", "error", "wall_time", "traceback", "case_dir"])
    # metrics and tail columns after the parameters
    tail = [c for c in ("traceback", "case_dir") if c in df.columns]
    df = df[[c for c in df.columns if c not in tail] + tail]
    for col in ("error", "traceback", "case_dir"):
        if col in df.columns:
            df[col] = df[col].astype(object)
    for col in df.columns:  # a column of numbers and text (e.g. a setting swept over 1e-4 and "none")
        if df[col].dtype == object:  # is written as text: parquet columns have one type
            vals = [v for v in df[col] if v is not None and not (isinstance(v, float) and math.isnan(v))]
            if any(isinstance(v, str) for v in vals) and not all(isinstance(v, str) for v in vals):
                df[col] = [None if v is None or (isinstance(v, float) and math.isnan(v)) else str(v)
                           for v in df[col]]
    params = {k for c in cases for k in (c if isinstance(c, dict) else c.to_dict())["params"]}
    for col in df.columns:  # integer metrics stay integers next to failed (missing) rows
        if col in _RESERVED or col in params or df[col].dtype != float:
            continue
        vals = [v for v in _rows_values(rows, col) if v is not None and not (isinstance(v, float) and math.isnan(v))]
        if vals and all(isinstance(v, int) and not isinstance(v, bool) for v in vals):
            df[col] = df[col].astype("Int64")
    return df


def _rows_values(rows: list[dict], col: str) -> list:
    """The raw values of column ``col`` in ``rows`` (missing keys left out)."""
    return [r[col] for r in rows if col in r]


def _read_json_or_none(path: Path):
    try:
        return read_json(path)
    except (OSError, json.JSONDecodeError, UnicodeDecodeError):
        return None


def _dump(value) -> str | None:
    return None if value is None else json.dumps(json_safe(value))


def pack_study(study_dir: str | os.PathLike, *, keep_case_dirs: bool = False) -> dict:
    """Fold the case directories of a study into one file each: ``cases.parquet`` (every finished
    case's ``case.json``, ``result.json`` and ``summary.json``) and ``timeseries.parquet`` (their
    thinned logs, :mod:`knotsim.study.series`), then remove the case directories.

    What a packed study keeps: ``study.toml``, ``results.parquet``, ``provenance.json``, the two
    files above and the report with its figures; what it drops with the case directories: each
    case's full log, trajectory and checkpoint. It reopens (:func:`load_study`, ``knotsim report``)
    and resumes (its finished cases are reused) as before. Packing a study packed already adds
    the case directories run since (their records win) to what it holds.

    Parameters
    ----------
    study_dir:
        The study directory (with ``study.toml``); it must not be running (its lock is taken).
    keep_case_dirs:
        Write the two files but leave the case directories where they are.

    Returns
    -------
    dict
        ``cases`` (the number packed), ``series`` (cases with a time series), ``removed`` (case
        directories removed) and ``results_rewritten`` (True when ``results.parquet`` lacked
        finished cases and was written again from the records).

    Raises
    ------
    ConfigError
        When ``study_dir`` is not a study directory, or another session runs it.
    """
    import pandas as pd

    from knotsim.errors import ConfigError
    from knotsim.study.series import event_times, thin_log

    store = StudyStore(study_dir)
    if not store.study_file.is_file():
        raise ConfigError("study_dir", f"{str(study_dir)!r} is not a study directory (no study.toml)")
    with StudyLock(study_dir):
        entries = dict(store.packed())
        dirs: list[Path] = []
        if store.cases_dir.is_dir():
            for d in sorted(store.cases_dir.iterdir()):
                rec = None if d.name.startswith(".") or not d.is_dir() else _read_summary(d)
                if rec is None:  # a case being run, or a corrupt one (resume runs it again): left alone
                    continue
                entries[d.name] = {"case": _read_json_or_none(d / "case.json"), "record": rec,
                                   "summary": _read_json_or_none(d / SUMMARY)}
                dirs.append(d)
        try:
            from knotsim.study.spec import load_study_spec

            cases: list = load_study_spec(store.study_file).expand()
        except (ConfigError, OSError):  # a study file this version cannot expand: the records' order
            cases = []
        order = {c.case_id: i for i, c in enumerate(cases)}
        ids = sorted(entries, key=lambda cid: (order.get(cid, len(order)), cid))
        rows = [{"case_id": cid, "kind": entries[cid]["record"].get("kind"),
                 "outcome": entries[cid]["record"]["outcome"],
                 **{k: _dump(entries[cid][k]) for k in ("case", "record", "summary")}} for cid in ids]
        if rows or store.pack_file.is_file():  # (a study without case records gets no empty file)
            table = pd.DataFrame(rows, columns=["case_id", "kind", "outcome", "case", "record", "summary"])
            _replace_parquet(table.astype(object), store.pack_file)

        series = store.series_by_case([d.name for d in dirs])
        for d in dirs:
            if d.name not in series and (d / "log.parquet").is_file():  # run before studies kept series
                config = (entries[d.name]["case"] or {}).get("config") or {}
                try:
                    series[d.name] = thin_log(pd.read_parquet(d / "log.parquet"), config.get("protocol"),
                                              event_times(entries[d.name]["summary"]))
                except (OSError, ValueError):
                    pass
        store.write_series({cid: series[cid] for cid in ids if cid in series})

        rewritten = False
        have = set(pd.read_parquet(store.results_file, columns=["case_id"])["case_id"]) \
            if store.results_file.is_file() else set()
        if cases and not set(ids) <= have:
            store.write_results(cases, {cid: e["record"] for cid, e in entries.items()})
            rewritten = True
        removed = 0
        if not keep_case_dirs:
            for d in dirs:
                store.discard(d.name)
                removed += 1
            try:
                store.cases_dir.rmdir()  # only when nothing is left in it
            except OSError:
                pass
    return {"cases": len(ids), "series": sum(cid in series for cid in ids), "removed": removed,
            "results_rewritten": rewritten}


def load_study(study_dir: str | os.PathLike):
    """The results table of a study directory (``results.parquet``) as a pandas DataFrame.

    When ``results.parquet`` is missing or older than some case directory (a study killed before
    it could write it), the table is rebuilt from ``study.toml`` and the case directories.
    """
    import pandas as pd

    from knotsim.errors import ConfigError

    store = StudyStore(study_dir)
    if not store.study_file.is_file():
        raise ConfigError("study_dir", f"{str(study_dir)!r} is not a study directory (no study.toml)")
    if store.results_file.is_file() and not _stale(store):
        table = pd.read_parquet(store.results_file)
        if "friction_model" not in table.columns and "kind" in table.columns and len(table):
            # a table from before knotsim had surface friction: its protocol cases ran the centre-line law
            done = (table["kind"] == "protocol") & (table["outcome"] == "completed")
            if done.any():
                table["friction_model"] = [LEGACY_FRICTION_MODEL if d else None for d in done]
        return table
    from knotsim.study.spec import load_study_spec

    spec = load_study_spec(store.study_file)
    cases = spec.expand()
    return results_frame(cases, store.finished())


def _stale(store: StudyStore) -> bool:
    t = store.results_file.stat().st_mtime
    try:
        return store.cases_dir.stat().st_mtime > t + 1e-3
    except FileNotFoundError:
        return False
