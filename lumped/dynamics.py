"""Lumped dynamics: a second-order model M q̈ + C q̇ + K q = B u, y = C_out q (docs/dynamics.md §4.6).

In the style of pyMOR's ``SecondOrderModel``: the matrices are arrays, batched
over designs (leading axis), and :meth:`SecondOrderModel.freq_resp` returns
(n_freq, n_out, n_in) for one design, (n_design, n_freq, n_out, n_in) for many.

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
  (:func:`calibration.pipeline.fit_shear`; 0.84 in the shipped calibration).

Why these two additions to a joint-and-pedicle chain: on the shipped calibration's 24
FE modal designs, a chain clamped at z_j, with the capsule walls sheared over their free
length t + 2 (reach − bond) only, reached f1 within 7.4 % and, with its shear factor
fitted, f2 within 30 %; the errors grew with a soft stapes (the head's bending and shear
were missing) and with the capsule's share of the shear stiffness. With the stapes head
and the walls' whole span: f1 within 1.2 %, f2 within 3.0 % (training) and 4.6 %
(held-out), ``benchmarks/dynamics.py``.

α = θ_joint and β = ψ_root + φ_tip + ψ_top are point-pair rotations, so the static
limit reproduces the calibrated static α and β exactly (the stapes head's and the
shear's deformations leave them unchanged). The mass is consistent: ∫ ρ A (g gᵀ +
w_x²/12 h hᵀ) dz over the FE regions (densities of docs/dynamics.md §4.2), g(z) and h(z) the x
displacement and rotation per unit coordinate (Hermite cubics along the stapes head
and the pedicle), by exact Gauss quadrature; the capsule's mass is left out. Damping
is the FE model's: Rayleigh C = a M + b K and/or a structural loss factor, K(1 + iη).

Outputs y = [α, β, u_x at the load centroid]; input u = the pressure (Pa).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isj.design import DEFAULT_PRESSURE_PA, Geometry, InvalidParameter, Materials
from isj.validate import check_frequencies

from .model import FACTOR_NAMES, Lever, equations, moduli_arrays

OUTPUTS = ("alpha_rad", "beta_rad", "incus_ux_m")
#: Units of :data:`OUTPUTS`' amplitudes (at a given pressure amplitude).
UNITS = {"alpha_rad": "rad", "beta_rad": "rad", "incus_ux_m": "m"}


@dataclass(frozen=True)
class SecondOrderModel:
    """M q̈ + E q̇ + K(1 + iη) q = B u,  y = C q  (arrays; a leading design axis is allowed).

    ``M``, ``E``, ``K``: (..., n, n); ``B``: (..., n, n_in); ``C``: (..., n_out, n);
    ``loss_factor`` η (dimensionless). SI units throughout.
    """

    M: np.ndarray
    E: np.ndarray
    K: np.ndarray
    B: np.ndarray
    C: np.ndarray
    loss_factor: float = 0.0

    def freq_resp(self, freq_hz) -> np.ndarray:
        """Transfer function C (K(1+iη) + iωE − ω²M)⁻¹ B at ``freq_hz`` (Hz).

        Returns (n_freq, n_out, n_in), or (n_design, n_freq, n_out, n_in) for batched matrices.

        With proportional damping (E diagonal in the undamped modes, as Rayleigh damping is) and
        M positive definite, the response is summed over all the modes (exact): below the first
        natural frequency as the static response C (K(1+iη))⁻¹ B from a direct solve plus each
        mode's dynamic part (so that ω = 0 is the static solve), above it as the plain modal
        sum; otherwise one dense solve per design and frequency.
        """
        f = check_frequencies(freq_hz)
        w = 2 * np.pi * f
        batched = self.M.ndim == 3
        M, E, K, B, C = (x if batched else x[None] for x in (self.M, self.E, self.K, self.B, self.C))
        modal = _modal(M, E, K)
        eta = 1 + 1j * self.loss_factor
        if modal is not None:
            w2, Phi, e_m = modal  # (d, n), (d, n, n), (d, n)
            cphi = np.einsum("dij,djm->dim", C, Phi)
            phib = np.einsum("djm,djk->dmk", Phi, B)
            k_m = w2[:, None, :] * eta  # (d, 1, n)
            iwe = 1j * w[None, :, None] * e_m[:, None, :]
            den = k_m + iwe - (w**2)[None, :, None]  # (d, f, n)
            # below the first mode: the static solve plus each mode's dynamic part, 1/den − 1/k_m
            # written without cancellation; above it: the plain modal sum
            static = np.einsum("dij,djk->dik", C, np.linalg.solve(K, B)) / eta  # (d, n_out, n_in)
            below = (w**2)[None, :] < w2[:, :1]  # (d, f)
            part = np.where(below[..., None], ((w**2)[None, :, None] - iwe) / (den * k_m), 1 / den)
            H = np.einsum("dim,dfm,dmk->dfik", cphi, part, phib, optimize=True)
            H = np.where(below[..., None, None], static[:, None] + H, H)
            return H if batched else H[0]
        # (design, freq, n, n): one small dense solve per design and frequency, vectorised
        Z = (
            K[:, None] * eta
            + 1j * w[None, :, None, None] * E[:, None]
            - (w**2)[None, :, None, None] * M[:, None]
        )
        X = np.linalg.solve(Z, np.broadcast_to(B[:, None], Z.shape[:2] + B.shape[-2:]).astype(complex))
        H = np.einsum("dij,dfjk->dfik", C, X)
        return H if batched else H[0]

    def poles(self) -> tuple[np.ndarray, np.ndarray]:
        """Natural frequencies (Hz) and damping ratios of the modes, sorted by frequency.

        Undamped natural frequencies from K φ = ω² M φ; damping ratios from the
        modal damping φᵀEφ / (2 ω φᵀMφ) plus η/2 (exact for proportional damping).
        """
        batched = self.M.ndim == 3
        M, E, K = (x if batched else x[None] for x in (self.M, self.E, self.K))
        w2, Phi = _eig(M, K)
        w = np.sqrt(np.maximum(w2, 0))
        modal_e = np.einsum("dim,dij,djm->dm", Phi, E, Phi)
        zeta = modal_e / (2 * w) + self.loss_factor / 2
        f = w / (2 * np.pi)
        return (f, zeta) if batched else (f[0], zeta[0])


def _eig(M, K) -> tuple[np.ndarray, np.ndarray]:
    """Undamped modes of (d, n, n) stacks: ω² (d, n) ascending, Φ (d, n, n) with Φᵀ M Φ = I.

    The coordinates are first scaled to a unit mass diagonal (they mix metres and radians), then
    the symmetric-definite problem is reduced by a Cholesky factor of M; raises
    ``numpy.linalg.LinAlgError`` when M is not positive definite.
    """
    d = 1 / np.sqrt(np.abs(np.diagonal(M, axis1=-2, axis2=-1)))  # (d, n)
    S = d[:, :, None] * d[:, None, :]
    Li = np.linalg.inv(np.linalg.cholesky(M * S))
    A = Li @ (K * S) @ np.swapaxes(Li, -1, -2)
    w2, Y = np.linalg.eigh((A + np.swapaxes(A, -1, -2)) / 2)
    return w2, d[:, :, None] * (np.swapaxes(Li, -1, -2) @ Y)


def _modal(M, E, K):
    """(ω², Φ, diag ΦᵀEΦ) when M is positive definite and E is diagonal in the modes; else None."""
    if not np.all(np.isfinite(M)) or np.any(np.diagonal(M, axis1=-2, axis2=-1) <= 0):
        return None
    try:
        w2, Phi = _eig(M, K)
    except np.linalg.LinAlgError:
        return None
    if np.any(w2 <= 0):
        return None
    Em = np.swapaxes(Phi, -1, -2) @ E @ Phi
    diag = np.diagonal(Em, axis1=-2, axis2=-1)
    off = Em - diag[:, :, None] * np.eye(Em.shape[-1])
    scale = np.sqrt(np.abs(diag[:, :, None] * diag[:, None, :])) + 1e-12 * np.abs(diag).max(-1)[:, None, None]
    if np.any(np.abs(off) > 1e-9 * scale):
        return None
    return w2, Phi, diag


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
    e = np.atleast_1d(np.asarray(e_pa, dtype=float))
    ei = e * wy * wx**3 / 12 / factor
    kappa = 10 * (1 + nu) / (12 + 11 * nu)
    phi = 12 * ei / (kappa * e / (2 * (1 + nu)) * wx * wy * length**2)
    L = length
    out = np.empty(e.shape + (2, 2))
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
    **moduli : Young's moduli (Pa), floats or broadcastable arrays

    Returns
    -------
    ChainStiffness, arrays with leading axis n_design (1 for floats)
    """
    if not np.isfinite(shear_factor) or shear_factor <= 0:
        raise InvalidParameter(f"shear_factor = {shear_factor!r}: must be a finite number > 0")
    g = geometry or Geometry()
    nu = (materials or Materials()).nu
    lever = Lever.from_geometry(g)
    E = moduli_arrays(**moduli)
    fac = np.asarray(factors, dtype=float)
    f = dict(zip(FACTOR_NAMES, fac, strict=True))
    a_pa, b_pa = equations(E, fac, lever)
    shape = np.broadcast_shapes(*(np.shape(v) for v in E.values()))
    nd = int(np.prod(shape))
    E = {k: np.broadcast_to(v, shape).reshape(nd) for k, v in E.items()}
    a_pa, b_pa = (np.broadcast_to(v, shape).reshape(nd) for v in (a_pa, b_pa))
    z = _levels(g)
    punch = g.pedicle_x_m**2 * g.pedicle_y_m
    foundation = 1 + f["root_foundation"] * (1e3 * E["gap_e_pa"] / E["plate_e_pa"]) ** 0.25
    jx, jy, t, tc = g.joint_x_m, g.joint_y_m, g.gap_thickness_m, g.capsule_thickness_m
    span = t + 2 * g.capsule_reach_m
    k_shear = (
        shear_factor
        / (2 * (1 + nu))
        * (E["gap_e_pa"] * jx * jy / t + E["capsule_e_pa"] * 2 * (jx + 2 * tc) * tc / span)
    )
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
    factors, geometry: Geometry | None = None, materials: Materials | None = None, **moduli
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
    **moduli : Young's moduli (Pa), floats or broadcastable arrays

    Returns
    -------
    JointCoupling, arrays with leading axis n_design
    """
    g = geometry or Geometry()
    st = chain_stiffness(factors, DEFAULT_SHEAR_FACTOR, g, materials, **moduli)
    lv = _levels(g)
    nd = st.k_joint.size
    K = np.zeros((nd, 5, 5))
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


def chain_mass(geometry: Geometry | None = None, materials: Materials | None = None) -> np.ndarray:
    """Consistent 8 × 8 mass of :data:`COORDINATES` (kg, kg·m, kg·m²); independent of the moduli.

    ∫ ρ A (g gᵀ + w_x²/12 h hᵀ) dz over the stapes head, the gap, the plate, the pedicle and the
    incus block (g, h from :func:`chain_shapes`), by Gauss–Legendre quadrature (exact).
    """
    g = geometry or Geometry()
    mat = materials or Materials()
    rho_b, rho_s = mat.bone_density_kg_m3, mat.soft_density_kg_m3
    jx, jy, z_j = g.joint_x_m, g.joint_y_m, _levels(g)["j"]
    bodies = [  # (density, w_x, w_y, z0, z1): no body straddles a kink of the shapes
        (rho_b, jx, jy, 0.0, g.z_gap),  # stapes head
        (rho_s, jx, jy, g.z_gap, z_j),  # lower half of the gap
        (rho_s, jx, jy, z_j, g.z_plate),  # upper half of the gap
        (rho_b, jx, jy, g.z_plate, g.z_pedicle),  # plate
        (rho_b, g.pedicle_x_m, g.pedicle_y_m, g.z_pedicle, g.z_incus),  # pedicle
        (rho_b, g.incus_x_m, g.incus_y_m, g.z_incus, g.z_top),  # incus block
    ]
    x, w = np.polynomial.legendre.leggauss(_GAUSS_POINTS)
    M = np.zeros((8, 8))
    for rho, wx, wy, z0, z1 in bodies:
        zq = (z0 + z1) / 2 + (z1 - z0) / 2 * x
        dz = rho * wx * wy * (z1 - z0) / 2 * w
        gu, gr = chain_shapes(zq, g)
        M += np.einsum("q,qi,qj->ij", dz, gu, gu) + wx**2 / 12 * np.einsum("q,qi,qj->ij", dz, gr, gr)
    return (M + M.T) / 2  # exactly symmetric


def chain_model(
    factors,
    shear_factor: float = DEFAULT_SHEAR_FACTOR,
    geometry: Geometry | None = None,
    materials: Materials | None = None,
    rayleigh_a_per_s: float = 0.0,
    rayleigh_b_s: float = 1e-4,
    loss_factor: float = 0.0,
    **moduli,
) -> SecondOrderModel:
    """The eight-coordinate chain (module docstring) for one or many designs.

    Parameters
    ----------
    factors : the calibrated static factors (``lumped.model.FACTOR_NAMES`` order)
    shear_factor : the joint shear factor f_shear (dimensionless; calibrated to FE second in-plane
        natural frequencies by :func:`calibration.pipeline.fit_shear`)
    geometry, materials : dimensions (m); ν and densities (kg/m³) from ``materials``
    rayleigh_a_per_s, rayleigh_b_s : Rayleigh damping E = a M + b K (1/s, s)
    loss_factor : structural loss factor η (dimensionless)
    **moduli : Young's moduli (Pa), floats or broadcastable arrays (``lumped.model.MODULI``);
        floats only (or none): one design, no design axis

    Returns
    -------
    SecondOrderModel : input the pressure (Pa), outputs :data:`OUTPUTS` (rad, rad, m)
    """
    g = geometry or Geometry()
    st = chain_stiffness(factors, shear_factor, g, materials, **moduli)
    nd = st.k_joint.size
    K = np.zeros((nd, 8, 8))
    K[:, 0:2, 0:2] = st.stapes
    K[:, 2, 2] = st.k_joint
    K[:, 3, 3] = 1 / st.c_root
    K[:, 4:6, 4:6] = st.beam
    K[:, 6, 6] = 1 / st.c_top
    K[:, 7, 7] = st.k_shear
    M = np.broadcast_to(chain_mass(g, materials), (nd, 8, 8)).copy()
    g_load = chain_shapes([_levels(g)["load"]], g)[0][0]  # u_x at the load centroid per unit q
    force = Lever.from_geometry(g).force_per_pa
    Bm = np.broadcast_to((force * g_load)[:, None], (nd, 8, 1)).copy()
    C = np.zeros((3, 8))
    C[0, 2] = 1.0  # α = θ_joint
    C[1, [3, 5, 6]] = 1.0  # β = ψ_root + φ_tip + ψ_top
    C[2] = g_load
    Cm = np.broadcast_to(C, (nd, 3, 8)).copy()
    if all(np.ndim(v) == 0 for v in moduli.values()):  # one design: no design axis
        M, K, Bm, Cm = M[0], K[0], Bm[0], Cm[0]
    return SecondOrderModel(
        M=M, E=rayleigh_a_per_s * M + rayleigh_b_s * K, K=K, B=Bm, C=Cm, loss_factor=loss_factor
    )


def frequency_response(model: SecondOrderModel, freq_hz, pressure_pa: float = DEFAULT_PRESSURE_PA):
    """Complex α, β (rad) and incus u_x (m) at ``freq_hz`` for a pressure amplitude (Pa)."""
    return model.freq_resp(freq_hz)[..., 0] * pressure_pa

