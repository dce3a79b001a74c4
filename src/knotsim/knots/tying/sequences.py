"""Tying sequences: full run configurations (plain dicts, see :mod:`knotsim.io.config`) built from
the hands of :mod:`knotsim.knots.tying.hands`, and their TOML files.

Every length is in metres, every time in seconds; ``radius`` (m), ``youngs`` (Pa), ``density``
(kg/m³), ``damping`` (Pa s), ``mu`` (friction coefficient, 1), ``dt`` and ``out_dt`` (time step and
output interval, s). The shipped files ``knotsim/data/tying/*.toml`` were written by
:func:`write_sequence` from :func:`overhand_sequence` (``overhand``) and
:func:`~knotsim.knots.tying.channel.channel_sequence` (``reef``, ``granny``).
"""

from __future__ import annotations

from pathlib import Path

from knotsim._util.toml import dumps_toml, write_toml
from knotsim.knots.tying.hands import Hand, _straight, overhand_hands

__all__ = ["dumps_toml", "overhand_sequence", "write_sequence"]


def _config(hands: list[Hand], description: str, duration: float, *, length, n_nodes, radius, youngs,
            density, damping, mu, dt, out_dt) -> dict:
    """Run configuration of one straight rod ``rope`` (no gravity) moved by ``hands``."""
    return {
        "description": description,
        "rods": [{
            "name": "rope", "shape": "straight", "length": length, "n_nodes": n_nodes,
            "start": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.0], "radius": radius,
            "youngs_modulus": youngs, "density": density, "poisson_ratio": 0.5,
        }],
        "model": {"gravity": [0.0, 0.0, 0.0], "damping": damping},
        "bc": [h.to_bc(_straight(n_nodes, length)) for h in hands],
        "solver": {"dt": dt},
        "run": {"duration": duration, "output_interval": out_dt},
        "contact": {"mu": mu},
    }


def overhand_sequence(*, length=0.8, n_nodes=129, radius=2.5e-3, youngs=0.5e6, density=1000.0,
                      damping=0.05, mu=0.3, dt=2e-3, out_dt=0.05, **kw) -> dict:
    """Full run configuration (dict) tying an overhand knot in a straight rod (``kw``: the
    geometry of :func:`~knotsim.knots.tying.hands.overhand_hands`)."""
    hands, _ = overhand_hands(length=length, n_nodes=n_nodes, **kw)
    t_end = max(max(h.times) for h in hands)
    return _config(hands, "overhand knot tied from a straight rod: loop curled by grips, end threaded, pulled tight",
                   t_end + 0.4, length=length, n_nodes=n_nodes, radius=radius, youngs=youngs, density=density,
                   damping=damping, mu=mu, dt=dt, out_dt=out_dt)


def write_sequence(cfg: dict, path, header: str = "") -> Path:
    """Write a configuration dict as a TOML run file (with an optional ``#`` comment header).

    Floats are written exactly (:func:`knotsim._util.toml.dumps_toml`): the file loads back to the
    very values of ``cfg``."""
    return write_toml(path, cfg, header)
