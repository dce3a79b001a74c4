"""Rendering of rods as shaded tubes (pyvista when installed, matplotlib otherwise) and animations.

The picture functions load on first use: :func:`render_frame`, :func:`render_run`,
:func:`render_key_frames` (:mod:`knotsim.viz.render`) and :func:`knot_region`
(:mod:`knotsim.viz.framing`).
"""

from __future__ import annotations

from knotsim._util.lazy import lazy_loader

_LAZY = {"render_frame": "knotsim.viz.render", "render_run": "knotsim.viz.render",
         "render_key_frames": "knotsim.viz.render", "knot_region": "knotsim.viz.framing"}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_loader("knotsim.viz", _LAZY, globals())
