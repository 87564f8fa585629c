"""The whole ear split into parts, its joint model condensed onto the two rigid bodies it is tied to.

Parts. The ear's reduced stiffness K = Tᵀ K_full T (:class:`fem.ear.middle_ear.MiddleEarModel`)
is the sum of one real matrix per part, and so is its mass:

- stiffness: each region of the joint model (``incus``, ``pedicle``, ... at the build moduli),
  ``eardrum``, ``footplate``, and the spring sets ``annular_ligament``,
  ``mallear_ligament`` and ``incudal_ligaments``;
- mass: each region of the joint model, ``eardrum``, ``footplate``, ``malleus_incus`` and
  ``stapes_superstructure`` (their Rayleigh a is that of ``incus`` and ``stapes``);
- dashpots: ``cochlea``, a unit (1 N·s/m) resistance along the piston direction shared equally
  by the annular springs' outline nodes, in parallel with them.

The dynamic stiffness for any damping is then (:func:`part_coefficients`)

    Z(ω) = Σ_p (1 + iη_p + iω b_p) K_p + iω Σ_m a_m M_m + iω R D_cochlea − ω² M,

the law of :mod:`isj.damping`; any projection VᵀZV is the same sum of projected parts, so a new
set of loss factors costs nothing but the sum.

Condensation (Craig–Bampton). The joint model holds 96 % of the ear's dofs but is tied to the
rest only through the malleus–incus body and the stapes superstructure: its interior J meets the
rest through those bodies' twelve dofs B. So u_J = Ψ x_B + Φ z, with Ψ = −K_JJ⁻¹ K_JB the exact
static condensation and Φ a few interior vectors (:func:`condense_joint`): the inertia of the
static shapes, K_JJ⁻¹ (M_JJ Ψ + M_JB), and the next one; the first-order change of the
condensation with each region's loss factor, K_JJ⁻¹ (K_r,JJ Ψ + K_r,JB); and the inertia of those.
Statics are exact for real moduli. The loss-factor vectors are needed because the joint's loss
factor (0.15) differs from the bone's (0.01), which changes the joint's own deformation in a way
no real static shape follows; with all four kinds the condensed ear matches full harmonic solves
on the coarse test ear to about 1e-4 in α and β (the measurements: docs/history.md).
"""

from __future__ import annotations

import contextlib
import functools
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from isj.design import Materials
from isj.ear import EarMasses, EarMaterials
from isj.kinematics import rigid_mass

from ..assembly import lame_unit, region_entries
from .shell import ShellMaterial
from .shell import mass_matrix as shell_mass_matrix

#: Spring sets of the ear, in the order of :meth:`MiddleEarModel._fixed_values`.
SPRING_PARTS = ("annular_ligament", "mallear_ligament", "incudal_ligaments")
#: Mass parts outside the joint model, and the damping name whose Rayleigh a each takes.
RIGID_MASS_PARTS = {"malleus_incus": "incus", "stapes_superstructure": "stapes"}


@dataclass
class EarParts:
    """The ear's reduced matrices (n_dofs × n_dofs CSR, SI), part by part (module docstring).

    Attributes
    ----------
    stiffness : name → K_p (N/m, N, N·m/rad entries)
    mass : name → M_p (kg, kg·m, kg·m²)
    dashpots : name → D_p for a unit coefficient (per N·s/m)
    load : (n_dofs,) reduced load of 1 Pa of ear-canal pressure (N/Pa)
    footplate_area_m2 : converts the cochlear impedance to the ``cochlea`` dashpot's R = Z_C A²
    timings_s : seconds spent
    """

    stiffness: dict[str, sp.csr_matrix]
    mass: dict[str, sp.csr_matrix]
    dashpots: dict[str, sp.csr_matrix]
    load: np.ndarray
    footplate_area_m2: float
    timings_s: dict = field(default_factory=dict)

    def total_stiffness(self) -> sp.csr_matrix:
        return _sum(self.stiffness.values())

    def total_mass(self) -> sp.csr_matrix:
        return _sum(self.mass.values())


def _sum(mats) -> sp.csr_matrix:
    out = None
    for A in mats:
        out = A.copy() if out is None else out + A
    return out.tocsr()


def _compact(A: sp.csr_matrix) -> sp.csr_matrix:
    A = sp.csr_matrix(A, copy=True)  # a copy: the pattern's index arrays are shared, never pruned
    A.eliminate_zeros()
    return A


