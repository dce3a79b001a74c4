"""Hands: node groups moved along waypoint paths (``[[bc]]`` groups of type ``move``), and the
paths that tie an overhand (the loop curled by grips, the end threaded through it).

Every length is in metres, every time in seconds; positions are world coordinates of a rod that
starts straight along +x from the origin (viewer on +z). See :mod:`knotsim.knots.tying` for the
design of the sequences.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Hand", "hand_stretch", "overhand_hands"]


@dataclass
class Hand:
    """One moving node group: absolute target positions of its centroid at given times (s, m).

    ``times`` / ``points`` are absolute (run time, world positions); the group becomes active at
    ``times[0]`` and stops at ``stop`` (``None``: never). ``rel`` points are displacements from
    wherever the group is when it activates (for re-grips after other motion).
    """

    name: str
    nodes: list[int]
    times: list[float]
    points: list
    stop: float | None = None
    rel: bool = False
    twist: bool = False

    def to_bc(self, x0: np.ndarray) -> dict:
        """The ``[[bc]]`` table (type ``move``, rod ``rope``) of this hand: waypoint times (s) from
        its start, displacements (m) from its centroid in ``x0`` ((N, 3) initial node positions,
        m; for a ``rel`` hand, from its first point), rounded to 1 ns and 1 µm."""
        t0 = float(self.times[0])
        pts = np.asarray(self.points, float)
        if self.rel:
            disp = pts - pts[0]
        else:
            c = x0[self.nodes].mean(axis=0)
            disp = pts - c
            if np.linalg.norm(disp[0]) > 1e-9:
                raise ValueError(f"hand {self.name}: first point {pts[0]} is not the centroid {c}")
        times = [round(float(t) - t0, 9) for t in self.times]
        bc = {"type": "move", "name": self.name, "rod": "rope", "nodes": [int(n) for n in self.nodes]}
        if len(self.nodes) > 1:
            bc["twist"] = bool(self.twist)
        if t0 > 0:
            bc["start"] = t0
        if self.stop is not None:
            bc["stop"] = float(self.stop)
        bc["waypoints"] = {"times": times, "points": [[round(float(x), 6) for x in p] for p in disp]}
        return bc


def _straight(n_nodes: int, length: float) -> np.ndarray:
    """(n_nodes, 3) node positions (m) of a straight rod of ``length`` (m) along +x from the origin."""
    x = np.zeros((n_nodes, 3))
    x[:, 0] = np.linspace(0.0, length, n_nodes)
    return x


def _check_kind(kind: str) -> None:
    """``ValueError`` unless ``kind`` is ``"reef"`` or ``"granny"``."""
    if kind not in ("reef", "granny"):
        raise ValueError(f"kind must be 'reef' or 'granny', got {kind!r}")


def _node(s: float, ds: float) -> int:
    return int(round(s / ds))


def _curl(a: float, length: float, s, frac: float, e: float) -> np.ndarray:
    """Points at arc lengths ``s`` (from the curl start) of a segment of ``length`` starting at
    ``(a, 0)`` heading +x, curled counterclockwise to the fraction ``frac`` of a full circle
    (``frac = 1``: a closed circle of circumference ``length`` above the start); z rises linearly
    from -e to +e along the segment (times ``frac``) so that its end passes over its start. Beyond
    ``length`` the rod continues straight along the end tangent."""
    s = np.atleast_1d(np.asarray(s, float))
    kappa = frac * 2.0 * math.pi / length
    sc = np.minimum(s, length)
    rest = s - sc
    if kappa < 1e-12:
        x, y = a + sc, 0.0 * sc
        tx, ty = np.ones_like(s), np.zeros_like(s)
    else:
        x, y = a + np.sin(kappa * sc) / kappa, (1.0 - np.cos(kappa * sc)) / kappa
        tx, ty = np.cos(kappa * sc), np.sin(kappa * sc)
    z = frac * e * (2.0 * sc / length - 1.0)
    out = np.stack([x + rest * tx, y + rest * ty, z], axis=-1)
    return out[0] if out.shape[0] == 1 else out


def _smooth(u):
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def overhand_hands(*, length=0.8, n_nodes=129, a=0.12, loop=0.18, e=0.004, t_curl=2.0,
                   tail_gap=0.06, tail_target=(0.04, -0.035, -0.012), depth=0.02, margin=0.025,
                   t_thread=(2.4, 3.0, 3.6, 4.0, 4.6), draw=0.08, t_draw=5.4, t_release=5.6,
                   pull=0.22, t_end=8.6, pull_dir_b=(1.0, 0.0, 0.0), exit_side=1.0, x0=None, n_curl=9):
    """Hands for an overhand knot tied in the rope ``[a, ...]`` (see :mod:`knotsim.knots.tying`).

    Lengths in m (``loop``: the loop's length along the rope, ``e``: half the height step at the
    crossing), times in s. Returns ``(hands, info)``; ``x0`` the (N, 3) initial node positions (m;
    default: straight along x).
    """
    ds = length / (n_nodes - 1)
    if x0 is None:
        x0 = _straight(n_nodes, length)
    R = loop / (2.0 * math.pi)
    i_in = _node(a, ds)
    a = i_in * ds
    loop_nodes = [i_in + _node(k * loop / 4.0, ds) for k in range(5)]
    loop = (loop_nodes[-1] - i_in) * ds
    R = loop / (2.0 * math.pi)
    names = ["loop_in", "loop_q1", "loop_top", "loop_q3", "loop_out"]
    hands = []
    taus = np.linspace(0.0, 1.0, n_curl)
    tcurl = list(taus * t_curl)

    def curl_path(n):
        pts = [_curl(a, loop, (n - i_in) * ds, _smooth(u), e) for u in taus]
        pts[0] = x0[n].copy()
        return pts

    for name, n in zip(names, loop_nodes, strict=True):
        hands.append(Hand(name, [n], tcurl, curl_path(n), stop=t_release))
    X = np.array([a, 0.0, 0.0])
    t1, t2, t3, t4, t5 = t_thread
    i_tail = loop_nodes[-1] + _node(tail_gap, ds)
    hands.append(Hand("tail", [i_tail], tcurl + [t1], curl_path(i_tail) + [X + np.asarray(tail_target)],
                      stop=t5))
    # end B: single node, so that the rope trails behind it
    # during the curl the free end translates with the tail grip (slightly slack), then goes round
    off = 0.97 * (x0[-1] - x0[i_tail])
    b_pts = [x0[-1].copy()] + [p + off for p in curl_path(i_tail)[1:]] + [
        X + np.array([0.12, -0.05, -depth]),
        X + np.array([R + margin, R, -depth]),
        X + np.array([0.0, R, -depth]),
        X + np.array([0.0, R, depth]),
        X + np.array([exit_side * (R + margin + 0.01), R, depth])]
    b_times = tcurl + [t1, t2, t3, t4, t5]
    d = np.asarray(pull_dir_b, float)
    d /= np.linalg.norm(d)
    b_pts += [b_pts[-1] + draw * d, b_pts[-1] + draw * d, b_pts[-1] + (draw + pull) * d]
    b_times += [t_draw, t_release, t_end]
    hands.append(Hand("end_b", [n_nodes - 1], b_times, b_pts))
    a_c = x0[[0, 1]].mean(axis=0)
    hands.append(Hand("end_a", [0, 1], [0.0, t_release, t_end], [a_c, a_c, a_c + [-pull, 0.0, 0.0]], twist=True))
    info = {"loop_nodes": loop_nodes, "tail_node": i_tail, "R": R, "X": X}
    return hands, info


def hand_stretch(hands: list[Hand], ds: float, dt: float = 0.01) -> tuple[float, float, tuple]:
    """Largest ratio (distance between two simultaneously prescribed groups) / (rod length between
    them) over the sequence, with the time and the pair: above ~0.95 the hands stretch the rod."""
    t_max = max(max(h.times) for h in hands)
    worst = (0.0, 0.0, ())
    for t in np.arange(0.0, t_max + dt, dt):
        act = []
        for h in hands:
            if h.rel or t < h.times[0] or (h.stop is not None and t >= h.stop):
                continue
            pts = np.asarray(h.points, float)
            p = np.array([np.interp(t, h.times, pts[:, k]) for k in range(3)])
            act.append((h, p))
        for i in range(len(act)):
            for j in range(i + 1, len(act)):
                (hi, pi), (hj, pj) = act[i], act[j]
                arc = abs(np.mean(hi.nodes) - np.mean(hj.nodes)) * ds
                r = float(np.linalg.norm(pi - pj) / arc)
                if r > worst[0]:
                    worst = (r, float(t), (hi.name, hj.name))
    return worst
