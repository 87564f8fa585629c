"""Modal analysis and damped harmonic response of the pedicle-and-joint model (docs/dynamics.md §4).

Equation of motion K u + C u̇ + M u = f; at angular frequency ω = 2π f_hz, with damping per
region r (:class:`isj.damping.Damping`: loss factor η_r, Rayleigh a_r and b_r),

    Z(ω) û = f̂,   Z = Σ_r (1 + iη_r + iω b_r) K_r + (iω a_r − ω²) M_r = K + iL + iωC − ω²M,

K_r = E_r K̂_r and M_r = ρ_r M̂_r the region's assembled stiffness and mass
(:func:`damping_matrices`). Default: the published loss factors (bone 0.01, the joint's gap
and capsule 0.15), no Rayleigh terms (docs/dynamics.md §4.3).

:func:`harmonic` solves it for every frequency at once on one real SPD factorization of K by
the model's static solver (its analysis reused), then triangular solves:

- proportional damping (one η, a and b for every region: Z = αK + βM with complex scalars
  α = 1 + i(η + ωb), β = iωa − ω²): Z û = f̂ is (I + c K⁻¹M) û = K⁻¹f̂ / α with c = β/α, and the
  Krylov space of K⁻¹M from K⁻¹f̂ does not depend on c, so Lanczos in the M inner product
  serves every frequency (a Galerkin solution each; the iterations it takes: docs/history.md);
- otherwise (the default) there is no such shift: a Galerkin projection on a basis grown from
  K⁻¹f̂ by the preconditioned residuals K⁻¹r of the worst frequency (:func:`_projected`),
  which matches the direct solve to the residual tolerance below (docs/history.md).

Every frequency's true residual ‖Zû − f̂‖/‖f̂‖ is checked; one that misses it, or does not
converge, is solved directly: Z is complex symmetric with the pattern of K, so PARDISO factors
it in complex symmetric mode (mtype 6, the static solver's ordering reused; SuperLU where
PARDISO is missing or ``solver="superlu"`` was asked for); undamped, Z is real symmetric
indefinite (PARDISO mtype −2). :func:`modal_damping` gives each mode's damping ratio.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from isj.damping import Damping, resolve, warn_rayleigh_band
from isj.design import DEFAULT_PRESSURE_PA, Materials
from isj.errors import InvalidParameter
from isj.responses import FrequencyResponse
from isj.validate import check_frequencies

from .assembly import combine, lame_unit
from .solvers import lanczos_start, make_complex_symmetric_solver, make_indefinite_solver

#: Lanczos iterations before :func:`harmonic` solves a frequency directly (each costs one
#: triangular solve, ~0.15 s on the default mesh; the complex factorization ~3.5 s).
KRYLOV_MAX_ITERATIONS = 30
#: Relative residual of the preconditioned system (I + c K⁻¹M) û = K⁻¹f̂ / α at which Lanczos stops.
KRYLOV_TOL = 1e-12
#: Largest true relative residual ‖Zû − f̂‖/‖f̂‖ accepted from Lanczos (a guard against
#: breakdown; the direct solves themselves reached 4e-10 to 4e-8 on the default mesh).
KRYLOV_RESIDUAL_GUARD = 1e-6


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
    solver = model.factored_solver(materials)  # K's factorization, shared with static solves
    opinv = spla.LinearOperator(K.shape, matvec=lambda x: np.ravel(solver.solve(x)), dtype=float)
    # a fixed start vector: the same modes, bit for bit, on every run
    w2, vec = spla.eigsh(
        K, k=n, M=M, sigma=0.0, which="LM", OPinv=opinv, tol=1e-10, v0=lanczos_start(K.shape[0])
    )
    order = np.argsort(w2)
    w2, vec = w2[order], vec[:, order]
    freq_hz = np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi)
    full = np.column_stack([model.reduction.expand(vec[:, i]) for i in range(n)])
    return freq_hz, full


def harmonic(
    model,
    freq_hz,
    materials: Materials | None = None,
    damping: Damping | str | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    method: str = "auto",
):
    """Complex displacement amplitudes (full dof vectors, m) at each frequency (Hz).

    ``damping``: a :class:`isj.damping.Damping`, a preset name or None (the published loss
    factors per region, docs/dynamics.md §4.3). ``method``: ``"auto"`` (Krylov on the static
    factorization, direct where it does not converge) or ``"direct"`` (one complex
    factorization per frequency). ``"auto"`` factors K with the model's static solver, creating
    it (and its analysis, kept for later static solves) if the model has none: damping
    proportional over the model's regions (one η, a and b for all) is solved by shifted Lanczos,
    any other by a Galerkin projection grown from the preconditioned residuals
    (:func:`_projected`). Every Krylov solution's true residual is checked.
    Returns an array of shape (n_freq, n_dofs_full), complex.
    """
    if method not in ("auto", "direct"):
        raise InvalidParameter(f"method = {method!r}: must be 'auto' or 'direct'")
    materials = materials or Materials()
    damping = resolve(damping)
    freqs = check_frequencies(freq_hz)
    damping.check_names(model.regions)
    warn_rayleigh_band(damping, float(freqs.min()), float(freqs.max()), tuple(model.regions))
    red = model.reduction
    K, L, C, M = damping_matrices(model, materials, damping)
    f = red.restrict(model.unit_load) * pressure_pa
    w = 2 * np.pi * freqs
    uniform = damping.uniform_values(tuple(model.regions))
    u = np.zeros((freqs.size, K.shape[0]), dtype=complex)
    todo = np.ones(freqs.size, dtype=bool)
    if method == "auto":
        model.factored_solver(materials)  # as a static solve would: kept for later ones
        if uniform is not None:  # Z = αK + βM with scalars: one Krylov space for every frequency
            a, b, eta = uniform
            alpha, beta = 1 + 1j * (eta + w * b), 1j * w * a - w**2
            x, ok, _ = _shifted_lanczos(model._solver.solve, M, f, beta / alpha)
            x /= alpha[:, None]
        else:
            x, ok, _ = _projected(model._solver.solve, K, L, C, M, f, w)
        ok &= _residuals(K, L, C, M, f, w, x) <= KRYLOV_RESIDUAL_GUARD
        u[ok], todo = x[ok], ~ok
    if todo.any():
        if uniform is not None:
            a, b, eta = uniform
            alpha, beta = 1 + 1j * (eta + w * b), 1j * w * a - w**2
            u[todo] = _direct(model, K, M, f, alpha[todo], beta[todo], damping.damped(tuple(model.regions)))
        else:
            u[todo] = _direct_general(model, K, L, C, M, f, w[todo])
    return np.stack([red.expand(v) for v in u]) if u.size else np.zeros((0, red.n_dofs), complex)


def region_weighted_data(model, materials: Materials, weights, part: str = "stiffness") -> np.ndarray:
    """Full-pattern data of Σ_r w_r K_r (``part="stiffness"``, N/m) or Σ_r w_r M_r (``"mass"``, kg).

    K_r = E_r (λ̂ K_λ,r + μ̂ K_μ,r) and M_r = ρ_r M̂_r are region r's stiffness and mass; ``weights``
    maps region names to w_r (a :class:`isj.damping.Damping` table, for instance).
    """
    regions = model.regions
    if part == "mass":
        model.mass_data(materials)  # the unit-density mass, assembled once
        coef = {r: (weights[r] * materials.density(r), 0.0) for r in regions}
        return combine(model.pattern, regions, coef, part)
    lam, mu = lame_unit(materials.nu)
    e = {r: weights[r] * materials.youngs(r) for r in regions}
    return combine(model.pattern, regions, {r: (e[r] * lam, e[r] * mu) for r in regions})


def damping_matrices(model, materials: Materials, damping: Damping):
    """Reduced K, L = Σ_r η_r K_r, C = Σ_r (a_r M_r + b_r K_r) and M (CSR on one pattern, SI).

    With K_r and M_r region r's stiffness and mass (:func:`region_weighted_data`),
    Z(ω) = K + iL + iωC − ω²M = Σ_r (1 + iη_r + iωb_r) K_r + (iωa_r − ω²) M_r.
    """
    damping.check_names(model.regions)
    red = model.reduction
    kd, md = model.stiffness_data(materials), model.mass_data(materials)
    ld = region_weighted_data(model, materials, damping.loss_factor)
    cd = region_weighted_data(model, materials, damping.rayleigh_b_s)
    cd += region_weighted_data(model, materials, damping.rayleigh_a_per_s, "mass")
    return red.matrix(kd), red.matrix(ld), red.matrix(cd), red.matrix(md)


def _residuals(K, L, C, M, f, w, x) -> np.ndarray:
    """‖Z(ω_j) x_j − f‖ / ‖f‖ for each frequency, Z = K + iL + iωC − ω²M (real matrices, 2 vectors each)."""
    n = w.size
    xr = np.column_stack([x.real.T, x.imag.T])
    kx, lx, cx, mx = (A @ xr for A in (K, L, C, M))

    def cplx(y):
        return y[:, :n] + 1j * y[:, n:]

    zx = cplx(kx) + 1j * cplx(lx) + 1j * w * cplx(cx) - w**2 * cplx(mx)
    return np.linalg.norm(zx - f[:, None], axis=0) / max(np.linalg.norm(f), np.finfo(float).tiny)


#: Relative true residual at which :func:`_projected` stops, and its largest basis. On the coarse
#: test mesh the direct solves' own residuals were 3e-10 to 3e-9, and projected solutions at 1e-8
#: differed from them by at most 5e-10 relative (u, α and β; 100 Hz – 30 kHz).
PROJECTION_TOL = 1e-8
PROJECTION_MAX_BASIS = 60


def _projected(solve, K, L, C, M, f, w, tol=None, kmax=None):
    """Galerkin solutions of (K + iL + iωC − ω²M) x = f at every ω from one real basis V.

    Non-proportional damping (η, a, b differing between regions) leaves no scalar shift: the
    Krylov space of K⁻¹M no longer holds the solution. The basis starts from K⁻¹f and grows,
    while some frequency's true residual r exceeds ``tol`` relative, by K⁻¹ Re r and K⁻¹ Im r of
    the worst frequency (M-orthonormalised, twice): a preconditioned Krylov method for that
    frequency whose space every frequency shares. Each step costs two triangular solves and one
    product of the n × 4k block [KV, LV, CV, MV] with the projected solutions (the true residuals
    of every frequency); the projected k × k complex symmetric systems are solved densely.

    Returns (x, converged, basis size): x of shape (n_freq, n), complex.
    """
    tol = PROJECTION_TOL if tol is None else tol
    kmax = PROJECTION_MAX_BASIS if kmax is None else kmax
    n, nf = f.size, w.size
    fn = max(np.linalg.norm(f), np.finfo(float).tiny)
    mats = (K, L, C, M)
    V = np.empty((n, kmax))
    AV = np.empty((4, n, kmax))  # K V, L V, C V, M V, column by column
    P = np.zeros((4, kmax, kmax))  # Vᵀ K V, Vᵀ L V, Vᵀ C V, Vᵀ M V (symmetric), grown with V
    k = 0
    new = np.asarray(solve(f)).reshape(n, -1)
    Y = np.zeros((nf, 0), dtype=complex)
    res = np.full(nf, np.inf)
    while True:
        added = 0
        for j in range(new.shape[1]):  # M-orthonormalise each new direction against V, twice
            if k >= kmax:
                break
            v = new[:, j].copy()
            v0 = np.sqrt(max(v @ (M @ v), 0.0))
            for _ in range(2):
                v -= V[:, :k] @ (AV[3, :, :k].T @ v)
            nv = np.sqrt(max(v @ (M @ v), 0.0))
            if not nv > 1e-12 * v0:
                continue
            V[:, k] = v / nv
            for i, A in enumerate(mats):
                AV[i, :, k] = A @ V[:, k]
                P[i, : k + 1, k] = V[:, : k + 1].T @ AV[i, :, k]
                P[i, k, :k] = P[i, :k, k]
            k, added = k + 1, added + 1
        if added == 0:
            break  # nothing new: the residuals' directions are already in the basis
        Pk = P[:, :k, :k]
        fp = V[:, :k].T @ f
        Y = np.empty((nf, k), dtype=complex)
        for j, wj in enumerate(w):
            try:
                Y[j] = np.linalg.solve(Pk[0] + 1j * Pk[1] + 1j * wj * Pk[2] - wj**2 * Pk[3], fp)
            except np.linalg.LinAlgError:
                Y[j] = np.nan
        R = np.repeat(f[:, None], nf, axis=1).astype(complex)  # f − Z(ω) V y for every ω, in real BLAS
        for i, c in enumerate((1.0, 1j, 1j * w, -(w**2))):
            cy = (c * Y.T) if np.ndim(c) == 0 else (Y * c[:, None]).T  # (k, nf)
            R -= AV[i, :, :k] @ cy.real + 1j * (AV[i, :, :k] @ cy.imag)
        res = np.linalg.norm(R, axis=0) / fn
        res[~np.isfinite(res)] = np.inf
        worst = int(np.argmax(res))
        if res[worst] <= tol or k >= kmax:
            break
        r = R[:, worst]
        new = np.asarray(solve(np.column_stack([r.real, r.imag]))).reshape(n, 2)
    x = np.nan_to_num(Y) @ V[:, : Y.shape[1]].T
    return x, res <= tol, k


def _shifted_lanczos(solve, M, f, c, tol=None, kmax=None):
    """Galerkin solutions of (I + c_j K⁻¹M) x_j = K⁻¹f for every shift c_j from one Krylov space.

    ``solve`` applies K⁻¹ (real SPD K); M is real SPD, so K⁻¹M is self-adjoint
    in the M inner product: Lanczos in that inner product (with full
    reorthogonalization, twice) builds an M-orthonormal basis V and a
    tridiagonal T with K⁻¹M V = V T + β v eᵀ, and x_j = ‖K⁻¹f‖_M V (I + c_j T)⁻¹ e₁.
    The residual of the preconditioned system is |c_j| β |y_j,last| relative.

    Returns (x, converged, iterations): x of shape (n_shifts, n), complex; converged, bool
    per shift; iterations, the number of K⁻¹ solves after the first.
    """
    tol = KRYLOV_TOL if tol is None else tol
    kmax = KRYLOV_MAX_ITERATIONS if kmax is None else kmax
    c = np.atleast_1d(np.asarray(c, dtype=complex))
    n = f.size
    r0 = np.ravel(solve(f))
    mr = M @ r0
    nr = np.sqrt(r0 @ mr)
    if not nr > 0:  # no load: no response
        return np.zeros((c.size, n), dtype=complex), np.ones(c.size, dtype=bool), 0
    V, MV = np.empty((n, kmax)), np.empty((n, kmax))
    V[:, 0], MV[:, 0] = r0 / nr, mr / nr
    a, b = np.zeros(kmax), np.zeros(kmax)
    for k in range(kmax):
        v = np.ravel(solve(MV[:, k]))
        for _ in range(2):  # classical Gram–Schmidt twice, M inner product
            h = MV[:, : k + 1].T @ v
            v -= V[:, : k + 1] @ h
            a[k] += h[k]
        mv = M @ v
        bk = np.sqrt(max(v @ mv, 0.0))
        T = np.diag(a[: k + 1]) + np.diag(b[:k], 1) + np.diag(b[:k], -1)
        e1 = np.zeros(k + 1)
        e1[0] = 1.0
        Y = np.full((c.size, k + 1), np.nan, dtype=complex)
        for j, cj in enumerate(c):
            try:
                Y[j] = np.linalg.solve(np.eye(k + 1) + cj * T, e1)
            except np.linalg.LinAlgError:  # (I + cT) singular: an undamped resonance of T
                pass
        est = np.abs(c) * bk * np.abs(Y[:, k])
        converged = est <= tol  # NaN (singular) is not converged
        if converged.all() or k + 1 == kmax or bk == 0:
            break
        b[k] = bk
        V[:, k + 1], MV[:, k + 1] = v / bk, mv / bk
    x = nr * (np.nan_to_num(Y) @ V[:, : k + 1].T)
    return x, converged, k + 1


def _direct(model, K, M, f, alpha, beta, damped: bool) -> np.ndarray:
    """Solve (αK + βM) x = f at each (α, β) pair by a direct factorization; x of shape (n, n_dofs)."""
    backend = "superlu" if model._solver_name == "superlu" else "auto"
    perm = getattr(model._solver, "perm", None)  # the static analysis's ordering, same pattern
    out = np.zeros((alpha.size, K.shape[0]), dtype=complex)
    solver = None  # K and M come from one reduction: the same indices and indptr
    try:
        for i, (al, be) in enumerate(zip(alpha, beta, strict=True)):  # one factorization per frequency
            if damped:  # K(1 + iη) + iω(aM + bK) − ω²M: complex symmetric
                Z = sp.csr_matrix((al * K.data + be * M.data, K.indices, K.indptr), shape=K.shape)
            else:
                Z = sp.csr_matrix((K.data + be.real * M.data, K.indices, K.indptr), shape=K.shape)
            if solver is None:  # the pattern is the same at every frequency: analyse once
                make = make_complex_symmetric_solver if damped else make_indefinite_solver
                solver = make(Z, backend, perm)
            solver.factor(Z)
            out[i] = np.ravel(solver.solve(f))
    finally:
        if solver is not None:
            solver.free()  # the complex factor: 44M nonzeros (0.7 GB) on the default mesh
    return out


def _direct_general(model, K, L, C, M, f, w) -> np.ndarray:
    """Solve (K + iL + iωC − ω²M) x = f at each ω by a complex symmetric factorization (any damping)."""
    backend = "superlu" if model._solver_name == "superlu" else "auto"
    perm = getattr(model._solver, "perm", None)
    out = np.zeros((w.size, K.shape[0]), dtype=complex)
    solver = None  # K, L, C and M share one reduced pattern
    try:
        for i, wi in enumerate(w):
            data = K.data + 1j * (L.data + wi * C.data) - wi**2 * M.data
            Z = sp.csr_matrix((data, K.indices, K.indptr), shape=K.shape)
            if solver is None:
                solver = make_complex_symmetric_solver(Z, backend, perm)
            solver.factor(Z)
            out[i] = np.ravel(solver.solve(f))
    finally:
        if solver is not None:
            solver.free()
    return out


def _solve_block(A: sp.csr_matrix, B: sp.csr_matrix, f: np.ndarray) -> np.ndarray:
    """Solve (A + iB) x = f, A and B real symmetric, f real, as the real 2n × 2n block system.

    [[A, B], [B, −A]] [Re x; −Im x] = [f; 0], symmetric indefinite: an independent
    reference for :func:`harmonic`'s direct solves, in tests and ``benchmarks/dynamics.py``.
    """
    n = A.shape[0]
    big = sp.bmat([[A, B], [B, -A]], format="csr")
    s = make_indefinite_solver(big)
    try:
        s.factor(big)
        xz = np.ravel(s.solve(np.concatenate([f, np.zeros(n)])))
    finally:
        s.free()
    return xz[:n] - 1j * xz[n:]


def harmonic_outputs(
    model,
    freq_hz,
    materials: Materials | None = None,
    damping: Damping | str | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
) -> dict[str, np.ndarray]:
    """Complex α, β (rad, point pairs) and the incus face's mean u_x (m) at each frequency (Hz)."""
    u = harmonic(model, freq_hz, materials, damping, pressure_pa)
    w = model.unit_load.reshape(-1, 3)[:, 0]  # ∫ N_i dA on the loaded face: area weights
    ux = u.reshape(u.shape[0], -1, 3)[:, :, 0] @ w / w.sum()
    ang = model.angles[:2] @ u.T
    return {"alpha_rad": ang[0], "beta_rad": ang[1], "incus_ux_m": ux}


