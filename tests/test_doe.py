"""Design of experiments: seeded, inside the box, log-uniform (calibration.doe)."""

import json
import math

import numpy as np
import pytest
from isj.calibration.doe import corners, grid, sample

from isj.design_space import DesignSpace
from isj.errors import InvalidParameter

SPACE = DesignSpace()


def test_defaults_are_spec_ranges():
    assert SPACE.pedicle_e_pa == (1e9, 27e9)
    assert SPACE.gap_e_pa == (1e6, 50e6)
    assert SPACE.capsule_e_pa == (10e6, 300e6)
    assert SPACE.plate_e_pa == SPACE.stapes_e_pa == (0.3e9, 5e9)
    assert "incus_e_pa" not in SPACE.names


@pytest.mark.parametrize("method", ["sobol", "lhs"])
def test_seeded_and_inside(method):
    a = sample(SPACE, 64, seed=7, method=method)
    assert a == sample(SPACE, 64, seed=7, method=method)
    assert a != sample(SPACE, 64, seed=8, method=method)
    assert len(a) == 64 and all(set(d) == set(SPACE.names) for d in a)
    assert all(type(v) is float for d in a for v in d.values())
    assert SPACE.contains(a).all()
    e = np.array([[d[n] for n in SPACE.names] for d in a])
    assert np.all(e >= SPACE.lower) and np.all(e <= SPACE.upper)


@pytest.mark.parametrize("method", ["sobol", "lhs"])
def test_log_uniform(method):
    designs = sample(SPACE, 1024, seed=3, method=method)
    for name in SPACE.names:
        lo, hi = getattr(SPACE, name)
        x = (np.log10([d[name] for d in designs]) - math.log10(lo)) / math.log10(hi / lo)
        # uniform in log E: median at the log mid-point, each decile ~10 % of the points
        assert abs(np.median(x) - 0.5) < 0.02, name
        counts = np.histogram(x, bins=10, range=(0, 1))[0]
        assert np.all(np.abs(counts - 102.4) < 15), (name, counts)


def test_contains_tolerance_and_missing():
    lo = SPACE.lower
    d = dict(zip(SPACE.names, lo * (1 - 1e-12), strict=True))
    assert SPACE.contains([d]).tolist() == [True]
    assert SPACE.contains(d).tolist() == [True]  # a single design is accepted too
    out = {**d, "gap_e_pa": 0.9e6}
    missing = {k: v for k, v in d.items() if k != "capsule_e_pa"}
    nan = {**d, "plate_e_pa": float("nan")}
    assert SPACE.contains([out, missing, nan, {**d, "nu": 0.3}]).tolist() == [False, False, False, True]


def test_dict_round_trip_through_json():
    space = SPACE.replace(pedicle_e_pa=(2e9, 20e9))
    back = DesignSpace.from_dict(json.loads(json.dumps(space.to_dict())))
    assert back == space and hash(back) == hash(space)
    with pytest.raises(InvalidParameter, match="incus_e_pa"):
        DesignSpace.from_dict({"incus_e_pa": [1e9, 2e9]})
    with pytest.raises(InvalidParameter, match="gap_e_pa"):
        DesignSpace(gap_e_pa=(5e6, 1e6))


def test_corners_and_grid():
    c = corners(SPACE)
    assert len(c) == 32 and len({tuple(d.values()) for d in c}) == 32
    assert SPACE.contains(c).all()
    assert c[0] == dict(zip(SPACE.names, SPACE.lower, strict=True))
    g = grid(SPACE, "gap_e_pa", 5)
    gap = [d["gap_e_pa"] for d in g]
    assert gap[0] == 1e6 and gap[-1] == 50e6
    np.testing.assert_allclose(np.diff(np.log(gap)), math.log(50) / 4)
    assert all(d["pedicle_e_pa"] == pytest.approx(math.sqrt(27e18)) for d in g)
    with pytest.raises(ValueError, match="incus"):
        grid(SPACE, "incus_e_pa", 3)


def test_bad_arguments():
    with pytest.raises(ValueError, match="method"):
        sample(SPACE, 8, seed=0, method="grid")
    with pytest.raises(ValueError, match="n = 0"):
        sample(SPACE, 0, seed=0)
