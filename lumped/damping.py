"""The lumped models' damping per region and part (docs/dynamics.md §4.3).

A lumped element stands for one or several FE regions: the chain's joint
rotation for the gap, the capsule, and the faces of the plate and the stapes
head; the pedicle's cantilever for the pedicle. Each element takes the loss
factors of the regions it represents in proportion to what each region's
modulus contributes to its stiffness: K_r = E_r ∂K/∂E_r, the part of K that region
r carries (for the FE's assembled K = Σ_r E_r K̂_r this is exactly E_r K̂_r). The
lumped stiffnesses are homogeneous of degree one in the moduli (scaling every
modulus scales every spring), so Σ_r K_r = K (Euler), and equal loss factors give
K_loss = η K exactly, as in the FE model.

K_r is computed by complex step, Im K(E_r (1 + ih)) / h with h = 1e-20, exact to
rounding (no difference quotient, so no cancellation), through the same code that
builds K.

Then, as for the FE model (:func:`isj.fem.dynamics.damping_matrices`),

    K_loss = Σ_r η_r K_r,   E = Σ_r (a_r M_r + b_r K_r) + dashpots.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from isj.damping import Damping
from isj.design import REGIONS

#: Complex step, relative to each modulus.
H_STEP = 1e-20


def region_stiffness(build: Callable[[dict], np.ndarray], moduli: Mapping, regions=REGIONS) -> dict:
    """{region: E_r ∂K/∂E_r} for K = ``build(moduli)``, by complex step.

    Parameters
    ----------
    build : moduli dict (``{region}_e_pa`` → arrays, possibly complex) → stiffness array; must be
        analytic in the moduli (plain arithmetic, no abs or comparisons)
    moduli : ``{region}_e_pa`` → floats or arrays (Pa)
    regions : the regions to split K into
    """
    out = {}
    for r in regions:
        E = {k: np.asarray(v, dtype=complex) for k, v in moduli.items()}
        E[f"{r}_e_pa"] = E[f"{r}_e_pa"] * (1 + 1j * H_STEP)
        out[r] = np.imag(build(E)) / H_STEP
    return out


def damping_terms(
    damping: Damping,
    stiffness_parts: Mapping[str, np.ndarray],
    mass_parts: Mapping[str, np.ndarray] | None = None,
    dashpots: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(E, K_loss) of :class:`isj.lumped.second_order.SecondOrderModel` from the parts' matrices.

    K_loss = Σ_r η_r K_r and E = Σ_r a_r M_r + Σ_r b_r K_r + ``dashpots`` (SI), the names those of
    :class:`isj.damping.Damping` (regions, ear parts, spring sets).
    """
    parts = list(stiffness_parts.items())
    K_loss = sum(damping.loss_factor[n] * k for n, k in parts)
    E = sum(damping.rayleigh_b_s[n] * k for n, k in parts)
    for n, m in (mass_parts or {}).items():
        E = E + damping.rayleigh_a_per_s[n] * m
    if dashpots is not None:
        E = E + dashpots
    return np.asarray(E, dtype=float), np.asarray(K_loss, dtype=float)