def _restrict(model, A_full: sp.spmatrix) -> sp.csr_matrix:
    """Tᵀ A T for a sparse full-dof matrix A touching few dofs (only T's rows on them are used)."""
    A = sp.csr_matrix(A_full)
    rows = np.unique(np.concatenate([sp.coo_matrix(A).row, sp.coo_matrix(A).col]))
    Ts = model.T[rows]
    return _compact((Ts.T @ A[rows][:, rows] @ Ts).tocsr())


def _point_block(model, dofs, M6) -> sp.csr_matrix:
    dofs = np.asarray(dofs)
    return sp.coo_matrix((M6.ravel(), (np.repeat(dofs, 6), np.tile(dofs, 6))), shape=(model.n_full,) * 2)


def ear_parts(
    model,
    materials: Materials | None = None,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
) -> EarParts:
    """Split the ear's reduced K and M into parts (module docstring); their sums are the model's own.

    Raises RuntimeError when the parts do not add up to :meth:`MiddleEarModel.stiffness` (a
    guard against a change of the model's entry layout that this split does not know).
    """
    from .dynamics import footplate_mass_matrix, stapes_rigid_mass

    t0 = time.perf_counter()
    materials = materials or Materials()
    em = ear_materials or EarMaterials()
    ms = masses or EarMasses()
    g, d, pat = model.geometry, model.drum, model.pattern
    fixed = model.fixed_parts(em)  # {part: values on the fixed entries}, the damping's names
    n_fixed = model.n_fixed_entries

    def on_pattern(values):
        at = np.flatnonzero(values)
        return pat.part_matrix(at, values[at])

    stiff = {p: on_pattern(v) for p, v in fixed.items() if p != "cochlea"}
    dashpots = {"cochlea": on_pattern(fixed["cochlea"])}
    mass = {}
    if ms.drum_density_kg_m3 > 0:
        drum = ShellMaterial(em.drum_e_pa, em.drum_nu, em.drum_thickness_m, ms.drum_density_kg_m3)
        Md = sp.coo_matrix(shell_mass_matrix(d.nodes_m, d.triangles, drum))
        mass["eardrum"] = _restrict(
            model,
            sp.coo_matrix(
                (Md.data, (Md.row + model.off_drum, Md.col + model.off_drum)), shape=(model.n_full,) * 2
            ),
        )
    Mf = sp.coo_matrix(footplate_mass_matrix(model, em, ms))
    if Mf.nnz:
        mass["footplate"] = _restrict(
            model,
            sp.coo_matrix(
                (Mf.data, (Mf.row + model.off_fp, Mf.col + model.off_fp)), shape=(model.n_full,) * 2
            ),
        )
    st = stapes_rigid_mass(model, em, ms)
    x_body = np.asarray(g.body_reference_m)
    x_stapes = np.asarray(g.stapes_head_m) if model.joint is not None else x_body
    m_mi = rigid_mass(ms.malleus_incus_kg, ms.malleus_incus_gyration_m, ms.malleus_incus_centroid(g), x_body)
    m_st = rigid_mass(
        st["superstructure_kg"], ms.stapes_gyration_m, st["superstructure_centroid_m"], x_stapes
    )
    mass["malleus_incus"] = _restrict(model, _point_block(model, model.body_dofs, m_mi))
    mass["stapes_superstructure"] = _restrict(model, _point_block(model, model.stapes_dofs, m_st))
    if model.joint is not None:
        j = model.joint
        lam, mu = lame_unit(materials.nu)
        j.mass_data(materials)  # assembles the regions' unit masses once
        for r, rm in j.regions.items():
            # region r alone: its entries of combine(), without the zeros of the other regions
            at, ks = region_entries(j.pattern, rm, (materials.youngs(r) * lam, materials.youngs(r) * mu))
            stiff[r] = pat.part_matrix(n_fixed + at, ks)
            at, mr = region_entries(j.pattern, rm, (materials.density(r), 0.0), part="mass")
            mass[r] = pat.part_matrix(n_fixed + at, mr)
    parts = EarParts(stiff, mass, dashpots, np.asarray(model.load_reduced, float), float(g.footplate_area_m2))
    K = model.stiffness(materials, em)
    err = abs(parts.total_stiffness() - K).max()
    if not err <= 1e-10 * abs(K).max():
        raise RuntimeError(f"ear_parts: the parts' stiffness differs from the model's by {err:.3g}")
    parts.timings_s["parts"] = time.perf_counter() - t0
    return parts


