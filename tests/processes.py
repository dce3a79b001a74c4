"""Run independent long checks side by side, one worker process each (the CI machine has two cores).

The workers start fresh (``spawn``: no copy of the test process's state) and load the compiled
kernels from numba's cache; the thread limits of the environment (``OPENBLAS_NUM_THREADS=1``) pass
to them. ``fn`` must be a module-level function of an importable module and its arguments and
result picklable.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any


def map_in_processes(fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Any]:
    """``[fn(item) for item in items]``, computed in at most ``os.cpu_count()`` worker processes at
    once (an exception in a worker is raised here)."""
    workers = max(1, min(len(items), os.cpu_count() or 1))
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        return list(pool.map(fn, items))
