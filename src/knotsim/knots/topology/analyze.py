"""The one-call analysis :func:`analyze` and its result record :class:`TopologyResult`."""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from knotsim.knots.topology.alexander import alexander_polynomial, knot_determinant
from knotsim.knots.topology.closure import ClosureMethod, _close, close_bend
from knotsim.knots.topology.curves import TopologyError
from knotsim.knots.topology.diagram import Diagram, project
from knotsim.knots.topology.jones import _jones_from_bracket, kauffman_bracket
from knotsim.knots.topology.polynomials import _jones_key, _mirror, _pmul_jones
from knotsim.knots.topology.simplify import simplify_pd
from knotsim.knots.topology.table import identify_bend, identify_knot


@dataclass
class TopologyResult:
    """Topological description of a set of (closed) ropes.

    Attributes
    ----------
    n_components:
        Closed components after closure.
    component_ropes:
        Rope indices making up each component.
    n_crossings:
        Crossings of the chosen projection (before simplification).
    n_crossings_reduced:
        Crossings left after Reidemeister I/II simplification.
    writhe:
        Diagram writhe (sum of crossing signs of the projection, all components).
    writhe_reduced:
        Writhe of the simplified diagram.
    linking:
        ``(k, k)`` int array of pairwise linking numbers.
    alexander:
        Normalised Alexander coefficient list (``t^-m..t^m``) for a knot, ``None`` for a link.
    determinant:
        Knot/link determinant ``|Delta(-1)|``.
    jones:
        Jones polynomial ``{exponent: coefficient}`` (``None`` if skipped, see ``max_jones_crossings``).
    knot_type:
        Name from :data:`KNOT_TABLE` (``"unknot"``, ``"trefoil_right"``, ``"figure_eight"``,
        ``"granny_left"``, ``"reef"``, ``"5_2_right"``, ...), for links ``"unlink"``,
        ``"hopf_positive"``/``"hopf_negative"``, else ``"unknown"``.
    rolfsen, chirality:
        Rolfsen name (``"3_1"``, ``"3_1#3_1*"``) and ``"right"``/``"left"``/``"achiral"`` or ``None``.
    component_types:
        ``knot_type`` of each component taken alone.
    diagram:
        The projection (:class:`Diagram`).
    pd_code, signs, free_loops:
        Simplified PD code, its crossing signs and number of crossing-free circles.
    closed_curves:
        The closed polygons ``(M_k, 3)`` (m) that were analysed.
    bend:
        Set by :func:`analyze_bend` only: the bend's name from :data:`~knotsim.knots.topology.table.
        BEND_TABLE` (``"thief bend"``, ...), ``None`` when not in the table.
    """

    n_components: int
    component_ropes: list[list[int]]
    n_crossings: int
    n_crossings_reduced: int
    writhe: int
    writhe_reduced: int
    linking: np.ndarray
    alexander: list[int] | None
    determinant: int
    jones: dict | None
    knot_type: str
    rolfsen: str | None
    chirality: str | None
    component_types: list[str]
    diagram: Diagram
    pd_code: list[tuple[int, int, int, int]]
    signs: np.ndarray
    free_loops: int
    closed_curves: list[np.ndarray] = field(repr=False)
    bend: str | None = None

    @property
    def gauss_code(self) -> list[list[int]]:
        """Gauss code of the (unsimplified) projection, see :attr:`Diagram.gauss_code`."""
        return self.diagram.gauss_code


def _name_knot(pd, signs, free, compute_jones: bool, max_jones: int):
    alex = alexander_polynomial(pd, signs, free, simplify=False)
    jones = None
    if compute_jones and len(pd) <= max_jones:
        jones = _jones_from_bracket(kauffman_bracket(pd, free), int(np.sum(signs)))
    entry = identify_knot(alex, jones)
    return alex, jones, entry


def _name_link(k: int, jones: dict | None, linking: np.ndarray, det: int):
    if jones is None:
        return "unknown", None
    unlink = {0: 1}
    d = {Fraction(1, 2): -1, Fraction(-1, 2): -1}
    for _ in range(k - 1):
        unlink = _pmul_jones(unlink, d)
    if _jones_key(jones) == _jones_key(unlink) and not np.any(linking):
        return "unlink", "achiral"
    hopf = {Fraction(1, 2): -1, Fraction(5, 2): -1}
    if k == 2 and _jones_key(jones) == _jones_key(hopf):
        return "hopf_positive", "right"
    if k == 2 and _jones_key(jones) == _jones_key(_mirror(hopf)):
        return "hopf_negative", "left"
    return "unknown", None


