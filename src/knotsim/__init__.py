"""knotsim: Discrete Elastic Rods with implicit frictional contact, for tying knots."""

from knotsim.errors import ConfigError, GeometryError, KnotsimError, PenetrationError, SimulationError

__version__ = "0.1.0"

__all__ = [
    "ConfigError",
    "GeometryError",
    "KnotsimError",
    "PenetrationError",
    "SimulationError",
    "__version__",
]
