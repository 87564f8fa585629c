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
