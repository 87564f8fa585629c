"""The whole cat middle ear, static, with the 3-D pedicle-and-joint model inside (docs/ear.md §5).

>>> ear = MiddleEarModel(joint=PedicleJointModel(order=2))   # doctest: +SKIP
>>> res = ear.static(Materials())                            # per Pa of ear-canal pressure
>>> res.footplate_m_per_pa, res.alpha_rad_per_pa             # doctest: +SKIP

Parts and their dofs (one full vector, SI units):

- eardrum (:mod:`fem.ear.eardrum`): shell, 6 dofs a node; ring clamped;
  manubrium nodes tied to the malleus–incus body (all six dofs, exact
  master–slave elimination, :func:`fem.ear.constraints.rigid_body_modes`);
- malleus + incus: one rigid body, six dofs (u, θ) at
  :attr:`isj.ear.EarGeometry.body_reference_m`, suspended by grounded
  translational springs at the ligaments' attachments (:mod:`fem.ear.rigid`);
- the pedicle-and-joint model (:class:`fem.model.PedicleJointModel`, P1/P2
  tetrahedra, 3 dofs a node, its own frame): the nodes of its incus block's far
  face (z = z_top, where the block continues into the long process) are tied
  to the malleus–incus body, those of the stapes-head face it clamps when
  isolated (z = 0) to the stapes superstructure, both by translations only,
  u_s = Rᵀ (u_m + θ_m × (x_s − x_m)) with R the joint frame's axes in the ear;
- stapes superstructure (head bottom face + crura): a rigid body with six dofs at
  the centre of the stapes-head face, tied to the joint model and to the whole
  band of footplate nodes at the inner edge of the thick rim (many nodes, not four);
- footplate (:mod:`fem.ear.footplate`): shell with the annular springs at its outline.

Variant ``joint=None``: the joint replaced by a rigid connection; the stapes
superstructure is then part of the malleus–incus body (small and fast).

Dynamics (mass from :class:`isj.ear.EarMasses`, docs/dynamics.md §4.3 damping, harmonic response per
Pa, natural frequencies): :mod:`fem.ear.dynamics`, also as :meth:`MiddleEarModel.mass`,
:meth:`MiddleEarModel.frequency_response` and :meth:`MiddleEarModel.natural_frequencies_hz`.

Everything that does not depend on the moduli is built once: meshes, the
constraint map T, the pattern of Tᵀ K T and the map from the entries' values
to it (:class:`fem.ear.elimination.ReducedPattern`), the solver's analysis, the
load. A new set of joint moduli (or ear materials) costs one sparse mat-vec and
one numeric factorization.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from isj.cases import THESIS_CASES
from isj.design import Materials
from isj.ear import DEFAULT_DRUM_MESH_SIZE_M, EarGeometry, EarMasses, EarMaterials

from ..memo import kept_result
from ..sliding import tied_nodes
from ..solvers import make_solver
from .constraints import rigid_body_modes
from .dynamics import harmonic, natural_frequencies, reduced_mass
from .eardrum import EardrumGeometry, ear_canal_load, eardrum_mesh
from .elimination import ConstraintBuilder, ReducedPattern
from .footplate import FOOTPLATE_DENSITY_KG_M3, footplate_mesh
from .rigid import axis_of_rotation, grounded_springs, point_map
from .shell import NDOF, ShellMaterial, _element_dofs, element_stiffness

#: Static results each model keeps (:meth:`MiddleEarModel.static`), about 1 MB each on the default ear.
STATIC_MEMO = 16

#: Density of the pars tensa (kg/m³), :attr:`isj.ear.EarMasses.drum_density_kg_m3` (estimate);
#: statics ignore it, :mod:`fem.ear.dynamics` reads :class:`isj.ear.EarMasses`.
DRUM_DENSITY_KG_M3 = EarMasses().drum_density_kg_m3


def eardrum_geometry(g: EarGeometry, mesh_size_m: float = DEFAULT_DRUM_MESH_SIZE_M) -> EardrumGeometry:
    """The :class:`EardrumGeometry` described by an :class:`EarGeometry` (same frame, same numbers)."""
    return EardrumGeometry(
        semi_axis_manubrium_m=g.drum_semi_axis_manubrium_m,
        semi_axis_transverse_m=g.drum_semi_axis_transverse_m,
        cone_depth_m=g.drum_cone_depth_m,
        normalized_radius=g.drum_normalized_radius,
        umbo_x_m=g.umbo_x_m,
        manubrium_gap_m=g.manubrium_gap_m,
        mesh_size_m=mesh_size_m,
    )


def joint_frame(g: EarGeometry) -> np.ndarray:
    """(3, 3) R whose columns are the joint model's x, y, z axes in the ear: x_ear = head + R x_joint."""
    return np.column_stack([g.joint_x_direction, g.joint_y_direction, g.joint_z_direction])


