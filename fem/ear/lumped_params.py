"""The eardrum's lumped parameters, measured on the FE pars tensa (docs/ear.md §5.2), for ``lumped.ear``.

The manubrium, tied to the malleus–incus body, moves rigidly with it, and the
eardrum's displacement splits exactly (a Craig–Bampton split with constraint
modes and one load-dependent Ritz vector) into

- Ψ: the drum's static shape when the body moves by a unit rigid motion, no
  pressure (the *coupled* part), and
- φ: the drum's static shape under a unit ear-canal pressure with the
  manubrium held (the *uncoupled* part), scaled to a unit volume displacement.

Ψ and φ are stiffness-orthogonal (φ vanishes where Ψ's reactions act), so the
statics of the umbo need only Ψ's stiffness and its load.

The lumped ear lets the body move as a rigid body on its springs (six dofs
(u, θ) at :attr:`isj.ear.EarGeometry.body_reference_m`), so Ψ has six columns
(the manubrium moved by each unit body dof) and the drum's parameters are the
6-vector of its load per Pa (by reciprocity, the volume displacement per unit
body motion: m² per m, m³ per rad: the "effective area"), its 6 × 6 stiffness
and mass, the volume compliance with the manubrium held and that shape's mass.
For a rotation about the nominal axis alone (the line through the anterior
mallear ligament's attachment and the midpoint of the posterior incudal bundles'
attachments, :attr:`isj.ear.EarGeometry.lever_ratio`'s axis) they reduce to the
textbook figures, referred to the umbo's displacement u = r_u θ (r_u the umbo's
distance from the axis):

- ``area_m2``: A = volume displacement per unit umbo displacement of Ψ (by
  reciprocity, the force on the umbo per Pa with the manubrium held);
- ``stiffness_n_m``: k_d = Ψᵀ K Ψ / r_u², the drum's stiffness against the umbo;
- ``compliance_m3_per_pa``: C_d = the drum's volume displacement per Pa with the manubrium held;
- ``coupled_mass_kg``, ``cross_mass_kg_m2``, ``uncoupled_mass_kg_m4``: Ψᵀ M Ψ / r_u²,
  Ψᵀ M φ / r_u, φᵀ M φ (the shell's consistent mass, density
  :data:`fem.ear.middle_ear.DRUM_DENSITY_KG_M3`, an estimate);
- ``drum_mass_kg``: ρ t × the drum's surface area (for information).

This module may import from :mod:`isj` and :mod:`fem` only; it returns plain
numbers (a dict whose keys are the fields of ``lumped.ear.EardrumParameters``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from isj.ear import DEFAULT_DRUM_MESH_SIZE_M, EarGeometry, EarMaterials

from .constraints import rigid_body_modes
from .eardrum import ear_canal_load, eardrum_mesh
from .middle_ear import DRUM_DENSITY_KG_M3, eardrum_geometry
from .shell import NDOF, ShellMaterial, mass_matrix, stiffness_matrix, surface_area


def nominal_axis(g: EarGeometry) -> tuple[np.ndarray, np.ndarray]:
    """A point (m) and the unit direction of the malleus–incus body's nominal axis.

    The direction points from the mallear ligament's attachment to the midpoint of the
    incudal bundles' (with the defaults (0, −1, 0), the joint model's y axis), so that a
    positive rotation moves the umbo medially.
    """
    p = np.asarray(g.malleus_ligament_m, dtype=float)
    q = 0.5 * (np.asarray(g.incudal_lateral_m) + np.asarray(g.incudal_medial_m))
    d = q - p
    return p, d / np.linalg.norm(d)


@dataclass(frozen=True, eq=False)  # arrays: no elementwise == pretending to be equality
class ClampedDrum:
    """The FE pars tensa with its ring clamped and its manubrium as the interface (SI).

    Attributes
    ----------
    mesh : the drum's shell mesh (:func:`fem.ear.eardrum.eardrum_mesh`)
    stiffness, mass : K and M of the whole shell (CSR; N/m, kg)
    load : f, the nodal forces of 1 Pa of ear-canal pressure (N/Pa); f · u is the volume
        displacement (m³), medial positive
    free : the dofs neither on the ring nor on the manubrium
    lu : the sparse LU factor of K on ``free`` (``scipy.sparse.linalg.splu``)
    reference_m : (3,) the body's reference point (u, θ refer to it)
    constraint_modes : (n_dof, 6) Ψ, the drum's static shape when the manubrium moves by each
        unit body dof (u, θ) at ``reference_m``, no pressure (Guyan)
    """

    mesh: object
    stiffness: sp.csr_matrix
    mass: sp.csr_matrix
    load: np.ndarray
    free: np.ndarray
    lu: object
    reference_m: np.ndarray
    constraint_modes: np.ndarray


def clamped_drum(
    geometry: EarGeometry | None = None,
    materials: EarMaterials | None = None,
    mesh_size_m: float = DEFAULT_DRUM_MESH_SIZE_M,
    density_kg_m3: float = DRUM_DENSITY_KG_M3,
) -> ClampedDrum:
    """Mesh and assemble the drum shell, clamp its ring and build its six constraint modes.

    The one assembly of :func:`eardrum_parameters` and :func:`fem.ear.drum_modes.drum_modes`;
    parameters as theirs.
    """
    from scipy.sparse.linalg import splu  # scipy.sparse.linalg: only when a drum is measured

    g = geometry or EarGeometry()
    m = materials or EarMaterials()
    mesh = eardrum_mesh(eardrum_geometry(g, mesh_size_m))
    shell = ShellMaterial(m.drum_e_pa, m.drum_nu, m.drum_thickness_m, density_kg_m3)
    K = stiffness_matrix(mesh.nodes_m, mesh.triangles, shell).tocsr()
    M = mass_matrix(mesh.nodes_m, mesh.triangles, shell).tocsr()
    f = ear_canal_load(mesh, 1.0)  # N per Pa; f · u = volume displacement (m³), medial positive
    n = K.shape[0]

    def dofs(nodes):
        nodes = np.unique(np.asarray(nodes, dtype=np.int64))
        return (NDOF * nodes[:, None] + np.arange(NDOF)).ravel(), nodes

    ring, _ = dofs(mesh.node_sets["ring"])
    manu, manu_nodes = dofs(mesh.node_sets["manubrium"])
    fixed = np.zeros(n, dtype=bool)
    fixed[ring] = True
    fixed[manu] = True
    free = np.flatnonzero(~fixed)
    lu = splu(K[free][:, free].tocsc())

    # six constraint modes: the manubrium moved by the body's unit (u, θ) at its reference point
    x_ref = np.asarray(g.body_reference_m, dtype=float)
    psi = np.zeros((n, 6))
    psi[manu] = rigid_body_modes(mesh.nodes_m[manu_nodes], x_ref)
    psi[free] = -lu.solve(np.asarray(K[free] @ psi))
    return ClampedDrum(mesh, K, M, f, free, lu, x_ref, psi)


def eardrum_parameters(
    geometry: EarGeometry | None = None,
    materials: EarMaterials | None = None,
    mesh_size_m: float = DEFAULT_DRUM_MESH_SIZE_M,
    density_kg_m3: float = DRUM_DENSITY_KG_M3,
) -> dict:
    """Measure the eardrum's lumped parameters on the FE drum (SI; see the module docstring).

    Parameters
    ----------
    geometry : anatomy (m); the drum, the body's reference point and the nominal axis come from it
    materials : eardrum modulus (Pa), Poisson's ratio and thickness (m)
    mesh_size_m : eardrum element size (m), as :class:`fem.ear.middle_ear.MiddleEarModel`'s
    density_kg_m3 : eardrum density (kg/m³; an estimate)

    Returns
    -------
    dict of plain numbers and lists: the fields of ``lumped.ear.EardrumParameters``
    (``load_per_pa`` (6,), ``stiffness`` (6, 6), ``mass`` (6, 6), ``cross_mass`` (6,),
    ``compliance_m3_per_pa``, ``uncoupled_mass_kg_m4``, ``reference_m`` (3,), ``drum_e_pa``,
    ``drum_mass_kg``) and, for information, the nominal-axis figures at the umbo:
    ``area_m2``, ``stiffness_n_m``, ``coupled_mass_kg``, ``umbo_arm_m``.
    """
    g = geometry or EarGeometry()
    m = materials or EarMaterials()
    drum = clamped_drum(g, m, mesh_size_m, density_kg_m3)
    mesh, K, M, f, free, lu = drum.mesh, drum.stiffness, drum.mass, drum.load, drum.free, drum.lu
    x_ref, psi = drum.reference_m, drum.constraint_modes
    n = K.shape[0]
    # the uncoupled shape: unit pressure, manubrium held, scaled to a unit volume displacement
    phi = np.zeros(n)
    phi[free] = lu.solve(f[free])
    compliance = float(f @ phi)  # m³/Pa
    phi /= compliance

    k6 = psi.T @ (K @ psi)
    m6 = psi.T @ (M @ psi)
    a6 = psi.T @ f
    # the nominal-axis figures, referred to the umbo
    p0, e = nominal_axis(g)
    basis = np.concatenate([np.cross(e, x_ref - p0), e])  # body (u, θ) per rad about the axis
    r_u = float(np.linalg.norm(np.cross(e, np.asarray(g.umbo_m) - p0)))
    sym = lambda a: 0.5 * (a + a.T)  # noqa: E731
    return {
        "load_per_pa": [float(v) for v in a6],
        "stiffness": sym(k6).tolist(),
        "mass": sym(m6).tolist(),
        "cross_mass": [float(v) for v in psi.T @ (M @ phi)],
        "compliance_m3_per_pa": compliance,
        "uncoupled_mass_kg_m4": float(phi @ (M @ phi)),
        "reference_m": [float(v) for v in x_ref],
        "drum_e_pa": float(m.drum_e_pa),
        "drum_mass_kg": density_kg_m3 * m.drum_thickness_m * surface_area(mesh.nodes_m, mesh.triangles),
        "area_m2": float(basis @ a6) / r_u,
        "stiffness_n_m": float(basis @ k6 @ basis) / r_u**2,
        "coupled_mass_kg": float(basis @ m6 @ basis) / r_u**2,
        "umbo_arm_m": r_u,
    }
