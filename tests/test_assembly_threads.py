"""The stiffness and mass sums give the same bits on any number of threads."""

import numpy as np
import pytest
from isj.fem import assembly
from isj.fem.assembly import assemble_mass, combine


@pytest.fixture
def every_region_split(monkeypatch):
    # the coarse model's regions are small: split each one among the threads anyway
    monkeypatch.setattr(assembly, "_MIN_PAIRS_PER_THREAD", 1)


def _sum_on(threads: int, monkeypatch, model, coef, part="stiffness") -> np.ndarray:
    monkeypatch.setenv("ISJ_SOLVER_THREADS", str(threads))
    return combine(model.pattern, model.regions, coef, part)


@pytest.mark.parametrize("nu_zero", [False, True])
def test_stiffness_sum_same_bits_on_one_and_three_threads(
    coarse_model, monkeypatch, every_region_split, nu_zero
):
    rng = np.random.default_rng(3)
    coef = {
        r: (0.0 if nu_zero else rng.uniform(1e6, 1e9), rng.uniform(1e6, 1e9)) for r in coarse_model.regions
    }
    one = _sum_on(1, monkeypatch, coarse_model, coef)
    three = _sum_on(3, monkeypatch, coarse_model, coef)
    assert one.tobytes() == three.tobytes()
    # and the sum is the sum: each region's own entries, added up
    by_region = sum(
        combine(coarse_model.pattern, {r: rm}, {r: coef[r]}) for r, rm in coarse_model.regions.items()
    )
    np.testing.assert_allclose(three, by_region, rtol=1e-13, atol=1e-13 * np.abs(three).max())


def test_mass_sum_same_bits_on_one_and_two_threads(coarse_model, monkeypatch, every_region_split):
    assemble_mass(coarse_model.space, coarse_model.pattern, coarse_model.regions)
    coef = {r: (1000.0 + 100 * i, 0.0) for i, r in enumerate(coarse_model.regions)}
    one = _sum_on(1, monkeypatch, coarse_model, coef, "mass")
    two = _sum_on(2, monkeypatch, coarse_model, coef, "mass")
    assert one.tobytes() == two.tobytes()
    # a conservation law: the consistent mass sums to the body's mass, three times (x, y, z)
    space = coarse_model.space
    mass_kg = sum(
        coef[name][0] * space.det[space.region == rid].sum() / 6
        for rid, name in enumerate(space.region_names)
    )
    np.testing.assert_allclose(two.sum(), 3 * mass_kg, rtol=1e-12)
