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
from isj.lumped.model import (
    FACTOR_NAMES,
    MODULI,
    SCALED_TERMS,
    SCALING_DIMENSIONS,
    Lever,
    equations,
    moduli_arrays,
)

from isj.design import Geometry
from isj.errors import (
    FitFailed,
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


#: Weight of the ridge that pulls a fitted geometric exponent (``scaling_terms`` of
#: :func:`fit_factors`) toward 0, i.e. toward the documented forms of Lever alone, in units of the
#: objective ½ Σ r² (docs/lumped.md §3.16; chosen by the held-out error: 1e-2 and 3e-3 fit worse,
#: 3e-4 no better).
SCALING_RIDGE = 1e-3

#: Bound on a fitted geometric exponent.
SCALING_BOUND = 6.0


@dataclass(frozen=True)
class FitResult:
    factors: np.ndarray
    rms_rel_error: float
    max_rel_error: float
    iterations: int
    status: str
    scaling: dict | None = None  # fitted geometry_scaling (term -> dimension -> exponent), if any


def fe_arrays(records: list[dict]) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Moduli arrays and FE α, β (rad/Pa) from records ``{"design", "alpha_per_pa", "beta_per_pa"}``."""
    designs = {k: np.array([r["design"].get(k, np.nan) for r in records]) for k in MODULI}
    designs = {k: v for k, v in designs.items() if not np.all(np.isnan(v))}
    alpha = np.array([r["alpha_per_pa"] for r in records], dtype=float)
    beta = np.array([r["beta_per_pa"] for r in records], dtype=float)
    return moduli_arrays(designs), alpha, beta


def record_geometries(records: list[dict], geometry: Geometry | None = None) -> list[Geometry] | None:
    """Each record's own geometry (its ``"geometry"`` over ``geometry``), or None if none has one."""
    base = geometry or Geometry()
    if not any(r.get("geometry") for r in records):
        return None
    return [base.replace(**(r.get("geometry") or {})) for r in records]


def record_lever(records: list[dict], geometry: Geometry | None = None, scaling: dict | None = None) -> Lever:
    """The load path's constants of the records: one geometry, or one per record.

    A record may carry its own ``"geometry"`` (fields of :class:`~isj.design.Geometry`, m,
    over ``geometry``); then every field of the lever is an array over the records.
    ``scaling``: a calibration's ``geometry_scaling`` (:meth:`Lever.from_geometry`).
    """
    geometries = record_geometries(records, geometry)
    if geometries is None:
        return Lever.from_geometry(geometry or Geometry(), scaling)
    return Lever.from_geometries(geometries, scaling)


def _log_ratios(geometries: list[Geometry]) -> np.ndarray:
    """ln(d / d0) of :data:`SCALING_DIMENSIONS`, shape (n records, n dimensions)."""
    d0 = Geometry()
    ratios = [[getattr(g, d) / getattr(d0, d) for d in SCALING_DIMENSIONS] for g in geometries]
    return np.log(np.array(ratios))


def _scaled_casadi_lever(lever: Lever, log_ratios: np.ndarray, exponents, terms) -> Lever:
    """``lever`` (CasADi fields) with each term's field times exp(log_ratios · its exponents)."""
    import dataclasses

    import casadi as ca

    changes = {}
    L = ca.DM(log_ratios)
    for i, term in enumerate(terms):
        field = SCALED_TERMS[term]
        changes[field] = changes.get(field, getattr(lever, field)) * ca.exp(ca.mtimes(L, exponents[i, :].T))
    return dataclasses.replace(lever, **changes)


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
    scaling_terms: tuple[str, ...] = (),
    scaling_ridge: float = SCALING_RIDGE,
) -> FitResult:
    """Calibrate the lumped factors on FE records (see :func:`fe_arrays`).

    Records may carry their own ``"geometry"`` (:func:`record_lever`): geometry and moduli are
    then fitted together. ``norm`` p > 2 minimises the L^p norm of the relative errors of α, β
    and β/α instead of the sum of squares of α's and β's: each residual r becomes
    r (r²/s² + 10⁻¹²)^((p − 2)/4), s = :data:`NORM_SCALE`, so that ½ Σ r'² = ½ s^(2−p) Σ |r|^p,
    which for large p approaches the largest error (docs/lumped.md §3.15). ``joint`` is the FE
    records' joint, "bonded" or "sliding" (:func:`isj.lumped.model.equations`).

    ``scaling_terms`` (records with their own geometries only): terms of
    :data:`~isj.lumped.model.SCALED_TERMS` whose geometric exponents, one per dimension of
    :data:`~isj.lumped.model.SCALING_DIMENSIONS`, are fitted with the factors, each pulled toward
    0 (the forms of :class:`~isj.lumped.model.Lever` alone) by a ridge ``scaling_ridge`` · ½ c²;
    the result's ``scaling`` holds them (docs/lumped.md §3.16).
    """
    if not (isinstance(norm, int | float) and math.isfinite(norm) and norm >= 2):
        raise InvalidParameter(f"norm = {norm!r}: must be a finite number >= 2")
    E, alpha_fe, beta_fe = fe_arrays(records)
    terms = tuple(scaling_terms)
    geometries = record_geometries(records, geometry)
    # built once: the geometries are the costly part of a lever over hundreds of records
    lever = (
        Lever.from_geometry(geometry or Geometry())
        if geometries is None
        else Lever.from_geometries(geometries)
    )
    if terms and geometries is None:
        raise InvalidParameter("scaling_terms: the records must carry their own geometries")
    unknown = [t for t in terms if t not in SCALED_TERMS]
    if unknown:
        raise InvalidParameter(f"scaling_terms: unknown term(s) {', '.join(unknown)}")
    x, r = _residuals(E, alpha_fe, beta_fe, lever, geometries, terms, joint, norm)
    solver = _gauss_newton_ipopt(x, r, len(terms), scaling_ridge, max_iter)
    start, lbx, ubx = _start_and_bounds(x0, lever, len(terms))
    sol = solver(x0=start, lbx=lbx, ubx=ubx)
    stats = solver.stats()
    if not stats.get("success", False):
        raise FitFailed(f"calibration fit failed: IPOPT {stats.get('return_status')}", dict(stats))
    xs = np.asarray(sol["x"]).ravel()
    return _fit_result(xs, stats, E, alpha_fe, beta_fe, lever, geometries, terms, joint)


