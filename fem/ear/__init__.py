"""Whole-ear building blocks (docs/ear.md §5.2): a flat-facet thin-shell element and the cat eardrum.

- :mod:`fem.ear.shell`: material, element matrices (Allman membrane + DKT
  bending, 6 dofs a node), vectorised assembly of stiffness, mass and loads;
- :mod:`fem.ear.constraints`: dof numbering, clamping, static solves, rigid links;
- :mod:`fem.ear.meshes`: small structured triangulations (disk, rectangle, sphere)
  used for verification;
- :mod:`fem.ear.eardrum`: the parametric pars tensa of the cat and its mesh;
- :mod:`fem.ear.footplate`: the stapes footplate (thick-rimmed elliptical shell) and its
  annular-ligament springs;
- :mod:`fem.ear.rigid`: rigid bodies (point maps, grounded springs, axis of rotation);
- :mod:`fem.ear.elimination`: master–slave elimination over the whole ear's dofs, with a
  reusable reduced pattern;
- :mod:`fem.ear.middle_ear`: the whole cat middle ear, static, with the pedicle-and-joint
  model embedded (or a rigid joint). Anatomy and constants: :mod:`isj.ear`.

Nothing here touches the top-level ``fem`` modules, whose digest keys a results cache.
"""
