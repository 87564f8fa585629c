"""``isj app``: its state → outputs layer, and the page in headless Chromium (docs/app.md).

The layer's numbers are checked against ``isj lumped solve --json`` and the library's own
functions; the browser tests start ``isj app --no-browser`` on 127.0.0.1 at a free port and
drive it through Playwright with Debian's Chromium (/usr/bin/chromium, installed by
scripts/setup). Without Chromium or Playwright the browser tests skip, saying which.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from isj.app import state
from isj.errors import InvalidParameter

pytestmark = pytest.mark.slow  # the app in a browser and FE verify

CHROMIUM = "/usr/bin/chromium"


def lumped_solve_json(design: state.Design) -> dict:
    """``isj lumped solve --json`` of ``design`` (the command line, in a child process)."""
    cmd = [sys.executable, "-m", "isj", "lumped", "solve", "--json", "--pressure", repr(design.pressure_pa)]
    for k, v in design.moduli.items():
        cmd += [f"--{k.removesuffix('_e_pa')}-e", repr(v)]
    for k, v in design.dims.items():
        if v != getattr(state.Geometry(), k):
            cmd += ["--geometry", f"{k}={v!r}"]
    cmd += ["--joint", design.joint]
    r = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return json.loads(r.stdout)


def shown(x: float, digits: int = 4) -> str:
    """``x`` as the page shows it: ``digits`` significant digits (µrad for angles)."""
    return f"{x:.{digits}g}"


# ---- the state → outputs layer ----------------------------------------------------------------


@pytest.mark.parametrize("case", ["defaults", "j5", "p3"])
def test_static_outputs_equal_lumped_solve(case):
    d = state.Design.case(case)
    out = state.static_outputs(d)
    cli = lumped_solve_json(d)
    for k in ("alpha_rad", "beta_rad", "beta_over_alpha"):
        assert out[k] == cli[k]
    assert out["region"] == cli["region"]


def test_static_outputs_sliding_and_geometry_equal_lumped_solve():
    d = state.Design().replace("joint", "sliding")
    assert state.static_outputs(d)["alpha_rad"] == lumped_solve_json(d)["alpha_rad"]
    g = state.Design().replace("pedicle_x_m", 60e-6)
    out, cli = state.static_outputs(g), lumped_solve_json(g)
    assert (out["alpha_rad"], out["beta_rad"]) == (cli["alpha_rad"], cli["beta_rad"])
    assert out["outside_geometry"] == {}


def test_marks_outside_domain_and_geometry():
    lo, hi = state.calibrated_domain()["gap_e_pa"]
    out = state.static_outputs(state.Design().replace("gap_e_pa", hi * 2))
    assert set(out["outside_domain"]) == {"gap_e_pa"}
    assert out["outside_domain"]["gap_e_pa"] == (hi * 2, lo, hi)
    glo, ghi = state.geometry_domain()["pedicle_x_m"]
    out = state.static_outputs(state.Design().replace("pedicle_x_m", ghi * 1.2))
    assert "pedicle_x_m" in out["outside_geometry"]


@pytest.mark.parametrize(
    "name, text, words",
    [
        ("gap_e_pa", "abc", ["gap_e_pa", "not a number", "1000", "1e+12"]),
        ("gap_e_pa", "-5", ["gap_e_pa = -5", "[1000, 1e+12]"]),
        ("gap_e_pa", "nan", ["gap_e_pa = nan"]),
        ("pedicle_x_m", "1", ["pedicle_x_m = 1", "[1e-05, 0.002]"]),
        ("pressure_pa", "0", ["pressure_pa = 0"]),
    ],
)
def test_parse_value_refuses_in_one_line(name, text, words):
    with pytest.raises(InvalidParameter) as exc:
        state.parse_value(name, text)
    msg = str(exc.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg


def test_parse_value_takes_numbers():
    assert state.parse_value("gap_e_pa", " 5e6 ") == 5e6
    assert state.parse_value("pedicle_x_m", "6e-5") == 6e-5


def test_inconsistent_geometry_refused():
    with pytest.raises(InvalidParameter, match="capsule_bond_m"):
        state.Design().replace("capsule_bond_m", 50e-6)  # above capsule_reach_m = 40 µm


def test_ratio_map_agrees_with_static_at_grid_points():
    d = state.Design.case("c20")
    m = state.ratio_map(d, "pedicle_e_pa", "capsule_e_pa", n=7)
    assert m["ratio"].shape == (7, 7)
    i, j = 2, 5  # ratio[row j (y), column i (x)]
    point = d.replace("pedicle_e_pa", m["x"][i]).replace("capsule_e_pa", m["y"][j])
    assert math.isclose(m["ratio"][j, i], state.static_outputs(point)["beta_over_alpha"], rel_tol=1e-12)
    # a stiffer pedicle bends less: beta/alpha falls along x at every y
    assert np.all(np.diff(m["ratio"], axis=1) < 0)
    with pytest.raises(InvalidParameter):
        state.ratio_map(d, "gap_e_pa", "gap_e_pa")


def test_uncertainty_counts_and_probability():
    d = state.Design()
    kinds = {k: "loguniform" for k in state.MODULI}
    u = state.uncertainty(d, kinds, 2.0, 5000, seed=3)
    assert int(u["counts"].sum()) == 5000
    lo, hi = u["p_interval"]
    assert lo <= u["p_gt_1"] <= hi
    # the same draws through the study layer give the same probability
    from isj.studies.uq import evaluate_outputs, lumped_evaluator, sample_moduli
    from isj.studies.uq_inputs import Distribution, UQConfig

    dists = {k: Distribution.loguniform(*state.calibrated_domain()[k], name=k) for k in state.MODULI}
    dists["incus_e_pa"] = Distribution.fixed(12e9, name="incus_e_pa")
    out = evaluate_outputs(lumped_evaluator(), sample_moduli(UQConfig(dists, samples=5000, seed=3)))
    assert u["p_gt_1"] == np.mean(out["beta_over_alpha"] > 1)
    # a lognormal so narrow that every draw sits next to the design
    narrow = state.uncertainty(d, {"gap_e_pa": "lognormal"}, 1.0001, 1000)
    ratio = state.static_outputs(d)["beta_over_alpha"]
    assert narrow["p_gt_1"] == (1.0 if ratio > 1 else 0.0)
    with pytest.raises(InvalidParameter, match="samples"):
        state.uncertainty(d, kinds, 2.0, 10)


def test_ear_velocity_in_the_lumped_band():
    e = state.ear_velocity(state.Design(), n=20)
    assert e["source"] == "lumped ear"
    assert e["band_hz"] == state.LUMPED_EAR_BAND_HZ
    assert e["freq_hz"][0] >= e["band_hz"][0] and e["freq_hz"][-1] <= e["band_hz"][1]
    assert np.all(np.isfinite(e["h_v_abs"])) and np.all(e["h_v_abs"] > 0)
    # a rigid-like joint: moduli at the top of the physical range leave almost nothing to lose
    stiff = state.Design(moduli={k: 1e12 for k in state.MODULI})
    assert np.max(np.abs(state.ear_velocity(stiff, n=20)["delta_db"])) < 0.05


def test_case_toml_loads_as_report_config(tmp_path):
    from isj.reports.config import load_config

    d = state.Design.case("j5c20").replace("pedicle_x_m", 60e-6).replace("pressure_pa", 30.0)
    path = tmp_path / "case.toml"
    path.write_text(state.case_toml(d, 0.35))
    cfg = load_config(path)
    for k, v in d.moduli.items():
        assert getattr(cfg.design, k) == v
    assert cfg.design.pressure_pa == 30.0
    assert cfg.geometry.pedicle_x_m == 60e-6
    assert cfg.mesh.resolution == 0.35
    assert "isj report --config isj-case.toml" in state.report_command()


# ---- the page in a real browser ---------------------------------------------------------------


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (from /proc)."""
    out = []
    for p in Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                stat = (p / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(p.name))
    return out


