"""Rendering of rods as shaded tubes (pyvista when installed, matplotlib otherwise) and animations.

The picture functions load on first use: :func:`render_frame`, :func:`render_run`,
:func:`render_key_frames` (:mod:`knotsim.viz.render`) and :func:`knot_region`
(:mod:`knotsim.viz.framing`).
"""

from __future__ import annotations

import importlib

_LAZY = {"render_frame": "knotsim.viz.render", "render_run": "knotsim.viz.render",
         "render_key_frames": "knotsim.viz.render", "knot_region": "knotsim.viz.framing"}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'knotsim.viz' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
