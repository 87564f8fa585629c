"""The public Python API: ``isj.__all__``, LumpedModel, FrequencyResponse, static ``to_dict``, drawing.

LumpedModel is checked bit for bit against the paths the command line takes
(``isj lumped solve``, ``isj sweep``: run as subprocesses, so the check holds
whatever module the command line lives in) and against the lower-level functions
(``static_response``, ``chain_model``, ``ear_model``) threaded by hand.
"""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from isj.fem.ear.dynamics import harmonic
from isj.lumped.artifact import default_calibration
from isj.lumped.dynamics import chain_model, chain_outputs
from isj.lumped.ear import ear_model
from isj.lumped.model import MODULI, static_response

import isj
from isj.ear import EarMaterials
from isj.errors import CorruptCalibration, InvalidParameter
from isj.responses import FrequencyResponse


def _python(code: str, **env) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        env=dict(os.environ, **env),
        timeout=300,
    )


def _cli(*argv) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "isj", *argv], capture_output=True, text=True, timeout=300, cwd=os.getcwd()
    )


# ---- isj.__all__ --------------------------------------------------------------------------


def test_every_public_name_resolves():
    required = {"PedicleJointModel", "MiddleEarModel", "Materials", "Geometry", "LumpedModel"}
    assert required | {"FrequencyResponse", "StaticResult", "DesignSpace"} <= set(isj.__all__)
    for name in isj.__all__:
        assert getattr(isj, name) is not None, name
    assert set(isj.__all__) <= set(dir(isj))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        isj.nope  # noqa: B018


def test_import_isj_is_light():
    r = _python(
        """
        import sys, isj
        heavy = [m for m in ("numpy", "scipy", "gmsh", "casadi", "matplotlib", "isj.fem", "isj.lumped")
                 if m in sys.modules]
        print(heavy)
        """
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"


@pytest.mark.parametrize("name", ["PedicleJointModel", "MiddleEarModel", "LumpedModel", "DesignSpace"])
def test_first_access_meets_no_import_cycle(name):
    """Each entry point, reached first in a fresh interpreter, imports (isj.fem imports isj.design, ...)."""
    r = _python(f"import isj; print(isj.{name}.__module__)")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().startswith("isj.")


# ---- LumpedModel -----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def lm():
    return isj.LumpedModel.default()


def test_default_static_is_the_lumped_path_bit_for_bit(lm):
    rng = np.random.default_rng(3)
    designs = {k: np.exp(rng.uniform(np.log(lo), np.log(hi), 50)) for k, (lo, hi) in lm.domain.items()}
    got = lm.static(designs)
    factors = default_calibration().factor_array()
    ref = static_response(factors, pressure_pa=isj.DEFAULT_PRESSURE_PA, **designs)
    assert np.array_equal(got.alpha_rad, ref.alpha_rad) and np.array_equal(got.beta_rad, ref.beta_rad)
    # the same designs as keywords, and as a list of dicts (isj.sample's form)
    assert np.array_equal(lm.static(**designs).alpha_rad, ref.alpha_rad)
    listed = [{k: float(v[i]) for k, v in designs.items()} for i in range(50)]
    assert np.array_equal(lm.static(listed).beta_rad, ref.beta_rad)


def test_static_matches_isj_lumped_solve(lm):
    r = _cli("lumped", "solve", "--json", "--gap-e", "5e6", "--pedicle-e", "12e9", "--pressure", "30")
    assert r.returncode == 0, r.stderr
    cli = json.loads(r.stdout)
    got = lm.static(isj.Materials(gap_e_pa=5e6, pedicle_e_pa=12e9), pressure_pa=30.0).to_dict()
    assert got == {k: cli[k] for k in got}  # JSON floats round-trip: equality is bit for bit


def test_static_broadcasts_and_is_linear_in_pressure(lm):
    gap = np.geomspace(1e6, 50e6, 7)
    capsule = np.array([20e6, 80e6])
    r = lm.static(gap_e_pa=gap[:, None], capsule_e_pa=capsule, pressure_pa=np.array([1.0, 2.0]))
    assert r.alpha_rad.shape == (7, 2)
    one = lm.static(gap_e_pa=gap[:, None], capsule_e_pa=capsule, pressure_pa=1.0)
    assert np.array_equal(r.alpha_rad[:, 0], one.alpha_rad[:, 0])
    assert np.array_equal(r.alpha_rad[:, 1], 2 * one.alpha_rad[:, 1])  # times 2 is exact
    assert np.all(np.diff(one.alpha_rad[:, 0]) < 0)  # a stiffer gap: less joint rotation
    d = one.to_dict()
    assert np.shape(d["alpha_rad"]) == (7, 2) and d["pressure_pa"] == 1.0


def test_domain_and_in_domain(lm):
    dom = lm.domain
    assert set(dom) == set(default_calibration().domain) and set(dom) <= set(MODULI)
    lo = {k: v[0] for k, v in dom.items()}
    hi = {k: v[1] for k, v in dom.items()}
    assert lm.in_domain(lo) and lm.in_domain(hi)
    assert not lm.in_domain(lo, gap_e_pa=dom["gap_e_pa"][0] * 0.99)
    inside = lm.in_domain(gap_e_pa=[0.5e6, 10e6, 60e6])
    assert inside.tolist() == [False, True, False]


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda m: m.static(pressure_pa=0.0), "pressure_pa"),
        (lambda m: m.static(pressure_pa=[1.0, np.inf]), "pressure_pa"),
        (lambda m: m.static(gap_e_pa=-1.0), "gap_e_pa"),
        (lambda m: m.static(gap_pa=1e6), "unknown modulus"),
        (lambda m: m.static("gap"), "materials"),
        (lambda m: m.frequency_response([], None), "freq_hz"),
        (lambda m: m.frequency_response([10.0], gap_e_pa=np.array([1e6, 2e6])), "one design"),
    ],
)
def test_bad_input_names_the_parameter(lm, call, match):
    with pytest.raises(InvalidParameter, match=match):
        call(lm)


