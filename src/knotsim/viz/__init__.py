"""Rendering of rods as shaded tubes (pyvista when installed, matplotlib otherwise) and animations."""
