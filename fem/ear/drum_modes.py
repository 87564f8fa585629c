"""The eardrum's component modes on the FE pars tensa (docs/ear.md §5.10), for ``lumped.ear``.

A Craig–Bampton reduction of the drum shell with the manubrium as the interface.
The manubrium, tied to the malleus–incus body, moves rigidly with it (six dofs
(u, θ) at :attr:`isj.ear.EarGeometry.body_reference_m`); the ring is clamped.
The drum's displacement is written (exactly when every mode is kept) as

    u = Ψ q_b + Σ_j φ_j η_j + r w,

- Ψ (n_dof × 6): the constraint modes, the drum's static shape when the body moves by
  a unit rigid motion, no pressure (Guyan: its stiffness ΨᵀKΨ and mass ΨᵀMΨ are the
  ones :func:`fem.ear.lumped_params.eardrum_parameters` measures);
- φ_j: the lowest fixed-interface modes, the drum's natural modes with the manubrium
  held (K φ = ω² M φ on the interior dofs), mass-normalised (φᵀMφ = 1);
- r: the static residual of the ear-canal pressure, the static shape under 1 Pa with
  the manubrium held minus its part in the kept modes,
  r = K⁻¹f − Σ_j φ_j (φ_jᵀf)/ω_j², which is K- and M-orthogonal to every φ_j.

Ψ is K-orthogonal to every interior shape, so the reduced drum's stiffness is
block diagonal (ΨᵀKΨ, diag ω_j², rᵀKr), its mass couples the interface with the
modes (ΨᵀMφ_j) and the residual (ΨᵀMr), and its damping (η K + b K + a M per
part, as the FE ear's) projects onto the same blocks exactly.

The module returns the N lowest modes and the residual of all N, from which
``lumped.ear_drum`` builds the residual of any n ≤ N by adding back the dropped
modes (sums of positive terms, so no cancellation):
C_n = C_N + Σ_{j>n} b_j²/ω_j², rᵀMr grows by Σ b_j²/ω_j⁴, ΨᵀMr by Σ c_j b_j/ω_j².
With n = 0 the residual is the whole static pressure shape, and the reduced drum
is :func:`fem.ear.lumped_params.eardrum_parameters`' (Guyan plus one static shape).

This module may import from :mod:`isj` and :mod:`fem` only; it returns plain
numbers (a dict whose keys are the fields of ``lumped.ear_drum.DrumModes``).
"""

from __future__ import annotations

import numpy as np

from isj.ear import DEFAULT_DRUM_MESH_SIZE_M, EarGeometry, EarMaterials
from isj.errors import InvalidParameter

from ..solvers import lanczos_start
from .lumped_params import clamped_drum
from .middle_ear import DRUM_DENSITY_KG_M3

#: Modes the shipped data (``lumped/data/default_drum_modes.json``) holds: on the default drum the
#: lowest 300 reach 26.4 kHz, past the ear's 24 kHz (:data:`isj.validate.EAR_FMAX_HZ`); the lowest
#: 40, 5.9 kHz.
DEFAULT_N_MODES = 300


def drum_modes(
    geometry: EarGeometry | None = None,
    materials: EarMaterials | None = None,
    n_modes: int = DEFAULT_N_MODES,
    mesh_size_m: float = DEFAULT_DRUM_MESH_SIZE_M,
    density_kg_m3: float = DRUM_DENSITY_KG_M3,
) -> dict:
    """Measure the drum's fixed-interface modes and static residual (SI; see the module docstring).

    Parameters
    ----------
    geometry : anatomy (m); the drum and the body's reference point come from it
    materials : eardrum modulus (Pa), Poisson's ratio and thickness (m)
    n_modes : number N of fixed-interface modes to keep (>= 1)
    mesh_size_m : eardrum element size (m), as :class:`fem.ear.middle_ear.MiddleEarModel`'s
    density_kg_m3 : eardrum density (kg/m³; an estimate), as :class:`isj.ear.EarMasses`'

    Returns
    -------
    dict of plain numbers and lists, the fields of ``lumped.ear_drum.DrumModes``:

    - ``freq_hz`` (N,): the modes' natural frequencies with the manubrium held (Hz), ascending;
    - ``coupling`` (N, 6): ΨᵀMφ_j, each mode's mass coupling with the body's unit (u, θ)
        (kg^½ per m, kg^½·m per rad);
    - ``load_per_pa`` (N,): φ_jᵀf, each mode's generalized force per Pa (N·kg^-½/Pa); by
        reciprocity its volume displacement per unit modal coordinate;
    - ``residual_compliance_m3_per_pa``: fᵀr, the residual's volume displacement per Pa (m³/Pa);
    - ``residual_mass_kg_m4``: r̂ᵀMr̂ of the residual scaled to unit volume, r̂ = r/(fᵀr) (kg/m⁴);
    - ``residual_cross_mass`` (6,): ΨᵀMr̂ (kg/m², kg/m);
    - ``reference_m`` (3,), ``drum_e_pa``, ``mesh_size_m``, ``density_kg_m3``: what they refer to.

    Each mode's sign makes its load ≥ 0 (its largest coupling > 0 when the load vanishes), so
    that the data are reproducible.
    """
    if isinstance(n_modes, bool) or not isinstance(n_modes, int | np.integer) or n_modes < 1:
        raise InvalidParameter(f"n_modes = {n_modes!r}: must be an integer >= 1")
    m = materials or EarMaterials()
    # the clamped drum and its six constraint modes (Guyan), those of fem.ear.lumped_params
    drum = clamped_drum(geometry, m, mesh_size_m, density_kg_m3)
    M, free, x_ref, psi = drum.mass, drum.free, drum.reference_m, drum.constraint_modes
    if not n_modes < free.size - 1:
        raise InvalidParameter(f"n_modes = {n_modes!r}: must be < {free.size - 1} (the drum's free dofs)")
    w2, phi, b, c = _fixed_interface_modes(drum, int(n_modes))
    compliance, r = _static_residual(drum, phi, b, w2)
    r_hat = r / compliance
    return {
        "freq_hz": [float(v) for v in np.sqrt(w2) / (2 * np.pi)],
        "coupling": c.tolist(),
        "load_per_pa": [float(v) for v in b],
        "residual_compliance_m3_per_pa": compliance,
        "residual_mass_kg_m4": float(r_hat @ (M @ r_hat)),
        "residual_cross_mass": [float(v) for v in psi.T @ (M @ r_hat)],
        "reference_m": [float(v) for v in x_ref],
        "drum_e_pa": float(m.drum_e_pa),
        "mesh_size_m": float(mesh_size_m),
        "density_kg_m3": float(density_kg_m3),
    }


