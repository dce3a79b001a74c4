"""The version of knotsim: its one source (``pyproject.toml`` reads it, ``knotsim.__version__``
re-exports it)."""

__version__ = "0.1.0"
