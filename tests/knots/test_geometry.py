"""Tests of knotsim.knots.geometry, the re-export module: its docstring example builds, and every
name it re-exports is the one of the defining module."""

from __future__ import annotations

from knotsim.knots import geometry as G

from .brute import count_crossings, letters_along


def test_module_docstring_example_builds():
    import tomllib

    doc = G.__doc__
    block = doc[doc.index("::\n") + 3:doc.index("Any other top-level keys")]
    text = "\n".join(line[4:] for line in block.splitlines())
    geo = G.build_knot(tomllib.loads(text))
    assert geo.radius == 1.6e-3 and len(geo.ropes[0]) == 301
    assert geo.n_crossings == 3 and geo.writhe == +3
    assert letters_along(1, count_crossings(geo.ropes)) == ["UOUOUO"]
    assert geo.held == (G.NodeRef(0, 150),) and geo.min_clearance >= geo.contact_distance


def test_reexports_are_the_defining_objects():
    from knotsim.geometry import segments
    from knotsim.knots import build, clearance, crossings, spec

    for name in G.__all__:
        obj = getattr(G, name)
        home = {m.__name__: m for m in (segments, build, clearance, crossings, spec)}[obj.__module__]
        assert getattr(home, name) is obj
