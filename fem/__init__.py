"""Finite-element verifier of the pedicle-and-joint model (docs/model.md §2).

``import gmsh`` happens inside the meshing functions only, so that the rest of
the package (assembly, solvers, outputs) imports without it.
"""
