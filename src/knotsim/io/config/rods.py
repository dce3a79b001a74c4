"""``[[rods]]`` tables of a run file: the shape a rod starts in (from a formula, a list of points,
a node file, a library knot or a frame of an earlier run), its material and its rest shape.

Shapes (``shape = ...``) and their keys:

- ``"straight"``: ``length`` (m), ``n_nodes``, ``start`` (m), ``direction``;
- ``"helix"``: ``helix_radius`` (m), ``pitch`` (m per turn), ``turns``, ``n_nodes``, ``start``, ``axis``;
- ``"circle"`` (a closed ring): ``ring_radius`` (m), ``n_nodes``, ``center`` (m), ``normal``;
- ``"points"``: ``positions = [[x, y, z], ...]`` (m) or ``file`` (text ``x y z [...]`` columns,
  ``.csv``, ``.npy``, MATLAB ``.mat`` with ``matrix = "A"``; layouts in :mod:`knotsim.io.geometry`),
  relative to the run file; ``rope`` (index or name) picks one rope of a file that holds several
  (blank-line separated blocks of a text file, or the rope matrices of a .mat file); ``scale``
  multiplies the positions (default 1);
- ``"knot"``: ``knot`` (a library name or a drawing file), ``rope`` (index or name, default 0),
  optional ``n_nodes`` and ``length`` (m; default the drawing's); built at this rod's ``radius``;
- ``"run"``: ``run`` (an earlier run's output directory), ``frame`` (default -1, the last: its
  checkpoint), ``rod`` (name or index, default this rod's index); the rod starts with that frame's
  positions, velocities and material frames (``continue_motion = false``: from rest, untwisted).

Every rod takes its material as ``youngs_modulus`` (Pa), ``density`` (kg/m^3) and ``poisson_ratio`` or
``shear_modulus`` (Pa), and may set ``bending_stiffness`` (EI) and ``torsional_stiffness`` (GJ), N m^2,
independently of the axial stiffness ``E pi h^2`` (a fibrous rope; default: the solid rod's).

Every rod also takes ``velocities`` ``(N, 3)`` m/s, ``edge_angles`` (rad) and
``reference_directors`` ``(n_edges, 3)`` explicitly (a saved run file uses them).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from knotsim._util.fields import (
    as_numbers,
    as_points,
    as_table,
    as_unit,
    as_vec3,
    check_keys,
    error_message,
    get_field,
)
from knotsim._util.validate import as_bool, as_integer, as_number, as_string
from knotsim.errors import ConfigError
from knotsim.rods import RodSpec

_ROD_COMMON = ("name", "shape", "radius", "youngs_modulus", "density", "poisson_ratio", "shear_modulus",
               "bending_stiffness", "torsional_stiffness", "closed", "natural_curvature", "natural_twist", "rest_edge_length", "velocities", "edge_angles",
               "reference_directors")
_ROD_SHAPES = {
    "straight": ("length", "n_nodes", "start", "direction"),
    "helix": ("helix_radius", "pitch", "turns", "n_nodes", "start", "axis"),
    "circle": ("ring_radius", "n_nodes", "center", "normal"),
    "points": ("positions", "file", "matrix", "rope", "scale"),
    "knot": ("knot", "rope", "n_nodes", "length"),
    "run": ("run", "frame", "rod", "continue_motion"),
}


def _perpendicular_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``e1, e2`` with ``(e1, e2, axis)`` right handed (``e1 = x`` for ``axis = z``)."""
    ref = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - np.dot(ref, axis) * axis
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)



def _rod_positions(t: dict, path: str, shape: str, base_dir: Path) -> np.ndarray:
    if shape == "straight":
        length = get_field(t, "length", path, as_number, positive=True)
        n = get_field(t, "n_nodes", path, as_integer, minimum=2)
        start = get_field(t, "start", path, as_vec3, np.zeros(3))
        direction = get_field(t, "direction", path, as_unit, np.array([1.0, 0.0, 0.0]))
        s = np.linspace(0.0, length, n)
        return start[None, :] + s[:, None] * direction[None, :]
    if shape == "helix":
        radius = get_field(t, "helix_radius", path, as_number, positive=True)
        pitch = get_field(t, "pitch", path, as_number)
        turns = get_field(t, "turns", path, as_number, positive=True)
        n = get_field(t, "n_nodes", path, as_integer, minimum=2)
        start = get_field(t, "start", path, as_vec3, np.zeros(3))
        axis = get_field(t, "axis", path, as_unit, np.array([0.0, 0.0, 1.0]))
        e1, e2 = _perpendicular_basis(axis)
        phi = np.linspace(0.0, 2.0 * math.pi * turns, n)
        return (start[None, :] + radius * np.cos(phi)[:, None] * e1 + radius * np.sin(phi)[:, None] * e2
                + (pitch * phi / (2.0 * math.pi))[:, None] * axis)
    if shape == "circle":
        radius = get_field(t, "ring_radius", path, as_number, positive=True)
        n = get_field(t, "n_nodes", path, as_integer, minimum=3)
        center = get_field(t, "center", path, as_vec3, np.zeros(3))
        normal = get_field(t, "normal", path, as_unit, np.array([0.0, 0.0, 1.0]))
        e1, e2 = _perpendicular_basis(normal)
        phi = 2.0 * math.pi * np.arange(n) / n
        return center[None, :] + radius * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    # points
    has_pos, has_file = "positions" in t, "file" in t
    if has_pos == has_file:
        raise ConfigError(f"{path}.positions", "give exactly one of 'positions' or 'file' for shape 'points'")
    if has_pos:
        return as_points(t["positions"], f"{path}.positions") * get_field(t, "scale", path, as_number, 1.0,
                                                                          positive=True)
    return _file_positions(t, path, base_dir)


