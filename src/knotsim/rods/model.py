"""Rod descriptions and the assembled model.

A :class:`RodSpec` describes one rod: its initial centreline, material, cross-section, and its
*rest shape* (natural curvature and twist), which is always separate from the initial shape: a rope
is straight and untwisted at rest however knotted it starts.

A :class:`Model` gathers several rods into one global vector of unknowns ``q`` (see
``docs/architecture.md``) and precomputes everything that does not change during a run: the
stencils of the stretching and bending/twisting energies, their stiffnesses and rest values, the
lumped masses and the Voronoi lengths.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from knotsim.errors import ConfigError, GeometryError

#: Number of local unknowns of a bending/twisting stencil: x_{i-1}, theta_{i-1}, x_i, theta_i, x_{i+1}.
BEND_STENCIL_SIZE = 11


def _as_array(value, shape_desc: str, field_name: str, dtype=float) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise ConfigError(field_name, f"expected {shape_desc} of numbers, got {value!r}") from exc
    if not np.all(np.isfinite(arr)):
        raise ConfigError(field_name, "contains NaN or infinite values")
    return arr


def expand_indices(spec, n: int, where: str, field: str = "nodes") -> np.ndarray:
    """Indices ``(k,)`` into ``n`` items from ``spec``: an integer, ``"all"``, a range string
    ``"a:b"`` or ``"a:b:step"`` (Python slice rules, end excluded, negative counts from the end:
    ``"-3:"`` is the last three), a ``range``/``slice``, or a list mixing integers and range strings
    (``[0, 1, "5:8"]``). A range whose bounds lie outside ``[-n, n]`` or that selects nothing raises
    :class:`ConfigError` naming ``field``; single integers are checked by the caller."""
    if isinstance(spec, str) or isinstance(spec, range | slice):
        spec = [spec]
    items = spec if isinstance(spec, list | tuple) else None
    if items is None:
        return np.atleast_1d(np.asarray(spec))
    out: list[int] = []
    for item in items:
        if isinstance(item, str):
            text = item.strip()
            if text == "all":
                out.extend(range(n))
                continue
            parts = text.split(":")
            try:
                vals = [int(p) if p.strip() else None for p in parts]
            except ValueError:
                vals = []
            if not 2 <= len(parts) <= 3 or not vals:
                raise ConfigError(field, f"expected an index, 'all' or a range 'a:b' / 'a:b:step', got {item!r}")
            item = slice(*vals)
        if isinstance(item, range):
            item = slice(item.start, item.stop, item.step)
        if isinstance(item, slice):
            for bound in (item.start, item.stop):
                if bound is not None and not -n <= bound <= n:
                    raise ConfigError(field, f"range {_slice_text(item)!r} out of range for {where}")
            if item.step == 0:
                raise ConfigError(field, f"range {_slice_text(item)!r} has step 0")
            sel = list(range(n))[item]
            if not sel:
                raise ConfigError(field, f"range {_slice_text(item)!r} selects nothing for {where}")
            out.extend(sel)
        else:
            out.append(item)
    return np.atleast_1d(np.asarray(out))


def _slice_text(s: slice) -> str:
    text = f"{'' if s.start is None else s.start}:{'' if s.stop is None else s.stop}"
    return text + (f":{s.step}" if s.step is not None else "")


@dataclass
class RodSpec:
    """One elastic rod.

    Parameters
    ----------
    positions:
        Initial node positions, shape ``(N, 3)``, m. ``N >= 2`` (``N >= 3`` for a closed rod).
    radius:
        Cross-section radius ``h``, m.
    youngs_modulus:
        Young's modulus ``E``, Pa.
    density:
        Mass density ``rho``, kg/m^3.
    poisson_ratio:
        Poisson ratio, used for the shear modulus ``G = E / (2 (1 + nu))`` unless
        ``shear_modulus`` is given.
    shear_modulus:
        Shear modulus ``G``, Pa (overrides ``poisson_ratio``).
    closed:
        ``True`` for a ring: the last node connects back to the first.
    name:
        Name used in logs and boundary conditions.
    rest_edge_lengths:
        Rest (natural) length of each edge, shape ``(n_edges,)``, m; a scalar applies to all
        edges. Default: the initial edge lengths.
    natural_curvature:
        Natural material curvature per unit length, 1/m: shape ``(n_interior, 2)`` (components
        along the material directors ``m1``, ``m2``) or a pair applied at every interior node.
        Default zero (straight at rest).
    natural_twist:
        Natural twist per unit length, rad/m: shape ``(n_interior,)`` or a scalar. Default zero.
    edge_angles:
        Initial twist angle of each edge's material frame relative to its reference frame,
        shape ``(n_edges,)``, rad. Default zero.
    velocities:
        Initial node velocities, shape ``(N, 3)``, m/s. Default zero.
    reference_directors:
        Initial reference director ``d1`` of each edge, shape ``(n_edges, 3)`` (made unit and
        orthogonal to the edge). Default: space-parallel transport along the rod of a vector
        normal to the first edge.
    bending_stiffness:
        Bending stiffness ``EI``, N m^2, independent of the axial stiffness ``EA = E pi h^2``
        (a fibrous rope bends far more easily than a solid rod of the same ``EA``, see
        docs/physics.md, "Ropes that exist"). Default ``None``: the solid rod's ``E pi h^4 / 4``.
    torsional_stiffness:
        Torsional stiffness ``GJ``, N m^2. Default ``None``: the solid rod's ``G pi h^4 / 2``.

    ``n_edges`` is ``N - 1`` for an open rod and ``N`` for a closed one; ``n_interior`` (the nodes
    with a bending/twisting stencil) is ``N - 2`` for an open rod and ``N`` for a closed one.
    """

    positions: np.ndarray
    radius: float
    youngs_modulus: float
    density: float
    poisson_ratio: float = 0.5
    shear_modulus: float | None = None
    closed: bool = False
    name: str = ""
    rest_edge_lengths: np.ndarray | float | None = None
    natural_curvature: np.ndarray | Sequence[float] | None = None
    natural_twist: np.ndarray | float | None = None
    edge_angles: np.ndarray | None = None
    velocities: np.ndarray | None = None
    reference_directors: np.ndarray | None = None
    bending_stiffness: float | None = None
    torsional_stiffness: float | None = None
    _validated: bool = field(default=False, repr=False)

    # ------------------------------------------------------------------ derived sizes
    @property
    def n_nodes(self) -> int:
        return int(np.shape(self.positions)[0])

    @property
    def n_edges(self) -> int:
        return self.n_nodes if self.closed else self.n_nodes - 1

    @property
    def n_interior(self) -> int:
        return self.n_nodes if self.closed else self.n_nodes - 2

    @property
    def n_dofs(self) -> int:
        return 4 * self.n_nodes if self.closed else 4 * self.n_nodes - 1

    @property
    def area(self) -> float:
        """Cross-section area ``pi h^2``, m^2."""
        return math.pi * self.radius**2

    @property
    def second_moment(self) -> float:
        """Second moment of area ``I = pi h^4 / 4``, m^4."""
        return math.pi * self.radius**4 / 4.0

    @property
    def polar_moment(self) -> float:
        """Polar moment ``J = pi h^4 / 2``, m^4."""
        return math.pi * self.radius**4 / 2.0

    @property
    def G(self) -> float:
        """Shear modulus, Pa."""
        if self.shear_modulus is not None:
            return float(self.shear_modulus)
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def EA(self) -> float:
        """Axial stiffness ``E pi h^2``, N."""
        return self.youngs_modulus * self.area

    @property
    def EI(self) -> float:
        """Bending stiffness, N m^2: ``bending_stiffness`` if given, else ``E pi h^4 / 4``."""
        if self.bending_stiffness is not None:
            return float(self.bending_stiffness)
        return self.youngs_modulus * self.second_moment

    @property
    def GJ(self) -> float:
        """Torsional stiffness, N m^2: ``torsional_stiffness`` if given, else ``G pi h^4 / 2``."""
        if self.torsional_stiffness is not None:
            return float(self.torsional_stiffness)
        return self.G * self.polar_moment

    def edge_vectors(self) -> np.ndarray:
        x = np.asarray(self.positions, dtype=float)
        if self.closed:
            return np.roll(x, -1, axis=0) - x
        return x[1:] - x[:-1]

    def interior_node_edges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For each interior node: (previous node, node, next node) local indices and edges.

        Returns ``(nodes (n_interior, 3), edges (n_interior, 2))`` as local indices.
        """
        n = self.n_nodes
        if self.closed:
            mid = np.arange(n)
            nodes = np.stack([(mid - 1) % n, mid, (mid + 1) % n], axis=1)
            edges = np.stack([(mid - 1) % n, mid], axis=1)
        else:
            mid = np.arange(1, n - 1)
            nodes = np.stack([mid - 1, mid, mid + 1], axis=1)
            edges = np.stack([mid - 1, mid], axis=1)
        return nodes, edges

    # ------------------------------------------------------------------ validation
    def validate(self, where: str = "rod") -> None:
        """Check every field; raise :class:`ConfigError` naming the first bad one."""
        x = _as_array(self.positions, "an (N, 3) array", f"{where}.positions")
        if x.ndim != 2 or x.shape[1] != 3:
            raise ConfigError(f"{where}.positions", f"expected shape (N, 3), got {x.shape}")
        min_nodes = 3 if self.closed else 2
        if x.shape[0] < min_nodes:
            raise ConfigError(
                f"{where}.positions",
                f"a {'closed' if self.closed else 'open'} rod needs at least {min_nodes} nodes, got {x.shape[0]}",
            )
        self.positions = x
        for name in ("radius", "youngs_modulus", "density"):
            val = getattr(self, name)
            if not isinstance(val, int | float | np.floating | np.integer) or not math.isfinite(val) or val <= 0:
                raise ConfigError(f"{where}.{name}", f"must be a positive number, got {val!r}")
        if self.shear_modulus is None:
            nu = self.poisson_ratio
            if not isinstance(nu, int | float | np.floating) or not (-1.0 < nu <= 0.5):
                raise ConfigError(f"{where}.poisson_ratio", f"must lie in (-1, 0.5], got {nu!r}")
        elif not (self.shear_modulus > 0):
            raise ConfigError(f"{where}.shear_modulus", f"must be positive, got {self.shear_modulus!r}")
        for name in ("bending_stiffness", "torsional_stiffness"):
            val = getattr(self, name)
            if val is None:
                continue
            if (isinstance(val, bool) or not isinstance(val, int | float | np.floating | np.integer)
                    or not math.isfinite(val) or val <= 0):
                raise ConfigError(f"{where}.{name}", f"must be a positive number in N m^2 (or none: the solid "
                                                     f"rod's), got {val!r}")
        lengths = np.linalg.norm(self.edge_vectors(), axis=1)
        bad = np.nonzero(lengths <= 1e-12 * max(1.0, float(np.max(np.abs(x)))))[0]
        if bad.size:
            raise GeometryError(
                f"{where}.positions: edge {int(bad[0])} has zero length (nodes {int(bad[0])} and "
                f"{int((bad[0] + 1) % x.shape[0])} coincide); remove duplicate points"
            )
        ne, ni, nn = self.n_edges, self.n_interior, self.n_nodes
        if self.rest_edge_lengths is not None:
            r = _as_array(self.rest_edge_lengths, "a number or (n_edges,) array", f"{where}.rest_edge_lengths")
            r = np.broadcast_to(r, (ne,)).copy() if r.ndim == 0 else r
            if r.shape != (ne,) or np.any(r <= 0):
                raise ConfigError(
                    f"{where}.rest_edge_lengths", f"expected {ne} positive lengths, got shape {r.shape}"
                )
            self.rest_edge_lengths = r
        if self.natural_curvature is not None:
            k = _as_array(self.natural_curvature, "an (n_interior, 2) array", f"{where}.natural_curvature")
            if k.shape == (2,):
                k = np.tile(k, (ni, 1))
            if k.shape != (ni, 2):
                raise ConfigError(
                    f"{where}.natural_curvature", f"expected shape ({ni}, 2) or (2,), got {k.shape}"
                )
            self.natural_curvature = k
        if self.natural_twist is not None:
            t = _as_array(self.natural_twist, "a number or (n_interior,) array", f"{where}.natural_twist")
            t = np.full(ni, float(t)) if t.ndim == 0 else t
            if t.shape != (ni,):
                raise ConfigError(f"{where}.natural_twist", f"expected shape ({ni},), got {t.shape}")
            self.natural_twist = t
        if self.edge_angles is not None:
            a = _as_array(self.edge_angles, "an (n_edges,) array", f"{where}.edge_angles")
            if a.shape != (ne,):
                raise ConfigError(f"{where}.edge_angles", f"expected shape ({ne},), got {a.shape}")
            self.edge_angles = a
        if self.velocities is not None:
            v = _as_array(self.velocities, "an (N, 3) array", f"{where}.velocities")
            if v.shape != (nn, 3):
                raise ConfigError(f"{where}.velocities", f"expected shape ({nn}, 3), got {v.shape}")
            self.velocities = v
        if self.reference_directors is not None:
            d = _as_array(self.reference_directors, "an (n_edges, 3) array", f"{where}.reference_directors")
            if d.shape != (ne, 3):
                raise ConfigError(f"{where}.reference_directors", f"expected shape ({ne}, 3), got {d.shape}")
            self.reference_directors = d
        self._validated = True


