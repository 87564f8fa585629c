"""Batch runner: disk cache, resume after an interruption, process pool and Dask
(calibration.runner), and the FE evaluator it is meant for (fem.batch)."""

import json
import uuid
from pathlib import Path

import pytest
from isj.calibration.runner import (
    ResultCache,
    design_key,
    run_designs,
)

from isj.cachefile import json_checksum
from isj.errors import CorruptCacheEntry, EvaluationError


def fake_evaluate(design: dict, settings: dict) -> dict:
    """Cheap stand-in for the FE model (picklable: top level of an importable module).

    Every call leaves a file in ``settings["calls_dir"]``; a file ``fail-<E>``
    there makes the design with pedicle_e_pa == E raise once, with the exception
    named in the file.
    """
    calls = Path(settings["calls_dir"])
    e = design["pedicle_e_pa"]
    (calls / f"{uuid.uuid4().hex}.call").write_text(json.dumps(design))
    trigger = calls / f"fail-{e!r}"
    if trigger.exists():
        kind = trigger.read_text()
        trigger.unlink()
        raise {"KeyboardInterrupt": KeyboardInterrupt, "RuntimeError": RuntimeError}[kind](f"boom at {e!r}")
    return {"alpha_rad": e * 1e-21, "beta_rad": 3.0 / e, "strain_energy_j": {"gap": e * 1e-30}, "n_dofs": 7}


def calls_made(settings) -> list[float]:
    files = Path(settings["calls_dir"]).glob("*.call")
    return sorted(json.loads(f.read_text())["pedicle_e_pa"] for f in files)


def clear_calls(settings) -> None:
    for f in Path(settings["calls_dir"]).glob("*.call"):
        f.unlink()


@pytest.fixture
def settings(tmp_path):
    d = tmp_path / "calls"
    d.mkdir()
    return {"calls_dir": str(d), "order": 2, "resolution": 1.0}


def designs(n=6):
    return [{"pedicle_e_pa": 1e9 * (i + 1), "gap_e_pa": 10e6} for i in range(n)]


def test_design_key_is_canonical():
    s = {"order": 2, "resolution": 1.0}
    k = design_key({"pedicle_e_pa": 5e9, "gap_e_pa": 1e7}, s)
    assert k == design_key({"gap_e_pa": 10_000_000, "pedicle_e_pa": 5_000_000_000}, dict(reversed(s.items())))
    assert len(k) == 64
    assert k != design_key({"pedicle_e_pa": 5e9 * (1 + 1e-15), "gap_e_pa": 1e7}, s)  # repr: exact
    assert k != design_key({"pedicle_e_pa": 5e9, "gap_e_pa": 1e7}, {**s, "resolution": 2.0})
    with pytest.raises(ValueError, match="finite"):
        design_key({"pedicle_e_pa": float("nan")}, s)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["RuntimeError", "KeyboardInterrupt"])
def test_resume_after_interruption(tmp_path, settings, kind):
    ds = designs(6)
    (Path(settings["calls_dir"]) / f"fail-{ds[3]['pedicle_e_pa']!r}").write_text(kind)
    if kind == "RuntimeError":
        # a plain failure: the others are still evaluated and cached, the error names the design
        with pytest.raises(EvaluationError, match=r"(?s)1 of 6 .*pedicle_e_pa': 4000000000\.0.*boom"):
            run_designs(ds, fake_evaluate, settings, tmp_path / "cache", progress=False)
    else:
        with pytest.raises(KeyboardInterrupt):
            run_designs(ds, fake_evaluate, settings, tmp_path / "cache", progress=False)
    first = calls_made(settings)
    assert first[:4] == [d["pedicle_e_pa"] for d in ds[:4]]  # in order, up to the failure
    cache = ResultCache(tmp_path / "cache")
    cached = {d["pedicle_e_pa"] for d in ds if cache.get(design_key(d, settings))}
    assert {d["pedicle_e_pa"] for d in ds[:3]} <= cached and ds[3]["pedicle_e_pa"] not in cached
    if kind == "RuntimeError":
        assert len(cached) == 5

    clear_calls(settings)
    records = run_designs(ds, fake_evaluate, settings, tmp_path / "cache", progress=False)
    assert calls_made(settings) == sorted({d["pedicle_e_pa"] for d in ds} - cached)
    assert [r["design"] for r in records] == ds
    assert [r["result"]["beta_rad"] for r in records] == [3.0 / d["pedicle_e_pa"] for d in ds]