def _fixed_interface_modes(drum, n_modes: int):
    """(ω², φ, φᵀf, φᵀMΨ) of the drum's ``n_modes`` lowest modes with the manubrium held: M-normal,
    ascending, each with a reproducible sign (its load positive, or its largest coupling where the
    load vanishes)."""
    from scipy.sparse.linalg import LinearOperator, eigsh

    K, M, f, free, lu = drum.stiffness, drum.mass, drum.load, drum.free, drum.lu
    Kff = K[free][:, free].tocsc()
    Mff = M[free][:, free].tocsc()
    # shift-invert about 0 with the interior's own factor
    opinv = LinearOperator(Kff.shape, matvec=lu.solve, dtype=float)
    w2, vec = eigsh(
        Kff,
        k=n_modes,
        M=Mff,
        sigma=0.0,
        which="LM",
        OPinv=opinv,
        tol=1e-12,
        v0=lanczos_start(free.size),  # fixed: the same modes on every run
    )
    order = np.argsort(w2)
    w2, vec = w2[order], vec[:, order]
    vec /= np.sqrt(np.einsum("im,im->m", vec, Mff @ vec))  # φᵀMφ = 1 to rounding
    phi = np.zeros((K.shape[0], n_modes))
    phi[free] = vec
    b = phi.T @ f
    c = phi.T @ (M @ drum.constraint_modes)  # (N, 6)
    big = c[np.arange(n_modes), np.argmax(np.abs(c), axis=1)]
    tiny = np.abs(b) <= 1e-9 * np.abs(b).max()
    sign = np.where(tiny, np.sign(big), np.sign(b))
    sign[sign == 0] = 1.0
    return w2, phi * sign, b * sign, c * sign[:, None]


def _static_residual(drum, phi, b, w2) -> tuple[float, np.ndarray]:
    """(fᵀr, r): the static displacement r of 1 Pa with the manubrium held, the kept modes removed."""
    r = np.zeros(drum.stiffness.shape[0])
    r[drum.free] = drum.lu.solve(drum.load[drum.free])
    r -= phi @ (b / w2)
    compliance = float(drum.load @ r)
    if not compliance > 0:
        raise RuntimeError(f"the static residual's compliance {compliance!r} m³/Pa is not positive")
    return compliance, r


def main(argv=None) -> int:
    """Write the shipped modes: ``python -m isj.fem.ear.drum_modes PATH`` (default anatomy and mesh)."""
    import argparse
    import json

    ap = argparse.ArgumentParser(description="measure the default drum's modes for lumped.ear_drum")
    ap.add_argument("path", help="JSON file to write (lumped/data/default_drum_modes.json)")
    ap.add_argument("--n-modes", type=int, default=DEFAULT_N_MODES)
    args = ap.parse_args(argv)
    d = drum_modes(n_modes=args.n_modes)
    d["source"] = "fem.ear.drum_modes.drum_modes(): default EarGeometry, EarMaterials and drum mesh"
    with open(args.path, "w") as fh:
        json.dump(d, fh, indent=0, sort_keys=True)
        fh.write("\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
