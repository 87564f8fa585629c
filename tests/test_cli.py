"""Command line: JSON keys others script against, one-line errors with exit 2, atomic outputs."""

import json

import meshio
import numpy as np
import pytest

from isj.cli import main

COARSE = ["--resolution", "0.35"]


def run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_solve_json_keys(capsys):
    code, out, _ = run(capsys, ["fem", "solve", "--json", "--order", "1", *COARSE])
    assert code == 0
    d = json.loads(out)
    for key in ("alpha_rad", "beta_rad", "n_tets", "n_dofs", "timings_s", "strain_energy_j"):
        assert key in d
    assert d["alpha_rad"] > 0 and d["beta_rad"] > 0


def test_solve_moduli_options_change_the_answer(capsys):
    _, out1, _ = run(capsys, ["fem", "solve", "--json", "--order", "1", *COARSE])
    _, out2, _ = run(capsys, ["fem", "solve", "--json", "--order", "1", *COARSE, "--pedicle-e", "10e9"])
    assert json.loads(out2)["beta_rad"] < json.loads(out1)["beta_rad"]


def test_solve_writes_vtu_and_run_record(capsys, tmp_path):
    vtu = tmp_path / "out" / "base.vtu"
    code, _, _ = run(capsys, ["fem", "solve", *COARSE, "--vtu", str(vtu)])
    assert code == 0
    m = meshio.read(vtu)
    assert m.cells[0].type == "tetra10"
    assert set(m.point_data) >= {"displacement_m"}
    assert set(m.cell_data) >= {"region_id", "strain_energy_density_j_m3"}
    assert m.cell_data["strain_energy_density_j_m3"][0].min() >= 0
    record = json.loads(vtu.with_suffix(".json").read_text())
    assert "numpy" in record["versions"] and record["config"]["resolution"] == 0.35
    assert not [p for p in vtu.parent.iterdir() if p.name.startswith(".")]  # no temp files left


@pytest.mark.parametrize(
    "argv, word",
    [
        (["--pedicle-e", "-5e9"], "--pedicle-e"),
        (["--gap-e", "0"], "--gap-e"),
        (["--capsule-e", "nan"], "--capsule-e"),
        (["--nu", "0.5"], "--nu"),
        (["--nu", "-1"], "--nu"),
        (["--pressure", "0"], "pressure"),
        (["--order", "3"], "--order"),
        (["--resolution", "-1"], "--resolution"),
        (["--incus-e", "abc"], "--incus-e"),
        (["--geometry", "pedicle_x_m=400e-6"], "pedicle_x_m"),
        (["--geometry", "capsule_bond_m=-1e-6"], "capsule_bond_m"),
        (["--geometry", "capsule_reach_m=200e-6"], "capsule_reach_m"),
        (["--geometry", "shoe_size_m=0.3"], "--geometry"),
    ],
)
def test_bad_input_one_line_exit_2_nothing_written(capsys, tmp_path, argv, word):
    vtu = tmp_path / "x.vtu"
    code, out, err = run(capsys, ["fem", "solve", "--vtu", str(vtu), *argv])
    assert code == 2
    assert word in err and len(err.strip().splitlines()) == 1
    assert not vtu.exists() and not list(tmp_path.iterdir())


def test_unknown_subcommand_exit_2(capsys):
    code, _, err = run(capsys, ["fem", "frobnicate"])
    assert code == 2 and len(err.strip().splitlines()) == 1


def test_cases_json(capsys):
    code, out, _ = run(capsys, ["fem", "cases", "--json", "--order", "1", *COARSE])
    assert code == 0
    rows = json.loads(out)
    assert [r["case"] for r in rows] == ["base", "j5", "c20", "c100", "j5c20", "p12", "p3"]
    for r in rows:
        assert {"pedicle_e_pa", "gap_e_pa", "capsule_e_pa", "alpha_rad", "beta_rad"} <= set(r)
    assert rows[5]["pedicle_e_pa"] == 12e9


def test_convergence_json(capsys):
    code, out, _ = run(
        capsys, ["fem", "convergence", "--direction", "y", "--json", "--resolutions", "1.5", "3"]
    )
    assert code == 0
    rows = json.loads(out)
    assert len(rows) == 2 and rows[1]["n_tets"] > rows[0]["n_tets"]
    for r in rows:
        assert {"n_tets", "n_dofs", "max_disp_m", "analytic_m", "rel_error"} <= set(r)
        assert abs(r["rel_error"]) < 0.15


