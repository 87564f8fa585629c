"""Strain energy: per region (where the compliance sits) and per element (for plots)."""

from __future__ import annotations

import numpy as np

from .assembly import Pattern, RegionMatrices, lame_unit
from .elements import barycentric, shape_gradients, tet_quadrature
from .space import Space


def region_strain_energy(
    pattern: Pattern,
    regions: dict[str, RegionMatrices],
    youngs_pa: dict[str, float],
    nu: float,
    u: np.ndarray,
) -> dict[str, float]:
    """Strain energy ½ uᵀ K_r u (J) of each region for displacement ``u`` (m)."""
    lam, mu = lame_unit(nu)
    un = u.reshape(-1, 3)
    out = {}
    for name, rm in regions.items():
        ui = un[pattern.pair_row[rm.pairs]]
        uj = un[pattern.pair_col[rm.pairs]]
        if lam == 0:  # ν = 0: the μ part alone
            e = mu * np.einsum("pk,pkl,pl->", ui, rm.mu, uj, optimize=True)
        else:  # the blocks the stiffness sums use (RegionMatrices.lam_plus): one product, not two
            e = lam * np.einsum("pk,pkl,pl->", ui, rm.lam_plus(mu / lam), uj, optimize=True)
        out[name] = 0.5 * youngs_pa[name] * float(e)
    return out


def element_strain_energy_density(
    space: Space, youngs_per_elem_pa: np.ndarray, nu: float, u: np.ndarray
) -> np.ndarray:
    """Mean strain-energy density (J/m³) of each element, ½ σ:ε averaged over it."""
    lam, mu = lame_unit(nu)
    qp, qw = tet_quadrature(2)
    g_ref = shape_gradients(space.order, barycentric(qp))  # (q, n, a)
    ue = u.reshape(-1, 3)[space.cells]  # (e, n, c)
    # ∂u_c/∂x_k = Σ_i u_ic Σ_a g_ref[q,i,a] invJ[e,a,k]
    gu = np.einsum("eic,qia->eqca", ue, g_ref)
    grad = np.einsum("eqca,eak->eqck", gu, space.inv_jac)
    eps = 0.5 * (grad + grad.transpose(0, 1, 3, 2))
    tr = np.einsum("eqkk->eq", eps)
    w = 0.5 * (lam * tr**2 + 2 * mu * np.einsum("eqck,eqck->eq", eps, eps))
    mean = (w @ qw) / qw.sum()
    return youngs_per_elem_pa * mean
