"""Slow, obvious numpy reference of the DER energies (one open or closed rod).

Written independently of the numba kernels: parallel transport by an explicit axis-angle rotation
matrix, material frames by rotating the reference frame, curvature binormal and twist from their
definitions.
"""

from __future__ import annotations

import numpy as np


def rotation_matrix(axis, angle):
    axis = np.asarray(axis, float)
    n = np.linalg.norm(axis)
    if n < 1e-300:
        return np.eye(3)
    k = axis / n
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def parallel_transport(u, t_from, t_to):
    axis = np.cross(t_from, t_to)
    angle = np.arctan2(np.linalg.norm(axis), np.dot(t_from, t_to))
    return rotation_matrix(axis, angle) @ u


def reference_energies(x, theta, d1_src, t_src, closed, rest_lengths, EA, EI, GJ, kappa_bar, twist_bar,
                       ref_twist_prev):
    """Stretching, bending and twisting energies (J) of one rod.

    ``x (N, 3)``, ``theta (ne,)``, ``d1_src, t_src (ne, 3)`` frames the reference directors are
    transported from, ``kappa_bar (ni, 2)`` and ``twist_bar (ni,)`` integrated rest values.
    """
    n = len(x)
    edges = [(k, (k + 1) % n) for k in range(n if closed else n - 1)]
    e = np.array([x[b] - x[a] for a, b in edges])
    lengths = np.linalg.norm(e, axis=1)
    t = e / lengths[:, None]
    d1 = np.array([parallel_transport(d1_src[k], t_src[k], t[k]) for k in range(len(e))])
    d1 -= np.sum(d1 * t, axis=1)[:, None] * t
    d1 /= np.linalg.norm(d1, axis=1)[:, None]
    d2 = np.cross(t, d1)
    m1 = np.cos(theta)[:, None] * d1 + np.sin(theta)[:, None] * d2
    m2 = -np.sin(theta)[:, None] * d1 + np.cos(theta)[:, None] * d2
    E_s = sum(0.5 * EA * (lengths[k] / rest_lengths[k] - 1) ** 2 * rest_lengths[k] for k in range(len(e)))
    pairs = [((i - 1) % n, i) for i in range(n)] if closed else [(i - 1, i) for i in range(1, n - 1)]
    E_b = 0.0
    E_t = 0.0
    for s, (ea, eb) in enumerate(pairs):
        kb = 2 * np.cross(t[ea], t[eb]) / (1 + np.dot(t[ea], t[eb]))
        k1 = 0.5 * np.dot(kb, m2[ea] + m2[eb])
        k2 = -0.5 * np.dot(kb, m1[ea] + m1[eb])
        lv = 0.5 * (rest_lengths[ea] + rest_lengths[eb])
        E_b += EI / (2 * lv) * ((k1 - kappa_bar[s, 0]) ** 2 + (k2 - kappa_bar[s, 1]) ** 2)
        u = parallel_transport(d1[ea], t[ea], t[eb])
        ang = np.arctan2(np.dot(np.cross(u, d1[eb]), t[eb]), np.dot(u, d1[eb]))
        ang += 2 * np.pi * np.round((ref_twist_prev[s] - ang) / (2 * np.pi))
        m = theta[eb] - theta[ea] + ang
        E_t += GJ / (2 * lv) * (m - twist_bar[s]) ** 2
    return E_s, E_b, E_t
