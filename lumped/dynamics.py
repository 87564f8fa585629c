"""Lumped dynamics: a second-order model M q̈ + C q̇ + K q = B u, y = C_out q (docs/dynamics.md §4.6).

The model class, :class:`SecondOrderModel`, lives in :mod:`isj.lumped.second_order`
(matrices batched over designs, in the style of pyMOR's ``SecondOrderModel``).

The pedicle-and-joint chain in the x–z plane (:func:`chain_model`) has eight
coordinates (:data:`COORDINATES`), from the clamped face of the stapes head up:

- ``u_stapes``, ``th_stapes``: the stapes head (z 0 – z_gap) as a Timoshenko
  cantilever clamped at z = 0, its top's deflection and rotation (physical
  stiffness, no factor); everything above moves rigidly with its top;
- ``theta_joint``: the joint's rotation about its mid-plane z_j = (z_gap + z_plate)/2,
  spring k_j = P (z_load − z_j)/α_P so that the static α is the calibrated one;
- ``psi_root``: the pedicle's root turning in the plate, the calibrated
  ``pedicle_root`` compliance;
- ``w_tip``, ``phi_tip``: the pedicle as a Timoshenko cantilever, its tip's
  deflection and rotation relative to the root's tangent (EI from the calibrated
  ``pedicle_bending`` term: the tip rotation under the tip load is that term exactly);
- ``psi_top``: the pedicle's top turning in the incus (``pedicle_top``);
- ``s_joint``: the joint's shear translation in x (everything above z_j moves),
  k_s = f_shear (G_gap j_x j_y / t + G_cap 2 (j_x + 2 t_c) t_c / (t + 2 reach)): the
  gap as a bonded layer and the capsule's two walls parallel to x sheared over their
  whole span. f_shear is calibrated against FE second in-plane natural frequencies
  (:func:`calibration.pipeline.fit_shear`; 0.84 in the shipped calibration). With the
  sliding joint (``joint="sliding"``) the gap's face glides: it carries no shear and its
  term drops, k_s = f_shear G_cap 2 (j_x + 2 t_c) t_c / (t + 2 reach) (docs/lumped.md §3.14).

Why the stapes head and the walls' whole span: a chain clamped at z_j lacks the head's
bending and shear, so its errors grow with a soft stapes, and walls sheared over their free
length only make them grow with the capsule's share of the shear stiffness (that chain's
figures: docs/history.md). With both, the first two in-plane natural frequencies follow FE's
on the calibration's modal designs within the figures of docs/performance.md §8.3
(``benchmarks/dynamics.py``).

α = θ_joint and β = ψ_root + φ_tip + ψ_top are point-pair rotations, so the static
limit reproduces the calibrated static α and β exactly (the stapes head's and the
shear's deformations leave them unchanged). The mass is consistent: ∫ ρ A (g gᵀ +
w_x²/12 h hᵀ) dz over the FE regions (densities of docs/dynamics.md §4.2), g(z) and h(z) the x
displacement and rotation per unit coordinate (Hermite cubics along the stapes head
and the pedicle), by exact Gauss quadrature; the capsule's mass is left out. Damping
is the FE model's, per region (:class:`isj.damping.Damping`): each spring takes the loss
factors and Rayleigh b of the regions whose moduli set it, in proportion to their share
(:mod:`isj.lumped.damping`), each body's mass its region's Rayleigh a.

Outputs y = [α, β, u_x at the load centroid]; input u = the pressure (Pa).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isj.damping import Damping, resolve
from isj.design import DEFAULT_PRESSURE_PA, REGIONS, Geometry, Materials
from isj.errors import InvalidParameter

from .damping import damping_terms, region_stiffness
from .model import FACTOR_NAMES, Lever, equations, moduli_arrays
from .second_order import SecondOrderModel

OUTPUTS = ("alpha_rad", "beta_rad", "incus_ux_m")
#: Units of :data:`OUTPUTS`' amplitudes (at a given pressure amplitude).
UNITS = {"alpha_rad": "rad", "beta_rad": "rad", "incus_ux_m": "m"}


#: Coordinates of :func:`chain_model`, in order (m, rad, rad, rad, m, rad, rad, m).
COORDINATES = (
    "u_stapes",
    "th_stapes",
    "theta_joint",
    "psi_root",
    "w_tip",
    "phi_tip",
    "psi_top",
    "s_joint",
)

#: Default joint shear factor: 1 is the physical estimate (gap and capsule walls in shear).
DEFAULT_SHEAR_FACTOR = 1.0

#: Gauss–Legendre points per body for the consistent mass (exact: the integrands are
#: polynomials of degree ≤ 6 in z).
_GAUSS_POINTS = 4


@dataclass(frozen=True)
class ChainStiffness:
    """The chain's springs (arrays over designs, leading axis n_design; SI), see :func:`chain_stiffness`.

    Attributes
    ----------
    stapes : (n_design, 2, 2) the stapes head's Timoshenko cantilever stiffness on its top's
        deflection and rotation (N/m, N, N·m/rad)
    k_joint : joint rotational stiffness about z_j (N·m/rad)
    c_root, c_top : rotational compliances of the pedicle's root in the plate and of its top in
        the incus (rad/(N·m))
    beam : (n_design, 2, 2) the pedicle's Timoshenko cantilever stiffness on its tip's deflection
        and rotation (N/m, N, N·m/rad)
    k_shear : joint shear stiffness in x (N/m)
    alpha_per_pa, beta_per_pa : the calibrated static α, β per Pa (rad/Pa)
    """

    stapes: np.ndarray
    k_joint: np.ndarray
    c_root: np.ndarray
    c_top: np.ndarray
    beam: np.ndarray
    k_shear: np.ndarray
    alpha_per_pa: np.ndarray
    beta_per_pa: np.ndarray


def _levels(g: Geometry) -> dict[str, float]:
    """Heights (m): joint mid-plane, pedicle root and top, load centroid."""
    return {
        "j": (g.z_gap + g.z_plate) / 2,
        "r": g.z_pedicle,
        "t": g.z_incus,
        "load": g.z_incus + g.incus_length_m / 2,
    }


def _timoshenko(e_pa, factor, wx, wy, length, nu) -> np.ndarray:
    """(n, 2, 2) stiffness of a clamped Timoshenko cantilever on its tip's deflection and rotation.

    E I = E w_y w_x³ / 12 / ``factor``, shear G A κ with G = E / (2 (1 + ν)), κ = 10 (1 + ν)/(12 + 11 ν)
    (rectangle); Φ = 12 EI / (κ G A L²); K = EI / ((1 + Φ) L³) [[12, −6L], [−6L, (4 + Φ) L²]]. Units:
    N/m, N, N·m/rad.
    """
    e = np.atleast_1d(np.asarray(e_pa))
    e = e.astype(np.result_type(e.dtype, float))  # complex moduli (complex step) stay complex
    ei = e * wy * wx**3 / 12 / factor
    kappa = 10 * (1 + nu) / (12 + 11 * nu)
    phi = 12 * ei / (kappa * e / (2 * (1 + nu)) * wx * wy * length**2)
    L = length
    out = np.empty(e.shape + (2, 2), dtype=e.dtype)
    c = ei / ((1 + phi) * L**3)
    out[..., 0, 0] = 12 * c
    out[..., 0, 1] = out[..., 1, 0] = -6 * L * c
    out[..., 1, 1] = (4 + phi) * L**2 * c
    return out


def chain_stiffness(
    factors,
    shear_factor: float = DEFAULT_SHEAR_FACTOR,
    geometry: Geometry | None = None,
    materials: Materials | None = None,
    joint: str = "bonded",
    scaling: dict | None = None,
    **moduli,
) -> ChainStiffness:
    """The chain's springs from the calibrated static factors, for arrays of moduli (Pa).

    See the module docstring for each spring. The pedicle's tip rotation under the load
    (a force P at z_load, P (z_load − z_top) about the tip) is P L d_mid / (E_p I / f_beam), the
    ``pedicle_bending`` term of :func:`lumped.model.equations`, exactly: a Timoshenko element's
    shear adds to the deflection only.

    Parameters
    ----------
    factors : calibrated static factors (``lumped.model.FACTOR_NAMES`` order)
    shear_factor : joint shear factor f_shear (dimensionless, > 0)
    geometry, materials : dimensions (m); Poisson's ratio from ``materials``
    joint : "bonded" (the gap and the capsule in shear) or "sliding" (the capsule only)
    scaling : the calibration's ``geometry_scaling`` (:meth:`lumped.model.Lever.from_geometry`)
    **moduli : Young's moduli (Pa), floats or broadcastable arrays

    Returns
    -------
    ChainStiffness, arrays with leading axis n_design (1 for floats)
    """
    if not np.isfinite(shear_factor) or shear_factor <= 0:
        raise InvalidParameter(f"shear_factor = {shear_factor!r}: must be a finite number > 0")
    g = geometry or Geometry()
    E = moduli_arrays(**moduli)
    return _springs(factors, shear_factor, g, (materials or Materials()).nu, E, joint, scaling)


def _springs(
    factors, shear_factor: float, g: Geometry, nu: float, E: dict, joint: str = "bonded", scaling=None
) -> ChainStiffness:
    """:func:`chain_stiffness` on checked moduli arrays ``E``; plain arithmetic, so complex moduli
    (the complex step of :func:`isj.lumped.damping.region_stiffness`) give complex springs."""
    lever = Lever.from_geometry(g, scaling)
    fac = np.asarray(factors, dtype=float)
    f = dict(zip(FACTOR_NAMES, fac, strict=True))
    a_pa, b_pa = equations(E, fac, lever, joint)
    shape = np.broadcast_shapes(*(np.shape(v) for v in E.values()))
    nd = int(np.prod(shape))
    E = {k: np.broadcast_to(v, shape).reshape(nd) for k, v in E.items()}
    a_pa, b_pa = (np.broadcast_to(v, shape).reshape(nd) for v in (a_pa, b_pa))
    z = _levels(g)
    punch = g.pedicle_x_m**2 * g.pedicle_y_m
    foundation = 1 + f["root_foundation"] * (1e3 * E["gap_e_pa"] / E["plate_e_pa"]) ** 0.25
    jx, jy, t, tc = g.joint_x_m, g.joint_y_m, g.gap_thickness_m, g.capsule_thickness_m
    span = t + 2 * g.capsule_reach_m
    if joint not in ("bonded", "sliding"):
        raise InvalidParameter(f"joint = {joint!r}: must be bonded or sliding")
    gap = E["gap_e_pa"] * jx * jy / t if joint == "bonded" else 0.0  # a sliding face carries no shear
    k_shear = shear_factor / (2 * (1 + nu)) * (gap + E["capsule_e_pa"] * 2 * (jx + 2 * tc) * tc / span)
    return ChainStiffness(
        stapes=_timoshenko(E["stapes_e_pa"], 1.0, jx, jy, g.z_gap, nu),
        k_joint=lever.force_per_pa * (z["load"] - z["j"]) / a_pa,
        c_root=f["pedicle_root"] / (E["plate_e_pa"] * punch * foundation),
        c_top=f["pedicle_top"] / (E["incus_e_pa"] * punch),
        beam=_timoshenko(
            E["pedicle_e_pa"], f["pedicle_bending"], g.pedicle_x_m, g.pedicle_y_m, g.pedicle_length_m, nu
        ),
        k_shear=k_shear,
        alpha_per_pa=a_pa,
        beta_per_pa=b_pa,
    )


@dataclass(frozen=True)
class JointCoupling:
    """The chain's static joint-and-pedicle coupling on the coordinates (α, β), per design (SI).

    Attributes
    ----------
    stiffness : (n_design, 2, 2) stiffness on (α, β) (N·m/rad)
    motion : (n_design, 2, 2) the incus's rigid motion relative to the stapes per unit (α, β): row 0
        its x displacement extrapolated to the joint's mid-plane z_j (m/rad), row 1 its rotation
        about y (rad/rad, both 1)
    """

    stiffness: np.ndarray
    motion: np.ndarray


def joint_coupling(
    factors,
    geometry: Geometry | None = None,
    materials: Materials | None = None,
    *,
    joint: str = "bonded",
    **moduli,
) -> JointCoupling:
    """The chain's joint and pedicle, massless and condensed onto (α, β), for models that embed the joint.

    The springs of :func:`chain_stiffness` on q = [θ_joint, ψ_root, w_tip, φ_tip, ψ_top] (the stapes
    head rigid, no joint shear: the static calibration has neither) carry the incus relative to
    the stapes by d = (u_x at z_j, rotation) = T q. Exact static condensation onto d gives the
    stiffness (T K⁻¹ Tᵀ)⁻¹; α = θ_joint and β = ψ_root + φ_tip + ψ_top are then linear in d, α,β =
    A d, and (α, β) serve as the coordinates: d = A⁻¹ (α, β), stiffness A⁻ᵀ (T K⁻¹ Tᵀ)⁻¹ A⁻¹. Under
    any load on the incus (a force along x and a moment about y) this is the chain's static
    response, with the pedicle's pivot following the load; under the isolated model's load it
    gives the calibrated α and β.

    Parameters
    ----------
    factors : calibrated static factors
    geometry, materials : dimensions (m); Poisson's ratio from ``materials``
    joint : "bonded" or "sliding", the joint the factors were calibrated on
        (:func:`lumped.model.equations`; no shear here, so nothing else depends on it)
    **moduli : Young's moduli (Pa), floats or broadcastable arrays

    Returns
    -------
    JointCoupling, arrays with leading axis n_design
    """
    g = geometry or Geometry()
    return _coupling(factors, g, (materials or Materials()).nu, moduli_arrays(**moduli), joint)


def _coupling(factors, g: Geometry, nu: float, E: dict, joint: str = "bonded") -> JointCoupling:
    """:func:`joint_coupling` on checked moduli arrays ``E`` (complex allowed: plain arithmetic)."""
    st = _springs(factors, DEFAULT_SHEAR_FACTOR, g, nu, E, joint)
    lv = _levels(g)
    nd = st.k_joint.size
    K = np.zeros((nd, 5, 5), dtype=st.k_joint.dtype)
    K[:, 0, 0] = st.k_joint
    K[:, 1, 1] = 1 / st.c_root
    K[:, 2:4, 2:4] = st.beam
    K[:, 4, 4] = 1 / st.c_top
    dz_r, dz_t = lv["j"] - lv["r"], lv["j"] - lv["t"]
    T = np.array([[0.0, dz_r, 1.0, dz_t, dz_t], [1.0, 1.0, 0.0, 1.0, 1.0]])  # d = T q
    out = np.array([[1.0, 0.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 1.0, 1.0]])  # (α, β) = out q
    flex_q = np.linalg.solve(K, np.broadcast_to(T.T, (nd, 5, 2)))  # K⁻¹ Tᵀ
    k_d = np.linalg.inv(T @ flex_q)  # (nd, 2, 2) on d
    A = out @ flex_q @ k_d  # (α, β) = A d
    Ai = np.linalg.inv(A)
    return JointCoupling(stiffness=np.swapaxes(Ai, -1, -2) @ k_d @ Ai, motion=Ai)


def _hermite(s, length):
    """Cubic Hermite shapes of a clamped element's tip deflection and rotation at s ∈ [0, 1], and slopes."""
    return 3 * s**2 - 2 * s**3, length * (s**3 - s**2), 6 * (s - s**2) / length, 3 * s**2 - 2 * s


