"""Geometry: the region table, the half-section's dimensions, its gmsh model and the distributed mesh."""
