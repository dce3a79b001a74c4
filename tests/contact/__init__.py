"""Tests of knotsim.contact."""
