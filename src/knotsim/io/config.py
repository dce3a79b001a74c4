"""Run configuration: a TOML file describing a run, turned into ready-to-use objects.

>>> cfg = load_config("examples/pull_both_ends.toml")
>>> sim = build_simulation(cfg)
>>> log = sim.run(cfg.duration, output_dir="out", output_interval=cfg.output_interval)

Every value is in SI units (m, s, kg, N, Pa, rad). Every key is checked: an unknown key, a value of
the wrong type or out of range raises :class:`~knotsim.errors.ConfigError` whose field is the full
key path (``rods[0].youngs_modulus``, ``bc[2].waypoints.times``, ``solver.dt``), with a suggestion
for misspelt keys.

Schema
------
Top level tables: ``[[rods]]`` (one or more, required), ``[model]``, ``[[bc]]``, ``[solver]``,
``[run]`` (required: ``duration``), ``[contact]``, and an optional ``description`` string.

``[[rods]]`` -- one table per rod:

- ``name`` (str, default ``"rod<i>"``); ``shape`` (str, required) and its keys:

  - ``"straight"``: ``length`` (m), ``n_nodes``, ``start`` = [x, y, z] (m, default origin),
    ``direction`` = [x, y, z] (default [1, 0, 0], normalised);
  - ``"helix"``: ``helix_radius`` (m), ``pitch`` (m per turn), ``turns``, ``n_nodes``,
    ``start`` (centre of the helix base, m, default origin), ``axis`` (default [0, 0, 1]);
  - ``"circle"`` (closed ring): ``ring_radius`` (m), ``n_nodes``, ``center`` (m, default origin),
    ``normal`` (default [0, 0, 1]);
  - ``"points"``: either ``positions`` = [[x, y, z], ...] (m) or ``file`` = path of a ``.npy``
    array or ``.csv`` table of shape (N, 3), m, relative to the TOML file;

- material and cross-section: ``radius`` (cross-section radius, m), ``youngs_modulus`` (Pa),
  ``density`` (kg/m^3) -- all required; ``poisson_ratio`` (default 0.5) or ``shear_modulus`` (Pa);
- ``closed`` (bool; default false, true for ``"circle"``);
- rest shape: ``natural_curvature`` = [k1, k2] (1/m, along the material directors),
  ``natural_twist`` (rad/m), ``rest_edge_length`` (m, a number or one per edge; default the
  initial edge lengths). Per-node lists are accepted as well (see
  :class:`~knotsim.rods.RodSpec`).

``[model]``: ``gravity`` = [x, y, z] (m/s^2, default zero), ``damping`` (viscosity, Pa s,
default 0).

``[[bc]]`` -- boundary conditions, see :class:`~knotsim.bc.BoundaryConditions`. Keys:
``type`` (required), ``name`` (default ``"<type><i>"``; reaction forces are logged under it),
``rod`` (name or index, default 0), ``nodes`` (required list of local node indices, negative
counting from the end; a single integer is accepted), ``start`` / ``stop`` (s, active window
``[start, stop)``, default ``[0, inf)``), and per type:

- ``clamp``: ``twist`` (bool, default true: also fix the angles of the edges between the nodes);
- ``hold``: nothing more (twist stays free);
- ``move``: ``twist`` (default true) and exactly one of ``velocity`` = [vx, vy, vz] (m/s) or
  ``waypoints`` = {times = [...] (s since activation, first 0), points = [[x, y, z], ...] (m),
  absolute = false, from_current = false}; relative points are displacements (first one
  [0, 0, 0]), absolute ones are positions of the group's centroid (the first one must be where the
  centroid is, unless ``from_current = true``: then the path starts wherever the centroid is when the
  group activates and reaches ``points[0]`` at ``times[0] > 0``);
- ``rotate``: ``rate`` (rad/s) -- the nodes are clamped and the edges between them twisted;
- ``force``: exactly one of ``force`` = [fx, fy, fz] (N, total on the group, constant) or
  ``ramp`` = {from = [..], to = [..], duration = ..} (N, N, s: linear from ``start`` on, then
  constant);
- ``moment``: ``edges`` (instead of ``nodes``) and ``moment`` (N m on each edge) or ``ramp`` with
  scalar ``from`` / ``to``;
- ``release``: ``name`` (the group to release) and ``at`` (s). A released group stops acting at
  ``at`` and keeps its velocity (it is the same as giving that group ``stop = at``).

``[solver]``: any field of :class:`~knotsim.solver.stepper.SolverSettings` (``dt``, ``dt_min``,
``max_iterations``, ``force_tol``, ``moment_tol``, ``step_tol``, ``angle_tol``, ``line_search``,
``grow_after``, ``easy_iterations``, ``linear_solver``, ``predictor``).

``[run]``: ``duration`` (s, required), ``output_interval`` (s between trajectory frames; default
every step).

``[contact]``: passed as is to ``knotsim.contact.model.contact_from_config(model, table)`` when
that function exists (it checks its own keys: delta, nu, mu, stiffness, margin,
penetration_limit, ...); otherwise a ``[contact]`` table is an error.

Full example::

    description = "rope pulled from both ends"

    [[rods]]
    name = "rope"
    shape = "straight"
    length = 0.2            # m
    n_nodes = 41
    start = [0.0, 0.0, 0.0]
    direction = [1.0, 0.0, 0.0]
    radius = 1e-3           # m
    youngs_modulus = 1e7    # Pa
    density = 1000.0        # kg/m^3
    poisson_ratio = 0.5

    [model]
    gravity = [0.0, 0.0, -9.81]
    damping = 0.0

    [[bc]]
    type = "clamp"
    name = "left"
    rod = "rope"
    nodes = [0, 1]

    [[bc]]
    type = "move"
    name = "right"
    rod = "rope"
    nodes = [-2, -1]
    velocity = [0.01, 0.0, 0.0]   # m/s

    [[bc]]
    type = "release"
    name = "right"
    at = 0.5                      # s

    [solver]
    dt = 1e-3
    max_iterations = 25

    [run]
    duration = 1.0
    output_interval = 0.01
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import importlib
import importlib.util
import math
import os
import tomllib
import typing
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from knotsim.bc import BoundaryConditions, Waypoints
from knotsim.errors import ConfigError
from knotsim.rods import Model, RodSpec
from knotsim.solver.stepper import SolverSettings

__all__ = ["RunConfig", "build_simulation", "contact_interactions", "load_config"]

_MISSING = object()

# ---------------------------------------------------------------------------------------- schema
_TOP_KEYS = ("description", "rods", "model", "bc", "solver", "run", "contact")

_ROD_COMMON = ("name", "shape", "radius", "youngs_modulus", "density", "poisson_ratio", "shear_modulus",
               "closed", "natural_curvature", "natural_twist", "rest_edge_length")
_ROD_SHAPES = {
    "straight": ("length", "n_nodes", "start", "direction"),
    "helix": ("helix_radius", "pitch", "turns", "n_nodes", "start", "axis"),
    "circle": ("ring_radius", "n_nodes", "center", "normal"),
    "points": ("positions", "file"),
}

_BC_COMMON = ("type", "name", "rod", "nodes", "start", "stop")
_BC_TYPES = {
    "clamp": _BC_COMMON + ("twist",),
    "hold": _BC_COMMON,
    "move": _BC_COMMON + ("twist", "velocity", "waypoints"),
    "rotate": _BC_COMMON + ("rate",),
    "force": _BC_COMMON + ("force", "ramp"),
    "moment": ("type", "name", "rod", "edges", "start", "stop", "moment", "ramp"),
    "release": ("type", "name", "at"),
}

_MODEL_KEYS = ("gravity", "damping")
_RUN_KEYS = ("duration", "output_interval")


# ---------------------------------------------------------------------------------------- result
@dataclass
class RunConfig:
    """A run description, checked and turned into objects.

    - ``model``: the :class:`~knotsim.rods.Model`;
    - ``bcs_builder``: ``bcs_builder(model) -> BoundaryConditions``, a fresh set each call
      (groups capture anchors while running, so each simulation needs its own; see
      :meth:`build_bcs`);
    - ``solver``: :class:`~knotsim.solver.stepper.SolverSettings`;
    - ``duration`` (s) and ``output_interval`` (s between trajectory frames, ``None``: every step);
    - ``raw``: the configuration as a plain dict (recorded in ``run.json``);
    - ``contact``: the ``[contact]`` table or ``None``;
    - ``base_dir``: directory relative file names are resolved against.
    """

    model: Model
    bcs_builder: Callable[[Model], BoundaryConditions]
    solver: SolverSettings
    duration: float
    output_interval: float | None
    raw: dict
    contact: dict | None = None
    base_dir: Path = field(default_factory=Path.cwd)

    def build_bcs(self) -> BoundaryConditions:
        """A fresh :class:`~knotsim.bc.BoundaryConditions` for :attr:`model`."""
        return self.bcs_builder(self.model)


# ---------------------------------------------------------------------------------------- helpers
def _type_name(value) -> str:
    return type(value).__name__


def _check_keys(table: dict, path: str, allowed, elsewhere: dict[str, str] | None = None) -> None:
    """Raise :class:`ConfigError` for the first key of ``table`` not in ``allowed``.

    ``elsewhere`` maps keys that are valid in another variant (another rod shape, another bc type)
    to a hint naming that variant.
    """
    allowed = list(allowed)
    for key in table:
        if key in allowed:
            continue
        where = f"{path}.{key}" if path else str(key)
        if elsewhere and key in elsewhere:
            raise ConfigError(where, f"unknown key here ({elsewhere[key]})")
        close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
        if close:
            raise ConfigError(where, f"unknown key; did you mean '{close[0]}'?")
        raise ConfigError(where, f"unknown key; allowed keys are {', '.join(allowed)}")


def _table(value, path: str) -> dict:
    if not isinstance(value, dict):
        raise ConfigError(path, f"expected a table, got {value!r} ({_type_name(value)})")
    return value


def _is_number(v) -> bool:
    return isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool | np.bool_)


def _number(v, path: str, *, positive: bool = False, nonneg: bool = False) -> float:
    if not _is_number(v):
        raise ConfigError(path, f"expected a number, got {v!r} ({_type_name(v)})")
    x = float(v)
    if not math.isfinite(x):
        raise ConfigError(path, f"expected a finite number, got {v!r}")
    if positive and not x > 0:
        raise ConfigError(path, f"must be positive, got {v!r}")
    if nonneg and not x >= 0:
        raise ConfigError(path, f"must be non-negative, got {v!r}")
    return x


def _integer(v, path: str, *, minimum: int | None = None) -> int:
    if not isinstance(v, int | np.integer) or isinstance(v, bool | np.bool_):
        raise ConfigError(path, f"expected an integer, got {v!r} ({_type_name(v)})")
    if minimum is not None and v < minimum:
        raise ConfigError(path, f"must be at least {minimum}, got {v!r}")
    return int(v)


def _boolean(v, path: str) -> bool:
    if not isinstance(v, bool | np.bool_):
        raise ConfigError(path, f"expected true or false, got {v!r} ({_type_name(v)})")
    return bool(v)


def _string(v, path: str) -> str:
    if not isinstance(v, str):
        raise ConfigError(path, f"expected a string, got {v!r} ({_type_name(v)})")
    return v


def _numbers(v, path: str, shape: tuple | None = None) -> np.ndarray:
    """A number or (nested) list of numbers as a float array, optionally of a given shape."""

    def walk(x, p):
        if isinstance(x, list | tuple | np.ndarray):
            for i, y in enumerate(x):
                walk(y, f"{p}[{i}]")
        elif not _is_number(x):
            raise ConfigError(path, f"expected numbers, got {x!r} ({_type_name(x)}) at {p}")

    walk(v, path)
    try:
        arr = np.asarray(v, dtype=float)
    except ValueError:
        raise ConfigError(path, f"expected a rectangular list of numbers, got {v!r}") from None
    if not np.all(np.isfinite(arr)):
        raise ConfigError(path, f"contains NaN or infinite values: {v!r}")
    if shape is not None and arr.shape != shape:
        want = "a list of 3 numbers [x, y, z]" if shape == (3,) else f"shape {shape}"
        raise ConfigError(path, f"expected {want}, got {v!r}")
    return arr


def _vec3(v, path: str) -> np.ndarray:
    return _numbers(v, path, (3,))


def _unit(v, path: str) -> np.ndarray:
    a = _vec3(v, path)
    n = float(np.linalg.norm(a))
    if n == 0.0:
        raise ConfigError(path, "must be a non-zero vector")
    return a / n


def _points(v, path: str) -> np.ndarray:
    arr = _numbers(v, path)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ConfigError(path, f"expected a list of [x, y, z] points, got shape {arr.shape}")
    return arr


def _int_list(v, path: str) -> list[int]:
    if isinstance(v, int) and not isinstance(v, bool):
        return [v]
    if not isinstance(v, list) or not v:
        raise ConfigError(path, f"expected a non-empty list of integers, got {v!r}")
    return [_integer(x, f"{path}[{i}]") for i, x in enumerate(v)]


def _get(table: dict, key: str, path: str, conv, default=_MISSING, **kw):
    """``conv(table[key])`` or ``default``; a missing key without default is an error."""
    if key not in table:
        if default is _MISSING:
            raise ConfigError(f"{path}.{key}" if path else key, "missing required field")
        return default
    return conv(table[key], f"{path}.{key}" if path else key, **kw)


def _perpendicular_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``e1, e2`` with ``(e1, e2, axis)`` right handed (``e1 = x`` for ``axis = z``)."""
    ref = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - np.dot(ref, axis) * axis
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