def _node_block_dofs(nodes, ncomp: int, offset: int) -> np.ndarray:
    return (offset + ncomp * np.asarray(nodes, dtype=np.int64)[:, None] + np.arange(ncomp)).ravel()


@dataclass
class EarStaticResult:
    """Static response of the whole ear per Pa of ear-canal pressure (SI; positive pressure pushes medially).

    Attributes
    ----------
    umbo_vector_m_per_pa : (3,) umbo displacement (m/Pa), ear frame
    eardrum_max_m_per_pa : largest displacement magnitude over the eardrum's nodes (m/Pa)
    footplate_m_per_pa : (3,) displacement of the footplate's centre node (m/Pa), ear frame
    footplate_piston_m_per_pa : its component along the piston direction (into the cochlea)
    alpha_rad_per_pa, beta_rad_per_pa : joint and pedicle angles (docs/model.md §2.4 point pairs) of the
        embedded joint model (rad/Pa), about the joint's y axis; None for the rigid joint
    alpha_ls_rad_per_pa, beta_ls_rad_per_pa : the least-squares variants
    rotation_axis : the malleus–incus body's instantaneous axis: point (m), unit direction,
        rotation (rad/Pa) and axial translation (m/Pa)
    body_m_rad_per_pa : (6,) the body's (u, θ) at its reference point
    timings_s : seconds spent (values, factor, solve, post)
    """

    umbo_vector_m_per_pa: np.ndarray
    eardrum_max_m_per_pa: float
    footplate_m_per_pa: np.ndarray
    footplate_piston_m_per_pa: float
    alpha_rad_per_pa: float | None
    beta_rad_per_pa: float | None
    alpha_ls_rad_per_pa: float | None
    beta_ls_rad_per_pa: float | None
    rotation_axis: dict
    body_m_rad_per_pa: np.ndarray
    materials: Materials | None = None
    timings_s: dict = field(default_factory=dict)
    displacement: np.ndarray | None = field(default=None, repr=False)

    @property
    def umbo_m_per_pa(self) -> float:
        """Magnitude of the umbo's displacement (m/Pa)."""
        return float(np.linalg.norm(self.umbo_vector_m_per_pa))

    def to_dict(self) -> dict:
        return {
            "umbo_m_per_pa": self.umbo_m_per_pa,
            "umbo_vector_m_per_pa": [float(v) for v in self.umbo_vector_m_per_pa],
            "eardrum_max_m_per_pa": self.eardrum_max_m_per_pa,
            "footplate_m_per_pa": [float(v) for v in self.footplate_m_per_pa],
            "footplate_piston_m_per_pa": self.footplate_piston_m_per_pa,
            "alpha_rad_per_pa": self.alpha_rad_per_pa,
            "beta_rad_per_pa": self.beta_rad_per_pa,
            "alpha_ls_rad_per_pa": self.alpha_ls_rad_per_pa,
            "beta_ls_rad_per_pa": self.beta_ls_rad_per_pa,
            "rotation_axis": dict(self.rotation_axis),
            "body_m_rad_per_pa": [float(v) for v in self.body_m_rad_per_pa],
            "timings_s": dict(self.timings_s),
        }