def test_mesh_report(capsys):
    code, out, _ = run(capsys, ["fem", "mesh", "--json", "--order", "1", *COARSE])
    assert code == 0
    d = json.loads(out)
    assert sum(d["tets_per_region"].values()) == d["n_tets"]
    assert 0 < d["min_dihedral_deg"] < 70.53 and d["max_aspect_ratio"] >= 1
    assert d["stiffness_bandwidth_rcm"] < d["stiffness_bandwidth"]


@pytest.mark.slow
def test_geometry_option_changes_the_model(capsys):
    _, out1, _ = run(capsys, ["fem", "solve", "--json", "--order", "1", *COARSE])
    _, out2, _ = run(
        capsys, ["fem", "solve", "--json", "--order", "1", *COARSE, "--geometry", "pedicle_x_m=80e-6"]
    )
    assert json.loads(out2)["beta_rad"] < json.loads(out1)["beta_rad"]  # a thicker pedicle bends less


def test_modes_json_and_vtu(capsys, tmp_path):
    code, out, _ = run(
        capsys,
        ["fem", "modes", "--json", "--order", "1", *COARSE, "--n", "3", "--vtu-dir", str(tmp_path / "modes")],
    )
    assert code == 0
    f = json.loads(out)["freq_hz"]
    assert len(f) == 3 and 0 < f[0] <= f[1] <= f[2]
    assert (tmp_path / "modes" / "modes.pvd").exists() and (tmp_path / "modes" / "mode_03.vtu").exists()
    code, _, err = run(capsys, ["fem", "modes", "--n", "0"])
    assert code == 2 and "--n" in err


@pytest.mark.slow
def test_sweep_writes_csv_npz_plot_and_guards(capsys, tmp_path):
    out = tmp_path / "sw"
    argv = ["sweep", "--out", str(out), "--n", "50", "--fe-checks", "1", "--order", "1", *COARSE, "--json"]
    code, text, err = run(capsys, argv + ["--tolerance", "50"])  # P1 coarse: far from the calibration
    assert code == 0 and "warning: FE checks run at order 1" in err
    summary = json.loads(text)
    assert summary["passed"] and len(summary["fe_checks"]) == 1
    lines = (out / "sweep.csv").read_text().splitlines()
    assert lines[0].startswith("# units: freq_hz Hz") and len(lines) == 52
    data = np.load(out / "sweep.npz")
    assert data["response"].shape == (50, 3) and (out / "bode.png").stat().st_size > 10_000
    code, _, err = run(capsys, argv + ["--tolerance", "1e-9"])
    assert code == 1 and "exceeds the tolerance" in err
    code, _, err = run(
        capsys, ["sweep", "--fmin-hz", "5000", "--fmax-hz", "100", "--out", str(tmp_path / "x")]
    )
    assert code == 2 and "--fmin-hz" in err and not (tmp_path / "x").exists()


# -- the thin command line: one module per command group, shared workflows, one-line messages


def test_entry_points_are_one_main():
    import isj._cli
    import isj.cli

    assert isj.cli.main is isj._cli.main
    from isj._cli import _main

    assert [m.__name__.rsplit(".", 1)[-1] for m in _main.COMMANDS] == [
        "fem",
        "lumped",
        "calibrate",
        "explore",
        "sweep",
        "report",
        "ear",
        "rom",
        "uq",
        "app",
    ]


@pytest.mark.slow
def test_python_dash_m_isj(tmp_path):
    import subprocess
    import sys

    def isj(*argv):
        cmd = [sys.executable, "-m", "isj", *argv]
        return subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path)

    r = isj("--version")
    assert r.returncode == 0 and r.stdout.startswith("isj ")
    r = isj("fem", "solve", "--nu", "0.7")
    assert r.returncode == 2 and r.stderr.strip().count("\n") == 0 and "--nu" in r.stderr


