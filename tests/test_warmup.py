"""The compile ahead of a first run (knotsim._warmup): the kernel manifest and the groups of a run."""

from __future__ import annotations

import importlib
import inspect

import pytest

from knotsim._kernel_manifest import KERNELS
from knotsim._warmup import GROUPS, _halves, _type_from_text, _type_to_text, run_groups


def test_manifest_entries_name_kernels_with_their_argument_count():
    """Every entry is a cached numba kernel of its module, called with as many arguments as it takes
    (a renamed kernel or a changed argument list shows here: rewrite the manifest with
    ``python -m knotsim._warmup --record`` and an empty NUMBA_CACHE_DIR)."""
    assert KERNELS
    for group, module, name, args, cpu in KERNELS:
        assert group in GROUPS
        disp = getattr(importlib.import_module(module), name)
        assert hasattr(disp, "compile") and disp._cache is not None, f"{module}.{name}"
        params = inspect.signature(disp.py_func).parameters
        assert len(args) == len(params), f"{module}.{name}"
        assert cpu >= 0
        for text in args:
            assert _type_to_text(_type_from_text(text)) == text


@pytest.mark.parametrize("contact, groups", [
    (True, ("core", "topology", "contact")),
    (False, ("core", "topology")),
    ({"mu": 0.3}, ("core", "topology", "contact")),
    ({}, ("core", "topology", "contact", "centreline")),  # mu = 0: the centre-line loop
    ({"mu": 0.3, "friction_model": "centreline"}, ("core", "topology", "contact", "centreline")),
    ({"mu": {"default": 0.2}, "parallel_smoothing": 0.0}, ("core", "topology", "contact", "exact")),
    ({"mu": 0.0, "parallel_smoothing": 0}, ("core", "topology", "contact", "exact_centreline")),
])
def test_run_groups_follow_the_contact_settings(contact, groups):
    assert run_groups(contact) == groups
    assert run_groups(contact, topology=False, obstacles=True) == tuple(
        g for g in groups if g != "topology") + ("obstacles",)


def test_halves_split_every_entry_once_by_compile_time():
    entries = [("core", "m", f"k{i}", (), float(c)) for i, c in enumerate([5, 1, 1, 1, 1, 1, 3, 2])]
    a, b = _halves(entries)
    assert sorted(a + b) == sorted(entries)
    assert abs(sum(e[4] for e in a) - sum(e[4] for e in b)) <= 1.0
    assert a == sorted(a, key=entries.index) and b == sorted(b, key=entries.index)  # manifest order kept