# ---------------------------------------------------------------------------------------- rods
def _rod_positions(t: dict, path: str, shape: str, base_dir: Path) -> np.ndarray:
    if shape == "straight":
        length = _get(t, "length", path, _number, positive=True)
        n = _get(t, "n_nodes", path, _integer, minimum=2)
        start = _get(t, "start", path, _vec3, np.zeros(3))
        direction = _get(t, "direction", path, _unit, np.array([1.0, 0.0, 0.0]))
        s = np.linspace(0.0, length, n)
        return start[None, :] + s[:, None] * direction[None, :]
    if shape == "helix":
        radius = _get(t, "helix_radius", path, _number, positive=True)
        pitch = _get(t, "pitch", path, _number)
        turns = _get(t, "turns", path, _number, positive=True)
        n = _get(t, "n_nodes", path, _integer, minimum=2)
        start = _get(t, "start", path, _vec3, np.zeros(3))
        axis = _get(t, "axis", path, _unit, np.array([0.0, 0.0, 1.0]))
        e1, e2 = _perpendicular_basis(axis)
        phi = np.linspace(0.0, 2.0 * math.pi * turns, n)
        return (start[None, :] + radius * np.cos(phi)[:, None] * e1 + radius * np.sin(phi)[:, None] * e2
                + (pitch * phi / (2.0 * math.pi))[:, None] * axis)
    if shape == "circle":
        radius = _get(t, "ring_radius", path, _number, positive=True)
        n = _get(t, "n_nodes", path, _integer, minimum=3)
        center = _get(t, "center", path, _vec3, np.zeros(3))
        normal = _get(t, "normal", path, _unit, np.array([0.0, 0.0, 1.0]))
        e1, e2 = _perpendicular_basis(normal)
        phi = 2.0 * math.pi * np.arange(n) / n
        return center[None, :] + radius * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    # points
    has_pos, has_file = "positions" in t, "file" in t
    if has_pos == has_file:
        raise ConfigError(f"{path}.positions", "give exactly one of 'positions' or 'file' for shape 'points'")
    if has_pos:
        return _points(t["positions"], f"{path}.positions")
    return _load_points_file(_string(t["file"], f"{path}.file"), f"{path}.file", base_dir)