def analyze(curves, closed=None, *, pairing=None, closure: ClosureMethod | str = "radial",
            radius_factor: float = 20.0, direction=None, seed: int = 0, n_directions: int = 6,
            compute_jones: bool = True, max_jones_crossings: int = 80) -> TopologyResult:
    """Close, project and identify knotted ropes.

    Parameters
    ----------
    curves:
        List of ``(N_k, 3)`` centrelines (m), or one ``(N, 3)`` array.
    closed:
        One bool per rope (``None``: all open).
    pairing, closure, radius_factor:
        Closure of open ropes (:func:`close_curves`; ``closure`` is its ``method``).
    direction, seed, n_directions:
        Projection (:func:`project`).
    compute_jones:
        Compute the Jones polynomial (needed to tell chirality and granny from reef).
    max_jones_crossings:
        Skip the Jones polynomial when more crossings than this survive simplification.

    Returns
    -------
    :class:`TopologyResult`
    """
    comps, comp_ropes = _close(curves, closed, pairing, closure, radius_factor)
    dia = project(comps, direction, seed=seed, n_directions=n_directions)
    pd0, s0, f0 = dia.pd_code()
    pd, signs, free = simplify_pd(pd0, s0, f0)
    linking = dia.linking_matrix()
    k = dia.n_components
    det = knot_determinant(pd, signs, free)
    if k == 1:
        alex, jones, entry = _name_knot(pd, signs, free, compute_jones, max_jones_crossings)
        knot_type = entry.knot_type if entry else "unknown"
        rolfsen = entry.rolfsen if entry else None
        chir = entry.chirality if entry else None
        comp_types = [knot_type]
    else:
        alex = None
        jones = None
        if compute_jones and len(pd) <= max_jones_crossings:
            jones = _jones_from_bracket(kauffman_bracket(pd, free), int(np.sum(signs)))
        knot_type, chir = _name_link(k, jones, linking, det)
        rolfsen = None
        comp_types = []
        for c in range(k):
            cpd, cs, cf = simplify_pd(*dia.pd_code([c]))
            _, _, e = _name_knot(cpd, cs, cf, compute_jones, max_jones_crossings)
            comp_types.append(e.knot_type if e else "unknown")
    return TopologyResult(
        n_components=k,
        component_ropes=comp_ropes,
        n_crossings=dia.n_crossings,
        n_crossings_reduced=len(pd),
        writhe=dia.writhe,
        writhe_reduced=int(np.sum(signs)),
        linking=linking,
        alexander=alex,
        determinant=det,
        jones=jones,
        knot_type=knot_type,
        rolfsen=rolfsen,
        chirality=chir,
        component_types=comp_types,
        diagram=dia,
        pd_code=pd,
        signs=signs,
        free_loops=free,
        closed_curves=comps,
    )


def analyze_bend(ropes, standing, **kwargs) -> TopologyResult:
    """Topology of a two-rope bend whose standing (loaded) ends are known, with the bend named.

    The two standing ends are joined far away and the two tails far away into one closed curve
    (:func:`~knotsim.knots.topology.close_bend`, standing join above the knot, tails join
    below it), which is analysed by :func:`analyze`; the two ropes, each closed on itself, give the
    linking number that, with the closure's Rolfsen name, names the bend (:func:`identify_bend`).

    Parameters
    ----------
    ropes:
        The two ropes' ``(N, 3)`` centrelines (m).
    standing:
        ``((rope, end), (rope, end))`` of the two standing ends, one per rope (end 0 = first node,
        1 = last node); the first is the held one: the closure axis runs from it to the second.
    kwargs:
        Passed to :func:`analyze` (projection and Jones options).
    """
    arrs = [np.asarray(r, dtype=float) for r in ropes]
    (ra, ea), (rb, eb) = ((int(r), int(e)) for r, e in standing)
    if len(arrs) != 2 or {ra, rb} != {0, 1} or ea not in (0, 1) or eb not in (0, 1):
        raise TopologyError(f"analyze_bend: need two ropes and one standing end (rope, 0|1) on each, got "
                            f"{len(arrs)} ropes and standing={standing!r}")
    pa, pb = arrs[ra][-ea], arrs[rb][-eb]
    axis = pb - pa
    if not np.linalg.norm(axis) > 0:
        raise TopologyError("analyze_bend: the two standing ends coincide, no pull axis")
    closed = close_bend(arrs, axis / np.linalg.norm(axis), (ra, ea), (rb, eb))
    res = analyze([closed], [True], **kwargs)
    link = analyze(arrs, compute_jones=False, **{k: v for k, v in kwargs.items() if k != "compute_jones"})
    res.bend = identify_bend(res.rolfsen, int(link.linking[0, 1]))
    return res
