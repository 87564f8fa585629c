"""Damaged cache entries: each kind of cache, damaged three ways, is reported, deleted and recomputed.

Kinds: a mesh (.npz), an FE result record (.json), a report step's record
(.json) and its arrays (.npz). Damage: the file truncated; replaced by random
bytes; one number edited so that the file is still valid JSON or NPZ (only
the checksum can tell). Each time: one warning line of category
CorruptCacheEntry naming the file, the entry gone before the recompute, the
same result as before, and a sound entry written again.
"""

import json
import struct
import warnings
import zipfile

import numpy as np
import pytest
from isj.calibration.runner import ResultCache, run_designs
from isj.fem import mesh as mesh_mod
from isj.fem.geometry import MeshSizes
from isj.fem.mesh import mesh_cantilever
from isj.reports.store import StepStore

from isj.errors import CorruptCacheEntry

DAMAGES = ("truncated", "random bytes", "edited number")

#: Coarse sizes: any mesh will do.
COARSE = MeshSizes(
    stapes_m=120e-6, gap_m=30e-6, plate_m=80e-6, pedicle_m=40e-6, incus_m=120e-6, capsule_m=30e-6
)


def _edit_first_float(obj) -> bool:
    """Change the first non-zero float met (sorted keys, depth first) by 0.1 %; True if one was found."""
    items = sorted(obj.items()) if isinstance(obj, dict) else enumerate(obj)
    for k, v in items:
        if isinstance(v, float) and v != 0.0:
            obj[k] = v * 1.001
            return True
        if isinstance(v, dict | list) and _edit_first_float(v):
            return True
    return False


def damage(path, how: str) -> None:
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "random bytes":
        path.write_bytes(np.random.default_rng(1).bytes(len(data)))
    elif path.suffix == ".json":  # a result number edited; the stored checksum left as it was
        record = json.loads(data)
        assert _edit_first_float(record["result"])
        path.write_text(json.dumps(record))
    else:  # .npz rewritten with one float changed, its stored checksum array kept
        with np.load(path) as z:
            arrays = dict(z)
        name = next(k for k in sorted(arrays) if arrays[k].dtype.kind == "f" and np.any(arrays[k]))
        flat = arrays[name].reshape(-1)
        i = int(np.flatnonzero(flat)[0])
        flat[i] *= 1.001
        np.savez(path, **arrays)


