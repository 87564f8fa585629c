"""From a design space to a calibration artifact: sample, evaluate FE, fit, validate.

The FE evaluator and its settings come from the caller (the command line passes
``fem.batch.evaluate_design``); results are cached and resumable through
:func:`calibration.runner.run_designs`.
"""

from __future__ import annotations

import datetime as _dt
from importlib import metadata

import numpy as np

from isj.design import Geometry
from lumped.artifact import Calibration
from lumped.model import FACTOR_NAMES, Lever, equations, moduli_arrays

from .doe import DesignSpace, sample
from .fit import fit_factors
from .runner import run_designs


def records_for_fit(records: list[dict]) -> list[dict]:
    """Runner records → fit records: α, β per pascal (the model is linear in the load)."""
    out = []
    for r in records:
        p = r["settings"]["pressure_pa"]
        out.append(
            {
                "design": r["design"],
                "alpha_per_pa": r["result"]["alpha_rad"] / p,
                "beta_per_pa": r["result"]["beta_rad"] / p,
            }
        )
    return out


def error_stats(factors, fit_records: list[dict], geometry: Geometry | None = None) -> dict:
    """Relative errors of the lumped α, β, β/α against FE records: max and RMS, and the count."""
    designs = {k: np.array([r["design"][k] for r in fit_records]) for k in fit_records[0]["design"]}
    a_fe = np.array([r["alpha_per_pa"] for r in fit_records])
    b_fe = np.array([r["beta_per_pa"] for r in fit_records])
    a, b = equations(moduli_arrays(designs), np.asarray(factors), Lever.from_geometry(geometry or Geometry()))
    out = {"n": len(fit_records)}
    for name, lum, fe in (("alpha", a, a_fe), ("beta", b, b_fe), ("ratio", b / a, b_fe / a_fe)):
        e = lum / fe - 1
        out[f"max_{name}"] = float(np.abs(e).max())
        out[f"rms_{name}"] = float(np.sqrt(np.mean(e**2)))
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
    res = fit_factors(train_rec, geometry)
    mesh_hashes = sorted({r["result"].get("mesh_hash", "") for r in records})
    return Calibration(
        factors={n: float(v) for n, v in zip(FACTOR_NAMES, res.factors, strict=True)},
        domain=space.to_dict(),
        training=error_stats(res.factors, train_rec, geometry) | {"ipopt_iterations": res.iterations},
        validation=error_stats(res.factors, held_rec, geometry) if held_rec else {},
        fe_settings={k: v for k, v in settings.items()} | {"mesh_hash": mesh_hashes},
        provenance={
            "samples": samples,
            "validation_samples": validation,
            "seed": seed,
            "versions": _versions(),
            "date": _dt.date.today().isoformat(),
        },
    )


def fit_hinge(factors, designs: list[dict], fe_freq_hz: np.ndarray, geometry: Geometry | None = None) -> dict:
    """Fit the chain model's hinge fraction to FE first in-plane frequencies (Hz).

    One parameter in [0, 1], least squares on relative errors (bounded scalar
    minimisation). Returns the fraction and the errors of the first and second
    in-plane frequencies.
    """
    from scipy.optimize import minimize_scalar

    from lumped.dynamics import chain_model

    moduli = {k: np.array([d[k] for d in designs]) for k in designs[0]}
    fe = np.asarray(fe_freq_hz, dtype=float)

    def lumped_f(h):
        f, _ = chain_model(factors, h, geometry, rayleigh_b_s=0.0, **moduli).poles()
        return f

    res = minimize_scalar(
        lambda h: np.sum((lumped_f(h)[:, 0] / fe[:, 0] - 1) ** 2),
        bounds=(0, 1),
        method="bounded",
        options={"xatol": 1e-6},
    )
    f = lumped_f(res.x)
    e1 = f[:, 0] / fe[:, 0] - 1
    out = {
        "hinge_fraction": float(res.x),
        "n": len(designs),
        "max_f1": float(np.abs(e1).max()),
        "rms_f1": float(np.sqrt(np.mean(e1**2))),
    }
    if fe.shape[1] > 1:
        e2 = f[:, 1] / fe[:, 1] - 1
        out |= {"max_f2": float(np.abs(e2).max()), "rms_f2": float(np.sqrt(np.mean(e2**2)))}
    return out


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
    """Extend a calibration: hinge fraction fitted to FE modal frequencies, checked on held-out designs."""
    import dataclasses

    space = DesignSpace.from_dict(cal.domain)
    train = sample(space, samples, seed, method="sobol")
    held = sample(space, validation, seed + 1, method="lhs") if validation else []
    msettings = dict(settings, kind="modes", n_modes=6)
    recs = run_designs(train + held, evaluate_modes, msettings, cache_dir, progress=progress)
    fe = np.array([r["result"]["in_plane_freq_hz"][:2] for r in recs])
    geometry = Geometry(**settings["geometry"]) if "geometry" in settings else Geometry()
    fit = fit_hinge(cal.factor_array(), train, fe[: len(train)], geometry)
    dyn = {"hinge_fraction": fit["hinge_fraction"], "training": fit}
    if held:
        from lumped.dynamics import chain_model

        moduli = {k: np.array([d[k] for d in held]) for k in held[0]}
        f, _ = chain_model(
            cal.factor_array(), fit["hinge_fraction"], geometry, rayleigh_b_s=0.0, **moduli
        ).poles()
        e1 = f[:, 0] / fe[len(train) :, 0] - 1
        e2 = f[:, 1] / fe[len(train) :, 1] - 1
        dyn["validation"] = {
            "n": len(held),
            "max_f1": float(np.abs(e1).max()),
            "rms_f1": float(np.sqrt(np.mean(e1**2))),
            "max_f2": float(np.abs(e2).max()),
        }
    return dataclasses.replace(cal, dynamics=dyn)