def _residuals(E, alpha_fe, beta_fe, lever: Lever, geometries, terms, joint: str, norm: float):
    """The unknowns x = (log factors, vec(exponents)) and the residual vector r(x) (CasADi SX).

    r: the relative errors of α and β, with ``norm`` p > 2 also of β/α, each then raised as in
    :func:`fit_factors`.
    """
    import casadi as ca

    n, nd = len(FACTOR_NAMES), len(SCALING_DIMENSIONS)
    logf = ca.SX.sym("log_factors", n)
    C = ca.SX.sym("exponents", len(terms), nd)
    f = ca.exp(logf)
    Edm = {k: ca.DM(np.broadcast_to(v, alpha_fe.shape)) for k, v in E.items()}
    clever = _casadi_lever(lever, alpha_fe.size)
    if terms:
        clever = _scaled_casadi_lever(clever, _log_ratios(geometries), C, terms)
    a, b = equations(Edm, [f[i] for i in range(n)], clever, joint)
    r = ca.vertcat(a / ca.DM(alpha_fe) - 1, b / ca.DM(beta_fe) - 1)
    if norm != 2:
        r = ca.vertcat(r, (b / a) / ca.DM(beta_fe / alpha_fe) - 1)
        r = r * (r**2 / NORM_SCALE**2 + 1e-12) ** ((norm - 2) / 4)
    return ca.vertcat(logf, ca.vec(C)), r