@pytest.mark.slow
def test_out_of_domain_warns_in_one_line_every_time(capsys):
    from isj.lumped.artifact import default_calibration

    hi = default_calibration().domain["gap_e_pa"][1]
    for _ in range(2):  # a second run in the same process warns again
        code, out, err = run(capsys, ["lumped", "solve", "--json", "--gap-e", f"{3 * hi:g}"])
        assert code == 0 and json.loads(out)["alpha_rad"] > 0
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("isj: warning: gap_e_pa outside the calibrated domain")


def test_lumped_solve_is_the_shared_lumped_static(capsys):
    from isj.calibration.checks import lumped_static
    from isj.lumped.artifact import default_calibration

    from isj.design import Materials

    code, out, _ = run(capsys, ["lumped", "solve", "--json", "--pedicle-e", "8e9", "--pressure", "50"])
    d = json.loads(out)
    m = Materials(pedicle_e_pa=8e9)
    design = {f"{r}_e_pa": m.youngs(r) for r in ("pedicle", "gap")}
    ref = lumped_static(default_calibration(), [design], None, 50.0)
    assert code == 0 and d["alpha_rad"] == float(ref.alpha_rad[0]) and d["beta_rad"] == float(ref.beta_rad[0])
    assert d["beta_over_alpha"] == pytest.approx(d["beta_rad"] / d["alpha_rad"], rel=1e-15)


def test_explore_grid_without_spot_checks(capsys):
    code, out, err = run(
        capsys,
        ["explore", "--gap-e", "2e6:4e7", "--capsule-e", "2e7:2e8", "--n", "4", "--spot-checks", "0"]
        + ["--no-guard", "--json"],  # the guard: tests/test_explore_guard.py
    )
    assert code == 0 and err == ""
    d = json.loads(out)
    assert d["n_designs"] == 16 and d["spot_checks"] == [] and d["passed"] and d["outside_domain"] == 0
    assert d["guard"] == {"available": False, "reason": "--no-guard"}
    assert 0 < d["alpha_rad_range"][0] < d["alpha_rad_range"][1]
    # a stiffer gap and capsule turn the joint less: the softest corner gives the largest alpha
    code, out, _ = run(capsys, ["lumped", "solve", "--json", "--gap-e", "2e6", "--capsule-e", "2e7"])
    assert json.loads(out)["alpha_rad"] == pytest.approx(d["alpha_rad_range"][1], rel=1e-12)


@pytest.mark.parametrize(
    "argv, word",
    [
        (["explore", "--gap-e", "1e6:5e7", "--capsule-e", "1e7:3e8", "--n", "100000"], "--n"),
        (["explore", "--gap-e", "1e6:5e7", "--sample", "100000000"], "--sample"),
        (["explore", "--gap-e", "1e6:5e7", "--seed", "-1"], "--seed"),
        (["explore", "--gap-e", "5e7:1e6"], "--gap-e"),
        (["sweep", "--fmin-hz", "100", "--fmax-hz", "100"], "--fmin-hz"),
        (["sweep", "--n", "1"], "--n"),
        (["ear", "sweep", "--fe-checks", "51"], "--fe-checks"),
        (["calibrate", "--seed", "-2"], "--seed"),
    ],
)
def test_refused_before_computing(capsys, tmp_path, monkeypatch, argv, word):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, argv)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and word in err
    assert not list(tmp_path.iterdir())


def test_entry_point_only_reexports_main():
    from pathlib import Path

    cli = Path(__file__).resolve().parent.parent / "isj" / "cli.py"
    assert len(cli.read_text().splitlines()) < 30


# -- issue 17: sizes, non-finite results, whole output sets, the scheduler, before computing


def test_resolution_refused_with_a_memory_estimate(capsys):
    from isj.fem.sizing import MAX_MODEL_BYTES, estimate_mesh_size

    assert estimate_mesh_size(None, 2, 6.0)[2] > MAX_MODEL_BYTES  # in the option's range, too large
    code, out, err = run(capsys, ["fem", "solve", "--resolution", "6"])
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "--resolution = 6" in err and "GiB" in err and "must be <=" in err
    allowed = float(err.rsplit("must be <= ", 1)[1].split()[0])
    assert estimate_mesh_size(None, 2, allowed)[2] <= MAX_MODEL_BYTES < estimate_mesh_size(None, 2, 6.0)[2]
    code, _, err = run(capsys, ["ear", "cases", "--order", "1", "--resolution", "8"])  # P1: 29 GiB
    assert code == 2 and "P1 model" in err and "--resolution = 8" in err


