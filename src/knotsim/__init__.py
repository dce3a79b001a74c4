"""knotsim: Discrete Elastic Rods with implicit frictional contact, for tying knots."""

from knotsim.errors import ConfigError, GeometryError, KnotsimError, PenetrationError, SimulationError

__version__ = "0.1.0"


def load_study(study_dir):
    """Results table of a study directory as a pandas DataFrame (see :mod:`knotsim.study`)."""
    from knotsim.study import load_study as _load

    return _load(study_dir)


__all__ = [
    "ConfigError",
    "GeometryError",
    "KnotsimError",
    "PenetrationError",
    "SimulationError",
    "__version__",
    "load_study",
]
