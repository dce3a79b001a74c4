"""``[[obstacles]]`` tables of a run file: rigid planes, capsules and spheres in frictional contact
with the rods (:mod:`knotsim.contact.obstacles`; every key in ``docs/run-files.md``)."""

from __future__ import annotations

from collections.abc import Callable

from knotsim._util.fields import as_table, as_vec3, check_keys, error_message, get_field
from knotsim._util.validate import as_number, as_string
from knotsim.errors import ConfigError

_COMMON = ("type", "name", "rods", "mu", "delta", "nu", "stiffness", "stiffness_scaler", "penetration_limit",
           "velocity", "waypoints", "angular_velocity", "pivot", "friction_model", "stick_distance", "mu_static")
_SPIN = ("spin_inertia", "initial_spin")
_GEOMETRY = {"plane": ("point", "normal"), "capsule": ("a", "b", "radius") + _SPIN,
             "sphere": ("center", "radius", "spin_axis") + _SPIN}
_NUMBERS = ("mu", "delta", "nu", "stiffness", "stiffness_scaler", "penetration_limit", "radius", "spin_inertia",
            "stick_distance", "mu_static")
_VECTORS = ("point", "normal", "a", "b", "center", "angular_velocity", "pivot", "spin_axis", "initial_spin")
#: Names an obstacle may not take (interactions and log columns of their own).
_RESERVED = ("contact", "elastic", "kinetic", "gravity", "time", "dt")


def parse_obstacle(t, i: int) -> tuple[str, str, dict]:
    """One ``[[obstacles]]`` table: ``(type, name, keyword arguments of its class)``."""
    from knotsim.io.config.bc import parse_waypoints

    path = f"obstacles[{i}]"
    t = as_table(t, path)
    if "type" not in t:
        raise ConfigError(f"{path}.type", f"missing required field: one of {', '.join(_GEOMETRY)}")
    kind = get_field(t, "type", path, as_string)
    if kind not in _GEOMETRY:
        raise ConfigError(f"{path}.type", f"unknown obstacle type {kind!r}; expected one of {', '.join(_GEOMETRY)}")
    own = _COMMON + _GEOMETRY[kind]
    elsewhere = {k: f"not used by type '{kind}'" for keys in _GEOMETRY.values() for k in keys if k not in own}
    check_keys(t, path, own, elsewhere)
    name = get_field(t, "name", path, as_string, f"{kind}{i}")
    if not name or name in _RESERVED:
        raise ConfigError(f"{path}.name", f"must be a non-empty name other than {', '.join(_RESERVED)}, got {name!r}")
    kw: dict = {}
    for key in _NUMBERS:
        if key in t:
            kw[key] = as_number(t[key], f"{path}.{key}")
    for key in _VECTORS:
        if key in t:
            kw[key] = as_vec3(t[key], f"{path}.{key}")
    if "friction_model" in t:
        kw["friction_model"] = get_field(t, "friction_model", path, as_string)
    if "velocity" in t and "waypoints" in t:
        raise ConfigError(f"{path}.velocity", "give at most one of 'velocity' or 'waypoints'")
    if "velocity" in t:
        kw["path"] = as_vec3(t["velocity"], f"{path}.velocity")
    elif "waypoints" in t:
        kw["path"] = parse_waypoints(t["waypoints"], f"{path}.waypoints")
    if "rods" in t:
        rods = t["rods"]
        rods = rods if isinstance(rods, list) else [rods]
        for j, r in enumerate(rods):
            if not (isinstance(r, str) or (isinstance(r, int) and not isinstance(r, bool))):
                raise ConfigError(f"{path}.rods[{j}]", f"expected a rod name or index, got {r!r}")
        kw["rods"] = rods
    return kind, name, kw


def obstacles_builder(raw) -> Callable:
    """Check the ``[[obstacles]]`` array and return ``build(model) -> [Obstacle, ...]`` (fresh
    obstacles each call: they keep their stiffness memory while running)."""
    from knotsim.contact.obstacles import Capsule, Plane, Sphere

    if not isinstance(raw, list):
        raise ConfigError("obstacles", "expected an array of tables [[obstacles]]")
    specs = [parse_obstacle(t, i) for i, t in enumerate(raw)]
    seen: dict[str, int] = {}
    for i, (_, name, _) in enumerate(specs):
        if name in seen:
            raise ConfigError(f"obstacles[{i}].name", f"duplicate name {name!r} (also used by obstacles[{seen[name]}])")
        seen[name] = i
    classes = {"plane": Plane, "capsule": Capsule, "sphere": Sphere}

    def build(model) -> list:
        out = []
        for i, (kind, name, kw) in enumerate(specs):
            try:
                out.append(classes[kind](model, name, **kw))
            except ConfigError as exc:
                prefix = f"obstacles.{name}"
                fld = exc.field
                rest = fld[len(prefix) + 1:] if fld.startswith(prefix + ".") else fld
                if rest == "path":
                    rest = "velocity" if "velocity" in raw[i] else "waypoints"
                raise ConfigError(f"obstacles[{i}].{rest}", error_message(exc)) from None
        return out

    build.names = list(seen)
    return build


__all__ = ["obstacles_builder", "parse_obstacle"]