def test_cache_hit_returns_identical_records(tmp_path, settings):
    ds = designs(3) + designs(1)  # a duplicate is evaluated once
    first = run_designs(ds, fake_evaluate, settings, tmp_path / "cache", progress=True)
    assert len(calls_made(settings)) == 3
    assert first[3] == first[0]
    clear_calls(settings)
    again = run_designs(ds, fake_evaluate, settings, tmp_path / "cache", progress=False)
    assert calls_made(settings) == []
    assert again == first
    rec = first[1]
    assert set(rec) == {"key", "design", "settings", "result"} and rec["settings"] == settings
    stored = json.loads((tmp_path / "cache" / f"{rec['key']}.json").read_text())
    assert stored.pop("sha256") == json_checksum(rec) and stored == rec  # the record plus its checksum


@pytest.mark.slow
def test_corrupt_entries_warn_and_recompute(tmp_path, settings):
    ds = designs(3)
    recs = run_designs(ds, fake_evaluate, settings, tmp_path / "cache", progress=False)
    paths = [tmp_path / "cache" / f"{r['key']}.json" for r in recs]
    text = paths[0].read_text()
    paths[0].write_text(text[: len(text) // 2])  # truncated
    paths[1].write_bytes(b"\x00garbage")
    clear_calls(settings)
    with pytest.warns(CorruptCacheEntry) as caught:
        again = run_designs(ds, fake_evaluate, settings, tmp_path / "cache", progress=False)
    assert len(caught) == 2
    assert calls_made(settings) == [ds[0]["pedicle_e_pa"], ds[1]["pedicle_e_pa"]]
    assert again == recs


@pytest.mark.parametrize(
    "mutate",
    [
        lambda r: r.update(key="0" * 64),  # wrong key inside
        lambda r: r.pop("result"),  # missing field
        lambda r: r["design"].update(pedicle_e_pa=1.0),  # does not hash to its key
        lambda r: r.update(result=[1.0]),  # result not an object
    ],
)
def test_mismatched_record_is_never_used(tmp_path, mutate):
    cache = ResultCache(tmp_path)
    d, s = {"pedicle_e_pa": 5e9}, {"order": 2}
    key = design_key(d, s)
    rec = cache.put(key, d, s, {"alpha_rad": 1e-6})
    assert cache.get(key) == rec
    mutate(rec)
    # with a checksum that matches: the record's own checks must catch it
    cache.path(key).write_text(json.dumps(rec | {"sha256": json_checksum(rec)}))
    with pytest.warns(CorruptCacheEntry, match="FE result cache entry"):
        assert cache.get(key) is None
    assert not cache.path(key).exists()


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "1e999"])
def test_non_finite_numbers_are_corrupt(tmp_path, literal):
    cache = ResultCache(tmp_path)
    d, s = {"pedicle_e_pa": 5e9}, {"order": 2}
    key = design_key(d, s)
    cache.put(key, d, s, {"alpha_rad": 1e-6})
    path = cache.path(key)
    path.write_text(path.read_text().replace("1e-06", literal))
    with pytest.warns(CorruptCacheEntry, match="finite"):
        assert cache.get(key) is None
    with pytest.raises(ValueError, match="finite"):
        cache.put(key, d, s, {"alpha_rad": float("nan")})


