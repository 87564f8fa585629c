"""One vocabulary for every public model: ``static``, ``frequency_response``, ``natural_frequencies_hz``.

Each model answers to the same three names (the surrogate, static only, documents why it has
no dynamics); ``static(...).to_dict()`` carries the result's numbers unchanged, and
``frequency_response`` returns an :class:`isj.responses.FrequencyResponse` whose numbers are
those of the model's own array path. The lumped models are microseconds; the FE models use the
coarse test mesh (``coarse_model``, P2 at resolution 0.35).
"""

import inspect
import json

import numpy as np
import pytest
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.ear.reduced_ear import ReducedEar, reduced_ear
from isj.fem.model import PedicleJointModel
from isj.fem.rom.model import ReducedModel
from isj.lumped.api import LumpedModel
from isj.lumped.ear import OUTPUTS, LumpedEar

import isj
from isj.design_space import BOX_SLACK, DesignSpace, inside
from isj.responses import FrequencyResponse

VOCABULARY = ("static", "frequency_response", "natural_frequencies_hz")

#: Every public model class and the names it lacks, with the reason its docstring gives.
MODELS = {
    PedicleJointModel: (),
    MiddleEarModel: (),
    ReducedEar: (),
    LumpedModel: (),
    LumpedEar: (),
    ReducedModel: ("frequency_response", "natural_frequencies_hz"),
}

#: Names of the dialects the vocabulary replaced: no public model keeps them.
OLD_NAMES = (
    "solve",
    "harmonic",
    "response",
    "freq_resp",
    "outputs",
    "static_response",
    "chain_response",
    "ear_response",
    "natural_frequencies",
)


@pytest.mark.parametrize("cls", list(MODELS), ids=lambda c: c.__name__)
def test_every_model_answers_to_the_three_names_or_says_why_not(cls):
    missing = MODELS[cls]
    for name in VOCABULARY:
        if name in missing:
            assert not hasattr(cls, name)
            assert name in inspect.getdoc(cls), f"{cls.__name__}'s docstring must say why it has no {name}"
        else:
            assert callable(getattr(cls, name)), (cls.__name__, name)
    assert [n for n in OLD_NAMES if hasattr(cls, n)] == [], cls.__name__


def test_the_surrogate_says_it_is_static_only():
    assert "static only" in inspect.getdoc(ReducedModel)


# ---- the lumped models (microseconds) ------------------------------------------------------------


@pytest.fixture(scope="module")
def lm():
    return LumpedModel.default()


def test_lumped_joint_static_to_dict_round_trips_the_numbers(lm):
    r = lm.static(gap_e_pa=7e6, pressure_pa=30.0)
    d = json.loads(json.dumps(r.to_dict()))
    assert d["alpha_rad"] == float(r.alpha_rad) and d["beta_rad"] == float(r.beta_rad)
    assert d["beta_over_alpha"] == float(r.beta_rad) / float(r.alpha_rad)
    assert d["pressure_pa"] == 30.0


def test_lumped_joint_frequency_response_and_modes(lm):
    f = np.array([0.0, 500.0, 5000.0])
    r = lm.frequency_response(f, gap_e_pa=7e6, pressure_pa=30.0)
    assert isinstance(r, FrequencyResponse) and r.input_amplitude == 30.0
    # at 0 Hz the chain's static α is the calibrated static model's, up to the loss factors' i η K
    static = lm.static(gap_e_pa=7e6, pressure_pa=30.0)
    assert abs(r["alpha_rad"][0]) == pytest.approx(float(static.alpha_rad), rel=0.02)
    f_n = lm.natural_frequencies_hz(gap_e_pa=7e6)
    assert f_n.shape == (8,) and np.all(np.diff(f_n) > 0) and np.all(f_n > 0)
    np.testing.assert_array_equal(lm.natural_frequencies_hz(3, gap_e_pa=7e6), f_n[:3])


def test_lumped_ear_static_to_dict_and_the_response_at_0_hz(lm):
    ear = lm.ear(gap_e_pa=7e6, damping="undamped")
    s = ear.static(2.0)
    d = json.loads(json.dumps(s.to_dict()))
    assert [d[k] for k in OUTPUTS] == [float(v) for v in s.outputs] and d["pressure_pa"] == 2.0
    np.testing.assert_array_equal(s.outputs, 2.0 * ear.static().outputs)
    r = ear.frequency_response([0.0, 800.0], pressure_pa=2.0)
    assert r.output_names == OUTPUTS and r.input_amplitude == 2.0
    # undamped at 0 Hz: the dynamic response is the static one (a different solve path)
    np.testing.assert_allclose(r.response[0, :, 0].real, s.outputs, rtol=1e-10)
    np.testing.assert_array_equal(r.response[..., 0], ear._freq_resp([0.0, 800.0], 2.0))
    f_n = ear.natural_frequencies_hz()
    assert np.all(np.diff(f_n) >= 0) and f_n[0] > 0
    np.testing.assert_array_equal(ear.natural_frequencies_hz(2), f_n[:2])


