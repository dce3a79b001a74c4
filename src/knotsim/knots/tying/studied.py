"""The single-rod reef and granny in the studied (MAE259B) form, tied from a straight rod around a
temporary post: an overhand whose loop is kept open by the post, then a second half-knot tied on
top of it by the two legs, the post taken away at the end (see :mod:`knotsim.knots.tying`).

Every length is in metres, every time in seconds. The reef and the granny come from the one
function :func:`post_sequence`; their configurations differ only in the sense of the wrap of the
second half-knot (``z -> -z``: its mirror image).
"""

from __future__ import annotations

import math

import numpy as np

from knotsim.knots.tying.hands import Hand, _check_kind, _knot_nodes, overhand_hands

__all__ = ["post_header", "post_sequence"]


def _frame(x: np.ndarray, radius: float, post_center: np.ndarray):
    """Knot centre ``c`` (m), rope direction ``u`` (end A to end B, in the xy plane) and ``up``
    (in the xy plane, away from the post: where the second half-knot goes) of the state ``x``
    (N, 3), and the first knot's node range."""
    knot = _knot_nodes(x, radius)
    if knot.size == 0:
        raise ValueError("no first knot found in the stage-1 state")
    k0, k1 = int(knot.min()), int(knot.max())
    c = x[knot].mean(axis=0)
    u = x[-1] - x[0]
    u[2] = 0.0
    u /= np.linalg.norm(u)
    n = post_center - c
    n[2] = 0.0
    n -= (n @ u) * u
    if np.linalg.norm(n) < 1e-6:
        raise ValueError("the post lies on the rope line: no side for the second half-knot")
    return c, u, -n / np.linalg.norm(n), (k0, k1)


def post_sequence(kind: str, *, length=1.3, n_nodes=209, a=0.45, pull1=0.3, t_end1=8.6, settle=0.3,
                  post_radius=0.006, post_height=1.55, post_drop=0.12, t_post=4.9, post_half_length=0.08, lift=0.04, wrap_radius=0.012,
                  wrap_half_width=0.02, turn=0.06, reach_b=0.15, pull2=0.12, post_out=0.1,
                  radius=2.5e-3, youngs=0.5e6, density=1000.0, damping=0.05, mu=0.3, dt=2e-3, out_dt=0.05,
                  state=None):
    """Full run configuration (dict) tying a single-rod ``kind`` = ``"reef"`` or ``"granny"`` in the
    studied form (see :mod:`knotsim.knots.tying`); returns ``(config, info)``.

    Stage 1 (0 .. ``t_end1``): :func:`~knotsim.knots.tying.hands.overhand_hands` with the loop
    starting at arc length ``a`` (m), the ends pulled apart by ``pull1`` (m) each, around a
    frictionless capsule post (radius ``post_radius``, along z, inside the loop at ``post_height``
    loop radii above the crossing): the overhand tightens onto the post and its loop stays open.
    Stage 2, from ``t0 = t_end1 + settle`` and designed on the state reached then (computed here by
    running stage 1, or pass that (N, 3) ``state``, m): the bottom of the loop (at the post) is
    held; end A (re-gripped as one node) swings round and, with a grip on the A leg ``turn`` (m)
    from the knot, lays that leg straight across the knot, ``lift`` (m) on the side away from the
    post; end B goes round to that side and wraps 1.5 turns (radius ``wrap_radius``, over a length
    ``2 wrap_half_width``) round the straight A leg, towards end A's side, then on by ``reach_b``;
    the sense of the wrap is the only difference between granny and reef (mirror image). Then the
    ends are pulled apart by ``pull2`` each and the post slides out along its axis by ``post_out``.
    """
    _check_kind(kind)
    ds = length / (n_nodes - 1)
    hands, info1 = overhand_hands(length=length, n_nodes=n_nodes, a=a, pull=pull1, t_end=t_end1)
    X, R = info1["X"], info1["R"]
    post_c = X + np.array([0.0, post_height * R, 0.0])
    # the post comes down along its axis into the loop once end B has threaded it (t_post), from
    # post_drop (m) above its place
    start = post_c + [0.0, 0.0, post_drop]
    post = {"type": "capsule", "name": "post", "a": [float(v) for v in start - [0, 0, post_half_length]],
            "b": [float(v) for v in start + [0, 0, post_half_length]], "radius": post_radius, "mu": 0.0}
    t_in = (t_post, t_post + 0.6)
    post["waypoints"] = {"times": [0.0, t_in[0], t_in[1]], "points": [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0],
                                                                       [0.0, 0.0, -post_drop]]}
    t0 = round(t_end1 + settle, 9)
    rod = dict(length=length, n_nodes=n_nodes, radius=radius, youngs=youngs, density=density,
               damping=damping, mu=mu, dt=dt, out_dt=out_dt)
    desc = (f"single-rod {kind} tied from a straight rod around a temporary post: an overhand, then a "
            f"half-knot of {'opposite' if kind == 'reef' else 'the same'} handedness on top of it")
    if state is None:
        from knotsim.knots.tying.sequences import _state_at

        stage1 = _cfg(hands, [post], desc, t0, **rod)
        state = _state_at(stage1, t0, None)
    x = np.asarray(state, float)
    c, u, up, (k0, k1) = _frame(x, radius, post_c)
    zs = 1.0 if kind == "granny" else -1.0  # the mirror: the sense of the wrap
    z = np.array([0.0, 0.0, 1.0])
    w, r, Y = wrap_half_width, wrap_radius, lift
    # A leg laid straight across the knot at `lift` on the far side: a grip `turn` (m of rope) from
    # the knot holds the bend, end A swings round (at twice the lift, then down onto the line)
    i_turn = k0 - int(round(turn / ds))
    if i_turn < 10:
        raise ValueError(f"the A leg (nodes 0-{k0}) is too short for turn = {turn} m")
    a_turn = c - u * (w + 0.02) + up * Y
    a_end = a_turn + u * (i_turn * ds / 1.06)
    t_a = [t0, t0 + 0.5, t0 + 4.0, t0 + 4.8]
    tb0 = t0 + 4.8
    t_rel = tb0 + 7.2
    t_end2 = t_rel + 3.0
    new = [Hand("a_turn", [i_turn], t_a[:2], [x[i_turn], a_turn], stop=t_rel, rel=True),
           Hand("end_a2", [0], t_a + [t_rel, t_end2],
                [x[0], x[0] + 2.0 * up * Y, a_end + up * Y, a_end, a_end, a_end + pull2 * u], rel=True)]
    # end B: round to the far side, along to the wrap, 1.5 turns round the A leg, on towards A's side
    th = np.linspace(0.0, 3.0 * math.pi, 13)
    helix = [c + u * (w - 2.0 * w * t / (3.0 * math.pi)) + up * (Y - r * math.cos(t)) + zs * z * r * math.sin(t)
             for t in th]
    b_exit = c - u * reach_b + up * (Y + r)
    b_pts = [x[-1], x[-1] + up * (Y - r), c + u * (w + 0.01) + up * (Y - r)] + helix + [b_exit, b_exit,
                                                                                        b_exit - pull2 * u]
    b_t = [tb0, tb0 + 0.5, tb0 + 3.5] + list(tb0 + 3.5 + np.linspace(0.15, 2.0, 13)) + [tb0 + 7.0, t_rel, t_end2]
    new.append(Hand("end_b2", [n_nodes - 1], [round(float(t), 9) for t in b_t], b_pts, rel=True))
    # the first knot stays put: the bottom of its loop (at the post) and the B leg next to it held
    # (the leg until end B has come round, the loop until the final pull)
    i_bot = k0 + int(np.argmin(np.linalg.norm((x[k0:k1 + 1] - post_c)[:, :2], axis=1)))
    i_bleg = k1 + int(round(turn / ds))
    new += [Hand("loop_hold", [i_bot - 1, i_bot, i_bot + 1], [t0, t_rel], [x[[i_bot - 1, i_bot, i_bot + 1]].mean(0)] * 2,
                 stop=t_rel, rel=True),
            Hand("b_hold", [i_bleg], [t0, tb0 + 0.5], [x[i_bleg]] * 2, stop=tb0 + 0.5, rel=True)]
    for h in hands:
        if h.name in ("end_a", "end_b"):
            h.stop = t0
    post["waypoints"] = {"times": [0.0, t_in[0], t_in[1], t_end2, t_end2 + 1.0],
                         "points": [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, -post_drop], [0.0, 0.0, -post_drop],
                                    [0.0, 0.0, -post_drop - post_out]]}
    cfg = _cfg(hands + new, [post], desc, round(t_end2 + 1.5, 6), **rod)
    info = {"first": info1, "t_second": t0, "knot1_nodes": (k0, k1), "a_turn_node": i_turn, "hold_node": i_bot,
            "post_center": post_c, "state": x, "t_pull": t_rel, "t_post_out": t_end2}
    return cfg, info


