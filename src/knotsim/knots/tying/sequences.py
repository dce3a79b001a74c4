"""Tying sequences: full run configurations (plain dicts, see :mod:`knotsim.io.config`) built from
the hands of :mod:`knotsim.knots.tying.hands`, and their TOML files.

Every length is in metres, every time in seconds; ``radius`` (m), ``youngs`` (Pa), ``density``
(kg/m³), ``damping`` (Pa s), ``mu`` (friction coefficient, 1), ``dt`` and ``out_dt`` (time step and
output interval, s). The shipped files ``knotsim/data/tying/*.toml`` were written by
:func:`write_sequence` from :func:`overhand_sequence` and :func:`same_end_sequence`.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from knotsim._util.toml import dumps_toml, write_toml
from knotsim.knots.tying.hands import (
    Hand,
    _check_kind,
    _knot_nodes,
    _straight,
    overhand_hands,
    second_half_knot_hands,
    two_overhands_hands,
)

__all__ = ["double_knot_sequence", "double_sequence", "dumps_toml", "overhand_sequence", "same_end_header",
           "same_end_sequence", "write_sequence"]


def _config(hands: list[Hand], description: str, duration: float, *, length, n_nodes, radius, youngs,
            density, damping, mu, dt, out_dt) -> dict:
    """Run configuration of one straight rod ``rope`` (no gravity) moved by ``hands``."""
    return {
        "description": description,
        "rods": [{
            "name": "rope", "shape": "straight", "length": length, "n_nodes": n_nodes,
            "start": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.0], "radius": radius,
            "youngs_modulus": youngs, "density": density, "poisson_ratio": 0.5,
        }],
        "model": {"gravity": [0.0, 0.0, 0.0], "damping": damping},
        "bc": [h.to_bc(_straight(n_nodes, length)) for h in hands],
        "solver": {"dt": dt},
        "run": {"duration": duration, "output_interval": out_dt},
        "contact": {"mu": mu},
    }


def _state_at(cfg: dict, t: float, state) -> np.ndarray:
    """Node positions (N, 3) (m) at time ``t`` (s) of the run ``cfg``: ``state`` when given, else
    computed by running ``cfg`` up to ``t``."""
    if state is None:
        from knotsim.io.config import load_config
        from knotsim.runspec import build_simulation

        rc = load_config(copy.deepcopy(cfg))
        sim = build_simulation(rc)
        sim.run(t)
        state = rc.model.node_positions(sim.state.q)
    return np.asarray(state, float)


def _handedness(kind: str) -> str:
    return "opposite" if kind == "reef" else "the same"


def overhand_sequence(*, length=0.8, n_nodes=129, radius=2.5e-3, youngs=0.5e6, density=1000.0,
                      damping=0.05, mu=0.3, dt=2e-3, out_dt=0.05, **kw) -> dict:
    """Full run configuration (dict) tying an overhand knot in a straight rod (``kw``: the
    geometry of :func:`~knotsim.knots.tying.hands.overhand_hands`)."""
    hands, _ = overhand_hands(length=length, n_nodes=n_nodes, **kw)
    t_end = max(max(h.times) for h in hands)
    return _config(hands, "overhand knot tied from a straight rod: loop curled by grips, end threaded, pulled tight",
                   t_end + 0.4, length=length, n_nodes=n_nodes, radius=radius, youngs=youngs, density=density,
                   damping=damping, mu=mu, dt=dt, out_dt=out_dt)


def double_sequence(kind: str, *, length=1.1, n_nodes=177, a=0.35, radius=2.5e-3, youngs=0.5e6,
                    density=1000.0, damping=0.05, mu=0.3, dt=2e-3, out_dt=0.05, settle=0.4,
                    first: dict | None = None, second: dict | None = None, state=None):
    """Full run configuration (dict) tying a single-rod ``kind`` = ``"reef"`` or ``"granny"``
    (not shipped: it ends as 5_1, see :mod:`knotsim.knots.tying`).

    An overhand (:func:`overhand_hands`) is tied and pulled snug, then a half-knot of the opposite
    (reef) or same (granny) handedness is tied above it (:func:`second_half_knot_hands`) and the
    ends are pulled apart. The second stage is designed on the state reached after the first one
    (``settle`` s after its end), computed here by running the first stage (``state``: pass that
    (N, 3) state, m, to skip the run). Returns ``(config, info)``.
    """
    _check_kind(kind)
    ds = length / (n_nodes - 1)
    hands, info1 = overhand_hands(length=length, n_nodes=n_nodes, a=a, **(first or {}))
    t0 = max(max(h.times) for h in hands) + settle
    desc = (f"single-rod {kind} tied from a straight rod: an overhand, then a half-knot of "
            f"{_handedness(kind)} handedness above it, pulled tight")
    rod = dict(length=length, n_nodes=n_nodes, radius=radius, youngs=youngs, density=density, damping=damping,
               mu=mu, dt=dt, out_dt=out_dt)
    x = _state_at(_config(hands, desc, t0, **rod), t0, state)
    # handedness of the second half-knot: the same motion as the first (granny) or its mirror (reef)
    new, b_t, b_p, a_t, a_p, info2 = second_half_knot_hands(x, t0, radius=radius, ds=ds,
                                                           mirror=(kind == "reef"), **(second or {}))
    for h in hands:
        if h.name == "end_b":
            h.times = list(h.times) + b_t
            h.points = list(h.points) + b_p
        if h.name == "end_a":
            h.times = list(h.times) + a_t
            h.points = list(h.points) + a_p
    cfg = _config(hands + new, desc, round(info2["t_end"] + 0.4, 6), **rod)
    return cfg, {"first": info1, "second": info2, "t_second": t0, "state": x}


def double_knot_sequence(kind: str, *, half_length=0.8, half_nodes=129, radius=2.5e-3, youngs=0.5e6,
                         density=1000.0, damping=0.05, mu=0.3, dt=2e-3, out_dt=0.05, **kw) -> dict:
    """Full run configuration (dict) tying a single-rod reef (``kind="reef"``) or granny from a
    straight rod: two overhands of opposite / the same handedness (:func:`two_overhands_hands`)."""
    hands, info = two_overhands_hands(kind, half_length=half_length, half_nodes=half_nodes, **kw)
    t_end = max(max(h.times) for h in hands)
    desc = (f"single-rod {kind} tied from a straight rod: two overhands of "
            f"{_handedness(kind)} handedness, one by each end, pulled tight")
    return _config(hands, desc, t_end + 0.4, length=info["length"], n_nodes=info["n_nodes"], radius=radius,
                   youngs=youngs, density=density, damping=damping, mu=mu, dt=dt, out_dt=out_dt)


def same_end_sequence(kind: str, *, length=1.3, n_nodes=209, a=0.12, pull1=0.45, t_end1=9.6, settle=0.3,
                      gap=0.03, pull2=0.1, radius=2.5e-3, youngs=0.5e6, density=1000.0, damping=0.05, mu=0.3,
                      dt=2e-3, out_dt=0.05, state=None):
    """Full run configuration (dict) tying a single-rod ``kind`` = ``"reef"`` or ``"granny"`` as two
    overhands tied one after the other by the same end B (see :mod:`knotsim.knots.tying`).
    Returns ``(config, info)``.

    Stage 1 is :func:`overhand_hands` on the whole rod (end A pulled back by ``pull1`` (m) and then
    held, end B drawing the long tail through the loop, ``pull1`` as well). Stage 2, from
    ``t0 = t_end1 + settle`` (s), is designed on the state reached then (computed here by running
    stage 1; pass that (N, 3) ``state`` (m) to skip the run): the overhand hands again, with
    relative paths, in the frame of the rope between the first knot and end B, the loop starting
    ``gap`` (m) after the first knot; for the reef they are mirrored through the vertical plane of
    that rope (the loop curls the other way: opposite handedness). Finally both ends are pulled by
    ``pull2`` (m).
    """
    _check_kind(kind)
    ds = length / (n_nodes - 1)
    hands, info1 = overhand_hands(length=length, n_nodes=n_nodes, a=a, pull=pull1, t_end=t_end1)
    t0 = round(t_end1 + settle, 9)
    desc = (f"single-rod {kind} tied from a straight rod: two overhands of "
            f"{_handedness(kind)} handedness tied one after the other by end B")
    rod = dict(length=length, n_nodes=n_nodes, radius=radius, youngs=youngs, density=density, damping=damping,
               mu=mu, dt=dt, out_dt=out_dt)
    x = _state_at(_config(hands, desc, t0, **rod), t0, state)
    knot = _knot_nodes(x, radius)
    if knot.size == 0:
        raise ValueError("no first knot found in the stage-1 state")
    i2 = int(knot.max()) + int(round(gap / ds))
    n_loc = n_nodes - i2
    local, info2 = overhand_hands(length=(n_loc - 1) * ds, n_nodes=n_loc, a=4 * ds, pull=pull2)
    origin = x[i2].copy()
    u = x[-1] - x[i2]
    u[2] = 0.0
    u /= np.linalg.norm(u)
    w = np.array([0.0, 0.0, 1.0])
    v = np.cross(w, u) * (-1.0 if kind == "reef" else 1.0)

    def world(q):
        return origin + q[0] * u + q[1] * v + q[2] * w

    new = []
    a_times = None
    for h in local:
        if h.name == "end_a":  # the local end A (node i2) is not gripped; end A itself pulls
            a_times = [t0 + h.times[1], t0 + h.times[2]]
            continue
        new.append(Hand(h.name + "2", [i2 + j for j in h.nodes], [t0 + t for t in h.times],
                        [world(np.asarray(p, float)) for p in h.points],
                        stop=None if h.stop is None else t0 + h.stop, rel=True))
    for h in hands:
        if h.name == "end_b":
            h.stop = t0
        if h.name == "end_a":
            p = np.asarray(h.points[-1], float)
            h.times = list(h.times) + a_times
            h.points = list(h.points) + [p, p - pull2 * u]
    cfg = _config(hands + new, desc, round(a_times[1] + 0.4, 6), **rod)
    info = {"first": info1, "second": info2, "t_second": t0, "knot1_nodes": (int(knot.min()), int(knot.max())),
            "second_start_node": i2, "state": x}
    return cfg, info


def same_end_header(kind: str, info: dict) -> str:
    """Comment header of the shipped ``reef`` / ``granny`` TOML (``info`` from :func:`same_end_sequence`)."""
    k0, k1 = info["knot1_nodes"]
    i2 = info["second_start_node"]
    t0 = info["t_second"]
    return (
        f"Single-rod {kind} tied from a straight rod (generated by "
        f"knotsim.knots.tying.same_end_sequence({kind!r})).\n"
        "Rope L = 1.3 m, N = 209, h = 2.5 mm, E = 0.5 MPa, eta = 0.05 Pa s, mu = 0.3, no gravity.\n"
        "Stage 1 (0-9.6 s), grips loop_*, tail, end_a, end_b: the overhand sequence (overhand.toml) at\n"
        "s = 0.12 m; end B draws the long tail through the loop; 5.6-9.6 s the ends are pulled apart by\n"
        "0.45 m each (end A then stays put): the first knot is snug, not fully tight.\n"
        f"Stage 2 (from {t0} s), grips *2 with paths relative to where they are at {t0} s: the same\n"
        f"overhand hands in the frame of the rope from the first knot (nodes {k0}-{k1} at {t0} s) to end B,\n"
        f"loop from node {i2}, threaded again by end B (end_b2)"
        + (", mirrored through the rope's vertical plane\n(the loop curls the other way: opposite "
           "handedness)." if kind == "reef" else " (same handedness).") + "\n"
        f"{t0 + 5.6:.1f}-{t0 + 8.6:.1f} s: loop grips released, both ends pulled by 0.1 m each.\n"
        "The result is two tight overhands about 0.2 m apart on one rod: topologically the connected\n"
        f"sum {'3_1 # 3_1* (square knot, reef)' if kind == 'reef' else '3_1 # 3_1 (granny)'} that the "
        "MAE259B single-rod knot is, not its shape.\n"
        f"Expected: knotsim.knots.topology.analyze of the final centreline -> "
        f"{'reef' if kind == 'reef' else 'granny (granny_right)'}."
    )


def write_sequence(cfg: dict, path, header: str = "") -> Path:
    """Write a configuration dict as a TOML run file (with an optional ``#`` comment header).

    Floats are written exactly (:func:`knotsim._util.toml.dumps_toml`): the file loads back to the
    very values of ``cfg``."""
    return write_toml(path, cfg, header)
