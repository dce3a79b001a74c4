"""Boundary conditions: clamp, hold, move, rotate, release, forces; reaction forces."""

from knotsim.bc.conditions import BoundaryConditions, Group
from knotsim.bc.paths import ConstantVelocity, FunctionPath, Path, Waypoints

__all__ = ["BoundaryConditions", "ConstantVelocity", "FunctionPath", "Group", "Path", "Waypoints"]