def test_solver_not_installed_refused_before_meshing(capsys, tmp_path, monkeypatch):
    from isj.fem.solvers import available_backends

    missing = [b for b in ("cholmod", "pardiso") if b not in available_backends()]
    if not missing:
        pytest.skip("every solver is installed here")
    monkeypatch.setenv("ISJ_CACHE_DIR", str(tmp_path))
    code, out, err = run(capsys, ["fem", "solve", "--solver", missing[0], *COARSE])
    assert code == 2 and out == "" and "--solver" in err and len(err.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())  # no mesh was made, so no mesh cache entry


def test_non_finite_result_is_one_line_not_json_nan(capsys, monkeypatch):
    import isj.calibration.checks as checks

    real = checks.lumped_static

    def nan_static(*a, **k):
        r = real(*a, **k)
        return type(r)(**{**r.__dict__, "alpha_rad": np.full_like(r.alpha_rad, np.nan)})

    monkeypatch.setattr(checks, "lumped_static", nan_static)
    code, out, err = run(capsys, ["lumped", "solve", "--json", "--pedicle-e", "8e9"])
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "not finite" in err and "--pedicle-e 8e+09" in err and "alpha_rad" in err


def test_print_json_never_writes_nan(capsys):
    from isj._cli import _common as c

    with pytest.raises(ValueError):
        c.print_json({"x": float("nan")})
    with pytest.raises(c.UsageError, match="y.z\\[1\\] = inf"):
        c.check_finite({"y": {"z": [1.0, float("inf")]}}, "--a 1")
    c.check_finite({"y": np.ones(3), "n": 3, "s": "text"}, "--a 1")  # finite: no error


def test_sweep_with_nan_damping_ratios_never_passes(capsys, tmp_path, monkeypatch):
    import dataclasses

    import isj.studies.sweeps as sweeps

    real = sweeps.chain_sweep

    def nan_sweep(*a, **k):
        sw = real(*a, **k)
        return dataclasses.replace(sw, damping_ratio=np.full_like(sw.damping_ratio, np.nan))

    monkeypatch.setattr(sweeps, "chain_sweep", nan_sweep)
    out = tmp_path / "s"
    code, text, err = run(capsys, ["sweep", "--fe-checks", "0", "--n", "20", "--out", str(out), "--json"])
    assert code == 2 and text == "" and "damping_ratio" in err and "--damping published" in err
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_sweep_files_replaced_as_a_set(capsys, tmp_path, monkeypatch):
    import isj.lumped.plots as plots

    out = tmp_path / "s"
    argv = ["sweep", "--fe-checks", "0", "--n", "20", "--out", str(out)]
    assert run(capsys, argv)[0] == 0
    names = {"sweep.csv", "sweep.npz", "bode.png", "sweep.json"}
    first = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(first) == names

    def interrupted(*a, **k):  # after the CSV and the NPZ of the second run were written
        raise KeyboardInterrupt

    monkeypatch.setattr(plots, "save_bode", interrupted)
    code, _, err = run(capsys, [*argv, "--capsule-e", "8e7"])
    assert code == 130
    assert {p.name: p.read_bytes() for p in out.iterdir()} == first  # the previous set, whole
    assert [p.name for p in tmp_path.iterdir()] == ["s"]  # no partial folder left
    monkeypatch.undo()
    assert run(capsys, [*argv, "--capsule-e", "8e7"])[0] == 0
    second = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(second) == names and second["sweep.csv"] != first["sweep.csv"]
    assert [p.name for p in tmp_path.iterdir()] == ["s"]  # the old set removed
    (out / "notes.txt").write_text("mine")  # a folder holding other files is never replaced
    code, _, err = run(capsys, argv)
    assert code == 2 and "notes.txt" in err and (out / "notes.txt").read_text() == "mine"


