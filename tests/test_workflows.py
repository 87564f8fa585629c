"""The workflows the CLI, the report and the benchmarks share (isj.calibration.checks, .sweeps, .explore).

FE enters these through an evaluator passed in; here a fake evaluator returns
the lumped model's own answer scaled by a known factor, so every error the
tables report is known exactly, without meshing anything.
"""

import math
import warnings

import numpy as np
import pytest
from isj.calibration.checks import (
    STATIC_KEYS,
    compare_static,
    lumped_static,
    static_row,
    warn_fe_settings,
    warn_outside_domain,
)
from isj.lumped.artifact import default_calibration

from isj.design import Materials
from isj.design_space import DesignSpace
from isj.errors import CalibrationWarning, InvalidParameter, OutOfDomainWarning
from isj.studies.explore import (
    MAX_DESIGNS,
    ExploreSpace,
    count_designs,
    explore,
    explore_designs,
    spot_check_picks,
)
from isj.studies.sweeps import HarmonicComparison, chain_sweep, compare_harmonic, fe_check_frequencies

#: The fake FE answers α·A_SCALE and β·B_SCALE of the lumped model.
A_SCALE, B_SCALE = 1.25, 0.8


def fake_fe(design, settings):
    """Picklable stand-in for isj.fem.batch.evaluate_design: the lumped α, β scaled."""
    r = lumped_static(default_calibration(), [design], None, settings["pressure_pa"])
    return {"alpha_rad": float(r.alpha_rad[0]) * A_SCALE, "beta_rad": float(r.beta_rad[0]) * B_SCALE}


SETTINGS = {"order": 1, "resolution": 0.5, "pressure_pa": 100.0}


@pytest.fixture(scope="module")
def cal():
    return default_calibration()


def _designs(n, seed=0):
    from isj.calibration.doe import sample

    return sample(DesignSpace.from_dict(default_calibration().domain), n, seed, method="lhs")


def test_static_row_identities():
    r = static_row(0.25, 0.375)  # exact in binary: the identities hold bit for bit
    assert list(r) == list(STATIC_KEYS)
    assert r["alpha_plus_beta_rad"] == 0.625 and r["beta_over_alpha"] == 1.5


def test_compare_static_errors_are_the_known_scales(cal, tmp_path):
    comp = compare_static(cal, _designs(5), fake_fe, SETTINGS, tmp_path, max_workers=0, progress=False)
    assert comp.n == 5
    np.testing.assert_allclose(comp.rel_error("alpha_rad"), 1 / A_SCALE - 1, rtol=1e-12)
    np.testing.assert_allclose(comp.rel_error("beta_rad"), 1 / B_SCALE - 1, rtol=1e-12)
    np.testing.assert_allclose(comp.rel_error("beta_over_alpha"), A_SCALE / B_SCALE - 1, rtol=1e-12)
    # the sum's error is the α- and β-weighted mean of the two
    la, lb = comp.lumped_alpha_rad, comp.lumped_beta_rad
    np.testing.assert_allclose(
        comp.rel_error("alpha_plus_beta_rad"), (la + lb) / (A_SCALE * la + B_SCALE * lb) - 1, rtol=1e-12
    )
    assert comp.max_abs_error() == pytest.approx(0.25)  # |1/0.8 − 1|
    assert not comp.passed(0.2499).any() and comp.passed(0.2501).all()
    s = comp.error_summary()
    keys = ("alpha_rad", "beta_rad", "beta_over_alpha")
    assert list(s) == [f"{p}_{k}" for p in ("max_abs", "rms") for k in keys]
    assert s["max_abs_alpha_rad"] == pytest.approx(0.2) and s["rms_beta_rad"] == pytest.approx(0.25)
    assert comp.fe_row(0)["alpha_rad"] == pytest.approx(A_SCALE * comp.lumped_row(0)["alpha_rad"], rel=1e-12)
    # the records went into the FE result cache: a second comparison evaluates nothing
    assert len(list(tmp_path.rglob("*.json"))) == 5


