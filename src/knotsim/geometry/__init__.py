"""Geometric primitives shared by the contact model and the knot tools.

* :mod:`knotsim.geometry.segments`: distance between two 3D segments (scalar numba kernel and a
  vectorized wrapper), and small inline helpers shared with the contact distance kernels;
* :mod:`knotsim.geometry.planar`: crossings of projected (2D) polylines, one numba sweep;
* :mod:`knotsim.geometry.exclusion`: the same-rod rule saying which pairs of edges of one rod can
  never be in contact.
"""
