"""Optional certified identification with spherogram (imported only when called)."""

from __future__ import annotations

from knotsim.knots.topology.analyze import TopologyResult
from knotsim.knots.topology.curves import TopologyError


def spherogram_link(pd):
    """Build a ``spherogram.Link`` from a PD code (needs the optional ``spherogram`` package).

    spherogram uses the same PD convention as this module (checked: same crossing signs).
    Crossing-free components cannot be given in a PD code; a diagram without crossings raises
    :class:`TopologyError`.  Raises :class:`ImportError` with an install hint when spherogram is missing.
    """
    try:
        import spherogram
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("spherogram is not installed: pip install 'knotsim[topology]'") from exc
    if len(pd) == 0:
        raise TopologyError(
            "spherogram_link: the diagram has no crossing (unknot or unlink), nothing to build"
        )
    return spherogram.Link([[int(v) for v in x] for x in pd])


def identify_with_spherogram(result_or_pd) -> dict:
    """Independent identification with spherogram (optional dependency, imported only here).

    Parameters
    ----------
    result_or_pd:
        A :class:`TopologyResult` or a PD code (list of 4-tuples).

    Returns
    -------
    dict with

    * ``"crossings"``: crossings left after spherogram's global simplification;
    * ``"knot_floer_homology"``: the dict of ``Link.knot_floer_homology()`` for a knot
      (``seifert_genus``, ``fibered``, ``tau``, ...; ``tau > 0`` for right-handed = positive knots
      such as the right trefoil), ``None`` for links or when ``knot_floer_homology`` is missing;
    * ``"identify"``: names from ``Link.exterior().identify()`` (e.g. ``["K3a1"]``) when SnapPy is
      installed and the complement is recognised, else ``None``.

    A diagram without crossings gives ``{"crossings": 0, "knot_floer_homology": None, "identify": ["unknot"]}``
    (or ``"unlink"``).
    """
    if isinstance(result_or_pd, TopologyResult):
        pd, free = result_or_pd.pd_code, result_or_pd.free_loops
    else:
        pd, free = list(result_or_pd), 0
    if len(pd) == 0:
        return {
            "crossings": 0,
            "knot_floer_homology": None,
            "identify": ["unknot" if free <= 1 else "unlink"],
        }
    L = spherogram_link(pd)
    L.simplify("global")
    out: dict = {"crossings": len(L.crossings), "knot_floer_homology": None, "identify": None}
    if len(L.link_components) == 1 and free == 0:
        try:
            out["knot_floer_homology"] = dict(L.knot_floer_homology())
        except ImportError:  # pragma: no cover - depends on the environment
            pass
    try:
        out["identify"] = [str(m) for m in L.exterior().identify()]
    except (ImportError, RuntimeError):
        pass
    return out
