"""Solve: SNES Newton on the reduced unknowns, the admissible-domain guard, load-path control, diagnoses."""
