"""Checkpoints: everything that decides a run's next step, in one file (``checkpoint.npz``).

A checkpoint holds

- the :class:`~knotsim.solver.state.State` (positions and edge angles ``q``, rates ``v``,
  reference directors, tangents, reference twist, time);
- its run memory (:class:`~knotsim.solver.state.RunMemory`), written and read here and nowhere
  else: the stepper's (the previous step's start velocity and size for the acceleration predictor,
  the Jacobian the next step may start from, the sparse LU's ordering memory), the adaptive step
  policy's (current step, easy-step count, retry cool-down, failures so far), the validity guards'
  and each interaction's (contact: stiffness ``k_c``, the force driving it, the Verlet pair list
  and the positions it was built at; an interaction's memory is a dataclass of numbers and arrays,
  written field by field) and each boundary-condition group's (the positions and angles it
  prescribes from, the time they were captured, a turning grip's pivot, the start point of a
  ``from_current`` path, a load cell's controller: :class:`~knotsim.solver.state.GroupMemory`);
- the model's layout (rod names, node and edge counts, closed flags, radii), checked on restore.

When the run's last step was shortened to land on the requested end time, the checkpoint holds
the state just before that step (and the end time reached), so that the continuation takes the
same steps as an uninterrupted run. Restoring a checkpoint into a simulation built from the same
run description continues the run exactly: a run of ``2T`` and a run of ``T`` continued for ``T``
end in the same state (see ``tests/run/test_restart_and_replay.py``). Arrays are stored under flat
keys (``state/q``, ``bc/<name>/anchor``, ``interaction/<name>/pairs``) with the scalars as one JSON
document (``meta``; the sections' scalars under ``meta["components"][prefix]``). ``meta["run_state"]``
numbers the layout of the sections (2; checkpoints without it, written before the run memory moved
into the state, have the same layout and load alike).
"""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from knotsim._version import __version__
from knotsim.errors import ConfigError
from knotsim.solver.state import (
    DriverMemory,
    GroupMemory,
    JacobianMemory,
    LoadCellMemory,
    PredictorMemory,
    RunMemory,
    State,
    StepMemory,
    ValidityMemory,
)

__all__ = ["Checkpoint", "RodFrame", "read_checkpoint", "write_checkpoint"]

