"""Random surface-friction records for the tests of the spin relaxation (shared by
``tests/contact/test_spin_friction.py`` and ``tests/solver/test_spin_relaxation.py``)."""

from __future__ import annotations

import numpy as np


def random_friction_records(rng, k: int, slip: float, lever: float, mufn_min: float, *, stick: bool = False,
                            dt: float = 1.0) -> np.ndarray:
    """``(k, RECORD_SIZE)`` records as :class:`~knotsim.contact.spin_minimiser.SpinFriction` takes them:
    per pair the slip velocity ``u0`` (m/s, scale ``slip``), the velocities per unit rate of the two
    edge angles ``c_a``, ``c_b`` (m, scale ``lever``), all tangent to a random contact normal, the
    normal force ``F_n`` drawn from ``[mufn_min, 1)`` N and the coefficient 1 (so ``μ F_n = F_n``).
    ``stick``: elastic-stick records instead, the coefficient ``μ_L`` in [0.1, 0.6) and ``κ`` such
    that the spring ``ξ = u0 dt`` is from half to twice its limit."""
    from knotsim.contact.surface_friction import RECORD_SIZE

    rec = np.zeros((k, RECORD_SIZE))
    for p in range(k):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        proj = np.eye(3) - np.outer(n, n)
        rec[p, 0:3] = proj @ rng.normal(size=3) * slip
        rec[p, 3:6] = proj @ rng.normal(size=3) * lever
        rec[p, 6:9] = proj @ rng.normal(size=3) * lever
        rec[p, 9] = rng.uniform(mufn_min, 1.0)
        rec[p, 10] = 1.0
        if stick:
            rec[p, 10] = rng.uniform(0.1, 0.6)
            rec[p, 11] = rec[p, 10] / (np.linalg.norm(rec[p, 0:3]) * dt * rng.uniform(0.5, 2.0) + 1e-300)
        rec[p, 12:15] = n
    return rec
