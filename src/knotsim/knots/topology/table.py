"""The knot table (:data:`KNOT_TABLE`) and identification from the Alexander and Jones polynomials."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from knotsim.knots.topology.polynomials import _alex_mul, _jones_key, _mirror, _pmul_jones

# Prime knots up to 7 crossings: (name, alias, Alexander, Jones of one mirror image as
# {exponent: coefficient}).  The Jones polynomials were computed with this module from the PD codes of
# the Rolfsen table (as shipped with spherogram); the Alexander polynomials computed the same way match
# the Rolfsen table.
_PRIME = [
    ("3_1", "trefoil", [1, -1, 1], {1: 1, 3: 1, 4: -1}),
    ("4_1", "figure_eight", [-1, 3, -1], {-2: 1, -1: -1, 0: 1, 1: -1, 2: 1}),
    ("5_1", None, [1, -1, 1, -1, 1], {2: 1, 4: 1, 5: -1, 6: 1, 7: -1}),
    ("5_2", None, [2, -3, 2], {1: 1, 2: -1, 3: 2, 4: -1, 5: 1, 6: -1}),
    ("6_1", None, [-2, 5, -2], {-4: 1, -3: -1, -2: 1, -1: -2, 0: 2, 1: -1, 2: 1}),
    ("6_2", None, [-1, 3, -3, 3, -1], {-1: 1, 0: -1, 1: 2, 2: -2, 3: 2, 4: -2, 5: 1}),
    ("6_3", None, [1, -3, 5, -3, 1], {-3: -1, -2: 2, -1: -2, 0: 3, 1: -2, 2: 2, 3: -1}),
    ("7_1", None, [1, -1, 1, -1, 1, -1, 1], {3: 1, 5: 1, 6: -1, 7: 1, 8: -1, 9: 1, 10: -1}),
    ("7_2", None, [3, -5, 3], {1: 1, 2: -1, 3: 2, 4: -2, 5: 2, 6: -1, 7: 1, 8: -1}),
    ("7_3", None, [2, -3, 3, -3, 2], {2: 1, 3: -1, 4: 2, 5: -2, 6: 3, 7: -2, 8: 1, 9: -1}),
    ("7_4", None, [4, -7, 4], {1: 1, 2: -2, 3: 3, 4: -2, 5: 3, 6: -2, 7: 1, 8: -1}),
    ("7_5", None, [2, -4, 5, -4, 2], {2: 1, 3: -1, 4: 3, 5: -3, 6: 3, 7: -3, 8: 2, 9: -1}),
    ("7_6", None, [-1, 5, -7, 5, -1], {-6: -1, -5: 2, -4: -3, -3: 4, -2: -3, -1: 3, 0: -2, 1: 1}),
    ("7_7", None, [1, -5, 9, -5, 1], {-4: 1, -3: -2, -2: 3, -1: -4, 0: 4, 1: -3, 2: 3, 3: -1}),
]


def _torus_2q(q: int) -> tuple[list[int], dict[int, int]]:
    """Alexander coefficients and Jones polynomial of the torus knot ``T(2, q)`` (``q`` odd >= 3).

    Closed forms: ``Delta(t) = (t^q + 1)/(t + 1)`` (alternating ones) and Jones' formula
    ``V(t) = t^((q-1)/2) (1 - t^3 - t^(q+1) + t^(q+2)) / (1 - t^2)`` for the positive knot. They
    reproduce the table's 3_1, 5_1 and 7_1 (tested) and supply 9_1 (the open overhand with n = 4).
    """
    num = {0: 1, 3: -1, q + 1: -1, q + 2: 1}
    quotient = {}
    rem = dict(num)
    # divide by (1 - t^2) from the lowest power up: c_k = r_k + c_{k-2}
    for k in range(q + 1):
        c = rem.get(k, 0) + quotient.get(k - 2, 0)
        if c:
            quotient[k] = c
    shift = (q - 1) // 2
    jones = {k + shift: c for k, c in quotient.items()}
    alexander = [(-1) ** i for i in range(q)]
    return alexander, jones


@dataclass(frozen=True)
class KnotEntry:
    """One entry of :data:`KNOT_TABLE`."""

    knot_type: str  # e.g. "trefoil_right", "figure_eight", "reef", "5_2_left"
    rolfsen: str  # e.g. "3_1", "3_1#3_1", "3_1#3_1*"
    chirality: str  # "right", "left" or "achiral"
    alexander: tuple[int, ...]
    jones: tuple  # ((exponent, coefficient), ...)


def _chirality(v: dict) -> str:
    """Chirality label: achiral when ``V(t) = V(1/t)``, else right when the exponents centre above 0."""
    if _jones_key(v) == _jones_key(_mirror(v)):
        return "achiral"
    for key in (min(v) + max(v), sum(e * c for e, c in v.items()), sum(e * c * c for e, c in v.items())):
        if key != 0:
            return "right" if key > 0 else "left"
    return "right"  # pragma: no cover - no such knot in the table


def _build_table() -> list[KnotEntry]:
    entries = [KnotEntry("unknot", "0_1", "achiral", (1,), ((0, 1),))]

    def add(rolf: str, alias: str | None, alex: list[int], v: dict, mirror_rolf: str | None = None):
        base = alias or rolf
        ch = _chirality(v)
        if ch == "achiral":
            entries.append(KnotEntry(base, rolf, "achiral", tuple(alex), _jones_key(v)))
            return
        for vv in (v, _mirror(v)):
            c = _chirality(vv)
            entries.append(KnotEntry(f"{base}_{c}", rolf, c, tuple(alex), _jones_key(vv)))

    prime = {}
    for rolf, alias, alex, v in _PRIME:
        add(rolf, alias, alex, v)
        prime[rolf] = (alex, v)
    a9, v9 = _torus_2q(9)
    add("9_1", None, a9, v9)
    a3, v3 = prime["3_1"]
    a4, v4 = prime["4_1"]
    add("3_1#3_1", "granny", _alex_mul(a3, a3), _pmul_jones(v3, v3))
    add("3_1#3_1*", "reef", _alex_mul(a3, a3), _pmul_jones(v3, _mirror(v3)))
    add("3_1#4_1", None, _alex_mul(a3, a4), _pmul_jones(v3, v4))
    return entries


KNOT_TABLE: list[KnotEntry] = _build_table()
"""Knots recognised by :func:`identify_knot` (prime knots up to 7 crossings, 9_1, granny, reef, 3_1#4_1)."""
_BY_JONES = {e.jones: e for e in KNOT_TABLE}


def identify_knot(alexander: Sequence[int] | None, jones: dict | None) -> KnotEntry | None:
    """Look a knot up in :data:`KNOT_TABLE` from its Alexander coefficient list and Jones polynomial.

    Both invariants must match when both are given; with ``jones=None`` only knots whose Alexander
    polynomial is unique in the table (and amphichiral, so no chirality is claimed) are returned.
    Returns ``None`` when nothing matches.
    """
    if jones is not None:
        e = _BY_JONES.get(_jones_key(jones))
        if e is None:
            return None
        if alexander is not None and tuple(alexander) != e.alexander:
            return None
        return e
    if alexander is None:
        return None
    cands = [x for x in KNOT_TABLE if x.alexander == tuple(alexander)]
    return cands[0] if len(cands) == 1 else None


#: Bends named from two invariants: the Rolfsen name of the knot made by joining the two standing
#: (loaded) ends far away and the two tails far away (:func:`knotsim.knots.topology.close_bend`,
#: handedness ignored: for bends whose standing ends and tails alternate around the knot, thief and
#: grief, it is a convention of the closure), and the absolute linking number of the two ropes each
#: closed on itself. Reef and thief (granny and grief) are one drawing loaded at different ends.
#: Hunter's and the alpine butterfly bend as drawn and loaded in the library (Patil's hunter13 and
#: alpine13 loadings); the zeppelin, Ashley's, carrick, double sheet and double fisherman's closures are
#: not in :data:`KNOT_TABLE`, so those bends are not named.
BEND_TABLE: dict[tuple[str, int], str] = {
    ("3_1#3_1*", 0): "reef bend",
    ("3_1#3_1", 3): "granny bend",
    ("6_1", 0): "thief bend",
    ("3_1", 3): "grief bend",
    ("6_2", 1): "sheet bend",
    ("6_1", 3): "hunter's bend",
    ("0_1", 1): "alpine butterfly bend",
}


def identify_bend(rolfsen: str | None, linking: int) -> str | None:
    """Name of a bend in :data:`BEND_TABLE` from its closure's Rolfsen name and the linking number of
    its two ropes each closed on itself (sign ignored); ``None`` when nothing matches."""
    if rolfsen is None:
        return None
    return BEND_TABLE.get((rolfsen, abs(int(linking))))
