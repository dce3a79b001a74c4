"""Boundary conditions: clamp, hold, move (and turn), rotate, pin, release, forces, springs, load
cells, ring twist; reaction forces."""

from knotsim.bc.conditions import BoundaryConditions
from knotsim.bc.group import Group, GroupKind
from knotsim.bc.paths import ConstantVelocity, FunctionPath, Path, Waypoints
from knotsim.bc.rigid import Rotation

__all__ = ["BoundaryConditions", "ConstantVelocity", "FunctionPath", "Group", "GroupKind", "Path", "Rotation", "Waypoints"]
