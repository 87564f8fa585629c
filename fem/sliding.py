"""The joint as a sliding interface, or as a thin layer of low shear modulus (docs/model.md §2.12).

Three joints, :data:`JOINTS`:

- ``"bonded"`` (the thesis's model, the default): the gap's cartilage is one
  block bonded to the stapes head and the lenticular plate.
- ``"sliding"``: a frictionless, bilateral interface on the gap's face against
  the lenticular plate (z = ``Geometry.z_plate``). The gap's nodes on that face
  are duplicated (:func:`split_gap_face`; the gap's tetrahedra take the copies,
  so the cartilage stays bonded to the stapes head and glides on the plate)
  and each copy is tied to its plate node by the one exact linear constraint
  n·(u_gap − u_plate) = 0, n = e_z: its u_z is eliminated (u_z,gap := u_z,plate,
  a master–slave transformation T with K_r = Tᵀ K T, :class:`TiedReduction`);
  u_x and u_y stay free. Nodes the capsule shares (none on the default
  geometry, where the capsule's interface over the gap is free) stay bonded.
  The cut needs no new mesh: bonded and sliding use the same nodes, so the
  sliding model is the bonded one with constraints released.
- ``"layer"``: the gap as a transversely isotropic layer (axis z): the
  cartilage's isotropic stiffness with the through-thickness shear moduli
  G_xz = G_yz replaced by ``layer_shear_pa`` (:data:`DEFAULT_LAYER_SHEAR_PA`);
  its normal and in-plane stiffness are the cartilage's. No ν near ½, so no
  volumetric locking.

:func:`shear_split` says how the joint's shear (x, the load direction) splits
between the capsule and the gap; :func:`isj.fem.model.compare_cases` gives the seven thesis
cases for several joints.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from isj.design import Geometry, Materials
from isj.errors import InvalidParameter

from .assembly import lame_unit

#: The joint variants.
JOINTS: tuple[str, ...] = ("bonded", "sliding", "layer")

#: Default through-thickness shear modulus of the ``layer`` joint (Pa). Estimate: a synovial
#: film of ~1 µm (storage modulus G' of order 1–10 Pa, Fam et al. 2007, Biorheology 44:59) in
#: series with ~34 µm of cartilage (G = 3.8 MPa) gives G ≈ 35 µm / (1 µm / 10 Pa) ≈ 0.35 kPa;
#: rounded up to 1 kPa (docs/model.md §2.12).
DEFAULT_LAYER_SHEAR_PA = 1e3


def check_joint(joint: str) -> str:
    if joint not in JOINTS:
        raise InvalidParameter(f"joint = {joint!r}: must be one of {', '.join(JOINTS)}")
    return joint


def check_layer_shear(g_pa: float) -> float:
    if not isinstance(g_pa, int | float) or not math.isfinite(g_pa) or g_pa <= 0:
        raise InvalidParameter(f"layer_shear_pa = {g_pa!r} Pa: must be a finite number > 0")
    return float(g_pa)


# --------------------------------------------------------------------------- the cut


def _tol(geometry: Geometry) -> float:
    return 1e-6 * geometry.gap_thickness_m


def split_gap_face(mesh, geometry: Geometry):
    """``mesh`` with the gap–plate face cut open: the gap's tetrahedra get copies of its vertices.

    Vertices shared by gap and plate tetrahedra (all at z = z_plate) are
    duplicated, except those the capsule's tetrahedra use (bonded to the
    capsule, they stay shared). Named faces whose triangles bound gap
    tetrahedra are renumbered to the copies.
    """
    from .mesh import TetMesh

    gap, plate, cap = (mesh.region == mesh.region_id(r) for r in ("gap", "plate", "capsule"))
    shared = np.intersect1d(np.unique(mesh.tets[gap]), np.unique(mesh.tets[plate]))
    cut = np.setdiff1d(shared, np.unique(mesh.tets[cap]))
    if cut.size == 0 or np.abs(mesh.points[cut, 2] - geometry.z_plate).max() > _tol(geometry):
        raise InvalidParameter("the gap and the plate share no face at z_plate: cannot cut the joint")
    n = mesh.n_nodes
    new_id = np.arange(n, dtype=np.int64)
    new_id[cut] = n + np.arange(cut.size)
    tets = mesh.tets.copy()
    tets[gap] = new_id[tets[gap]]
    points = np.concatenate([mesh.points, mesh.points[cut]])
    faces = {}
    for name, tri in mesh.faces.items():
        zc = mesh.points[tri, 2].mean(axis=1)
        below = zc < geometry.z_plate - _tol(geometry)  # triangles on the gap's side of the face
        tri = tri.copy()
        tri[below] = new_id[tri[below]]
        faces[name] = tri
    return TetMesh(points, tets, mesh.region, mesh.region_names, faces)


def tied_nodes(space, geometry: Geometry) -> tuple[np.ndarray, np.ndarray]:
    """(gap nodes, plate nodes) at the same places on the cut face: the tied pairs (P1 or P2 nodes)."""
    from scipy.spatial import cKDTree

    def face_nodes(region):
        nodes = np.unique(space.cells[space.region == space.region_id(region)])
        return nodes[np.abs(space.points[nodes, 2] - geometry.z_plate) <= _tol(geometry)]

    g, p = face_nodes("gap"), face_nodes("plate")
    both = np.intersect1d(g, p)  # not cut (shared with the capsule): bonded
    g, p = np.setdiff1d(g, both), np.setdiff1d(p, both)
    dist, idx = cKDTree(space.points[p]).query(space.points[g])
    if g.size != p.size or g.size == 0 or dist.max() > _tol(geometry) or np.unique(idx).size != g.size:
        raise InvalidParameter("the cut gap face's nodes do not pair up with the plate's")
    return g, p[idx]


class TiedReduction:
    """Clamped dofs removed and each ``slave`` dof merged into its ``master`` (u_slave = u_master).

    The interface of :class:`fem.boundary.Reduction`: u = T q with T a 0/1
    matrix, ``matrix(data)`` = Tᵀ K T on a fixed CSR pattern (a fixed scatter of
    the full pattern's data, so a solver's symbolic analysis stays valid),
    ``restrict(f)`` = Tᵀ f, ``expand(q)`` = T q.
    """

    def __init__(self, pattern, fixed: np.ndarray, slave: np.ndarray, master: np.ndarray):
        n = pattern.n_dofs
        status = np.zeros(n, dtype=np.int8)  # 0 free, 1 clamped, 2 slave
        status[fixed] = 1
        if (status[slave] == 1).any() or (status[master] == 1).any():
            raise InvalidParameter("a tied dof is clamped")
        status[slave] = 2
        self.free = np.flatnonzero(status == 0)  # the independent dofs, in order
        new = np.full(n, -1, dtype=np.int64)
        new[self.free] = np.arange(self.free.size)
        new[slave] = new[master]
        self.new_id = new
        self.n_dofs = n
        rows, cols = new[pattern.rows()], new[pattern.indices]
        self._valid = np.flatnonzero((rows >= 0) & (cols >= 0))
        keys = rows[self._valid] * self.n_free + cols[self._valid]
        uniq, self._scatter = np.unique(keys, return_inverse=True)
        r, c = np.divmod(uniq, self.n_free)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=self.n_free))])
        self.indices = c.astype(np.int32 if self.n_free < 2**31 else np.int64)
        self._nnz = uniq.size
        kept = np.flatnonzero(new >= 0)
        self.T = sp.csr_matrix((np.ones(kept.size), (kept, new[kept])), shape=(n, self.n_free))

    @property
    def n_free(self) -> int:
        return self.free.size

    def matrix(self, data: np.ndarray, dtype=np.float64) -> sp.csr_matrix:
        vals = np.bincount(self._scatter, weights=np.asarray(data, float)[self._valid], minlength=self._nnz)
        return sp.csr_matrix(
            (vals.astype(dtype), self.indices, self.indptr), shape=(self.n_free, self.n_free)
        )

    def restrict(self, f: np.ndarray) -> np.ndarray:
        """Tᵀ f: the reduced load (a slave's force adds to its master's). For loads only:
        a displacement's reduced coordinates are :meth:`coordinates`."""
        return self.T.T @ f

    def coordinates(self, u: np.ndarray) -> np.ndarray:
        """q with T q = u for a displacement ``u`` that satisfies the ties and the clamps."""
        return u[self.free]

    def expand(self, u_free: np.ndarray) -> np.ndarray:
        return self.T @ u_free


