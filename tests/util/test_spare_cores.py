"""The idle-CPU estimate that decides whether the first run compiles in two processes."""

import os
import threading
import time

import pytest

from knotsim import _warmup as W


@pytest.mark.skipif(not os.path.exists("/proc/stat"), reason="needs the kernel's CPU counters")
def test_spare_cores_sees_a_busy_core():
    n = os.cpu_count() or 1
    idle = W.spare_cores()
    assert 0.0 <= idle <= n + 1e-9
    stop = time.monotonic() + 1.0

    def spin():  # one busy thread: at most n - 1 CPUs can be idle meanwhile (the GIL keeps it to one)
        while time.monotonic() < stop:
            pass

    t = threading.Thread(target=spin)
    t.start()
    try:
        busy = W.spare_cores()
    finally:
        t.join()
    assert busy <= n - 0.5


def test_spare_cores_without_proc_stat_falls_back_to_load_average(monkeypatch):
    monkeypatch.setattr(W, "_idle_fraction", lambda window=0.25: None)
    monkeypatch.setattr(W.os, "getloadavg", lambda: (0.5, 0.0, 0.0))
    assert W.spare_cores() == pytest.approx(max(0.0, (os.cpu_count() or 1) - 0.5))