def chain_shapes(z, geometry: Geometry | None = None) -> tuple[np.ndarray, np.ndarray]:
    """x displacement (m) and rotation about y (rad) per unit coordinate at heights ``z`` (m).

    Parameters
    ----------
    z : heights in [0, z_top] (m)
    geometry : dimensions (m)

    Returns
    -------
    g, h : (len(z), 8) each, columns in :data:`COORDINATES` order
    """
    geo = geometry or Geometry()
    lv = _levels(geo)
    z = np.atleast_1d(np.asarray(z, dtype=float))
    gu, gr = np.zeros(z.shape + (8,)), np.zeros(z.shape + (8,))
    hs, L = geo.z_gap, geo.pedicle_length_m
    n_w, n_p, d_w, d_p = _hermite(np.clip(z / hs, 0.0, 1.0), hs)
    above = z > hs  # rigid with the stapes head's top
    gu[:, 0], gu[:, 1] = np.where(above, 1.0, n_w), np.where(above, z - hs, n_p)
    gr[:, 0], gr[:, 1] = np.where(above, 0.0, d_w), np.where(above, 1.0, d_p)
    up, on, top = z > lv["j"], z > lv["r"], z > lv["t"]
    n_w, n_p, d_w, d_p = _hermite(np.clip((z - lv["r"]) / L, 0.0, 1.0), L)
    gu[:, 2], gr[:, 2] = np.where(up, z - lv["j"], 0.0), up
    gu[:, 3], gr[:, 3] = np.where(on, z - lv["r"], 0.0), on
    gu[:, 4], gr[:, 4] = np.where(on, n_w, 0.0), np.where(on & ~top, d_w, 0.0)
    gu[:, 5] = np.where(top, z - lv["t"], np.where(on, n_p, 0.0))
    gr[:, 5] = np.where(top, 1.0, np.where(on, d_p, 0.0))
    gu[:, 6], gr[:, 6] = np.where(top, z - lv["t"], 0.0), top
    gu[:, 7] = up
    return gu, gr