def test_scheduler_checked_by_connecting(capsys, tmp_path, monkeypatch):
    import socket

    from isj._cli._common import check_scheduler
    from isj.errors import UsageError

    with socket.create_server(("127.0.0.1", 0)) as server:  # something listening: accepted
        port = server.getsockname()[1]
        check_scheduler(f"tcp://127.0.0.1:{port}")
        check_scheduler(f"127.0.0.1:{port}")
    with pytest.raises(UsageError, match="no scheduler reachable"):
        check_scheduler(f"tcp://127.0.0.1:{port}")  # closed now
    # an address that never answers is given up after the stated timeout, not waited on
    timeouts = []

    def unanswered(address, timeout):
        timeouts.append(timeout)
        raise TimeoutError

    monkeypatch.setattr(socket, "create_connection", unanswered)
    with pytest.raises(UsageError, match=r"within 2\.5 s"):
        check_scheduler("tcp://10.255.255.1:8786", timeout_s=2.5)
    assert timeouts == [2.5]
    for bad in ("inproc://x", "tcp://127.0.0.1", "tcp://:80", "tcp://h:99999"):
        with pytest.raises(UsageError, match="--scheduler"):
            check_scheduler(bad)


def test_lumped_solve_nu_of_the_calibration_accepted(capsys):
    code, out, _ = run(capsys, ["lumped", "solve", "--json", "--nu", "0.3"])
    ref = json.loads(run(capsys, ["lumped", "solve", "--json"])[1])
    assert code == 0 and json.loads(out) == ref
    code, _, err = run(capsys, ["lumped", "solve", "--nu", "0.3000001"])
    assert code == 2 and "--nu" in err and "calibrated at nu = 0.3" in err


def test_out_path_checks_leave_nothing(tmp_path, monkeypatch):
    from isj._cli import _common as c
    from isj.errors import UsageError

    monkeypatch.chdir(tmp_path)
    assert c.check_out_path("a/b/c.vtu", "--vtu", ".vtu") is not None
    assert c.check_out_dir("a/b", "--out", frozenset()) is not None
    (tmp_path / "f").write_text("")
    for args in (("f/x.vtu", "--vtu", ".vtu"), ("x.txt", "--vtu", ".vtu"), ("", "--vtu", ".vtu")):
        with pytest.raises(UsageError, match="--vtu"):
            c.check_out_path(*args)
    with pytest.raises(UsageError, match="not a folder"):
        c.check_out_dir("f/sub", "--out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]  # the probe folders are gone


def test_a_library_warning_is_one_line(capsys, monkeypatch):
    """A warning that is not isj's (scipy's, say) is one ``isj: warning:`` line, not Python's two."""
    import warnings

    from isj._cli import lumped

    def solve(args):
        warnings.warn("balance properties\nare lost", UserWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(lumped, "solve", solve)
    code, out, err = run(capsys, ["lumped", "solve"])
    assert code == 0 and not out
    assert err == "isj: warning: balance properties are lost (UserWarning)\n"


def test_cache_dirs_checked_without_leaving_anything(tmp_path, monkeypatch):
    from isj.caches import cache_dir_problem, check_cache_dirs
    from isj.errors import InvalidParameter

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "new" / "fe"))
    monkeypatch.setenv("ISJ_CACHE_DIR", str(tmp_path / "meshes"))
    got = check_cache_dirs("mesh", "fe", "rom", "report")
    assert got["rom"] == tmp_path / "new" / "fe" / "rom" and got["mesh"] == tmp_path / "meshes"
    assert list(tmp_path.iterdir()) == []  # checked, not created
    (tmp_path / "f").write_text("")
    assert "is not a folder" in cache_dir_problem(tmp_path / "f")
    assert "is not a folder" in cache_dir_problem(tmp_path / "f" / "below")
    assert "nothing can be written" in cache_dir_problem("/proc/isj-cache")
    with pytest.raises(InvalidParameter, match=r"^--cache = .*not a folder"):
        check_cache_dirs("fe", fe_path=tmp_path / "f")
    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "fe"))
    (tmp_path / "fe").mkdir()
    (tmp_path / "fe" / "report").write_text("")
    check_cache_dirs("fe", "rom")
    with pytest.raises(InvalidParameter, match=r"^\$ISJ_FE_CACHE_DIR \(its 'report' folder\)"):
        check_cache_dirs("fe", "report")
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["f", "fe", "report"]


