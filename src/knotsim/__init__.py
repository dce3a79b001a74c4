"""knotsim: Discrete Elastic Rods with implicit frictional contact, for tying knots and measuring
how strong they are.

``import knotsim as ks`` is all a user needs::

    rope = ks.RodSpec(x, radius=1.6e-3, youngs_modulus=0.18e6, density=1180)
    model = ks.Model([rope], damping=0.01)
    bcs = ks.BoundaryConditions(model)
    contact = ks.Contact(model, ks.ContactOptions(mu=0.3))
    log = ks.Simulation(model, bcs, ks.SolverOptions(dt=2.5e-3), interactions=[contact]).run(2.0)

    result = ks.run_protocol("overhand-pull", knot="overhand_n1", quick=True)    # knot strength
    result["outcome"], result.metrics, result.log                               # summary and log
    result = ks.run(ks.RunSpec.load("examples/hanging_rod.toml"), "out")        # a run file

Names are loaded on first use, so that ``import knotsim`` stays fast. Input bundles are called
``...Spec`` (what a thing is: ``RodSpec``, ``RunSpec``) or ``...Options`` (how to compute:
``SolverOptions``, ``ContactOptions``); closed sets of choices are enums whose members are their
strings (``ks.LinearSolver.SPARSE == "sparse"``, ``ks.Predictor``, ``ks.StiffnessMode``). Every time-dependent callable of a boundary condition (paths,
twist angles, forces, moments) takes the time elapsed since its group became active (s).
"""

from __future__ import annotations

from knotsim._util.lazy import lazy_loader
from knotsim._version import __version__
from knotsim.errors import (
    ConfigError,
    GeometryError,
    KnotsimError,
    SimulationError,
    ValidityError,
)

#: public name -> module that defines it
_LAZY = {
    # rods and model
    "RodSpec": "knotsim.rods", "Model": "knotsim.rods", "State": "knotsim.solver.state",
    "RopePreset": "knotsim.rods.ropes", "rope_presets": "knotsim.rods.ropes",
    # boundary conditions
    "BoundaryConditions": "knotsim.bc", "Waypoints": "knotsim.bc", "ConstantVelocity": "knotsim.bc",
    "FunctionPath": "knotsim.bc", "Rotation": "knotsim.bc",
    # contact
    "Contact": "knotsim.contact.model", "ContactOptions": "knotsim.contact.model",
    "StiffnessMode": "knotsim.contact.model", "LinearSolver": "knotsim.solver.options",
    "Predictor": "knotsim.solver.options",
    "Obstacle": "knotsim.contact.obstacles", "Plane": "knotsim.contact.obstacles",
    "Capsule": "knotsim.contact.obstacles", "Sphere": "knotsim.contact.obstacles",
    # solver and simulation
    "SolverOptions": "knotsim.solver.options", "Simulation": "knotsim.simulation",
    "solve_static": "knotsim.solver.static",
    # runs
    "RunSpec": "knotsim.runspec", "RunResult": "knotsim.runspec", "build_run": "knotsim.runspec", "run": "knotsim.runspec",
    "read_checkpoint": "knotsim.io.checkpoint", "read_trajectory": "knotsim.io.trajectory",
    # knots
    "get_knot": "knotsim.knots.library", "list_knots": "knotsim.knots.library", "analyze": "knotsim.knots.topology",
    "load_knot_spec": "knotsim.knots.library",
    "counting_rules": "knotsim.knots.topology", "knot_counting_rules": "knotsim.knots.topology",
    "tie_from_straight": "knotsim.knots.tying", "list_tying_sequences": "knotsim.knots.tying",
    # protocols and studies
    "run_protocol": "knotsim.protocols", "build_protocol_run": "knotsim.protocols",
    "critical_friction": "knotsim.study.critical", "CriticalFriction": "knotsim.study.critical",
    "ProtocolResult": "knotsim.protocols",
    "run_study": "knotsim.study", "load_study": "knotsim.study", "write_report": "knotsim.study",
    "compare_knots": "knotsim.study",
}


__getattr__, __dir__ = lazy_loader("knotsim", _LAZY, globals())


__all__ = ["ConfigError", "GeometryError", "KnotsimError", "SimulationError", "ValidityError", "__version__",
           *sorted(_LAZY)]
