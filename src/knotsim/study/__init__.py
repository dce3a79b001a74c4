"""Parametric studies: a base case swept over parameters, run in parallel, stored, reported.

- :mod:`knotsim.study.spec`: study files (TOML) and their expansion into cases;
- :mod:`knotsim.study.executors`: how a case runs (plain run configuration or protocol);
- :mod:`knotsim.study.runner`: :func:`run_study` on local worker processes or a Dask cluster;
- :mod:`knotsim.study.store`: the results directory (resumable) and :func:`load_study`;
- :mod:`knotsim.study.report`: :func:`write_report` (``report.md`` with tables and plots).

See ``docs/studies.md``.
"""

from knotsim.study.compare import CompareResult, compare_knots
from knotsim.study.spec import Case, Study, expand, load_study_spec
from knotsim.study.store import load_study

__all__ = ["Case", "CompareResult", "Study", "compare_knots", "expand", "load_study", "load_study_spec", "run_study", "write_report"]


def run_study(*args, **kwargs):
    """See :func:`knotsim.study.runner.run_study`."""
    from knotsim.study.runner import run_study as _run

    return _run(*args, **kwargs)


def write_report(*args, **kwargs):
    """See :func:`knotsim.study.report.write_report`."""
    from knotsim.study.report import write_report as _write

    return _write(*args, **kwargs)
