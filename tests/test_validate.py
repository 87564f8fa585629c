"""One frequency check and one Poisson-ratio check, used by every model that takes them.

The FE chain, the lumped chain, the FE ear and the lumped ear used to disagree
on an empty frequency list (two computed an empty response, one refused it);
now all four refuse the same inputs with the same message.
"""

import math

import numpy as np
import pytest

from isj.errors import InvalidParameter
from isj.validate import check_band, check_frequencies, check_poisson

BAD_FREQUENCIES = [[], [100.0, float("nan")], [float("inf")], [-1.0], [[100.0, 200.0]], "abc"]


@pytest.mark.parametrize("bad", BAD_FREQUENCIES, ids=["empty", "nan", "inf", "negative", "2d", "text"])
def test_check_frequencies_refuses_naming_the_parameter(bad):
    with pytest.raises(InvalidParameter, match=r"^f_hz\b.*finite numbers >= 0 \(Hz\)$"):
        check_frequencies(bad, "f_hz")


def test_check_frequencies_accepts_zero_and_scalars():
    assert check_frequencies(0.0).tolist() == [0.0]
    f = check_frequencies((1, 10, 100))
    assert f.dtype == float and f.shape == (3,) and f.tolist() == [1.0, 10.0, 100.0]


def _lumped_chain(f):
    from isj.lumped.artifact import default_calibration
    from isj.lumped.dynamics import chain_model

    cal = default_calibration()
    return chain_model(cal.factor_array(), cal.shear_factor).freq_resp(f)


def _lumped_ear(f):
    from isj.lumped.artifact import default_calibration
    from isj.lumped.ear import ear_model

    return ear_model(default_calibration().factor_array())._freq_resp(f)


def _fe_chain(f):
    from isj.fem.dynamics import harmonic

    return harmonic(None, f)  # refused before the model is touched


def _fe_ear(f):
    from isj.fem.ear.dynamics import harmonic

    return harmonic(None, f)


MODELS = {"lumped chain": _lumped_chain, "lumped ear": _lumped_ear, "FE chain": _fe_chain, "FE ear": _fe_ear}


@pytest.mark.parametrize("model", MODELS.values(), ids=MODELS.keys())
@pytest.mark.parametrize("bad", [[], [float("nan")], [-5.0]], ids=["empty", "nan", "negative"])
def test_every_model_refuses_the_same_frequencies(model, bad):
    with pytest.raises(InvalidParameter) as info:
        model(bad)
    assert str(info.value) == str(pytest.raises(InvalidParameter, check_frequencies, bad).value)


def test_lumped_models_accept_what_the_check_accepts():
    h = _lumped_chain([0.0, 1e3])
    assert h.shape[0] == 2 and np.all(np.isfinite(h))
    assert _lumped_ear([500.0]).shape[0] == 1


@pytest.mark.parametrize(
    "lo, hi", [(0.0, 10.0), (100.0, 100.0), (200.0, 100.0), (1.0, math.inf), (math.nan, 1.0), (True, 5.0)]
)
def test_check_band(lo, hi):
    with pytest.raises(InvalidParameter, match="^--lo/--hi = "):
        check_band(lo, hi, ("--lo", "--hi"))


def test_check_band_accepts_a_band():
    check_band(1.0, 2.0)


@pytest.mark.parametrize("bad", [True, False, 0.5, -1.0, math.nan, math.inf, "0.3", None])
def test_check_poisson_refuses(bad):
    rule = r"Poisson's ratio must be a finite number in \(-1, 0.5\)"
    with pytest.raises(InvalidParameter, match=rf"^nu_x = .*{rule}$"):
        check_poisson(bad, "nu_x")


@pytest.mark.parametrize("good", [-0.99, 0, 0.3, 0.4999])
def test_check_poisson_accepts(good):
    assert check_poisson(good) == float(good)


def _materials(nu):
    from isj.design import Materials

    return Materials(nu=nu)


def _ear_materials(nu):
    from isj.ear import EarMaterials

    return EarMaterials(drum_nu=nu)


def _shell(nu):
    from isj.fem.ear.shell import ShellMaterial

    return ShellMaterial(e_pa=20e6, nu=nu, thickness_m=40e-6)


POISSON_SITES = {
    "Materials": (_materials, "nu"),
    "EarMaterials": (_ear_materials, "drum_nu"),
    "shell": (_shell, "nu"),
}


@pytest.mark.parametrize("site, name", POISSON_SITES.values(), ids=POISSON_SITES.keys())
@pytest.mark.parametrize("bad", [False, 0.5, math.nan, -1.0])
def test_every_poisson_site_refuses_the_same_values(site, name, bad):
    with pytest.raises(InvalidParameter) as info:
        site(bad)
    assert str(info.value) == str(pytest.raises(InvalidParameter, check_poisson, bad, name).value)


@pytest.mark.parametrize("site, name", POISSON_SITES.values(), ids=POISSON_SITES.keys())
def test_every_poisson_site_accepts_a_valid_ratio(site, name):
    assert getattr(site(0.45), name) == 0.45
