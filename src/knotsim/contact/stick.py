"""Per-contact history of the elastic-stick friction law (docs/physics.md §3.6): :class:`StickHistory`.

With ``ContactOptions.stick_distance = δ_s`` every listed pair of edges carries a tangential spring:
its displacement ``ξ`` (m, in the contact's tangent plane) and whether it slides. During a step the
pair kernel (:func:`knotsim.contact.surface_friction.surface_friction_pair`) takes the spring as it
was at the start, ``ξ0``, stretches it by the surface slip of the step, ``ξ = ξ0 + u dt``, and pulls
with ``−F_n φ(|ξ|) ξ``: elastically with stiffness ``κ F_n`` (``κ = μ_k/δ_s``) up to the limit
``μ_L F_n``, at the limit beyond. The limit is ``μ_s`` while the pair sticks and ``μ_k`` once it
slides. After an accepted step (:meth:`StickHistory.accept`):

* the spring is carried into the new tangent plane (projected, its length kept);
* a spring beyond its limit slid: the pair slides, and the spring is put back to ``|ξ| = δ_s``, the
  kinetic limit (a return mapping: the rest of the step's slip was sliding);
* a spring within its limit holds: the pair sticks (a sliding pair whose spring came back inside
  the kinetic limit has stopped);
* a pair out of contact forgets its spring.

A contact point that moves along a rope passes from one pair of edges to the next; a pair without a
spring takes over the spring of a neighbouring pair of the same two ropes (edges ±1) that has one
(:meth:`StickHistory.inherit`), so a sliding contact keeps sliding as it crosses the nodes. When the
pair list is rebuilt the springs follow their pairs (:meth:`StickHistory.remap`).

The arrays live in the contact's run memory (:class:`knotsim.contact.model.ContactMemory`,
``stick_xi`` (k, 3) m and ``stick_sliding`` (k,) bool, aligned with ``pairs``), so checkpoints carry
them and a continued run equals an uninterrupted one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from knotsim.errors import ConfigError

__all__ = ["STICK_TOLERANCE", "SpringMemory", "StickHistory", "return_map", "spring_arrays"]

#: A spring counts as beyond its limit when longer than the limit by this fraction: a contact that
#: slid and stopped keeps ``|ξ| = δ_s`` up to rounding and must stick again, not slide on forever.
STICK_TOLERANCE = 1e-9


@dataclass
class SpringMemory:
    """The springs of the elastic-stick law in a holder's run memory (contact, obstacle): every
    contact's tangential spring ``stick_xi (k, 3)`` (m) and whether it slides ``stick_sliding (k,)``
    (``None``: no springs yet)."""

    stick_xi: np.ndarray | None = None
    stick_sliding: np.ndarray | None = None


def spring_arrays(mem, k: int) -> tuple[np.ndarray, np.ndarray]:
    """A run memory's springs ``(stick_xi (k, 3) m, stick_sliding (k,) bool)`` for ``k`` contacts, set
    to zero springs, sticking, where it has none (or a different number)."""
    if mem.stick_xi is None or np.shape(mem.stick_xi) != (k, 3):
        mem.stick_xi = np.zeros((k, 3))
    if mem.stick_sliding is None or np.shape(mem.stick_sliding) != (k,):
        mem.stick_sliding = np.zeros(k, bool)
    mem.stick_xi = np.ascontiguousarray(mem.stick_xi, dtype=float)
    mem.stick_sliding = np.asarray(mem.stick_sliding, bool)
    return mem.stick_xi, mem.stick_sliding


def return_map(xi_trial: np.ndarray, normal: np.ndarray, inside: np.ndarray, limit_length: np.ndarray,
               stick_distance: float) -> tuple[np.ndarray, np.ndarray]:
    """The springs after an accepted step.

    Parameters
    ----------
    xi_trial : (k, 3) springs at the end of the step, ``ξ0 + u dt`` (m).
    normal : (k, 3) unit contact normals at the end of the step.
    inside : (k,) bool, contacts that carry friction at the end of the step.
    limit_length : (k,) m, the length at which each spring reaches its limit, ``μ_L/κ = μ_L δ_s/μ_k``.
    stick_distance : δ_s (m), the length at the kinetic limit.

    Returns
    -------
    ``(xi (k, 3) m, sliding (k,) bool)``: each spring carried into the new tangent plane (projected,
    its length kept); beyond its limit (by more than ``STICK_TOLERANCE``) the contact slides and the
    spring is put back to ``|ξ| = δ_s``; zero out of contact.
    """
    k = xi_trial.shape[0]
    r = np.sqrt(np.einsum("ij,ij->i", xi_trial, xi_trial))
    xp = xi_trial - np.einsum("ij,ij->i", xi_trial, normal)[:, None] * normal
    rp = np.sqrt(np.einsum("ij,ij->i", xp, xp))
    keep = rp > 0.0
    xp[keep] *= (r[keep] / rp[keep])[:, None]
    xp[~keep] = 0.0
    sliding = inside & (r > limit_length * (1.0 + STICK_TOLERANCE))
    scale = np.ones(k)
    scale[sliding] = stick_distance / r[sliding]
    xi = xp * scale[:, None]
    xi[~inside] = 0.0
    return np.ascontiguousarray(xi), sliding


class StickHistory:
    """The elastic-stick law's bookkeeping for :class:`~knotsim.contact.model.Contact`.

    Parameters
    ----------
    model : the rods' model (for the edges' rods and the number of edges).
    stick_distance : δ_s (m), the spring's stretch at the kinetic limit.
    mu_table, mu_static_table : (n_rods, n_rods) kinetic and static coefficients per pair of rods.
    """

    def __init__(self, model, stick_distance: float, mu_table: np.ndarray, mu_static_table: np.ndarray):
        bad = np.argwhere(mu_static_table < mu_table)
        if bad.size:
            a, b = (int(i) for i in bad[0])
            raise ConfigError("contact.mu_static",
                              f"must be at least mu for every pair of rods; rods {a} and {b} have mu_static "
                              f"{mu_static_table[a, b]:g} < mu {mu_table[a, b]:g}")
        self.stick_distance = float(stick_distance)
        self.mu_static = np.ascontiguousarray(mu_static_table, dtype=float)
        self._edge_rod = np.asarray(model.edge_rod, np.int64)
        self._n_edges = int(model.n_edges)

    # ------------------------------------------------------------------ memory
    def kernel_args(self, mem, pair_mu: np.ndarray, pair_mu_static: np.ndarray) -> tuple:
        """``(pair_xi0 (k, 3) m, pair_mu_limit (k,), stick_distance m)`` for the contact kernels."""
        xi, sliding = spring_arrays(mem, pair_mu.shape[0])
        return xi, np.ascontiguousarray(np.where(sliding, pair_mu, pair_mu_static)), self.stick_distance

    def _keys(self, pairs: np.ndarray) -> np.ndarray:
        return pairs[:, 0] * self._n_edges + pairs[:, 1]

    def remap(self, mem, old_pairs: np.ndarray | None, new_pairs: np.ndarray) -> None:
        """The springs of ``old_pairs`` (k_old, 2) moved onto the rebuilt list ``new_pairs`` (k, 2):
        pairs in both keep theirs, new pairs start without one."""
        k = new_pairs.shape[0]
        xi = np.zeros((k, 3))
        sliding = np.zeros(k, bool)
        if old_pairs is not None and old_pairs.shape[0] and k and mem.stick_xi is not None \
                and np.shape(mem.stick_xi) == (old_pairs.shape[0], 3):
            old_keys = self._keys(old_pairs)
            order = np.argsort(old_keys, kind="stable")
            new_keys = self._keys(new_pairs)
            pos = np.clip(np.searchsorted(old_keys[order], new_keys), 0, old_keys.shape[0] - 1)
            found = old_keys[order][pos] == new_keys
            src = order[pos[found]]
            xi[found] = mem.stick_xi[src]
            if mem.stick_sliding is not None and np.shape(mem.stick_sliding) == (old_pairs.shape[0],):
                sliding[found] = np.asarray(mem.stick_sliding, bool)[src]
        mem.stick_xi = xi
        mem.stick_sliding = sliding

    def inherit(self, mem, pairs: np.ndarray) -> None:
        """Pairs without a spring take over the longest spring (and its sliding state) among the
        neighbouring pairs of the list: the same two ropes, each edge shifted by at most one."""
        k = pairs.shape[0]
        xi, sliding = spring_arrays(mem, k)
        length = np.sqrt(np.einsum("ij,ij->i", xi, xi))
        empty = np.flatnonzero(length == 0.0)
        if not empty.size or not np.any(length > 0.0):
            return
        keys = self._keys(pairs)
        order = np.argsort(keys, kind="stable")
        sorted_keys = keys[order]
        a = pairs[empty, 0]
        b = pairs[empty, 1]
        best = np.full(empty.shape[0], -1, np.int64)
        best_len = np.zeros(empty.shape[0])
        er = self._edge_rod
        ne = self._n_edges
        for da in (-1, 0, 1):  # the eight neighbours (not a loop over pairs)
            for db in (-1, 0, 1):
                if da == 0 and db == 0:
                    continue
                na = a + da
                nb = b + db
                ok = (na >= 0) & (na < ne) & (nb >= 0) & (nb < ne)
                ok[ok] &= (er[na[ok]] == er[a[ok]]) & (er[nb[ok]] == er[b[ok]])
                if not ok.any():
                    continue
                nkeys = na * ne + nb
                pos = np.clip(np.searchsorted(sorted_keys, nkeys), 0, k - 1)
                hit = ok & (sorted_keys[pos] == nkeys)
                src = order[pos]
                cand = np.where(hit, length[src], 0.0)
                better = cand > best_len
                best[better] = src[better]
                best_len[better] = cand[better]
        take = best >= 0
        if take.any():
            xi = xi.copy()
            sliding = sliding.copy()
            xi[empty[take]] = xi[best[take]]
            sliding[empty[take]] = sliding[best[take]]
            mem.stick_xi = xi
            mem.stick_sliding = sliding

    # ------------------------------------------------------------------ after an accepted step
    def accept(self, mem, surface: np.ndarray, dt: float) -> None:
        """New springs from the accepted step's pair records ``surface`` (k, SURFACE_COLUMNS) (see
        :func:`knotsim.contact.assembly.contact_evaluate`): carried into the new tangent plane,
        returned to the kinetic limit where they slid, forgotten out of contact."""
        fn = surface[:, 13]
        coef = surface[:, 14]
        kappa = surface[:, 15]
        inside = (fn > 0.0) & (coef > 0.0) & (kappa > 0.0)
        limit = np.zeros(fn.shape[0])
        limit[inside] = coef[inside] / kappa[inside]
        mem.stick_xi, mem.stick_sliding = return_map(surface[:, 4:7] * dt, surface[:, 16:19], inside, limit,
                                                     self.stick_distance)

    @staticmethod
    def stats(mem, surface: np.ndarray) -> dict:
        """``stuck_contacts`` and ``sliding_contacts``: pairs in contact whose spring holds, and
        that slide, after the last accepted step."""
        inside = (surface[:, 13] > 0.0) & (surface[:, 14] > 0.0)
        sliding = np.asarray(mem.stick_sliding, bool) if mem.stick_sliding is not None else np.zeros(0, bool)
        if sliding.shape != inside.shape:
            sliding = np.zeros(inside.shape, bool)
        return {"stuck_contacts": int(np.count_nonzero(inside & ~sliding)),
                "sliding_contacts": int(np.count_nonzero(inside & sliding))}