#: Outputs of :func:`harmonic_outputs` and :func:`harmonic_response`, and their units.
HARMONIC_OUTPUTS = ("alpha_rad", "beta_rad", "incus_ux_m")
HARMONIC_UNITS = ("rad", "rad", "m")


def harmonic_response(
    model,
    freq_hz,
    materials: Materials | None = None,
    damping: Damping | str | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
):
    """:func:`harmonic_outputs` as an :class:`isj.responses.FrequencyResponse` (same numbers).

    Parameters
    ----------
    model : :class:`fem.model.PedicleJointModel`
    freq_hz : frequencies (Hz), >= 0
    materials : moduli (Pa), ν and densities (kg/m³)
    damping : :class:`isj.damping.Damping` or a preset name (default: the published loss
        factors per region, docs/dynamics.md §4.3)
    pressure_pa : pressure amplitude on the incus's face (Pa)

    Returns
    -------
    FrequencyResponse : α, β (rad, point pairs) and the loaded face's mean u_x (m), the outputs
    of the lumped chain (:data:`isj.lumped.dynamics.OUTPUTS`)
    """
    out = harmonic_outputs(model, freq_hz, materials, damping, pressure_pa)
    f = check_frequencies(freq_hz)
    H = np.stack([out[k] for k in HARMONIC_OUTPUTS], axis=1)
    return FrequencyResponse(f, H, HARMONIC_OUTPUTS, HARMONIC_UNITS, input_amplitude=pressure_pa)


def modal_damping(
    model, materials: Materials | None = None, damping: Damping | str | None = None, n: int = 6
):
    """Natural frequencies (Hz) and damping ratios ζ of the ``n`` lowest modes (modal projection).

    ζ_m = φ_mᵀ L φ_m / (2 ω_m²) + φ_mᵀ C φ_m / (2 ω_m) for mass-normalised undamped modes φ_m
    (L, C of :func:`damping_matrices`): a loss factor η contributes η/2 at resonance, Rayleigh
    terms (a/ω + b ω)/2. Exact for proportional damping; with η, a or b differing between
    regions the modes couple and this is the diagonal of the projected damping.

    Returns
    -------
    freq_hz, zeta : (n,) arrays
    """
    materials = materials or Materials()
    damping = resolve(damping)
    freq, shapes = modes(model, materials, n)
    _, L, C, _ = damping_matrices(model, materials, damping)
    phi = np.column_stack([model.reduction.restrict(shapes[:, i]) for i in range(shapes.shape[1])])
    w = 2 * np.pi * freq
    zeta = np.einsum("im,im->m", phi, L @ phi) / (2 * w**2) + np.einsum("im,im->m", phi, C @ phi) / (2 * w)
    return freq, zeta
