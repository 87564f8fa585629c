"""Calibration fit: recovers known factors from synthetic data; a failed fit says so."""

import casadi  # noqa: F401 - a hard dependency: without it these tests fail, they do not skip
import numpy as np
import pytest
from isj.calibration.fit import fit_factors
from isj.lumped.model import FACTOR_NAMES, MODULI, Lever, equations

from isj.design import Geometry
from isj.errors import FitFailed


def synthetic_records(factors, n=40, seed=3):
    rng = np.random.default_rng(seed)
    bounds = {
        "pedicle_e_pa": (1e9, 27e9),
        "gap_e_pa": (1e6, 50e6),
        "capsule_e_pa": (10e6, 300e6),
        "plate_e_pa": (0.3e9, 5e9),
        "stapes_e_pa": (0.3e9, 5e9),
        "incus_e_pa": (12e9, 12e9),
    }
    E = {k: np.exp(rng.uniform(np.log(lo), np.log(hi), n)) for k, (lo, hi) in bounds.items()}
    a, b = equations(E, factors, Lever.from_geometry(Geometry()))
    return [
        {
            "design": {k: float(E[k][i]) for k in MODULI},
            "alpha_per_pa": float(a[i]),
            "beta_per_pa": float(b[i]),
        }
        for i in range(n)
    ]


def test_recovers_known_factors_exactly():
    true = np.array([0.98, 5.2, 2.7, 0.07, 1.15, 0.43, 0.04, 0.15, 0.76, 0.3, 0.05, 4.5, 0.0, 0.2])
    assert true.size == len(FACTOR_NAMES)
    res = fit_factors(synthetic_records(true))
    assert res.status == "Solve_Succeeded"
    assert np.allclose(res.factors, true, rtol=1e-6)
    assert res.max_rel_error < 1e-9


def test_failed_fit_raises_with_solver_statistics():
    true = np.full(len(FACTOR_NAMES), 3.0)
    with pytest.raises(FitFailed) as info:
        fit_factors(synthetic_records(true), max_iter=1)
    assert info.value.stats["return_status"] == "Maximum_Iterations_Exceeded"
    assert "iter_count" in info.value.stats