def test_lumped_ear_refuses_many_designs_for_one_response(lm):
    many = lm.ear(gap_e_pa=np.array([3e6, 3e7]))
    assert many.static().outputs.shape == (2, 4)
    with pytest.raises(isj.InvalidParameter, match="one design"):
        many.frequency_response([100.0])


# ---- the FE models (the coarse test mesh) --------------------------------------------------------


@pytest.mark.slow
def test_fe_joint_static_to_dict_and_modes(coarse_model):
    r = coarse_model.static(isj.Materials(gap_e_pa=7e6), 30.0)
    d = json.loads(json.dumps(r.to_dict()))
    assert d["alpha_rad"] == r.alpha_rad and d["beta_rad"] == r.beta_rad and d["pressure_pa"] == 30.0
    assert sum(d["strain_energy_fraction"].values()) == pytest.approx(1.0, rel=1e-12)
    f = coarse_model.natural_frequencies_hz(3)
    assert f.shape == (3,) and np.all(np.diff(f) >= 0) and f[0] > 0


def test_fe_joint_frequency_response_at_0_hz_undamped_is_the_static_one(coarse_model):
    m = isj.Materials(gap_e_pa=7e6)
    r = coarse_model.frequency_response([0.0], m, isj.Damping.preset("undamped"), pressure_pa=30.0)
    s = coarse_model.static(m, 30.0)
    assert isinstance(r, FrequencyResponse)
    assert r["alpha_rad"][0].real == pytest.approx(s.alpha_rad, rel=1e-9)
    assert r["beta_rad"][0].real == pytest.approx(s.beta_rad, rel=1e-9)


@pytest.fixture(scope="module")
def rigid_ear():
    return MiddleEarModel(joint=None)


def test_fe_ear_static_to_dict_and_the_three_names(rigid_ear):
    s = rigid_ear.static()
    d = json.loads(json.dumps(s.to_dict()))
    assert (
        d["umbo_m_per_pa"] == s.umbo_m_per_pa
        and d["footplate_piston_m_per_pa"] == s.footplate_piston_m_per_pa
    )
    r = rigid_ear.frequency_response([1.0], damping=isj.Damping.preset("undamped"))
    assert isinstance(r, FrequencyResponse) and r.output_names == OUTPUTS
    assert abs(r["stapes_m"][0]) == pytest.approx(s.footplate_piston_m_per_pa, rel=1e-6)
    f = rigid_ear.natural_frequencies_hz(2)
    assert f.shape == (2,) and 0 < f[0] <= f[1]


@pytest.mark.slow
def test_reduced_ear_static_to_dict_and_the_three_names(rigid_ear):
    rom = reduced_ear(rigid_ear, fmax_hz=5000.0)
    s = rom.static()
    d = json.loads(json.dumps(s.to_dict()))
    assert d["umbo_vector_m_per_pa"] == [float(v) for v in s.umbo_vector_m_per_pa]
    assert d["alpha_rad_per_pa"] is None and d["beta_rad_per_pa"] is None  # the rigid joint
    # the reduction is exact at 0 Hz: the FE ear's static footplate
    np.testing.assert_allclose(s.footplate_m_per_pa, rigid_ear.static().footplate_m_per_pa, rtol=1e-8)
    r = rom.frequency_response([100.0, 1000.0])
    assert isinstance(r, FrequencyResponse) and "stapes_velocity_m_s" in r
    f = rom.natural_frequencies_hz(2)
    assert f.shape == (2,) and 0 < f[0] <= f[1]


# ---- one design space, one box test ---------------------------------------------------------------


def test_one_box_test_with_one_slack():
    lo, hi = 1e6, 50e6
    assert inside(hi * (1 + 0.5 * BOX_SLACK), lo, hi) and not inside(hi * (1 + 2 * BOX_SLACK), lo, hi)
    assert inside(lo * (1 - 0.5 * BOX_SLACK), lo, hi) and not inside(lo * (1 - 2 * BOX_SLACK), lo, hi)
    assert not inside(np.nan, lo, hi) and not inside(np.inf, lo, hi)
    space = DesignSpace()
    edge = {**space.mid(), "gap_e_pa": hi * (1 + 0.5 * BOX_SLACK)}
    assert space.contains(edge).tolist() == [True]
    E = np.array([[edge[k] for k in space.names]])
    assert space.check(E) is not None  # the surrogate's check: the same test
    with pytest.raises(isj.InvalidParameter, match="gap_e_pa"):
        space.check(E * np.array([1, 1 + 2 * BOX_SLACK, 1, 1, 1]))


def test_the_design_space_serves_both_views_with_the_same_box():
    space = DesignSpace(gap_e_pa=(2e6, 20e6))
    assert DesignSpace.from_dict(space.to_dict()) == space
    assert DesignSpace.from_record(space.to_record()) == space
    c = space.corners()
    assert c.shape == (32, 5) and set(c[:, 1]) == {2e6, 20e6}
    t = np.array([[0.0, 0.5, 1.0, 0.25, 0.75]])
    np.testing.assert_allclose(space.to_unit(space.from_unit(t)), t, atol=1e-15)
    rows = space.designs_from_unit(t)
    assert space.contains(rows).all()
    np.testing.assert_allclose([rows[0][k] for k in space.names], space.from_unit(t)[0], rtol=1e-14)
