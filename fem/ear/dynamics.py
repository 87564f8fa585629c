"""Dynamics of the whole cat middle ear (docs/ear.md §5.11): mass, harmonic response, natural frequencies.

On the reduced system of :class:`fem.ear.middle_ear.MiddleEarModel` (u = T q):

    (K_r + i L_r + iω C_r − ω² M_r) q̂ = f_r p̂,   K_r = Tᵀ K T, M_r = Tᵀ M T, ...

with the damping of docs/dynamics.md §4.3 per part (:class:`isj.damping.Damping`; default: the
published loss factors): L = Σ_p η_p K_p over the drum, the footplate, the spring sets and the
joint model's regions, C = Σ_p (b_p K_p + a_p M_p) plus the cochlear resistance R = Z_C A² as a
dashpot along the piston direction shared by the annular springs (R/n each); f_r the reduced
load of 1 Pa of ear-canal pressure.

Mass data (:class:`isj.ear.EarMasses`, the one place the lumped ear
:mod:`lumped.ear` reads too; all estimates but the bone density):

- eardrum: the shell's consistent mass, density 1200 kg/m³ (rotary inertia lumped,
  :func:`fem.ear.shell.mass_matrix`), as the lumped ear's condensed drum;
- footplate: the shell's consistent mass, bone, 2000 kg/m³ (docs/dynamics.md §4.2), centre 20 µm
  and rim 200 µm thick;
- malleus + incus: 6 mg, isotropic radius of gyration 1.0 mm about its centroid (the
  body's reference point by default), a 6 × 6 rigid-body mass at the reference point:
  m GᵀG + m r_g² diag(0, I) with G = [I, −[c − x₀]×];
- stapes: 0.5 mg for the whole stapes, the lumped ear's one rigid stapes. Here the
  footplate shell carries its own mass (≈ 0.2 mg by default, measured on the mesh), the
  superstructure's rigid body the rest, at the centroid that puts the whole stapes's
  centroid where :meth:`isj.ear.EarMasses.stapes_centroid` says (0.3 of the crura's
  height above the footplate), radius of gyration 0.4 mm about its own centroid. So the
  stapes's mass and first moment equal the lumped ear's; its rotary inertia does not (the
  footplate's distributed inertia is anisotropic; :func:`stapes_rigid_mass` gives both);
- the embedded joint model's regions (bone 2000, soft tissue 1100 kg/m³,
  :meth:`isj.design.Materials.density`): its consistent mass
  (:meth:`fem.model.PedicleJointModel.mass_data`); the lumped ear neglects them.

Every mass entry lies on an entry of K's pattern, so M_r is stored on K_r's CSR
pattern and Z = αK_r + βM_r is one axpy on the data; the complex symmetric Z is
factored by PARDISO (mtype 6, analysed once per call) or SuperLU; the static solution
(first, for the umbo's direction) comes from the same solver, the model's static one untouched.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from isj.cavities import DEFAULT_CAVITIES, cavity_factor, check_cavities
from isj.damping import Damping, resolve, warn_rayleigh_band
from isj.design import Materials
from isj.ear import EarMasses, EarMaterials
from isj.errors import InvalidParameter
from isj.kinematics import rigid_mass
from isj.responses import FrequencyResponse
from isj.validate import check_frequencies

from ..dynamics import region_weighted_data
from ..solvers import lanczos_start, make_complex_symmetric_solver, make_indefinite_solver, make_solver
from .constraints import rigid_body_modes
from .shell import ShellMaterial
from .shell import mass_matrix as shell_mass_matrix

#: Output names, as :data:`lumped.ear.OUTPUTS`: umbo along its static direction (m/Pa), stapes
#: piston (m/Pa), α and β (rad/Pa; zero for the rigid joint).
OUTPUTS = ("umbo_m", "stapes_m", "alpha_rad", "beta_rad")


def damping_parts(model) -> tuple[str, ...]:
    """The :class:`isj.damping.Damping` names this ear has: shells, spring sets, the joint's regions."""
    joint = tuple(model.joint.regions) if model.joint is not None else ()
    return ("eardrum", "footplate", "mallear_ligament", "incudal_ligaments", "annular_ligament") + joint


