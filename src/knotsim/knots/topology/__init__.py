"""Topology of knotted rods: closure, knot diagrams, linking numbers and knot invariants.

Input everywhere is a list of rope centrelines, each an ``(N_k, 3)`` float array of node positions
in metres, plus a flag per rope saying whether it is closed (a ring: the last node connects back to
the first) or open.  The pipeline is

1. **Closure** (:func:`close_curves`): knot theory only speaks about closed curves, so each open
   rope is closed far away from the tangle.  Every free end ``p`` is joined by a straight segment to
   a point on a large sphere around the tangle (radially from the centroid ``c`` of all nodes,
   ``method="radial"``, or along the end tangent, ``method="tangent"``), and the two far points of a
   pair of ends are joined by a great-circle arc sampled on that sphere.  The sphere radius is
   ``radius_factor`` times the radius of the tangle (default 20), and every closure arc gets its own
   sphere radius, so arcs never meet each other.  Seen along almost every direction the far arcs
   project outside the tangle and add no crossing with it.  Which ends are joined is given by
   ``pairing`` (default: the two ends of each open rope together).  For a *bend* (two ropes tied
   together) knot theory closes the two standing (pulled) ends together and the two tails together,
   which makes one closed curve: see :func:`bend_pairing`.  The closure of an open rope is a choice,
   not a fact: when an end finishes deep inside the tangle, different reasonable closures can give
   different knots.  Rods in knotsim normally have long tails that leave the knot, and then the
   closure is unambiguous.

2. **Projection** (:func:`project`): the closed polygons are projected along a direction ``d``
   (random but seeded; several are tried, degenerate ones are rejected and the one with the fewest
   crossings is kept).  The viewer sits at ``+infinity * d`` and looks along ``-d``; a strand is *over*
   when its height ``x . d`` is larger.  Crossings are found with a numba sweep over the projected
   segments (a few milliseconds for 3000 segments).

3. **Invariants**: writhe, linking numbers, the Alexander polynomial and knot determinant (Fox
   calculus on the Wirtinger presentation), and the Jones polynomial from the Kauffman bracket,
   evaluated on the diagram after Reidemeister I and II simplifications with a planar contraction
   algorithm (crossing after crossing, keeping one Laurent polynomial per planar matching of the
   open ends), which handles tens of crossings.

Conventions (chirality)
-----------------------
* **Crossing sign** (right-hand rule): with ``o`` and ``u`` the projected directions of the over and
  the under strand, the sign is ``sign((o x u) . d)``, ``d`` pointing at the viewer.  Equivalently:
  both strands pointing up the page, the crossing is positive when the over strand goes from lower
  left to upper right.  With this sign, ``writhe`` is the sum of the signs and the linking number is
  half the sum over crossings between two components; it agrees with the Gauss linking integral
  (:func:`gauss_linking_number`) and with the algebraic intersection of one component with a
  Seifert surface of the other (right-hand-rule normal).
* **Right-handed trefoil** = the trefoil whose minimal diagrams have three positive crossings
  (writhe +3).  Its Jones polynomial is ``V(t) = t + t^3 - t^4`` (the left-handed one has
  ``t -> 1/t``).  The Jones polynomial is ``V(t) = (-A^3)^(-w) <D>`` at ``A = t^(-1/4)``, with the
  Kauffman bracket ``<X> = A <A-smoothing> + A^-1 <B-smoothing>``, ``<O> = 1``.  The positive Hopf
  link (linking number +1) has ``V = -t^(1/2) - t^(5/2)``.
* For other chiral knots of the table, ``"_right"`` names the mirror image whose Jones polynomial
  has its exponents centred on a positive value (for 5_1, 5_2, 7_x these are the positive knots,
  all crossings positive in a minimal diagram), ``"_left"`` the other one.
* **Alexander polynomial** is returned symmetric and normalised (``Delta(t) = Delta(1/t)``,
  ``Delta(1) = 1``) as the coefficient list of ``t^-m, ..., t^m``: trefoil ``[1, -1, 1]``,
  figure-eight ``[-1, 3, -1]``.
* **PD code** follows the KnotTheory / SnapPy convention: each crossing is ``(i, j, k, l)``, edges
  listed counterclockwise (seen by the viewer) starting with the incoming under edge ``i``; ``k`` is
  the outgoing under edge.  The crossing is positive when the over strand runs ``l -> j``.  Edge labels
  are 0-based and increase along each component in its direction.
* **Gauss code**: one list per component of ``+(c+1)`` (passes over crossing ``c``) or ``-(c+1)``
  (passes under), in the order met along the component; the signs are in ``Diagram.signs``.

The knot table (:data:`KNOT_TABLE`) holds the prime knots up to seven crossings (both mirror images),
the torus knot 9_1 (the closure of the open overhand knot with n = 4, from the closed forms of
:func:`_torus_2q`) and the composites granny (``3_1#3_1``, both chiralities), reef (the square knot ``3_1#3_1*``,
amphichiral) and ``3_1#4_1``.  A knot is named when both its Alexander and Jones
polynomials match an entry; the names are a guess from these two invariants (a few knots with more
crossings share both polynomials with a table entry), ``"unknown"`` otherwise.  For a certified
identification use :func:`identify_with_spherogram` (needs the optional ``spherogram`` package).

Modules
-------
:mod:`~knotsim.knots.topology.curves` (input checks, :class:`TopologyError`),
:mod:`~knotsim.knots.topology.closure` (closing open ropes),
:mod:`~knotsim.knots.topology.diagram` (projection, crossings, Gauss and PD codes),
:mod:`~knotsim.knots.topology.simplify` (Reidemeister I/II on PD codes),
:mod:`~knotsim.knots.topology.polynomials` (Laurent polynomials),
:mod:`~knotsim.knots.topology.jones` (Kauffman bracket, Jones polynomial),
:mod:`~knotsim.knots.topology.alexander` (Alexander polynomial, determinant),
:mod:`~knotsim.knots.topology.linking` (Gauss linking integral, 3D writhe),
:mod:`~knotsim.knots.topology.table` (knot table, identification),
:mod:`~knotsim.knots.topology.analyze` (:func:`analyze`, :class:`TopologyResult`),
:mod:`~knotsim.knots.topology.spherogram_bridge` (optional spherogram identification),
:mod:`~knotsim.knots.topology.counting` (Patil's counting rules N, τ, Γ of a loaded bend).
Everything public is re-exported here.
"""