def tied_reduction(model, fixed: np.ndarray) -> TiedReduction:
    """The sliding joint's reduction: ``fixed`` clamped, u_z of each cut gap node = its plate node's."""
    g, p = tied_nodes(model.space, model.geometry)
    return TiedReduction(model.pattern, fixed, 3 * g + 2, 3 * p + 2)


# --------------------------------------------------------------------------- the layer


def transverse_shear_blocks(rm) -> np.ndarray:
    """Blocks (pairs, 3, 3) of ∫ (γ_xz² + γ_yz²) dV, the unit through-thickness shear stiffness.

    From the region's gradient products A = ``rm.lam`` (A[k, l] = ∫ ∂_k N_i ∂_l N_j):
    γ_pz = ∂_z u_p + ∂_p u_z, p = x, y.
    """
    A = rm.lam
    S = np.zeros_like(A)
    z = 2
    for p in (0, 1):
        S[:, p, p] += A[:, z, z]
        S[:, p, z] += A[:, z, p]
        S[:, z, p] += A[:, p, z]
        S[:, z, z] += A[:, p, p]
    return S


def _layer_drop(model, materials: Materials) -> float:
    """μ_gap − G_layer (Pa): what the layer takes off the gap's through-thickness shear modulus."""
    return materials.gap_e_pa * lame_unit(materials.nu)[1] - model.layer_shear_pa


