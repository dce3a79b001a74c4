"""What the protocols that load a bend (two ropes) share beyond the rope measures
(:mod:`knotsim.protocols.rope_measures`): which ends are held, pulled and free (:class:`BendEnds`,
from the knot's hints or the ``held_end`` / ``pulled_end`` parameters), the bend's topology key
(:func:`link_key`, :func:`bend_topology_key`), when it has come untied (:func:`untied`) and its name
from the whole-bend closure (:func:`bend_names`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from knotsim.errors import ConfigError
from knotsim.protocols.geometry import default_ends, parse_end
from knotsim.protocols.rope_measures import ends_interleaved, free_tail_ends

__all__ = ["BendEnds", "bend_ends", "bend_names", "bend_topology_key", "link_key", "split_jones", "untied"]


@dataclass(frozen=True)
class BendEnds:
    """The ends of a bend: ``held`` and ``pulled`` (``End``: ``rope``, ``node``), ``held_end`` and
    ``pulled_end`` (0: the rope's first node, 1: its last), the two free tails (``free_ends``:
    ``(rope, end)``) and whether the standing ends and the tails alternate round the knot
    (``interleaved``: thief and grief)."""

    held: Any
    pulled: Any
    held_end: int
    pulled_end: int
    free_ends: list[tuple[int, int]]
    interleaved: bool


def bend_ends(geo, params) -> BendEnds:
    """The :class:`BendEnds` of the bend ``geo`` (two ropes): the ``held_end`` / ``pulled_end``
    parameters (``"ROPE:NODE"``) or else the knot's ``[loading]`` hints; :class:`ConfigError` when
    neither names them or both are on one rope."""
    hint_held, hint_pulled = default_ends(geo)
    he, pe = params["held_end"], params["pulled_end"]
    # a text default (""), not None: a None default is resolved as a number (pipeline.build_protocol_run)
    held_list = (parse_end(he, geo, "held_end"),) if he else hint_held
    pulled_list = (parse_end(pe, geo, "pulled_end"),) if pe else hint_pulled
    if not held_list or not pulled_list:
        raise ConfigError("knot", f"knot {geo.name!r} has no [loading] held/pulled hints; give held_end and "
                                  "pulled_end (ROPE:NODE)")
    held, pulled = held_list[0], pulled_list[0]
    if held.rope == pulled.rope:
        raise ConfigError("knot", "the held and pulled ends must be on different ropes")
    return BendEnds(held, pulled, 0 if held.node == 0 else 1, 0 if pulled.node == 0 else 1,
                    free_tail_ends(held, pulled),
                    ends_interleaved(geo.ropes, [(held.rope, held.node), (pulled.rope, pulled.node)]))


def bend_topology_key(topo: dict, interleaved: bool) -> str | None:
    """What must stay equal for a bend to count as unchanged: :func:`link_key` of the two ropes each
    closed on itself (``"unlink"`` once they have come apart). A one-component record (a bend closure,
    as written by earlier versions) keeps the old rule: its knot type, without handedness when the
    standing ends and tails alternate round the knot (``interleaved``: thief, grief), whose closure
    must cross one join over the other."""
    if topo.get("n_components") == 2 and topo.get("component_types") is not None:
        return link_key(topo)
    key = topo.get("signature")
    if key is None or not interleaved or topo.get("knot_type") in ("unknot", "unlink"):
        return key
    return topo.get("rolfsen") or key


def untied(metrics: dict, topology_end: dict | None) -> bool:
    """A bend has come untied when its two ropes are apart at the end (metric ``ropes_apart``: no
    nodes within ``4h``) and their link is split (:func:`link_key`; the reef and thief bends' ropes
    are an unlink from the start, so only the geometry shows them coming apart)."""
    end = topology_end or {}
    return bool(metrics.get("ropes_apart") and end.get("n_components") == 2 and end.get("component_types") is not None
                and link_key(end) == "unlink")


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


def bend_names(geo, ends: BendEnds | None) -> dict:
    """The starting bend ``geo`` named by its whole-bend closure (:func:`knotsim.knots.topology.analyze_bend`:
    standing ends joined above, tails below): ``bend_closure`` (its knot type, e.g. ``"reef"``) and
    ``bend_name`` (from :data:`~knotsim.knots.topology.BEND_TABLE`, ``None`` when not there). Both
    ``None`` when the check fails; ``{}`` without a geometry or ends (not a bend). Informational: the
    outcome does not use this closure."""
    from knotsim.knots.topology import analyze_bend

    if ends is None or geo is None:
        return {}
    try:
        res = analyze_bend([np.asarray(x, float) for x in geo.ropes],
                           ((ends.held.rope, ends.held_end), (ends.pulled.rope, ends.pulled_end)))
    except Exception:  # recorded as missing, never raised: a naming aid only
        return {"bend_closure": None, "bend_name": None}
    return {"bend_closure": res.knot_type, "bend_name": res.bend}