def test_compare_static_of_no_designs(cal, tmp_path):
    comp = compare_static(cal, [], fake_fe, SETTINGS, tmp_path)
    assert comp.n == 0 and comp.max_abs_error() == 0.0
    assert set(comp.error_summary().values()) == {None}
    assert not list(tmp_path.iterdir())


def test_lumped_static_takes_lists_and_columns_alike(cal):
    designs = _designs(4)
    cols = {k: np.array([d[k] for d in designs]) for k in designs[0]}
    a, b = lumped_static(cal, designs), lumped_static(cal, cols | {"nu": np.full(4, 0.3)})
    assert np.array_equal(a.alpha_rad, b.alpha_rad) and np.array_equal(a.beta_rad, b.beta_rad)


def test_domain_warnings(cal):
    lo, hi = cal.domain["gap_e_pa"]
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        assert warn_outside_domain(cal, {"gap_e_pa": np.array([lo, hi])}) == 0
        assert warn_outside_domain(cal, {"gap_e_pa": np.array([lo / 2, hi * 2, hi])}) == 2
    assert len(w) == 1 and issubclass(w[0].category, OutOfDomainWarning)
    assert "gap_e_pa" in str(w[0].message) and "2 design(s)" in str(w[0].message)
    fs = cal.fe_settings
    with pytest.warns(CalibrationWarning, match="discretisation errors differ"):
        assert warn_fe_settings(cal, 1, 0.5)
    if fs:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert not warn_fe_settings(cal, fs["order"], fs["resolution"])


def test_explore_grid_is_log_uniform_with_exact_ends():
    space = ExploreSpace.pinned(gap_e_pa=(1e6, 100e6), pedicle_e_pa=(1e9, 4e9))
    assert space.ranged == ("pedicle_e_pa", "gap_e_pa") and count_designs(space, 3) == 9
    d = explore_designs(space, 3)
    assert sorted(set(d["gap_e_pa"])) == pytest.approx([1e6, 10e6, 100e6], rel=1e-12)
    assert sorted(set(d["pedicle_e_pa"])) == pytest.approx([1e9, 2e9, 4e9], rel=1e-12)
    assert d["gap_e_pa"].min() == 1e6 and d["gap_e_pa"].max() == 100e6  # clipped to the box exactly
    m = Materials()
    for k in ("capsule_e_pa", "plate_e_pa", "stapes_e_pa", "incus_e_pa"):
        assert np.all(d[k] == getattr(m, k))  # pinned moduli keep their value bit for bit
    # every pair of (pedicle, gap) values appears once
    assert len({(a, b) for a, b in zip(d["pedicle_e_pa"], d["gap_e_pa"], strict=True)}) == 9


def test_explore_sample_lies_in_the_box_and_repeats_with_its_seed():
    space = ExploreSpace.pinned(incus_e_pa=(5e9, 20e9), capsule_e_pa=(10e6, 300e6))
    a, b = explore_designs(space, sample=64, seed=3), explore_designs(space, sample=64, seed=3)
    assert all(np.array_equal(a[k], b[k]) for k in a) and a["incus_e_pa"].size == 64
    assert a["incus_e_pa"].min() >= 5e9 and a["incus_e_pa"].max() <= 20e9
    # a Latin hypercube: one design in each of 64 equal bins of log E
    u = (np.log(a["capsule_e_pa"]) - math.log(10e6)) / (math.log(300e6) - math.log(10e6))
    assert sorted(np.floor(u * 64).astype(int)) == list(range(64))


def test_explore_refuses_too_many_designs_before_allocating():
    space = ExploreSpace.pinned(**{k: (1e6, 1e9) for k in ExploreSpace().names})
    assert count_designs(space, 100) == 100**6 > MAX_DESIGNS
    with pytest.raises(InvalidParameter, match="too many"):
        explore_designs(space, 100)
    with pytest.raises(InvalidParameter, match="sample"):
        count_designs(space, sample=0)


def test_columns_from_unit_is_from_unit():
    space = DesignSpace()
    u = np.random.default_rng(1).random((33, 5))
    cols, rows = space.columns_from_unit(u), space.designs_from_unit(u)
    assert all(cols[k][i] == r[k] for i, r in enumerate(rows) for k in space.names)