def flip_a_stored_byte(path) -> None:
    """Flip one byte in the middle of the largest array stored in the NPZ at ``path``.

    A byte chosen by its place in the file alone may land in a zip header field that no
    reader checks (a member's modification date), leaving every array whole.
    """
    with zipfile.ZipFile(path) as z:
        member = max(z.infolist(), key=lambda info: info.compress_size)
    data = bytearray(path.read_bytes())
    name_len, extra_len = struct.unpack_from("<HH", data, member.header_offset + 26)
    start = member.header_offset + 30 + name_len + extra_len  # after the member's local header
    data[start + member.compress_size // 2] ^= 0xFF
    path.write_bytes(bytes(data))


def one_warning_naming(caught, path, how: str) -> None:
    msgs = [str(w.message) for w in caught if issubclass(w.category, CorruptCacheEntry)]
    assert len(msgs) == 1, msgs
    assert str(path) in msgs[0] and "\n" not in msgs[0] and "deleted" in msgs[0]
    if how == "edited number":  # still valid JSON or NPZ: only the checksum can tell
        assert "checksum does not match" in msgs[0]


def silently(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error", CorruptCacheEntry)
        return fn(*args, **kwargs)


@pytest.mark.parametrize("how", DAMAGES)
def test_damaged_mesh_entry(tmp_path, monkeypatch, how):
    first = mesh_cantilever(sizes=COARSE, cache_dir=tmp_path)
    (path,) = tmp_path.glob("*.npz")
    damage(path, how)

    seen = []  # at each recompute: was the damaged entry still there?
    real = mesh_mod.cached_mesh

    def spy(kind, geometry, sizes, cache_dir, compute):
        def watched():
            seen.append(path.exists())
            return compute()

        return real(kind, geometry, sizes, cache_dir, watched)

    monkeypatch.setattr(mesh_mod, "cached_mesh", spy)
    with pytest.warns(CorruptCacheEntry) as caught:
        again = mesh_cantilever(sizes=COARSE, cache_dir=tmp_path)
    one_warning_naming(caught, path, how)
    assert seen == [False]  # deleted, then recomputed once
    assert again.content_hash() == first.content_hash()
    assert silently(mesh_cantilever, sizes=COARSE, cache_dir=tmp_path).content_hash() == first.content_hash()
    assert seen == [False]  # the third read came from the rewritten entry


def _evaluate(design: dict, settings: dict) -> dict:
    """A cheap, deterministic stand-in for the FE evaluator."""
    e = design["pedicle_e_pa"]
    return {"alpha_rad": e * 1e-21 + 1.7e-6, "beta_rad": 3.0e3 / e, "strain_energy_j": {"gap": 2.5e-13}}


@pytest.mark.parametrize("how", DAMAGES)
def test_damaged_fe_record(tmp_path, how):
    settings = {"order": 1, "resolution": 0.35}
    designs = [{"pedicle_e_pa": 2e9}, {"pedicle_e_pa": 5e9}]
    first = run_designs(designs, _evaluate, settings, tmp_path, max_workers=0, progress=False)
    path = ResultCache(tmp_path).path(first[0]["key"])
    damage(path, how)

    seen = []

    def evaluate(design, settings):
        seen.append((design["pedicle_e_pa"], path.exists()))
        return _evaluate(design, settings)

    with pytest.warns(CorruptCacheEntry) as caught:
        again = run_designs(designs, evaluate, settings, tmp_path, max_workers=0, progress=False)
    one_warning_naming(caught, path, how)
    assert seen == [(2e9, False)]  # only the damaged design, after its record was deleted
    assert again == first
    third = silently(run_designs, designs, evaluate, settings, tmp_path, max_workers=0, progress=False)
    assert third == first
    assert len(seen) == 1


@pytest.mark.parametrize("part", ["json", "npz"])
@pytest.mark.parametrize("how", DAMAGES)
def test_damaged_report_step_entry(tmp_path, part, how):
    store = StepStore(tmp_path)
    key = "0123456789abcdef01234567"
    result = {"alpha_rad": 1.8e-6, "rows": [{"beta_rad": 1.2e-5, "case": "base"}], "n_dofs": 3}
    arrays = {"freq_hz": np.geomspace(100.0, 4e4, 7), "tri": np.arange(12, dtype=np.int32).reshape(4, -1)}
    store.put("sweep", key, result, arrays)
    jpath, npath = tmp_path / f"sweep-{key}.json", tmp_path / f"sweep-{key}.npz"
    bad = jpath if part == "json" else npath
    damage(bad, how)
    with pytest.warns(CorruptCacheEntry) as caught:
        assert store.get("sweep", key) is None
    one_warning_naming(caught, bad, how)
    assert not jpath.exists() and not npath.exists()  # the record and its arrays go together
    store.put("sweep", key, result, arrays)  # what the report does next: recompute and store
    got, got_arrays = silently(store.get, "sweep", key)
    assert got == result
    assert got_arrays.keys() == arrays.keys()
    for k, a in arrays.items():
        assert got_arrays[k].dtype == a.dtype and np.array_equal(got_arrays[k], a)


def _close(a, b) -> bool:
    """Equal JSON trees, floats to 1e-9 relative (a recomputed FE solve may round differently)."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(map(_close, a, b))
    if isinstance(a, float):
        return b == pytest.approx(a, rel=1e-9, abs=1e-300)
    return a == b


def test_report_recomputes_damaged_steps(report, tmp_path, monkeypatch):
    """The report itself: a damaged step record and damaged step arrays are recomputed, the rest cached."""
    import isj.reports.run as run_mod
    from isj.reports.steps import STEPS, Context, step_inputs
    from isj.reports.store import step_key

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(report["fe_cache"]))
    config = report["config"]
    ctx = Context(config, run_mod.load_calibration(config), report["fe_cache"])
    keys = {name: step_key(name, step_inputs(ctx, sections, fn)) for name, fn, sections in STEPS}
    steps_dir = report["fe_cache"] / "report"
    model_npz = steps_dir / f"model-{keys['model']}.npz"
    cases_json = steps_dir / f"cases-{keys['cases']}.json"
    damage(model_npz, "edited number")
    damage(cases_json, "random bytes")

    with pytest.warns(CorruptCacheEntry) as caught:
        res = run_mod.run_report(config, tmp_path / "out", verbosity=0)
    msgs = sorted(str(w.message) for w in caught if issubclass(w.category, CorruptCacheEntry))
    assert len(msgs) == 2 and str(cases_json) in msgs[0] and str(model_npz) in msgs[1]
    assert res["cached"] == [name for name, _, _ in STEPS if name not in ("model", "cases")]
    before = report["second"]
    for name in ("model", "cases"):
        assert _close(before["steps"][name], res["steps"][name]), name
    for k, a in before["arrays"]["model"].items():
        np.testing.assert_allclose(res["arrays"]["model"][k], a, rtol=1e-9, atol=0)
    # and they were stored again, sound: a further run recomputes nothing
    again = silently(run_mod.run_report, config, tmp_path / "out", verbosity=0)
    assert again["cached"] == [name for name, _, _ in STEPS]
