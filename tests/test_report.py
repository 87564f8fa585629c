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
from isj.reports import pdf
from isj.reports.config import ConfigError, ReportConfig, load_config

from isj.cli import main

# the coarse report itself is the `report` fixture of tests/conftest.py (shared with the cache tests)


def _pages_text(path) -> list[str]:
    return [p.extract_text() for p in pypdf.PdfReader(path).pages]


def test_interrupted_run_writes_no_pdf_and_resumes_from_the_finished_steps(report):
    assert not report["pdf_after_interrupt"]
    # every step but the interrupted one came from the cache
    steps = ["model", "cases", "trends", "convergence", "calibration", "sweep", "ear"]
    assert report["first"]["cached"] == steps[: steps.index("sweep")]  # the ear never ran before
    assert report["second"]["cached"] == steps


def test_pdf_has_the_pages_in_order(report):
    texts = _pages_text(report["dir"] / "report.pdf")
    assert len(texts) == len(pdf.PAGE_TITLES) == 9
    for text, title in zip(texts, pdf.PAGE_TITLES, strict=True):
        assert title in text


def test_pdf_is_reproducible_without_creation_date(report):
    path = report["dir"] / "report.pdf"
    meta = pypdf.PdfReader(path).metadata or {}
    assert "/CreationDate" not in meta
    # the same inputs give the same bytes (the date on the pages differs only across midnight)
    if report["first"]["provenance"]["date"] == report["second"]["provenance"]["date"]:
        assert path.read_bytes() == report["first_bytes"]


def test_pdf_text_carries_the_numbers_of_the_json(report):
    data = report["dir"] / "data"
    texts = _pages_text(report["dir"] / "report.pdf")
    model = json.loads((data / "model.json").read_text())
    assert pdf.urad(model["base"]["alpha_rad"]) in texts[1]
    assert pdf.urad(model["base"]["beta_rad"]) in texts[1]
    assert str(model["n_tets"]) in texts[1]
    cases = json.loads((data / "cases.json").read_text())
    assert len(cases["rows"]) == 7
    for row in cases["rows"]:
        for side in ("fe", "lumped"):
            for k in ("alpha_rad", "beta_rad", "alpha_plus_beta_rad"):
                assert pdf.urad(row[side][k]) in texts[2], (row["case"], side, k)
            assert pdf.ratio(row[side]["beta_over_alpha"]) in texts[2]
        assert pdf.pct(row["rel_diff"]["alpha_rad"]) in texts[2]
    assert pdf.urad(cases["thesis_base"]["alpha_plus_beta_rad"]) in texts[2]
    cal = json.loads((data / "calibration.json").read_text())
    assert pdf.pct(cal["check"]["max_abs_alpha_rad"]) in texts[6]
    assert "NOTE: this report's FE mesh (P2, resolution 0.35)" in texts[6]  # coarse, not the calibration's
    sweep = json.loads((data / "sweep.json").read_text())
    assert len(sweep["fe_checks"]) == 1
    assert pdf.urad(sweep["fe_checks"][0]["beta_rad"]["fe_abs"]) in texts[7]
    assert f"{sweep['fe_modes_hz'][0]:10.0f}".strip() in texts[7]
    ear = json.loads((data / "ear.json").read_text())
    for c in ear["cases"]:
        assert pdf.urad(c["alpha_rad_per_pa"]) in texts[8] and pdf.urad(c["beta_rad_per_pa"]) in texts[8]
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
    # model (2), cases (2), trends (2 x 3), energy (1), convergence (1), calibration (6), sweep (2), ear (1)
    assert n_axes == 2 + 2 + 6 + 1 + 1 + 6 + 2 + 1


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
        ("[geometry]\npedicle_x_m = 400e-6\n", [], "pedicle_x_m"),
        ("[trends]\nmoduli = ['incus']\n", [], "trends.moduli"),
        ("[calibration]\nfile = 'no/such.json'\n", [], "calibration.file"),
        ("design = 3\n", [], "design"),
        ("[design\n", [], "TOML"),
        ("", ["design.pedicle_e_pa"], "SECTION.KEY=VALUE"),
        ("", ["sweep.fmin_hz=abc"], "sweep.fmin_hz"),
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
    assert set(data) == {"design", "geometry", "mesh", "trends", "convergence", "calibration", "sweep", "ear"}
    assert math.isclose(data["design"]["pedicle_e_pa"], cfg.design.pedicle_e_pa)
