"""Whole-ear building blocks (spec §5): a flat-facet thin-shell element and the cat eardrum.

- :mod:`fem.ear.shell`: material, element matrices (Allman membrane + DKT
  bending, 6 dofs a node), vectorised assembly of stiffness, mass and loads;
- :mod:`fem.ear.constraints`: dof numbering, clamping, static solves, rigid links;
- :mod:`fem.ear.meshes`: small structured triangulations (disk, rectangle, sphere)
  used for verification;
- :mod:`fem.ear.eardrum`: the parametric pars tensa of the cat and its mesh.

Nothing here touches the top-level ``fem`` modules, whose digest keys a results cache.
"""