from __future__ import annotations

from knotsim.knots.topology.alexander import _bareiss_det as _bareiss_det
from knotsim.knots.topology.alexander import _fox_matrices as _fox_matrices
from knotsim.knots.topology.alexander import _minor_poly as _minor_poly
from knotsim.knots.topology.alexander import _wirtinger as _wirtinger
from knotsim.knots.topology.alexander import alexander_polynomial, knot_determinant
from knotsim.knots.topology.analyze import TopologyResult, analyze, analyze_bend
from knotsim.knots.topology.closure import ClosureMethod, bend_pairing, close_bend, close_curves
from knotsim.knots.topology.counting import CountingRules, counting_rules, knot_counting_rules
from knotsim.knots.topology.curves import TopologyError
from knotsim.knots.topology.diagram import Diagram, project
from knotsim.knots.topology.jones import jones_polynomial, kauffman_bracket
from knotsim.knots.topology.linking import gauss_linking_number, writhe_3d
from knotsim.knots.topology.polynomials import _DELTA as _DELTA
from knotsim.knots.topology.polynomials import _mirror as _mirror
from knotsim.knots.topology.polynomials import _pmul_jones as _pmul_jones
from knotsim.knots.topology.polynomials import _ppow as _ppow
from knotsim.knots.topology.simplify import _faces as _faces
from knotsim.knots.topology.simplify import simplify_pd
from knotsim.knots.topology.spherogram_bridge import identify_with_spherogram, spherogram_link
from knotsim.knots.topology.table import _PRIME as _PRIME
from knotsim.knots.topology.table import BEND_TABLE, KNOT_TABLE, KnotEntry, identify_bend, identify_knot
from knotsim.knots.topology.table import _torus_2q as _torus_2q

__all__ = [
    "BEND_TABLE",
    "ClosureMethod",
    "KNOT_TABLE",
    "CountingRules",
    "Diagram",
    "KnotEntry",
    "TopologyError",
    "TopologyResult",
    "alexander_polynomial",
    "analyze",
    "analyze_bend",
    "bend_pairing",
    "close_bend",
    "close_curves",
    "counting_rules",
    "gauss_linking_number",
    "identify_bend",
    "identify_knot",
    "identify_with_spherogram",
    "jones_polynomial",
    "kauffman_bracket",
    "knot_determinant",
    "knot_counting_rules",
    "project",
    "simplify_pd",
    "spherogram_link",
    "writhe_3d",
]
