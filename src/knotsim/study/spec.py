"""Study files: a base case plus sweep axes, expanded into fully resolved cases.

A study is a TOML file::

    name = "pull_E_speed"                 # optional, default: the file name
    description = "rod pulled from both ends"
    repeats = 1                           # optional: run every case this many times

    [base]                                # a complete knotsim run configuration (knotsim.io.config)
    [[base.rods]]
    shape = "straight"
    length = 0.1                          # m
    ...
    [base.run]
    duration = 0.2                        # s

    [grid]                                # cartesian product over every key
    "rods[0].youngs_modulus" = [1e6, 1e7] # Pa
    "bc[1].velocity" = [[1e-3, 0, 0], [2e-3, 0, 0]]   # m/s

    [[zip]]                               # lists of equal length, varied together (one axis)
    "solver.dt" = [1e-2, 5e-3]            # s
    "run.output_interval" = [1e-2, 5e-3]  # s

    [[cases]]                             # explicit cases (one axis; each a table of dotted keys)
    "model.damping" = 0.0
    [[cases]]
    "model.damping" = 0.1

Instead of an inline ``[base]`` table, ``base = "path/to/run.toml"`` names a run configuration
file (relative to the study file). A *protocol* case has ``protocol``, ``knot`` and
``overrides`` in its base instead of a run configuration::

    [base]
    protocol = "single-rod-bend"
    knot = "single_rod_reef"
    [base.overrides]
    mu = 0.1

    [grid]
    knot = ["single_rod_granny", "single_rod_reef"]
    "overrides.mu" = [0.1, 0.2, 0.3, 0.4, 0.5]

The cases are the product of: every ``grid`` key, every ``[[zip]]`` group, the ``[[cases]]``
list (when given), then ``repeats``. Keys are dotted paths into the base (``a.b[2].c``); missing
tables and keys are created, list indices must exist. A case is identified by a hash of its
fully resolved configuration (:attr:`Case.case_id`), so editing a study and resuming reuses every
case whose configuration did not change.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from knotsim._util.toml import dumps_toml, load_toml  # dumps_toml: re-exported (study files)
from knotsim._util.validate import number
from knotsim.errors import ConfigError

__all__ = ["Case", "Study", "case_hash", "dumps_toml", "expand", "load_study_spec", "parse_key", "set_key"]

_TOP_KEYS = ("name", "description", "repeats", "base", "grid", "zip", "cases")
_KEY_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]*|\[(-?\d+)\]|\.")


# ------------------------------------------------------------------------------------------ keys
def parse_key(key: str) -> list[str | int]:
    """Split a dotted key ``"bc[1].velocity[0]"`` into ``["bc", 1, "velocity", 0]``.

    Raises :class:`ConfigError` (field: the key) when the key is malformed.
    """
    if not isinstance(key, str) or not key:
        raise ConfigError(str(key), "a parameter key must be a non-empty string like 'rods[0].radius'")
    parts: list[str | int] = []
    pos = 0
    expect_name = True
    while pos < len(key):
        m = _KEY_RE.match(key, pos)
        if m is None:
            raise ConfigError(key, f"malformed parameter key at character {pos} ({key[pos:]!r})")
        tok = m.group(0)
        if tok == ".":
            if expect_name:
                raise ConfigError(key, "malformed parameter key: empty name around '.'")
            expect_name = True
        elif tok.startswith("["):
            if expect_name and parts:
                raise ConfigError(key, "malformed parameter key: '[' after '.'")
            if not parts:
                raise ConfigError(key, "malformed parameter key: it cannot start with an index")
            parts.append(int(m.group(1)))
            expect_name = False
        else:
            if not expect_name:
                raise ConfigError(key, f"malformed parameter key: missing '.' before {tok!r}")
            parts.append(tok)
            expect_name = False
        pos = m.end()
    if expect_name:
        raise ConfigError(key, "malformed parameter key: it ends with '.'")
    return parts


def set_key(tree: dict, key: str, value: Any) -> None:
    """Set ``value`` at dotted ``key`` inside ``tree`` (in place).

    Missing tables and keys are created; list indices (negative: from the end) must exist.
    Raises :class:`ConfigError` whose field is ``key`` otherwise.
    """
    parts = parse_key(key)
    node: Any = tree
    for i, p in enumerate(parts):
        last = i == len(parts) - 1
        where = key if last else _join(parts[: i + 1])
        if isinstance(p, int):
            if not isinstance(node, list):
                raise ConfigError(key, f"{_join(parts[:i])} is not a list, cannot index it with [{p}]")
            if not -len(node) <= p < len(node):
                raise ConfigError(key, f"index [{p}] out of range: {_join(parts[:i])} has {len(node)} entries")
            if last:
                node[p] = copy.deepcopy(value)
            else:
                node = node[p]
        else:
            if not isinstance(node, dict):
                raise ConfigError(key, f"{_join(parts[:i]) or 'the base'} is not a table, cannot set {p!r}")
            if last:
                node[p] = copy.deepcopy(value)
            else:
                if p not in node:
                    if isinstance(parts[i + 1], int):
                        raise ConfigError(key, f"{where} does not exist, so it cannot be indexed")
                    node[p] = {}
                node = node[p]


def _join(parts) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


# ------------------------------------------------------------------------------------------ cases
def _canonical(obj: Any) -> Any:
    """JSON-ready copy with integral floats kept as floats and tuples as lists."""
    if isinstance(obj, dict):
        return {str(k): _canonical(v) for k, v in sorted(obj.items())}
    if isinstance(obj, list | tuple):
        return [_canonical(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return repr(obj)
    if hasattr(obj, "item") and not isinstance(obj, str | bytes):
        return obj.item()
    return obj


def case_hash(kind: str, config: dict, repeat: int = 0) -> str:
    """Identifier of a case: 16 hex digits of the SHA-256 of its canonical resolved configuration."""
    payload = json.dumps({"kind": kind, "config": _canonical(config), "repeat": int(repeat)},
                         sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(payload.encode()).hexdigest()[:16]


@dataclass
class Case:
    """One fully resolved case of a study.

    - ``index``: position in the expansion order;
    - ``kind``: executor name (``"run"`` for a plain run, ``"protocol"`` for a protocol case);
    - ``params``: swept values of this case by dotted key (plus ``repeat`` when ``repeats > 1``);
    - ``config``: the resolved configuration given to the executor;
    - ``repeat``: repeat number (0 ...);
    - ``case_id``: hash of ``kind``, ``config`` and ``repeat``.
    """

    index: int
    kind: str
    params: dict[str, Any]
    config: dict
    repeat: int = 0
    case_id: str = ""

    def __post_init__(self):
        if not self.case_id:
            self.case_id = case_hash(self.kind, self.config, self.repeat)

    def to_dict(self) -> dict:
        """Plain (JSON/pickle-friendly) dict."""
        return {"index": self.index, "kind": self.kind, "params": self.params, "config": self.config,
                "repeat": self.repeat, "case_id": self.case_id}


@dataclass
class Study:
    """A parsed study file.

    ``base`` is the base case; ``axes`` a list of axes, each a list of ``{dotted key: value}``
    points (a grid key gives one axis, a ``[[zip]]`` group one axis, ``[[cases]]`` one axis);
    ``base_dir`` is where relative file names of the base are resolved (the study file's folder).
    """

    name: str
    base: dict
    axes: list[list[dict[str, Any]]] = field(default_factory=list)
    repeats: int = 1
    description: str = ""
    base_dir: Path = field(default_factory=Path.cwd)
    raw: dict = field(default_factory=dict)

    @property
    def swept_keys(self) -> list[str]:
        """Every dotted key varied by some axis, in order of first appearance."""
        keys: dict[str, None] = {}
        for axis in self.axes:
            for point in axis:
                for k in point:
                    keys.setdefault(k, None)
        return list(keys)

    def expand(self) -> list[Case]:
        """All cases (see :func:`expand`)."""
        return expand(self)


def case_kind(config: dict) -> str:
    """``"protocol"`` when the configuration names a protocol, otherwise ``"run"``."""
    return "protocol" if isinstance(config, dict) and "protocol" in config else "run"


def expand(study: Study) -> list[Case]:
    """The cases of ``study``: the product of its axes, then repeats (the last axis varies fastest)."""
    keys = study.swept_keys
    cases: list[Case] = []
    seen: dict[str, int] = {}
    for combo in itertools.product(*study.axes) if study.axes else [()]:
        point: dict[str, Any] = {}
        for part in combo:
            point.update(part)
        config = copy.deepcopy(study.base)
        for k, v in point.items():
            set_key(config, k, v)
        for r in range(study.repeats):
            params = {k: point.get(k) for k in keys}
            if study.repeats > 1:
                params["repeat"] = r
            c = Case(index=len(cases), kind=case_kind(config), params=params, config=config, repeat=r)
            if c.case_id in seen:
                raise ConfigError("sweep", f"cases {seen[c.case_id]} and {c.index} are identical ({params}); "
                                  "two axes set the same key, or an axis repeats a value")
            seen[c.case_id] = c.index
            cases.append(c)
    return cases


# ------------------------------------------------------------------------------------------ parsing
def _axis_values(key: str, values: Any, where: str) -> list:
    if not isinstance(values, list):
        raise ConfigError(f"{where}.{key}", f"axis {key!r} must be a list of values, got {values!r}")
    if not values:
        raise ConfigError(f"{where}.{key}", f"axis {key!r} has no values")
    return values


def _check_key(key: str, base: dict, where: str) -> None:
    try:
        parse_key(key)
        set_key(copy.deepcopy(base), key, None)
    except ConfigError as exc:
        msg = str(exc).split(": ", 1)[-1]
        raise ConfigError(f"{where}.{key}", f"bad axis {key!r}: {msg}") from None


def load_study_spec(source: str | os.PathLike | dict, *, base_dir: str | os.PathLike | None = None) -> Study:
    """Read a study file (TOML path or dict) and check its axes.

    Raises :class:`ConfigError` naming the offending axis (``grid.rods[3].radius``,
    ``zip[0]``, ``cases[2].solver.dt``) or top-level key.
    """
    if isinstance(source, dict):
        raw = copy.deepcopy(source)
        bdir = Path(base_dir) if base_dir is not None else Path.cwd()
        default_name = "study"
    else:
        path = Path(source)
        raw = load_toml(path, "study")
        bdir = Path(base_dir) if base_dir is not None else path.resolve().parent
        default_name = path.stem

    for k in raw:
        if k not in _TOP_KEYS:
            raise ConfigError(str(k), f"unknown study key; allowed keys are {', '.join(_TOP_KEYS)} "
                              "(parameters of the base case go under [base])")
    name = raw.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise ConfigError("name", f"expected a non-empty string, got {name!r}")
    description = raw.get("description", "")
    if not isinstance(description, str):
        raise ConfigError("description", f"expected a string, got {description!r}")
    repeats = number(raw.get("repeats", 1), "repeats", integer=True, at_least=1, must="be an integer >= 1")

    base = raw.get("base")
    if base is None:
        raise ConfigError("base", "missing required field: a [base] table (run configuration or protocol case) "
                          "or base = \"run.toml\"")
    if isinstance(base, str):
        bpath = (bdir / base) if not Path(base).is_absolute() else Path(base)
        root = bdir.resolve()
        if not bpath.resolve().is_relative_to(root):
            raise ConfigError("base", f"{base!r} lies outside the study's folder {str(root)!r}; keep the base run "
                                      "file beside the study file or in a folder below it")
        base = load_toml(bpath, "base")
        bdir = bpath.resolve().parent
    if not isinstance(base, dict):
        raise ConfigError("base", f"expected a table or a file name, got {base!r}")

    axes: list[list[dict]] = []
    grid = raw.get("grid", {})
    if not isinstance(grid, dict):
        raise ConfigError("grid", "expected a table of 'dotted.key' = [values]")
    for key, values in grid.items():
        _check_key(key, base, "grid")
        vals = _axis_values(key, values, "grid")
        axes.append([{key: v} for v in vals])

    zips = raw.get("zip", [])
    if isinstance(zips, dict):
        zips = [zips]
    if not isinstance(zips, list):
        raise ConfigError("zip", "expected [[zip]] tables of 'dotted.key' = [values]")
    for i, group in enumerate(zips):
        where = f"zip[{i}]"
        if not isinstance(group, dict) or not group:
            raise ConfigError(where, "expected a non-empty table of 'dotted.key' = [values]")
        lengths = {}
        for key, values in group.items():
            _check_key(key, base, where)
            lengths[key] = len(_axis_values(key, values, where))
        if len(set(lengths.values())) > 1:
            detail = ", ".join(f"{k!r} has {n}" for k, n in lengths.items())
            raise ConfigError(where, f"zipped axes must have the same number of values: {detail}")
        n = next(iter(lengths.values()))
        axes.append([{k: group[k][j] for k in group} for j in range(n)])

    explicit = raw.get("cases")
    if explicit is not None:
        if not isinstance(explicit, list) or not explicit:
            raise ConfigError("cases", "expected one or more [[cases]] tables of 'dotted.key' = value")
        points = []
        for i, point in enumerate(explicit):
            if not isinstance(point, dict):
                raise ConfigError(f"cases[{i}]", f"expected a table of 'dotted.key' = value, got {point!r}")
            for key in point:
                _check_key(key, base, f"cases[{i}]")
            points.append(dict(point))
        axes.append(points)

    keys_by_axis = [{k for p in axis for k in p} for axis in axes]
    for a, b in itertools.combinations(range(len(axes)), 2):
        common = keys_by_axis[a] & keys_by_axis[b]
        if common:
            raise ConfigError(sorted(common)[0], "this key is swept by two axes; zip them or keep one")

    return Study(name=name, base=base, axes=axes, repeats=repeats, description=description, base_dir=bdir,
                 raw=raw)
