"""``isj explore``'s guard (isj.calibration.guard, docs/rom.md §10.10): numbers recomputed independently.

One small surrogate of a coarse P1 mesh (resolution 0.35, tol 1e-2, small training sets: ~15 s) is
built for the module in a private cache; the command line gets it through
``isj._cli.explore.load_surrogate`` (patched: the command's own default greedy settings would
take about a minute here). The lumped model is calibrated to the P2 mesh, so on this mesh it errs by
tens of per cent: the tests check what is recorded, not that the lumped model passes.
"""

import csv
import itertools
import json
import math
import sys

import numpy as np
import pytest
from isj.calibration import guard as G
from isj.lumped.artifact import default_calibration
from isj.lumped.model import MODULI, static_response

from isj._cli import explore as cli_explore
from isj.cli import main

pytestmark = pytest.mark.slow  # builds a small surrogate (module fixture)

ORDER, RESOLUTION = 1, 0.35
MESH = ["--order", str(ORDER), "--resolution", str(RESOLUTION)]
PRESSURE = 28.5


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    path = tmp_path_factory.mktemp("fe-cache")
    mp.setenv("ISJ_FE_CACHE_DIR", str(path))
    yield path
    mp.undo()


@pytest.fixture(scope="module")
def rom(cache):
    from isj.fem.rom import reduced_model

    return reduced_model(order=ORDER, resolution=RESOLUTION, tol=1e-2, n_train=64, n_validate=256)


@pytest.fixture
def cli(rom, monkeypatch, capsys):
    """Run ``isj explore ...`` in this process with the module's surrogate; (code, stdout, stderr)."""
    asked = []

    def load(order, resolution, geometry=None, incus_e_pa=None, progress=None):
        asked.append((order, resolution, incus_e_pa))
        return rom, None

    monkeypatch.setattr(cli_explore, "load_surrogate", load)

    def run(*argv):
        code = main(["explore", *MESH, *argv])
        out, err = capsys.readouterr()
        return code, out, err

    run.asked = asked
    return run


def _read_csv(path):
    lines = path.read_text().splitlines()
    assert lines[0].startswith("# units:") and "_e_pa Pa" in lines[0]
    rows = list(csv.DictReader(lines[1:]))
    return {k: [r[k] for r in rows] for k in rows[0]}


def _floats(col):
    return np.array([float(v) for v in col])


def test_corners_are_the_calibrated_domain_and_fe_lies_within_the_bound(rom):
    from isj.fem.model import PedicleJointModel

    cal = default_calibration()
    g = G.run_guard(cal, rom, {"gap_e_pa": np.array([2e7])}, n_dense=64, pressure_pa=PRESSURE)
    corners = g.sets["corners"]
    d = len(cal.domain)
    assert corners.n == 2**d == 32 and corners.inside.all()
    got = {tuple(corners.designs[k][i] for k in cal.domain) for i in range(corners.n)}
    assert got == set(itertools.product(*[tuple(v) for v in cal.domain.values()]))
    assert g.sets["dense"].n == 64 and g.sets["dense"].inside.all()
    fe = PedicleJointModel(order=ORDER, resolution=RESOLUTION)
    lows = np.flatnonzero(
        [all(corners.designs[k][i] == cal.domain[k][0] for k in cal.domain) for i in range(32)]
    )
    for i in (int(lows[0]), int(np.argmax(corners.max_certified))):  # every modulus low; the worst corner
        e = [corners.designs[k][i] for k in rom.space.bounds]
        r = fe.static(rom.space.materials(e), PRESSURE)
        for k, truth in (("alpha_rad", r.alpha_rad), ("beta_rad", r.beta_rad), ("beta_over_alpha", r.ratio)):
            assert abs(truth - corners.surrogate[k][i]) <= corners.surrogate[G.GUARDED[k]][i], (i, k)


def test_certified_error_brackets_every_fe_value_in_the_bound():
    lum, s, ds = 1.1, 1.0, 0.01
    cert = G.certified_error(np.array([lum]), np.array([s]), np.array([ds]))[0]
    for f in np.linspace(s - ds, s + ds, 101):
        assert abs(lum / f - 1) <= cert * (1 + 1e-15)
    assert cert == pytest.approx(lum / (s - ds) - 1, rel=1e-15)
    assert math.isinf(G.certified_error(np.array([1.0]), np.array([0.5]), np.array([0.6]))[0])


