"""From a design space to a calibration artifact: sample, evaluate FE, fit, validate.

The FE evaluator and its settings come from the caller (the command line passes
``fem.batch.evaluate_design``); results are cached and resumable through
:func:`calibration.runner.run_designs`.
"""

from __future__ import annotations

import datetime as _dt
from importlib import metadata

import numpy as np
from isj.lumped.artifact import CALIBRATED_JOINTS, Calibration
from isj.lumped.model import (
    FACTOR_NAMES,
    PLATE_SUPPORT_LIMIT,
    SCALED_TERMS,
    equations,
    moduli_arrays,
    plate_support_argument,
)

from isj.design import Geometry
from isj.design_space import DesignSpace
from isj.errors import InvalidParameter

from .doe import GeometrySpace, mixed_corners, sample, sample_with_geometry
from .fit import fit_factors, record_lever
from .runner import run_designs, run_geometry_designs


def settings_joint(settings: dict) -> str:
    """The joint of FE ``settings`` (``fem.batch.fe_settings``): its ``joint``, else bonded.

    The FE settings carry the joint into every cache key (a bonded and a sliding design never
    share a record) and, through :func:`calibrate`, into the artifact's ``joint``.
    """
    joint = settings.get("joint", "bonded")
    if joint not in CALIBRATED_JOINTS:
        raise InvalidParameter(
            f"settings['joint'] = {joint!r}: must be one of {', '.join(CALIBRATED_JOINTS)}"
        )
    return joint


def records_for_fit(records: list[dict], with_geometry: bool = False) -> list[dict]:
    """Runner records → fit records: α, β per pascal (the model is linear in the load).

    ``with_geometry``: each fit record also carries its FE settings' ``geometry`` (m), for a fit
    over geometry and moduli together.
    """
    out = []
    for r in records:
        p = r["settings"]["pressure_pa"]
        rec = {
            "design": r["design"],
            "alpha_per_pa": r["result"]["alpha_rad"] / p,
            "beta_per_pa": r["result"]["beta_rad"] / p,
        }
        if with_geometry:
            rec["geometry"] = dict(r["settings"].get("geometry") or {})
        out.append(rec)
    return out


def error_stats(
    factors,
    fit_records: list[dict],
    geometry: Geometry | None = None,
    joint: str = "bonded",
    scaling: dict | None = None,
) -> dict:
    """Relative errors of the lumped α, β, β/α against FE records: max and RMS, and the count.

    ``joint``: the records' FE joint, "bonded" or "sliding" (:func:`isj.lumped.model.equations`);
    ``scaling``: the calibration's ``geometry_scaling``.
    """
    designs = {k: np.array([r["design"][k] for r in fit_records]) for k in fit_records[0]["design"]}
    a_fe = np.array([r["alpha_per_pa"] for r in fit_records])
    b_fe = np.array([r["beta_per_pa"] for r in fit_records])
    lever = record_lever(fit_records, geometry, scaling)
    a, b = equations(moduli_arrays(designs), np.asarray(factors), lever, joint)
    out = {"n": len(fit_records)}
    for name, lum, fe in (("alpha", a, a_fe), ("beta", b, b_fe), ("ratio", b / a, b_fe / a_fe)):
        e = lum / fe - 1
        out[f"max_{name}"] = float(np.abs(e).max())
        out[f"rms_{name}"] = float(np.sqrt(np.mean(e**2)))
    return out


def support_arguments(factors, fit_records: list[dict], scaling: dict | None, joint: str = "bonded"):
    """The plate-support argument s of each record (lumped.model.plate_support_argument), an array."""
    E = moduli_arrays({k: np.array([r["design"][k] for r in fit_records]) for k in fit_records[0]["design"]})
    lever = record_lever(fit_records, None, scaling)
    f = dict(zip(FACTOR_NAMES, factors, strict=True))
    s = plate_support_argument(f["plate_support"], lever, E["gap_e_pa"], E["plate_e_pa"], joint)
    return np.atleast_1d(s)


def support_limited_errors(
    factors, fit_records: list[dict], scaling: dict | None, joint: str = "bonded"
) -> dict:
    """:func:`error_stats` of the records at or below the plate-support limit, and the count and
    largest errors of those beyond it (``n_beyond_support_limit``, ``max_alpha_beyond_support_limit``,
    ...)."""
    s = support_arguments(factors, fit_records, scaling, joint)
    inside = [r for r, v in zip(fit_records, s, strict=True) if v <= PLATE_SUPPORT_LIMIT]
    beyond = [r for r, v in zip(fit_records, s, strict=True) if v > PLATE_SUPPORT_LIMIT]
    stats = error_stats(factors, inside, joint=joint, scaling=scaling) if inside else {"n": 0}
    out = stats | {"n_beyond_support_limit": len(beyond)}
    if beyond:
        e = error_stats(factors, beyond, joint=joint, scaling=scaling)
        out |= {f"{k}_beyond_support_limit": e[k] for k in ("max_alpha", "max_beta", "max_ratio")}
    return out