# ---------------------------------------------------------------------------- damping


def part_coefficients(damping, parts: EarParts) -> dict:
    """Each part's damping: {"eta": {stiffness part: η}, "b_s": {..: b (s)}, "a_per_s": {mass part: a (1/s)},
    "c_n_s_m": {dashpot: c (N·s/m)}}.

    ``damping``: an :class:`isj.damping.Damping`, a preset name or None (the published loss factors).
    Its tables are by part name; the rigid bodies take the Rayleigh a of ``incus`` and ``stapes``
    (:data:`RIGID_MASS_PARTS`), the cochlea's dashpot is R = Z_C A² (N·s/m).
    """
    from isj.damping import resolve

    d = resolve(damping)
    return {
        "eta": {p: d.loss_factor[p] for p in parts.stiffness},
        "b_s": {p: d.rayleigh_b_s[p] for p in parts.stiffness},
        "a_per_s": {p: d.rayleigh_a_per_s[RIGID_MASS_PARTS.get(p, p)] for p in parts.mass},
        "c_n_s_m": {"cochlea": d.cochlear_resistance_n_s_m(parts.footplate_area_m2)},
    }


def dynamic_terms(parts_k, parts_m, parts_d, coef) -> tuple:
    """(A0, A1, M) with Z(ω) = A0 + iω A1 − ω² M from parts (sparse or dense), :func:`part_coefficients`."""
    A0 = sum((1 + 1j * coef["eta"][p]) * K for p, K in parts_k.items())
    A1 = sum(coef["b_s"][p] * K for p, K in parts_k.items())
    A1 = A1 + sum(coef["a_per_s"][p] * M for p, M in parts_m.items())
    A1 = A1 + sum(coef["c_n_s_m"][p] * D for p, D in parts_d.items())
    M = sum(parts_m.values())
    return A0, A1, M


# ---------------------------------------------------------------------------- condensation


def orthonormalize(X: np.ndarray, weights: np.ndarray, tol: float = 1e-10, against: np.ndarray | None = None):
    """Columns spanning X's to relative accuracy ``tol``, orthonormal in the weighted dot product Σ w² x y.

    ``weights``: per dof, √ of the mass matrix's diagonal (√kg for a translation, √(kg·m²) for a
    rotation): a kinetic-energy-like scale that puts metres and radians on one footing. Not the
    stiffness inner product: the drum's drilling rotations make K's condition number ≈ 1e16,
    and a K-orthonormal basis built in floating point loses the response's span (docs/history.md).
    Columns are normalised, orthogonalised against ``against`` (already
    orthonormal, in the same product) twice, then a column-pivoted QR keeps those whose pivot
    exceeds ``tol`` times the largest.
    """
    import scipy.linalg as sla

    w = np.asarray(weights, float)[:, None]
    Y = np.asarray(X, float) * w
    norms = np.linalg.norm(Y, axis=0)
    Y = Y[:, norms > 0] / norms[norms > 0]
    A = None if against is None or against.shape[1] == 0 else against * w
    if A is not None:
        for _ in range(2):  # twice: one pass leaves cancellation errors of order eps × growth
            Y -= A @ (A.T @ Y)
    if Y.shape[1] == 0:
        return np.zeros((X.shape[0], 0))
    Q, Rm, _ = sla.qr(Y, mode="economic", pivoting=True)
    d = np.abs(np.diag(Rm))
    # against a basis, what is left of a unit column is measured against 1, not the largest rest
    rank = int(np.sum(d > tol * (1.0 if A is not None else d[0])))
    Q = Q[:, :rank]
    if A is not None and rank:
        Q -= A @ (A.T @ Q)
        Q, _ = np.linalg.qr(Q)
    return Q / w


