"""Protocol ``two-rope-bend``: bends tied between two ropes (Patil et al., Science 2020;
docs/physics.md §4.3).

Reef, granny, thief and grief bends (``reef_bend``, ``granny_bend``, ``thief_bend``,
``grief_bend``; ``h = 2 mm``, ``L = 1 m`` per rope, ``N = 301``). Loading as in Patil's study: the
end of rope A named by the knot's ``held`` hint is clamped (its two end nodes and their edge
angle), the end of rope B named by the ``pulled`` hint is pulled away along the axis from the
held end to the pulled end, the two other ends (the tails) are free. Patil's friction was a
viscous coupling, so only the ranking of the bends carries over, not the numbers; the default
``mu`` is 0.3, the default time step 2 ms (none published). The loose drawings snap their ring
strands together at t = 0.16 s (contacts jump from about 15 to 80 in 40 ms); Newton used to cycle
there at every step size (grief at 2.5 ms, thief at 1 and 1.5 ms, granny and grief at mu = 0.5);
the safeguard of :func:`knotsim.solver.newton.newton_solve` removed those stalls.

Two modes (parameter ``mode``):

* ``"displacement"``: the pulled end (two nodes + edge angle) moves at ``pull_speed`` (m/s,
  default 10 mm/s) for ``pull_length`` (m, default 0.4: 40 s) unless ``duration`` is given;
  recorded: the axial reaction ``F`` (N) there;
* ``"force"``: a total force ``F = force_rate * t`` (N, ``force_rate`` in N/s) along the axis is
  applied to the two pulled end nodes (twist free) for 40 s unless ``duration`` is given;
  recorded: the applied ``F``.

Cinching stage (``pre_tighten``, m, default 0 = off): the library bends are drawn loose, and
Patil compared tightened bends. With ``pre_tighten = p`` all four ends (two end nodes and their
edge angle each) first move outwards along their own end tangents by ``p`` at
``pre_tighten_speed`` (m/s), taking ``t_pre = p / pre_tighten_speed``; then the tails are released,
the held end stays where it got to, and the pull (or the force ramp) starts. The metrics refer to
the pull after ``t_pre`` (their times count from ``t_pre``); the run lasts ``t_pre`` longer.

In both modes the log has ``F``, ``F_norm = F h^2 / EI``, ``F_held`` (N, axial reaction at the
held end, positive in tension), ``u_pull`` (m): displacement of the pulled end along the axis
since the start, the tail lengths ``tail_a``, ``tail_b`` (m) and ``rope_gap`` (m): the smallest
distance between a node of one rope and a node of the other.

Tail length (definition): the arc length from a free end, walking inwards, to where the rope
first comes within ``2h + delta + l/2`` (``l`` the mean edge length) of a node of the *other* rope,
interpolated along the edge between the last node outside and the first inside from their
distances (so it changes continuously as rope slides through, not in steps of one edge), i.e.
the length of the free tail outside the knot (a bend is held by the two ropes interlocking; a
tail lying on its own standing part away from the knot does not count). Tail draw-in = decrease of the tail length over the
run (positive when the knot swallows its tails); the pulled-end draw-in is the increase of
``u_pull``. In force control ``u_pull`` is the displacement that answers the applied force.

Topology check (start and end): the two ropes, each closed on itself (radial closure), are a
two-component link; the key compared is each rope's own knot type, the linking number and the
link's Jones polynomial (:func:`link_key`). A different key is ``changed knot type``; a split link
at the end (linking number 0, Jones polynomial of the split link of the ropes' own knots) is
``untied``. The ropes of the reef and thief bends, closed on themselves, are an unlink from the
start, so for them (and any bend whose link is split) ``untied`` is decided by geometry: the ropes
are apart at the end (no node of one within ``4h`` of the other, ``rope_gap_final``). The whole-bend
closure :func:`~knotsim.knots.topology.close_bend` (standing ends joined, tails joined) names a bend but moves with the
loose tails and is not used for the outcome.

Metrics (times in s from the start of the pull, after any ``settle_time`` and cinching stage):
mean ``F_norm`` over the pull and its peak after the start-up transient (``F_norm_peak`` at
``F_norm_peak_time``: the loose drawing rings the rope as its strands snap together, far above the
load the bend then holds); the holding force ``F_norm_hold``: the largest
0.5 s moving average of ``F_norm`` after the start-up transient (the first ``transient`` s,
default 2 s), i.e. the peak force the bend carries before or while it gives way; tail and
pulled-end draw-in; and the slip onset, which decides the outcome ``"slipped"``:

* displacement control: the two free tails are drawn into the knot together faster than
  ``slip_draw_in_rate`` x ``pull_speed`` (default 0.25; tail lengths on a 2 s centred average)
  for at least ``slip_hold`` s (default 2 s) after the transient
  (:func:`knotsim.protocols.metrics.draw_in_onset`). A bend's pull force need not drop when it
  slips: a tightened bend whose tails run in loses only ~15 % of its force, and a loose bend
  slides from the start with no peak to drop from, so the force-drop rule (first drop of the
  0.5 s average by more than 30 % below its running maximum, once that exceeds half the largest
  averaged force) is only reported, as ``force_drop_onset``;
* force control: the pulled end runs away, its speed (displacement on a 0.5 s average) above
  ``runaway_speed`` for 0.5 s after the transient; ``F_norm_hold`` is then the applied force at
  the onset (the largest applied force when the bend never runs away).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from knotsim.errors import ConfigError
from knotsim.protocols.base import LoadingProtocol, RunContext, end_group_nodes, stage_duration, unit
from knotsim.protocols.geometry import default_ends, parse_end
from knotsim.protocols.metrics import (
    draw_in_onset,
    moving_average,
    slip_onset,
    sustained_onset,
    tail_draw_in,
    window_mean,
    window_peak_at,
)
from knotsim.protocols.timeline import measured_log, pull_start


def entry_arc_length(x: np.ndarray, dist: np.ndarray, cutoff: float, from_last: bool) -> float:
    """Arc length (m) from one end of a rope to where it first comes within ``cutoff`` of something
    else, interpolated along the edge on which that happens.

    ``x`` ``(N, 3)`` node positions (m); ``dist`` ``(N,)`` each node's distance (m) to the nearest
    point of the other thing (``inf`` where farther than anything that matters); from the first node
    (``from_last`` False) or the last. With ``i`` the first node (counted from that end) with
    ``dist[i] <= cutoff`` and ``j`` the node before it, the entry is at the fraction
    ``(dist[j] − cutoff)/(dist[j] − dist[i])`` of the edge from ``j`` to ``i``: the length changes
    continuously as the rope slides, not in steps of one edge. The whole length when no node is
    within ``cutoff``; 0 when the end node is."""
    if from_last:
        x = x[::-1]
        dist = dist[::-1]
    seg = np.linalg.norm(np.diff(x, axis=0), axis=1)
    inside = np.flatnonzero(dist <= cutoff)
    if inside.size == 0:
        return float(seg.sum())
    i = int(inside[0])
    if i == 0:
        return 0.0
    d_out, d_in = float(dist[i - 1]), float(dist[i])
    frac = 1.0 if not np.isfinite(d_out) else (d_out - cutoff) / (d_out - d_in)
    return float(seg[:i - 1].sum() + frac * seg[i - 1])


def tail_lengths(ropes: list[np.ndarray], free_ends: list[tuple[int, int]], radius: float,
                 delta: float) -> list[float]:
    """Length (m) of each free tail outside the knot (see the module docstring): the arc length from
    the tail's end to where it first comes within ``2h + delta + l/2`` of a node of another rope
    (``l`` the mean edge length), interpolated along the edge (:func:`entry_arc_length`).

    Parameters
    ----------
    ropes:
        ``(N_k, 3)`` node positions of each rope, m.
    free_ends:
        ``(rope index, end)`` with end 0 (first node) or 1 (last node).
    radius, delta:
        Rod radius ``h`` and contact tolerance, m.
    """
    out = []
    for r, end in free_ends:
        x = ropes[r]
        seg = float(np.mean(np.linalg.norm(np.diff(x, axis=0), axis=1)))
        cutoff = 2.0 * radius + delta + 0.5 * seg
        others = np.concatenate([y for k, y in enumerate(ropes) if k != r])
        dist = cKDTree(others).query(x, distance_upper_bound=4.0 * cutoff)[0]
        out.append(entry_arc_length(x, dist, cutoff, end == 1))
    return out


def self_tail_lengths(x: np.ndarray, radius: float, delta: float) -> list[float]:
    """Length (m) of each end of one rope outside its own knot, ``[first end, last end]``: from the
    end to where it first comes within the contact distance of the rope itself (cut-off as in
    :func:`tail_lengths`, interpolated along the edge as there), not counting the nodes next to it
    along the rope (within half a turn of that distance, ``π`` x the cut-off of arc length: a bend
    cannot bring them closer).

    ``x`` ``(N, 3)`` node positions (m); ``radius`` and ``delta`` the rod radius and contact
    tolerance (m)."""
    seg = float(np.mean(np.linalg.norm(np.diff(x, axis=0), axis=1)))
    cutoff = 2.0 * radius + delta + 0.5 * seg
    skip = int(np.ceil(np.pi * cutoff / seg)) + 1
    # each node's distance to the nodes of the rope more than `skip` nodes away (inf beyond 4 cut-offs)
    tree = cKDTree(x)
    dist = np.full(len(x), np.inf)
    pairs = tree.query_pairs(4.0 * cutoff, output_type="ndarray")
    if len(pairs):
        far = pairs[np.abs(pairs[:, 0] - pairs[:, 1]) > skip]
        if far.size:
            d = np.linalg.norm(x[far[:, 0]] - x[far[:, 1]], axis=1)
            np.minimum.at(dist, far[:, 0], d)
            np.minimum.at(dist, far[:, 1], d)
    if not np.any(dist <= cutoff):
        return [float(np.linalg.norm(np.diff(x, axis=0), axis=1).sum()), 0.0]  # no knot: counted once
    return [entry_arc_length(x, dist, cutoff, False), entry_arc_length(x, dist, cutoff, True)]


#: The ropes are *apart* when no node of one is within this many rod radii of a node of the other
#: (centreline distance 4h: one rope diameter of clear space between their surfaces).
APART_RADII = 4.0


def turning_in_knot(x: np.ndarray, outside_first: float, outside_last: float) -> float:
    """Total turning angle (rad) of a rope inside the knot: the sum of the angles between successive
    edges at the nodes whose arc length lies between ``outside_first`` (m, from the first node) and
    the total length less ``outside_last`` (m, from the last node), e.g. the lengths of its two ends
    outside the knot (:func:`tail_lengths`). A straight rope through the knot turns by about 0, a rope
    that goes round another and back by π or more. ``x`` ``(N, 3)`` node positions (m)."""
    e = np.diff(np.asarray(x, float), axis=0)
    lengths = np.linalg.norm(e, axis=1)
    t = e / lengths[:, None]
    s = np.cumsum(lengths)[:-1]  # arc length of the interior nodes 1 .. N-2
    inside = (s >= outside_first) & (s <= float(np.sum(lengths)) - outside_last)
    angles = np.arccos(np.clip(np.einsum("ij,ij->i", t[1:], t[:-1]), -1.0, 1.0))
    return float(np.sum(angles[inside]))


def rope_gap(ropes: list[np.ndarray]) -> float:
    """Smallest distance (m) between a node of rope 0 and a node of rope 1 (``(N_k, 3)`` node
    positions, m): the centreline distance, ``2h`` when the ropes touch."""
    return float(cKDTree(ropes[1]).query(ropes[0])[0].min())


def free_tail_ends(held, pulled) -> list[tuple[int, int]]:
    """``(rope, end)`` of the two free tails: the other end of the held and of the pulled rope
    (end 0 = first node, 1 = last node)."""
    return [(held.rope, 0 if held.node != 0 else 1), (pulled.rope, 0 if pulled.node != 0 else 1)]


def ends_interleaved(ropes: list[np.ndarray], standing: list[tuple[int, int]]) -> bool:
    """Whether the two standing ends and the two tails alternate around the knot (thief and grief
    bends) rather than lying side by side (reef and granny): the angular order of the four end
    nodes about the centroid, in the plane of largest spread of all nodes.

    Parameters
    ----------
    ropes:
        The two ropes' ``(N, 3)`` node positions (m).
    standing:
        ``(rope, node)`` of the two standing ends.
    """
    allp = np.concatenate(ropes)
    c = allp.mean(axis=0)
    e = np.linalg.svd(allp - c, full_matrices=False)[2]
    ends = []
    for r, x in enumerate(ropes):
        for node in (0, len(x) - 1):
            p = x[node] - c
            ends.append((math.atan2(float(p @ e[1]), float(p @ e[0])), (r, node) in standing))
    kinds = [k for _, k in sorted(ends)]
    return all(kinds[i] != kinds[(i + 1) % 4] for i in range(4))


def _jones_text(v: dict) -> str:
    """Jones polynomial ``{exponent: coefficient}`` as text, as the protocols' topology record
    writes it (``"-1t^1/2 -1t^5/2"``: coefficient and exponent of each term, exponents rising)."""
    return " ".join(f"{c:+d}t^{e}" for e, c in sorted(v.items()) if c)


def split_jones(types: list[str]) -> str | None:
    """Jones polynomial (as :func:`_jones_text`) of the split link of two knots of the given table
    types, ``V(K_a) V(K_b) (-t^(1/2) - t^(-1/2))``; ``None`` when a type is not in the table."""
    from fractions import Fraction

    from knotsim.knots.topology import KNOT_TABLE
    from knotsim.knots.topology.polynomials import _pmul_jones

    table = {e.knot_type: dict(e.jones) for e in KNOT_TABLE}
    if any(t not in table for t in types):
        return None
    v = {Fraction(1, 2): -1, Fraction(-1, 2): -1}
    for t in types:
        v = _pmul_jones(v, table[t])
    return _jones_text(v)


def link_key(topo: dict) -> str:
    """Topology key of a two-rope bend from its topology record (the two ropes each closed on
    itself; keys ``component_types``, ``linking_number``, ``jones``): ``"unlink"`` when the ropes
    have come apart (linking number 0 and the Jones polynomial of the split link of the two ropes'
    own knots, :func:`split_jones`; the ropes may keep their own knots, e.g. the overhands of a
    hunter's bend), else ``"A + B; lk n; V = ..."`` (the Jones polynomial left out when it was not
    computed). Two records with the same key are the same link as far as these invariants tell."""
    types = [str(t) for t in topo["component_types"]]
    lk = int(topo.get("linking_number") or 0)
    jones = topo.get("jones")
    if lk == 0 and jones is not None and jones == split_jones(types):
        return "unlink"
    return f"{' + '.join(types)}; lk {lk}" + (f"; V = {jones}" if jones is not None else "")


def bend_names(ctx: RunContext) -> dict:
    """The starting bend named by its whole-bend closure (:func:`knotsim.knots.topology.analyze_bend`:
    standing ends joined above, tails below): ``bend_closure`` (its knot type, e.g. ``"reef"``) and
    ``bend_name`` (from :data:`~knotsim.knots.topology.BEND_TABLE`, ``None`` when not there). Both
    ``None`` when the check fails. Informational: the outcome does not use this closure."""
    from knotsim.knots.topology import analyze_bend

    d = getattr(ctx, "data", {})
    if "held" not in d or getattr(ctx, "geometry", None) is None:
        return {}
    try:
        res = analyze_bend([np.asarray(x, float) for x in ctx.geometry.ropes],
                           ((d["held"].rope, d["held_end"]), (d["pulled"].rope, d["pulled_end"])))
    except Exception:  # recorded as missing, never raised: a naming aid only
        return {"bend_closure": None, "bend_name": None}
    return {"bend_closure": res.knot_type, "bend_name": res.bend}


def pre_tighten_time(params) -> float:
    """Duration (s) of the cinching stage, ``pre_tighten / pre_tighten_speed`` (0 when off; see
    :func:`~knotsim.protocols.base.stage_duration` for the errors)."""
    return stage_duration(params["pre_tighten"], params["pre_tighten_speed"], "pre_tighten", "pre_tighten_speed")


class TwoRopeBend(LoadingProtocol):
    name = "two-rope-bend"
    event_time_keys = ("F_norm_peak_time",)
    description = "Hold one end of rope A, pull the far end of rope B, tails free (Patil et al. 2020)"
    kinds: tuple[str, ...] = ("bend",)
    default_knot = "reef_bend"
    defaults = {
        "mu": 0.3,
        "dt": 2e-3,  # s; no published value
        "mode": "displacement",
        "held_end": "",        # "ROPE:NODE" of the held end ("": the knot's hint)
        "pulled_end": "",      # "ROPE:NODE" of the pulled end ("": the knot's hint)
        "pull_speed": 0.01,    # m/s (displacement mode)
        "pull_length": 0.4,    # m pulled in displacement mode when no duration is given
        "pre_tighten": 0.0,    # m each of the four ends moves outwards first (0: no cinching stage)
        "pre_tighten_speed": 0.01,  # m/s per end during the cinching stage
        "force_rate": 0.05,    # N/s (force mode)
        "runaway_speed": 0.05,  # m/s, force mode: pulled end faster than this = slipping
        "transient": 2.0,          # s, start-up transient left out of the holding force and slip detection
        "slip_draw_in_rate": 0.25,  # tails drawn in faster than this x pull_speed = slipping
        "slip_hold": 2.0,          # s, the fast draw-in must last this long
        "output_interval": 0.1,
    }
    quick = {"n_nodes": 101, "dt": 5e-3, "duration": 1.5, "output_interval": 0.5, "transient": 0.3}

    def setup(self, ctx: RunContext) -> None:
        geo = ctx.geometry
        if len(geo.ropes) != 2:
            raise ConfigError("knot", f"two-rope-bend needs a knot of two ropes, {geo.name!r} has {len(geo.ropes)}")
        hint_held, hint_pulled = default_ends(geo)
        he, pe = ctx.params["held_end"], ctx.params["pulled_end"]
        # a text default (""), not None: a None default is resolved as a number (base.build_protocol_run)
        held_list = (parse_end(he, geo, "held_end"),) if he else hint_held
        pulled_list = (parse_end(pe, geo, "pulled_end"),) if pe else hint_pulled
        if not held_list or not pulled_list:
            raise ConfigError("knot", f"knot {geo.name!r} has no [loading] held/pulled hints; give held_end and "
                                      "pulled_end (ROPE:NODE)")
        mode = ctx.params["mode"]
        if mode not in ("displacement", "force"):
            raise ConfigError("mode", f"must be 'displacement' or 'force', got {mode!r}")
        held, pulled = held_list[0], pulled_list[0]
        if held.rope == pulled.rope:
            raise ConfigError("knot", "the held and pulled ends must be on different ropes")
        xa = geo.ropes[held.rope][held.node]
        xb = geo.ropes[pulled.rope][pulled.node]
        axis = unit(xb - xa)
        ctx.data.update(axis=axis, held=held, pulled=pulled,
                        held_end=0 if held.node == 0 else 1, pulled_end=0 if pulled.node == 0 else 1)
        # each group sized by its own rope's node count (the ropes may differ in length and resolution)
        pull_nodes = end_group_nodes(pulled.node, len(geo.ropes[pulled.rope]))
        held_nodes = end_group_nodes(held.node, len(geo.ropes[held.rope]))
        t_pre = pre_tighten_time(ctx.params)
        ctx.data["t_pre"] = t_pre
        if t_pre > 0:
            # cinch first: all four ends move outwards along their own end tangents, then the tails
            # are released, the held end stays where it got to and the pulled end goes on
            v_pre = float(ctx.params["pre_tighten_speed"])

            def outward(rope: int, node: int):
                x = geo.ropes[rope]
                inner = min(5, len(x) - 1)
                return unit(x[node] - x[inner if node == 0 else len(x) - 1 - inner])

            def pre(d, then=None):
                """Waypoints: out along ``d`` at v_pre for t_pre, then at ``then`` (m/s) or still."""
                w = {"times": [0.0, t_pre], "points": [[0.0, 0.0, 0.0], list(v_pre * t_pre * d)]}
                if then is not None:
                    w["then_velocity"] = list(then)
                return w

            d_held = outward(held.rope, held.node)
            d_pull = outward(pulled.rope, pulled.node)
            ctx.add_bc("move", "held", rod=held.rope, nodes=held_nodes, waypoints=pre(d_held))
            for name, (rope, end) in zip(("tail_a", "tail_b"), free_tail_ends(held, pulled), strict=True):
                n = len(geo.ropes[rope])
                node = 0 if end == 0 else n - 1
                ctx.add_bc("move", f"pre_{name}", rod=rope, nodes=end_group_nodes(node, n),
                           waypoints=pre(outward(rope, node)), stop=t_pre)
        else:
            ctx.add_bc("clamp", "held", rod=held.rope, nodes=held_nodes)
            d_pull = axis
        if mode == "displacement":
            v = float(ctx.params["pull_speed"])
            if t_pre > 0:
                ctx.add_bc("move", "pull", rod=pulled.rope, nodes=pull_nodes, waypoints=pre(d_pull, v * axis))
            else:
                ctx.add_bc("move", "pull", rod=pulled.rope, nodes=pull_nodes, velocity=list(v * axis),
                           ramp_time=float(ctx.params["ramp_time"]) or None)
        else:
            rate = float(ctx.params["force_rate"])
            if t_pre > 0:
                ctx.add_bc("move", "pre_pull", rod=pulled.rope, nodes=pull_nodes, waypoints=pre(d_pull), stop=t_pre)
            ctx.add_bc("force", "pull", rod=pulled.rope, nodes=pull_nodes, start=t_pre,
                       ramp={"from": [0.0, 0.0, 0.0], "rate": list(rate * axis)})
        ctx.data["pull_local"] = (pulled.rope, pull_nodes)
        ctx.data["x_pull0"] = np.mean([geo.ropes[pulled.rope][i] for i in pull_nodes], axis=0)
        ctx.data["free_ends"] = free_tail_ends(held, pulled)
        ctx.data["ends_interleaved"] = ends_interleaved(geo.ropes, [(held.rope, held.node), (pulled.rope, pulled.node)])

    def prepare(self, ctx: RunContext) -> None:
        rope, nodes = ctx.data["pull_local"]
        ctx.data["pull_nodes"] = ctx.model.global_nodes(rope, nodes)

    def duration(self, ctx: RunContext) -> float:
        """Default run length (s): ``pull_length / pull_speed`` in displacement control (400 mm of
        pull: the loose library bends are flattened and the reef and granny slip after about
        300 mm, see ``validation/reports/knots_bends.md``), 40 s in force control."""
        t_pre = ctx.data.get("t_pre", 0.0)
        if ctx.params["mode"] == "displacement":
            ramp = 0.5 * float(ctx.params["ramp_time"]) if t_pre == 0 else 0.0  # a ramp over T loses T/2 at full speed
            return t_pre + float(ctx.params["pull_length"]) / float(ctx.params["pull_speed"]) + ramp
        return t_pre + 40.0

    def closure(self, ctx: RunContext, curves):
        """The two ropes, each closed on itself (:func:`~knotsim.knots.topology.close_curves`,
        radial): a two-component link whose invariants (each rope's knot type, the linking number,
        the Jones polynomial) change only when rope passes through rope. (The bend closure of
        :func:`~knotsim.knots.topology.close_bend`, which joins the standing ends together and the tails together, names the
        bend but depends on where the loose tails lie: it flagged hunter's, Ashley's and the double
        fisherman's bends as changed and the alpine butterfly as untied after 0.3 s of pull.)"""
        return [np.asarray(c, float) for c in curves], None, None

    def record(self, ctx: RunContext, q, t, reactions) -> dict:
        m = ctx.model
        axis = ctx.data["axis"]
        x = m.node_positions(q)
        u = float(np.dot(x[ctx.data["pull_nodes"]].mean(axis=0) - ctx.data["x_pull0"], axis))
        if ctx.params["mode"] == "displacement":
            f = float(np.dot(reactions["pull"][:3], axis))
        else:
            f = float(ctx.params["force_rate"]) * max(float(t) - pull_start(ctx), 0.0)  # the applied ramp
        f_held = -float(np.dot(reactions["held"][:3], axis))
        ropes = [x[m.rod_node_start[r]:m.rod_node_start[r + 1]] for r in range(m.n_rods)]
        delta = float(ctx.params.contact.get("delta", 5e-4))
        ta, tb = tail_lengths(ropes, ctx.data["free_ends"], ctx.radius, delta)
        return {"F": f, "F_norm": f * ctx.radius**2 / ctx.EI, "F_held": f_held, "u_pull": u,
                "tail_a": ta, "tail_b": tb, "rope_gap": rope_gap(ropes)}

    def metrics(self, ctx: RunContext, log) -> dict:
        t_pre = float(getattr(ctx, "data", {}).get("t_pre", 0.0))
        if pull_start(ctx) > 0:  # metrics on the pull after settling and cinching, time from its start
            log = measured_log(ctx, log)
            if len(log) < 2:
                return {"mode": ctx.params["mode"], "pre_tighten_time": t_pre}
        t = np.asarray(log["time"], float)
        t_skip = float(ctx.params["transient"])
        if not t_skip >= 0:
            raise ConfigError("transient", f"must be a duration >= 0 in s, got {t_skip!r}")
        peak, t_peak = window_peak_at(log, "F_norm", t_skip) if t[-1] > t_skip else (None, None)
        out = {
            "mode": ctx.params["mode"],
            "pre_tighten_time": t_pre,
            "F_norm_mean": window_mean(log, "F_norm"),
            "F_norm_peak": peak,  # after the start-up transient, as F_norm_hold
            "F_norm_peak_time": t_peak,
            "F_norm_final": window_mean(log, "F_norm", float(log["time"].iloc[-1]) - 0.25),  # last 0.25 s
            "tail_a_draw_in": tail_draw_in(log, "tail_a"),
            "tail_b_draw_in": tail_draw_in(log, "tail_b"),
            "pull_draw_in": tail_draw_in(log, "u_pull", kind="increase"),
        }
        out.update(bend_names(ctx))
        if "rope_gap" in log.columns:
            gap = float(log["rope_gap"].iloc[-1])
            out["rope_gap_final"] = gap
            out["ropes_apart"] = bool(gap > APART_RADII * ctx.radius)
        p = ctx.params
        after = t >= t_skip
        need = float(p["slip_hold"]) + 2.0 if p["mode"] == "displacement" else 0.5
        out["decidable"] = bool(t[-1] - t_skip >= need)
        f_avg = moving_average(log, "F_norm", 0.5)
        if p["mode"] == "displacement":
            fmax = float(np.max(f_avg[after])) if after.any() else 0.0
            out["F_norm_hold"] = fmax if after.any() else None
            out["force_drop_onset"] = slip_onset(log, "F_norm", mode="drop", drop_fraction=0.3,
                                                 min_force=0.5 * max(fmax, 1e-12), smooth=0.5, t0=t_skip)
            rate = float(p["slip_draw_in_rate"]) * float(p["pull_speed"])
            out["slip_onset"] = draw_in_onset(log, ["tail_a", "tail_b"], rate, smooth=2.0,
                                              hold=float(p["slip_hold"]), t0=t_skip)
        else:
            u = moving_average(log, "u_pull", 0.5)
            speed = np.gradient(u, t) if len(t) > 2 else np.zeros_like(u)
            k = sustained_onset(t, after & (speed > float(p["runaway_speed"])), 0.5)
            f = np.asarray(log["F_norm"], float)
            out["slip_onset"] = (None if k is None else
                                 {"time": float(t[k]), "force": float(f[k]), "detected_at": float(t[k]),
                                  "criterion": "runaway"})
            out["F_norm_hold"] = float(f[k] if k is not None else f[-1])
        return out

    def topology_key(self, ctx: RunContext, topo: dict) -> str | None:
        """What must stay equal for the bend to count as unchanged: :func:`link_key` of the two
        ropes each closed on itself (``"unlink"`` once they have come apart: the outcome is then
        ``untied``). A one-component record (a bend closure, as written by earlier versions) keeps
        the old rule: its knot type, without handedness when the standing ends and tails alternate
        around the knot (thief, grief), whose closure must cross one join over the other."""
        if topo.get("n_components") == 2 and topo.get("component_types") is not None:
            return link_key(topo)
        key = topo.get("signature")
        if key is None or not ctx.data.get("ends_interleaved") or topo.get("knot_type") in ("unknot", "unlink"):
            return key
        return topo.get("rolfsen") or key

    def slipped(self, ctx: RunContext, metrics: dict) -> bool:
        return metrics.get("slip_onset") is not None

    def verdict(self, ctx: RunContext, metrics: dict) -> str | None:
        """``untied`` when the two ropes are apart at the end (no nodes within ``4h``,
        :data:`APART_RADII`) and their link is split (:func:`link_key`; the reef and thief bends'
        ropes are an unlink from the start, so only the geometry shows them coming apart), else
        ``slipped``, else ``undecided`` when the pull after the transient is shorter than the
        evidence the slip rule needs (``slip_hold`` plus its 2 s smoothing in displacement control,
        0.5 s in force control), else held."""
        end = getattr(ctx, "data", {}).get("topology_end") or {}
        if (metrics.get("ropes_apart") and end.get("n_components") == 2 and end.get("component_types") is not None
                and link_key(end) == "unlink"):
            return "untied"
        return self.slip_verdict(ctx, metrics)