def chain_mass(
    geometry: Geometry | None = None, materials: Materials | None = None, per_region: bool = False
):
    """Consistent 8 × 8 mass of :data:`COORDINATES` (kg, kg·m, kg·m²); independent of the moduli.

    ∫ ρ A (g gᵀ + w_x²/12 h hᵀ) dz over the stapes head, the gap, the plate, the pedicle and the
    incus block (g, h from :func:`chain_shapes`), by Gauss–Legendre quadrature (exact).
    ``per_region``: a dict region → its bodies' mass instead (the capsule's is left out).
    """
    g = geometry or Geometry()
    mat = materials or Materials()
    rho_b, rho_s = mat.bone_density_kg_m3, mat.soft_density_kg_m3
    jx, jy, z_j = g.joint_x_m, g.joint_y_m, _levels(g)["j"]
    bodies = [  # (region, density, w_x, w_y, z0, z1): no body straddles a kink of the shapes
        ("stapes", rho_b, jx, jy, 0.0, g.z_gap),  # stapes head
        ("gap", rho_s, jx, jy, g.z_gap, z_j),  # lower half of the gap
        ("gap", rho_s, jx, jy, z_j, g.z_plate),  # upper half of the gap
        ("plate", rho_b, jx, jy, g.z_plate, g.z_pedicle),
        ("pedicle", rho_b, g.pedicle_x_m, g.pedicle_y_m, g.z_pedicle, g.z_incus),
        ("incus", rho_b, g.incus_x_m, g.incus_y_m, g.z_incus, g.z_top),  # incus block
    ]
    x, w = np.polynomial.legendre.leggauss(_GAUSS_POINTS)
    parts = {}
    for region, rho, wx, wy, z0, z1 in bodies:
        zq = (z0 + z1) / 2 + (z1 - z0) / 2 * x
        dz = rho * wx * wy * (z1 - z0) / 2 * w
        gu, gr = chain_shapes(zq, g)
        Mi = np.einsum("q,qi,qj->ij", dz, gu, gu) + wx**2 / 12 * np.einsum("q,qi,qj->ij", dz, gr, gr)
        parts[region] = parts.get(region, 0.0) + Mi
    if per_region:
        return {r: (m + m.T) / 2 for r, m in parts.items()}
    M = sum(parts.values())
    return (M + M.T) / 2  # exactly symmetric