def footplate_mass_matrix(model, ear_materials: EarMaterials | None = None, masses: EarMasses | None = None):
    """The footplate shell's consistent mass (6N × 6N CSR; kg, kg·m²): centre and rim thicknesses."""
    g, fp = model.geometry, model.footplate
    m = ear_materials or EarMaterials()
    rho = (masses or EarMasses()).footplate_density_kg_m3
    if rho == 0:
        return sp.csr_matrix((6 * len(fp.nodes_m),) * 2)
    out = None
    for tris, t in (
        (fp.triangles[~fp.rim], g.footplate_centre_thickness_m),
        (fp.triangles[fp.rim], g.footplate_rim_thickness_m),
    ):
        Mi = shell_mass_matrix(fp.nodes_m, tris, ShellMaterial(m.footplate_e_pa, m.footplate_nu, t, rho))
        out = Mi if out is None else out + Mi
    return out.tocsr()


def stapes_rigid_mass(model, ear_materials: EarMaterials | None = None, masses: EarMasses | None = None):
    """How the FE ear splits the stapes's mass, and its 6 × 6 rigid mass against the lumped ear's.

    Returns
    -------
    dict: ``footplate_kg``, ``footplate_centroid_m`` (3,), ``superstructure_kg``,
    ``superstructure_centroid_m`` (3,), ``fe_6x6`` and ``lumped_6x6`` (the whole stapes moving
    rigidly, at the footplate's centre, SI), as arrays.
    Raises InvalidParameter when the footplate shell alone outweighs ``stapes_kg``.
    """
    g = model.geometry
    ms = masses or EarMasses()
    F = np.asarray(g.footplate_centre_m)
    R = rigid_body_modes(model.footplate.nodes_m, F)
    M6_fp = R.T @ (footplate_mass_matrix(model, ear_materials, ms) @ R)
    m_fp = float(M6_fp[0, 0])
    S = -M6_fp[:3, 3:] / m_fp if m_fp > 0 else np.zeros((3, 3))  # = −[c − F]× ... skew(c − F)
    c_fp = F + np.array([S[2, 1], S[0, 2], S[1, 0]])
    m_sup = ms.stapes_kg - m_fp
    if m_sup < 0:
        raise InvalidParameter(
            f"stapes_kg = {ms.stapes_kg!r} kg: must be >= the footplate shell's mass {m_fp:.4g} kg "
            f"(footplate_density_kg_m3 = {ms.footplate_density_kg_m3!r})"
        )
    c_s = np.asarray(ms.stapes_centroid(g))
    c_sup = (ms.stapes_kg * c_s - m_fp * c_fp) / m_sup if m_sup > 0 else c_s
    fe = M6_fp + rigid_mass(m_sup, ms.stapes_gyration_m, c_sup, F)
    return {
        "footplate_kg": m_fp,
        "footplate_centroid_m": c_fp,
        "superstructure_kg": m_sup,
        "superstructure_centroid_m": c_sup,
        "fe_6x6": fe,
        "lumped_6x6": rigid_mass(ms.stapes_kg, ms.stapes_gyration_m, c_s, F),
    }


def full_mass(
    model,
    materials: Materials | None = None,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
    weights=None,
) -> sp.csr_matrix:
    """Unconstrained M (n_full × n_full CSR, SI) of the whole ear, before elimination.

    ``weights``: a factor per part (names of :data:`isj.damping.MASS_PARTS`: ``eardrum``,
    ``footplate``, the joint's regions; the malleus–incus body takes ``incus``'s, the stapes
    superstructure ``stapes``'s) for Σ_p w_p M_p, the Rayleigh a term; None: M itself.
    """
    w = weights if weights is not None else dict.fromkeys(("eardrum", "footplate", "incus", "stapes"), 1.0)
    g = model.geometry
    em = ear_materials or EarMaterials()
    ms = masses or EarMasses()
    d = model.drum
    parts = []  # (coo block, offset)
    if ms.drum_density_kg_m3 > 0:
        drum = ShellMaterial(em.drum_e_pa, em.drum_nu, em.drum_thickness_m, ms.drum_density_kg_m3)
        parts.append((w["eardrum"] * shell_mass_matrix(d.nodes_m, d.triangles, drum).tocoo(), model.off_drum))
    parts.append((w["footplate"] * footplate_mass_matrix(model, em, ms).tocoo(), model.off_fp))
    rows = [p.row.astype(np.int64) + off for p, off in parts]
    cols = [p.col.astype(np.int64) + off for p, off in parts]
    vals = [p.data for p, _ in parts]
    x_body = np.asarray(g.body_reference_m)
    x_stapes = np.asarray(g.stapes_head_m) if model.joint is not None else x_body
    st = stapes_rigid_mass(model, em, ms)
    blocks = (
        (
            model.body_dofs,
            w["incus"]
            * rigid_mass(
                ms.malleus_incus_kg, ms.malleus_incus_gyration_m, ms.malleus_incus_centroid(g), x_body
            ),
        ),
        (
            model.stapes_dofs,
            w["stapes"]
            * rigid_mass(
                st["superstructure_kg"], ms.stapes_gyration_m, st["superstructure_centroid_m"], x_stapes
            ),
        ),
    )
    for dofs, M6 in blocks:
        rows.append(np.repeat(dofs, 6))
        cols.append(np.tile(dofs, 6))
        vals.append(M6.ravel())
    if model.joint is not None:
        j = model.joint
        mat = materials or Materials()
        vals.append(j.mass_data(mat) if weights is None else region_weighted_data(j, mat, w, "mass"))
        rows.append(j.pattern.rows().astype(np.int64) + model.off_joint)
        cols.append(j.pattern.indices.astype(np.int64) + model.off_joint)
    M = sp.coo_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(model.n_full,) * 2
    )
    return M.tocsr()


