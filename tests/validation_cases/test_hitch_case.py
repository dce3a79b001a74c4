"""The hitch validation case of ``knotsim validate`` passes at quick size, and its reference is the
string theory's band for the library's clove hitch."""

from __future__ import annotations

import pytest

from knotsim.validation.cases import CASES
from knotsim.validation.hitches import theory_band


def test_theory_band_of_the_library_clove_hitch():
    lo, hi = theory_band()
    assert lo == pytest.approx(0.1486, abs=1e-3)  # rider flat on the post (docs/physics.md §4.5)
    assert lo < hi < 0.3  # the pitched rider pinches less; the quick check's 0.3 lies above the band


def test_hitch_theory_case_passes_quick():
    rows = CASES["hitch_theory"](True)
    assert len(rows) == 3 and all(r["passed"] for r in rows), rows