def _chain_stiffness_matrix(st: ChainStiffness) -> np.ndarray:
    """(n_design, 8, 8) stiffness of :data:`COORDINATES` from the springs (complex springs allowed)."""
    nd = st.k_joint.size
    K = np.zeros((nd, 8, 8), dtype=np.result_type(st.k_joint, st.stapes, float))
    K[:, 0:2, 0:2] = st.stapes
    K[:, 2, 2] = st.k_joint
    K[:, 3, 3] = 1 / st.c_root
    K[:, 4:6, 4:6] = st.beam
    K[:, 6, 6] = 1 / st.c_top
    K[:, 7, 7] = st.k_shear
    return K


def chain_model(
    factors,
    shear_factor: float = DEFAULT_SHEAR_FACTOR,
    geometry: Geometry | None = None,
    materials: Materials | None = None,
    rayleigh_a_per_s=None,
    rayleigh_b_s=None,
    loss_factor=None,
    *,
    damping: Damping | str | None = None,
    joint: str = "bonded",
    scaling: dict | None = None,
    **moduli,
) -> SecondOrderModel:
    """The eight-coordinate chain (module docstring) for one or many designs.

    Parameters
    ----------
    factors : the calibrated static factors (``lumped.model.FACTOR_NAMES`` order)
    shear_factor : the joint shear factor f_shear (dimensionless; calibrated to FE second in-plane
        natural frequencies by :func:`calibration.pipeline.fit_shear`)
    geometry, materials : dimensions (m); ν and densities (kg/m³) from ``materials``
    damping : :class:`isj.damping.Damping` or a preset name (default: the published loss factors
        per region, docs/dynamics.md §4.3)
    rayleigh_a_per_s, rayleigh_b_s, loss_factor : changes to ``damping`` (1/s, s, dimensionless):
        a number for every region or a mapping region → value; None leaves it
    joint : "bonded" or "sliding" (the joint's shear spring: gap and capsule, or capsule only)
    scaling : the calibration's ``geometry_scaling`` (:meth:`lumped.model.Lever.from_geometry`)
    **moduli : Young's moduli (Pa), floats or broadcastable arrays (``lumped.model.MODULI``);
        floats only (or none): one design, no design axis

    Returns
    -------
    SecondOrderModel : input the pressure (Pa), outputs :data:`OUTPUTS` (rad, rad, m); each spring
    with the loss factors and Rayleigh b of the regions that set it (``K_loss`` and ``E``), each
    body's mass with its region's Rayleigh a
    """
    g = geometry or Geometry()
    d = resolve(
        damping, rayleigh_a_per_s=rayleigh_a_per_s, rayleigh_b_s=rayleigh_b_s, loss_factor=loss_factor
    )
    nu = (materials or Materials()).nu
    E = moduli_arrays(**moduli)
    K = _chain_stiffness_matrix(_springs(factors, shear_factor, g, nu, E, joint, scaling))
    nd = K.shape[0]
    M = np.broadcast_to(chain_mass(g, materials), (nd, 8, 8)).copy()
    uniform = d.uniform_values(REGIONS)
    if uniform is not None:  # one η, a and b for every region: proportional, no split needed
        a, b, eta = uniform
        Ed, K_loss = a * M + b * K, eta * K
    else:
        parts = region_stiffness(
            lambda Ec: _chain_stiffness_matrix(_springs(factors, shear_factor, g, nu, Ec, joint, scaling)), E
        )
        masses = {
            r: np.broadcast_to(m, (nd, 8, 8)) for r, m in chain_mass(g, materials, per_region=True).items()
        }
        Ed, K_loss = damping_terms(d, parts, masses)
    g_load = chain_shapes([_levels(g)["load"]], g)[0][0]  # u_x at the load centroid per unit q
    force = Lever.from_geometry(g).force_per_pa
    Bm = np.broadcast_to((force * g_load)[:, None], (nd, 8, 1)).copy()
    C = np.zeros((3, 8))
    C[0, 2] = 1.0  # α = θ_joint
    C[1, [3, 5, 6]] = 1.0  # β = ψ_root + φ_tip + ψ_top
    C[2] = g_load
    Cm = np.broadcast_to(C, (nd, 3, 8)).copy()
    if all(np.ndim(v) == 0 for v in moduli.values()):  # one design: no design axis
        M, K, Ed, K_loss, Bm, Cm = M[0], K[0], Ed[0], K_loss[0], Bm[0], Cm[0]
    return SecondOrderModel(M=M, E=Ed, K=K, B=Bm, C=Cm, K_loss=K_loss)


def chain_outputs(model: SecondOrderModel, freq_hz, pressure_pa: float = DEFAULT_PRESSURE_PA) -> np.ndarray:
    """Complex α, β (rad) and incus u_x (m) at ``freq_hz`` for a pressure amplitude (Pa), any designs.

    (n_freq, 3), or (n_design, n_freq, 3) for a batched model; for one design as an
    :class:`isj.responses.FrequencyResponse`: :meth:`isj.lumped.api.LumpedModel.frequency_response`.
    """
    return model.freq_resp(freq_hz)[..., 0] * pressure_pa
