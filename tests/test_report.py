"""``isj report``: the PDF's pages and numbers, its figures, caching, bad configuration.

One coarse report (P2, resolution 0.35, few points) is computed per session,
first interrupted at its last step, then completed, so that resume, caching
and the PDF are all checked on the same run.
"""

import json
import math

import numpy as np
import pypdf
import pytest
from isj.reports import layout, pdf
from isj.reports.config import ReportConfig, load_config
from isj.reports.steps import STEPS

from isj.cli import main
from isj.errors import ConfigError

# the coarse report itself is the `report` fixture of tests/conftest.py (shared with the cache tests)


def _pages_text(path) -> list[str]:
    return [p.extract_text() for p in pypdf.PdfReader(path).pages]


def test_interrupted_run_writes_no_pdf_and_resumes_from_the_finished_steps(report):
    assert not report["pdf_after_interrupt"]
    # every step but the interrupted one came from the cache
    steps = ["model", "sweep", "cases", "trends", "convergence", "calibration", "ear"]
    steps += ["transmission", "load_path", "sliding", "guard", "uq", "geometry_trends"]
    assert report["first"]["cached"] == steps[: steps.index("ear")]  # the ear never ran before
    assert report["second"]["cached"] == steps


def test_pdf_has_the_pages_in_order(report):
    texts = _pages_text(report["dir"] / "report.pdf")
    assert len(texts) == len(pdf.PAGE_TITLES) == 15
    for text, title in zip(texts, pdf.PAGE_TITLES, strict=True):
        assert title in text


def test_pdf_is_reproducible_without_creation_date(report, tmp_path):
    path = report["dir"] / "report.pdf"
    meta = pypdf.PdfReader(path).metadata or {}
    assert "/CreationDate" not in meta
    # laid out again from the cached steps' results: the same bytes (the date on the pages
    # differs only across midnight)
    res, again = report["second"], tmp_path / "again.pdf"
    pdf.write_report(again, report["config"], res["steps"], res["arrays"], res["provenance"])
    if report["first"]["provenance"]["date"] == res["provenance"]["date"]:
        assert again.read_bytes() == report["first_bytes"]