def _gauss_newton_ipopt(x, r, n_terms: int, scaling_ridge: float, max_iter: int):
    """IPOPT on ½ rᵀr (plus the exponents' ridge), with the Gauss–Newton Hessian JᵀJ (+ ridge)."""
    import casadi as ca

    n, nd = len(FACTOR_NAMES), len(SCALING_DIMENSIONS)
    J = ca.jacobian(r, x)
    obj = 0.5 * ca.dot(r, r)
    gn = ca.mtimes(J.T, J)
    if n_terms:
        ridge = ca.DM(np.concatenate([np.zeros(n), np.full(n_terms * nd, float(scaling_ridge))]))
        obj = obj + 0.5 * ca.dot(ridge, x**2)
        gn = gn + ca.diag(ridge)
    # Gauss–Newton Hessian of the Lagrangian: JᵀJ plus the ridge (objective factor sigma)
    sigma = ca.SX.sym("sigma")
    lam = ca.SX.sym("lam", 0)
    hess = ca.Function("nlp_hess_l", [x, ca.SX.sym("p", 0), sigma, lam], [ca.triu(sigma * gn)])
    return ca.nlpsol(
        "fit",
        "ipopt",
        {"x": x, "f": obj},
        {
            "hess_lag": hess,
            "print_time": False,
            "ipopt": {"print_level": 0, "sb": "yes", "tol": 1e-12, "max_iter": max_iter},
        },
    )


def _start_and_bounds(x0, lever: Lever, n_terms: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The start point and the bounds of x = (log factors, exponents)."""
    n, nd = len(FACTOR_NAMES), len(SCALING_DIMENSIONS)
    start = np.log(INITIAL_FACTORS if x0 is None else np.asarray(x0, dtype=float)).copy()
    # bounds keep exp() finite: a factor that wants to vanish (a term the data
    # do not need) parks at e^-25 instead of running to -inf
    lbx, ubx = np.full(n, -LOG_BOUND), np.full(n, LOG_BOUND)
    if not np.ndim(lever.root_plate):
        # one geometry: the plate-bending term is proportional to the punch term, so the data
        # cannot tell them apart; it stays at e^-25 (0) and the punch term carries both
        i = FACTOR_NAMES.index("root_plate")
        start[i] = lbx[i] = ubx[i] = -LOG_BOUND
    ne = n_terms * nd
    start = np.concatenate([start, np.zeros(ne)])
    lbx = np.concatenate([lbx, np.full(ne, -SCALING_BOUND)])
    ubx = np.concatenate([ubx, np.full(ne, SCALING_BOUND)])
    return start, lbx, ubx


def _fit_result(xs, stats, E, alpha_fe, beta_fe, lever: Lever, geometries, terms, joint: str) -> FitResult:
    """The :class:`FitResult` of IPOPT's solution ``xs``: factors, exponents and the errors."""
    n, nd = len(FACTOR_NAMES), len(SCALING_DIMENSIONS)
    factors = np.exp(xs[:n])
    scaling = None
    if terms:
        # ca.vec stacks column-major: exponent (term i, dimension j) at n + j * len(terms) + i
        c = xs[n:].reshape(nd, len(terms)).T
        scaling = {
            t: {d: float(c[i, j]) for j, d in enumerate(SCALING_DIMENSIONS)} for i, t in enumerate(terms)
        }
        lever = Lever.from_geometries(geometries, scaling)
    ea, eb = relative_errors(factors, E, alpha_fe, beta_fe, lever, joint)
    err = np.abs(np.concatenate([ea, eb]))  # α and β (β/α: error_stats)
    return FitResult(
        factors=factors,
        rms_rel_error=float(np.sqrt(np.mean(err**2))),
        max_rel_error=float(err.max()),
        iterations=int(stats.get("iter_count", -1)),
        status=str(stats.get("return_status")),
        scaling=scaling,
    )
