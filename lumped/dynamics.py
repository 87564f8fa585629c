"""Lumped dynamics: a second-order model M q̈ + C q̇ + K q = B u, y = C_out q (spec §4).

In the style of pyMOR's ``SecondOrderModel``: the matrices are arrays, batched
over designs (leading axis), and :meth:`SecondOrderModel.freq_resp` returns
(n_freq, n_out, n_in) for one design, (n_design, n_freq, n_out, n_in) for many.

The pedicle-and-joint chain in the x–z plane has two coordinates,
q = [θ_joint, θ_pedicle]: everything above the joint's mid-plane z_j turns
about it by θ_joint, and everything above the pedicle's hinge z_p =
z_pedicle + h L turns by θ_pedicle more. The hinge fraction h is a
calibrated factor (a bent cantilever's effective pivot). The stiffnesses come
from the calibrated static model, so that the static limit reproduces its α
and β exactly; the masses and rotary inertias are those of the FE regions
(densities of spec §4) above each hinge. Damping is the FE model's: Rayleigh
C = a M + b K and/or a structural loss factor, K(1 + iη).

Outputs y = [α, β, u_x at the load centroid]; input u = the pressure (Pa).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isj.design import DEFAULT_PRESSURE_PA, Geometry, InvalidParameter, Materials

from .model import Lever, equations, moduli_arrays

OUTPUTS = ("alpha_rad", "beta_rad", "incus_ux_m")

#: Default hinge fraction of the pedicle (pivot at this fraction of its length above the plate).
DEFAULT_HINGE_FRACTION = 1 / 3


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
        """
        f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
        if f.ndim != 1 or np.any(~np.isfinite(f)) or np.any(f < 0):
            raise InvalidParameter("freq_hz: every frequency must be a finite number >= 0 (Hz)")
        w = 2 * np.pi * f
        batched = self.M.ndim == 3
        M, E, K, B, C = (x if batched else x[None] for x in (self.M, self.E, self.K, self.B, self.C))
        # (design, freq, n, n): one small dense solve per design and frequency, vectorised
        Z = (
            K[:, None] * (1 + 1j * self.loss_factor)
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
        # symmetric-definite problem via Cholesky of M
        Lm = np.linalg.cholesky(M)
        Li = np.linalg.inv(Lm)
        A = Li @ K @ np.swapaxes(Li, -1, -2)
        w2, Y = np.linalg.eigh(A)
        Phi = np.swapaxes(Li, -1, -2) @ Y
        w = np.sqrt(np.maximum(w2, 0))
        modal_e = np.einsum("dim,dij,djm->dm", Phi, E, Phi)
        modal_m = np.einsum("dim,dij,djm->dm", Phi, M, Phi)
        zeta = modal_e / (2 * w * modal_m) + self.loss_factor / 2
        f = w / (2 * np.pi)
        return (f, zeta) if batched else (f[0], zeta[0])


@dataclass(frozen=True)
class _Body:
    mass: float  # kg
    z: float  # centroid height (m)
    inertia: float  # rotary inertia about y through the centroid (kg m²)


def _box(density, wx, wy, z0, z1) -> _Body:
    h = z1 - z0
    m = density * wx * wy * h
    return _Body(m, (z0 + z1) / 2, m * (wx**2 + h**2) / 12)


def chain_model(
    factors,
    hinge_fraction: float = DEFAULT_HINGE_FRACTION,
    geometry: Geometry | None = None,
    materials: Materials | None = None,
    rayleigh_a_per_s: float = 0.0,
    rayleigh_b_s: float = 1e-4,
    loss_factor: float = 0.0,
    **moduli,
) -> SecondOrderModel:
    """The two-coordinate chain for one or many designs (moduli arrays in Pa broadcast).

    ``factors``: the calibrated static factors (``lumped.model.FACTOR_NAMES``).
    """
    g = geometry or Geometry()
    mat = materials or Materials()
    lever = Lever.from_geometry(g)
    E = moduli_arrays(**moduli)
    a_pa, b_pa = equations(E, np.asarray(factors, dtype=float), lever)
    a_pa, b_pa = np.broadcast_arrays(np.atleast_1d(a_pa), np.atleast_1d(b_pa))
    nd = a_pa.size
    F = lever.force_per_pa  # N per Pa
    z_load = g.z_incus + g.incus_length_m / 2
    z_j = (g.z_gap + g.z_plate) / 2
    z_p = g.z_pedicle + hinge_fraction * g.pedicle_length_m
    # stiffnesses that reproduce the static α, β: k θ = F · lever arm
    k_j = F * (z_load - z_j) / a_pa
    k_p = F * (z_load - z_p) / b_pa
    K = np.zeros((nd, 2, 2))
    K[:, 0, 0], K[:, 1, 1] = k_j, k_p
    rho_b, rho_s = mat.bone_density_kg_m3, mat.soft_density_kg_m3
    jx, jy, px, py = g.joint_x_m, g.joint_y_m, g.pedicle_x_m, g.pedicle_y_m
    bodies = [  # (body, turns with the pedicle?)
        (_box(rho_s, jx, jy, z_j, g.z_plate), False),  # upper half of the gap
        (_box(rho_b, jx, jy, g.z_plate, g.z_pedicle), False),  # plate
        (_box(rho_b, px, py, g.z_pedicle, z_p), False),  # pedicle below the hinge
        (_box(rho_b, px, py, z_p, g.z_incus), True),  # pedicle above the hinge
        (_box(rho_b, g.incus_x_m, g.incus_y_m, g.z_incus, g.z_top), True),  # incus block
    ]
    M = np.zeros((2, 2))
    for body, above in bodies:
        gvec = np.array([body.z - z_j, (body.z - z_p) if above else 0.0])  # u_x per unit θ
        hvec = np.array([1.0, 1.0 if above else 0.0])  # rotation per unit θ
        M += body.mass * np.outer(gvec, gvec) + body.inertia * np.outer(hvec, hvec)
    M = np.broadcast_to(M, (nd, 2, 2)).copy()
    Bm = np.broadcast_to(np.array([[F * (z_load - z_j)], [F * (z_load - z_p)]]), (nd, 2, 1)).copy()
    Cm = np.broadcast_to(np.array([[1.0, 0.0], [0.0, 1.0], [z_load - z_j, z_load - z_p]]), (nd, 3, 2)).copy()
    if all(np.ndim(v) == 0 for v in moduli.values()):  # one design: no design axis
        M, K, Bm, Cm = M[0], K[0], Bm[0], Cm[0]
    return SecondOrderModel(
        M=M, E=rayleigh_a_per_s * M + rayleigh_b_s * K, K=K, B=Bm, C=Cm, loss_factor=loss_factor
    )


def frequency_response(model: SecondOrderModel, freq_hz, pressure_pa: float = DEFAULT_PRESSURE_PA):
    """Complex α, β (rad) and incus u_x (m) at ``freq_hz`` for a pressure amplitude (Pa)."""
    return model.freq_resp(freq_hz)[..., 0] * pressure_pa