@contextlib.contextmanager
def serving_app(env: dict):
    """``isj app --no-browser`` on 127.0.0.1 at a free port with ``env``: yields (url, process),
    and stops the server afterwards."""
    port = _free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "isj", "app", "--no-browser", "--port", str(port)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    log: list[str] = []
    try:
        line = proc.stdout.readline()
        assert line.startswith("isj app: serving on http://127.0.0.1:"), line
        # the rest of its output is read as it comes: a full pipe would stop the server, and a
        # test that fails shows what the server said (captured output, below)
        threading.Thread(target=lambda: log.extend(proc.stdout), daemon=True).start()
        yield f"http://127.0.0.1:{port}/", proc
    finally:
        exited = proc.poll()
        proc.terminate()
        proc.wait(20)
        if exited is not None:
            print(f"isj app exited with {exited} before the end")
        print("".join(log[-40:]))  # its last output, shown with a failing test's captured output


@contextlib.contextmanager
def chromium():
    """Debian's Chromium, headless, through Playwright."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, headless=True)
        try:
            yield b
        finally:
            b.close()


@pytest.fixture(scope="module")
def app_server(tmp_path_factory):
    """``isj app --no-browser`` on 127.0.0.1 at a free port, with private caches; yields (url, process)."""
    if not Path(CHROMIUM).exists():
        pytest.skip(f"no Chromium at {CHROMIUM} (scripts/setup installs Debian's chromium)")
    pytest.importorskip(
        "playwright.sync_api", reason="playwright is not installed (pip install -e '.[test]')"
    )
    tmp = tmp_path_factory.mktemp("app")
    env = dict(os.environ, HOME=str(tmp / "home"), ISJ_FE_CACHE_DIR=str(tmp / "fe"))
    with serving_app(env) as served:
        yield served


@pytest.fixture(scope="module")
def browser(app_server):
    with chromium() as b:
        yield b


def _open(browser, url):
    page = browser.new_page(viewport={"width": 1400, "height": 1200})
    page.goto(url)
    page.locator("#alpha").wait_for(timeout=90_000)
    return page


def _shown_design(page) -> state.Design:
    """The design whose values the page's text fields show."""
    d = state.Design()
    for k in (*state.MODULI, *state.GEOMETRY_FIELDS, "pressure_pa"):
        d = d.replace(k, float(page.locator(f".isj-text-{k} input").input_value()))
    return d


