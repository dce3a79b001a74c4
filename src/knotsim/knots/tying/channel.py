"""The single-rod reef and granny in the studied (MAE259B) form, tied from a straight rod by feeding
it through a knotting channel, then tightened with the bottom of the first loop held.

Every length is in metres, every time in seconds. The channel is the studied form laid out loosely:
the drawing ``single_rod_reef`` of :mod:`knotsim.knots.library` built in 3D at the rope's radius
with a wide clearance. For the granny the same drawing is used with the three crossings of the
second half-knot mirrored (their over/under letters swapped): the two channels differ only there,
and so do the two sequences (:func:`channel_sequence`).

Feeding (0 .. ``t_feed``): the rope starts straight on the channel's entry line (the continuation
of end A's tail) and slides along the channel like a train on its track, end B first: every
``guide_every``-th node (and both ends) is a single-node grip whose path is the channel's
centreline, all at the same arc speed, so that no strand ever leaves the channel and no two
strands meet. Walking the channel, end B lays the A tail, passes the crossings of the second
half-knot for the first time, completes the first half-knot (the overhand, round the bottom
loop), and then completes the second half-knot on top of it.

Tightening (``t_feed`` .. end): the grips let go; the bottom of the first overhand's loop (the
drawing's hold hint) is held, and the two ends are pulled apart along the end-to-end line by
``pull`` each at ``pull_speed``; contact and friction keep the crossings, the loose knot shrinks
onto itself and the second half-knot stays on top of the first.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from knotsim.knots.tying.hands import _check_kind
from knotsim.knots.tying.sequences import _config

__all__ = ["DEFAULT_N_NODES", "SECOND_HALF_KNOT_PASSES", "channel_curve", "channel_header", "channel_sequence"]

#: Indices, among the 12 over/under letters of the ``single_rod_reef`` drawing (in walking order),
#: of the passes through the three crossings of the second half-knot (the one on top, that both
#: legs run through); swapping them mirrors that half-knot (reef <-> granny).
SECOND_HALF_KNOT_PASSES = (0, 1, 2, 9, 10, 11)

#: Default number of nodes of the tied rope (1.3 m: 2.17 mm = 0.43 rope diameters between nodes).
#: Chosen from the resolution rows of ``validation/studies/convergence_tied/convergence.md``: with
#: the rope tied again at N = 201, 301, 401, 601, the pulled means still fell by 2-7 % from
#: N = 301 to 601 (against <= 0.6 % for dt, contact stiffness and delta), and the former default
#: N = 209 put the mu = 0.1 granny 31 % above its N = 601 value; so the tie is shipped at 601.
DEFAULT_N_NODES = 601


def channel_curve(kind: str, *, length=1.3, n_nodes=DEFAULT_N_NODES, radius=2.5e-3, margin=0.6):
    """The channel's centreline: the studied-form drawing built at ``radius`` (m), ``length`` (m),
    ``n_nodes`` (default :data:`DEFAULT_N_NODES` = 601, see there why), pairs pushed to
    ``2 radius (1 + margin)`` apart (see
    :func:`knotsim.knots.build.build_knot`), the second half-knot mirrored for the granny.

    Returns ``(x, hold_node)``: (n_nodes, 3) node positions (m) and the node of the hold hint."""
    from knotsim.knots.build import build_knot
    from knotsim.knots.library import load_knot_spec

    _check_kind(kind)
    spec = load_knot_spec("single_rod_reef")
    rope = spec.ropes[0]
    passes = list(rope.passes)
    if kind == "granny":
        for k in SECOND_HALF_KNOT_PASSES:
            passes[k] = not passes[k]
    spec = dataclasses.replace(spec, name=f"single_rod_{kind}",
                               ropes=(dataclasses.replace(rope, passes=tuple(passes)),))
    geo = build_knot(spec, n_nodes=n_nodes, radius=radius, length=length, margin=margin)
    return np.asarray(geo.ropes[0], float), int(geo.held[0].node)


def _simplify(p: np.ndarray, tol: float) -> list[int]:
    """Indices of the vertices of the polyline ``p`` (M, 3) kept by Douglas-Peucker at ``tol`` (m)."""
    keep = np.zeros(len(p), bool)
    keep[0] = keep[-1] = True
    stack = [(0, len(p) - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        a, b = p[i], p[j]
        ab = b - a
        t = np.clip((p[i + 1:j] - a) @ ab / max(ab @ ab, 1e-30), 0.0, 1.0)
        d = np.linalg.norm(p[i + 1:j] - (a + t[:, None] * ab), axis=1)
        k = int(np.argmax(d))
        if d[k] > tol:
            m = i + 1 + k
            keep[m] = True
            stack += [(i, m), (m, j)]
    return [int(k) for k in np.flatnonzero(keep)]


def _bc(name, nodes, times, disp, *, start=None, stop=None, twist=None) -> dict:
    bc = {"type": "move", "name": name, "rod": "rope", "nodes": [int(n) for n in nodes]}
    if twist is not None:
        bc["twist"] = bool(twist)
    if start:
        bc["start"] = float(start)
    if stop is not None:
        bc["stop"] = float(stop)
    bc["waypoints"] = {"times": [round(float(t), 9) for t in times],
                       "points": [[round(float(v), 6) for v in p] for p in disp]}
    return bc


def channel_sequence(kind: str, *, length=1.3, n_nodes=DEFAULT_N_NODES, radius=2.5e-3, margin=0.6, guide_every=4,
                     feed_speed=0.25, t_ramp=0.5, tol=1e-4, settle=0.3, pull=0.22, pull_speed=0.03,
                     hold_nodes=3, youngs=0.5e6, density=1000.0, damping=0.05, mu=0.3, dt=2e-3,
                     out_dt=0.05):
    """Full run configuration (dict) tying a single-rod ``kind`` = ``"reef"`` or ``"granny"`` in the
    studied form (module docstring); returns ``(config, info)``.

    Channel: :func:`channel_curve` (``length``, ``n_nodes``, ``radius``, ``margin``; ``n_nodes``
    defaults to :data:`DEFAULT_N_NODES` = 601, the resolution at which the convergence table
    ``validation/studies/convergence_tied/convergence.md`` was read: N = 209 and 301 are not
    converged); its vertices
    are thinned to ``tol`` (m) for the grip paths. Feeding: every ``guide_every``-th node and both
    ends slide along the channel at ``feed_speed`` (m/s), reached and left over ``t_ramp`` (s,
    speed linear in time); then ``settle`` (s) at rest, grips still on. Tightening: grips
    released, ``hold_nodes`` (odd) nodes round the hold hint held, the end pairs pulled apart by
    ``pull`` (m) each at ``pull_speed`` (m/s).
    """
    _check_kind(kind)
    if not (isinstance(hold_nodes, int) and hold_nodes >= 1 and hold_nodes % 2 == 1):
        raise ValueError(f"hold_nodes must be an odd number >= 1, got {hold_nodes!r}")
    ds = length / (n_nodes - 1)
    curve, hold = channel_curve(kind, length=length, n_nodes=n_nodes, radius=radius, margin=margin)
    t0 = curve[1] - curve[0]
    t0 /= np.linalg.norm(t0)
    if abs(t0[0]) < 0.999:
        raise ValueError(f"the channel's entry is not along +x (tangent {t0})")
    # the channel in the run's frame: its entry (node 0 of the knot) at (length, 0, 0), the entry
    # line along -x back to the origin, where the straight rod lies at t = 0
    curve = curve - curve[0] + np.array([length, 0.0, 0.0])
    k = n_nodes - 1
    feed = np.array([[length - j * ds, 0.0, 0.0] for j in range(k, 0, -1)])
    path = np.concatenate([feed, curve])      # path index p = sigma + k, sigma in [-k, n_nodes - 1]
    keep = _simplify(path, tol)
    # arc parameter (in nodes) run through by every grip: piecewise linear speed, ramps at both ends
    v = feed_speed / ds                       # nodes per second
    t_const = (k - v * t_ramp) / v
    if t_const < 0:
        raise ValueError(f"feed_speed {feed_speed} m/s too high for t_ramp {t_ramp} s")
    t_feed = 2.0 * t_ramp + t_const
    n_r = 4
    tr = np.linspace(0.0, t_ramp, n_r + 1)
    brk_t = np.concatenate([tr, t_ramp + t_const + tr[1:]])
    brk_u = np.concatenate([0.5 * v * tr**2 / t_ramp,
                            0.5 * v * t_ramp + v * t_const + v * tr[1:] - 0.5 * v * tr[1:]**2 / t_ramp])
    # piecewise-linear u(t) through the ramp samples (u in nodes, u(t_feed) = k)
    brk_u *= k / brk_u[-1]

    def t_of(u):
        return float(np.interp(u, brk_u, brk_t))

    x0 = np.zeros((n_nodes, 3))
    x0[:, 0] = np.arange(n_nodes) * ds
    guides = sorted(set(range(0, n_nodes, guide_every)) | {n_nodes - 1})
    bcs = []
    t_rel = round(t_feed + settle, 6)
    for i in guides:
        # node i sits at path index i + u(t)
        us = sorted({float(u) for u in brk_u} | {float(p - i) for p in keep if 0 < p - i < k})
        times = [t_of(u) for u in us]
        pts = []
        for u in us:
            p = i + u
            j = min(int(np.floor(p)), len(path) - 2)
            f = p - j
            pts.append((1.0 - f) * path[j] + f * path[j + 1] - x0[i])
        pts[0] = np.zeros(3)
        bcs.append(_bc(f"guide_{i}", [i], times, pts, stop=t_rel))
    # tightening: ends pulled apart along the end-to-end line, the bottom of the first loop held
    e = curve[-1] - curve[0]
    e /= np.linalg.norm(e)
    t_pull = pull / pull_speed
    for name, nodes, sgn in (("pull_a", [0, 1], -1.0), ("pull_b", [n_nodes - 2, n_nodes - 1], 1.0)):
        bcs.append(_bc(name, nodes, [0.0, t_pull], [np.zeros(3), sgn * pull * e], start=t_rel, twist=True))
    held = list(range(hold - hold_nodes // 2, hold + hold_nodes // 2 + 1))
    bcs.append({"type": "hold", "name": "loop_hold", "rod": "rope", "nodes": held, "start": t_rel})
    desc = (f"single-rod {kind} in the studied form, tied from a straight rod fed through a channel (an "
            f"overhand, then a half-knot of {'opposite' if kind == 'reef' else 'the same'} handedness on top "
            "of it), tightened with the bottom of the first loop held")
    cfg = _config([], desc, round(t_rel + t_pull + 0.2, 6), length=length, n_nodes=n_nodes, radius=radius,
                  youngs=youngs, density=density, damping=damping, mu=mu, dt=dt, out_dt=out_dt)
    cfg["bc"] = bcs
    info = {"hold_node": hold, "held_nodes": held, "t_feed": t_feed, "t_release": t_rel, "t_pull": t_pull,
            "n_guides": len(guides), "guide_every": guide_every, "pull": pull, "curve": curve, "path_vertices": len(keep)}
    return cfg, info


def channel_header(kind: str, cfg: dict, info: dict) -> str:
    """Comment header of the shipped ``reef`` / ``granny`` TOML (from :func:`channel_sequence`)."""
    rod = cfg["rods"][0]
    return (
        f"Single-rod {kind} in the studied (MAE259B) form, tied from a straight rod fed through a knotting channel\n"
        f"(generated by knotsim.knots.tying.channel_sequence({kind!r})).\n"
        f"Rope L = {rod['length']} m, N = {rod['n_nodes']}, h = {rod['radius'] * 1e3:g} mm, "
        f"E = {rod['youngs_modulus'] / 1e6:g} MPa, eta = {cfg['model']['damping']} Pa s, mu = {cfg['contact']['mu']}, "
        "no gravity.\n"
        f"Feeding (0-{info['t_feed']:.2f} s): {info['n_guides']} single-node grips guide_* (every "
        f"{info['guide_every']}th node and both ends) slide the rope\nalong the channel, end B first: the studied-form drawing single_rod_reef "
        + ("" if kind == "reef" else "with the three crossings of the\nsecond half-knot mirrored ")
        + "laid out loosely; end B completes the overhand round the bottom loop,\nthen the second half-knot on "
        f"top of it. From {info['t_release']:.2f} s: grips released, nodes {info['held_nodes']} (the bottom of\n"
        f"the first loop) held, ends pulled apart {info['pull']} m each along the end-to-end line in "
        f"{info['t_pull']:.1f} s.\n"
        f"Expected: knotsim.knots.topology.analyze of the final centreline -> "
        f"{'reef (3_1 # 3_1*)' if kind == 'reef' else 'granny (3_1 # 3_1)'}, half_knot_gap <= 10 diameters."
    )
