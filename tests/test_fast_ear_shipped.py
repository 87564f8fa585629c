"""The fast ear shipped with isj (fem/ear/data, docs/fast_ear.md §14.7): keyed, whole, and accurate."""

from __future__ import annotations

import numpy as np
import pytest
from test_cache_entries import flip_a_stored_byte

from isj.design import Materials
from isj.errors import CacheWarning

# the mechanism on the session's coarse fast ear (tests/conftest.py), the default one on its own
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("coarse_fast_ear")]

FREQ_HZ = np.geomspace(100.0, 20e3, 40)


def _same(a, b) -> bool:
    return list(a) == list(b) and all(a[k].dtype == b[k].dtype and np.array_equal(a[k], b[k]) for k in a)


def test_the_default_fast_ears_ship_under_their_current_keys():
    from isj.fem.ear.fast_ear import SHIPPED_DIR, cache_key_of
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.model import PedicleJointModel

    # the bonded joint's (every case) and the sliding joint's (the transmission step's sliding case)
    keys = [
        cache_key_of(MiddleEarModel(joint=PedicleJointModel(order=2, resolution=1.0, joint=joint)))
        for joint in ("bonded", "sliding")
    ]
    assert keys[0] != keys[1]
    shipped = sorted(p.name for p in SHIPPED_DIR.glob("fast-ear-*.npz"))
    assert shipped == sorted(f"fast-ear-{key[:32]}.npz" for key in keys), (
        f"the default fast ears' keys are {[k[:32] for k in keys]}, shipped are {shipped}: "
        "run scripts/ship_fast_ear.py"
    )


def test_a_shipped_fast_ear_is_the_built_one_bit_for_bit(coarse_fast_ear, coarse_ear, tmp_path):
    from isj.fem.ear.fast_ear import cache_key_of, load_shipped, ship

    key = cache_key_of(coarse_ear)
    path = ship(coarse_fast_ear, key, tmp_path)
    stored = np.load(path).files
    assert "k:eardrum|data" in stored and "k:eardrum" not in stored  # packed, not dense
    back = load_shipped(key, tmp_path)
    assert _same(back.arrays, coarse_fast_ear.arrays)
    assert back.space == coarse_fast_ear.space
    # another key finds nothing, even under a file of the same name
    other = cache_key_of(coarse_ear, fmax_hz=10e3)
    assert load_shipped(other, tmp_path) is None
    path.rename(tmp_path / f"fast-ear-{other[:32]}.npz")
    assert load_shipped(other, tmp_path) is None


def test_fast_ear_takes_the_shipped_one_and_caches_it(coarse_fast_ear, coarse_ear, tmp_path, monkeypatch):
    import isj.fem.ear.fast_ear as fe

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "fe"))
    fe.ship(coarse_fast_ear, fe.cache_key_of(coarse_ear), tmp_path / "shipped")
    monkeypatch.setattr(fe, "SHIPPED_DIR", tmp_path / "shipped")

    def no_build(*args, **kwargs):
        raise AssertionError("built although one is shipped")

    monkeypatch.setattr(fe, "build_fast_ear", no_build)
    got = fe.fast_ear(coarse_ear)
    assert got.meta["shipped"] and len(list(fe.fast_ear_cache_dir().glob("fast-ear-*.npz"))) == 1
    m = Materials()
    assert np.array_equal(got.batch(FREQ_HZ, m)["h_v"], coarse_fast_ear.batch(FREQ_HZ, m)["h_v"])
    with pytest.raises(AssertionError, match="built although"):
        fe.fast_ear(coarse_ear, fmax_hz=10e3)  # another key: nothing ships for it
    with pytest.raises(AssertionError, match="built although"):
        fe.fast_ear(coarse_ear, cache=False, shipped=False)


def test_a_damaged_shipped_fast_ear_is_reported_and_passed_over(coarse_fast_ear, coarse_ear, tmp_path):
    from isj.fem.ear.fast_ear import cache_key_of, load_shipped, ship

    key = cache_key_of(coarse_ear)
    flip_a_stored_byte(ship(coarse_fast_ear, key, tmp_path))
    with pytest.warns(CacheWarning, match="damaged"):
        assert load_shipped(key, tmp_path) is None


def test_a_part_with_a_negative_zero_or_no_symmetry_is_kept_whole():
    from isj.fem.ear.fast_ear import _pack_symmetric, _unpack_symmetric

    rng = np.random.default_rng(3)
    a = rng.standard_normal((5, 5))
    a[a < 0.5] = 0.0
    s = a + a.T
    z = s.copy()
    z[0, 1] = -0.0
    for m in (a, s, z):
        back = _unpack_symmetric(_pack_symmetric("k:x", m))["k:x"]
        assert np.array_equal(back, m) and np.array_equal(np.signbit(back), np.signbit(m))
    assert bool(_pack_symmetric("k:x", s)["k:x|symmetric"])
    assert not bool(_pack_symmetric("k:x", a)["k:x|symmetric"])
    assert "k:x" in _pack_symmetric("k:x", z)


@pytest.mark.parametrize("joint", ["bonded", "sliding"])
def test_the_shipped_default_fast_ear_meets_its_targets_against_fe(tmp_path, monkeypatch, joint):
    """The default ear's base case and rigid connection, FE reductions against the shipped fast ear:
    H_V within 0.5 dB and 3°, ΔH_V within 0.1 dB and 1°, to 10 kHz (docs/fast_ear.md §14), for each
    joint whose fast ear ships."""
    from isj.fem.ear.fast_ear import fast_ear
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.ear.reduced_ear import reduced_ear
    from isj.fem.model import PedicleJointModel

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "fe"))
    ear = MiddleEarModel(joint=PedicleJointModel(order=2, resolution=1.0, joint=joint))
    fast = fast_ear(ear)
    assert fast.meta.get("shipped"), "the default fast ear was built, not taken from fem/ear/data"
    low = FREQ_HZ <= 10e3
    hv = "stapes_velocity_m_s"
    fe = reduced_ear(ear, Materials(), fmax_hz=20e3).frequency_response(FREQ_HZ)[hv]
    rigid = reduced_ear(ear.rigid_connection(), fmax_hz=20e3).frequency_response(FREQ_HZ)[hv]
    out = fast.batch(FREQ_HZ, Materials())
    for got, want, db_max, deg_max in (
        (out["h_v"][0], fe, 0.5, 3.0),
        (out["h_v_rigid"], rigid, 0.5, 3.0),
        (out["h_v"][0] / out["h_v_rigid"], fe / rigid, 0.1, 1.0),
    ):
        r = got[low] / want[low]
        db, deg = np.abs(20 * np.log10(np.abs(r))).max(), np.abs(np.degrees(np.angle(r))).max()
        assert db <= db_max and deg <= deg_max, (db, deg)