def _resolve(name: str, base_dir: Path) -> Path:
    f = Path(name).expanduser()
    return f if f.is_absolute() else base_dir / f


def _file_positions(t: dict, path: str, base_dir: Path) -> np.ndarray:
    """Positions (m) of shape 'points' from ``file`` (text, .csv, .npy, .mat; see
    :func:`knotsim.io.geometry.read_node_ropes`); ``matrix`` names a .mat matrix, ``rope`` (index
    or name) picks one rope of a file with several, ``scale`` multiplies."""
    from knotsim.io.geometry import read_node_ropes

    f = _resolve(as_string(t["file"], f"{path}.file"), base_dir)
    matrix = get_field(t, "matrix", path, as_string, None)
    scale = get_field(t, "scale", path, as_number, 1.0, positive=True)
    if matrix is not None and "rope" in t:
        raise ConfigError(f"{path}.rope", "give matrix or rope, not both")
    nodes = read_node_ropes(f, matrices=[matrix] if matrix else None, scale=scale, field=f"{path}.file",
                            choose='name the one for this rod with matrix = "A"')
    if "rope" in t:
        rope = t["rope"]
        if isinstance(rope, str):
            if rope not in nodes.names:
                raise ConfigError(f"{path}.rope", f"{str(f)!r} has no rope {rope!r}; {nodes.describe()}")
            return nodes.ropes[nodes.names.index(rope)]
        k = as_integer(rope, f"{path}.rope", minimum=0)
        if k >= len(nodes.ropes):
            raise ConfigError(f"{path}.rope", f"rope = {k} is out of range: {nodes.describe()}")
        return nodes.ropes[k]
    if len(nodes.ropes) != 1:
        raise ConfigError(f"{path}.file", f"{nodes.describe()}; pick the one for this rod with rope = NAME or "
                                          "INDEX (one [[rods]] table per rope)")
    return nodes.ropes[0]


def _knot_positions(t: dict, path: str, radius: float) -> tuple[np.ndarray, dict]:
    """Positions (m) of shape 'knot': rope ``rope`` of the library drawing ``knot`` built at this
    rod's radius with the drawing's own ``n_nodes`` and ``length`` unless given."""
    from knotsim.knots.library import get_knot

    name = get_field(t, "knot", path, as_string)
    kw = {"radius": radius}
    if "n_nodes" in t:
        kw["n_nodes"] = get_field(t, "n_nodes", path, as_integer, minimum=2)
    if "length" in t:
        kw["length"] = get_field(t, "length", path, as_number, positive=True)
    try:
        geo = get_knot(name, **kw)
    except ConfigError as exc:
        raise ConfigError(f"{path}.knot", error_message(exc)) from None
    rope = t.get("rope", 0)
    names = list(geo.rope_names)
    if isinstance(rope, str):
        if rope not in names:
            raise ConfigError(f"{path}.rope", f"knot {name!r} has no rope {rope!r}; its ropes are {names}")
        rope = names.index(rope)
    rope = as_integer(rope, f"{path}.rope", minimum=0)
    if rope >= len(geo.ropes):
        raise ConfigError(f"{path}.rope", f"knot {name!r} has {len(geo.ropes)} rope(s), got rope = {rope}")
    return np.array(geo.ropes[rope], float), {}