def _check_numbers_equal_cli(page):
    """α, β and β/α on the page equal ``isj lumped solve --json`` of the design in its fields."""
    from playwright.sync_api import expect

    cli = lumped_solve_json(_shown_design(page))
    expect(page.locator("#alpha")).to_have_text(shown(cli["alpha_rad"] * 1e6))
    expect(page.locator("#beta")).to_have_text(shown(cli["beta_rad"] * 1e6))
    expect(page.locator("#ratio")).to_have_text(shown(cli["beta_over_alpha"]))


def _wait_field(page, name: str, text: str) -> None:
    """Wait until the text field of ``name`` shows ``text``."""
    from playwright.sync_api import expect

    expect(page.locator(f".isj-text-{name} input")).to_have_value(text)


def test_page_slider_and_typed_value_match_lumped_solve(browser, app_server):
    page = _open(browser, app_server[0])
    _check_numbers_equal_cli(page)
    page.locator(".isj-slider-gap_e_pa .noUi-handle").focus()
    for _ in range(5):  # five steps of 0.01 in log10 E: 1e7 Pa -> 10^6.95 Pa
        page.keyboard.press("ArrowLeft")
    _wait_field(page, "gap_e_pa", f"{10**6.95:.6g}")
    _check_numbers_equal_cli(page)

    field = page.locator(".isj-text-pedicle_e_pa input")
    field.fill("12e9")
    field.press("Enter")
    _wait_field(page, "pedicle_e_pa", "1.2e+10")  # the page writes back its own format
    _check_numbers_equal_cli(page)
    assert float(page.locator(".isj-text-pedicle_e_pa input").input_value()) == 12e9
    page.close()