def test_pdf_has_the_same_bytes_from_one_process_two_or_a_failed_second(report, tmp_path, monkeypatch):
    res = report["second"]
    args = (report["config"], res["steps"], res["arrays"], res["provenance"])
    two, one, failed = tmp_path / "two.pdf", tmp_path / "one.pdf", tmp_path / "failed.pdf"
    assert pdf.write_report(two, *args) == list(pdf.PAGE_TITLES)
    pdf.write_report(one, *args, processes=1)
    heard = []
    monkeypatch.setattr(pdf.sys, "executable", "/bin/false")  # the second process exits 1 at once
    pdf.write_report(failed, *args, say=lambda message, level=1: heard.append(message))
    assert two.read_bytes() == one.read_bytes() == failed.read_bytes()
    assert len(heard) == 1 and "pages 12-15 drawn here: the second process failed (exit 1" in heard[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["failed.pdf", "one.pdf", "two.pdf"]  # no parts left


def test_a_warm_rerun_keeps_the_pdf_and_a_damaged_one_is_laid_out_again(report, tmp_path, monkeypatch):
    import shutil

    import isj.reports.run as run_mod

    same_date = report["first"]["provenance"]["date"] == report["second"]["provenance"]["date"]
    second = json.loads((report["dir"] / "run.json").read_text())  # the fixture's warm rerun
    assert second["pdf"]["reused"] and len(second["cached_steps"]) == len(run_mod.STEPS)
    assert (report["dir"] / "report.pdf").read_bytes() == report["first_bytes"] or not same_date
    # the previous PDF cut short: the next run lays it out again, to the same bytes
    out = tmp_path / "out"
    shutil.copytree(report["dir"], out)
    whole = (out / "report.pdf").read_bytes()
    (out / "report.pdf").write_bytes(whole[: len(whole) // 2])
    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(report["fe_cache"]))
    run_mod.run_report(report["config"], out, verbosity=0)
    third = json.loads((out / "run.json").read_text())
    assert not third["pdf"]["reused"] and third["pdf"]["key"] == second["pdf"]["key"]
    assert (out / "report.pdf").read_bytes() == whole or not same_date
    # what the PDF is made from: every step key, the configuration and the provenance
    cfg, keys, prov = report["config"], second["step_keys"], second["provenance"]
    key = run_mod._pdf_key(cfg, keys, prov)
    assert key == second["pdf"]["key"]
    assert run_mod._pdf_key(cfg, keys | {"uq": "another"}, prov) != key
    assert run_mod._pdf_key(cfg, keys, prov | {"date": "1999-12-31"}) != key
    assert run_mod._pdf_key(load_config(report["case"], ["guard.seed=1"]), keys, prov) != key


def test_pdf_text_carries_the_numbers_of_the_json(report):
    data = report["dir"] / "data"
    texts = _pages_text(report["dir"] / "report.pdf")
    model = json.loads((data / "model.json").read_text())
    assert layout.urad(model["base"]["alpha_rad"]) in texts[1]
    assert layout.urad(model["base"]["beta_rad"]) in texts[1]
    assert str(model["n_tets"]) in texts[1]
    cases = json.loads((data / "cases.json").read_text())
    assert len(cases["rows"]) == 7
    for row in cases["rows"]:
        for side in ("fe", "lumped"):
            for k in ("alpha_rad", "beta_rad", "alpha_plus_beta_rad"):
                assert layout.urad(row[side][k]) in texts[2], (row["case"], side, k)
            assert layout.ratio(row[side]["beta_over_alpha"]) in texts[2]
        assert layout.pct(row["rel_diff"]["alpha_rad"]) in texts[2]
    assert layout.urad(cases["thesis_base"]["alpha_plus_beta_rad"]) in texts[2]
    cal = json.loads((data / "calibration.json").read_text())
    assert layout.pct(cal["check"]["max_abs_alpha_rad"]) in texts[6]
    assert "NOTE: this report's FE mesh (P2, resolution 0.35)" in texts[6]  # coarse, not the calibration's
    sweep = json.loads((data / "sweep.json").read_text())
    assert len(sweep["fe_checks"]) == 1
    assert layout.urad(sweep["fe_checks"][0]["beta_rad"]["fe_abs"]) in texts[7]
    assert f"{sweep['fe_modes_hz'][0]:10.0f}".strip() in texts[7]
    ear = json.loads((data / "ear.json").read_text())
    for c in ear["cases"]:
        assert (
            layout.urad(c["alpha_rad_per_pa"]) in texts[8] and layout.urad(c["beta_rad_per_pa"]) in texts[8]
        )
    assert f"{ear['cases'][0]['umbo_m_per_pa'] * 1e9:.2f}" in texts[8]


def test_json_numbers_are_physical(report):
    """Checks that could fail: FE and lumped agree on the cases, the FE check sits on the lumped curve."""
    data = report["dir"] / "data"
    cases = json.loads((data / "cases.json").read_text())
    for row in cases["rows"]:
        assert row["fe"]["alpha_rad"] > 0 and row["fe"]["beta_rad"] > 0
        # lumped and FE differ by the calibration error plus this coarse mesh (about 18 % stiffer in
        # beta than the default mesh), never by a unit or a factor
        assert abs(row["rel_diff"]["beta_rad"]) < 0.3 and abs(row["rel_diff"]["alpha_rad"]) < 0.3
    sweep = json.loads((data / "sweep.json").read_text())
    for k in ("alpha_rad", "beta_rad"):
        assert sweep["fe_checks"][0][k]["rel_error"] < 0.2
    # the whole ear: within a factor of 2 of the cat's umbo (53 nm/Pa), and a joint that barely
    # changes the stapes's piston motion compared with a rigid one
    ear = json.loads((data / "ear.json").read_text())
    base = ear["cases"][0]
    assert base["case"] == "base"
    assert 0.5 < base["umbo_m_per_pa"] / 53e-9 < 2
    assert base["footplate_piston_m_per_pa"] == pytest.approx(
        ear["rigid_joint"]["footplate_piston_m_per_pa"], rel=0.1
    )
    lumped = np.loadtxt(data / "sweep_lumped.csv", delimiter=",", skiprows=2)
    assert lumped.shape[0] == 20 and np.isfinite(lumped).all()


def test_every_figure_has_data(report):
    """Each plotting axes of each page holds at least one artist with finite data."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    res = report["second"]
    n_axes = 0
    for title, fig in pdf.build_pages(report["config"], res["steps"], res["arrays"], res["provenance"]):
        fig.canvas.draw()  # 3-D collections get their paths when drawn
        for ax in fig.axes:
            if ax.get_label() in ("<colorbar>", "legend"):
                continue
            n_axes += 1
            finite = []
            for line in ax.get_lines():
                y = np.asarray(line.get_ydata(), dtype=float)
                finite.append(y.size > 0 and np.isfinite(y).any())
            for coll in ax.collections:
                finite.append(len(coll.get_paths()) > 0)
            finite += [p.get_window_extent().width * p.get_window_extent().height > 0 for p in ax.patches]
            assert any(finite), f"empty axes on page {title!r}: {ax.get_title() or ax.get_ylabel()}"
        plt.close(fig)
    # model (2), cases (2), trends (2 x 3 + 2 geometry), energy (1), convergence (1), calibration (6),
    # sweep (2), ear (1), H_V (3), dH_V (3: one case, so no pedicle-or-joint ratio panel), sliding (1),
    # uncertainty (3 + 3), guard (one map per pair of the five moduli: 10), the cat circuit (4)
    assert n_axes == 2 + 2 + 6 + 2 + 1 + 1 + 6 + 2 + 1 + 3 + 3 + 1 + 6 + 10 + 4


def test_data_files_and_resolved_config(report):
    out = report["dir"]
    for name in ("model", "cases", "trends", "convergence", "calibration", "sweep", "ear"):
        assert (out / "data" / f"{name}.json").is_file()
    for csv in ("cases.csv", "strain_energy.csv", "convergence.csv", "calibration_check.csv", "ear.csv"):
        assert len((out / "data" / csv).read_text().splitlines()) >= 2
    assert (out / "base.vtu").stat().st_size > 0
    # the resolved configuration reads back as the same configuration
    assert load_config(out / "resolved_config.toml") == report["config"]
    run = json.loads((out / "run.json").read_text())
    assert "numpy" in run["provenance"]["versions"]
    # the process's peak memory after each step, in step order: a running peak never falls
    peak = run["peak_memory_gb_after_step"]
    assert set(peak) == {name for name, _, _ in STEPS}  # the file's keys are sorted
    gb = [peak[name] for name, _, _ in STEPS]
    assert gb[0] > 0 and all(a <= b for a, b in zip(gb[:-1], gb[1:], strict=True))
    held = run["memory_gb_after_step"]  # resident after each step: never above the peak so far
    assert all(0 < held[name] <= 1.001 * peak[name] for name, _, _ in STEPS)
    assert not [p for p in out.rglob(".*")]  # no temp files left


# ---- configuration: no FE needed ----------------------------------------------------------------


def test_defaults_file_and_overrides_in_that_order(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text("[design]\npedicle_e_pa = 12e9\ngap_e_pa = 7e6\n[sweep]\nfmax_hz = 20000\n")
    cfg = load_config(case, ["design.gap_e_pa=8e6", "mesh.order=1"])
    assert cfg.design.pedicle_e_pa == 12e9  # file
    assert cfg.design.gap_e_pa == 8e6  # override beats file
    assert cfg.mesh.order == 1
    assert cfg.sweep.fmax_hz == 20000.0 and isinstance(cfg.sweep.fmax_hz, float)
    assert cfg.design.capsule_e_pa == ReportConfig().design.capsule_e_pa  # default


@pytest.mark.parametrize(
    "text, overrides, word",
    [
        ("[design]\npedicle_e = 5e9\n", [], "design.pedicle_e"),
        ("[desing]\n", [], "desing"),
        ("[design]\npedicle_e_pa = -5e9\n", [], "pedicle_e_pa"),
        ("[design]\nnu = 0.5\n", [], "nu"),
        ("[sweep]\nfmax_hz = 50\n", [], "sweep.fmax_hz"),
        ("[sweep]\nn_freq = 2.5\n", [], "sweep.n_freq"),
        ("[mesh]\norder = 3\n", [], "mesh.order"),
        ("[mesh]\ndrum_mesh_size_m = 1e-3\n", [], "mesh.drum_mesh_size_m"),
        ("", ["mesh.drum_mesh_size_m=1e-5"], "mesh.drum_mesh_size_m"),
        ("[geometry]\npedicle_x_m = 400e-6\n", [], "pedicle_x_m"),
        ("[trends]\nmoduli = ['incus']\n", [], "trends.moduli"),
        ("", ["geometry_trends.fe_points=1"], "geometry_trends.fe_points"),
        ("[geometry_trends]\nn_lumped = 4\n", [], "geometry_trends.n_lumped"),
        ("[calibration]\nfile = 'no/such.json'\n", [], "calibration.file"),
        ("design = 3\n", [], "design"),
        ("[design\n", [], "TOML"),
        ("", ["design.pedicle_e_pa"], "SECTION.KEY=VALUE"),
        ("", ["sweep.fmin_hz=abc"], "sweep.fmin_hz"),
        ("[transmission]\ncavities = 'closed'\n", [], "transmission.cavities"),
        ("", ["transmission.cavities=3"], "transmission.cavities"),
        ("[transmission]\nfast_ear_check = 'reduced'\n", [], "transmission.fast_ear_check"),
    ],
)
def test_bad_config_is_one_line_naming_it(tmp_path, text, overrides, word):
    case = tmp_path / "case.toml"
    case.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_config(case, overrides)
    msg = str(exc.value)
    assert word in msg and "\n" not in msg


def test_cli_bad_config_exits_2_and_writes_nothing(tmp_path, capsys):
    case = tmp_path / "case.toml"
    case.write_text("[sweep]\nfmax_hz = -1\n")
    out = tmp_path / "out"
    assert main(["report", "--config", str(case), "--out", str(out)]) == 2
    assert "sweep.fmax_hz" in capsys.readouterr().err
    assert not out.exists()
    assert main(["report", "--out", str(out), "--set", "design.capsule_e_pa=0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("isj: error:") and "capsule_e_pa" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_cli_corrupt_calibration_exits_2(tmp_path, capsys):
    bad = tmp_path / "cal.json"
    bad.write_text("{not json")
    out = tmp_path / "out"
    assert main(["report", "--out", str(out), "--set", f"calibration.file='{bad}'"]) == 2
    assert "cal.json" in capsys.readouterr().err
    assert not out.exists()


def test_toml_round_trip_of_every_default():
    import tomllib

    cfg = ReportConfig()
    data = tomllib.loads(cfg.to_toml())
    assert set(data) == {
        "design",
        "geometry",
        "mesh",
        "trends",
        "convergence",
        "calibration",
        "sweep",
        "ear",
        "transmission",
        "sliding",
        "guard",
        "uq",
        "geometry_trends",
    }
    assert math.isclose(data["design"]["pedicle_e_pa"], cfg.design.pedicle_e_pa)


def test_transmission_pages_carry_the_fe_ear_over_the_band(report):
    """ΔH_V from the reduced FE ear: its direct check, its low-frequency limit, its CSV."""
    data = report["dir"] / "data"
    tr = json.loads((data / "transmission.json").read_text())
    ear = json.loads((data / "ear.json").read_text())
    assert tr["cases"] == ["p12", "p12_sliding"]
    chk = tr["fe_checks"]
    assert chk["passed"] and chk["max_mag_rel_error"] < 0.01 and chk["max_phase_error_deg"] < 1.0
    assert [c["freq_hz"] for c in chk["checks"]] == [20000.0]
    # the direct solves check the first case as the step computed it: here the fast ear itself
    # (fast_ear_check = "direct"), which is also compared with the rigid connection's FE reduction
    assert chk["checked_model"] == tr["fe_reductions"]["p12"]["model"] == "fast"
    assert "h_v" not in chk["fast_ear"] and chk["fast_ear"]["rigid_h_v"]["band"]["max_db"] < 0.5
    # at 100 Hz ΔH_V is the static FE ear's ratio of footplate pistons (independent solves), up to
    # the joint's loss factors (complex moduli; measured 0.01 dB)
    static = {c["case"]: c["footplate_piston_m_per_pa"] for c in ear["cases"]}
    ratio_db = 20 * math.log10(static["p12"] / ear["rigid_joint"]["footplate_piston_m_per_pa"])
    lines = (data / "transmission.csv").read_text().splitlines()
    cols = lines[1].split(",")
    first = dict(zip(cols, map(float, lines[2].split(",")), strict=True))
    assert first["freq_hz"] == 100.0 and len(lines) == 2 + 40
    assert first["p12_delta_hv_db"] == pytest.approx(ratio_db, abs=0.03)
    # the sliding joint in the ear moves H_V at 100 Hz by less than 0.1 dB (measured 0.01 dB)
    assert -0.1 < first["p12_sliding_delta_hv_db"] - first["p12_delta_hv_db"] < 0.1
    # H_V at 100 Hz, far below the first mode (1.7 kHz), is stiffness-controlled: ω times the static
    # piston, lowered by the complex moduli by at most 1/sqrt(1 + η²) of the largest loss factor
    # (0.3), raised by inertia by at most 1/(1 - (0.1/1.7)²) (measured: 2.0 % low)
    v = math.hypot(first["rigid_stapes_velocity_re_m_s_per_pa"], first["rigid_stapes_velocity_im_m_s_per_pa"])
    static = 2 * math.pi * 100 * ear["rigid_joint"]["footplate_piston_m_per_pa"]
    eta = max(tr["damping"]["loss_factor"].values())
    assert static / math.sqrt(1 + eta**2) <= v <= static / (1 - (0.1 / 1.7) ** 2)
    texts = _pages_text(report["dir"] / "report.pdf")
    assert "dH_V = H_V / H_V,rigid" in texts[10]
    assert f"{tr['quote'][0]['delta_db']['p12']:+7.2f}dB" in texts[10]


def test_transmission_holds_both_cavity_states_and_the_intact_ear_is_the_cavity_factor(report):
    """Both cavity states in transmission.json; intact / open H_V is 1 / (1 + K_cav X_U), X_U the
    stored open drum volume velocity over iω (docs/circuit.md §13.3), for every ear of the step."""
    from isj.cavities import DEFAULT_CAVITIES, cavity_factor

    data = report["dir"] / "data"
    tr = json.loads((data / "transmission.json").read_text())
    cav = tr["cavities"]
    assert ReportConfig().transmission.cavities == "both" and DEFAULT_CAVITIES == "open"
    assert cav["states"] == ["open", "intact"] and cav["ears"] == ["rigid", "p12", "p12_sliding"]
    f = np.asarray(tr["freq_hz"])
    lines = (data / "transmission.csv").read_text().splitlines()
    cols = lines[1].split(",")
    table = np.array([[float(x) for x in row.split(",")] for row in lines[2:]])
    for name in cav["ears"]:
        open_, intact = cav["per_state"]["open"][name], cav["per_state"]["intact"][name]
        # the open state is the step's own H_V, as its CSV has it
        re, im = (table[:, cols.index(f"{name}_stapes_velocity_{p}_m_s_per_pa")] for p in ("re", "im"))
        np.testing.assert_allclose(open_["stapes_velocity_db"], 20 * np.log10(np.hypot(re, im)), atol=1e-6)
        u = np.asarray(cav["open_drum_volume_velocity_m3_s_per_pa_re_im"][name]) @ [1, 1j]
        factor = cavity_factor(f, u / (2j * np.pi * f), "intact")
        got_db = np.subtract(intact["stapes_velocity_db"], open_["stapes_velocity_db"])
        got_deg = np.subtract(intact["stapes_velocity_deg"], open_["stapes_velocity_deg"])
        np.testing.assert_allclose(got_db, 20 * np.log10(np.abs(factor)), atol=1e-6)
        wrap = (got_deg - np.degrees(np.angle(factor)) + 180) % 360 - 180
        np.testing.assert_allclose(wrap, 0, atol=1e-5)
        # the cavities' air springs load the drum: below 1 kHz the intact ear moves about 2.9 dB less
        # (docs/circuit.md 13.3: lumped ear 2.9 dB, FE rigid-joint ear 2.86 dB at 200 Hz)
        assert np.all((-3.5 < np.asarray(got_db)[f < 1000]) & (np.asarray(got_db)[f < 1000] < -2.0))
    # ΔH_V in each state is against the rigid connection of the same state
    for s in cav["states"]:
        rows = cav["per_state"][s]
        d = np.subtract(rows["p12"]["stapes_velocity_db"], rows["rigid"]["stapes_velocity_db"])
        np.testing.assert_allclose(rows["p12"]["delta_hv_db"], d, atol=1e-9)
    # the open state's ΔH_V is the step's existing one
    q = tr["quote"][0]
    assert cav["quote"][0]["open"]["delta_db"]["p12"] == pytest.approx(q["delta_db"]["p12"], abs=1e-12)
    assert len((data / "transmission_cavities.csv").read_text().splitlines()) == 2 + f.size


def test_circuit_page_shows_the_published_cat_circuit_in_both_cavity_states(report):
    """The circuit's curves in the JSON are isj.lumped.circuit's at the stored frequencies; the
    deviations per band are the circuit study's on the stored H_V; the page names the circuit as
    a published model and states the drum's converged band from its one constant."""
    from isj.lumped.circuit import CatCircuit
    from isj.reports.transmission_step import DRUM_CONVERGENCE

    from isj.studies.circuit_comparison import compare_with_circuit

    data = report["dir"] / "data"
    tr = json.loads((data / "transmission.json").read_text())
    circ = tr["circuit"]
    f = np.asarray(circ["freq_hz"])
    assert circ["case"] == "p12" and set(circ["states"]) == {"open", "intact"}
    assert "not a measurement" in circ["label"]
    hv = {}
    for s, st in circ["states"].items():
        c = CatCircuit.load().frequency_response(f, s)
        us = st["circuit"]["stapes_volume_velocity"]
        np.testing.assert_allclose(us["magnitude"], np.abs(c.stapes_volume_velocity_m3_s), rtol=1e-12)
        np.testing.assert_allclose(
            us["phase_deg"], np.degrees(np.angle(c.stapes_volume_velocity_m3_s)), atol=1e-9
        )
        np.testing.assert_allclose(st["circuit"]["vestibule_gain"]["db"], c.vestibule_gain_db(), atol=1e-9)
        ear = st["ear"]["stapes_volume_velocity"]
        hv[s] = (
            np.asarray(ear["magnitude"])
            * np.exp(1j * np.radians(ear["phase_deg"]))
            / circ["footplate_area_m2"]
        )
        # the ear's U_S is A_fp times the step's H_V in that state
        db = 20 * np.log10(np.asarray(ear["magnitude"]) / circ["footplate_area_m2"])
        np.testing.assert_allclose(db, tr["cavities"]["per_state"][s]["p12"]["stapes_velocity_db"], atol=1e-9)
    study = compare_with_circuit(f, hv, circ["footplate_area_m2"], circ["cochlear_impedance_pa_s_m3"])
    for s in circ["states"]:
        for q, rows in circ["states"][s]["deviation_per_band"].items():
            for a, b in zip(rows, study["states"][s]["deviation_per_band"][q], strict=True):
                assert a["band_hz"] == b["band_hz"] and a["n_freq"] == b["n_freq"]
                for k in ("mean_abs_db", "max_abs_db", "mean_db", "mean_abs_deg", "max_abs_deg"):
                    assert a.get(k) == pytest.approx(b.get(k), abs=1e-6), (s, q, a["band_hz"], k)
    conv = tr["drum_convergence"]
    size = ReportConfig().mesh.drum_mesh_size_m  # the coarse report keeps the default drum
    assert conv["drum_mesh_size_m"] == size
    assert conv["within_1db_up_to_hz"] == DRUM_CONVERGENCE["drums"][size]["h_v_1db_hz"]
    texts = _pages_text(report["dir"] / "report.pdf")
    page = texts[pdf.PAGE_TITLES.index("14. The ear beside the published cat circuit")]
    assert "published model (Bruce et al. 2003), not a measurement" in page
    assert (
        f"({size * 1e3:.3g} mm) is converged up to {conv['within_1db_up_to_hz'] / 1e3:.1f} kHz"
        in " ".join(page.split())
    )
    band = circ["states"]["intact"]["deviation_per_band"]["stapes_volume_velocity"][3]
    assert f"{band['mean_abs_db']:8.2f}{band['max_abs_db']:8.2f}".strip() in page


def test_uq_page_carries_the_probability_and_the_indices(report):
    """The report's uncertainty step is isj uq's computation on the report's lumped model."""
    from isj.studies.uq import run_uq
    from isj.studies.uq_inputs import UQConfig

    uq = json.loads((report["dir"] / "data" / "uq.json").read_text())
    assert uq["samples"] == 20000 and uq["sobol_samples"] == 512
    direct = run_uq(UQConfig.default(samples=20000, sobol_samples=512, bootstrap=20))
    # the same draws on the same (shipped) calibration give the same count, bit for bit
    assert uq["n_beta_over_alpha_gt_1"] == direct.n_beta_over_alpha_gt_1
    lo, hi = uq["p_beta_over_alpha_gt_1_ci"]
    assert lo <= uq["p_beta_over_alpha_gt_1"] <= hi
    texts = _pages_text(report["dir"] / "report.pdf")
    assert f"P(beta/alpha > 1) = {uq['p_beta_over_alpha_gt_1']:.4f}" in texts[12]


def test_uq_section_has_isj_uq_ranges():
    """The report checks [uq] with isj uq's own ranges, before anything runs."""
    from isj.reports.config import UQ_RANGES

    from isj.studies import uq_inputs as ui

    assert UQ_RANGES == {
        "samples": ui.SAMPLES_RANGE,
        "sobol_samples": ui.SOBOL_SAMPLES_RANGE,
        "bootstrap": ui.BOOTSTRAP_RANGE,
        "seed": ui.SEED_RANGE,
    }
    assert ui.MAX_BOOTSTRAP_DRAWS == 2**24
    for bad, word in (("uq.sobol_samples=1000", "power of 2"), ("uq.samples=10", "uq.samples")):
        with pytest.raises(ConfigError, match=word):
            load_config(overrides=[bad])


def test_sliding_page_carries_bonded_and_sliding_cases(report):
    """The sliding step is fem.sliding's comparison on the report's mesh; releasing never stiffens."""
    res = json.loads((report["dir"] / "data" / "sliding.json").read_text())
    rows = {(r["case"], r["joint"]): r for r in res["rows"]}
    assert len(rows) == 14
    cases = json.loads((report["dir"] / "data" / "cases.json").read_text())
    for row in cases["rows"]:
        bonded, sliding = rows[row["case"], "bonded"], rows[row["case"], "sliding"]
        # the bonded joint is the cases step's own FE solve, to the last bit of the JSON
        assert bonded["alpha_rad"] == row["fe"]["alpha_rad"] and bonded["beta_rad"] == row["fe"]["beta_rad"]
        # releasing the tangential constraint never lowers the compliance (energy = work / 2)
        assert sliding["strain_energy_j"] >= bonded["strain_energy_j"] * (1 - 1e-12)
        # with the gap's face free to slide, the capsule carries all of the shear
        assert sliding["capsule_shear_share"] == pytest.approx(1.0, abs=1e-6)
    texts = _pages_text(report["dir"] / "report.pdf")
    assert "A sliding joint" in texts[11] and layout.urad(rows["base", "sliding"]["alpha_rad"]) in texts[11]


def test_guard_page_checks_the_lumped_model_over_the_domain(report):
    """The surrogate guards the report's lumped model at all 32 corners and a dense sample."""
    g = json.loads((report["dir"] / "data" / "guard.json").read_text())
    assert g["corners"]["n"] == 32 == len(g["corner_rows"]) and g["dense"]["n"] == 512
    rows = g["corner_rows"]
    dom = g["domain_pa"]
    # the corners are exactly the calibrated domain's bounds, each combination once
    assert len({tuple(r[k] for k in dom) for r in rows}) == 32
    assert all(r[k] in dom[k] for r in rows for k in dom)
    # the worst certified error is the largest over the rows, and FE lies within the surrogate's bound there
    worst = max(max(r[f"{k}_certified_error"] for k in ("alpha", "beta", "beta_over_alpha")) for r in rows)
    assert g["corners"]["max_certified_error"] == pytest.approx(worst, rel=1e-12)
    assert len(g["fe_confirmations"]) == 1 and g["fe_confirmed"]
    c = g["fe_confirmations"][0]
    assert abs(c["fe_alpha_rad"] - c["surrogate_alpha_rad"]) <= c["surrogate_alpha_bound_rad"]
    texts = _pages_text(report["dir"] / "report.pdf")
    assert "corners: 32 designs" in texts[13]


def test_geometry_trends_follow_the_pedicle_bending_law(report):
    """β against the pedicle's thickness b_x, α against the gap's, FE on the report's mesh.

    β is the pedicle's rotation: a sum of compliances, Euler-Bernoulli bending ∝ b_x^-3 (second
    moment b_y b_x³/12) and shear ∝ b_x^-1 (area b_x b_y), so its log-log slope is a weighted
    mean of -3 and -1 and lies between them; a slope steeper than -3 is impossible, one above -1
    would mean β is not the pedicle's. Measured here: about -2.5 on either side of 55 um.
    """
    g = json.loads((report["dir"] / "data" / "geometry_trends.json").read_text())
    px = g["trends"]["pedicle_x_m"]
    assert px["value_m"] == report["config"].geometry.pedicle_x_m
    assert [q["value_m"] for q in px["fe_points"]] == sorted(q["value_m"] for q in px["fe_points"])
    assert len(px["fe_points"]) == 3  # the report's value and the domain's two ends
    for slope in (px["fe_slope_below"], px["fe_slope_above"]):
        assert -3.0 < slope < -1.0
    # α: the gap is in series in the joint's load path, so a thicker gap is a more compliant joint
    gap = g["trends"]["gap_thickness_m"]
    alpha = [q["fe"]["alpha_rad"] for q in gap["fe_points"]]
    assert all(b > a for a, b in zip(alpha, alpha[1:], strict=False))
    assert gap["fe_slope_below"] > 0 and gap["fe_slope_above"] > 0
    # the report's geometry is the cases step's own FE solve, to the last bit of the JSON
    here = next(q for q in px["fe_points"] if q["value_m"] == px["value_m"])
    base = json.loads((report["dir"] / "data" / "cases.json").read_text())["rows"][0]["fe"]
    assert here["fe"]["beta_rad"] == base["beta_rad"] and here["fe"]["alpha_rad"] == base["alpha_rad"]
    # the lumped curves come from the geometry calibration: within its held-out error plus this
    # coarse mesh (cases: under 30 %) of FE at every point
    for tr in g["trends"].values():
        for q in tr["fe_points"]:
            for k in ("alpha_rad", "beta_rad"):
                assert abs(q["lumped"][k] / q["fe"][k] - 1) < 0.3
    texts = _pages_text(report["dir"] / "report.pdf")
    assert "pedicle_x_m (um)" in texts[3] and "gap_thickness_m (um)" in texts[3]
    assert f"FE slope {px['fe_slope_below']:+.2f} / {px['fe_slope_above']:+.2f}" in texts[3]
    assert (report["dir"] / "data" / "geometry_trends.csv").read_text().count("pedicle_x_m") == 3


def test_calibration_page_shows_the_geometry_domain(report):
    """The geometry calibration's box (um) and held-out errors, as the shipped artifact records them."""
    from isj.calibration.doe import GEOMETRY_DOMAIN_M
    from isj.lumped.artifact import geometry_calibration

    cal = json.loads((report["dir"] / "data" / "calibration.json").read_text())["geometry"]
    shipped = geometry_calibration()
    assert cal["domain_m"] == {k: list(v) for k, v in GEOMETRY_DOMAIN_M.items()}
    v = cal["validation"]
    assert v == shipped.validation and v["n"] + v["n_beyond_support_limit"] == 64
    text = _pages_text(report["dir"] / "report.pdf")[6]
    assert f"held out: max |error| alpha {100 * cal['validation']['max_alpha']:.1f} %" in text
    for k, (lo, hi) in GEOMETRY_DOMAIN_M.items():
        assert k in text and f"{lo * 1e6:7.2f}".strip() in text and f"{hi * 1e6:7.2f}".strip() in text


def test_the_drum_bands_the_report_states_are_the_convergence_benchmarks():
    """DRUM_CONVERGENCE holds benchmarks/drum_convergence.py's stored measurement, not typed numbers."""
    from pathlib import Path

    from isj.reports.transmission_step import DRUM_CONVERGENCE, drum_convergence

    stored = json.loads(
        (Path(__file__).parents[1] / "benchmarks" / "results" / "drum_convergence.json").read_text()
    )
    bands = stored["converged_band_against_finest_hz"]
    assert {float(k) for k in bands} == set(DRUM_CONVERGENCE["drums"])
    for size, band in DRUM_CONVERGENCE["drums"].items():
        measured = bands[next(k for k in bands if float(k) == size)]
        assert band["h_v_1db_hz"] == pytest.approx(measured["h_v_1db_hz"], abs=0.1)
        assert band["delta_0p1db_hz"] == pytest.approx(measured["delta_0.1db_hz"], abs=0.1)
        assert band["delta_1deg_hz"] == pytest.approx(measured["delta_1deg_hz"], abs=0.1)
    assert DRUM_CONVERGENCE["against_m"] == min(r["drum_mesh_size_m"] for r in stored["rows"])
    assert drum_convergence(ReportConfig().mesh.drum_mesh_size_m)["within_1db_up_to_hz"] > 10e3
    assert drum_convergence(0.2e-3)["within_1db_up_to_hz"] is None  # not measured: not stated


def test_the_band_check_reduces_the_first_case_and_compares_the_fast_ear_over_the_band(report, monkeypatch):
    """``fast_ear_check = "band"``: the first case also reduced with FE; the fast ear against that
    reduction over the band (within the targets to 10 kHz) and the reduction against the direct
    solves, which then agree far more closely than the fast ear's default check did."""
    import dataclasses

    import isj.reports.run as run_mod
    from isj.reports.steps import Context
    from isj.reports.transmission_step import fe_band

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(report["fe_cache"]))
    config = report["config"]
    t = dataclasses.replace(config.transmission, fast_ear_check="band", sliding_cases=())
    config = dataclasses.replace(config, transmission=t)
    ctx = Context(config, run_mod.load_calibration(config), report["fe_cache"], progress=False)
    freq_hz = np.geomspace(t.fmin_hz, t.fmax_hz, t.n_freq)
    _, info, checks, _ = fe_band(ctx, freq_hz)
    assert info["p12"]["model"] == "fast" and checks["checked_model"] == "fe"
    band = checks["fast_ear"]
    targets = band["targets_to_10khz"]
    assert band["h_v"]["to_10khz"]["max_db"] < targets["h_v_db"]
    assert band["delta_h_v"]["to_10khz"]["max_deg"] < targets["delta_deg"]
    assert checks["passed"] and checks["max_mag_rel_error"] < 1e-3
    default = json.loads((report["dir"] / "data" / "transmission.json").read_text())["fe_checks"]
    assert (
        default["checked_model"] == "fast"
        and default["checks"][0]["freq_hz"] == checks["checks"][0]["freq_hz"]
    )