def test_geometry_is_the_calibrations(lm):
    import dataclasses

    assert lm.geometry == isj.Geometry()  # the shipped calibration's FE geometry is the default one
    cal = default_calibration()
    wider = dict(cal.fe_settings["geometry"], pedicle_x_m=70e-6)
    other = isj.LumpedModel(dataclasses.replace(cal, fe_settings=dict(cal.fe_settings, geometry=wider)))
    assert other.geometry.pedicle_x_m == 70e-6
    # a thicker pedicle bends less: β drops; α, the joint's, does not depend on the pedicle's section
    assert float(other.static().beta_rad) < float(lm.static().beta_rad)
    assert float(other.static().alpha_rad) == pytest.approx(float(lm.static().alpha_rad), rel=1e-14)
    bad = dataclasses.replace(cal, fe_settings=dict(cal.fe_settings, geometry={"pedicle_x_m": -1.0}))
    with pytest.raises(InvalidParameter, match="geometry"):
        isj.LumpedModel(bad)


def test_load_and_corrupt_file(tmp_path):
    path = tmp_path / "cal.json"
    path.write_text(default_calibration().to_json())
    loaded = isj.LumpedModel.load(path)
    assert np.array_equal(loaded.factors, isj.LumpedModel.default().factors)
    assert loaded.shear_factor == default_calibration().shear_factor
    path.write_text("{}")
    with pytest.raises(CorruptCalibration):
        isj.LumpedModel.load(path)


