"""Derived per-frame output of a run (``trajectory.h5`` datasets of :data:`~knotsim.io.trajectory.FRAME_FIELDS`).

- ``edge_strain`` ``(n_edges,)``, dimensionless: axial strain ``|e| / l0 - 1`` of each edge (``l0``
  its rest length), the strain of the stretching energy ``E = 1/2 EA strain^2 l0``;
- ``edge_tension`` ``(n_edges,)``, N: the axial force ``EA * strain`` of each edge;
- ``contact_force``, ``friction_force`` ``(n_nodes,)``, N: magnitudes of the net contact and
  friction force on each node at the last accepted step, from every interaction that reports them
  (:meth:`knotsim.contact.model.Contact.node_forces`); only written when the run has contact.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["edge_strain", "frame_field_names", "frame_fields"]


def edge_strain(model, q: np.ndarray) -> np.ndarray:
    """``(n_edges,)`` axial strain (dimensionless) of every edge of ``model`` at unknowns ``q``."""
    x = model.node_positions(q)
    e = x[model.edge_nodes[:, 1]] - x[model.edge_nodes[:, 0]]
    return np.linalg.norm(e, axis=1) / model.rest_length - 1.0


def _force_sources(interactions: Sequence) -> list:
    return [inter for inter in interactions if callable(getattr(inter, "node_forces", None))]


def frame_field_names(interactions: Sequence) -> list[str]:
    """The derived datasets a run with these interactions writes."""
    names = ["edge_strain", "edge_tension"]
    if _force_sources(interactions):
        names += ["contact_force", "friction_force"]
    return names


def frame_fields(model, q: np.ndarray, interactions: Sequence) -> dict[str, np.ndarray]:
    """Values of :func:`frame_field_names` at the current frame (shapes and units in the module docstring)."""
    strain = edge_strain(model, q)
    out = {"edge_strain": strain, "edge_tension": model.edge_EA * strain}
    sources = _force_sources(interactions)
    if sources:
        # vector sums over several contact models are not kept; their magnitudes add (one model in practice)
        pairs = [inter.node_forces() for inter in sources]
        out["contact_force"] = np.sum([c for c, _ in pairs], axis=0)
        out["friction_force"] = np.sum([f for _, f in pairs], axis=0)
    return out