class MiddleEarModel:
    """Meshed and assembled whole cat middle ear (docs/ear.md §5) with or without the 3-D joint inside.

    Parameters
    ----------
    geometry : anatomy (m), :class:`isj.ear.EarGeometry`
    joint : a :class:`fem.model.PedicleJointModel` to embed, or None for the rigid-joint
        variant. The ear's joint length is the joint's z_top (:meth:`isj.ear.EarGeometry.for_joint`),
        so ``self.geometry`` may differ from ``geometry`` in ``joint_length_m``: pass
        ``self.geometry`` to a rigid-joint variant of the same ear.
    drum_mesh_size_m : eardrum element size (m); the default (0.125 mm, ≈ 6,200 triangles) is the
        coarsest converged drum (:data:`isj.ear.DEFAULT_DRUM_MESH_SIZE_M`, docs/ear.md §5.15)
    solver : sparse solver backend (``fem.solvers.make_solver``)
    """

    def __init__(
        self,
        geometry: EarGeometry | None = None,
        joint=None,
        drum_mesh_size_m: float = DEFAULT_DRUM_MESH_SIZE_M,
        solver: str = "auto",
    ):
        t0 = time.perf_counter()
        g = geometry or EarGeometry()
        if joint is not None:  # any stack height the joint model accepts: its length, not a check
            g = g.for_joint(joint.geometry)
        self.geometry = g
        self.joint = joint
        self._solver_name = solver
        self._solver = None
        self.drum_mesh_size_m = float(drum_mesh_size_m)
        self.drum = eardrum_mesh(eardrum_geometry(g, drum_mesh_size_m))
        self.footplate = footplate_mesh(g)
        nd, nf = len(self.drum.nodes_m), len(self.footplate.nodes_m)
        self.off_drum = 0
        self.off_fp = NDOF * nd
        self.off_joint = self.off_fp + NDOF * nf
        nj = 0 if joint is None else joint.space.n_nodes
        self.off_body = self.off_joint + 3 * nj
        self.off_stapes = self.off_body + 6 if joint is not None else self.off_body
        self.n_full = self.off_stapes + 6 if joint is not None else self.off_body + 6
        self.body_dofs = np.arange(self.off_body, self.off_body + 6)
        self.stapes_dofs = np.arange(self.off_stapes, self.off_stapes + 6)
        x_body = np.asarray(g.body_reference_m)
        x_stapes = np.asarray(g.stapes_head_m) if joint is not None else x_body

        self.T, self.free = self._constraints(x_body, x_stapes)

        rows, cols = self._fixed_entries()
        self.n_fixed_entries = rows.size
        if joint is not None:
            jrows = joint.pattern.rows().astype(np.int64) + self.off_joint
            jcols = joint.pattern.indices.astype(np.int64) + self.off_joint
            rows, cols = np.concatenate([rows, jrows]), np.concatenate([cols, jcols])
        t1 = time.perf_counter()
        self.pattern = ReducedPattern(self.T, rows, cols)
        f = np.zeros(self.n_full)
        f[self.off_drum : self.off_fp] = ear_canal_load(self.drum, 1.0)
        self.unit_load = f
        self.load_reduced = self.T.T @ f
        t2 = time.perf_counter()
        self.timings_s = {"setup": t1 - t0, "reduced_pattern": t2 - t1}

    def _constraints(self, x_body, x_stapes) -> tuple[sp.csr_matrix, np.ndarray]:
        """(T, free): the drum clamped at its ring, its manubrium and the footplate's crura tied to
        the two rigid bodies (reference points ``x_body``, ``x_stapes``, m), and the joint's faces
        (:meth:`_tie_joint`)."""
        cb = ConstraintBuilder(self.n_full)
        ring = self.drum.node_sets["ring"]
        cb.clamp(_node_block_dofs(ring, NDOF, self.off_drum))
        manu = np.unique(self.drum.node_sets["manubrium"])
        cb.tie(
            _node_block_dofs(manu, NDOF, self.off_drum),
            self.body_dofs,
            rigid_body_modes(self.drum.nodes_m[manu], x_body),
        )
        crura = np.unique(self.footplate.node_sets["crura"])
        cb.tie(
            _node_block_dofs(crura, NDOF, self.off_fp),
            self.stapes_dofs,
            rigid_body_modes(self.footplate.nodes_m[crura], x_stapes),
        )
        if self.joint is not None:
            self._tie_joint(cb, x_body, x_stapes)
        return cb.build()

    def _tie_joint(self, cb: ConstraintBuilder, x_body, x_stapes) -> None:
        """The joint model's incus face to the malleus–incus body, its stapes face to the stapes,
        and with the sliding joint its cut gap–plate face in the joint's z (docs/model.md §2.12)."""
        joint, g = self.joint, self.geometry
        R = joint_frame(g)
        pts = joint.space.points
        zt = joint.geometry.z_top
        self.joint_points_m = np.asarray(g.stapes_head_m) + pts @ R.T
        self.incus_face = np.flatnonzero(np.abs(pts[:, 2] - zt) <= 1e-9 * zt)
        self.stapes_face = joint.space.face_nodes("clamped")
        for nodes, master, x_m in (
            (self.incus_face, self.body_dofs, x_body),
            (self.stapes_face, self.stapes_dofs, x_stapes),
        ):
            coef = np.einsum("ji,pjk->pik", R, point_map(self.joint_points_m[nodes], x_m))  # Rᵀ G
            cb.tie(_node_block_dofs(nodes, 3, self.off_joint), master, coef.reshape(-1, 6))
        if getattr(joint, "joint", "bonded") == "sliding":  # the face keeps u_z (the joint's z) continuous
            gap, plate = tied_nodes(joint.space, joint.geometry)
            for gn, pn in zip(gap, plate, strict=True):
                cb.tie([self.off_joint + 3 * gn + 2], [self.off_joint + 3 * pn + 2], [[1.0]])

    # ------------------------------------------------------------------ assembly

    def rigid_connection(self) -> MiddleEarModel:
        """The same ear (anatomy, drum mesh, solver) with the incus and the stapes rigidly joined:
        the reference of ΔH_V."""
        return MiddleEarModel(
            geometry=self.geometry,
            joint=None,
            drum_mesh_size_m=self.drum_mesh_size_m,
            solver=self._solver_name,
        )

    def _fixed_entries(self):
        """Positions (rows, cols) of the entries of everything but the joint model (moduli-independent)."""
        d, fp = self.drum, self.footplate
        dofs = [_element_dofs(d.triangles) + self.off_drum, _element_dofs(fp.triangles) + self.off_fp]
        rows = [np.repeat(x, x.shape[1], axis=1).ravel() for x in dofs]
        cols = [np.tile(x, (1, x.shape[1])).ravel() for x in dofs]
        out = self._outline_dofs()
        rows.append(np.repeat(out, 3, axis=1).ravel())
        cols.append(np.tile(out, (1, 3)).ravel())
        rows.append(np.repeat(self.body_dofs, 6))
        cols.append(np.tile(self.body_dofs, 6))
        return np.concatenate(rows), np.concatenate(cols)

    def _outline_dofs(self) -> np.ndarray:
        nodes = self.footplate.node_sets["outline"]
        return self.off_fp + NDOF * nodes[:, None] + np.arange(3)

    def ligament_springs(self, materials: EarMaterials) -> tuple[np.ndarray, np.ndarray]:
        """Attachment points (P, 3) (m) and 3 × 3 stiffnesses (P, 3, 3) (N/m) of the suspension.

        Anterior mallear ligament: three springs of k/3 along x, y and z at its attachment;
        posterior incudal ligament: lateral and medial bundles, isotropic (k I) at theirs.
        """
        g, m = self.geometry, materials
        pts = np.array([g.malleus_ligament_m, g.incudal_lateral_m, g.incudal_medial_m])
        k = np.array(
            [
                m.malleus_ligament_n_m / 3.0 * np.eye(3),
                m.incudal_lateral_n_m * np.eye(3),
                m.incudal_medial_n_m * np.eye(3),
            ]
        )
        return pts, k

    def _fixed_values(self, m: EarMaterials) -> np.ndarray:
        """The ear's entries (shells, annular springs, ligaments) for ``m``; the last ones kept
        (read-only): the seven cases and the transmission's checks share one ear."""
        kept = getattr(self, "_fixed_kept", None)
        if kept is not None and kept[0] == m:
            return kept[1]
        vals = self._fixed_values_for(m)
        vals.flags.writeable = False
        self._fixed_kept = (m, vals)
        return vals

    def _fixed_values_for(self, m: EarMaterials) -> np.ndarray:
        g, d, fp = self.geometry, self.drum, self.footplate
        drum = ShellMaterial(m.drum_e_pa, m.drum_nu, m.drum_thickness_m, DRUM_DENSITY_KG_M3)
        centre = ShellMaterial(
            m.footplate_e_pa, m.footplate_nu, g.footplate_centre_thickness_m, FOOTPLATE_DENSITY_KG_M3
        )
        rim = ShellMaterial(
            m.footplate_e_pa, m.footplate_nu, g.footplate_rim_thickness_m, FOOTPLATE_DENSITY_KG_M3
        )
        kd = element_stiffness(d.nodes_m, d.triangles, drum)
        kc = element_stiffness(fp.nodes_m, fp.triangles, centre)
        kr = element_stiffness(fp.nodes_m, fp.triangles, rim)
        kf = np.where(fp.rim[:, None, None], kr, kc)
        n = fp.normal
        block = m.annular_out_of_plane_n_m * np.outer(n, n) + m.annular_in_plane_n_m * (
            np.eye(3) - np.outer(n, n)
        )
        springs = np.tile(block.ravel(), len(fp.node_sets["outline"]))
        pts, k = self.ligament_springs(m)
        body = grounded_springs(g.body_reference_m, pts, k)
        return np.concatenate([kd.ravel(), kf.ravel(), springs, body.ravel()])

    def fixed_parts(self, m: EarMaterials) -> dict[str, np.ndarray]:
        """:meth:`_fixed_values` split by part: {part: its entries' values, zero elsewhere} (SI).

        Parts (the names of :class:`isj.damping.Damping`): ``eardrum``, ``footplate``,
        ``annular_ligament``, ``mallear_ligament``, ``incudal_ligaments``; they sum to
        :meth:`_fixed_values`. Also ``cochlea``: the direction n nᵀ (1 N·s/m in all) of a dashpot
        along the piston direction shared by the annular springs, to be scaled by R.
        """
        vals = self._fixed_values(m)
        n_out = len(self.footplate.node_sets["outline"])
        block = (3 * NDOF) ** 2  # one triangle's 18 × 18 stiffness
        sizes = [len(self.drum.triangles) * block, len(self.footplate.triangles) * block, 9 * n_out, 36]
        cuts = np.cumsum([0, *sizes])
        seg = {
            p: slice(cuts[i], cuts[i + 1])
            for i, p in enumerate(("eardrum", "footplate", "annular_ligament", "ligaments"))
        }
        if cuts[-1] != vals.size:
            raise RuntimeError("fixed_parts: the value layout of _fixed_values changed")
        out = {}
        for p in ("eardrum", "footplate", "annular_ligament"):
            out[p] = np.zeros_like(vals)
            out[p][seg[p]] = vals[seg[p]]
        pts, k = self.ligament_springs(m)
        for p, rows in (("mallear_ligament", [0]), ("incudal_ligaments", [1, 2])):
            kk = np.zeros_like(k)
            kk[rows] = k[rows]
            out[p] = np.zeros_like(vals)
            out[p][seg["ligaments"]] = grounded_springs(self.geometry.body_reference_m, pts, kk).ravel()
        nrm = self.footplate.normal
        out["cochlea"] = np.zeros_like(vals)
        out["cochlea"][seg["annular_ligament"]] = np.tile(np.outer(nrm, nrm).ravel() / n_out, n_out)
        return out

    def stiffness(self, materials: Materials | None = None, ear_materials: EarMaterials | None = None):
        """Reduced stiffness Tᵀ K T (CSR, SI) for the joint's and the ear's materials."""
        vals = [self._fixed_values(ear_materials or EarMaterials())]
        if self.joint is not None:
            vals.append(self.joint.stiffness_data(materials or Materials()))
        return self.pattern.matrix(np.concatenate(vals))

    def full_stiffness(self, materials: Materials | None = None, ear_materials: EarMaterials | None = None):
        """Unconstrained K (n_full × n_full, CSR) with the ground springs, before elimination (for tests)."""
        vals = [self._fixed_values(ear_materials or EarMaterials())]
        rows, cols = self._fixed_entries()
        if self.joint is not None:
            vals.append(self.joint.stiffness_data(materials or Materials()))
            rows = np.concatenate([rows, self.joint.pattern.rows() + self.off_joint])
            cols = np.concatenate([cols, self.joint.pattern.indices + self.off_joint])
        return sp.coo_matrix((np.concatenate(vals), (rows, cols)), shape=(self.n_full,) * 2).tocsr()

    @property
    def n_dofs(self) -> int:
        """Independent dofs (the size of the solved system)."""
        return self.T.shape[1]

    # ------------------------------------------------------------------ solve

    def free_solver(self) -> None:
        """Release the factorization :meth:`static` keeps (the next solve analyses again)."""
        solver, self._solver = self._solver, None
        if solver is not None:
            solver.free()

    def solve_reduced(self, K, f_reduced) -> np.ndarray:
        """Full dof vector(s) u = T q with K q = f_reduced, reusing the solver's analysis."""
        if self._solver is None:
            self._solver = make_solver(K, self._solver_name)
        self._solver.factor(K)
        q = self._solver.solve(f_reduced)
        return self.T @ np.asarray(q).reshape(self.n_dofs, -1)

    def static(
        self, materials: Materials | None = None, ear_materials: EarMaterials | None = None
    ) -> EarStaticResult:
        """Static response per Pa of uniform ear-canal pressure (pushing the drum medially).

        The model keeps its last :data:`STATIC_MEMO` results: the same materials again return
        the same result (its displacement read-only), as a new solve would bit for bit, without
        the factorization. The report's ear step and the transmission step's direct checks
        (:func:`fem.ear.dynamics.harmonic` takes the umbo's direction from this result) ask for
        the same designs.

        Parameters
        ----------
        materials : moduli of the embedded joint model (ignored by the rigid-joint variant)
        ear_materials : eardrum, footplate and spring constants (default: docs/ear.md §5.8)
        """
        materials = materials or Materials()
        ear_materials = ear_materials or EarMaterials()
        key = (materials, ear_materials)
        return kept_result(self, key, lambda: self._static(materials, ear_materials), STATIC_MEMO)

    def _static(self, materials: Materials, ear_materials: EarMaterials) -> EarStaticResult:
        t0 = time.perf_counter()
        K = self.stiffness(materials, ear_materials)
        t1 = time.perf_counter()
        fresh = self._solver is None
        u = self.solve_reduced(K, self.load_reduced)[:, 0]
        t2 = time.perf_counter()
        res = self.result(u, materials)
        t3 = time.perf_counter()
        res.timings_s = {
            "values": t1 - t0,
            ("analyse_factor_solve" if fresh else "factor_solve"): t2 - t1,
            "post": t3 - t2,
            "total": t3 - t0,
        }
        res.displacement.flags.writeable = False  # a kept result (static()): nobody may change it
        return res

    def drum_displacement(self, u) -> np.ndarray:
        """(N_drum, 3) eardrum translations (m)."""
        return u[self.off_drum : self.off_fp].reshape(-1, NDOF)[:, :3]

    def joint_displacement(self, u) -> np.ndarray:
        """Full dof vector of the joint model in its own frame (m), as ``PedicleJointModel`` numbers it."""
        return u[self.off_joint : self.off_body]

    def result(self, u, materials: Materials | None = None) -> EarStaticResult:
        """Outputs of a full dof vector ``u`` (per Pa if the load was 1 Pa)."""
        g = self.geometry
        drum = self.drum_displacement(u)
        umbo = drum[self.drum.node_sets["umbo"][0]]
        fp = u[self.off_fp : self.off_joint].reshape(-1, NDOF)[self.footplate.node_sets["centre"][0], :3]
        body = u[self.body_dofs]
        angles = [None] * 4
        if self.joint is not None:
            angles = [float(a) for a in self.joint.angles @ self.joint_displacement(u)]
        return EarStaticResult(
            umbo_vector_m_per_pa=umbo.copy(),
            eardrum_max_m_per_pa=float(np.linalg.norm(drum, axis=1).max()),
            footplate_m_per_pa=fp.copy(),
            footplate_piston_m_per_pa=float(fp @ np.asarray(g.piston_direction)),
            alpha_rad_per_pa=angles[0],
            beta_rad_per_pa=angles[1],
            alpha_ls_rad_per_pa=angles[2],
            beta_ls_rad_per_pa=angles[3],
            rotation_axis=axis_of_rotation(body[:3], body[3:], g.body_reference_m),
            body_m_rad_per_pa=body.copy(),
            materials=materials,
            displacement=u,
        )

    # ------------------------------------------------------------------ dynamics

    def mass(
        self, materials: Materials | None = None, ear_materials: EarMaterials | None = None, masses=None
    ):
        """Reduced mass Tᵀ M T (CSR, SI) on the stiffness's pattern (:func:`.dynamics.reduced_mass`)."""
        return reduced_mass(self, materials, ear_materials, masses)

    def frequency_response(
        self,
        freq_hz,
        materials: Materials | None = None,
        ear_materials: EarMaterials | None = None,
        damping=None,
        masses=None,
        pressure_pa: float = 1.0,
        cavities: str = "open",
    ):
        """Damped umbo, stapes (m), α and β (rad) at ``freq_hz`` (Hz), a ``FrequencyResponse``.

        At the ear-canal pressure amplitude ``pressure_pa`` (Pa; 1: per Pa); the outputs of
        :meth:`isj.lumped.ear.LumpedEar.frequency_response`, name by name. The solve and the
        full displacements: :func:`fem.ear.dynamics.harmonic`. ``cavities``: "open" or "intact",
        the middle-ear cavities' load (docs/circuit.md §13.3).
        """
        return harmonic(
            self, freq_hz, materials, ear_materials, damping, masses, pressure_pa, cavities=cavities
        ).response()

    def natural_frequencies_hz(
        self,
        n: int = 6,
        materials: Materials | None = None,
        ear_materials: EarMaterials | None = None,
        masses=None,
    ) -> np.ndarray:
        """The ``n`` lowest undamped natural frequencies (Hz), ascending.

        The mode shapes beside them: :func:`fem.ear.dynamics.natural_frequencies`.
        """
        return natural_frequencies(self, n, materials, ear_materials, masses).freq_hz

    def solve_cases(
        self, cases=None, ear_materials: EarMaterials | None = None
    ) -> dict[str, EarStaticResult]:
        """Results for named joint materials (default: the seven thesis cases), one assembly reused."""
        cases = THESIS_CASES if cases is None else cases
        return {c.name: self.static(c.materials(), ear_materials) for c in cases}
