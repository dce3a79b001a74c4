"""All elastic energies of a model evaluated together, with their reference frames.

:class:`ElasticEnergy` owns the work arrays (tangents, frames, gradient, per-stencil Hessian
blocks) so that a Newton iteration allocates nothing; the kernels it calls live in
:mod:`~knotsim.energies.stretching`, :mod:`~knotsim.energies.bending` and
:mod:`~knotsim.energies.twisting`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from knotsim.energies.bending import bending_energy, bending_twisting_energy
from knotsim.energies.stretching import stretching_energy
from knotsim.energies.twisting import twisting_energy
from knotsim.rods.frames import turned_material_frames, update_frames


@dataclass
class FrameSource:
    """Frames the reference directors are transported from: ``d1 (ne, 3)``, ``tangents (ne, 3)``,
    ``ref_twist (nb,)`` (rad) — usually those of the state at the start of the step."""

    d1: np.ndarray
    tangents: np.ndarray
    ref_twist: np.ndarray


class ElasticEnergy:
    """Stretching + bending + twisting energy of a :class:`~knotsim.rods.Model`."""

    def __init__(self, model, separate_blocks: bool = False):
        """``separate_blocks``: keep twisting Hessian blocks apart from the bending ones (for
        tests); by default they are summed into ``bend_hess``."""
        self.model = model
        self.separate_blocks = separate_blocks
        ne, nb, nd = model.n_edges, model.n_bend, model.n_dofs
        self.tangents = np.zeros((ne, 3))
        self.lengths = np.zeros(ne)
        self.d1 = np.zeros((ne, 3))
        self.m1 = np.zeros((ne, 3))
        self.m2 = np.zeros((ne, 3))
        self.ref_twist = np.zeros(nb)
        self.kappa = np.zeros((nb, 2))
        self.twist = np.zeros(nb)
        self.grad = np.zeros(nd)
        self.stretch_hess = np.zeros((ne, 6, 6))
        self.bend_hess = np.zeros((nb, 11, 11))
        self.twist_hess = np.zeros((nb, 11, 11)) if separate_blocks else self.bend_hess
        self.energies = {"stretching": 0.0, "bending": 0.0, "twisting": 0.0}
        # what an evaluation of turned edge angles only reuses (see evaluate): the unknowns and frame
        # source of the last evaluation when it had the Hessian (None otherwise), its stretching
        # gradient and every stencil's own gradient and energies
        self._hessian_at: np.ndarray | None = None
        self._hessian_source: FrameSource | None = None
        self._stretch_grad = np.zeros(nd)
        self._stencil_grad = np.zeros((nb, 8))
        self._stencil_energy = np.zeros((nb, 2))
        self._stencil_turned = np.zeros(nb, dtype=np.bool_)
        self._every_stencil = np.zeros(0, dtype=np.bool_)

    def update_frames(self, q: np.ndarray, source: FrameSource) -> None:
        """Tangents, reference directors (transported from ``source``), reference twist and material
        frames at ``q``."""
        m = self.model
        self._hessian_at = None  # the frames are no longer those of the last evaluation
        update_frames(q, m.edge_dofs, m.edge_theta_dof, m.bend_edges, source.d1, source.tangents, source.ref_twist,
                      self.tangents, self.lengths, self.d1, self.ref_twist, self.m1, self.m2)

    def evaluate(self, q: np.ndarray, source: FrameSource, want_hessian: bool = True,
                 turned_only: bool = False) -> float:
        """Energy (J) at ``q``; fills ``self.grad`` (n_dofs,) with its gradient and, when
        ``want_hessian``, the per-stencil Hessian blocks.

        ``turned_only``: the caller expects ``q`` to differ from the last evaluation's unknowns in
        edge angles only (e.g. after the stepper's spin relaxation). When that evaluation had the
        Hessian, with the same frame ``source``, and no position differs (checked), only the
        material frames of the turned edges and the stencils with a turned edge are evaluated again;
        energy, gradient and blocks are those of a full evaluation, bit for bit. Otherwise the
        evaluation is a full one."""
        m = self.model
        if (turned_only and want_hessian and not self.separate_blocks and self._hessian_at is not None
                and source is self._hessian_source
                and turned_material_frames(q, self._hessian_at, m.theta_mask, m.edge_theta_dof, m.bend_edges,
                                           self.d1, self.tangents, self.m1, self.m2, self._stencil_turned)):
            es = self.energies["stretching"]
            g = self.grad
            g[:] = self._stretch_grad
            recompute = self._stencil_turned
        else:
            self.update_frames(q, source)
            g = self.grad
            g[:] = 0.0
            es = stretching_energy(q, m.edge_dofs, m.rest_length, m.edge_EA, g, self.stretch_hess, want_hessian)
            if want_hessian:
                self._stretch_grad[:] = g
            recompute = self._every_stencil
        if self.separate_blocks:
            eb = bending_energy(q, m.bend_dofs, m.bend_edges, self.tangents, self.lengths, self.m1, self.m2,
                                m.bend_EI, m.voronoi_rest, m.kappa_bar, g, self.bend_hess, want_hessian, self.kappa)
            et = twisting_energy(q, m.bend_dofs, m.bend_edges, self.tangents, self.lengths, self.ref_twist,
                                 m.twist_GJ, m.voronoi_rest, m.twist_bar, g, self.twist_hess, want_hessian,
                                 self.twist, False)
        else:  # both terms in one pass over the stencils, their Hessians summed into bend_hess
            eb, et = bending_twisting_energy(q, m.bend_dofs, m.bend_edges, self.tangents, self.lengths, self.m1,
                                             self.m2, self.ref_twist, m.bend_EI, m.twist_GJ, m.voronoi_rest,
                                             m.kappa_bar, m.twist_bar, g, self.bend_hess, want_hessian, self.kappa,
                                             self.twist, self._stencil_grad, self._stencil_energy, recompute,
                                             True, True, False)
        if want_hessian:
            self._hessian_at = q.copy()
            self._hessian_source = source
        else:
            self._hessian_at = None
        self.energies["stretching"] = es
        self.energies["bending"] = eb
        self.energies["twisting"] = et
        return es + eb + et