def _run_frame(t: dict, path: str, index: int, base_dir: Path):
    """The :class:`~knotsim.io.geometry.RodFrame` of shape 'run': rod ``rod`` (name or index,
    default this rod's index) at ``frame`` (default -1, the last) of the run directory ``run``."""
    from knotsim.io.geometry import read_run_frame

    d = _resolve(get_field(t, "run", path, as_string), base_dir)
    frame = get_field(t, "frame", path, as_integer, -1)
    frames = read_run_frame(d, frame, field=f"{path}.run")
    rod = t.get("rod", index)
    if isinstance(rod, str):
        names = [f.name for f in frames]
        if rod not in names:
            raise ConfigError(f"{path}.rod", f"run {str(d)!r} has no rod {rod!r}; its rods are {names}")
        rod = names.index(rod)
    rod = as_integer(rod, f"{path}.rod", minimum=0)
    if rod >= len(frames):
        raise ConfigError(f"{path}.rod", f"run {str(d)!r} has {len(frames)} rod(s), got rod = {rod}")
    return frames[rod]


def parse_rod(t, i: int, base_dir: Path) -> RodSpec:
    path = f"rods[{i}]"
    t = as_table(t, path)
    if "shape" not in t:
        check_keys(t, path, sorted(set(_ROD_COMMON).union(*_ROD_SHAPES.values())))
    shape = get_field(t, "shape", path, as_string)
    if shape not in _ROD_SHAPES:
        raise ConfigError(f"{path}.shape", f"unknown shape {shape!r}; expected one of {', '.join(_ROD_SHAPES)}")
    own = _ROD_COMMON + _ROD_SHAPES[shape]
    elsewhere = {k: f"it belongs to shape '{s}', this rod has shape '{shape}'"
                 for s, keys in _ROD_SHAPES.items() for k in keys if k not in own}
    check_keys(t, path, own, elsewhere)
    radius = get_field(t, "radius", path, as_number, positive=True)
    frame = None
    if shape == "knot":
        positions, _ = _knot_positions(t, path, radius)
    elif shape == "run":
        frame = _run_frame(t, path, i, base_dir)
        positions = frame.positions
    else:
        positions = _rod_positions(t, path, shape, base_dir)

    closed = get_field(t, "closed", path, as_bool, shape == "circle" or (frame is not None and frame.closed))
    if shape == "circle" and not closed:
        raise ConfigError(f"{path}.closed", "a circle is a closed ring; use shape 'points' for an open arc")
    kw = {
        "positions": positions,
        "radius": radius,
        "youngs_modulus": get_field(t, "youngs_modulus", path, as_number, positive=True),
        "density": get_field(t, "density", path, as_number, positive=True),
        "closed": closed,
        "name": get_field(t, "name", path, as_string, ""),
    }
    if "poisson_ratio" in t and "shear_modulus" in t:
        raise ConfigError(f"{path}.shear_modulus", "give either poisson_ratio or shear_modulus, not both")
    if "poisson_ratio" in t:
        kw["poisson_ratio"] = get_field(t, "poisson_ratio", path, as_number)
    if "shear_modulus" in t:
        kw["shear_modulus"] = get_field(t, "shear_modulus", path, as_number, positive=True)
    for key in ("bending_stiffness", "torsional_stiffness"):  # EI, GJ in N m^2 (default: the solid rod's)
        if key in t:
            kw[key] = get_field(t, key, path, as_number, positive=True)
    if "natural_curvature" in t:
        kw["natural_curvature"] = as_numbers(t["natural_curvature"], f"{path}.natural_curvature")
    if "natural_twist" in t:
        kw["natural_twist"] = as_numbers(t["natural_twist"], f"{path}.natural_twist")
    if "rest_edge_length" in t:
        kw["rest_edge_lengths"] = as_numbers(t["rest_edge_length"], f"{path}.rest_edge_length")
    if frame is not None and get_field(t, "continue_motion", path, as_bool, True):
        # the run goes on physically: velocities and material frames come with the positions
        kw["velocities"] = frame.velocities
        if frame.reference_directors is not None:
            kw["reference_directors"] = frame.reference_directors
            kw["edge_angles"] = frame.edge_angles
    if frame is not None and frame.rest_edge_lengths is not None and "rest_edge_length" not in t:
        kw["rest_edge_lengths"] = frame.rest_edge_lengths  # the same rope: its rest shape carries over
    for key in ("velocities", "edge_angles", "reference_directors"):
        if key in t:
            kw[key] = as_numbers(t[key], f"{path}.{key}")
    spec = RodSpec(**kw)
    # RodSpec names its own fields (rest_edge_lengths); validate here so the key path matches the TOML.
    try:
        spec.validate(where=path)
    except ConfigError as exc:
        fld = exc.field.replace(f"{path}.rest_edge_lengths", f"{path}.rest_edge_length")
        raise ConfigError(fld, error_message(exc)) from None
    return spec
