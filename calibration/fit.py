"""Fit the lumped model's factors to FE results with CasADi + IPOPT.

Least squares on the relative errors of α and β, over the logarithms of the
factors (they are positive and span orders of magnitude), with a
Gauss–Newton Hessian JᵀJ (as in CasADi's ``sysid.py`` example). The solver's
status is checked: a failed fit raises :class:`FitFailed` carrying IPOPT's
statistics. FE results come in as plain data; nothing here needs gmsh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from isj.lumped.model import FACTOR_NAMES, MODULI, Lever, equations, moduli_arrays

from isj.design import Geometry
from isj.errors import (
    FitFailed,  # noqa: F401 - re-exported, its old home
    InvalidParameter,
)

#: Bound on |log factor| during the fit.
LOG_BOUND = 25.0

#: Starting point of the fit: the idealised physics (factors 1), but plate_support 0.1, which
#: keeps the plate face's e^(−s) cos s alive over the design space (s from about 0.03 to 2);
#: from 1 the fit can settle where that term has died out (s > 5) and the plate term is lost.
INITIAL_FACTORS = np.array([0.1 if n in ("plate_support", "pedicle_face") else 1.0 for n in FACTOR_NAMES])

#: Scale of the relative errors in the L^p objective (:func:`fit_factors` ``norm``): the tolerance.
NORM_SCALE = 0.03


@dataclass(frozen=True)
class FitResult:
    factors: np.ndarray
    rms_rel_error: float
    max_rel_error: float
    iterations: int
    status: str


def fe_arrays(records: list[dict]) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Moduli arrays and FE α, β (rad/Pa) from records ``{"design", "alpha_per_pa", "beta_per_pa"}``."""
    designs = {k: np.array([r["design"].get(k, np.nan) for r in records]) for k in MODULI}
    designs = {k: v for k, v in designs.items() if not np.all(np.isnan(v))}
    alpha = np.array([r["alpha_per_pa"] for r in records], dtype=float)
    beta = np.array([r["beta_per_pa"] for r in records], dtype=float)
    return moduli_arrays(designs), alpha, beta


def record_lever(records: list[dict], geometry: Geometry | None = None) -> Lever:
    """The load path's constants of the records: one geometry, or one per record.

    A record may carry its own ``"geometry"`` (fields of :class:`~isj.design.Geometry`, m,
    over ``geometry``); then every field of the lever is an array over the records.
    """
    base = geometry or Geometry()
    if not any(r.get("geometry") for r in records):
        return Lever.from_geometry(base)
    return Lever.from_geometries([base.replace(**(r.get("geometry") or {})) for r in records])


def _casadi_lever(lever: Lever, n: int) -> Lever:
    """``lever`` with its array fields as CasADi column vectors of length ``n``."""
    import dataclasses

    import casadi as ca

    return dataclasses.replace(
        lever,
        **{
            f: ca.DM(np.broadcast_to(np.asarray(getattr(lever, f), dtype=float), (n,)))
            for f in Lever.__dataclass_fields__
            if np.ndim(getattr(lever, f))
        },
    )


def relative_errors(
    factors, E, alpha_fe, beta_fe, lever: Lever, joint: str = "bonded"
) -> tuple[np.ndarray, np.ndarray]:
    a, b = equations(E, np.asarray(factors, dtype=float), lever, joint)
    return a / alpha_fe - 1, b / beta_fe - 1


def fit_factors(
    records: list[dict],
    geometry: Geometry | None = None,
    x0=None,
    max_iter: int = 500,
    norm: float = 2,
    joint: str = "bonded",
) -> FitResult:
    """Calibrate the lumped factors on FE records (see :func:`fe_arrays`).

    Records may carry their own ``"geometry"`` (:func:`record_lever`): geometry and moduli are
    then fitted together. ``norm`` p > 2 minimises the L^p norm of the relative errors of α, β
    and β/α instead of the sum of squares of α's and β's: each residual r becomes
    r (r²/s² + 10⁻¹²)^((p − 2)/4), s = :data:`NORM_SCALE`, so that ½ Σ r'² = ½ s^(2−p) Σ |r|^p,
    which for large p approaches the largest error (docs/lumped.md §3.15). ``joint`` is the FE
    records' joint, "bonded" or "sliding" (:func:`isj.lumped.model.equations`).
    """
    import casadi as ca

    if not (isinstance(norm, int | float) and math.isfinite(norm) and norm >= 2):
        raise InvalidParameter(f"norm = {norm!r}: must be a finite number >= 2")
    lever = record_lever(records, geometry)
    E, alpha_fe, beta_fe = fe_arrays(records)
    n = len(FACTOR_NAMES)
    logf = ca.SX.sym("log_factors", n)
    f = ca.exp(logf)
    Edm = {k: ca.DM(np.broadcast_to(v, alpha_fe.shape)) for k, v in E.items()}
    a, b = equations(Edm, [f[i] for i in range(n)], _casadi_lever(lever, alpha_fe.size), joint)
    r = ca.vertcat(a / ca.DM(alpha_fe) - 1, b / ca.DM(beta_fe) - 1)
    if norm != 2:
        r = ca.vertcat(r, (b / a) / ca.DM(beta_fe / alpha_fe) - 1)
        r = r * (r**2 / NORM_SCALE**2 + 1e-12) ** ((norm - 2) / 4)
    J = ca.jacobian(r, logf)
    obj = 0.5 * ca.dot(r, r)
    # Gauss–Newton Hessian of the Lagrangian: JᵀJ (objective factor sigma)
    sigma = ca.SX.sym("sigma")
    lam = ca.SX.sym("lam", 0)
    hess = ca.Function(
        "nlp_hess_l", [logf, ca.SX.sym("p", 0), sigma, lam], [ca.triu(sigma * ca.mtimes(J.T, J))]
    )
    solver = ca.nlpsol(
        "fit",
        "ipopt",
        {"x": logf, "f": obj},
        {
            "hess_lag": hess,
            "print_time": False,
            "ipopt": {"print_level": 0, "sb": "yes", "tol": 1e-12, "max_iter": max_iter},
        },
    )
    start = np.log(INITIAL_FACTORS if x0 is None else np.asarray(x0, dtype=float)).copy()
    # bounds keep exp() finite: a factor that wants to vanish (a term the data
    # do not need) parks at e^-25 instead of running to -inf
    lbx, ubx = np.full(n, -LOG_BOUND), np.full(n, LOG_BOUND)
    if not np.ndim(lever.root_plate):
        # one geometry: the plate-bending term is proportional to the punch term, so the data
        # cannot tell them apart; it stays at e^-25 (0) and the punch term carries both
        i = FACTOR_NAMES.index("root_plate")
        start[i] = lbx[i] = ubx[i] = -LOG_BOUND
    sol = solver(x0=start, lbx=lbx, ubx=ubx)
    stats = solver.stats()
    if not stats.get("success", False):
        raise FitFailed(f"calibration fit failed: IPOPT {stats.get('return_status')}", dict(stats))
    factors = np.exp(np.asarray(sol["x"]).ravel())
    ea, eb = relative_errors(factors, E, alpha_fe, beta_fe, lever, joint)
    err = np.abs(np.concatenate([ea, eb]))  # α and β (β/α: error_stats)
    return FitResult(
        factors=factors,
        rms_rel_error=float(np.sqrt(np.mean(err**2))),
        max_rel_error=float(err.max()),
        iterations=int(stats.get("iter_count", -1)),
        status=str(stats.get("return_status")),
    )
