"""Parametric test curves of the topology tests (closed and open polylines, ``(N, 3)`` arrays)."""

from __future__ import annotations

import numpy as np

RIGHT_TREFOIL_JONES = {1: 1, 3: 1, 4: -1}


def torus_knot(p: int, q: int, n: int = 400, mirror: bool = False) -> np.ndarray:
    """(p, q) torus knot on a torus R=2, r=1; with z = -sin(q t) (mirror=False) it is right-handed."""
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    z = np.sin(q * t) * (1.0 if mirror else -1.0)
    return np.c_[(2 + np.cos(q * t)) * np.cos(p * t), (2 + np.cos(q * t)) * np.sin(p * t), z]


def trefoil(n: int = 400, right: bool = True) -> np.ndarray:
    return torus_knot(2, 3, n, mirror=not right)


def figure_eight(n: int = 400) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.c_[(2 + np.cos(2 * t)) * np.cos(3 * t), (2 + np.cos(2 * t)) * np.sin(3 * t), np.sin(4 * t)]


def circle(n: int = 100, radius: float = 1.0) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return radius * np.c_[np.cos(t), np.sin(t), np.zeros_like(t)]


def trefoil_arc(right: bool = True, delta: float = 0.15, n: int = 400) -> np.ndarray:
    """Open overhand knot: the trefoil cut open at its outermost point (3, 0, 0)."""
    t = np.linspace(delta, 2.0 * np.pi - delta, n)
    z = -np.sin(3 * t) if right else np.sin(3 * t)
    return np.c_[(2 + np.cos(3 * t)) * np.cos(2 * t), (2 + np.cos(3 * t)) * np.sin(2 * t), z]


def rope_with_tails(right: bool = True, tail: float = 20.0) -> np.ndarray:
    """Overhand knot in a rope: the trefoil arc plus straight tails leaving along +y and -y."""
    arc = trefoil_arc(right)
    s = np.linspace(1.0, 0.0, 30, endpoint=False)[:, None]
    head = arc[0] + s * np.array([0.0, tail - arc[0, 1], 0.0])  # from y = tail down to the arc start
    s2 = np.linspace(0.0, 1.0, 31)[1:, None]
    foot = arc[-1] + s2 * np.array([0.0, -tail - arc[-1, 1], 0.0])  # from the arc end down to y = -tail
    return np.concatenate([head, arc, foot])


def rot_z180_shift(a: np.ndarray, dx: float) -> np.ndarray:
    return np.c_[dx - a[:, 0], -a[:, 1], a[:, 2]]


def connected_sum(right_a: bool, right_b: bool, gap: float = 9.0) -> np.ndarray:
    """Closed polyline K_a # K_b of two trefoils, joined by two straight bridges across a gap.

    K_b is K_a's construction rotated by 180 degrees about z (a rotation, so chirality is kept) and
    shifted along x; the plane x = gap/2 meets the curve only on the two bridges.
    """
    a = trefoil_arc(right_a)
    b = rot_z180_shift(trefoil_arc(right_b), gap)
    # a ends at y < 0, b starts at y < 0 (rotated start): a -> b -> back to a
    return np.concatenate([a, b])


def hopf(positive: bool) -> list[np.ndarray]:
    """Two round circles linked once; with z flipped the linking number changes sign."""
    t = np.linspace(0.0, 2.0 * np.pi, 120, endpoint=False)
    c1 = np.c_[np.cos(t), np.sin(t), 0 * t]
    c2 = np.c_[1 + np.cos(t), 0 * t, np.sin(t)]  # linking number -1 (checked by hand in the docs)
    if positive:
        c2 = c2 * [1, 1, -1]
    return [c1, c2]


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