def _data_on_pattern(A: sp.csr_matrix, indptr, indices) -> np.ndarray:
    """A's values on a CSR pattern (sorted) that contains A's nonzeros."""
    n = len(indptr) - 1
    A = sp.csr_matrix(A)
    A.sum_duplicates()
    A.sort_indices()
    kp = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr)) * n + indices
    ka = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr)) * n + A.indices
    pos = np.minimum(np.searchsorted(kp, ka), kp.size - 1)
    ok = kp[pos] == ka
    if not np.all(ok | (A.data == 0)):
        raise RuntimeError("the reduced mass has entries outside the reduced stiffness's pattern")
    out = np.zeros(kp.size)
    np.add.at(out, pos[ok], A.data[ok])
    return out


def reduced_mass(
    model,
    materials: Materials | None = None,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
) -> sp.csr_matrix:
    """Tᵀ M T (CSR, SI) on the pattern of :meth:`MiddleEarModel.stiffness` (cached per inputs)."""
    key = (materials or Materials(), ear_materials or EarMaterials(), masses or EarMasses())
    cache = model.__dict__.setdefault("_mass_cache", {})
    if key not in cache:
        Mf = full_mass(model, *key)
        Mr = (model.T.T @ Mf @ model.T).tocsr()
        p = model.pattern
        data = _data_on_pattern(Mr, p.indptr, p.indices)
        cache.clear()  # one entry: a new set of inputs replaces the old
        cache[key] = sp.csr_matrix((data, p.indices, p.indptr), shape=(p.n, p.n))
    return cache[key]


