"""The surrogate shipped with isj (fem/rom/data, docs/rom.md §10.12): keyed, complete, and certified."""

from __future__ import annotations

import numpy as np
import pytest
from test_cache_entries import flip_a_stored_byte

from isj.design import Geometry
from isj.design_space import DesignSpace
from isj.errors import CacheWarning

pytestmark = pytest.mark.slow  # FE models and surrogates on real meshes

#: A small surrogate on a coarse mesh, for the mechanism
ORDER, RESOLUTION = 1, 0.35
SMALL = {"n_train": 16, "n_validate": 16, "max_snapshots": 4}


def _key(order, resolution, settings):
    from isj.fem.mesh import mesh_pedicle_joint
    from isj.fem.rom.model import DEFAULT_TOL, surrogate_key

    mesh = mesh_pedicle_joint(Geometry(), resolution=resolution)
    return surrogate_key(mesh, order, Geometry(), DesignSpace(), DEFAULT_TOL, resolution, settings)


@pytest.fixture
def empty_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "fe"))
    return tmp_path / "fe"


@pytest.fixture(scope="module")
def small_rom():
    from isj.fem.rom import reduced_model

    return reduced_model(order=ORDER, resolution=RESOLUTION, cache=False, **SMALL)


def test_the_default_surrogate_ships_under_its_current_key():
    from isj.fem.rom.model import SHIPPED_DIR

    key = _key(2, 1.0, {})
    shipped = sorted(p.name for p in SHIPPED_DIR.glob("rom-*.npz"))
    assert shipped == [f"rom-{key[:32]}.npz"], (
        f"the default surrogate's key is {key[:32]}, shipped are {shipped}: run scripts/ship_surrogate.py"
    )


def test_a_shipped_surrogate_is_the_built_one_bit_for_bit(small_rom, tmp_path):
    from isj.fem.rom.model import DEFAULT_TOL, load_shipped, ship

    key = _key(ORDER, RESOLUTION, SMALL)
    path = ship(small_rom, key, tmp_path)
    assert not any(k.startswith("box") for k in np.load(path).files)  # the local stage is remade
    back = load_shipped(
        key, DesignSpace(), tol=DEFAULT_TOL, n_validate=SMALL["n_validate"], seed=0, folder=tmp_path
    )
    assert back.arrays.keys() == small_rom.arrays.keys()
    for k, v in small_rom.arrays.items():
        assert np.array_equal(back.arrays[k], v), k
    assert back.meta["local_sizes"] == small_rom.meta["local_sizes"]
    # another key (here: another seed) finds nothing, even under a file of the same name
    other = _key(ORDER, RESOLUTION, SMALL | {"seed": 1})
    assert load_shipped(other, DesignSpace(), tol=DEFAULT_TOL, n_validate=16, seed=1, folder=tmp_path) is None
    path.rename(tmp_path / f"rom-{other[:32]}.npz")
    assert load_shipped(other, DesignSpace(), tol=DEFAULT_TOL, n_validate=16, seed=1, folder=tmp_path) is None


def test_reduced_model_takes_the_shipped_one_and_caches_it(small_rom, empty_cache, tmp_path, monkeypatch):
    from isj.fem.rom import model, reduced_model, rom_cache_dir

    ship_dir = tmp_path / "shipped"
    ship_dir.mkdir()
    model.ship(small_rom, _key(ORDER, RESOLUTION, SMALL), ship_dir)
    monkeypatch.setattr(model, "SHIPPED_DIR", ship_dir)

    def no_build(*args, **kwargs):
        raise AssertionError("built although one is shipped")

    monkeypatch.setattr(model, "_build", no_build)
    got = reduced_model(order=ORDER, resolution=RESOLUTION, **SMALL)
    assert got.meta["shipped"] and len(list(rom_cache_dir().glob("rom-*.npz"))) == 1
    E = got.space.sample(64, seed=5)
    assert np.array_equal(got.evaluate(E)["alpha_bound_rad"], small_rom.evaluate(E)["alpha_bound_rad"])
    with pytest.raises(AssertionError, match="built although"):
        reduced_model(order=ORDER, resolution=RESOLUTION, shipped=False, **SMALL | {"seed": 2})


def test_a_damaged_shipped_file_is_reported_and_passed_over(small_rom, tmp_path):
    from isj.fem.rom.model import DEFAULT_TOL, load_shipped, ship

    key = _key(ORDER, RESOLUTION, SMALL)
    flip_a_stored_byte(ship(small_rom, key, tmp_path))
    with pytest.warns(CacheWarning, match="damaged"):
        got = load_shipped(key, DesignSpace(), tol=DEFAULT_TOL, n_validate=16, seed=0, folder=tmp_path)
    assert got is None


def test_the_shipped_default_surrogate_bounds_hold_against_fe(empty_cache):
    """FE on the default mesh (P2) at the base design and two corners: within the certified bounds."""
    from isj.fem.model import PedicleJointModel
    from isj.fem.rom import reduced_model

    rom = reduced_model()
    assert rom.meta.get("shipped"), "the default surrogate was built, not taken from fem/rom/data"
    fe = PedicleJointModel(order=2, resolution=1.0)
    corners = rom.space.corners()
    E = np.concatenate([rom.space.designs_from(None), corners[[0, -1]]])
    ev = rom.evaluate(E, 1.0)
    for i, e in enumerate(E):
        r = fe.static(rom.space.materials(e), 1.0)
        for k, kb, truth in (
            ("alpha_rad", "alpha_bound_rad", r.alpha_rad),
            ("beta_rad", "beta_bound_rad", r.beta_rad),
            ("beta_over_alpha", "beta_over_alpha_bound", r.ratio),
        ):
            err = abs(truth - ev[k][i])
            assert err <= ev[kb][i], (
                f"design {i} {k}: |FE − surrogate| {err:.3g} above its bound {ev[kb][i]:.3g}"
            )
            assert ev[kb][i] <= 1e-3 * abs(truth), f"design {i} {k}: bound above the 1e-3 target"


def test_the_local_stage_is_the_same_bit_for_bit_on_one_thread_and_on_two(small_rom, monkeypatch):
    """The sub-boxes run on the solver's threads; each box's arrays must not depend on that."""
    from isj.fem.rom.model import DEFAULT_TOL, local_stage

    arrays = {k: v for k, v in small_rom.arrays.items() if not k.startswith("box")}
    meta = {k: v for k, v in small_rom.meta.items() if not k.startswith("local_")}
    made = {}
    for threads in ("1", "2"):
        monkeypatch.setenv("ISJ_SOLVER_THREADS", threads)
        made[threads] = local_stage(arrays, DesignSpace(), meta, tol=DEFAULT_TOL, n_validate=16, seed=0)
    assert made["1"].arrays.keys() == made["2"].arrays.keys() == small_rom.arrays.keys()
    for k, v in made["1"].arrays.items():
        assert np.array_equal(made["2"].arrays[k], v), k
    assert made["1"].meta["local_sizes"] == made["2"].meta["local_sizes"] == small_rom.meta["local_sizes"]
