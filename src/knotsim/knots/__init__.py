"""Knot geometry from drawings, the built-in knot library, and topology checks of knotted rods."""
