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