def test_toml_nesting_limit():
    from isj.errors import ConfigError
    from isj.validate import MAX_TOML_DEPTH, loads_toml

    n = MAX_TOML_DEPTH - 1  # the document's table is one level, each array one more
    assert loads_toml("v = " + "[" * n + "]" * n, "x")["v"] is not None
    for depth in (n + 1, 5000):  # past the limit; past Python's recursion
        with pytest.raises(ConfigError, match=f"^x: nested more than {MAX_TOML_DEPTH} levels"):
            loads_toml("v = " + "[" * depth + "]" * depth, "x")
    with pytest.raises(ConfigError, match="nested"):
        loads_toml("\n".join(f"[{'.'.join(['t'] * 40)}]" for _ in range(1)), "x")


def test_band_limits_of_each_model():
    from isj.errors import InvalidParameter
    from isj.validate import CHAIN_FMAX_HZ, EAR_FMAX_HZ, check_band

    check_band(100.0, EAR_FMAX_HZ, model="ear")
    check_band(100.0, CHAIN_FMAX_HZ, model="chain")
    check_band(100.0, 1e9)  # no model: no upper limit
    with pytest.raises(InvalidParameter, match="fmax_hz = 24001: must be <= 24000 Hz"):
        check_band(100.0, 24001.0, model="ear")
    with pytest.raises(InvalidParameter, match="must be <= 100000 Hz"):
        check_band(100.0, CHAIN_FMAX_HZ * 1.001, model="chain")


def test_report_and_sweep_share_the_damping_limits(capsys, tmp_path):
    """The report's [sweep] damping and isj sweep's options are refused at the same values."""
    from isj.reports.config import load_config

    load_config(None, ["sweep.loss_factor=10"])  # the largest allowed
    code, _, err = run(capsys, ["sweep", "--loss-factor", "10.5", "--out", str(tmp_path / "s")])
    assert code == 2 and "[0, 10]" in err
    code, _, err = run(capsys, ["report", "--set", "sweep.loss_factor=10.5", "--out", str(tmp_path / "r")])
    assert code == 2 and "sweep.loss_factor" in err and "[0, 10]" in err
    # omega b <= 100 at the band's top: 40 kHz for the report's sweep, 20 kHz for isj sweep
    b = 100 / (2 * np.pi * 40e3)
    load_config(None, [f"sweep.rayleigh_b_s={b * 0.999}"])
    code, _, err = run(
        capsys, ["report", "--set", f"sweep.rayleigh_b_s={b * 1.001}", "--out", str(tmp_path / "r")]
    )
    assert code == 2 and "sweep.rayleigh_b_s" in err
    code, _, err = run(capsys, ["sweep", "--rayleigh-b", f"{2 * b * 1.001}", "--out", str(tmp_path / "s")])
    assert code == 2 and "--rayleigh-b" in err
    assert not (tmp_path / "s").exists() and not (tmp_path / "r").exists()


def test_modes_vtu_dir_rewritten_but_not_a_foreign_folder(capsys, tmp_path):
    d = tmp_path / "modes"
    argv = ["fem", "modes", "--json", "--order", "1", *COARSE, "--n", "2", "--vtu-dir", str(d)]
    assert run(capsys, argv)[0] == 0
    assert run(capsys, argv)[0] == 0  # a folder this command wrote is written again
    (d / "notes.txt").write_text("mine")
    code, _, err = run(capsys, argv)
    assert code == 2 and "--vtu-dir" in err and "notes.txt" in err


@pytest.mark.slow
def test_a_command_writes_nothing_into_the_home_folder(tmp_path):
    """``isj sweep`` with an FE check, from an empty home in a fresh process: gmsh meshes and
    matplotlib plots, and the home folder stays empty (matplotlib's font cache goes into the FE
    result cache, FLTK's preferences nowhere)."""
    import os
    import subprocess
    import sys

    home, fe = tmp_path / "home", tmp_path / "fe"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("XDG_", "MPL"))}
    env |= {"HOME": str(home), "ISJ_FE_CACHE_DIR": str(fe), "ISJ_CACHE_DIR": str(tmp_path / "meshes")}
    argv = ["sweep", "--n", "5", "--fe-checks", "1", "--order", "1", *COARSE, "--tolerance", "50"]
    done = subprocess.run(
        [sys.executable, "-m", "isj", *argv, "--out", str(tmp_path / "s")],
        env=env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert sorted(str(p.relative_to(home)) for p in home.rglob("*")) == []
    assert list((fe / "matplotlib").glob("fontlist-*.json"))
    assert (tmp_path / "s" / "bode.png").exists()
