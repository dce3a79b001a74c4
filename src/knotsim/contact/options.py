"""Settings of the rope-rope contact (IMC) and friction: :class:`ContactOptions`."""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import StrEnum

from knotsim._util.validate import choice, flag, number
from knotsim.errors import ConfigError

__all__ = ["ContactOptions", "FrictionModel", "StiffnessMode"]


def _positive(name: str, value, allow_zero: bool = False) -> float:
    return (number(value, f"contact.{name}", at_least=0.0, must="be a non-negative finite number") if allow_zero
            else number(value, f"contact.{name}", above=0.0, must="be a positive finite number"))


def _coefficient(name: str, value) -> float | dict:
    """A friction coefficient: a non-negative number, or a per-rod-pair table (see ``mu``)."""
    if isinstance(value, dict):
        for key, val in value.items():
            _positive(f"{name}[{key!r}]", val, allow_zero=True)
            if key != "default" and not (isinstance(key, tuple) and len(key) == 2):
                raise ConfigError(f"contact.{name}",
                                  f"table keys must be (rod_a, rod_b) pairs or 'default', got {key!r}")
        return value
    return _positive(name, value, allow_zero=True)


class StiffnessMode(StrEnum):
    """How the contact stiffness k_c is chosen (:attr:`ContactOptions.stiffness_mode`)."""

    ADAPTIVE = "adaptive"  #: from the largest contact force and approach speed, step by step
    CONSTANT = "constant"  #: ``stiffness`` throughout


class FrictionModel(StrEnum):
    """Where friction acts (:attr:`ContactOptions.friction_model`; docs/physics.md §3)."""

    SURFACE = "surface"  #: at the rods' surface points: strands roll and twist as well as slide
    CENTRELINE = "centreline"  #: on the centre lines' contact points (the IMC law; no friction torque)


