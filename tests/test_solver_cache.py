"""PARDISO's fill-reducing ordering, cached per pattern (fem.solvers.make_solver, fem.cache).

A solve that reads the ordering from the cache must give the same bits as the
one that computed it, in another process as in this one; a damaged entry is
reported once (CorruptCacheEntry), deleted and recomputed, never handed to
PARDISO (which crashes on a bad permutation).
"""

import json
import subprocess
import sys
import warnings

import numpy as np
import pytest
from isj.fem import cache as fem_cache
from isj.fem.model import PedicleJointModel
from isj.fem.solvers import _mkl_rt_path, available_backends

from isj.design import Materials
from isj.errors import CorruptCacheEntry

pytestmark = [
    pytest.mark.skipif("pardiso" not in available_backends(), reason="needs PARDISO (pypardiso)"),
    pytest.mark.slow,  # FE solves in subprocesses
]

#: A coarse P1 model: any pattern will do.
ORDER, RESOLUTION = 1, 0.35


def _solve(cache_dir):
    model = PedicleJointModel(order=ORDER, resolution=RESOLUTION, cache_dir=cache_dir)
    res = model.static(Materials(gap_e_pa=7e6))
    return model, res


def _entries(cache_dir):
    return sorted(cache_dir.glob("ordering-*.npz"))


def test_cached_ordering_gives_the_same_bits(tmp_path):
    _, cold = _solve(tmp_path)
    assert len(_entries(tmp_path)) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", CorruptCacheEntry)
        model, warm = _solve(tmp_path)
    # the warm solver was handed the ordering (PARDISO's iparm(5) = 1: "use perm")
    assert model._solver._ps.iparm[4] == 1
    assert np.array_equal(cold.displacement_m, warm.displacement_m)
    assert (cold.alpha_rad, cold.beta_rad) == (warm.alpha_rad, warm.beta_rad)


def test_cached_ordering_same_bits_in_another_process(tmp_path):
    _, here = _solve(tmp_path)
    code = (
        "import json, sys; from isj.fem.model import PedicleJointModel; from isj.design import Materials; "
        f"m = PedicleJointModel(order={ORDER}, resolution={RESOLUTION}, cache_dir=sys.argv[1]); "
        "r = m.static(Materials(gap_e_pa=7e6)); "
        "print(json.dumps([r.alpha_rad.hex(), r.beta_rad.hex(), int(m._solver._ps.iparm[4])]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, check=True
    )
    alpha, beta, iparm5 = json.loads(out.stdout)
    assert iparm5 == 1  # the other process read the ordering
    assert (float.fromhex(alpha), float.fromhex(beta)) == (here.alpha_rad, here.beta_rad)


@pytest.mark.parametrize("damage", ["truncated", "random bytes", "swapped entries", "not a permutation"])
def test_damaged_ordering_is_reported_and_recomputed(tmp_path, damage):
    _, cold = _solve(tmp_path)
    (entry,) = _entries(tmp_path)
    data = entry.read_bytes()
    if damage == "truncated":
        entry.write_bytes(data[: len(data) // 2])
    elif damage == "random bytes":
        entry.write_bytes(np.random.default_rng(3).bytes(len(data)))
    else:
        with np.load(entry) as z:
            arrays = dict(z)
        perm = arrays["perm"]
        if damage == "swapped entries":  # still a permutation: only the checksum tells
            perm[[0, 1]] = perm[[1, 0]]
            np.savez(entry, **arrays)
        else:  # a duplicate index, with a checksum that matches it
            perm[0] = perm[1]
            from isj.cachefile import write_npz_entry

            arrays = {k: v for k, v in arrays.items() if not k.startswith("_")}  # the old checksum
            write_npz_entry(entry, arrays)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model, warm = _solve(tmp_path)
    damaged = [w for w in caught if issubclass(w.category, CorruptCacheEntry)]
    assert len(damaged) == 1 and entry.name in str(damaged[0].message)
    assert model._solver._ps.iparm[4] == 2  # computed afresh
    assert (cold.alpha_rad, cold.beta_rad) == (warm.alpha_rad, warm.beta_rad)
    (again,) = _entries(tmp_path)  # a sound entry written again
    assert fem_cache.load_ordering(tmp_path, _key_of(again), model.n_dofs) is not None


def _key_of(entry):
    with np.load(entry) as z:
        return str(z["key"])


def test_no_cache_folder_no_entry(tmp_path, monkeypatch):
    monkeypatch.setenv("ISJ_CACHE_DIR", str(tmp_path / "unused"))
    _solve(False)
    assert not (tmp_path / "unused").exists()


def test_mkl_runtime_found_without_a_search():
    path = _mkl_rt_path()
    assert path is not None and "libmkl_rt.so" in path