def _cfg(hands, obstacles, description, duration, **rod) -> dict:
    from knotsim.knots.tying.sequences import _config

    cfg = _config(hands, description, duration, **rod)
    cfg["obstacles"] = obstacles
    return cfg


def post_header(kind: str, info: dict) -> str:
    """Comment header of the shipped ``reef`` / ``granny`` TOML (``info`` from :func:`post_sequence`)."""
    k0, k1 = info["knot1_nodes"]
    t0 = info["t_second"]
    return (
        f"Single-rod {kind} in the studied (MAE259B) form, tied from a straight rod around a temporary post\n"
        f"(generated by knotsim.knots.tying.post_sequence({kind!r})).\n"
        "Rope L = 1.3 m, N = 209, h = 2.5 mm, E = 0.5 MPa, eta = 0.05 Pa s, mu = 0.3, no gravity.\n"
        "Stage 1 (0-8.6 s): the overhand hands (overhand.toml) with the loop at s = 0.45 m, tied round a\n"
        "frictionless capsule post (r = 6 mm, along z) inside the loop; the ends pulled apart 0.3 m each:\n"
        "the overhand tightens onto the post, its loop stays open (the bottom of the loop: the hold).\n"
        f"Stage 2 (from {t0} s), paths relative to the grips' positions at {t0} s (first knot: nodes {k0}-{k1}):\n"
        f"end A (one node) and grip a_turn (node {info['a_turn_node']}) lay the A leg straight across the knot,\n"
        "4 cm on the side away from the post; end B goes round to that side and wraps 1.5 turns round the\n"
        "A leg towards A's side (the second half-knot, on top of the first; "
        + ("mirrored: the wrap turns the other way,\nopposite handedness" if kind == "reef" else
           "same handedness") + f"); {info['t_pull']:.1f}-{info['t_post_out']:.1f} s: ends pulled 0.12 m "
        "each;\nthen the post slides out along its axis.\n"
        f"Expected: knotsim.knots.topology.analyze of the final centreline -> "
        f"{'reef (3_1 # 3_1*)' if kind == 'reef' else 'granny (3_1 # 3_1)'}, half_knot_gap <= 10 diameters."
    )
