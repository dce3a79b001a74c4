"""Rods: description of each rod (:class:`RodSpec`) and the assembled :class:`Model`."""

from knotsim.rods.model import Model, RodSpec

__all__ = ["Model", "RodSpec"]
