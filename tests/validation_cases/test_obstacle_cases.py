"""The obstacle and partial-constraint validation cases of ``knotsim validate`` pass, and their
geometry is what they say (the capstan rope wraps the post by the stated angle)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from knotsim.validation.cases import CASES
from knotsim.validation.obstacles import H, R, capstan_rope


@pytest.mark.parametrize("k", [1, 2, 3])
def test_capstan_rope_wraps_the_post_by_k_pi(k):
    x, tangent = capstan_rope(k * math.pi)
    rc = R + H + 2e-4
    on_post = np.abs(np.hypot(x[:, 0], x[:, 2]) - rc) < 1e-9
    # the wrapped arc length is theta * rc (within one edge)
    seg = np.linalg.norm(np.diff(x, axis=0), axis=1)
    wrapped = float(np.sum(seg[on_post[:-1] & on_post[1:]]))
    assert wrapped == pytest.approx(k * math.pi * rc, abs=6e-3)
    assert np.linalg.norm(tangent) == pytest.approx(1.0)


def test_capstan_euler_and_floor_cases_pass_quick():
    rows = CASES["capstan"](True) + CASES["euler_pinned"](True) + CASES["floor_friction"](True) + CASES["michell"](True)
    assert rows and all(r["passed"] for r in rows), rows
