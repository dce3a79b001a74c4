"""The starting geometry of a protocol run, from any source: a library knot (name or drawing file),
a node file (text ``x y z [theta]``, ``.csv``, ``.npy``, ``.mat``) or an earlier run's directory.

Every protocol sees the same record, :class:`ProtocolGeometry`: the ropes' node positions, their
names, radius and length, and the loading hints (which rope ends are held and pulled; from the
drawing, or given by the protocol's parameters, or the rope ends by default). A frame of an earlier
run also brings its velocities and material frames, so the run continues physically.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from knotsim.errors import ConfigError, GeometryError

__all__ = ["ProtocolGeometry", "geometry_from_library", "geometry_from_source", "is_library_knot"]


@dataclass(frozen=True)
class EndRef:
    """A node of the geometry: rope index and node index (``node`` >= 0)."""

    rope: int
    node: int


@dataclass
class ProtocolGeometry:
    """Geometry handed to a protocol.

    ``ropes``: one ``(N, 3)`` array per rope (m); ``rope_names``; ``radius`` h (m); ``length``: arc
    length of the first rope (m); ``held`` / ``pulled``: :class:`EndRef` loading hints;
    ``name`` and ``kind`` (the drawing's, or ``"nodes"`` / ``"run"``); ``source``: where it came from;
    ``state``: per rope ``{"velocities", "edge_angles", "reference_directors"}`` arrays for a run
    frame, else empty; ``protocol_hint``: the protocol that produced a run frame (from its
    ``run.toml``), else ``None``; ``contact_stiffness``: the adaptive contact stiffness k_c (N/m)
    a run frame's ``checkpoint.npz`` ended with, else ``None``; ``found``: what a ``.mat`` node
    file holds (every matrix and its shape, :attr:`knotsim.io.geometry.NodeRopes.found`), else ``""``.
    """

    name: str
    kind: str
    ropes: list[np.ndarray]
    rope_names: list[str]
    radius: float
    length: float
    held: tuple = ()
    pulled: tuple = ()
    source: str = ""
    state: list[dict] = field(default_factory=list)
    protocol_hint: str | None = None
    knot_hint: str | None = None
    contact_stiffness: float | None = None
    found: str = ""
    post: Any = None

    def describe_ropes(self) -> str:
        """``"2 ropes in 'F.mat' (A: 125 nodes, B: 91 nodes)"``: how many ropes, where from, their
        names and node counts (and, for a .mat file, every matrix it holds)."""
        n = len(self.ropes)
        names = ", ".join(f"{a}: {len(x)} nodes" for a, x in zip(self.rope_names, self.ropes, strict=True))
        where = self.source or self.name
        held = f"; the file holds {self.found}" if self.found else ""
        return f"{n} rope{'s' if n != 1 else ''} in {where!r} ({names}){held}"


def is_library_knot(name: str) -> bool:
    """Whether ``name`` is a library knot name or a drawing (``.toml``) file."""
    from knotsim.knots.library import list_knots

    return name in {n for n, _ in list_knots()} or str(name).endswith(".toml")


def geometry_from_library(knot: str, *, n_nodes=None, radius=None, length=None, post_radius=None) -> ProtocolGeometry:
    """The library drawing ``knot`` built at the given resolution (defaults: the drawing's)."""
    from knotsim.knots.library import get_knot

    geo = get_knot(knot, n_nodes=n_nodes, radius=radius, length=length, post_radius=post_radius)
    return ProtocolGeometry(name=geo.name, kind=geo.kind, ropes=[np.array(x, float) for x in geo.ropes],
                            rope_names=list(geo.rope_names), radius=float(geo.radius), length=float(geo.length),
                            held=tuple(EndRef(h.rope, h.node) for h in geo.held),
                            pulled=tuple(EndRef(p.rope, p.node) for p in geo.pulled), source=str(knot),
                            post=geo.post)


def _arc_length(x: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(x, axis=0), axis=1)))


#: How a protocol's user chooses the matrices of a .mat node file (said in error messages).
CHOOSE_MATRICES = "choose the ropes with --matrices A,B (or the parameter geometry_matrices = \"A,B\")"


def parse_matrices(value) -> list[str] | None:
    """The ``geometry_matrices`` parameter as a list of names (``"A,B"`` or ``["A", "B"]``), ``None``
    when empty. Raises :class:`ConfigError` for an empty name."""
    if value is None or value == "" or (isinstance(value, list | tuple) and not value):
        return None
    items = value.split(",") if isinstance(value, str) else list(value) if isinstance(value, list | tuple) else [value]
    if not all(isinstance(v, str) and v.strip() for v in items):
        raise ConfigError("geometry_matrices", f"expected matrix names separated by commas, e.g. \"A,B\", got {value!r}")
    return [v.strip() for v in items]


