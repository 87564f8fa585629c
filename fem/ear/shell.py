"""Flat-facet triangular thin-shell element: Allman membrane + DKT plate bending.

Every node carries six dofs in global coordinates, ordered ``(ux, uy, uz, θx,
θy, θz)``: displacements (m) and rotation-vector components (rad); global dof
of component ``c`` of node ``i`` is ``6 i + c``. Each triangle is flat; its
local frame has e1 along edge 1→2 and e3 along (p2 − p1) × (p3 − p1), so the
node order fixes the facet normal.

- Membrane: Allman's (1984) triangle. Its displacement is the 6-node quadratic
  (LST) field whose mid-side values are the corner mean plus an edge-normal
  bubble set by the corner drilling rotations ω = θz (local). It carries a real
  in-plane rotation dof, so coplanar facets are not singular, and represents
  in-plane bending far better than the constant-strain triangle.
- Its one spurious mode (all three ω equal, no translation) is removed by a
  small penalty on ω − ½ curl u at the centroid (Hughes–Brezzi style). It
  vanishes for every rigid motion and constant-strain state, so the patch test
  still passes exactly.
- Bending: the discrete Kirchhoff triangle (DKT; Batoz, Bathe & Ho 1980). The
  normal's rotation β is quadratic; Kirchhoff's constraint is imposed at the
  corners and, via a cubic w along each edge, at the mid-sides. It reproduces
  any constant curvature exactly and converges as O(h²) in deflection.
- Membrane and bending are uncoupled in a flat facet (homogeneous section);
  curvature couples them through the facets' different orientations.

Units: SI throughout (m, Pa, kg/m³, N, rad). Assembly is vectorised over
elements; loops run only over the three quadrature points and three edges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from isj.design import check_positive
from isj.errors import InvalidParameter
from isj.validate import check_poisson

#: Dofs per node: ux, uy, uz, θx, θy, θz.
NDOF = 6

#: Default drilling penalty, as a fraction of G t A (dimensionless). Small, because
#: it only has to lift Allman's spurious mode off zero; the patch test does not depend on it.
DEFAULT_DRILL_FACTOR = 1e-2

# Mid-side nodes of the quadratic fields sit on edges (0,1), (1,2), (2,0).
_EDGES = ((0, 1), (1, 2), (2, 0))
# Three mid-side points, weight 1/3 each (area coordinates): exact for the
# quadratic integrands here (products of two linear strain fields).
_QUAD = np.array([[0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5]])
# Minimum |area| / (longest edge)² below which a triangle counts as degenerate.
_DEGENERATE = 1e-10


@dataclass(frozen=True)
class ShellMaterial:
    """Isotropic linear-elastic shell section.

    Parameters
    ----------
    e_pa : Young's modulus (Pa), > 0
    nu : Poisson's ratio, in (-1, 0.5)
    thickness_m : shell thickness (m), > 0
    density_kg_m3 : density (kg/m³), > 0; only the mass matrix uses it
    """

    e_pa: float
    nu: float
    thickness_m: float
    density_kg_m3: float = 1000.0

    def __post_init__(self) -> None:
        check_positive("e_pa", self.e_pa, "Pa")
        check_poisson(self.nu, "nu")
        check_positive("thickness_m", self.thickness_m, "m")
        check_positive("density_kg_m3", self.density_kg_m3, "kg/m^3")

    @property
    def shear_modulus_pa(self) -> float:
        """G = E / (2 (1 + ν)) (Pa)."""
        return self.e_pa / (2.0 * (1.0 + self.nu))

    @property
    def flexural_rigidity_n_m(self) -> float:
        """Plate bending stiffness D = E t³ / (12 (1 − ν²)) (N·m)."""
        return self.e_pa * self.thickness_m**3 / (12.0 * (1.0 - self.nu**2))

    def plane_stress(self) -> np.ndarray:
        """Plane-stress elasticity matrix E/(1 − ν²)[[1, ν, 0], [ν, 1, 0], [0, 0, (1 − ν)/2]] (Pa)."""
        nu = self.nu
        return (
            self.e_pa / (1.0 - nu**2) * np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, (1 - nu) / 2]])
        )


# --------------------------------------------------------------------------- geometry


def check_mesh(nodes_m, triangles) -> tuple[np.ndarray, np.ndarray]:
    """Validate and convert a triangle mesh.

    Parameters
    ----------
    nodes_m : (N, 3) node coordinates (m)
    triangles : (M, 3) node indices, 0-based

    Returns
    -------
    (nodes as float64 (N, 3), triangles as int64 (M, 3))

    Raises
    ------
    InvalidParameter
        Wrong shapes, non-finite coordinates, indices out of range, or a degenerate
        triangle (area ≤ 1e-10 × its longest edge squared).
    """
    x = np.asarray(nodes_m, dtype=float)
    t = np.asarray(triangles)
    if x.ndim != 2 or x.shape[1] != 3 or not np.all(np.isfinite(x)):
        raise InvalidParameter(f"nodes_m: shape {x.shape}: must be a finite (N, 3) array in metres")
    if t.ndim != 2 or t.shape[1] != 3 or t.shape[0] == 0 or not np.issubdtype(t.dtype, np.integer):
        raise InvalidParameter(f"triangles: shape {t.shape}: must be a non-empty integer (M, 3) array")
    t = t.astype(np.int64)
    if t.min() < 0 or t.max() >= len(x):
        raise InvalidParameter(f"triangles: node indices must lie in [0, {len(x) - 1}]")
    p = x[t]
    twice = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    longest2 = np.max(np.sum((p - np.roll(p, -1, axis=1)) ** 2, axis=2), axis=1)
    bad = np.flatnonzero(0.5 * twice <= _DEGENERATE * longest2)
    if bad.size:
        raise InvalidParameter(
            f"triangles[{bad[0]}] = {t[bad[0]].tolist()}: degenerate (area must be > 1e-10 × longest edge²)"
        )
    return x, t


def facet_frames(nodes_m, triangles):
    """Local frame, in-plane coordinates and area of each triangle.

    Returns
    -------
    rot : (M, 3, 3) rows e1, e2, e3 (local = rot @ global)
    xy : (M, 3, 2) local in-plane corner coordinates (m), corner 0 at the origin
    area : (M,) area (m²)
    """
    p = nodes_m[triangles]
    d1, d2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    n = np.cross(d1, d2)
    twice = np.linalg.norm(n, axis=1)
    e1 = d1 / np.linalg.norm(d1, axis=1)[:, None]
    e3 = n / twice[:, None]
    e2 = np.cross(e3, e1)
    rot = np.stack([e1, e2, e3], axis=1)
    xy = np.einsum("eij,ekj->eki", rot[:, :2], p - p[:, :1])
    return rot, xy, 0.5 * twice


def _p2_gradients(xy, area, lam):
    """Gradients (M, 6, 2) of the 6-node quadratic shape functions at area coordinates ``lam``."""
    x, y = xy[..., 0], xy[..., 1]
    j, k = [1, 2, 0], [2, 0, 1]
    # ∇L_i = (y_j − y_k, x_k − x_j) / 2A: constant over the triangle.
    dl = np.stack([y[:, j] - y[:, k], x[:, k] - x[:, j]], axis=2) / (2.0 * area)[:, None, None]
    corners = (4.0 * lam[None, :, None] - 1.0) * dl
    mids = [4.0 * (lam[a] * dl[:, b] + lam[b] * dl[:, a]) for a, b in _EDGES]
    return np.concatenate([corners, np.stack(mids, axis=1)], axis=1)


# --------------------------------------------------------------------------- membrane


def _allman_map(xy):
    """(M, 12, 9): corner dofs (u, v, ω)×3 → (u, v) at the 6 nodes of the quadratic field."""
    m = len(xy)
    T = np.zeros((m, 12, 9))
    for i in range(3):
        T[:, 2 * i, 3 * i] = 1.0
        T[:, 2 * i + 1, 3 * i + 1] = 1.0
    for e, (i, j) in enumerate(_EDGES):
        k = 3 + e
        dx, dy = (xy[:, j] - xy[:, i]).T
        for c in range(2):
            T[:, 2 * k + c, 3 * i + c] = 0.5
            T[:, 2 * k + c, 3 * j + c] = 0.5
        # Edge-normal bubble (L/8)(ω_j − ω_i) n_out, n_out = (Δy, −Δx)/L for a CCW triangle:
        # it gives the edge the end rotations ω_i, ω_j in the least-squares sense.
        T[:, 2 * k, 3 * j + 2], T[:, 2 * k, 3 * i + 2] = dy / 8, -dy / 8
        T[:, 2 * k + 1, 3 * j + 2], T[:, 2 * k + 1, 3 * i + 2] = -dx / 8, dx / 8
    return T


def membrane_stiffness(xy, area, material: ShellMaterial, drill_factor: float = DEFAULT_DRILL_FACTOR):
    """Local Allman membrane stiffness (M, 9, 9) on dofs (u, v, ω) of the three corners (N/m, N, N·m)."""
    T = _allman_map(xy)
    C = material.plane_stress() * material.thickness_m
    K = np.zeros((len(xy), 9, 9))
    for lam in _QUAD:
        dn = _p2_gradients(xy, area, lam)
        B = np.zeros((len(xy), 3, 12))
        B[:, 0, 0::2] = dn[..., 0]
        B[:, 1, 1::2] = dn[..., 1]
        B[:, 2, 0::2] = dn[..., 1]
        B[:, 2, 1::2] = dn[..., 0]
        BT = B @ T
        K += (area / 3.0)[:, None, None] * (BT.transpose(0, 2, 1) @ (C @ BT))
    # Penalty on mean(ω) − ½ curl u at the centroid: zero for rigid motions and
    # constant strain, non-zero for Allman's spurious equal-ω mode.
    dn = _p2_gradients(xy, area, np.full(3, 1.0 / 3.0))
    curl = np.zeros((len(xy), 12))
    curl[:, 1::2] = 0.5 * dn[..., 0]
    curl[:, 0::2] = -0.5 * dn[..., 1]
    g = -np.einsum("ea,eaj->ej", curl, T)
    g[:, 2::3] += 1.0 / 3.0
    k_drill = drill_factor * material.shear_modulus_pa * material.thickness_m * area
    return K + k_drill[:, None, None] * g[:, :, None] * g[:, None, :]


# --------------------------------------------------------------------------- bending


def _dkt_map(xy):
    """(M, 12, 9): corner dofs (w, θx, θy)×3 → normal rotation (βx, βy) at the 6 quadratic nodes.

    β is the rotation of the normal seen as in-plane displacement per unit height,
    u = z β, so β = (θy, −θx) and Kirchhoff's constraint is β = −∇w.
    """
    m = len(xy)
    T = np.zeros((m, 12, 9))
    for i in range(3):
        T[:, 2 * i, 3 * i + 2] = 1.0
        T[:, 2 * i + 1, 3 * i + 1] = -1.0
    for e, (i, j) in enumerate(_EDGES):
        k = 3 + e
        d = xy[:, j] - xy[:, i]
        len2 = np.sum(d**2, axis=1)
        s = d / np.sqrt(len2)[:, None]
        # Tangential part from a cubic w along the edge, normal part linear:
        # β_k = 3Δ(w_i − w_j)/(2L²) + (½ I − ¾ s sᵀ)(β_i + β_j).
        P = 0.5 * np.eye(2)[None] - 0.75 * s[:, :, None] * s[:, None, :]
        for c in range(2):
            T[:, 2 * k + c, 3 * i] = 1.5 * d[:, c] / len2
            T[:, 2 * k + c, 3 * j] = -1.5 * d[:, c] / len2
            for n in (i, j):
                T[:, 2 * k + c, 3 * n + 1] = -P[:, c, 1]
                T[:, 2 * k + c, 3 * n + 2] = P[:, c, 0]
    return T


def bending_stiffness(xy, area, material: ShellMaterial):
    """Local DKT bending stiffness (M, 9, 9) on dofs (w, θx, θy) of the three corners (N/m, N, N·m)."""
    T = _dkt_map(xy)
    D = material.plane_stress() * material.thickness_m**3 / 12.0
    K = np.zeros((len(xy), 9, 9))
    for lam in _QUAD:
        dn = _p2_gradients(xy, area, lam)
        B = np.zeros((len(xy), 3, 12))
        B[:, 0, 0::2] = dn[..., 0]  # κx = ∂βx/∂x
        B[:, 1, 1::2] = dn[..., 1]  # κy = ∂βy/∂y
        B[:, 2, 0::2] = dn[..., 1]  # κxy = ∂βx/∂y + ∂βy/∂x
        B[:, 2, 1::2] = dn[..., 0]
        BT = B @ T
        K += (area / 3.0)[:, None, None] * (BT.transpose(0, 2, 1) @ (D @ BT))
    return K


# --------------------------------------------------------------------------- assembly

_MEMBRANE = np.array([[6 * i, 6 * i + 1, 6 * i + 5] for i in range(3)]).ravel()
_BENDING = np.array([[6 * i + 2, 6 * i + 3, 6 * i + 4] for i in range(3)]).ravel()


def element_stiffness(nodes_m, triangles, material: ShellMaterial, drill_factor=DEFAULT_DRILL_FACTOR):
    """Element stiffness matrices in global coordinates, (M, 18, 18).

    Element dof ``6 a + c`` is component ``c`` (ux, uy, uz, θx, θy, θz) of corner ``a``.
    """
    x, t = check_mesh(nodes_m, triangles)
    check_positive("drill_factor", drill_factor, "(dimensionless)")
    rot, xy, area = facet_frames(x, t)
    m = len(t)
    K = np.zeros((m, 18, 18))
    K[:, _MEMBRANE[:, None], _MEMBRANE[None, :]] = membrane_stiffness(xy, area, material, drill_factor)
    K[:, _BENDING[:, None], _BENDING[None, :]] = bending_stiffness(xy, area, material)
    # Both the displacement and the rotation triplet of each node rotate with the
    # facet frame: K_global = Tᵀ K_local T, T = blockdiag(rot × 6).
    T = np.zeros((m, 18, 18))
    for b in range(6):
        T[:, 3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = rot
    K = T.transpose(0, 2, 1) @ K @ T
    return 0.5 * (K + K.transpose(0, 2, 1))


def _element_dofs(triangles):
    return (NDOF * triangles[:, :, None] + np.arange(NDOF)).reshape(len(triangles), 3 * NDOF)


def _assemble(blocks, triangles, n_nodes) -> sp.csr_matrix:
    dofs = _element_dofs(triangles)
    rows = np.repeat(dofs, dofs.shape[1], axis=1).ravel()
    cols = np.tile(dofs, (1, dofs.shape[1])).ravel()
    n = NDOF * n_nodes
    return sp.coo_matrix((blocks.ravel(), (rows, cols)), shape=(n, n)).tocsr()


def stiffness_matrix(nodes_m, triangles, material: ShellMaterial, drill_factor=DEFAULT_DRILL_FACTOR):
    """Global stiffness matrix (6N × 6N, scipy CSR) of a shell mesh.

    Parameters
    ----------
    nodes_m : (N, 3) node coordinates (m)
    triangles : (M, 3) node indices; their order sets each facet's normal (right-hand rule)
    material : section properties
    drill_factor : drilling penalty as a fraction of G t A (dimensionless, > 0)

    Returns
    -------
    K : symmetric positive semi-definite; units N/m (translation rows and columns),
        N (mixed), N·m (rotation).
    """
    x, t = check_mesh(nodes_m, triangles)
    return _assemble(element_stiffness(x, t, material, drill_factor), t, len(x))


def mass_matrix(nodes_m, triangles, material: ShellMaterial, lumped: bool = False) -> sp.csr_matrix:
    """Global mass matrix (6N × 6N, scipy CSR; kg for translations, kg·m² for rotations).

    Translations: consistent mass of linear interpolation, ρ t A (1 + δ_ab) / 12 per
    component, or ρ t A / 3 on the diagonal when ``lumped``. Rotations: lumped rotary
    inertia ρ (t³/12) A / 3 on each of the three rotation dofs (the drilling one gets
    the same, so that M is positive definite; it is negligible for thin shells).
    Both are isotropic, so they need no rotation to global axes.
    """
    x, t = check_mesh(nodes_m, triangles)
    _, _, area = facet_frames(x, t)
    rho_t = material.density_kg_m3 * material.thickness_m
    m = len(t)
    M = np.zeros((m, 3, 6, 3, 6))
    if lumped:
        trans = np.eye(3)[None] * (rho_t * area / 3.0)[:, None, None]
    else:
        trans = (np.ones((3, 3)) + np.eye(3))[None] * (rho_t * area / 12.0)[:, None, None]
    for c in range(3):
        M[:, :, c, :, c] = trans
    rotary = material.density_kg_m3 * material.thickness_m**3 / 12.0 * area / 3.0
    for a in range(3):
        for c in range(3, 6):
            M[:, a, c, a, c] = rotary
    return _assemble(M.reshape(m, 18, 18), t, len(x))


def traction_load(nodes_m, triangles, traction_pa) -> np.ndarray:
    """Nodal forces (6N,) of a uniform traction per unit area, given in global axes.

    Parameters
    ----------
    traction_pa : (3,) force per unit area (Pa), e.g. ``(0, 0, -ρ g t)`` for self-weight

    Notes
    -----
    Consistent with linear interpolation of the translations: A/3 of each facet's
    force to each corner; no nodal moments.
    """
    x, t = check_mesh(nodes_m, triangles)
    q = np.asarray(traction_pa, dtype=float)
    if q.shape != (3,) or not np.all(np.isfinite(q)):
        raise InvalidParameter(f"traction_pa = {traction_pa!r}: must be 3 finite numbers (Pa)")
    _, _, area = facet_frames(x, t)
    return _lump_forces(np.outer(area / 3.0, q), t, len(x))


def pressure_load(nodes_m, triangles, pressure_pa: float) -> np.ndarray:
    """Nodal forces (6N,) of a uniform pressure acting along each facet's normal.

    Parameters
    ----------
    pressure_pa : pressure (Pa), finite. The force on a facet is ``pressure_pa × A × e3``
        with e3 = (p2 − p1) × (p3 − p1) / |…|: positive pressure pushes along the
        normal that the node order defines. A/3 goes to each corner (consistent
        with linear interpolation of the translations); no nodal moments.
    """
    x, t = check_mesh(nodes_m, triangles)
    if not isinstance(pressure_pa, int | float) or not math.isfinite(pressure_pa):
        raise InvalidParameter(f"pressure_pa = {pressure_pa!r} Pa: must be a finite number")
    rot, _, area = facet_frames(x, t)
    return _lump_forces(rot[:, 2] * (pressure_pa * area / 3.0)[:, None], t, len(x))


def _lump_forces(per_corner, triangles, n_nodes):
    f = np.zeros((n_nodes, NDOF))
    for a in range(3):
        np.add.at(f[:, :3], triangles[:, a], per_corner)
    return f.ravel()


def surface_area(nodes_m, triangles) -> float:
    """Total area of the facets (m²)."""
    x, t = check_mesh(nodes_m, triangles)
    return float(facet_frames(x, t)[2].sum())