@dataclass
class ContactOptions:
    """Settings of :class:`Contact` (SI units).

    - ``delta``: IMC distance tolerance δ (m), default 5e-4;
    - ``nu``: slip tolerance ν (m/s) of the smooth Coulomb law, default 1e-4;
    - ``mu``: friction coefficient; a number, or a per-rod-pair table ``{(rod_a, rod_b): mu, ...}``
      (rods by index or name, order irrelevant; self-contact of rod ``a`` is ``(a, a)``) with an
      optional ``"default"`` entry (default 0) for the pairs not listed. Default 0 (no friction);
    - ``stiffness_mode``: ``"adaptive"`` (default) or ``"constant"``;
    - ``stiffness``: contact stiffness k_c (N/m); required for ``"constant"``; in adaptive mode
      an optional lower bound / starting value;
    - ``stiffness_scaler``: adaptive ``k_c = scaler × F_max / h_min`` (default 500);
    - ``stiffness_floor``: smallest adaptive k_c (N/m); default from the model (see module doc);
    - ``initial_stiffness``: adaptive k_c at the start (N/m, not below the floor); default the floor.
      A run that continues a pressed knot (``knotsim pull --geometry RUN_DIR``) starts from that
      run's k_c, so that its contacts carry the same forces at the start;
    - ``margin``: broad-phase cut-off margin (m), default 2e-3;
    - ``penetration_limit``: deepest accepted penetration as a fraction of the smaller radius of the
      pair (default 0.2); a deeper step is retried smaller;
    - ``self_contact``: whether edges of the same rod touch (default True);
    - ``friction_model``: ``"surface"`` (default): friction acts at the rods' surface points, whose
      velocity includes the cross-sections' rotation, and exerts torques on the edge angles
      (:mod:`knotsim.contact.surface_friction`), so a strand can roll through a crossing;
      ``"centreline"``: the Implicit Contact Model's law on the centre lines' contact points
      (:mod:`knotsim.contact.friction`; the results of knotsim before the surface model, bit for bit);
    - ``parallel_smoothing``: length ℓ (m) of the regularization of the edge–edge distance
      (:mod:`knotsim.contact.regularized_distance`) that makes contact between (nearly) parallel
      edges smooth, default 2e-6. Each pair gets ``η = 8 d ℓ / (l̄_a² + l̄_b²)`` (``d`` its contact
      distance, ``l̄`` the rest lengths of its edges), so that the regularized distance Δ exceeds the
      exact one by at most ``ℓ d / Δ`` (at unstretched edges), and the contact point of two parallel
      edges moves from the middle of their overlap to its end over node motions of about 4ℓ, whatever
      the mesh. 0 uses
      the exact segment distance, whose force jumps between the nodes of parallel edges.
    - ``stick_distance``: δ_s (m), switches the surface friction to the elastic-stick law
      (docs/physics.md §3.6): every contact carries a tangential spring of stiffness ``μ F_n/δ_s``
      that holds below its limit (no creep: a knot below its slip load does not move) and slips at
      the limit, ``mu_static × F_n`` while it sticks and ``mu × F_n`` once it slides. ``None``
      (default): the smooth law of ``nu``, which creeps under any tangential load. Needs
      ``friction_model = "surface"``;
    - ``mu_static``: static friction coefficient μ_s ≥ ``mu`` (a number or a table like ``mu``) of the
      elastic-stick law; default ``mu`` (no static excess). Needs ``stick_distance``.
    """

    delta: float = 5e-4
    nu: float = 1e-4
    mu: float | dict = 0.0
    stiffness_mode: StiffnessMode | str = "adaptive"
    stiffness: float | None = None
    stiffness_scaler: float = 500.0
    stiffness_floor: float | None = None
    initial_stiffness: float | None = None
    margin: float = 2e-3
    penetration_limit: float = 0.2
    self_contact: bool = True
    parallel_smoothing: float = 2e-6
    friction_model: FrictionModel | str = "surface"
    stick_distance: float | None = None
    mu_static: float | dict | None = None

    @classmethod
    def from_table(cls, table: dict) -> ContactOptions:
        """Options from a ``[contact]`` configuration table (checked by :meth:`validate`).

        Keys are the fields of this class; an unknown key raises :class:`ConfigError` naming it.
        ``mu`` may be a number or a table ``{default = 0.1, "rope,obstacle" = 0.3}`` whose keys other
        than ``default`` are two rod names (or indices) separated by a comma.
        """
        if not isinstance(table, dict):
            raise ConfigError("contact", f"expected a table, got {type(table).__name__}")
        names = {f.name for f in fields(cls)}
        kwargs = {}
        for key, val in table.items():
            if key not in names:
                raise ConfigError(f"contact.{key}", f"unknown key; known keys are {sorted(names)}")
            kwargs[key] = val
        for name in ("mu", "mu_static"):
            mu = kwargs.get(name)
            if isinstance(mu, dict):
                parsed = {}
                for key, val in mu.items():
                    if key == "default":
                        parsed["default"] = val
                        continue
                    parts = [p.strip() for p in str(key).split(",")]
                    if len(parts) != 2 or not all(parts):
                        raise ConfigError(f"contact.{name}.{key}",
                                          "expected two rod names separated by a comma, e.g. \"a,b\"")
                    parsed[tuple(int(p) if p.lstrip("-").isdigit() else p for p in parts)] = val
                kwargs[name] = parsed
        opts = cls(**kwargs)
        opts.validate()
        return opts

    def validate(self) -> None:
        """Raise :class:`ConfigError` naming the first bad field."""
        self.delta = _positive("delta", self.delta)
        self.nu = _positive("nu", self.nu)
        self.mu = _coefficient("mu", self.mu)
        if self.mu_static is not None:
            self.mu_static = _coefficient("mu_static", self.mu_static)
        self.stiffness_mode = choice(self.stiffness_mode, "contact.stiffness_mode", StiffnessMode,
                                     must="be 'adaptive' or 'constant'")
        if self.stiffness is not None:
            self.stiffness = _positive("stiffness", self.stiffness)
        elif self.stiffness_mode == "constant":
            raise ConfigError("contact.stiffness", "constant stiffness mode needs a stiffness (N/m)")
        self.stiffness_scaler = _positive("stiffness_scaler", self.stiffness_scaler)
        if self.stiffness_floor is not None:
            self.stiffness_floor = _positive("stiffness_floor", self.stiffness_floor)
        if self.initial_stiffness is not None:
            self.initial_stiffness = _positive("initial_stiffness", self.initial_stiffness)
        self.friction_model = choice(self.friction_model, "contact.friction_model", FrictionModel,
                                     must="be 'surface' or 'centreline'")
        self.margin = _positive("margin", self.margin, allow_zero=True)
        self.penetration_limit = _positive("penetration_limit", self.penetration_limit)
        self.parallel_smoothing = _positive("parallel_smoothing", self.parallel_smoothing, allow_zero=True)
        if self.parallel_smoothing > 0.1 * self.delta:
            raise ConfigError("contact.parallel_smoothing",
                              f"must be at most 0.1 delta = {0.1 * self.delta:g} m (it is the largest increase of "
                              f"the contact distance it causes), got {self.parallel_smoothing!r}; "
                              f"typical values are 1e-6 to 1e-5 m")
        if self.stick_distance is not None:
            self.stick_distance = _positive("stick_distance", self.stick_distance)
            if self.friction_model != FrictionModel.SURFACE:
                raise ConfigError("contact.stick_distance",
                                  "the elastic-stick law acts at the rods' surfaces; set friction_model = \"surface\" "
                                  "or remove stick_distance")
        elif self.mu_static is not None:
            raise ConfigError("contact.mu_static", "static friction needs the elastic-stick law: set "
                              "contact.stick_distance (m), e.g. 1e-5, or remove mu_static")
        flag(self.self_contact, "contact.self_contact")