def test_dask_matches_process_pool(tmp_path, settings):
    distributed = pytest.importorskip("distributed")
    ds = designs(4)
    bad = {"pedicle_e_pa": 9e9, "gap_e_pa": 10e6}
    pool = run_designs(ds, fake_evaluate, settings, tmp_path / "pool", progress=False)
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        viaclient = run_designs(
            ds, fake_evaluate, settings, tmp_path / "dask", scheduler=client, progress=False
        )
        (Path(settings["calls_dir"]) / f"fail-{bad['pedicle_e_pa']!r}").write_text("RuntimeError")
        with pytest.raises(EvaluationError, match="9000000000"):
            run_designs([*ds, bad], fake_evaluate, settings, tmp_path / "dask", scheduler=client)
        address = cluster.scheduler_address
        viaaddress = run_designs(
            [*ds, bad], fake_evaluate, settings, tmp_path / "dask", scheduler=address, progress=False
        )
        assert client.status != "closed"  # a client we were given is left open
    assert viaclient == pool
    assert viaaddress[:4] == pool
    assert viaaddress[4]["result"]["beta_rad"] == 3.0 / 9e9


# --- the real FE evaluator ------------------------------------------------------------------


def test_fe_evaluate_design_linear_and_memoised():
    from isj.fem import batch

    from isj.design import DEFAULT_PRESSURE_PA
    from isj.errors import InvalidParameter

    s1 = batch.fe_settings(order=1, resolution=0.35)
    s2 = batch.fe_settings(order=1, resolution=0.35, pressure_pa=2 * DEFAULT_PRESSURE_PA)
    assert json.loads(json.dumps(s1)) == s1
    design = {"pedicle_e_pa": 3e9, "gap_e_pa": 20e6, "capsule_e_pa": 80e6}

    r1 = batch.evaluate_design(design, s1)
    memo = {k: id(m) for k, (m, _) in batch._MODELS.items()}
    # another pressure and the defaults reuse the memoised model: no meshing or assembly again
    r2 = batch.evaluate_design(design, s2)
    r3 = batch.evaluate_design({}, {"order": 1, "resolution": 0.35})  # the same model, defaults
    assert {k: id(m) for k, (m, _) in batch._MODELS.items()} == memo

    assert r2["alpha_rad"] == pytest.approx(2 * r1["alpha_rad"], rel=1e-9)
    assert r2["beta_rad"] == pytest.approx(2 * r1["beta_rad"], rel=1e-9)
    assert r1["alpha_rad"] > 0 and r1["beta_rad"] > 0
    assert r1["mesh_hash"] == r2["mesh_hash"] == r3["mesh_hash"] and r1["n_dofs"] == r3["n_dofs"]
    assert set(r1["strain_energy_j"]) == {"stapes", "gap", "plate", "pedicle", "incus", "capsule"}
    assert all(type(v) is float for k, v in r1.items() if k.endswith(("_rad", "_m")))

    with pytest.raises(InvalidParameter, match="resolutoin"):
        batch.evaluate_design(design, {"resolutoin": 1.0})
    with pytest.raises(InvalidParameter, match="pedicle_e"):
        batch.evaluate_design({"pedicle_e": 1e9}, s1)
    with pytest.raises(InvalidParameter, match="versions"):  # settings made by other FE results
        batch.evaluate_design(design, {**s1, "versions": {**s1["versions"], "fe_static": 0}})


@pytest.mark.slow
def test_fe_evaluator_through_the_runner(tmp_path):
    """fem.batch.evaluate_design pickles into a spawned worker and its results cache."""
    from isj.fem import batch

    s = batch.fe_settings(order=1, resolution=0.35)
    ds = [{"pedicle_e_pa": 3e9}, {"pedicle_e_pa": 12e9}]
    recs = run_designs(ds, batch.evaluate_design, s, tmp_path, progress=False)
    assert recs[0]["result"]["beta_rad"] > recs[1]["result"]["beta_rad"]  # stiffer pedicle bends less
    again = batch.evaluate_design(ds[0], s)
    # the same up to rounding: PARDISO's threaded factorization is not bit-reproducible across processes
    assert recs[0]["result"]["mesh_hash"] == again["mesh_hash"]
    for k in ("alpha_rad", "beta_rad", "alpha_ls_rad", "beta_ls_rad", "max_disp_m"):
        assert recs[0]["result"][k] == pytest.approx(again[k], rel=1e-9)