def damping_data(
    model,
    damping: Damping | str | None = None,
    materials: Materials | None = None,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """L = Σ_p η_p K_p and C = Σ_p (b_p K_p + a_p M_p) + R n nᵀ as data on K's reduced pattern (SI).

    Parts: the drum, the footplate, the three spring sets
    (:meth:`fem.ear.middle_ear.MiddleEarModel.fixed_parts`) and the joint model's regions; the
    cochlear resistance R = Z_C A (A the footplate's area) shared by the annular springs along
    the piston direction. Rayleigh a: the mass of each part (:func:`full_mass`'s ``weights``).
    """
    d = resolve(damping)
    em = ear_materials or EarMaterials()
    mat = materials or Materials()
    parts = model.fixed_parts(em)
    shells = [p for p in parts if p != "cochlea"]
    r_cochlea = d.cochlear_resistance_n_s_m(model.geometry.footplate_area_m2)
    vl = [sum(d.loss_factor[p] * parts[p] for p in shells)]
    vc = [sum(d.rayleigh_b_s[p] * parts[p] for p in shells) + r_cochlea * parts["cochlea"]]
    if model.joint is not None:
        vl.append(region_weighted_data(model.joint, mat, d.loss_factor))
        vc.append(region_weighted_data(model.joint, mat, d.rayleigh_b_s))
    L, C = (model.pattern.matrix(np.concatenate(v)).data for v in (vl, vc))
    a = d.rayleigh_a_per_s
    if any(a[p] > 0 for p in ("eardrum", "footplate", "incus", "stapes", *damping_parts(model)) if p in a):
        p = model.pattern
        Ma = (model.T.T @ full_mass(model, mat, em, masses, weights=a) @ model.T).tocsr()
        C = C + _data_on_pattern(Ma, p.indptr, p.indices)
    return L, C


@dataclass
class EarHarmonicResult:
    """Complex response of the whole ear per Pa of ear-canal pressure at each frequency (SI).

    Attributes
    ----------
    freq_hz : (n,) frequencies (Hz)
    umbo_m_per_pa : (n,) umbo displacement along its static direction of motion (m/Pa)
    stapes_m_per_pa : (n,) footplate centre's displacement along the piston direction (m/Pa)
    alpha_rad_per_pa, beta_rad_per_pa : (n,) joint and pedicle angles (rad/Pa); None for the
        rigid joint
    umbo_vector_m_per_pa, footplate_m_per_pa : (n, 3) complex displacement vectors (m/Pa)
    umbo_direction : (3,) the umbo's static direction of motion
    static : the static solution (:class:`fem.ear.middle_ear.EarStaticResult`)
    timings_s : seconds (stiffness_mass; factor_solve: every frequency's, and the static solve
        where the model does not keep it; per_frequency)
    """

    freq_hz: np.ndarray
    umbo_m_per_pa: np.ndarray
    stapes_m_per_pa: np.ndarray
    alpha_rad_per_pa: np.ndarray | None
    beta_rad_per_pa: np.ndarray | None
    umbo_vector_m_per_pa: np.ndarray
    footplate_m_per_pa: np.ndarray
    umbo_direction: np.ndarray
    static: object = None
    timings_s: dict = field(default_factory=dict)
    displacement: np.ndarray | None = field(default=None, repr=False)
    pressure_pa: float = 1.0

    def outputs(self) -> np.ndarray:
        """(n, 4) complex, columns :data:`OUTPUTS` (α, β zero for the rigid joint), as the lumped ear's."""
        n = self.freq_hz.size
        a = np.zeros(n, complex) if self.alpha_rad_per_pa is None else self.alpha_rad_per_pa
        b = np.zeros(n, complex) if self.beta_rad_per_pa is None else self.beta_rad_per_pa
        return np.column_stack([self.umbo_m_per_pa, self.stapes_m_per_pa, a, b])

    def response(self):
        """:meth:`outputs` as an :class:`isj.responses.FrequencyResponse` (m, m, rad, rad).

        At the ear-canal pressure amplitude :attr:`pressure_pa` (Pa; 1: per Pa), the outputs
        and their order those of :meth:`isj.lumped.ear.LumpedEar.frequency_response`, so the two
        compare name by name.
        """
        units = ("m", "m", "rad", "rad")
        return FrequencyResponse(
            self.freq_hz, self.outputs(), OUTPUTS, units, input_amplitude=self.pressure_pa
        )

    def to_dict(self) -> dict:
        def c(v):
            return None if v is None else [[float(x.real), float(x.imag)] for x in np.asarray(v)]

        return {
            "freq_hz": [float(f) for f in self.freq_hz],
            **{f"{k}_re_im": c(getattr(self, f"{k}_per_pa")) for k in ("umbo_m", "stapes_m")},
            "alpha_rad_re_im": c(self.alpha_rad_per_pa),
            "beta_rad_re_im": c(self.beta_rad_per_pa),
            "timings_s": dict(self.timings_s),
        }


def harmonic(
    model,
    freq_hz,
    materials: Materials | None = None,
    ear_materials: EarMaterials | None = None,
    damping: Damping | None = None,
    masses: EarMasses | None = None,
    pressure_pa: float = 1.0,
    keep_displacement: bool = False,
    cavities: str = DEFAULT_CAVITIES,
) -> EarHarmonicResult:
    """Damped harmonic response of the whole ear to ``pressure_pa`` (Pa) of ear-canal pressure.

    Parameters
    ----------
    model : :class:`fem.ear.middle_ear.MiddleEarModel`
    freq_hz : frequencies (Hz), >= 0
    materials : the embedded joint's moduli and densities (ignored by the rigid joint)
    ear_materials : eardrum, footplate and springs (docs/ear.md §5.8)
    damping : :class:`isj.damping.Damping` or a preset name (default: the published loss factors
        per part and the cat cochlear resistance, docs/dynamics.md §4.3)
    masses : :class:`isj.ear.EarMasses` (estimates)
    keep_displacement : keep the full complex dof vectors (n_freq, n_full)
    cavities : "open" (default) or "intact": the middle-ear cavities' back pressure on the drum
        (:mod:`isj.cavities`, docs/circuit.md §13.3); the static solution stays the open ear's

    Returns
    -------
    :class:`EarHarmonicResult`, per Pa when ``pressure_pa`` = 1. One complex factorization
    per frequency (its analysis shared by all frequencies).
    """
    freqs = check_frequencies(freq_hz)
    check_cavities(cavities)
    if not np.isfinite(pressure_pa):
        raise InvalidParameter(f"pressure_pa = {pressure_pa!r} Pa: must be a finite number")
    damping = resolve(damping)
    materials = materials or Materials()
    names = damping_parts(model)
    warn_rayleigh_band(damping, float(freqs.min()), float(freqs.max()), names)
    t0 = time.perf_counter()
    K = model.stiffness(materials, ear_materials)
    M = reduced_mass(model, materials, ear_materials, masses)
    L, C = damping_data(model, damping, materials, ear_materials, masses)
    t1 = time.perf_counter()
    f = model.load_reduced * pressure_pa
    q = _harmonic_solutions(model, (K, M, L, C), f, 2 * np.pi * freqs, damping.damped(names))
    # the umbo's direction is the static solution's: the model's own (kept per design: the report's
    # ear step has solved it), by a real SPD factorization rather than a complex one
    static = model.static(materials, ear_materials)
    d_umbo = static.umbo_vector_m_per_pa / np.linalg.norm(static.umbo_vector_m_per_pa)
    t2 = time.perf_counter()
    if cavities != "open" and pressure_pa != 0:  # fᵀq per Pa: the drum's volume displacement
        q *= cavity_factor(freqs, q @ model.load_reduced / pressure_pa, cavities)[:, None]
    u = (model.T @ q.T).T  # (n_freq, n_full)
    umbo, fp, alpha_r, beta_r = _point_motions(model, u)
    return EarHarmonicResult(
        freq_hz=freqs,
        umbo_m_per_pa=umbo @ d_umbo,
        stapes_m_per_pa=fp @ np.asarray(model.geometry.piston_direction),
        alpha_rad_per_pa=alpha_r,
        beta_rad_per_pa=beta_r,
        umbo_vector_m_per_pa=umbo,
        footplate_m_per_pa=fp,
        umbo_direction=d_umbo,
        static=static,
        pressure_pa=float(pressure_pa),
        timings_s={
            "stiffness_mass": t1 - t0,
            "factor_solve": t2 - t1,
            "per_frequency": (t2 - t1) / freqs.size,
        },
        displacement=u if keep_displacement else None,
    )


def _system_data(K, M_data, L, C, w, damped: bool) -> np.ndarray:
    """Z(ω)'s data on K's pattern.

    Damped: K + iL + iωC − ω²M (complex symmetric); undamped: K − ω²M (real symmetric indefinite).
    """
    if damped:
        # real and imaginary parts in place: the same numbers as K + i(L + ωC) − ω²M, with one
        # complex array instead of three (the peak memory of the whole ear's direct solves)
        data = np.empty(K.data.size, dtype=complex)
        np.subtract(K.data, w**2 * M_data, out=data.real)
        np.add(L, w * C, out=data.imag)
        return data
    return K.data - w**2 * M_data


def _harmonic_solutions(model, system, f, w, damped: bool) -> np.ndarray:
    """Z(ω) q = f at each ω of ``w`` (rad/s), by one solver: one analysis, one factorization per ω.

    Parameters
    ----------
    model : :class:`fem.ear.middle_ear.MiddleEarModel`
    system : (K, M, L, C): the reduced stiffness and mass (CSR) and the damping data on K's pattern
    f : (n_dofs,) reduced load
    w : (n,) angular frequencies (rad/s)
    damped : whether L or C is nonzero (complex symmetric solver; real indefinite otherwise)

    Returns
    -------
    (n, n_dofs) complex harmonic solutions.
    """
    K, M, L, C = system
    backend = "superlu" if model._solver_name == "superlu" else "auto"
    solver = None
    q = np.zeros((w.size, model.n_dofs), dtype=complex)
    try:
        for i, wi in enumerate(w):
            data = _system_data(K, M.data, L, C, wi, damped)
            Z = sp.csr_matrix((data, K.indices, K.indptr), shape=K.shape)
            if solver is None:
                make = make_complex_symmetric_solver if damped else make_indefinite_solver
                solver = make(Z, backend)
            solver.factor(Z)
            q[i] = np.ravel(solver.solve(f))
    finally:
        if solver is not None:
            solver.free()
    return q


def _point_motions(model, u: np.ndarray):
    """The umbo's and the footplate centre's (n, 3) displacements and α, β (n,) of full dof vectors ``u``.

    α and β are None for the rigid joint.
    """
    drum_umbo = model.drum.node_sets["umbo"][0]
    fp_centre = model.footplate.node_sets["centre"][0]
    ndof = 6
    umbo = u[:, model.off_drum + ndof * drum_umbo : model.off_drum + ndof * drum_umbo + 3]
    fp = u[:, model.off_fp + ndof * fp_centre : model.off_fp + ndof * fp_centre + 3]
    alpha_r = beta_r = None
    if model.joint is not None:
        ang = model.joint.angles[:2] @ u[:, model.off_joint : model.off_body].T
        alpha_r, beta_r = ang[0], ang[1]
    return umbo, fp, alpha_r, beta_r


@dataclass
class EarModes:
    """Lowest natural frequencies (Hz) of the undamped whole ear and mass-normalised mode shapes.

    Attributes
    ----------
    freq_hz : (n,) ascending
    shapes_reduced : (n_dofs, n) q-vectors, M_r-orthonormal (qᵢᵀ M_r qⱼ = δᵢⱼ, kg^-1/2 m units)
    shapes : (n_full, n) full dof vectors T q
    """

    freq_hz: np.ndarray
    shapes_reduced: np.ndarray
    shapes: np.ndarray


def natural_frequencies(
    model,
    n: int = 6,
    materials: Materials | None = None,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
) -> EarModes:
    """The ``n`` lowest natural frequencies of K_r q = ω² M_r q (shift-invert Lanczos about 0)."""
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 1 <= n < model.n_dofs - 1:
        raise InvalidParameter(f"n = {n!r}: must be an integer in [1, {model.n_dofs - 2}]")
    K = model.stiffness(materials, ear_materials)
    M = reduced_mass(model, materials, ear_materials, masses)
    solver = make_solver(K, model._solver_name)  # its own: the static solver's state is left alone
    try:
        solver.factor(K)
        opinv = spla.LinearOperator(K.shape, matvec=lambda x: np.ravel(solver.solve(x)), dtype=float)
        v0 = lanczos_start(K.shape[0])  # fixed: the same modes, bit for bit, on every run
        w2, vec = spla.eigsh(K, k=int(n), M=M, sigma=0.0, which="LM", OPinv=opinv, tol=1e-10, v0=v0)
    finally:
        if hasattr(solver, "free"):
            solver.free()
    order = np.argsort(w2)
    w2, vec = w2[order], vec[:, order]
    return EarModes(
        freq_hz=np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi),
        shapes_reduced=vec,
        shapes=np.asarray(model.T @ vec),
    )


def modal_damping(
    model,
    n: int = 6,
    materials: Materials | None = None,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
    damping: Damping | str | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``n`` lowest natural frequencies (Hz) and their damping ratios ζ by modal projection.

    ζ_m = q_mᵀ L q_m / (2 ω_m²) + q_mᵀ C q_m / (2 ω_m) for the M_r-orthonormal undamped modes
    (:func:`natural_frequencies`) and :func:`damping_data`'s L and C: exact for proportional
    damping, the diagonal of the projected damping otherwise.
    """
    modes = natural_frequencies(model, n, materials, ear_materials, masses)
    L, C = damping_data(model, damping, materials, ear_materials, masses)
    p = model.pattern
    Ls, Cs = (sp.csr_matrix((v, p.indices, p.indptr), shape=(p.n, p.n)) for v in (L, C))
    q = modes.shapes_reduced
    w = 2 * np.pi * modes.freq_hz
    zeta = np.einsum("im,im->m", q, Ls @ q) / (2 * w**2) + np.einsum("im,im->m", q, Cs @ q) / (2 * w)
    return modes.freq_hz, zeta
