"""The structural rule of the package: its modules form layers, and a module imports only from its
own layer or a lower one, with no import circles (``docs/architecture.md``, "Layers").

Every ``import`` of ``src/knotsim`` counts, also those inside functions (made late to keep start-up
fast, they are dependencies all the same) and ``importlib.import_module("knotsim...")`` with a
literal name. The layer table is read from ``docs/architecture.md``, so that the page and the
check cannot disagree; a new package must be entered there.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
ARCHITECTURE = ROOT / "docs" / "architecture.md"


def modules() -> dict[str, Path]:
    """Dotted module name -> file, for every module of ``src/knotsim`` (a package is its ``__init__``)."""
    out = {}
    for f in sorted((SRC / "knotsim").rglob("*.py")):
        parts = list(f.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = f
    return out


def _owner(name: str, mods: dict[str, Path]) -> str | None:
    """The module ``name`` lives in: itself, or the longest module prefix (``a.b.C`` -> ``a.b``)."""
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def imports_of(name: str, path: Path, mods: dict[str, Path]) -> dict[str, int]:
    """The knotsim modules ``name`` imports (anywhere in the file), each with the first line."""
    tree = ast.parse(path.read_text(), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: dict[str, int] = {}

    def add(target: str | None, line: int) -> None:
        if target is not None and target != name and (target == "knotsim" or target.startswith("knotsim.")):
            found.setdefault(target, line)

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                add(_owner(alias.name, mods), node.lineno)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            for alias in node.names:  # `from pkg import submodule` imports the submodule
                full = f"{source}.{alias.name}"
                add(full if full in mods else _owner(source, mods), node.lineno)
        elif (isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", None))
              == "import_module" and node.args and isinstance(node.args[0], ast.Constant)
              and isinstance(node.args[0].value, str)):
            add(_owner(node.args[0].value, mods), node.lineno)
    return found


def import_graph() -> dict[str, dict[str, int]]:
    mods = modules()
    return {name: imports_of(name, path, mods) for name, path in mods.items()}


def layer_table() -> list[tuple[int, str, list[str]]]:
    """``(number, name, module prefixes)`` of each row of the layer table of docs/architecture.md."""
    text = ARCHITECTURE.read_text()
    section = text.split("## Layers", 1)[1].split("\n## ", 1)[0]
    rows = []
    for line in section.splitlines():
        m = re.match(r"\|\s*(\d+)\s*\|\s*([^|]+?)\s*\|([^|]*)\|", line)
        if m:
            rows.append((int(m.group(1)), m.group(2), re.findall(r"`(knotsim[\w.]*)`", m.group(3))))
    return rows


def layer_of(module: str, table) -> tuple[int, str] | None:
    """The layer of the longest prefix in the table that ``module`` falls under."""
    best = None
    for number, name, prefixes in table:
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and (best is None or len(p) > best[0]):
                best = (len(p), number, name)
    return None if best is None else best[1:]


def test_layer_table_is_read():
    table = layer_table()
    numbers = [n for n, _, _ in table]
    assert numbers == list(range(1, len(table) + 1)), "layers are numbered 1, 2, ... lowest first"
    assert all(prefixes for _, _, prefixes in table)
    listed = [p for _, _, prefixes in table for p in prefixes]
    assert len(listed) == len(set(listed)), "a package is listed in two layers"


def test_every_module_has_a_layer():
    table = layer_table()
    missing = sorted(m for m in modules() if layer_of(m, table) is None)
    assert not missing, f"modules in no layer of docs/architecture.md: {missing}"


def test_imports_follow_the_layer_order():
    """A module imports only from its own layer or lower."""
    table = layer_table()
    mods = modules()
    bad = []
    for name, targets in import_graph().items():
        mine = layer_of(name, table)
        for target, line in targets.items():
            theirs = layer_of(target, table)
            if mine is not None and theirs is not None and theirs[0] > mine[0]:
                bad.append(f"{mods[name].relative_to(ROOT)}:{line}: {name} (layer {mine[0]} {mine[1]}) imports "
                           f"{target} (layer {theirs[0]} {theirs[1]})")
    assert not bad, "imports against the layer order:\n" + "\n".join(sorted(bad))


def _cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out = []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(graph[root]))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in graph:
                    continue
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(graph[w])))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def test_no_import_cycles():
    cycles = _cycles(import_graph())
    assert not cycles, "import circles:\n" + "\n".join(" <-> ".join(c) for c in cycles)


def test_the_checks_see_what_they_check(tmp_path):
    """The import parser sees function-local, relative and ``import_module`` imports, and the cycle
    finder finds a circle."""
    mods = {"knotsim": Path(), "knotsim.a": Path(), "knotsim.b": Path(), "knotsim.b.c": Path()}
    f = tmp_path / "a.py"
    f.write_text("import os\n\ndef f():\n    from knotsim.b import c\n    from . import b\n"
                 "    import importlib\n    importlib.import_module('knotsim.b.c.X')\n")
    assert set(imports_of("knotsim.a", f, mods)) == {"knotsim.b.c", "knotsim.b"}
    assert _cycles({"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 1}, "d": {"a": 1}}) == [["a", "b", "c"]]
    table = [(1, "low", ["knotsim.x"]), (2, "high", ["knotsim.x.y", "knotsim"])]
    assert layer_of("knotsim.x.z", table) == (1, "low")
    assert layer_of("knotsim.x.y.z", table) == (2, "high")
    assert layer_of("knotsim", table) == (2, "high")


def test_one_command_line_package():
    """The command line is the package ``knotsim.cli``; no command modules elsewhere."""
    assert not [p for p in (SRC / "knotsim").rglob("*cli*.py") if "cli" not in p.relative_to(SRC).parts[:-1]]
