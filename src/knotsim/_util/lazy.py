"""Names of a package loaded on first use (``import knotsim`` stays fast): a package keeps a table
``{name: module}`` and takes its module-level ``__getattr__`` and ``__dir__`` from :func:`lazy_loader`."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_loader"]


def lazy_loader(package: str, table: Mapping[str, str],
                namespace: dict[str, Any]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package`` (its name, for the error), whose public names
    ``table`` maps to the modules that define them; a name is imported at its first use and kept in
    ``namespace`` (the package's ``globals()``)."""

    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__
