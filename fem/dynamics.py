"""Modal analysis and damped harmonic response of the pedicle-and-joint model (spec §4).

Equation of motion K u + C u̇ + M u = f; at angular frequency ω = 2π f_hz,

    (K_d + iωC − ω²M) û = f̂,   K_d = K (1 + iη) with a structural loss factor η,
                                 C = a M + b K (Rayleigh).

Defaults: Rayleigh b = 1e-4 s, a = 0, η = 0 (spec §4). The complex system is
solved as the real symmetric indefinite block system

    [[A, B], [B, −A]] [Re û; −Im û] = [Re f̂; Im f̂],  A = Re K_dyn, B = Im K_dyn,

so that PARDISO (real only) factors it in symmetric-indefinite mode; SuperLU on
the complex matrix is the fallback.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from isj.design import DEFAULT_PRESSURE_PA, InvalidParameter, Materials

from .solvers import available_backends, make_indefinite_solver, make_solver


@dataclass(frozen=True)
class Damping:
    """Rayleigh coefficients a (1/s), b (s) and structural loss factor η (dimensionless)."""

    rayleigh_a_per_s: float = 0.0
    rayleigh_b_s: float = 1e-4
    loss_factor: float = 0.0

    def __post_init__(self):
        for name in ("rayleigh_a_per_s", "rayleigh_b_s", "loss_factor"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise InvalidParameter(f"{name} = {v!r}: must be a finite number >= 0")


def _check_freqs(freq_hz) -> np.ndarray:
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if f.ndim != 1 or np.any(~np.isfinite(f)) or np.any(f < 0):
        raise InvalidParameter("freq_hz: every frequency must be a finite number >= 0 (Hz)")
    return f


def modes(model, materials: Materials | None = None, n: int = 6):
    """Lowest ``n`` natural frequencies (Hz) and mode shapes (full dof vectors, mass-normalised).

    Shift-invert Lanczos about 0 (``scipy.sparse.linalg.eigsh``) with K⁻¹
    applied by the model's sparse direct solver, factored once.
    """
    materials = materials or Materials()
    if n < 1 or n >= model.n_dofs:
        raise InvalidParameter(f"n = {n!r}: must be between 1 and {model.n_dofs - 1}")
    K = model.stiffness(materials)
    M = model.reduction.matrix(model.mass_data(materials))
    solver = make_solver(K, model._solver_name)
    solver.factor(K)
    opinv = spla.LinearOperator(K.shape, matvec=lambda x: np.ravel(solver.solve(x)), dtype=float)
    w2, vec = spla.eigsh(K, k=n, M=M, sigma=0.0, which="LM", OPinv=opinv, tol=1e-10)
    order = np.argsort(w2)
    w2, vec = w2[order], vec[:, order]
    freq_hz = np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi)
    full = np.column_stack([model.reduction.expand(vec[:, i]) for i in range(n)])
    return freq_hz, full


def harmonic(
    model,
    freq_hz,
    materials: Materials | None = None,
    damping: Damping | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
):
    """Complex displacement amplitudes (full dof vectors, m) at each frequency (Hz).

    Returns an array of shape (n_freq, n_dofs_full), complex.
    """
    materials = materials or Materials()
    damping = damping or Damping()
    freqs = _check_freqs(freq_hz)
    red = model.reduction
    K = model.stiffness(materials)
    M = red.matrix(model.mass_data(materials))
    f = red.restrict(model.unit_load) * pressure_pa
    out = np.zeros((freqs.size, red.n_dofs), dtype=complex)
    for i, fr in enumerate(freqs):  # one factorization per frequency (the matrix changes)
        w = 2 * np.pi * fr
        A = (K - w**2 * M).tocsr()
        B = (damping.loss_factor * K + w * (damping.rayleigh_a_per_s * M + damping.rayleigh_b_s * K)).tocsr()
        out[i] = red.expand(_solve_complex(A, B, f))
    return out


def _solve_complex(A: sp.csr_matrix, B: sp.csr_matrix, f: np.ndarray) -> np.ndarray:
    """Solve (A + iB) x = f for real symmetric A, B and real f."""
    n = A.shape[0]
    if B.nnz == 0 or abs(B).max() == 0:  # undamped: real, possibly indefinite
        s = make_indefinite_solver(A)
        s.factor(A)
        return np.ravel(s.solve(f)).astype(complex)
    if "pardiso" in available_backends():
        big = sp.bmat([[A, B], [B, -A]], format="csr")
        s = make_indefinite_solver(big)
        s.factor(big)
        xz = np.ravel(s.solve(np.concatenate([f, np.zeros(n)])))
        return xz[:n] - 1j * xz[n:]
    lu = spla.splu((A + 1j * B).tocsc())
    return lu.solve(f.astype(complex))


def harmonic_outputs(
    model,
    freq_hz,
    materials: Materials | None = None,
    damping: Damping | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
) -> dict[str, np.ndarray]:
    """Complex α, β (rad, point pairs) and the incus face's mean u_x (m) at each frequency (Hz)."""
    u = harmonic(model, freq_hz, materials, damping, pressure_pa)
    w = model.unit_load.reshape(-1, 3)[:, 0]  # ∫ N_i dA on the loaded face: area weights
    ux = u.reshape(u.shape[0], -1, 3)[:, :, 0] @ w / w.sum()
    ang = model.angles[:2] @ u.T
    return {"alpha_rad": ang[0], "beta_rad": ang[1], "incus_ux_m": ux}