@pytest.mark.slow
def test_chain_response_is_isj_sweep_bit_for_bit(lm, tmp_path):
    out = tmp_path / "sweep"
    r = _cli(
        "sweep",
        "--fe-checks",
        "0",
        "--n",
        "30",
        "--fmin-hz",
        "50",
        "--capsule-e",
        "80e6",
        "--nu",
        "0.3",  # the calibration's: isj sweep refuses another
        "--out",
        str(out),
    )
    assert r.returncode == 0, r.stderr
    with np.load(out / "sweep.npz") as npz:
        freq, H = npz["freq_hz"], npz["response"]
    m = isj.Materials(capsule_e_pa=80e6, nu=0.3)
    got = lm.frequency_response(freq, m)
    assert got.shape == (30, 3, 1) and got.output_names == ("alpha_rad", "beta_rad", "incus_ux_m")
    assert np.array_equal(got.response[..., 0], H)
    assert got.input_amplitude == isj.DEFAULT_PRESSURE_PA


def test_chain_response_static_limit_and_batch(lm):
    m = isj.Materials(gap_e_pa=3e6)
    d = isj.Damping.uniform(loss_factor=0.1)
    r = lm.frequency_response([0.0, 1e3], m, damping=d)
    s = lm.static(m)
    # 0 Hz is the static solve: the calibrated α and β, over 1 + iη with one loss factor everywhere
    assert r["alpha_rad"][0] == pytest.approx(float(s.alpha_rad) / (1 + 0.1j), rel=1e-12)
    assert r["beta_rad"][0] == pytest.approx(float(s.beta_rad) / (1 + 0.1j), rel=1e-12)
    cal = default_calibration()
    moduli = {k: getattr(m, k) for k in MODULI}
    ref = chain_model(cal.factor_array(), cal.shear_factor, materials=m, damping=d, **moduli)
    assert np.array_equal(r.response[..., 0], chain_outputs(ref, [0.0, 1e3]))
    many = lm.chain(gap_e_pa=np.array([3e6, 30e6]), damping=d).freq_resp([1e3])
    assert many.shape == (2, 1, 3, 1)
    assert np.allclose(many[0, :, :, 0] * isj.DEFAULT_PRESSURE_PA, r.response[1:, :, 0], rtol=1e-12)
    f_nat = lm.natural_frequencies_hz(materials=m)
    assert f_nat.shape == (8,) and np.all(np.diff(f_nat) > 0)


def test_ear_response_is_the_ear_sweep_path(lm):
    ear_mat = EarMaterials(drum_e_pa=30e6)
    m = isj.Materials(pedicle_e_pa=8e9)
    freq = np.geomspace(100, 5000, 9)
    got = lm.ear(m, ear_materials=ear_mat).frequency_response(freq)
    designs = {k: getattr(m, k) for k in MODULI}
    ref = ear_model(default_calibration().factor_array(), ear_materials=ear_mat, **designs)
    assert np.array_equal(got.response[..., 0], ref._freq_resp(freq))  # what isj ear sweep writes
    assert got.output_names == ("umbo_m", "stapes_m", "alpha_rad", "beta_rad")
    assert got.output_units == ("m", "m", "rad", "rad")
    rigid = lm.ear(m, rigid_joint=True).frequency_response(freq)
    assert np.all(rigid["alpha_rad"] == 0) and np.all(rigid["beta_rad"] == 0)
    # a compliant joint lets the stapes lag the umbo: less piston per umbo motion than rigid
    ratio = abs(got["stapes_m"][0] / got["umbo_m"][0])
    assert ratio < abs(rigid["stapes_m"][0] / rigid["umbo_m"][0])


# ---- FrequencyResponse ----------------------------------------------------------------------


def _two_input_response():
    f = np.array([0.0, 10.0, 1000.0])
    h = np.arange(12).reshape(3, 2, 2) * (1 + 0.5j) - 3j
    return FrequencyResponse(f, h, ("a_m", "b_rad"), ("m", "rad"), ("p", "q"), ("Pa", "N"), 2.5)