def layer_correction(model, materials: Materials) -> np.ndarray:
    """Full-pattern data to add to the bonded stiffness to make the gap the layer (N/m)."""
    rm = model.regions["gap"]
    if getattr(model, "_shear_blocks", None) is None:
        model._shear_blocks = transverse_shear_blocks(rm)
    data = np.zeros(model.pattern.nnz)
    data[model.pattern.block_pos[rm.pairs].ravel()] = (
        -_layer_drop(model, materials) * model._shear_blocks.ravel()
    )
    return data


def _blocks_apply(pattern, pairs, blocks, u) -> np.ndarray:
    """Σ over node pairs of blocks @ u_J into row I: the full force vector (N)."""
    un = u.reshape(-1, 3)
    f = np.einsum("pkl,pl->pk", blocks, un[pattern.pair_col[pairs]])
    out = np.zeros_like(un)
    np.add.at(out, pattern.pair_row[pairs], f)
    return out.ravel()


def layer_gap_energy_change(model, materials: Materials, u: np.ndarray) -> float:
    """Change of the gap's strain energy (J) from the layer's lower shear modulus."""
    rm = model.regions["gap"]
    layer_correction(model, materials)  # caches the blocks
    f = _blocks_apply(model.pattern, rm.pairs, model._shear_blocks, u)
    return -0.5 * _layer_drop(model, materials) * float(u @ f)


# --------------------------------------------------------------------------- the split