class Model:
    """Several rods assembled into one global vector of unknowns.

    Attributes (all numpy arrays; ``ne`` = total edges, ``nn`` = total nodes, ``nb`` = total
    bending/twisting stencils):

    - ``n_dofs``; ``rod_dof_start (n_rods+1,)``, ``rod_node_start (n_rods+1,)``,
      ``rod_edge_start (n_rods+1,)``, ``rod_bend_start (n_rods+1,)``, ``rod_closed (n_rods,)``;
    - ``node_dof (nn,)``: index in ``q`` of each node's x coordinate;
    - ``edge_nodes (ne, 2)``, ``edge_dofs (ne, 2)``, ``edge_theta_dof (ne,)``, ``edge_rod (ne,)``,
      ``edge_local (ne,)``, ``edge_radius (ne,)`` m, ``rest_length (ne,)`` m, ``edge_EA (ne,)`` N;
    - ``stretch_dofs (ne, 6)``: the six position unknowns of each edge;
    - ``bend_dofs (nb, 11)``: unknowns of each stencil (x_prev, theta_prev_edge, x, theta_next_edge,
      x_next); ``bend_edges (nb, 2)``; ``bend_node (nb,)``; ``voronoi_rest (nb,)`` m;
      ``bend_EI (nb,)`` N m^2; ``twist_GJ (nb,)`` N m^2; ``kappa_bar (nb, 2)`` (integrated,
      dimensionless); ``twist_bar (nb,)`` rad (integrated);
    - ``mass (n_dofs,)``: lumped mass per unknown (kg for positions, kg m^2 for edge angles);
    - ``node_voronoi (nn,)``: rest Voronoi length of each node, m;
    - ``gravity (3,)`` m/s^2; ``damping`` viscosity ``eta``, Pa s (force ``-eta v l_voronoi``).
    """

    def __init__(
        self,
        rods: Sequence[RodSpec] | RodSpec,
        gravity: Sequence[float] = (0.0, 0.0, 0.0),
        damping: float = 0.0,
    ):
        if isinstance(rods, RodSpec):
            rods = [rods]
        rods = list(rods)
        if not rods:
            raise ConfigError("rods", "a model needs at least one rod")
        names = []
        for i, rod in enumerate(rods):
            if not isinstance(rod, RodSpec):
                raise ConfigError(f"rods[{i}]", f"expected a RodSpec, got {type(rod).__name__}")
            rod.validate(where=f"rods[{i}]" + (f" ({rod.name})" if rod.name else ""))
            if not rod.name:
                rod.name = f"rod{i}"
            if rod.name in names:
                raise ConfigError(f"rods[{i}].name", f"duplicate rod name {rod.name!r}")
            names.append(rod.name)
        g = _as_array(gravity, "a 3-vector", "gravity")
        if g.shape != (3,):
            raise ConfigError("gravity", f"expected 3 components, got shape {g.shape}")
        if not (isinstance(damping, int | float) and damping >= 0 and math.isfinite(damping)):
            raise ConfigError("damping", f"must be a non-negative viscosity in Pa s, got {damping!r}")
        self.rods = rods
        self.rod_names = names
        self.gravity = g
        self.damping = float(damping)
        self._build()

    # ------------------------------------------------------------------ construction
    def _build(self) -> None:
        rods = self.rods
        nr = len(rods)
        self.n_rods = nr
        self.rod_dof_start = np.zeros(nr + 1, np.int64)
        self.rod_node_start = np.zeros(nr + 1, np.int64)
        self.rod_edge_start = np.zeros(nr + 1, np.int64)
        self.rod_bend_start = np.zeros(nr + 1, np.int64)
        for r, rod in enumerate(rods):
            self.rod_dof_start[r + 1] = self.rod_dof_start[r] + rod.n_dofs
            self.rod_node_start[r + 1] = self.rod_node_start[r] + rod.n_nodes
            self.rod_edge_start[r + 1] = self.rod_edge_start[r] + rod.n_edges
            self.rod_bend_start[r + 1] = self.rod_bend_start[r] + rod.n_interior
        self.n_dofs = int(self.rod_dof_start[-1])
        self.n_nodes = int(self.rod_node_start[-1])
        self.n_edges = int(self.rod_edge_start[-1])
        self.n_bend = int(self.rod_bend_start[-1])
        self.rod_closed = np.array([rod.closed for rod in rods], dtype=np.bool_)
        self.rod_radius = np.array([rod.radius for rod in rods], dtype=float)
        self.rod_n_edges = np.array([rod.n_edges for rod in rods], dtype=np.int64)

        nn, ne, nb, nd = self.n_nodes, self.n_edges, self.n_bend, self.n_dofs
        self.node_dof = np.zeros(nn, np.int64)
        self.node_rod = np.zeros(nn, np.int64)
        self.edge_nodes = np.zeros((ne, 2), np.int64)
        self.edge_theta_dof = np.zeros(ne, np.int64)
        self.edge_rod = np.zeros(ne, np.int64)
        self.edge_local = np.zeros(ne, np.int64)
        self.edge_radius = np.zeros(ne)
        self.rest_length = np.zeros(ne)
        self.edge_EA = np.zeros(ne)
        self.bend_edges = np.zeros((nb, 2), np.int64)
        self.bend_node = np.zeros(nb, np.int64)
        self.bend_dofs = np.zeros((nb, 11), np.int64)
        self.voronoi_rest = np.zeros(nb)
        self.bend_EI = np.zeros(nb)
        self.twist_GJ = np.zeros(nb)
        self.kappa_bar = np.zeros((nb, 2))
        self.twist_bar = np.zeros(nb)
        self.mass = np.zeros(nd)
        self.node_voronoi = np.zeros(nn)
        self.theta_mask = np.zeros(nd, np.bool_)

        for r, rod in enumerate(rods):
            d0, n0, e0, b0 = (int(a[r]) for a in (self.rod_dof_start, self.rod_node_start,
                                                   self.rod_edge_start, self.rod_bend_start))
            N, E = rod.n_nodes, rod.n_edges
            local_nodes = np.arange(N)
            self.node_dof[n0:n0 + N] = d0 + 4 * local_nodes
            self.node_rod[n0:n0 + N] = r
            le = np.arange(E)
            self.edge_nodes[e0:e0 + E, 0] = n0 + le
            self.edge_nodes[e0:e0 + E, 1] = n0 + (le + 1) % N
            self.edge_theta_dof[e0:e0 + E] = d0 + 4 * le + 3
            self.theta_mask[d0 + 4 * le + 3] = True
            self.edge_rod[e0:e0 + E] = r
            self.edge_local[e0:e0 + E] = le
            self.edge_radius[e0:e0 + E] = rod.radius
            lengths = np.linalg.norm(rod.edge_vectors(), axis=1)
            rest = lengths if rod.rest_edge_lengths is None else np.asarray(rod.rest_edge_lengths, float)
            self.rest_length[e0:e0 + E] = rest
            self.edge_EA[e0:e0 + E] = rod.EA

            # Voronoi (rest) length of every node.
            vor = np.zeros(N)
            vor[le] += 0.5 * rest
            vor[(le + 1) % N] += 0.5 * rest
            self.node_voronoi[n0:n0 + N] = vor
            # Lumped masses.
            m_lin = rod.density * rod.area
            for k in range(3):
                self.mass[d0 + 4 * local_nodes + k] = m_lin * vor
            self.mass[d0 + 4 * le + 3] = rod.density * rod.polar_moment * rest

            nodes, edges = rod.interior_node_edges()
            nI = rod.n_interior
            sl = slice(b0, b0 + nI)
            self.bend_edges[sl] = e0 + edges
            self.bend_node[sl] = n0 + nodes[:, 1]
            nd_ = d0 + 4 * nodes
            th = d0 + 4 * edges + 3
            cols = [nd_[:, 0], nd_[:, 0] + 1, nd_[:, 0] + 2, th[:, 0], nd_[:, 1], nd_[:, 1] + 1, nd_[:, 1] + 2,
                    th[:, 1], nd_[:, 2], nd_[:, 2] + 1, nd_[:, 2] + 2]
            self.bend_dofs[sl] = np.stack(cols, axis=1)
            lv = 0.5 * (rest[edges[:, 0]] + rest[edges[:, 1]])
            self.voronoi_rest[sl] = lv
            self.bend_EI[sl] = rod.EI
            self.twist_GJ[sl] = rod.GJ
            if rod.natural_curvature is not None:
                self.kappa_bar[sl] = np.asarray(rod.natural_curvature) * lv[:, None]
            if rod.natural_twist is not None:
                self.twist_bar[sl] = np.asarray(rod.natural_twist) * lv

        self.edge_dofs = self.node_dof[self.edge_nodes]
        sd = np.zeros((ne, 6), np.int64)
        for k in range(3):
            sd[:, k] = self.edge_dofs[:, 0] + k
            sd[:, 3 + k] = self.edge_dofs[:, 1] + k
        self.stretch_dofs = sd
        self.position_mask = ~self.theta_mask

    # ------------------------------------------------------------------ helpers
    def rod_index(self, rod: int | str) -> int:
        """Index of a rod given by index or name; raises :class:`ConfigError` if unknown."""
        if isinstance(rod, str):
            if rod not in self.rod_names:
                raise ConfigError("rod", f"unknown rod {rod!r}; rods are {self.rod_names}")
            return self.rod_names.index(rod)
        if not isinstance(rod, int | np.integer) or not (-self.n_rods <= rod < self.n_rods):
            raise ConfigError("rod", f"rod index {rod!r} out of range (model has {self.n_rods} rods)")
        return int(rod) % self.n_rods

    def global_nodes(self, rod: int | str, nodes) -> np.ndarray:
        """Global node numbers of local node indices ``nodes`` of ``rod`` (negative indices count from
        the end; ``"all"``, ranges ``"a:b"`` / ``"a:b:step"`` and lists mixing both, see
        :func:`expand_indices`). Raises :class:`ConfigError` naming the index if one is out of range."""
        r = self.rod_index(rod)
        n = int(self.rod_node_start[r + 1] - self.rod_node_start[r])
        idx = expand_indices(nodes, n, f"rod {self.rod_names[r]!r} with {n} nodes")
        if idx.size == 0:
            raise ConfigError("nodes", "empty node list")
        if not np.issubdtype(idx.dtype, np.integer):
            raise ConfigError("nodes", f"node indices must be integers, got {nodes!r}")
        bad = idx[(idx < -n) | (idx >= n)]
        if bad.size:
            raise ConfigError(
                "nodes", f"node index {int(bad[0])} out of range for rod {self.rod_names[r]!r} with {n} nodes"
            )
        return self.rod_node_start[r] + (idx % n)

    def node_positions(self, q: np.ndarray) -> np.ndarray:
        """All node positions from ``q``: shape ``(n_nodes, 3)``, m."""
        return q[self.node_dof[:, None] + np.arange(3)[None, :]]

    def edge_angles(self, q: np.ndarray) -> np.ndarray:
        """All edge angles from ``q``: shape ``(n_edges,)``, rad."""
        return q[self.edge_theta_dof]

    def rod_positions(self, q: np.ndarray, rod: int | str) -> np.ndarray:
        r = self.rod_index(rod)
        return self.node_positions(q)[self.rod_node_start[r]:self.rod_node_start[r + 1]]

    def total_mass(self) -> float:
        """Total mass of all rods, kg."""
        return float(np.sum(self.mass[self.node_dof]))