def geometry_from_source(path: str, *, radius: float | None, scale: float = 1.0,
                         matrices: list[str] | None = None) -> ProtocolGeometry:
    """Geometry from a node file or an earlier run's directory.

    ``radius`` (m) is the rod radius for a node file (a run directory brings its own); ``matrices``
    names the ropes of a ``.mat`` file (:func:`knotsim.io.geometry.read_node_ropes`; the ropes are
    named after their matrices). Raises :class:`ConfigError` for a missing or unreadable source or
    an ambiguous ``.mat`` file (listing its matrices), :class:`GeometryError` for zero-length edges."""
    from knotsim.io.geometry import is_run_directory, read_node_ropes, read_run_frame

    p = Path(path)
    if matrices and (is_run_directory(p) or p.suffix.lower() != ".mat"):
        raise ConfigError("geometry_matrices", f"names the matrices of a .mat node file; {str(p)!r} is not one")
    if is_run_directory(p):
        if scale != 1.0:
            raise ConfigError("geometry_scale", f"{str(p)!r} is a run directory, already in m; geometry_scale must be 1")
        if _run_file(p).get("obstacles"):
            raise ConfigError("geometry", f"{str(p)!r} is a run with rigid obstacles (a hitch's or a loop's post): "
                                          "continuing it with --geometry would lose them; run the library knot again "
                                          "instead (knotsim pull KNOT)")
        frames = read_run_frame(p, -1, field="geometry")
        ropes = [f.positions for f in frames]
        state = [{"velocities": f.velocities, "edge_angles": f.edge_angles,
                  "reference_directors": f.reference_directors, "rest_edge_length": f.rest_edge_lengths}
                 for f in frames]
        hint, knot_hint = _provenance(p)
        geo = ProtocolGeometry(name=f"{p.name} (t = {frames[0].time:.4g} s)", kind="run", ropes=ropes,
                               rope_names=[f.name for f in frames], radius=float(frames[0].radius),
                               length=(float(np.sum(frames[0].rest_edge_lengths))
                                       if frames[0].rest_edge_lengths is not None else _arc_length(ropes[0])),
                               source=str(p), state=state, protocol_hint=hint,
                               knot_hint=knot_hint, held=_tie_hold(p, len(ropes[0])),
                               contact_stiffness=_contact_stiffness(p))
    else:
        if not p.exists():
            raise ConfigError("geometry", f"no such node file or run directory: {str(p)!r}")
        if p.is_dir():
            raise ConfigError("geometry", f"{str(p)!r} is a directory but not a knotsim run (no checkpoint.npz "
                                          "or trajectory.h5)")
        if radius is None:
            raise ConfigError("radius", "a node file needs the rod radius (--set radius=...)")
        nodes = read_node_ropes(p, matrices=matrices, scale=scale, field="geometry", choose=CHOOSE_MATRICES)
        geo = ProtocolGeometry(name=p.name, kind="nodes", ropes=nodes.ropes, rope_names=nodes.names,
                               radius=float(radius), length=_arc_length(nodes.ropes[0]), source=str(p),
                               found=nodes.found if p.suffix.lower() == ".mat" else "")
    check_edges(geo)
    return geo


def _contact_stiffness(run_dir: Path) -> float | None:
    """The adaptive contact stiffness k_c (N/m) in a run directory's ``checkpoint.npz``, else ``None``."""
    f = run_dir / "checkpoint.npz"
    if not f.is_file():
        return None
    from knotsim.io.checkpoint import read_checkpoint

    try:
        k = read_checkpoint(f).section("interaction/contact")[0].get("k_c")
    except (ConfigError, OSError, ValueError, KeyError):
        return None
    return float(k) if isinstance(k, int | float) and math.isfinite(k) and k > 0 else None


def _tie_hold(run_dir: Path, n_nodes: int) -> tuple:
    """The hold hint of a tied reef or granny: ``hold_node`` of the tie's ``summary.json`` (the
    bottom of the first knot's loop, see :func:`knotsim.knots.tying.half_knot_gap`), else ``()``."""
    import json

    f = run_dir / "summary.json"
    try:
        node = json.loads(f.read_text(encoding="utf-8")).get("hold_node") if f.is_file() else None
    except (OSError, ValueError, AttributeError):
        return ()
    if isinstance(node, int) and 0 <= node < n_nodes:
        return (EndRef(0, node),)
    return ()


def _provenance(run_dir: Path) -> tuple[str | None, str | None]:
    """Protocol and knot recorded in a run directory's ``run.toml`` (``None`` when absent)."""
    prov = _run_file(run_dir).get("provenance", {})
    return prov.get("protocol"), prov.get("knot")


def _run_file(run_dir: Path) -> dict:
    f = run_dir / "run.toml"
    if not f.is_file():
        return {}
    from knotsim._util.toml import load_toml

    try:
        return load_toml(f)
    except ConfigError:
        return {}