@dataclass
class CondensedEar:
    """The ear with its joint model condensed (module docstring): y = [x_R, z], q[R] = x_R,
    q[J] = Ψ x_R[b] + Φ z.

    Attributes
    ----------
    stiffness, mass, dashpots : name → level-1 matrix (CSR, SI), as :class:`EarParts`
    load : (n,) reduced load of 1 Pa (N/Pa)
    R, J : the reduced model's dofs kept, and those of the joint's interior
    b : positions in R of the malleus–incus body's and the stapes superstructure's dofs (12,)
    psi, phi : (n_J, 12) static condensation, (n_J, m) interior vectors
    timings_s : seconds spent
    """

    stiffness: dict
    mass: dict
    dashpots: dict
    load: np.ndarray
    R: np.ndarray
    J: np.ndarray
    b: np.ndarray
    psi: np.ndarray
    phi: np.ndarray
    n_q: int
    timings_s: dict = field(default_factory=dict)

    @property
    def n_dofs(self) -> int:
        return self.R.size + self.phi.shape[1]

    def lift(self, y: np.ndarray) -> np.ndarray:
        """The reduced model's dof vectors q (n_q,) or (n_q, k) of level-1 vectors y."""
        y = np.asarray(y)
        nr = self.R.size
        q = np.zeros((self.n_q,) + y.shape[1:], dtype=y.dtype)
        q[self.R] = y[:nr]
        q[self.J] = self.psi @ y[:nr][self.b] + self.phi @ y[nr:]
        return q

    def restrict(self, C: sp.spmatrix) -> np.ndarray:
        """Output rows C (k, n_q) acting on q, as rows (k, n) acting on y: C V1 (dense)."""
        C = sp.csr_matrix(C)
        CJ = C[:, self.J]
        out = np.hstack([C[:, self.R].toarray(), np.asarray(CJ @ self.phi)])
        out[:, self.b] += np.asarray(CJ @ self.psi)
        return out


def condense_joint(
    parts: EarParts,
    model,
    enrich: tuple[str, ...] = ("mass", "damping", "cross"),
    tol: float = 1e-10,
    backend: str = "auto",
) -> CondensedEar:
    """Condense the joint model's interior onto the two rigid bodies (module docstring).

    Parameters
    ----------
    parts : :func:`ear_parts` of ``model`` (with the joint inside)
    enrich : interior vectors to add to the static condensation: ``"mass"`` (inertia of the
        static shapes), ``"mass2"`` (and the next Krylov vector), ``"damping"`` (change with
        each region's loss factor), ``"cross"`` (the inertia of those changes)
    tol : relative norm below which an interior vector counts as dependent
    """
    from isj.fem.solvers import make_solver

    t0 = time.perf_counter()
    if model.joint is None:
        raise ValueError("condense_joint: the model has no joint to condense")
    fq = model.free
    inJ = (fq >= model.off_joint) & (fq < model.off_body)
    J, R = np.flatnonzero(inJ), np.flatnonzero(~inJ)
    B = np.searchsorted(fq, np.concatenate([model.body_dofs, model.stapes_dofs]))

    K = parts.total_stiffness()
    KJ = K[J]
    if (abs(KJ[:, R]) @ np.ones(R.size) - abs(KJ[:, B]) @ np.ones(12) > 0).any():
        raise RuntimeError("condense_joint: the joint's interior meets the ear outside its two rigid bodies")
    KJJ = KJ[:, J].tocsr()
    solver = make_solver(KJJ, backend)
    try:
        solver.factor(KJJ)
        t1 = time.perf_counter()
        psi, X = _static_shapes_and_interior(solver, KJ[:, B], parts, model, J, B, enrich)
    finally:
        if hasattr(solver, "free"):
            solver.free()
    t2 = time.perf_counter()
    phi = orthonormalize(X, np.sqrt(np.abs(parts.total_mass().diagonal()[J])), tol)
    out = _level1_parts(parts, model, J, R, B, psi, phi)
    out.timings_s = {"factor": t1 - t0, "solves": t2 - t1, "project": time.perf_counter() - t2}
    return out


def _static_shapes_and_interior(solver, KJB, parts, model, J, B, enrich) -> tuple[np.ndarray, np.ndarray]:
    """(Ψ, X): the joint interior's static shapes for unit motions of the bodies' 12 dofs, and the
    interior vectors ``enrich`` asks for, solved with ``solver`` (K_JJ factored)."""
    fq, nJ = model.free, J.size
    psi = -np.asarray(solver.solve(KJB.toarray())).reshape(nJ, 12)
    Vpsi = np.zeros((fq.size, 12))  # Ψ lifted to the free dofs, with B's unit dofs
    Vpsi[J] = psi
    Vpsi[B, np.arange(12)] = 1.0
    rhs = []
    if "mass" in enrich or "mass2" in enrich:
        rhs.append((parts.total_mass() @ Vpsi)[J])
    if "damping" in enrich:
        # rigid motions of both bodies strain nothing: the stapes's six columns span the change
        rhs += [(parts.stiffness[r] @ Vpsi[:, 6:])[J] for r in model.joint.regions]
    X = np.asarray(solver.solve(np.hstack(rhs))).reshape(nJ, -1) if rhs else np.zeros((nJ, 0))
    MJJ = parts.total_mass()[J][:, J] if {"mass2", "cross"} & set(enrich) else None
    if "mass2" in enrich:  # the next inertia correction of the static shapes
        X = np.hstack([X, np.asarray(solver.solve(MJJ @ X[:, :12])).reshape(nJ, 12)])
    if "cross" in enrich and "damping" in enrich:  # inertia of the loss factors' corrections
        Xd = X[:, 12 if "mass" in enrich else 0 :][:, : 6 * len(model.joint.regions)]
        X = np.hstack([X, np.asarray(solver.solve(MJJ @ Xd)).reshape(nJ, -1)])
    return psi, X