def test_frequency_response_shapes_and_access():
    r = _two_input_response()
    assert r.shape == (3, 2, 2) and r["b_rad"].shape == (3, 2)
    one = FrequencyResponse([1.0, 2.0], np.array([[1j, 2.0], [-1.0, -2j]]), ("x_m", "y_m"), ("m", "m"))
    assert one.shape == (2, 2, 1) and one["y_m"].tolist() == [2.0, -2j]
    assert one.magnitude("y_m").tolist() == [2.0, 2.0]
    assert one.phase_deg("x_m").tolist() == [90.0, 180.0]
    assert one.phase_deg("y_m").tolist() == [0.0, -90.0]
    assert "x_m" in one and one.unit("x_m") == "m"
    with pytest.raises(KeyError, match="x_m, y_m"):
        one["z"]
    with pytest.raises(InvalidParameter, match="response"):
        FrequencyResponse([1.0], np.zeros((2, 1, 1)), ("x",), ("m",))
    with pytest.raises(InvalidParameter, match="freq_hz"):
        FrequencyResponse([-1.0], np.zeros((1, 1, 1)), ("x",), ("m",))
    with pytest.raises(InvalidParameter, match="distinct"):
        FrequencyResponse([1.0], np.zeros((1, 2, 1)), ("x", "x"), ("m", "m"))


def _ear_response():
    return isj.LumpedModel.default().ear().frequency_response([0, 1e3])


@pytest.mark.parametrize("make", [_two_input_response, _ear_response])
def test_frequency_response_csv_and_dict_round_trip(tmp_path, make):
    r = make()
    path = tmp_path / "r.csv"
    r.to_csv(path)
    assert [p.name for p in tmp_path.iterdir()] == ["r.csv"]  # atomic: no temporary file left
    lines = path.read_text().splitlines()
    assert lines[0].startswith("# units: freq_hz Hz; ")
    assert f"{r.output_names[0]} {r.output_units[0]}" in lines[0]
    back = FrequencyResponse.read_csv(path)
    for b in (back, FrequencyResponse.from_dict(json.loads(json.dumps(r.to_dict())))):
        assert np.array_equal(b.freq_hz, r.freq_hz) and np.array_equal(b.response, r.response)
        assert (b.output_names, b.output_units, b.input_names, b.input_units, b.input_amplitude) == (
            r.output_names,
            r.output_units,
            r.input_names,
            r.input_units,
            r.input_amplitude,
        )
    table = np.loadtxt(lines[3:], delimiter=",", ndmin=2)
    assert np.allclose(table[:, 3], np.abs(r.response[:, 0, 0]), rtol=1e-15)  # the _abs column


def test_plot_returns_artists():
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    r = isj.LumpedModel.default().frequency_response(np.geomspace(10, 1e4, 20))
    artists = r.plot()
    assert len(artists) == 6  # magnitude and phase per output
    assert isinstance(artists[0].figure, Figure)
    assert np.array_equal(artists[0].get_ydata(), np.abs(r["alpha_rad"]))
    assert np.allclose(artists[1].get_ydata(), np.degrees(np.unwrap(np.angle(r["alpha_rad"]))))
    ax = Figure().subplots()
    assert isinstance(ax, Axes)
    one = r.plot(ax, outputs=["beta_rad"])
    assert len(one) == 1 and one[0].axes is ax and ax.get_yscale() == "log"