def _versions() -> dict[str, str]:
    out = {}
    for name in ("isj", "numpy", "scipy", "casadi", "gmsh"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return out


def calibrate(
    evaluate,
    settings: dict,
    cache_dir,
    samples: int = 64,
    validation: int = 32,
    seed: int = 0,
    space: DesignSpace | None = None,
    scheduler=None,
    progress: bool = True,
) -> Calibration:
    """Sample ``samples`` training and ``validation`` held-out designs, evaluate, fit, validate.

    Training designs are a scrambled Sobol sample (seeded); validation designs a
    Latin hypercube with another seed, so the fit never sees them.
    """
    space = space or DesignSpace()
    train = sample(space, samples, seed, method="sobol")
    held = sample(space, validation, seed + 1, method="lhs") if validation else []
    records = run_designs(train + held, evaluate, settings, cache_dir, scheduler=scheduler, progress=progress)
    fit_rec = records_for_fit(records)
    train_rec, held_rec = fit_rec[: len(train)], fit_rec[len(train) :]
    geometry = Geometry(**settings["geometry"]) if "geometry" in settings else Geometry()
    joint = settings_joint(settings)
    res = fit_factors(train_rec, geometry, joint=joint)
    mesh_hashes = sorted({r["result"].get("mesh_hash", "") for r in records})
    return Calibration(
        joint=joint,
        factors={n: float(v) for n, v in zip(FACTOR_NAMES, res.factors, strict=True)},
        domain=space.to_dict(),
        training=error_stats(res.factors, train_rec, geometry, joint) | {"ipopt_iterations": res.iterations},
        validation=error_stats(res.factors, held_rec, geometry, joint) if held_rec else {},
        fe_settings={k: v for k, v in settings.items()} | {"mesh_hash": mesh_hashes},
        provenance={
            "samples": samples,
            "validation_samples": validation,
            "seed": seed,
            "versions": _versions(),
            "date": _dt.date.today().isoformat(),
        },
    )


def geometry_designs(
    space: DesignSpace, geometry: GeometrySpace, samples: int, validation: int, seed: int
) -> tuple[list[tuple[dict, dict]], list[tuple[dict, dict]]]:
    """Training (scrambled Sobol', ``seed``) and held-out (Latin hypercube, ``seed + 1``) designs.

    Each a list of ``(moduli (Pa), dimensions (m))`` from :func:`calibration.doe.sample_with_geometry`.
    """
    train = sample_with_geometry(space, geometry, samples, seed, method="sobol")
    held = sample_with_geometry(space, geometry, validation, seed + 1, method="lhs") if validation else []
    return train, held


#: Training designs of the shipped geometry calibration: with the geometric exponents of every
#: term fitted (14 terms × 8 dimensions, docs/lumped.md §3.16), 96 designs held their own
#: errors to 2 % but missed 192 unseen ones by up to 12 %; 288 missed them by up to 7.5 %.
GEOMETRY_SAMPLES = 480


def geometry_fit_start() -> np.ndarray:
    """Start of the geometry fit: the shipped moduli-only factors, root_plate 0.5.

    From every factor at 1 IPOPT settles in a poorer minimum (the plate face's e^(−s) cos s).
    """
    from isj.lumped.artifact import default_calibration

    x0 = default_calibration().factor_array()
    x0[FACTOR_NAMES.index("root_plate")] = 0.5
    return x0


def calibrate_geometry(
    evaluate,
    settings: dict,
    cache_dir,
    samples: int = GEOMETRY_SAMPLES,
    validation: int = 64,
    seed: int = 0,
    space: DesignSpace | None = None,
    geometry: GeometrySpace | None = None,
    max_workers: int | None = 1,
    progress: bool = True,
    scheduler=None,
) -> Calibration:
    """:func:`calibrate` over geometry and moduli together (docs/lumped.md §3.13).

    Every design has its own moduli and dimensions (:func:`geometry_designs`); the fit sees each
    design's geometry through its own :class:`~isj.lumped.model.Lever`. The artifact records the
    geometric domain under ``geometry_domain`` and the errors at :func:`calibration.doe.mixed_corners`
    under ``corners``. ``scheduler`` (a Dask address or client) runs the FE designs on a cluster
    (:func:`calibration.runner.run_geometry_designs`) instead of ``max_workers`` local processes.
    """
    space = space or DesignSpace()
    geometry = geometry or GeometrySpace()
    train, held = geometry_designs(space, geometry, samples, validation, seed)
    corners = mixed_corners(space, geometry)
    items = train + held + [(m, g) for _, m, g in corners]
    records = run_geometry_designs(
        items, evaluate, settings, cache_dir, max_workers=max_workers, progress=progress, scheduler=scheduler
    )
    return geometry_calibration_from_records(
        records,
        len(train),
        len(held),
        [c[0] for c in corners],
        space,
        geometry,
        settings,
        samples,
        validation,
        seed,
    )


def geometry_calibration_from_records(
    records, n_train, n_held, corner_labels, space, geometry, settings, samples, validation, seed
) -> Calibration:
    """The artifact of :func:`calibrate_geometry` from its runner records (training, held-out, corners).

    The fit and the claim cover the designs whose plate-support argument s stays at or below
    :data:`~isj.lumped.model.PLATE_SUPPORT_LIMIT` (docs/lumped.md §3.16): fitted on all training
    designs, then refitted on those below the limit until that set stops changing. The errors
    of the held-out designs below it are ``validation``'s; those beyond it are counted
    (``n_beyond_support_limit``) with their largest errors; the corners record their s.
    """
    corners = [(label,) for label in corner_labels]
    fit_rec = records_for_fit(records, with_geometry=True)
    n1, n2 = n_train, n_train + n_held
    train_rec, held_rec, corner_rec = fit_rec[:n1], fit_rec[n1:n2], fit_rec[n2:]
    joint = settings_joint(settings)
    keep = list(range(n1))
    for _ in range(8):
        res = fit_factors(
            [train_rec[i] for i in keep],
            x0=geometry_fit_start(),
            joint=joint,
            scaling_terms=tuple(SCALED_TERMS),
        )
        s = support_arguments(res.factors, train_rec, res.scaling, joint)
        below = [i for i in range(n1) if s[i] <= PLATE_SUPPORT_LIMIT]
        if below == keep or not below:  # none below: keep the last fit rather than fit nothing
            break
        keep = below
    scaling = res.scaling
    mesh_hashes = sorted({r["result"].get("mesh_hash", "") for r in records[:n1]})
    corner_errors = {}
    for (label,), rec in zip(corners, corner_rec, strict=True):
        e = error_stats(res.factors, [rec], joint=joint, scaling=scaling)
        s_corner = float(support_arguments(res.factors, [rec], scaling, joint)[0])
        corner_errors[label] = {"alpha": e["max_alpha"], "beta": e["max_beta"], "plate_support": s_corner}
    fe = {k: v for k, v in settings.items()} | {"n_meshes": len(mesh_hashes)}
    fitted = [train_rec[i] for i in keep]
    held_stats = support_limited_errors(res.factors, held_rec, scaling, joint) if held_rec else {}
    return Calibration(
        joint=joint,
        factors={n: float(v) for n, v in zip(FACTOR_NAMES, res.factors, strict=True)},
        domain=space.to_dict(),
        geometry_domain=geometry.to_dict(),
        training=error_stats(res.factors, fitted, joint=joint, scaling=scaling)
        | {
            "ipopt_iterations": res.iterations,
            "n_beyond_support_limit": n1 - len(keep),
            "plate_support_limit": PLATE_SUPPORT_LIMIT,
        },
        validation=held_stats,
        corners=corner_errors,
        geometry_scaling=scaling,
        fe_settings=fe,
        provenance={
            "samples": samples,
            "validation_samples": validation,
            "seed": seed,
            "versions": _versions(),
            "date": _dt.date.today().isoformat(),
        },
    )


def frequency_errors(
    factors,
    shear_factor: float,
    designs: list[dict],
    fe_freq_hz,
    geometry: Geometry | None = None,
    joint: str = "bonded",
) -> dict:
    """Relative errors of the chain model's first two natural frequencies against FE in-plane ones.

    Parameters
    ----------
    factors : calibrated static factors
    shear_factor : the chain's joint shear factor (dimensionless)
    designs : moduli (Pa) per design
    fe_freq_hz : (n_design, 2) FE first and second in-plane natural frequencies (Hz)
    geometry : dimensions (m)
    joint : "bonded" or "sliding" (the chain's shear spring, :func:`isj.lumped.dynamics.chain_model`)

    Returns
    -------
    dict with ``n`` and ``max_f1``, ``rms_f1``, ``max_f2``, ``rms_f2`` (relative)
    """
    from isj.lumped.dynamics import chain_model

    moduli = {k: np.array([d[k] for d in designs]) for k in designs[0]}
    fe = np.asarray(fe_freq_hz, dtype=float)
    f, _ = chain_model(factors, shear_factor, geometry, rayleigh_b_s=0.0, joint=joint, **moduli).poles()
    out = {"n": len(designs)}
    for i in range(min(2, fe.shape[1])):
        e = f[:, i] / fe[:, i] - 1
        out |= {f"max_f{i + 1}": float(np.abs(e).max()), f"rms_f{i + 1}": float(np.sqrt(np.mean(e**2)))}
    return out


def fit_shear(
    factors,
    designs: list[dict],
    fe_freq_hz: np.ndarray,
    geometry: Geometry | None = None,
    joint: str = "bonded",
) -> dict:
    """Fit the chain model's joint shear factor to FE second in-plane natural frequencies (Hz).

    The static factors fix every other spring (and so the first frequency, within a few per
    cent); the joint's shear sets the second mode. One parameter, least squares on the relative
    errors of the second frequency, bounded scalar minimisation over log f_shear in
    [log 0.01, log 100].

    Parameters
    ----------
    factors : calibrated static factors
    designs : moduli (Pa) per design
    fe_freq_hz : (n_design, 2) FE first and second in-plane natural frequencies (Hz)
    geometry : dimensions (m)
    joint : "bonded" or "sliding" (with sliding, the gap carries no shear: docs/lumped.md §3.14)

    Returns
    -------
    dict: ``shear_factor`` and the errors of :func:`frequency_errors` at it
    """
    from isj.lumped.dynamics import chain_model
    from scipy.optimize import minimize_scalar

    moduli = {k: np.array([d[k] for d in designs]) for k in designs[0]}
    fe = np.asarray(fe_freq_hz, dtype=float)
    if fe.ndim != 2 or fe.shape[1] < 2:
        raise ValueError("fe_freq_hz: need the first two in-plane frequencies per design, shape (n, 2)")

    def cost(log_f):
        f, _ = chain_model(
            factors, float(np.exp(log_f)), geometry, rayleigh_b_s=0.0, joint=joint, **moduli
        ).poles()
        return float(np.sum((f[:, 1] / fe[:, 1] - 1) ** 2))

    res = minimize_scalar(
        cost, bounds=(np.log(0.01), np.log(100.0)), method="bounded", options={"xatol": 1e-8}
    )
    shear = float(np.exp(res.x))
    return {"shear_factor": shear} | frequency_errors(factors, shear, designs, fe, geometry, joint)


def calibrate_dynamics(
    cal: Calibration,
    evaluate_modes,
    settings: dict,
    cache_dir,
    samples: int = 16,
    validation: int = 8,
    seed: int = 100,
    progress: bool = True,
) -> Calibration:
    """Extend a calibration: the chain's joint shear factor fitted to FE modal frequencies.

    ``samples`` training designs (Sobol) and ``validation`` held-out ones (Latin hypercube, another
    seed) from the calibration's domain; FE modal analyses (cached); :func:`fit_shear` on the
    training designs. Stores ``dynamics = {"shear_factor", "training", "validation"}``, each error
    block as :func:`frequency_errors` (f1 and f2, max and RMS).
    """
    import dataclasses

    if settings_joint(settings) != cal.joint:
        raise InvalidParameter(
            f"settings['joint'] = {settings_joint(settings)!r}: the calibration is for the {cal.joint} joint"
        )
    space = DesignSpace.from_dict(cal.domain)
    train = sample(space, samples, seed, method="sobol")
    held = sample(space, validation, seed + 1, method="lhs") if validation else []
    msettings = dict(settings, kind="modes", n_modes=6)
    recs = run_designs(train + held, evaluate_modes, msettings, cache_dir, progress=progress)
    fe = np.array([r["result"]["in_plane_freq_hz"][:2] for r in recs])
    geometry = Geometry(**settings["geometry"]) if "geometry" in settings else Geometry()
    fit = fit_shear(cal.factor_array(), train, fe[: len(train)], geometry, cal.joint)
    dyn = {"shear_factor": fit["shear_factor"], "training": fit, "validation": {}}
    if held:
        dyn["validation"] = frequency_errors(
            cal.factor_array(), fit["shear_factor"], held, fe[len(train) :], geometry, cal.joint
        )
    return dataclasses.replace(cal, dynamics=dyn)