def test_out_files_recomputed_independently(cli, rom, tmp_path):
    out = tmp_path / "out"
    ranged = {"--gap-e": "1e6:1e8", "--capsule-e": "1e7:3e8", "--plate-e": "3e8:5e9"}  # gap past the domain
    argv = [x for kv in ranged.items() for x in kv]
    code, stdout, err = cli(
        *argv, "--n", "3", "--spot-checks", "2", "--guard-sample", "256", "--out", str(out), "--json"
    )
    assert cli.asked == [(ORDER, RESOLUTION, 12e9)]
    summary = json.loads(stdout)
    assert code == 1  # the lumped model (fitted to P2) fails the guard on this P1 mesh
    assert "fail the guard" in err
    # the CSV: one row per explored design, columns with units
    t = _read_csv(out / "designs.csv")
    assert len(t["verdict"]) == 27 == summary["n_designs"]
    E = {k: _floats(t[k]) for k in MODULI}
    lum = static_response(default_calibration().factor_array(), None, PRESSURE, **E)
    la, lb = _floats(t["lumped_alpha_rad"]), _floats(t["lumped_beta_rad"])
    np.testing.assert_allclose(la, lum.alpha_rad, rtol=1e-14)
    np.testing.assert_allclose(lb, lum.beta_rad, rtol=1e-14)
    np.testing.assert_allclose(_floats(t["lumped_beta_over_alpha"]), lb / la, rtol=1e-14)
    inside = E["gap_e_pa"] <= 5e7 * (1 + 1e-12)
    verdict = np.array(t["verdict"])
    assert np.all(verdict[~inside] == "outside") and np.all(verdict[inside] != "outside") and (~inside).any()
    assert np.all(np.isnan(_floats(t["surrogate_alpha_rad"])[~inside]))
    ev = rom.evaluate(np.stack([E[k][inside] for k in rom.space.bounds], axis=1), PRESSURE)
    for k, lk in (("alpha_rad", la), ("beta_rad", lb), ("beta_over_alpha", lb / la)):
        stem = k.removesuffix("_rad")
        np.testing.assert_allclose(_floats(t[f"surrogate_{k}"])[inside], ev[k], rtol=1e-13)
        np.testing.assert_allclose(
            _floats(t[f"{stem}_rel_error"])[inside], lk[inside] / ev[k] - 1, rtol=1e-9, atol=1e-15
        )
        b = G.GUARDED[k]
        lo, hi = ev[k] - ev[b], ev[k] + ev[b]
        cert = np.maximum(np.abs(lk[inside] / lo - 1), np.abs(lk[inside] / hi - 1))
        np.testing.assert_allclose(_floats(t[f"{stem}_certified_error"])[inside], cert, rtol=1e-9)
    worst = _floats(t["max_certified_error"])[inside]
    assert np.all((worst <= 0.03) == (verdict[inside] == "ok"))
    # the NPZ holds the same arrays
    with np.load(out / "designs.npz") as z:
        for k, col in t.items():
            if k in ("verdict", "in_region"):  # strings
                assert z[k].tolist() == col
            else:
                np.testing.assert_array_equal(z[k], _floats(col))  # %.17g: exact
    # guard.json: the counts and the worst explored design are the CSV's; FE confirms the surrogate
    g = json.loads((out / "guard.json").read_text())
    assert g == summary["guard"]
    assert g["explored"]["n_outside"] == int((~inside).sum())
    assert g["explored"]["n_ok"] + g["explored"]["n_fail"] == int(inside.sum())
    assert g["explored"]["max_certified_error"] == pytest.approx(worst.max(), rel=1e-12)
    assert g["n_corners"] == len(g["corner_rows"]) == 32 and g["n_dense"] == 256
    top = max(g[s]["max_certified_error"] for s in ("explored", "corners", "dense"))
    conf = g["fe_confirmations"]
    assert len(conf) == 2 and all(c["confirmed"] for c in conf) and g["fe_confirmed"]
    assert conf[0]["alpha_certified_error"] <= top and max(
        conf[0][f"{k}_certified_error"] for k in ("alpha", "beta", "beta_over_alpha")
    ) == pytest.approx(top, rel=1e-12)  # the first FE check is at the worst design of all
    for c in conf:
        for k in G.GUARDED:
            assert abs(c[f"fe_{k}"] - c[f"surrogate_{k}"]) <= c[f"surrogate_{G.GUARDED[k]}"]
    # one map per pair of ranged moduli
    maps = sorted(p.name for p in out.glob("map_*.png"))
    assert len(maps) == math.comb(3, 2) == 3 and "map_gap_capsule.png" in maps
    assert all((out / m).read_bytes()[:4] == b"\x89PNG" for m in maps)
    cfg = json.loads((out / "config.json").read_text())
    assert (
        cfg["config"]["guard_sample"] == 256
        and "numpy" in cfg["versions"]
        and sorted(cfg["results"]["maps"]) == maps
    )
    files = ["designs.csv", "designs.npz", "guard.json", "config.json", *maps]
    assert sorted(p.name for p in out.iterdir()) == sorted(files)


