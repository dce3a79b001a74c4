"""Where a failed Newton solve went wrong, in words for the error message."""

from __future__ import annotations

import numpy as np


def largest_residual_at(model, interactions, system, q: np.ndarray) -> str:
    """Where the residual of a failed solve at ``q`` ``(n_dofs,)`` is largest:
    ``"; largest residual ... at rod R node K"`` (or edge K's twist), and the nearest contact pair
    with the angle between its edges (from each interaction's ``describe_near``), so that a stall
    can be traced. One extra residual evaluation of ``system``, only on failure; ``""`` when the
    residual cannot be evaluated or is not finite (the diagnosis must not hide the failure)."""
    m = model
    try:
        r = system.residual(q, False)
    except Exception:  # the diagnosis must not hide the failure
        return ""
    if not np.all(np.isfinite(r)) or not r.size:
        return ""
    k = int(np.argmax(np.abs(r)))
    if m.theta_mask[k]:
        e = int(np.flatnonzero(m.edge_theta_dof == k)[0])
        rod = int(m.edge_rod[e])
        where = f"edge {int(m.edge_local[e])} (twist)"
        unit = "N m"
        node = None
    else:
        node = int(np.searchsorted(m.node_dof, k, side="right") - 1)
        rod = int(np.searchsorted(m.rod_node_start, node, side="right") - 1)
        where = f"node {node - int(m.rod_node_start[rod])}"
        unit = "N"
    out = f"; largest residual {abs(r[k]):.3g} {unit} at rod {m.rod_names[rod]!r} {where}"
    for inter in interactions:
        if node is not None:
            text = inter.describe_near(q, node)
            if text:
                out += f", {text}"
    return out