def test_page_bad_value_is_one_message_and_server_keeps_serving(browser, app_server):
    page = _open(browser, app_server[0])
    alpha = page.locator("#alpha").text_content()
    field = page.locator(".isj-text-capsule_e_pa input")
    field.fill("fifty")
    field.press("Enter")
    msg = page.locator("#message")
    msg.filter(has_text="capsule_e_pa").wait_for(timeout=20_000)
    text = msg.text_content()
    assert "not a number" in text and "Traceback" not in page.content()
    assert page.locator("#alpha").text_content() == alpha  # the design did not change
    # a second tab at the same time, and the first still answers
    other = _open(browser, app_server[0])
    assert other.locator("#message").text_content() == ""
    field.fill("2e7")
    field.press("Enter")
    _wait_field(page, "capsule_e_pa", "2e+07")
    from playwright.sync_api import expect

    expect(page.locator("#message")).to_have_text("")
    _check_numbers_equal_cli(page)
    assert other.locator("#alpha").text_content() == alpha  # tabs do not share a design
    other.close()
    page.close()
    assert app_server[1].poll() is None


def test_page_verify_with_fe_on_the_coarse_mesh(browser, app_server):
    page = _open(browser, app_server[0])
    res = page.locator(".isj-fe-res input")
    res.fill("0.35")
    res.press("Enter")
    page.locator(".isj-verify button").click()
    page.locator("#fe-alpha").wait_for(timeout=180_000)
    d = _shown_design(page)
    cmd = [sys.executable, "-m", "isj", "fem", "solve", "--json", "--resolution", "0.35"]
    for k, v in d.moduli.items():
        cmd += [f"--{k.removesuffix('_e_pa')}-e", repr(v)]
    fe = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
    assert page.locator("#fe-alpha").text_content() == shown(fe["alpha_rad"] * 1e6)
    assert page.locator("#fe-beta").text_content() == shown(fe["beta_rad"] * 1e6)
    page.close()


def test_closing_the_page_ends_its_fe_job(browser, app_server):
    url, proc = app_server
    page = _open(browser, url)
    res = page.locator(".isj-fe-res input")
    res.fill("2")  # a fine mesh: minutes, so the job is still running when the page closes
    res.press("Enter")
    page.locator(".isj-verify button").click()
    page.locator("#fe-progress").wait_for(timeout=20_000)
    assert _children(proc.pid), "the FE job did not start"
    page.close()
    deadline = time.monotonic() + 30
    while _children(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.25)
    assert _children(proc.pid) == []
    assert proc.poll() is None


def test_cli_refuses_bad_port():
    r = subprocess.run(
        [sys.executable, "-m", "isj", "app", "--port", "70000"], capture_output=True, text=True
    )
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == ["isj: error: --port = 70000: must be an integer in [0, 65535]"]


def test_job_cancel_ends_the_process_group():
    """A job and the process it starts are both gone after cancel()."""
    from isj.app.jobs import Job

    code = (
        "import subprocess, sys, time\n"
        "p = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)'])\n"
        "print('child', p.pid, flush=True)\n"
        "time.sleep(60)\n"
    )
    job = Job([sys.executable, "-c", code])
    deadline = time.monotonic() + 30
    while not job.lines and time.monotonic() < deadline:
        time.sleep(0.05)
    grandchild = int(job.lines[0].split()[1])
    assert Path(f"/proc/{grandchild}").exists() and not job.done
    job.cancel()
    assert job.returncode is not None and job.cancelled
    deadline = time.monotonic() + 10
    while _running(grandchild) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _running(grandchild)


def _running(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def test_fe_job_result_line(tmp_path, monkeypatch):
    """The FE job prints one result line with FE's α and β; a bad payload is one error line, exit 1."""
    from isj.app import jobs

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "fe"))
    bad = jobs.fe_job(
        dict(
            moduli={"gap_e_pa": 1e7}, geometry=None, joint="bonded", pressure_pa=28.5, order=2, resolution=99
        )
    )
    try:
        deadline = time.monotonic() + 60
        while not bad.done and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        bad.cancel()
    assert bad.returncode == 1 and bad.result is None
    assert bad.last_line.startswith("error: ") and "resolution" in bad.last_line
