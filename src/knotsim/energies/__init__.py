"""Elastic energies of Discrete Elastic Rods (numba kernels): stretching, bending, twisting."""
