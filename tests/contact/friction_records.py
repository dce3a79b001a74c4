"""Random surface-friction records for the tests of the spin relaxation (shared by
``tests/contact/test_spin_friction.py`` and ``tests/solver/test_spin_relaxation.py``)."""

from __future__ import annotations

import numpy as np


def random_friction_records(rng, k: int, slip: float, lever: float, mufn_min: float) -> np.ndarray:
    """``(k, 10)`` records as :class:`~knotsim.contact.surface_friction.SpinFriction` takes them:
    per pair the slip velocity ``u0`` (m/s, scale ``slip``), the velocities per unit rate of the two
    edge angles ``c_a``, ``c_b`` (m, scale ``lever``), all tangent to a random contact normal, and
    ``μ F_n`` drawn from ``[mufn_min, 1)`` N."""
    rec = np.zeros((k, 10))
    for p in range(k):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        proj = np.eye(3) - np.outer(n, n)
        rec[p, 0:3] = proj @ rng.normal(size=3) * slip
        rec[p, 3:6] = proj @ rng.normal(size=3) * lever
        rec[p, 6:9] = proj @ rng.normal(size=3) * lever
        rec[p, 9] = rng.uniform(mufn_min, 1.0)
    return rec