def test_spot_check_picks_start_at_the_extreme_corners():
    d = explore_designs(ExploreSpace.pinned(gap_e_pa=(1e6, 5e7), capsule_e_pa=(1e7, 3e8)), 4)
    picks = spot_check_picks(d, 5, seed=2)
    s = np.log(d["gap_e_pa"]) + np.log(d["capsule_e_pa"])
    assert picks[:2] == [int(np.argmin(s)), int(np.argmax(s))]
    assert len(picks) == len(set(picks)) == 5
    assert spot_check_picks(d, 0) == [] and spot_check_picks(d, 1) == [int(np.argmin(s))]


def test_explore_checks_its_picks(cal, tmp_path):
    d = explore_designs(ExploreSpace.pinned(gap_e_pa=cal.domain["gap_e_pa"]), 7)
    with pytest.warns(CalibrationWarning):  # SETTINGS is not the calibration's mesh
        ex = explore(cal, d, 3, fake_fe, SETTINGS, tmp_path, progress=False)
    assert ex.n_designs == 7 and ex.outside_domain == 0 and len(ex.picks) == 3
    np.testing.assert_allclose(ex.checks.lumped_alpha_rad, ex.lumped.alpha_rad[ex.picks], rtol=1e-14)
    np.testing.assert_allclose(ex.checks.rel_error("alpha_rad"), 1 / A_SCALE - 1, rtol=1e-12)


def test_fe_check_frequencies_inside_the_band():
    f = fe_check_frequencies(100.0, 10e3, 3)
    assert f.size == 3 and 100 < f[0] and f[-1] < 10e3
    np.testing.assert_allclose(f[1:] / f[:-1], 10**0.5, rtol=1e-12)  # log-spaced, quarter decades
    assert fe_check_frequencies(100.0, 10e3, 0).size == 0
    with pytest.raises(InvalidParameter):
        fe_check_frequencies(10e3, 100.0, 2)


def test_harmonic_comparison_errors_are_complex():
    lum = np.array([[1 + 1j, 2.0], [3j, -1.0]])

    def fe_response(f):
        return {"a": lum[:, 0] * (1 + 0.1j), "b": lum[:, 1] * 2}

    comp = compare_harmonic([10.0, 20.0], ("a", "b"), lambda f: lum, fe_response)
    assert isinstance(comp, HarmonicComparison)
    np.testing.assert_allclose(comp.rel_error[:, 0], abs(1 / (1 + 0.1j) - 1), rtol=1e-14)  # phase counts
    np.testing.assert_allclose(comp.rel_error[:, 1], 0.5, rtol=1e-14)
    assert comp.passed(0.2, ("a",)).all() and not comp.passed(0.2).any()
    assert comp.errors(1) == {"a": pytest.approx(0.0995037, rel=1e-6), "b": 0.5}


@pytest.mark.filterwarnings("ignore::isj.errors.DampingWarning")  # b = 2e-5 s: ωb > 0.5 above 4 kHz
def test_chain_sweep_is_the_chain_model(cal):
    from isj.lumped.dynamics import chain_model, chain_outputs

    m = Materials(gap_e_pa=20e6)
    f = np.geomspace(100, 5e3, 9)
    sw = chain_sweep(cal, f, m, rayleigh_b_s=2e-5, pressure_pa=50.0)
    moduli = {f"{r}_e_pa": m.youngs(r) for r in ("pedicle", "gap", "capsule", "plate", "stapes", "incus")}
    ref = chain_model(cal.factor_array(), cal.shear_factor, None, m, rayleigh_b_s=2e-5, **moduli)
    assert np.array_equal(sw.response, chain_outputs(ref, f, 50.0))
    assert np.array_equal(sw.natural_freq_hz, ref.poles()[0])
    # an FE response equal to the lumped one checks with zero error
    comp = sw.fe_checks([300.0], lambda q: chain_outputs(ref, q, 50.0))
    assert comp.outputs == sw.outputs and np.all(comp.rel_error < 1e-14)