def _region_matrix(pattern, rm):
    """(where, CSR pattern) of the entries region ``rm`` touches, cached on ``rm``.

    ``where[p, k, l]`` is the CSR position of entry (k, l) of the region's block
    p, laid out as in the full pattern (:func:`fem.assembly.build_pattern`) but
    with only the region's node pairs: each row keeps the full pattern's column
    order, so K_r u adds the same nonzero terms in the same order as the
    full-pattern K_r, which differs only by exact zeros (the same bits, without
    a full-pattern array per region).
    """
    cached = getattr(rm, "_csr", None)
    if cached is None:
        row, col = pattern.pair_row[rm.pairs], pattern.pair_col[rm.pairs]  # pairs sorted by (row, col)
        deg = np.bincount(row, minlength=pattern.n_dofs // 3)
        nptr = np.concatenate([[0], np.cumsum(deg)])
        k = np.arange(3)
        base = 9 * nptr[row] + 3 * (np.arange(row.size) - nptr[row])
        where = base[:, None, None] + 3 * k[:, None] * deg[row][:, None, None] + k[None, :]
        itype = pattern.indices.dtype
        indices = np.empty(where.size, dtype=itype)
        indices[where] = (3 * col[:, None, None] + k[None, None, :]).astype(itype)
        indptr = np.concatenate([[0], np.cumsum(np.repeat(3 * deg, 3))]).astype(itype)
        cached = (where.ravel(), indices, indptr)
        object.__setattr__(rm, "_csr", cached)
    return cached


def region_forces(model, materials: Materials, u: np.ndarray, regions=None) -> dict[str, np.ndarray]:
    """Internal nodal forces K_r u (N, full dof vectors) of each region of ``regions`` (default: all)."""
    lam, mu = lame_unit(materials.nu)
    n = model.pattern.n_dofs
    out = {}
    for r in model.regions if regions is None else regions:
        rm = model.regions[r]
        e = materials.youngs(r)
        where, indices, indptr = _region_matrix(model.pattern, rm)
        data = np.empty(where.size)
        data[where] = ((e * lam) * rm.lam + (e * mu) * rm.mu).ravel()  # the blocks as combine() forms them
        f = sp.csr_matrix((data, indices, indptr), shape=(n, n)) @ u
        if r == "gap" and model.joint == "layer":
            layer_correction(model, materials)
            f = f - _layer_drop(model, materials) * _blocks_apply(
                model.pattern, rm.pairs, model._shear_blocks, u
            )
        out[r] = f
    return out


def shear_split(model, result) -> dict[str, float]:
    """How the joint's shear force (x) splits between the capsule and the gap.

    Cut plane z_m at the gap's mid-height. The x force a region carries across
    it is Σ (K_r u)_x over the nodes above the plane: elements wholly above
    give self-equilibrated forces (sum 0), those below none, so only the gap's
    and the capsule's elements that the plane crosses count. Summed over regions
    it is Σ_above f_x, the whole load on the incus (the ties act in z only), so
    the shares add to 1.

    The bending moment about y through the plane's centre, Σ ((z − z_m) f_x − x f_z)
    over the same nodes, splits likewise (the tie forces are equal and opposite
    at one point, so they cancel in both sums).

    Returns
    -------
    dict
        ``capsule_shear_n``, ``gap_shear_n`` (N), ``total_shear_n`` (the applied
        x force, N), ``capsule_shear_share``, ``gap_shear_share`` (of the total);
        ``total_moment_nm`` (N·m), ``capsule_moment_share``, ``gap_moment_share``.
    """
    g = model.geometry
    z_m = 0.5 * (g.z_gap + g.z_plate)
    u = result.displacement_m.ravel()
    above = model.space.points[:, 2] > z_m
    x, dz = model.space.points[above, 0], model.space.points[above, 2] - z_m

    def sums(f):
        f = f.reshape(-1, 3)[above]
        return float(f[:, 0].sum()), float((dz * f[:, 0] - x * f[:, 2]).sum())

    # the two regions the plane crosses that carry the shear; the total is the load's
    forces = {r: sums(f) for r, f in region_forces(model, result.materials, u, ("capsule", "gap")).items()}
    fx = {r: v[0] for r, v in forces.items()}
    total, moment = sums(model.unit_load * result.pressure_pa)
    return {
        "total_moment_nm": moment,
        "capsule_moment_share": forces["capsule"][1] / moment,
        "gap_moment_share": forces["gap"][1] / moment,
        "capsule_shear_n": fx["capsule"],
        "gap_shear_n": fx["gap"],
        "total_shear_n": total,
        "capsule_shear_share": fx["capsule"] / total,
        "gap_shear_share": fx["gap"] / total,
    }
