"""Checkpoints: everything that decides a run's next step, in one file (``checkpoint.npz``).

A checkpoint holds

- the :class:`~knotsim.solver.state.State` (positions and edge angles ``q``, rates ``v``,
  reference directors, tangents, reference twist, time);
- the stepper's memory: the previous step's start velocity and size (acceleration predictor);
- the adaptive step policy: current step, easy-step count, retry cool-down, failures so far;
- each interaction's state (contact: stiffness ``k_c``, the force driving it, the Verlet pair
  list and the positions it was built at);
- each boundary-condition group's captured anchor (positions and angles it prescribes from, the
  time they were captured, and the start point of a ``from_current`` path);
- the model's layout (rod names, node and edge counts, closed flags, radii), checked on restore.

When the run's last step was shortened to land on the requested end time, the checkpoint holds
the state just before that step (and the end time reached), so that the continuation takes the
same steps as an uninterrupted run. Restoring a checkpoint into a simulation built from the same
run description continues the run exactly: a run of ``2T`` and a run of ``T`` continued for ``T`` end in the same state (see
``tests/test_restart.py``). Arrays are stored under flat keys (``state/q``, ``bc/<name>/anchor``,
``interaction/<name>/pairs``) with the scalars as one JSON document (``meta``).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from knotsim._version import __version__
from knotsim.errors import ConfigError

__all__ = ["Checkpoint", "RodFrame", "read_checkpoint", "write_checkpoint"]

FORMAT = "knotsim-checkpoint-1"
_STATE_KEYS = ("q", "v", "d1", "tangents", "ref_twist")


@dataclass
class Checkpoint:
    """Contents of a checkpoint file (see the module docstring). ``meta`` holds the scalars,
    ``arrays`` the arrays by flat key."""

    meta: dict
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def time(self) -> float:
        """Simulation time of the saved state, s."""
        return float(self.meta["time"])

    @property
    def end_time(self) -> float:
        """Time the saved run reached, s: :attr:`time`, or later when its last step was shortened
        to land on the requested end (the checkpoint then holds the state before that step, see
        :meth:`knotsim.simulation.Simulation.resume_point`); a continued run of duration ``T``
        ends at ``end_time + T``."""
        return float(self.meta.get("end_time", self.meta["time"]))

    def state(self):
        """The saved :class:`~knotsim.solver.state.State`."""
        from knotsim.solver.state import State

        return State(*(self.arrays[f"state/{k}"].copy() for k in _STATE_KEYS), self.time)

    def section(self, prefix: str) -> tuple[dict, dict[str, np.ndarray]]:
        """Scalars and arrays saved by one component (``"stepper"``, ``"bc/left"``, ...)."""
        meta = self.meta.get("components", {}).get(prefix, {})
        pre = prefix + "/"
        arrays = {k[len(pre):]: v for k, v in self.arrays.items() if k.startswith(pre)}
        return meta, arrays

    def rod_frames(self):
        """The saved state as one :class:`RodFrame` per rod."""
        lay = self.meta["layout"]
        q = self.arrays["state/q"]
        v = self.arrays["state/v"]
        d1 = self.arrays["state/d1"]
        node_dof = self.arrays["layout/node_dof"]
        theta_dof = self.arrays["layout/edge_theta_dof"]
        out = []
        for r, name in enumerate(lay["rod_names"]):
            n0, n1 = lay["rod_node_start"][r], lay["rod_node_start"][r + 1]
            e0, e1 = lay["rod_edge_start"][r], lay["rod_edge_start"][r + 1]
            dofs = node_dof[n0:n1, None] + np.arange(3)[None, :]
            rest = self.arrays.get("layout/rest_length")
            out.append(RodFrame(q[dofs].copy(), q[theta_dof[e0:e1]].copy(), v[dofs].copy(), d1[e0:e1].copy(),
                                bool(lay["rod_closed"][r]), float(lay["rod_radius"][r]), name, self.time,
                                rest[e0:e1].copy() if rest is not None else None))
        return out


@dataclass
class RodFrame:
    """The physical state of one rod at one frame of an earlier run.

    ``positions (N, 3)`` m; ``edge_angles (N-1,)`` or ``(N,)`` for a ring, rad;
    ``velocities (N, 3)`` m/s or ``None``; ``reference_directors (n_edges, 3)`` or ``None``;
    ``closed``; ``radius`` m; ``name``; ``time`` s of the frame; ``rest_edge_lengths (n_edges,)`` m
    of the run's rope (``None`` when not stored).
    """

    positions: np.ndarray
    edge_angles: np.ndarray
    velocities: np.ndarray | None
    reference_directors: np.ndarray | None
    closed: bool
    radius: float
    name: str
    time: float
    rest_edge_lengths: np.ndarray | None = None


def _layout(model) -> dict:
    return {"rod_names": list(model.rod_names), "rod_node_start": [int(x) for x in model.rod_node_start],
            "rod_edge_start": [int(x) for x in model.rod_edge_start],
            "rod_closed": [bool(x) for x in model.rod_closed], "rod_radius": [float(x) for x in model.rod_radius],
            "n_dofs": int(model.n_dofs)}


def write_checkpoint(path: str | os.PathLike, sim) -> Path:
    """Write the complete state of ``sim`` (a :class:`~knotsim.simulation.Simulation`) to ``path``
    (atomically: a temporary file, then a rename)."""
    p = Path(path)
    st, sections, end_time = sim.resume_point()
    arrays: dict[str, np.ndarray] = {f"state/{k}": np.asarray(getattr(st, k)) for k in _STATE_KEYS}
    arrays["layout/node_dof"] = np.asarray(sim.model.node_dof)
    arrays["layout/edge_theta_dof"] = np.asarray(sim.model.edge_theta_dof)
    arrays["layout/rest_length"] = np.asarray(sim.model.rest_length)
    components: dict[str, dict] = {}
    for prefix, (meta, arrs) in sections.items():
        components[prefix] = meta
        for k, a in arrs.items():
            arrays[f"{prefix}/{k}"] = np.asarray(a)
    meta = {"format": FORMAT, "knotsim_version": __version__, "time": float(st.time), "end_time": end_time,
            "layout": _layout(sim.model), "components": components}
    tmp = p.with_name(f".{p.name}.tmp.npz")
    np.savez(tmp, meta=np.array(json.dumps(meta)), **arrays)
    os.replace(tmp, p)
    return p


def read_checkpoint(path: str | os.PathLike) -> Checkpoint:
    """Read a checkpoint written by :func:`write_checkpoint`."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError("checkpoint", f"file not found: {str(p)!r}")
    try:
        with np.load(p, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            arrays = {k: z[k] for k in z.files if k != "meta"}
    except (OSError, ValueError, KeyError) as exc:
        raise ConfigError("checkpoint", f"{str(p)!r} is not a readable knotsim checkpoint: {exc}") from None
    if meta.get("format") != FORMAT:
        raise ConfigError("checkpoint", f"{str(p)!r} has format {meta.get('format')!r}, expected {FORMAT!r}")
    return Checkpoint(meta, arrays)


def check_layout(checkpoint: Checkpoint, model) -> None:
    """Raise :class:`ConfigError` unless ``model`` has the rods the checkpoint was saved from."""
    saved = checkpoint.meta["layout"]
    now = _layout(model)
    for key in ("rod_node_start", "rod_edge_start", "rod_closed", "n_dofs"):
        if saved[key] != now[key]:
            raise ConfigError("from", f"the checkpoint was saved from rods with {key} = {saved[key]}, but the run "
                                      f"description gives {now[key]}; continue with the same rods (node counts, "
                                      "open/closed) as the saved run")