@pytest.mark.slow
def test_library_plots_leave_the_backend_and_pyplot_alone(tmp_path):
    """A notebook's backend stays what it was and pyplot is never imported (checked in a fresh process)."""
    r = _python(
        f"""
        import sys, numpy as np, matplotlib
        import isj
        from isj.lumped.plots import bode, save_bode
        from isj.fem.convergence import plot_study
        f = np.geomspace(10, 1e4, 12)
        resp = isj.LumpedModel.default().frequency_response(f)
        resp.plot()
        bode(f, resp.response[:, :2, 0])
        save_bode({str(tmp_path / "b.png")!r}, f, resp.response[:, :2, 0])
        rows = [dict(n_tets=n, max_disp_m=1.0 + 1 / n, tip_mean_m=1.0, analytic_m=1.0) for n in (10, 100)]
        plot_study(rows, {str(tmp_path / "c.svg")!r})
        print("pyplot" if "matplotlib.pyplot" in sys.modules else "no pyplot", matplotlib.get_backend())
        """,
        MPLBACKEND="svg",  # a backend a user chose: it must survive
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["no", "pyplot", "svg"]
    assert (tmp_path / "b.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "c.svg").read_text().lstrip().startswith("<?xml")


# ---- FE results --------------------------------------------------------------------------------


@pytest.mark.slow
def test_fe_static_to_dict_keys_are_fem_solve_json(coarse_model):
    r = _cli("fem", "solve", "--json", "--resolution", "0.35", "--gap-e", "4e6")
    assert r.returncode == 0, r.stderr
    cli = json.loads(r.stdout)
    d = coarse_model.static(isj.Materials(gap_e_pa=4e6)).to_dict()
    # the CLI adds the run's facts, the joint variant and its load split (docs/model.md §2.12)
    split = {f"{r}_{q}" for r in ("capsule", "gap") for q in ("shear_share", "shear_n", "moment_share")}
    split |= {"total_shear_n", "total_moment_nm"}
    assert set(d) <= set(cli) and set(cli) - set(d) - split == {
        "n_tets",
        "n_dofs",
        "order",
        "resolution",
        "solver",
        "mesh_hash",
        "timings_s",
        "joint",
        "layer_shear_pa",
    }
    json.dumps(d, allow_nan=False)  # plain JSON
    assert d["alpha_rad"] == pytest.approx(cli["alpha_rad"], rel=1e-9)
    assert d["alpha_plus_beta_rad"] == d["alpha_rad"] + d["beta_rad"]
    assert set(d["strain_energy_j"]) == set(isj.REGIONS)
    assert sum(d["strain_energy_fraction"].values()) == pytest.approx(1.0, rel=1e-12)


@pytest.mark.slow
def test_fe_harmonic_response_is_harmonic_outputs(coarse_model):
    from isj.fem.dynamics import harmonic_outputs

    m = isj.Materials(capsule_e_pa=80e6)
    f = [0.0, 3000.0]
    d = isj.Damping.uniform(loss_factor=0.1)
    r = coarse_model.frequency_response(f, m, d)
    ref = harmonic_outputs(coarse_model, f, m, d)
    assert r.output_names == ("alpha_rad", "beta_rad", "incus_ux_m") and r.shape == (2, 3, 1)
    for k in r.output_names:
        assert np.allclose(r[k], ref[k], rtol=1e-10, atol=0)  # one solve each: Lanczos reductions only
    s = coarse_model.static(m)
    assert r["alpha_rad"][0] == pytest.approx(s.alpha_rad / (1 + 0.1j), rel=1e-8)  # 0 Hz: static / (1 + iη)
    lumped = isj.LumpedModel.default().frequency_response(f, m)
    assert lumped.output_names == r.output_names and lumped.output_units == r.output_units


@pytest.mark.slow
def test_fe_ear_response_and_static_to_dict():
    # its own joint model (the mesh is cached): the ear refactors the joint's matrices
    ear = isj.MiddleEarModel(joint=isj.PedicleJointModel(order=2, resolution=0.35))
    h = harmonic(ear, [200.0, 800.0])
    r = h.response()
    assert np.array_equal(r.response[..., 0], h.outputs()) and r.input_amplitude == 1.0
    lumped = isj.LumpedModel.default().ear().frequency_response([200.0, 800.0])
    assert r.output_names == lumped.output_names and r.output_units == lumped.output_units
    assert np.all(np.abs(lumped.magnitude() / r.magnitude() - 1) < 0.1)  # 3 % static, 10 % for α
    r2 = ear.frequency_response([200.0], pressure_pa=2.0)
    assert r2.input_amplitude == 2.0
    assert r2["umbo_m"][0] == pytest.approx(2 * r["umbo_m"][0], rel=1e-9)
    d = h.static.to_dict()
    json.dumps(d, allow_nan=False)
    assert {"umbo_m_per_pa", "footplate_piston_m_per_pa", "alpha_rad_per_pa", "beta_rad_per_pa"} <= set(d)