def _load_points_file(name: str, path: str, base_dir: Path) -> np.ndarray:
    f = Path(name)
    if not f.is_absolute():
        f = base_dir / f
    if not f.is_file():
        raise ConfigError(path, f"file not found: {str(f)!r}")
    suffix = f.suffix.lower()
    try:
        if suffix == ".npy":
            arr = np.load(f, allow_pickle=False)
        elif suffix == ".csv":
            try:
                arr = np.loadtxt(f, delimiter=",", ndmin=2)
            except ValueError:  # a header line
                arr = np.loadtxt(f, delimiter=",", ndmin=2, skiprows=1)
        else:
            raise ConfigError(path, f"expected a .npy or .csv file, got {name!r}")
    except ConfigError:
        raise
    except (OSError, ValueError) as exc:
        raise ConfigError(path, f"could not read {str(f)!r}: {exc}") from None
    arr = np.asarray(arr)
    if not np.issubdtype(arr.dtype, np.number):
        raise ConfigError(path, f"{str(f)!r} does not hold numbers (dtype {arr.dtype})")
    arr = arr.astype(float)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ConfigError(path, f"{str(f)!r} must hold an (N, 3) array of positions in m, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(path, f"{str(f)!r} contains NaN or infinite values")
    return arr


def _parse_rod(t, i: int, base_dir: Path) -> RodSpec:
    path = f"rods[{i}]"
    t = _table(t, path)
    if "shape" not in t:
        _check_keys(t, path, sorted(set(_ROD_COMMON).union(*_ROD_SHAPES.values())))
    shape = _get(t, "shape", path, _string)
    if shape not in _ROD_SHAPES:
        raise ConfigError(f"{path}.shape", f"unknown shape {shape!r}; expected one of {', '.join(_ROD_SHAPES)}")
    own = _ROD_COMMON + _ROD_SHAPES[shape]
    elsewhere = {k: f"it belongs to shape '{s}', this rod has shape '{shape}'"
                 for s, keys in _ROD_SHAPES.items() for k in keys if k not in own}
    _check_keys(t, path, own, elsewhere)
    positions = _rod_positions(t, path, shape, base_dir)

    closed = _get(t, "closed", path, _boolean, shape == "circle")
    if shape == "circle" and not closed:
        raise ConfigError(f"{path}.closed", "a circle is a closed ring; use shape 'points' for an open arc")
    kw = {
        "positions": positions,
        "radius": _get(t, "radius", path, _number, positive=True),
        "youngs_modulus": _get(t, "youngs_modulus", path, _number, positive=True),
        "density": _get(t, "density", path, _number, positive=True),
        "closed": closed,
        "name": _get(t, "name", path, _string, ""),
    }
    if "poisson_ratio" in t and "shear_modulus" in t:
        raise ConfigError(f"{path}.shear_modulus", "give either poisson_ratio or shear_modulus, not both")
    if "poisson_ratio" in t:
        kw["poisson_ratio"] = _get(t, "poisson_ratio", path, _number)
    if "shear_modulus" in t:
        kw["shear_modulus"] = _get(t, "shear_modulus", path, _number, positive=True)
    if "natural_curvature" in t:
        kw["natural_curvature"] = _numbers(t["natural_curvature"], f"{path}.natural_curvature")
    if "natural_twist" in t:
        kw["natural_twist"] = _numbers(t["natural_twist"], f"{path}.natural_twist")
    if "rest_edge_length" in t:
        kw["rest_edge_lengths"] = _numbers(t["rest_edge_length"], f"{path}.rest_edge_length")
    spec = RodSpec(**kw)
    # RodSpec names its own fields (rest_edge_lengths); validate here so the key path matches the TOML.
    try:
        spec.validate(where=path)
    except ConfigError as exc:
        fld = exc.field.replace(f"{path}.rest_edge_lengths", f"{path}.rest_edge_length")
        raise ConfigError(fld, _message(exc)) from None
    return spec


def _message(exc: ConfigError) -> str:
    s = str(exc)
    prefix = f"{exc.field}: "
    return s[len(prefix):] if s.startswith(prefix) else s


# ---------------------------------------------------------------------------------------- bcs
@dataclass
class _BCSpec:
    index: int
    kind: str
    name: str
    kwargs: dict
    key_map: dict = field(default_factory=dict)  # API field suffix -> TOML key


def _ramp(value, path: str, start: float, shape: tuple):
    r = _table(value, path)
    _check_keys(r, path, ("from", "to", "duration"))
    conv = _vec3 if shape == (3,) else _number
    f0 = _get(r, "from", path, conv)
    f1 = _get(r, "to", path, conv)
    dur = _get(r, "duration", path, _number, positive=True)

    def load(t: float):
        """Load at absolute time ``t`` (s): linear from ``start`` to ``start + duration``."""
        return f0 + (f1 - f0) * min(max((t - start) / dur, 0.0), 1.0)

    return load


def _parse_bc(t, i: int) -> _BCSpec:
    path = f"bc[{i}]"
    t = _table(t, path)
    if "type" not in t:
        _check_keys(t, path, sorted(set().union(*_BC_TYPES.values())))
    kind = _get(t, "type", path, _string)
    if kind not in _BC_TYPES:
        raise ConfigError(f"{path}.type", f"unknown type {kind!r}; expected one of {', '.join(_BC_TYPES)}")
    own = _BC_TYPES[kind]
    elsewhere = {k: f"not used by type '{kind}'" for keys in _BC_TYPES.values() for k in keys if k not in own}
    _check_keys(t, path, own, elsewhere)

    if kind == "release":
        name = _get(t, "name", path, _string)
        at = _get(t, "at", path, _number, nonneg=True)
        return _BCSpec(i, kind, name, {"at": at})

    name = _get(t, "name", path, _string, f"{kind}{i}")
    if not name:
        raise ConfigError(f"{path}.name", "must not be empty")
    rod = t.get("rod", 0)
    if not (isinstance(rod, str) or (isinstance(rod, int) and not isinstance(rod, bool))):
        raise ConfigError(f"{path}.rod", f"expected a rod name or index, got {rod!r} ({_type_name(rod)})")
    start = _get(t, "start", path, _number, 0.0, nonneg=True)
    stop = _get(t, "stop", path, _number, None)
    kw: dict = {"rod": rod, "start": start, "stop": stop}
    key_map: dict = {}
    if kind == "moment":
        kw["edges"] = _get(t, "edges", path, _int_list)
    else:
        kw["nodes"] = _get(t, "nodes", path, _int_list)
    if kind in ("clamp", "move"):
        kw["twist"] = _get(t, "twist", path, _boolean, True)
    if kind == "move":
        has_v, has_w = "velocity" in t, "waypoints" in t
        if has_v == has_w:
            raise ConfigError(f"{path}.velocity", "a moving group needs exactly one of 'velocity' or 'waypoints'")
        if has_v:
            kw["path"] = _vec3(t["velocity"], f"{path}.velocity")
            key_map["path"] = "velocity"
        else:
            wpath = f"{path}.waypoints"
            w = _table(t["waypoints"], wpath)
            _check_keys(w, wpath, ("times", "points", "absolute", "from_current"))
            times = _get(w, "times", wpath, _numbers)
            points = _get(w, "points", wpath, _numbers)
            absolute = _get(w, "absolute", wpath, _boolean, False)
            from_current = _get(w, "from_current", wpath, _boolean, False)
            try:
                kw["path"] = Waypoints(times, points, absolute=absolute, from_current=from_current)
            except ConfigError as exc:
                raise ConfigError(f"{wpath}.{exc.field}", _message(exc)) from None
            key_map["path"] = "waypoints"
    elif kind == "rotate":
        kw["rate"] = _get(t, "rate", path, _number)
    elif kind in ("force", "moment"):
        shape = (3,) if kind == "force" else ()
        has_c, has_r = kind in t, "ramp" in t
        if has_c == has_r:
            raise ConfigError(f"{path}.{kind}", f"give exactly one of '{kind}' (constant) or 'ramp'")
        if has_c:
            value = _vec3(t[kind], f"{path}.{kind}") if shape else _number(t[kind], f"{path}.{kind}")
            key_map[""] = kind
        else:
            value = _ramp(t["ramp"], f"{path}.ramp", start, shape)
            key_map[""] = "ramp"
        kw[kind] = value
    return _BCSpec(i, kind, name, kw, key_map)


def _resolve_releases(specs: list[_BCSpec]) -> list[_BCSpec]:
    """Fold ``release`` entries into the ``stop`` of the group they release."""
    groups: dict[str, _BCSpec] = {}
    for s in specs:
        if s.kind == "release":
            continue
        if s.name in groups:
            raise ConfigError(f"bc[{s.index}].name",
                              f"duplicate name {s.name!r} (also used by bc[{groups[s.name].index}])")
        groups[s.name] = s
    released: dict[str, int] = {}
    for s in specs:
        if s.kind != "release":
            continue
        where = f"bc[{s.index}]"
        if s.name not in groups:
            raise ConfigError(f"{where}.name", f"no boundary condition named {s.name!r} to release; "
                                               f"known: {sorted(groups)}")
        if s.name in released:
            raise ConfigError(f"{where}.name", f"{s.name!r} is already released by bc[{released[s.name]}]")
        g = groups[s.name]
        at = s.kwargs["at"]
        if g.kwargs["stop"] is not None:
            raise ConfigError(f"{where}.at", f"{s.name!r} already has stop = {g.kwargs['stop']} s; "
                                             "give either a stop time or a release")
        if at <= g.kwargs["start"]:
            raise ConfigError(f"{where}.at",
                              f"release time {at} s is not after the start {g.kwargs['start']} s of {s.name!r}")
        g.kwargs["stop"] = at
        released[s.name] = s.index
    return [s for s in specs if s.kind != "release"]


def _apply_bc(bcs: BoundaryConditions, s: _BCSpec) -> None:
    method = getattr(bcs, s.kind)
    try:
        method(s.name, **s.kwargs)
    except ConfigError as exc:
        prefix = f"bc.{s.name}"
        fld = exc.field
        if fld == prefix:
            rest = ""
        elif fld.startswith(prefix + "."):
            rest = fld[len(prefix) + 1:]
        else:
            rest = fld
        rest = s.key_map.get(rest, rest)
        raise ConfigError(f"bc[{s.index}]" + (f".{rest}" if rest else ""), _message(exc)) from None


def _bcs_builder(specs: list[_BCSpec]) -> Callable[[Model], BoundaryConditions]:
    def build(model: Model) -> BoundaryConditions:
        bcs = BoundaryConditions(model)
        for s in specs:
            _apply_bc(bcs, s)
        return bcs

    return build


# ---------------------------------------------------------------------------------------- solver
def _parse_solver(t) -> SolverSettings:
    t = _table(t, "solver")
    fields = {f.name: f for f in dataclasses.fields(SolverSettings)}
    _check_keys(t, "solver", list(fields))
    hints = typing.get_type_hints(SolverSettings)
    kw = {}
    for key, value in t.items():
        hint = hints[key]
        path = f"solver.{key}"
        args = set(typing.get_args(hint)) or {hint}
        if bool in args:
            kw[key] = _boolean(value, path)
        elif int in args:
            kw[key] = _integer(value, path)
        elif float in args:
            kw[key] = _number(value, path)
        elif str in args:
            kw[key] = _string(value, path)
        else:  # pragma: no cover - a new field of an unexpected type
            kw[key] = value
    settings = SolverSettings(**kw)
    settings.validate()
    return settings


# ---------------------------------------------------------------------------------------- contact
def _contact_hook():
    """``knotsim.contact.model.contact_from_config`` if this version has it, else ``None``."""
    try:
        spec = importlib.util.find_spec("knotsim.contact.model")
    except ModuleNotFoundError:
        return None
    if spec is None:
        return None
    return getattr(importlib.import_module("knotsim.contact.model"), "contact_from_config", None)


def contact_interactions(model: Model, table: dict | None) -> list:
    """Interactions (contact, friction) described by a ``[contact]`` table; ``[]`` without one.

    The table is handed to ``knotsim.contact.model.contact_from_config(model, table)``, which
    checks its keys; without that function a ``[contact]`` table raises :class:`ConfigError`.
    """
    if table is None:
        return []
    hook = _contact_hook()
    if hook is None:
        raise ConfigError("contact", "contact is not available in this version")
    out = hook(model, table)
    if out is None:
        return []
    if isinstance(out, list | tuple):
        return list(out)
    return [out]


# ---------------------------------------------------------------------------------------- entry points
def load_config(source, *, base_dir=None, duration: float | None = None) -> RunConfig:
    """Read and check a run description.

    Parameters
    ----------
    source:
        Path of a TOML file, or a dict with the same structure.
    base_dir:
        Directory that relative file names (``rods[i].file``) are resolved against. Default: the
        TOML file's directory, or the current directory for a dict.
    duration:
        Overrides ``run.duration`` (s); the override is recorded in :attr:`RunConfig.raw`.

    Raises
    ------
    ConfigError
        Naming the full key path of the first bad value.
    """
    if isinstance(source, dict):
        raw = copy.deepcopy(source)
        bdir = Path(base_dir) if base_dir is not None else Path.cwd()
    elif isinstance(source, str | os.PathLike):
        fpath = Path(source)
        if not fpath.is_file():
            raise ConfigError("config", f"file not found: {str(fpath)!r}")
        try:
            with open(fpath, "rb") as fh:
                raw = tomllib.load(fh)
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError("config", f"{str(fpath)!r} is not valid TOML: {exc}") from None
        except UnicodeDecodeError as exc:
            raise ConfigError("config", f"{str(fpath)!r} is not valid TOML: {exc}") from None
        bdir = Path(base_dir) if base_dir is not None else fpath.resolve().parent
    else:
        raise ConfigError("config", f"expected a TOML file path or a dict, got {_type_name(source)}")

    if duration is not None:
        run = raw.setdefault("run", {})
        if isinstance(run, dict):
            run["duration"] = duration

    _check_keys(raw, "", _TOP_KEYS)
    if "description" in raw:
        _string(raw["description"], "description")

    rods_raw = raw.get("rods")
    if rods_raw is None:
        raise ConfigError("rods", "missing required field: add at least one [[rods]] table")
    if not isinstance(rods_raw, list) or not rods_raw:
        raise ConfigError("rods", "expected an array of tables [[rods]] with at least one rod")
    rods = [_parse_rod(t, i, bdir) for i, t in enumerate(rods_raw)]

    mt = _table(raw.get("model", {}), "model")
    _check_keys(mt, "model", _MODEL_KEYS)
    gravity = _get(mt, "gravity", "model", _vec3, np.zeros(3))
    damping = _get(mt, "damping", "model", _number, 0.0, nonneg=True)
    try:
        model = Model(rods, gravity=gravity, damping=damping)
    except ConfigError as exc:
        fld = exc.field if exc.field.startswith("rods") else f"model.{exc.field}"
        raise ConfigError(fld, _message(exc)) from None

    bc_raw = raw.get("bc", [])
    if not isinstance(bc_raw, list):
        raise ConfigError("bc", "expected an array of tables [[bc]]")
    specs = _resolve_releases([_parse_bc(t, i) for i, t in enumerate(bc_raw)])
    builder = _bcs_builder(specs)
    builder(model)  # check node ranges, overlaps, path starts now rather than at run time

    solver = _parse_solver(raw.get("solver", {}))

    rt = raw.get("run")
    if rt is None:
        raise ConfigError("run.duration", "missing required field: add a [run] table with duration (s)")
    rt = _table(rt, "run")
    _check_keys(rt, "run", _RUN_KEYS)
    dur = _get(rt, "duration", "run", _number, positive=True)
    interval = _get(rt, "output_interval", "run", _number, None, positive=True)

    contact = raw.get("contact")
    if contact is not None:
        _table(contact, "contact")
        if _contact_hook() is None:
            raise ConfigError("contact", "contact is not available in this version")

    return RunConfig(model=model, bcs_builder=builder, solver=solver, duration=dur, output_interval=interval,
                     raw=raw, contact=contact, base_dir=bdir)


def build_simulation(config):
    """A :class:`~knotsim.simulation.Simulation` ready to run ``config`` (a :class:`RunConfig`,
    a TOML path or a dict); ``sim.config`` holds the raw configuration for ``run.json``."""
    from knotsim.simulation import Simulation

    if not isinstance(config, RunConfig):
        config = load_config(config)
    interactions = contact_interactions(config.model, config.contact)
    sim = Simulation(config.model, config.build_bcs(), dataclasses.replace(config.solver),
                     interactions=interactions)
    sim.config = copy.deepcopy(config.raw)
    return sim