FORMAT = "knotsim-checkpoint-1"
#: layout of the run-memory sections (see the module docstring)
RUN_STATE = 2
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

    def state(self, memory: RunMemory | None = None) -> State:
        """The saved :class:`~knotsim.solver.state.State`; with ``memory`` (the run memory of the
        simulation it goes into, whose interaction sections give the types to read into) also its
        run memory (without: an empty one)."""
        a = self.arrays
        st = State(a["state/q"].copy(), a["state/v"].copy(), a["state/d1"].copy(), a["state/tangents"].copy(),
                   a["state/ref_twist"].copy(), self.time)
        if memory is not None:
            st.memory = read_memory(self, memory)
        return st

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
    st, end_time = sim.resume_point()
    sections = memory_sections(st.memory)
    arrays: dict[str, np.ndarray] = {f"state/{k}": np.asarray(getattr(st, k)) for k in _STATE_KEYS}
    arrays["layout/node_dof"] = np.asarray(sim.model.node_dof)
    arrays["layout/edge_theta_dof"] = np.asarray(sim.model.edge_theta_dof)
    arrays["layout/rest_length"] = np.asarray(sim.model.rest_length)
    components: dict[str, dict] = {}
    for prefix, (meta, arrs) in sections.items():
        components[prefix] = meta
        for k, a in arrs.items():
            arrays[f"{prefix}/{k}"] = np.asarray(a)
    meta = {"format": FORMAT, "run_state": RUN_STATE, "knotsim_version": __version__, "time": float(st.time),
            "end_time": end_time,
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


# ---------------------------------------------------------------------- the run memory
Section = tuple[dict, dict[str, np.ndarray]]


def memory_sections(memory: RunMemory) -> dict[str, Section]:
    """The sections of ``memory`` as ``{prefix: (scalars, arrays)}`` (``"driver"``, ``"stepper"``,
    ``"validity"``, ``"interaction/<name>"``, ``"bc/<group name>"``)."""
    out = {"driver": (_scalars(memory.driver), {}), "stepper": _step_out(memory.step),
           "validity": _validity_out(memory.validity)}
    for name, mem in memory.interactions.items():
        if mem is not None:
            out[f"interaction/{name}"] = _fields_out(mem)
    for name, mem in memory.bc.items():
        out[f"bc/{name}"] = _group_out(mem)
    return out


def read_memory(checkpoint: Checkpoint, template: RunMemory) -> RunMemory:
    """The run memory saved in ``checkpoint``; ``template``'s interaction sections give the types
    (each saved field replaces the template's default, a field not saved keeps its default) and its
    boundary-condition sections the groups to read (a group the checkpoint holds no anchor of keeps
    the template's memory)."""
    meta, _ = checkpoint.section("driver")
    driver = DriverMemory(**{f.name: meta[f.name] for f in dataclasses.fields(DriverMemory) if f.name in meta})
    if not meta:
        driver = dataclasses.replace(template.driver)
    inter = {}
    for name, mem in template.interactions.items():
        meta, arrays = checkpoint.section(f"interaction/{name}")
        # an interaction the checkpoint has nothing of keeps the memory it brings
        inter[name] = mem if mem is None or not (meta or arrays) else _fields_in(type(mem), meta, arrays)
    bc = {name: _group_in(*checkpoint.section(f"bc/{name}"), mem) for name, mem in template.bc.items()}
    return RunMemory(driver, _step_in(*checkpoint.section("stepper")), _validity_in(*checkpoint.section("validity")),
                     inter, bc)


def _scalars(obj) -> dict:
    return {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}


def _fields_out(mem) -> Section:
    """A dataclass of numbers, strings and arrays (``None``: not written) as a section."""
    meta: dict[str, Any] = {}
    arrays: dict[str, np.ndarray] = {}
    for f in dataclasses.fields(mem):
        v = getattr(mem, f.name)
        if v is None:
            continue
        if isinstance(v, np.ndarray):
            arrays[f.name] = v
        else:
            meta[f.name] = v.item() if isinstance(v, np.generic) else v
    return meta, arrays


def _fields_in(cls, meta: dict, arrays: dict[str, np.ndarray]):
    """The dataclass ``cls`` from a section written by :func:`_fields_out` (fields not in it keep
    their defaults)."""
    kw: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if f.name in arrays:
            kw[f.name] = np.array(arrays[f.name], copy=True)
        elif f.name in meta:
            kw[f.name] = meta[f.name]
    return cls(**kw)


def _step_out(mem: StepMemory) -> Section:
    meta: dict[str, Any] = {"history": False}
    arrays: dict[str, np.ndarray] = {}
    p = mem.predictor
    if p is not None:
        meta = {"history": True, "time": float(p.time), "dt": float(p.dt)}
        arrays["v_prev"] = p.v_prev
    if mem.ordering is not None:
        meta.update(ordering_nnz_l=int(mem.ordering[1]), ordering_nnz_a=int(mem.ordering[2]))
        arrays["ordering_perm"] = mem.ordering[0]
    j = mem.jacobian
    if j is not None:
        meta.update(last_iterations=int(j.last_iterations), jacobian_dt=float(j.dt), jacobian_kind=j.kind,
                    n_interaction_blocks=len(j.blocks))
        arrays["jacobian_fixed"] = np.asarray(j.fixed, bool)
        for i, b in enumerate(j.blocks):
            arrays[f"jacobian_blocks_{i}"] = np.asarray(b, np.int64)
        if j.banded is not None:
            ab, kl, ku, symmetric = j.banded
            meta.update(jacobian_kl=int(kl), jacobian_ku=int(ku), jacobian_symmetric=bool(symmetric))
            arrays["jacobian_banded"] = np.asarray(ab)
        elif j.sparse is not None:
            indptr, indices, data = j.sparse
            arrays.update(jacobian_indptr=indptr, jacobian_indices=indices, jacobian_data=data)
    return meta, arrays


def _step_in(meta: dict, arrays: dict[str, np.ndarray]) -> StepMemory:
    predictor = None
    if meta.get("history"):
        predictor = PredictorMemory(float(meta["time"]), np.array(arrays["v_prev"], float), float(meta["dt"]))
    ordering = None
    if "ordering_nnz_l" in meta:
        ordering = (np.array(arrays["ordering_perm"]), int(meta["ordering_nnz_l"]), int(meta["ordering_nnz_a"]))
    jac = None
    if "jacobian_kind" in meta:
        blocks = tuple(np.array(arrays[f"jacobian_blocks_{i}"], np.int64) for i in range(int(meta["n_interaction_blocks"])))
        banded = sparse = None
        if meta["jacobian_kind"] == "banded":
            banded = (np.asfortranarray(np.array(arrays["jacobian_banded"], float)), int(meta["jacobian_kl"]),
                      int(meta["jacobian_ku"]), bool(meta["jacobian_symmetric"]))
        else:
            sparse = (np.array(arrays["jacobian_indptr"], np.int64), np.array(arrays["jacobian_indices"], np.int64),
                      np.array(arrays["jacobian_data"], float))
        jac = JacobianMemory(int(meta["last_iterations"]), float(meta["jacobian_dt"]),
                             np.array(arrays["jacobian_fixed"], bool), blocks, str(meta["jacobian_kind"]), banded, sparse)
    return StepMemory(predictor, jac, ordering)


def _validity_out(mem: ValidityMemory) -> Section:
    s, e, ts = mem.worst_strain
    g, tg = mem.worst_gain
    return ({"energy": mem.energy, "gravity_start": mem.gravity_start, "gain": mem.gain,
             "work_handled": mem.work_handled, "scale": mem.scale, "worst_strain": s, "worst_strain_edge": e,
             "worst_strain_time": ts, "worst_gain": g, "worst_gain_time": tg,
             **{f"penalty_k_c/{n}": k for n, (k, _) in mem.penalty.items()},
             **{f"penalty_energy/{n}": en for n, (_, en) in mem.penalty.items()}}, {})


def _validity_in(meta: dict, arrays: dict[str, np.ndarray]) -> ValidityMemory:
    if not meta:  # a checkpoint from before the monitor
        return ValidityMemory()
    penalty = {k.split("/", 1)[1]: (float(v), float(meta[f"penalty_energy/{k.split('/', 1)[1]}"]))
               for k, v in meta.items() if k.startswith("penalty_k_c/")}
    return ValidityMemory(float(meta["energy"]), float(meta["gravity_start"]), float(meta["gain"]),
                          float(meta["work_handled"]), float(meta["scale"]),
                          (float(meta["worst_strain"]), int(meta["worst_strain_edge"]), float(meta["worst_strain_time"])),
                          (float(meta["worst_gain"]), float(meta["worst_gain_time"])), penalty)


#: the load-cell controller's numbers, in the order written
_CELL_FIELDS = ("u", "u_cmd", "integral", "force", "error", "u_step")


def _group_out(mem: GroupMemory) -> Section:
    """A boundary-condition group's memory: ``anchored`` and, when it is, ``anchor_time`` and the
    arrays ``anchor``, ``anchor_theta``, ``pivot``, ``path_start`` (those it has); a load cell's
    controller as scalars (``t_last`` -1 for none)."""
    extra: dict[str, Any] = {}
    if mem.cell is not None:
        extra = {k: float(getattr(mem.cell, k)) for k in _CELL_FIELDS}
        extra["t_last"] = -1.0 if mem.cell.t_last is None else float(mem.cell.t_last)
    if mem.anchor is None:
        return {"anchored": False, **extra}, {}
    arrays = {"anchor": mem.anchor}
    for key in ("anchor_theta", "pivot", "path_start"):
        if getattr(mem, key) is not None:
            arrays[key] = getattr(mem, key)
    return {"anchored": True, "anchor_time": float(mem.anchor_time), **extra}, arrays


def _group_in(meta: dict, arrays: dict[str, np.ndarray], template: GroupMemory) -> GroupMemory:
    """The memory of a group written by :func:`_group_out`; ``template`` (the group's own) when the
    section holds no anchor. A controller field not written, a pivot or a path start keeps the
    template's."""
    if not meta.get("anchored"):
        return template
    cell = None
    if template.cell is not None:
        cell = LoadCellMemory(**{k: float(meta[k]) if k in meta else getattr(template.cell, k) for k in _CELL_FIELDS})
        t_last = float(meta.get("t_last", -1.0))
        cell.t_last = None if t_last < 0 else t_last

    def array(key: str, default):
        return np.array(arrays[key], float) if key in arrays else default

    return GroupMemory(np.array(arrays["anchor"], float), array("anchor_theta", None), float(meta["anchor_time"]),
                       array("pivot", template.pivot), array("path_start", template.path_start), cell)