def _level1_parts(parts, model, J, R, B, psi, phi) -> CondensedEar:
    """Every part of the ear on (the rest R, the interior coordinates z), the bodies' dofs B
    lifted through Ψ and the joint interior spanned by Ψ and Φ."""
    b = np.searchsorted(R, B)
    idx = np.concatenate([J, B])
    nR, m = R.size, phi.shape[1]
    W = np.block([[psi, phi], [np.eye(12), np.zeros((12, m))]])  # the lift of (x_b, z) to q[J ∪ B]
    n1 = nR + m
    pos = np.concatenate([b, nR + np.arange(m)])
    rr, cc = (x.ravel() for x in np.meshgrid(pos, pos, indexing="ij"))
    joint_parts = set(model.joint.regions)

    def level1(name, A):
        if name in joint_parts:
            D = W.T @ np.asarray(sp.csr_matrix(A)[idx][:, idx] @ W)  # a joint part acts on J ∪ B only
            D = 0.5 * (D + D.T)  # symmetric to rounding, as the part
            return sp.csr_matrix((D.ravel(), (rr, cc)), shape=(n1, n1))
        S = sp.csr_matrix(A)[R][:, R].tocoo()
        return sp.csr_matrix((S.data, (S.row, S.col)), shape=(n1, n1))

    load = np.concatenate([parts.load[R], phi.T @ parts.load[J]])
    load[b] += psi.T @ parts.load[J]  # zero for the pressure load, which acts on the drum only
    return CondensedEar(
        stiffness={k: level1(k, A) for k, A in parts.stiffness.items()},
        mass={k: level1(k, A) for k, A in parts.mass.items()},
        dashpots={k: level1(k, A) for k, A in parts.dashpots.items()},
        load=load,
        R=R,
        J=J,
        b=b,
        psi=psi,
        phi=phi,
        n_q=model.free.size,
    )


@contextlib.contextmanager
def one_blas_thread():
    """Run numpy's OpenBLAS on one thread inside the block (no-op where it cannot be found).

    The per-frequency solves are many small dense operations, for which OpenBLAS's threads on a
    loaded machine cost far more than they gain (docs/history.md).
    """
    lib = _openblas()
    if lib is None:
        yield
        return
    before = lib.scipy_openblas_get_num_threads64_()
    lib.scipy_openblas_set_num_threads64_(1)
    try:
        yield
    finally:
        lib.scipy_openblas_set_num_threads64_(before)


@functools.cache
def _openblas():
    """numpy's OpenBLAS (found once: reading /proc/self/maps at each call cost 2.5 ms)."""
    import ctypes

    try:
        with open("/proc/self/maps") as fh:
            paths = {line.split()[-1] for line in fh if "scipy_openblas64" in line and "numpy" in line}
        lib = ctypes.CDLL(sorted(paths)[0]) if paths else None
        if lib is not None:
            lib.scipy_openblas_get_num_threads64_.restype = ctypes.c_int
            lib.scipy_openblas_set_num_threads64_.argtypes = [ctypes.c_int]
        return lib
    except (OSError, AttributeError, IndexError):
        return None


def lowest_frequency_hz(K, M, lu) -> float:
    """Lowest natural frequency (Hz) of K x = ω² M x (shift-invert about 0 on the factor ``lu``)."""
    from isj.fem.solvers import lanczos_start

    op = spla.LinearOperator(K.shape, matvec=lu.solve, dtype=float)
    w2 = spla.eigsh(K, k=1, M=M, sigma=0.0, OPinv=op, tol=1e-6, v0=lanczos_start(K.shape[0]))[0]
    return float(np.sqrt(max(w2[0], 0.0)) / (2 * np.pi))