def test_sample_maps_and_a_passing_run(cli, tmp_path):
    out = tmp_path / "out"
    # a tolerance this P1 mesh's lumped errors meet: exit 0; a sample gives scatter maps
    code, stdout, _ = cli(
        "--pedicle-e",
        "1e9:27e9",
        "--stapes-e",
        "3e8:5e9",
        "--sample",
        "40",
        "--spot-checks",
        "0",
        "--guard-sample",
        "16",
        "--tolerance",
        "10",
        "--out",
        str(out),
        "--json",
    )
    d = json.loads(stdout)
    assert code == 0 and d["passed"] and d["guard"]["explored"]["n_ok"] == 40
    assert [p.name for p in out.glob("map_*.png")] == ["map_pedicle_stapes.png"]
    # one ranged modulus: no pair, no map; text output keeps its summary line
    code, stdout, _ = cli(
        "--gap-e",
        "1e6:5e7",
        "--n",
        "3",
        "--spot-checks",
        "0",
        "--guard-sample",
        "0",
        "--tolerance",
        "10",
        "--out",
        str(out),
    )
    assert code == 0 and stdout.startswith("lumped model: 3 designs")
    assert "dense   : 0/0 ok" in stdout and not list(out.glob("map_*.png"))


def test_ranged_incus_is_outside_the_surrogate(cli):
    code, stdout, _ = cli(
        "--incus-e",
        "6e9:24e9",
        "--n",
        "3",
        "--spot-checks",
        "0",
        "--guard-sample",
        "0",
        "--tolerance",
        "10",
        "--json",
    )
    g = json.loads(stdout)["guard"]
    assert code == 0 and g["explored"]["n_outside"] == 2 and g["explored"]["n"] == 3  # 12 GPa is inside


@pytest.mark.parametrize(
    "argv, word",
    [
        (["--out", "FILE"], "--out"),
        (["--out", "FOREIGN"], "--out"),
        (["--out", ""], "--out"),
        (["--gap-e", "1e6:5e7", "--capsule-e", "1e7:3e8", "--n", "1001", "--out", "new"], "--n"),
        (["--guard-sample", "-1"], "--guard-sample"),
        (["--guard-sample", str(2**22 + 1)], "--guard-sample"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_writes_nothing(cli, tmp_path, monkeypatch, argv, word):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "FILE").write_text("x")
    (tmp_path / "FOREIGN").mkdir()
    (tmp_path / "FOREIGN" / "mine.txt").write_text("y")
    before = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*"))
    code, out, err = cli(*argv)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and word in err
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")) == before
    assert cli.asked == []  # refused before any surrogate was asked for


def test_without_gmsh_the_guard_says_so(cache, monkeypatch, capsys, tmp_path):
    """No gmsh and no cached mesh: the guard is reported unavailable, the run goes on."""
    monkeypatch.setitem(sys.modules, "gmsh", None)
    monkeypatch.setenv("ISJ_CACHE_DIR", str(tmp_path / "meshes"))  # an empty mesh cache
    code = main(
        [
            "explore",
            "--order",
            "1",
            "--resolution",
            "0.3",
            "--gap-e",
            "1e6:5e7",
            "--n",
            "3",
            "--spot-checks",
            "0",
            "--json",
        ]
    )
    out, err = capsys.readouterr()
    g = json.loads(out)["guard"]
    assert code == 0 and g["available"] is False and "gmsh" in g["reason"]
    assert "NOT guarded" in err and "gmsh" in err
