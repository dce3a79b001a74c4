"""Derived per-frame output of a run (``trajectory.h5`` datasets of :data:`~knotsim.io.trajectory.FRAME_FIELDS`).

- ``edge_strain`` ``(n_edges,)``, dimensionless: axial strain ``|e| / l0 - 1`` of each edge (``l0``
  its rest length), the strain of the stretching energy ``E = 1/2 EA strain^2 l0``;
- ``edge_tension`` ``(n_edges,)``, N: the axial force ``EA * strain`` of each edge;
- ``contact_force``, ``friction_force`` ``(n_nodes,)``, N: magnitudes of the net contact and
  friction force on each node at the last accepted step, from every interaction that reports them
  (:meth:`knotsim.contact.model.Contact.node_forces`); only written when the run has contact;
- ``slip_speed``, ``rolling_speed`` ``(n_nodes,)``, m/s: at every node in contact, the slip speed
  of the surfaces and the part of their velocity difference that comes from the cross-sections'
  rotation (:meth:`knotsim.contact.model.Contact.node_slip`), NaN elsewhere; written when the run has
  rod-rod contact with surface friction. Where strands roll the slip is near zero and the rolling
  speed is not; where they slide it is the other way round.
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


#: the per-node datasets interactions may report (:attr:`Interaction.node_field_names
#: <knotsim.solver.stepper.Interaction.node_field_names>`), in the order written; the forces add
#: over the interactions that report them, the speeds come from the first
_NODE_FIELDS = ("contact_force", "friction_force", "slip_speed", "rolling_speed")
_ADDED = ("contact_force", "friction_force")


def frame_field_names(interactions: Sequence) -> list[str]:
    """The derived datasets a run with these interactions writes."""
    reported = {n for inter in interactions for n in inter.node_field_names}
    return ["edge_strain", "edge_tension", *(n for n in _NODE_FIELDS if n in reported)]


def frame_fields(model, q: np.ndarray, interactions: Sequence) -> dict[str, np.ndarray]:
    """Values of :func:`frame_field_names` at the current frame (shapes and units in the module docstring)."""
    strain = edge_strain(model, q)
    out = {"edge_strain": strain, "edge_tension": model.edge_EA * strain}
    reports = [inter.node_fields() for inter in interactions if inter.node_field_names]
    for name in _NODE_FIELDS:
        values = [r[name] for r in reports if name in r]
        if values:
            # vector sums over several contact models are not kept; their magnitudes add (one model in practice)
            out[name] = np.sum(values, axis=0) if name in _ADDED else values[0]
    return out