#: material keys a run's rope keeps when a protocol continues it
MATERIAL_KEYS = ("youngs_modulus", "density", "poisson_ratio", "bending_stiffness", "torsional_stiffness")


def run_material(run_dir: str | Path) -> dict:
    """The first rod's material (``youngs_modulus`` Pa, ``density`` kg/m^3, ``poisson_ratio``, and
    ``bending_stiffness`` / ``torsional_stiffness`` N m^2 when it set them) in a run directory's
    ``run.toml``, or ``{}``: continuing a run keeps its rope."""
    rods = _run_file(Path(run_dir)).get("rods") or [{}]
    return {k: rods[0][k] for k in MATERIAL_KEYS if isinstance(rods[0], dict) and k in rods[0]}


def check_edges(geo: ProtocolGeometry) -> None:
    """Raise :class:`GeometryError` naming the rope and edge of a zero-length edge."""
    for r, x in enumerate(geo.ropes):
        lengths = np.linalg.norm(np.diff(x, axis=0), axis=1)
        k = int(np.argmin(lengths))
        if lengths[k] <= 1e-9 * max(geo.length, 1e-12):
            raise GeometryError(f"geometry {geo.name!r}: rope {geo.rope_names[r]!r} edge {k} (nodes {k}, {k + 1}) "
                                f"has zero length ({lengths[k]:.3g} m); remove duplicate nodes")


def default_ends(geo: ProtocolGeometry) -> tuple[tuple, tuple]:
    """Loading hints, or the rope ends when the geometry has none: one rope: first end held,
    last end pulled; two ropes: rope 0's first node held, rope 1's first node pulled (as in Patil
    et al. 2020)."""
    if geo.held or geo.pulled:
        return geo.held, geo.pulled
    if len(geo.ropes) == 1:
        return (EndRef(0, 0),), (EndRef(0, len(geo.ropes[0]) - 1),)
    return (EndRef(0, 0),), (EndRef(1, 0),)


def parse_end(text, geo: ProtocolGeometry, field: str) -> EndRef:
    """An end given as ``"ROPE:NODE"`` (rope index or name; node 0 or -1) as an :class:`EndRef`."""
    if not isinstance(text, str) or ":" not in text:
        raise ConfigError(field, f"expected ROPE:NODE, e.g. \"0:0\" or \"B:-1\", got {text!r}")
    rope_s, node_s = text.split(":", 1)
    if rope_s in geo.rope_names:
        rope = geo.rope_names.index(rope_s)
    else:
        try:
            rope = int(rope_s)
        except ValueError:
            raise ConfigError(field, f"unknown rope {rope_s!r}; ropes are {geo.rope_names}") from None
    if not 0 <= rope < len(geo.ropes):
        raise ConfigError(field, f"rope {rope} out of range: the geometry has {len(geo.ropes)} rope(s)")
    n = len(geo.ropes[rope])
    try:
        node = int(node_s)
    except ValueError:
        raise ConfigError(field, f"expected an end node 0 or -1, got {node_s!r}") from None
    node = node % n
    if node not in (0, n - 1):
        raise ConfigError(field, f"node {node_s} is not an end of rope {rope} (0 or -1)")
    return EndRef(rope, node)


def other_end(geo: ProtocolGeometry, end: EndRef) -> EndRef:
    """The far end of the rope of ``end``."""
    n = len(geo.ropes[end.rope])
    return EndRef(end.rope, n - 1 if end.node == 0 else 0)


def one_rope_ends(geo: ProtocolGeometry, held_end: str, pulled_end: str) -> tuple[EndRef, EndRef, bool]:
    """The two loaded ends of a one-rope protocol: ``(start, pulled, held)``.

    Default (both texts empty): the two ends of rope 0 are pulled apart, ``start`` its first node,
    ``pulled`` its last, ``held`` false. With ``held_end`` and/or ``pulled_end`` (``"ROPE:NODE"``,
    :func:`parse_end`) that end is held still (clamped) and the other pulled (``held`` true); the end
    not given is the far end of the same rope. Raises :class:`ConfigError` (field ``held_end`` /
    ``pulled_end``) for a bad end or when both name the same end."""
    if not held_end and not pulled_end:
        return EndRef(0, 0), EndRef(0, len(geo.ropes[0]) - 1), False
    held = parse_end(held_end, geo, "held_end") if held_end else None
    pulled = parse_end(pulled_end, geo, "pulled_end") if pulled_end else None
    held = held if held is not None else other_end(geo, pulled)
    pulled = pulled if pulled is not None else other_end(geo, held)
    if held == pulled:
        raise ConfigError("pulled_end", f"the held and the pulled end are the same node ({pulled_end!r}); "
                                        "give the two ends of the rope")
    if held.rope != pulled.rope:
        raise ConfigError("pulled_end", f"held_end {held_end!r} and pulled_end {pulled_end!r} are on different ropes; "
                                        "a one-rope protocol holds one end of the rope and pulls the other")
    return held, pulled, True
