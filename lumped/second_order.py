"""Second-order models M q̈ + E q̇ + K q = B u, y = C q, with structural damping (docs/dynamics.md §4.6).

In the style of pyMOR's ``SecondOrderModel``: the matrices are arrays, batched
over designs (leading axis), and :meth:`SecondOrderModel.freq_resp` returns
(n_freq, n_out, n_in) for one design, (n_design, n_freq, n_out, n_in) for many.
At ω = 2π f the dynamic stiffness is

    Z(ω) = K (1 + iη) + i K_loss − ω² M + iω E,

η a loss factor for all of K, K_loss the structural damping matrix of loss factors
that differ per part (Σ_r η_r K_r, :mod:`isj.lumped.damping`) and E the viscous
damping (Rayleigh terms and dashpots).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isj.validate import check_frequencies


@dataclass(frozen=True)
class SecondOrderModel:
    """M q̈ + E q̇ + K q = B u,  y = C q, with Z(ω) = K(1 + iη) + iK_loss + iωE − ω²M (arrays; SI).

    ``M``, ``E``, ``K``, ``K_loss``: (..., n, n); ``B``: (..., n, n_in); ``C``: (..., n_out, n);
    ``loss_factor`` η (dimensionless) on all of K; ``K_loss`` (N/m, ...; None = 0) the structural
    damping of loss factors that differ per part. A leading design axis is allowed.
    """

    M: np.ndarray
    E: np.ndarray
    K: np.ndarray
    B: np.ndarray
    C: np.ndarray
    loss_factor: float = 0.0
    K_loss: np.ndarray | None = None

    def stiffness(self) -> np.ndarray:
        """The complex stiffness K(1 + iη) + iK_loss, batched: (d, n, n)."""
        K = self.K if self.K.ndim == 3 else self.K[None]
        out = K * (1 + 1j * self.loss_factor)
        if self.K_loss is not None:
            out = out + 1j * (self.K_loss if self.K_loss.ndim == 3 else self.K_loss[None])
        return out

    def freq_resp(self, freq_hz) -> np.ndarray:
        """Transfer function C Z(ω)⁻¹ B at ``freq_hz`` (Hz).

        Returns (n_freq, n_out, n_in), or (n_design, n_freq, n_out, n_in) for batched matrices.

        With proportional damping (E and K_loss diagonal in the undamped modes, as Rayleigh damping
        and one loss factor are) and M positive definite, the response is summed over all the
        modes (exact): below the first natural frequency as the static response C (K(1+iη) +
        iK_loss)⁻¹ B from a direct solve plus each mode's dynamic part (so that ω = 0 is the static
        solve), above it as the plain modal sum; otherwise one dense solve per design and frequency.
        """
        f = check_frequencies(freq_hz)
        w = 2 * np.pi * f
        batched = self.M.ndim == 3
        M, E, K, B, C = (x if batched else x[None] for x in (self.M, self.E, self.K, self.B, self.C))
        Kc = self.stiffness()
        KL = None if self.K_loss is None else (self.K_loss if batched else self.K_loss[None])
        modal = _modal(M, E, K, KL)
        eta = 1 + 1j * self.loss_factor
        if modal is not None:
            w2, Phi, e_m, l_m = modal  # (d, n), (d, n, n), (d, n), (d, n)
            cphi = np.einsum("dij,djm->dim", C, Phi)
            phib = np.einsum("djm,djk->dmk", Phi, B)
            k_m = (w2 * eta + 1j * l_m)[:, None, :]  # (d, 1, n): the modes' complex stiffnesses
            iwe = 1j * w[None, :, None] * e_m[:, None, :]
            den = k_m + iwe - (w**2)[None, :, None]  # (d, f, n)
            # below the first mode: the static solve plus each mode's dynamic part, 1/den − 1/k_m
            # written without cancellation; above it: the plain modal sum
            static = np.einsum("dij,djk->dik", C, np.linalg.solve(Kc, B.astype(complex)))  # (d, n_out, n_in)
            below = (w**2)[None, :] < w2[:, :1]  # (d, f)
            part = np.where(below[..., None], ((w**2)[None, :, None] - iwe) / (den * k_m), 1 / den)
            H = np.einsum("dim,dfm,dmk->dfik", cphi, part, phib, optimize=True)
            H = np.where(below[..., None, None], static[:, None] + H, H)
            return H if batched else H[0]
        # (design, freq, n, n): one small dense solve per design and frequency, vectorised
        Z = Kc[:, None] + 1j * w[None, :, None, None] * E[:, None] - (w**2)[None, :, None, None] * M[:, None]
        X = np.linalg.solve(Z, np.broadcast_to(B[:, None], Z.shape[:2] + B.shape[-2:]).astype(complex))
        H = np.einsum("dij,dfjk->dfik", C, X)
        return H if batched else H[0]

    def poles(self) -> tuple[np.ndarray, np.ndarray]:
        """Natural frequencies (Hz) and damping ratios of the modes, sorted by frequency.

        Undamped natural frequencies from K φ = ω² M φ; damping ratios by modal projection,
        φᵀEφ / (2 ω φᵀMφ) + η/2 + φᵀK_lossφ / (2 ω² φᵀMφ) (exact for proportional damping; the
        diagonal of the projected damping otherwise).
        """
        batched = self.M.ndim == 3
        M, E, K = (x if batched else x[None] for x in (self.M, self.E, self.K))
        w2, Phi = _eig(M, K)
        w = np.sqrt(np.maximum(w2, 0))
        zeta = np.einsum("dim,dij,djm->dm", Phi, E, Phi) / (2 * w) + self.loss_factor / 2
        if self.K_loss is not None:
            KL = self.K_loss if batched else self.K_loss[None]
            zeta = zeta + np.einsum("dim,dij,djm->dm", Phi, KL, Phi) / (2 * w2)
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


def _diagonal_in(Phi, A):
    """diag ΦᵀAΦ (d, n) when ΦᵀAΦ is diagonal (to 1e-9 of its diagonal), else None."""
    Am = np.swapaxes(Phi, -1, -2) @ A @ Phi
    diag = np.diagonal(Am, axis1=-2, axis2=-1)
    off = Am - diag[:, :, None] * np.eye(Am.shape[-1])
    scale = np.sqrt(np.abs(diag[:, :, None] * diag[:, None, :])) + 1e-12 * np.abs(diag).max(-1)[:, None, None]
    if np.any(np.abs(off) > 1e-9 * scale):
        return None
    return diag


def _modal(M, E, K, K_loss=None):
    """(ω², Φ, diag ΦᵀEΦ, diag ΦᵀK_lossΦ) when M is positive definite and E, K_loss are diagonal in
    the modes; else None."""
    if not np.all(np.isfinite(M)) or np.any(np.diagonal(M, axis1=-2, axis2=-1) <= 0):
        return None
    try:
        w2, Phi = _eig(M, K)
    except np.linalg.LinAlgError:
        return None
    if np.any(w2 <= 0):
        return None
    e = _diagonal_in(Phi, E)
    if e is None:
        return None
    if K_loss is None:
        return w2, Phi, e, np.zeros_like(e)
    kl = _diagonal_in(Phi, K_loss)
    if kl is None:
        return None
    return w2, Phi, e, kl
