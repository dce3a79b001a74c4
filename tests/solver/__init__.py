"""Tests of knotsim.solver."""
