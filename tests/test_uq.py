"""``isj uq`` and isj.studies.uq: Sobol' indices against exact values, reproducibility,
P(β/α > 1) and its interval against known probabilities, the JSON, one-line refusals."""

import json
import math

import numpy as np
import pytest
from isj.lumped.model import MODULI

from isj.cli import main
from isj.errors import ConfigError
from isj.studies.uq import (
    Distribution,
    UQConfig,
    compare_evaluators,
    default_distributions,
    lumped_evaluator,
    probability_interval,
    run_uq,
    sample_moduli,
    sobol_indices,
    uq_config_from_dict,
)

UNCERTAIN = MODULI[:5]  # pedicle, gap, capsule, plate, stapes (the incus is fixed by default)
#: Small counts: fast, still within the tolerances below.
SMALL = {"samples": 2_000, "sobol_samples": 64, "bootstrap": 10}


def _widths(cfg: UQConfig) -> dict[str, float]:
    """ln(high / low) of each log-uniform modulus: ln E is uniform with that width."""
    return {k: math.log(d.high_pa / d.low_pa) for k, d in cfg.distributions.items() if d.kind == "loguniform"}


def _unit(cfg: UQConfig, moduli, k: str) -> np.ndarray:
    """The uniform variable in [0, 1] behind a log-uniform modulus."""
    d = cfg.distributions[k]
    return np.log(moduli[k] / d.low_pa) / math.log(d.high_pa / d.low_pa)


def test_additive_model_indices_are_exact():
    """f = c + Σ a_i ln E_i with ln E_i uniform (log-uniform E_i) or normal (lognormal E_i):
    S1_i = ST_i = a_i² var(ln E_i) / Σ a_j² var(ln E_j), for α and for β (other coefficients)."""
    dists = default_distributions()
    dists["capsule_e_pa"] = Distribution.lognormal(100e6, sigma_ln=0.5, name="capsule_e_pa")
    cfg = UQConfig(dists, samples=1_000, sobol_samples=2**12, bootstrap=50, seed=3)
    var = {k: w**2 / 12 for k, w in _widths(cfg).items()} | {"capsule_e_pa": 0.25}
    a = dict(zip(UNCERTAIN, (1.0, 2.0, 0.5, 0.0, 1.5), strict=True))
    b = dict(zip(UNCERTAIN, (0.3, 0.0, 1.0, 2.0, 0.7), strict=True))

    def additive(moduli):
        la = sum(a[k] * np.log(moduli[k]) for k in UNCERTAIN)
        lb = sum(b[k] * np.log(moduli[k]) for k in UNCERTAIN)
        return 200.0 + la, 300.0 + lb  # positive α: the constant does not change any index

    got = sobol_indices(cfg, additive, outputs=("alpha_rad", "beta_rad"))
    for out, coef in (("alpha_rad", a), ("beta_rad", b)):
        total = sum(coef[k] ** 2 * var[k] for k in UNCERTAIN)
        for k in UNCERTAIN:
            exact = coef[k] ** 2 * var[k] / total
            assert got[out]["S1"][k] == pytest.approx(exact, abs=0.02), (out, k)
            assert got[out]["ST"][k] == pytest.approx(exact, abs=0.02), (out, k)
        # a modulus that does not enter has a total index of exactly zero
        zero = [k for k in UNCERTAIN if coef[k] == 0]
        assert all(got[out]["ST"][k] == 0 for k in zero)
        assert set(got[out]) == {"S1", "S1_conf", "ST", "ST_conf"}
        assert all(v >= 0 for v in got[out]["ST_conf"].values())


def test_ishigami_indices():
    """The Ishigami function (a = 7, b = 0.1) on [-π, π]³ through three log-uniform moduli: the
    exact S1 (0.3139, 0.4424, 0) and ST (0.5576, 0.4424, 0.2437) within the bootstrap intervals."""
    dists = default_distributions()
    for k in ("plate_e_pa", "stapes_e_pa"):
        dists[k] = Distribution.fixed(1e9, k)
    cfg = UQConfig(dists, samples=1_000, sobol_samples=2**13, bootstrap=100, seed=1)
    x1, x2, x3 = "pedicle_e_pa", "gap_e_pa", "capsule_e_pa"

    def ishigami(moduli):
        x = [-np.pi + 2 * np.pi * _unit(cfg, moduli, k) for k in (x1, x2, x3)]
        f = np.sin(x[0]) + 7 * np.sin(x[1]) ** 2 + 0.1 * x[2] ** 4 * np.sin(x[0])
        return f + 20.0, np.ones_like(f)

    got = sobol_indices(cfg, ishigami, outputs=("alpha_rad",))["alpha_rad"]
    assert set(got["ST"]) == {x1, x2, x3}  # fixed moduli are not inputs of the analysis
    exact_s1 = {x1: 0.3139, x2: 0.4424, x3: 0.0}
    exact_st = {x1: 0.5576, x2: 0.4424, x3: 0.2437}
    for k in (x1, x2, x3):
        assert abs(got["S1"][k] - exact_s1[k]) < max(2 * got["S1_conf"][k], 0.02), k
        assert abs(got["ST"][k] - exact_st[k]) < max(2 * got["ST_conf"][k], 0.02), k


def test_draws_are_reproducible_bit_for_bit():
    cfg = UQConfig.default(**SMALL, seed=7)
    one, two = sample_moduli(cfg), sample_moduli(cfg)
    assert all(np.array_equal(one[k], two[k]) for k in MODULI)
    other = sample_moduli(cfg, seed=8)
    assert not np.array_equal(one["gap_e_pa"], other["gap_e_pa"])
    assert np.all(one["incus_e_pa"] == 12e9)  # fixed: the default incus
    r1, r2 = run_uq(cfg), run_uq(cfg)
    d1, d2 = r1.to_dict(), r2.to_dict()
    d1.pop("time_s"), d2.pop("time_s")
    assert json.dumps(d1) == json.dumps(d2)


def test_draws_follow_their_distributions():
    dists = default_distributions()
    dists["gap_e_pa"] = Distribution.lognormal(8e6, factor=1.3, name="gap_e_pa")
    cfg = UQConfig(dists, samples=200_000, seed=0)
    m = sample_moduli(cfg)
    # log-uniform: every draw inside the range, ln E uniform (mean in the middle, var w²/12)
    lo, hi = cfg.distributions["pedicle_e_pa"].low_pa, cfg.distributions["pedicle_e_pa"].high_pa
    x = np.log(m["pedicle_e_pa"])
    assert lo <= m["pedicle_e_pa"].min() and m["pedicle_e_pa"].max() <= hi
    assert x.mean() == pytest.approx(0.5 * math.log(lo * hi), abs=0.01)
    assert x.var() == pytest.approx(math.log(hi / lo) ** 2 / 12, rel=0.01)
    # lognormal with a factor 1.3: median 8 MPa, σ of ln E = ln 1.3
    assert np.median(m["gap_e_pa"]) == pytest.approx(8e6, rel=0.005)
    assert np.log(m["gap_e_pa"]).std() == pytest.approx(math.log(1.3), rel=0.01)


def test_wilson_interval_exact_values():
    """Wilson score interval: k = 0 of n = 10 gives [0, z²/(n + z²)]; k = n/2 is symmetric."""
    z2 = 1.959963984540054**2
    lo, hi = probability_interval(0, 10)
    assert lo == pytest.approx(0, abs=1e-15) and hi == pytest.approx(z2 / (10 + z2), rel=1e-9)
    lo, hi = probability_interval(50, 100)
    half = math.sqrt(z2) / (1 + z2 / 100) * math.sqrt(0.25 / 100 + z2 / 4e4)
    assert (lo, hi) == pytest.approx((0.5 - half, 0.5 + half), rel=1e-9)


def _ratio_evaluator(threshold_pa: float):
    """β/α = E_gap / threshold: with gap log-uniform on [lo, hi], P(β/α > 1) = ln(hi/t) / ln(hi/lo)."""

    def evaluate(moduli):
        g = moduli["gap_e_pa"]
        return np.ones_like(g), g / threshold_pa

    return evaluate


def test_probability_and_its_interval_cover_a_known_p():
    cfg = UQConfig.default(samples=100_000, sobol_samples=64, bootstrap=10)
    d = cfg.distributions["gap_e_pa"]
    t = d.low_pa * (d.high_pa / d.low_pa) ** 0.15  # P = 0.85
    r = run_uq(cfg, _ratio_evaluator(t))
    lo, hi = r.p_beta_over_alpha_gt_1_ci
    assert lo < 0.85 < hi and hi - lo < 0.006
    assert r.p_beta_over_alpha_gt_1 == pytest.approx(0.85, abs=0.004)
    assert r.sobol["beta_over_alpha"]["ST"]["gap_e_pa"] == pytest.approx(1.0, abs=0.05)
    assert r.sobol["beta_over_alpha"]["ST"]["pedicle_e_pa"] == 0
    assert r.sobol["alpha_rad"]["ST"] == dict.fromkeys(UNCERTAIN, 0.0)  # α constant here
    # coverage: over 40 seeds of 2000 draws each, the 95 % interval holds p nearly every time
    covered = 0
    for seed in range(40):
        c = UQConfig.default(samples=2_000, sobol_samples=64, bootstrap=10, seed=seed)
        k = int(np.count_nonzero(_ratio_evaluator(t)(sample_moduli(c))[1] > 1))
        a, b = probability_interval(k, c.samples)
        covered += a < 0.85 < b
    assert covered >= 34  # binomial(40, 0.95): P(fewer than 34) < 1e-3


def test_lumped_model_structure_in_the_indices():
    """The lumped model's β has no capsule term (docs/lumped.md §3.4): its total index is exactly
    0; α's one pedicle term, the pedicle's face (§3.15), is small beside the joint's; β is driven
    by the pedicle and the plate."""
    r = run_uq(UQConfig.default(samples=20_000, sobol_samples=1024, bootstrap=20))
    assert r.sobol["beta_rad"]["ST"]["capsule_e_pa"] == 0
    assert 0 < r.sobol["alpha_rad"]["ST"]["pedicle_e_pa"] < 0.01
    assert [k for k, _ in r.top_total("beta_rad", 2)] == ["pedicle_e_pa", "plate_e_pa"]
    direct = lumped_evaluator()(sample_moduli(r.config))
    assert r.n_beta_over_alpha_gt_1 == int(np.count_nonzero(direct[1] / direct[0] > 1))
    assert r.n_outside_domain == 0  # log-uniform over the domain stays in it


def test_compare_evaluators():
    cfg = UQConfig.default(**SMALL)
    lumped = lumped_evaluator()

    def scaled(moduli):
        a, b = lumped(moduli)
        return 1.01 * a, b

    same = compare_evaluators(cfg, lumped, lumped)
    assert same["max_rel_diff_alpha_rad"] == 0 and same["first"] == same["second"]
    diff = compare_evaluators(cfg, lumped, scaled, where=lambda m: m["gap_e_pa"] > 1e7)
    assert 0 < diff["n"] < cfg.samples
    assert diff["max_rel_diff_alpha_rad"] == pytest.approx(0.01, rel=1e-9)
    assert diff["max_rel_diff_beta_over_alpha"] == pytest.approx(1 - 1 / 1.01, rel=1e-9)


def test_json_keys(capsys):
    assert main(["uq", "--json", "--samples", "2000", "--sobol-samples", "64", "--bootstrap", "10"]) == 0
    d = json.loads(capsys.readouterr().out)
    p, (lo, hi) = d["p_beta_over_alpha_gt_1"], d["p_beta_over_alpha_gt_1_ci"]
    assert 0 <= lo <= p <= hi <= 1 and d["ci_method"] == "wilson" and d["confidence"] == 0.95
    assert (d["samples"], d["sobol_samples"], d["seed"], d["bootstrap"]) == (2000, 64, 0, 10)
    assert d["sobol_evaluations"] == 64 * 7
    assert set(d["sobol"]) == {"alpha_rad", "beta_rad", "beta_over_alpha"}
    for out in d["sobol"].values():
        assert set(out) == {"S1", "S1_conf", "ST", "ST_conf"}
        assert all(set(v) == set(UNCERTAIN) for v in out.values())
    assert set(d["distributions"]) == set(MODULI)
    assert d["distributions"]["gap_e_pa"] == {"distribution": "loguniform", "low_pa": 1e6, "high_pa": 50e6}
    assert d["distributions"]["incus_e_pa"] == {"distribution": "fixed", "value_pa": 12e9}
    assert set(d["summary"]) == {"alpha_rad", "beta_rad", "alpha_plus_beta_rad", "beta_over_alpha"}


def test_config_file_and_out_folder(tmp_path, capsys):
    cfg = tmp_path / "uq.toml"
    cfg.write_text(
        "[uq]\nsamples = 3000\nsobol_samples = 64\nbootstrap = 10\nseed = 5\n"
        '[uq.gap_e_pa]\ndistribution = "lognormal"\nmedian_pa = 10e6\nfactor = 1.3\n'
        '[uq.stapes_e_pa]\ndistribution = "fixed"\nvalue_pa = 1e9\n'
    )
    out = tmp_path / "res"
    assert main(["uq", "--config", str(cfg), "--seed", "6", "--json", "--out", str(out)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["seed"] == 6 and d["samples"] == 3000  # the option wins over the file
    assert d["distributions"]["gap_e_pa"]["sigma_ln"] == pytest.approx(math.log(1.3))
    assert "stapes_e_pa" not in d["sobol"]["alpha_rad"]["ST"]
    assert sorted(p.name for p in out.iterdir()) == [
        "histograms.csv",
        "quantiles.csv",
        "sobol.csv",
        "uq.json",
        "uq.png",
    ]
    rec = json.loads((out / "uq.json").read_text())["results"]
    assert rec["p_beta_over_alpha_gt_1"] == d["p_beta_over_alpha_gt_1"]
    hist = rec["histograms"]["beta_over_alpha"]
    assert sum(hist["counts"]) == 3000 and len(hist["edges"]) == len(hist["counts"]) + 1
    q = (out / "quantiles.csv").read_text().splitlines()
    assert q[1] == "probability,alpha_rad,beta_rad,alpha_plus_beta_rad,beta_over_alpha"
    median = next(row for row in q if row.startswith("0.5,")).split(",")
    assert float(median[4]) == pytest.approx(d["summary"]["beta_over_alpha"]["quantiles"]["0.5"], rel=1e-8)


@pytest.mark.parametrize(
    ("toml", "names"),
    [
        ('[uq.gap_e_pa]\ndistribution = "beta"\n', "uq.gap_e_pa.distribution"),
        ('[uq.gap_e_pa]\ndistribution = "loguniform"\nlow_pa = 5e7\nhigh_pa = 1e6\n', "uq.gap_e_pa.high_pa"),
        ('[uq.gap_e_pa]\ndistribution = "loguniform"\nlow_pa = 0\nhigh_pa = 1e6\n', "uq.gap_e_pa.low_pa"),
        ('[uq.gap_e_pa]\ndistribution = "loguniform"\nlow_pa = 1e6\n', "uq.gap_e_pa.high_pa"),
        ('[uq.gap_e_pa]\ndistribution = "lognormal"\nmedian_pa = 1e7\nfactor = 0.9\n', "uq.gap_e_pa.factor"),
        ('[uq.gap_e_pa]\ndistribution = "lognormal"\nmedian_pa = 1e7\n', "sigma_ln"),
        (
            '[uq.gap_e_pa]\ndistribution = "lognormal"\nmedian_pa = 1e4\nsigma_ln = 2\n',
            "uq.gap_e_pa.sigma_ln",
        ),
        ('[uq.gap_e_pa]\ndistribution = "fixed"\nvalue_pa = "soft"\n', "uq.gap_e_pa.value_pa"),
        ('[uq.gap_e_pa]\ndistribution = "fixed"\nvalue = 1e6\n', "uq.gap_e_pa.value"),
        ('[uq.gap]\ndistribution = "fixed"\nvalue_pa = 1e6\n', "uq.gap"),
        ("[uq]\nsobol_samples = 1000\n", "uq.sobol_samples"),
        ("[uq]\nsamples = 10\n", "uq.samples"),
        ("[report]\n", "[uq]"),
        ("[uq\n", "not valid TOML"),
    ],
)
def test_bad_config_is_one_line_and_writes_nothing(tmp_path, capsys, toml, names):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(toml)
    out = tmp_path / "out"
    assert main(["uq", "--config", str(cfg), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("isj: error: ") and "\n" not in err and names in err, err
    assert not out.exists()


@pytest.mark.parametrize(
    ("argv", "names"),
    [
        (["--samples", "10"], "--samples = 10: must be an integer in [1000, 10000000]"),
        (["--sobol-samples", "100"], "--sobol-samples = 100: must be a power of 2"),
        (["--bootstrap", "1"], "--bootstrap = 1"),
        (["--seed", "-1"], "--seed = -1"),
        (["--config", "missing.toml"], "cannot read"),
        (["--sobol-samples", "262144", "--bootstrap", "100"], "uq.sobol_samples x uq.bootstrap"),
    ],
)
def test_bad_options_are_one_line(capsys, argv, names):
    assert main(["uq", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and names in err, err


def test_all_fixed_and_direct_construction_refused():
    with pytest.raises(ConfigError, match="at least one"):
        UQConfig({k: Distribution.fixed(1e9, k) for k in MODULI})
    with pytest.raises(ConfigError, match="uq.samples"):
        uq_config_from_dict({"samples": 1.5})
    with pytest.raises(ConfigError, match="every modulus"):
        UQConfig({"gap_e_pa": Distribution.loguniform(1e6, 1e7)})


def test_report_page():
    from isj.reports.uq import uq_figure

    r = run_uq(UQConfig.default(**SMALL))
    fig = uq_figure(r)
    assert len(fig.axes) == 6
    text = " ".join(t.get_text() for t in fig.texts)
    assert f"P(beta/alpha > 1) = {r.p_beta_over_alpha_gt_1:.4f}" in text
    fig.canvas.draw()  # an Agg canvas of its own, no pyplot


class _FakeSurrogate:
    """Stands in for isj.fem.rom's ReducedModel: the lumped model with α 1 % larger."""

    def __init__(self):
        from isj.design_space import DesignSpace

        self.space = DesignSpace()
        self.meta = {"mesh_hash": "fake"}
        self.calls = 0

    def evaluate(self, designs, pressure_pa):
        E = self.space.designs_from(designs)  # refuses a design outside the domain, like the real one
        self.calls += 1
        a, b = lumped_evaluator(pressure_pa=pressure_pa)(dict(zip(UNCERTAIN, E.T, strict=True)))
        return {"alpha_rad": 1.01 * a, "beta_rad": b}


@pytest.fixture()
def fake_surrogate(monkeypatch):
    import isj.fem.rom

    fake = _FakeSurrogate()
    monkeypatch.setattr(isj.fem.rom, "reduced_model", lambda **kw: fake)
    return fake


def test_surrogate_evaluator_and_comparison(fake_surrogate, capsys, tmp_path):
    argv = ["uq", "--json", "--samples", "4000", "--sobol-samples", "64", "--bootstrap", "10"]
    assert main([*argv, "--evaluator", "surrogate"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["evaluator"] == "surrogate" and fake_surrogate.calls == 2  # Monte Carlo and Sobol'
    assert main([*argv, "--compare-surrogate"]) == 0
    d2 = json.loads(capsys.readouterr().out)
    cmp = d2["surrogate_comparison"]
    assert d2["evaluator"] == "lumped" and cmp["n"] == 4000 and cmp["mesh_hash"] == "fake"
    assert cmp["max_rel_diff_alpha_rad"] == pytest.approx(0.01, rel=1e-9)
    assert cmp["max_rel_diff_beta_rad"] == pytest.approx(0, abs=1e-15)
    # the surrogate's P is that of the lumped model with alpha scaled by 1.01
    assert cmp["surrogate"]["p_beta_over_alpha_gt_1"] == d["p_beta_over_alpha_gt_1"]
    assert cmp["lumped"]["p_beta_over_alpha_gt_1"] == d2["p_beta_over_alpha_gt_1"]
    # a lognormal reaches outside the surrogate's domain: refused before anything is built
    cfg = tmp_path / "ln.toml"
    cfg.write_text('[uq.gap_e_pa]\ndistribution = "lognormal"\nmedian_pa = 1e7\nfactor = 1.3\n')
    fake_surrogate.calls = 0
    assert main(["uq", "--config", str(cfg), "--evaluator", "surrogate"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "uq.gap_e_pa is lognormal" in err and fake_surrogate.calls == 0
    # --compare-surrogate takes the lognormal draws inside the domain only
    assert main(["uq", "--config", str(cfg), *argv[1:], "--compare-surrogate"]) == 0
    cmp = json.loads(capsys.readouterr().out)["surrogate_comparison"]
    assert 3000 < cmp["n"] <= 4000


# ---- ΔH_V under uncertainty (the fast ear; docs/uq.md §11.10) --------------------------------------


class _FakeFastEar:
    """Stands in for isj.fem.ear.fast_ear.FastEar with a known ΔH_V: its magnitude depends on the
    gap alone, |ΔH_V| = (E_gap / G0)^(c f / 10 kHz), its phase on the pedicle alone,
    k ln(E_pedicle / P0) f / 10 kHz rad; the capsule, plate and stapes do not enter."""

    C, K, G0, P0 = 0.5, 0.2, 7e6, 2e9

    def __init__(self):
        from isj.design_space import DesignSpace

        self.space = DesignSpace()
        self.calls = 0

    def batch(self, freq_hz, designs, damping=None, **kw):
        E = self.space.check(designs)  # refuses a design outside the domain, like the real one
        self.calls += 1
        s = np.asarray(freq_hz)[None] / 1e4
        lg, lp = np.log(E[:, 1:2] / self.G0), np.log(E[:, 0:1] / self.P0)
        d = np.exp(self.C * s * lg + 1j * self.K * s * lp)
        return {"delta_h_v": d, "delta_db": 20 * np.log10(np.abs(d)), "delta_deg": np.degrees(np.angle(d))}


def _fake_db(f_hz, gap_pa):
    return 20 * _FakeFastEar.C * (f_hz / 1e4) * np.log(gap_pa / _FakeFastEar.G0) / math.log(10)


def test_transmission_grid_and_outputs():
    from isj.studies.uq import TRANSMISSION_FREQ_HZ, TRANSMISSION_OUTPUTS

    f = TRANSMISSION_FREQ_HZ
    assert f.size == 62 and f[0] == 100.0 and f[-1] == 10e3 and np.all(np.diff(f) > 0)
    assert {1000.0, 5000.0, 10000.0} <= set(f.tolist())
    assert TRANSMISSION_OUTPUTS[-1] == "max_abs_delta_h_v_db_to_10khz" and len(TRANSMISSION_OUTPUTS) == 7


def test_transmission_known_model_indices_probability_and_percentiles():
    """Against the fake ear's exact ΔH_V: each output's values, the Sobol' indices (the moduli that
    do not enter exactly 0, within their interval; the one that does 1), P(max |ΔH_V| > 1 dB) as
    the fraction counted directly with its standard error, and the percentiles of 20 000 draws
    within the Dvoretzky–Kiefer–Wolfowitz bound of the exact ones (ln E_gap uniform)."""
    from isj.studies.uq import TransmissionEvaluator, transmission_uq

    cfg = UQConfig.default(**SMALL, seed=4, transmission_samples=20_000, transmission_sobol_samples=256)
    ev = TransmissionEvaluator(_FakeFastEar())
    m = sample_moduli(cfg, 20_000)
    y = ev(m)
    assert np.allclose(y["delta_h_v_db_5khz"], _fake_db(5e3, m["gap_e_pa"]), rtol=0, atol=1e-12)
    phase = np.degrees(_FakeFastEar.K * 0.1 * np.log(m["pedicle_e_pa"] / _FakeFastEar.P0))
    assert np.allclose(y["delta_h_v_deg_1khz"], phase, rtol=0, atol=1e-10)
    assert np.allclose(y["max_abs_delta_h_v_db_to_10khz"], np.abs(_fake_db(1e4, m["gap_e_pa"])), atol=1e-12)
    t = transmission_uq(cfg, ev)
    # the first rows of the α/β draws
    assert np.array_equal(m["gap_e_pa"][:2_000], sample_moduli(cfg)["gap_e_pa"])
    k = int(np.count_nonzero(y["max_abs_delta_h_v_db_to_10khz"] > 1.0))
    assert 0 < k < 20_000 and t["n_abs_delta_h_v_gt_1db"] == k and t["p_abs_delta_h_v_gt_1db"] == k / 20_000
    p = k / 20_000
    assert t["p_abs_delta_h_v_gt_1db_se"] == pytest.approx(math.sqrt(p * (1 - p) / 20_000), rel=1e-12)
    lo, hi = t["p_abs_delta_h_v_gt_1db_ci"]
    assert lo < p < hi
    for out, driver in (("delta_h_v_db_1khz", "gap_e_pa"), ("delta_h_v_deg_10khz", "pedicle_e_pa")):
        ix = t["sobol"][out]
        assert ix["S1"][driver] == pytest.approx(1, abs=0.05) and ix["ST"][driver] == pytest.approx(
            1, abs=0.05
        )
        for name in set(UNCERTAIN) - {driver}:
            for key in ("S1", "ST"):
                assert abs(ix[key][name]) <= ix[f"{key}_conf"][name] + 1e-12, (out, name, key)
    # percentiles: ln E_gap uniform on [a, b], so the exact p-quantile of ΔH_V at 5 kHz is known
    d = cfg.distributions["gap_e_pa"]
    eps = math.sqrt(math.log(2 / 1e-6) / (2 * 20_000))  # P(sup |F_n - F| > eps) < 1e-6

    def exact(prob):
        return _fake_db(5e3, d.low_pa * (d.high_pa / d.low_pa) ** np.clip(prob, 0, 1))

    for prob, got in t["summary"]["delta_h_v_db_5khz"]["quantiles"].items():
        assert exact(float(prob) - eps) - 1e-12 <= got <= exact(float(prob) + eps) + 1e-12, prob


def test_transmission_refuses_what_the_fast_ear_does_not_hold():
    from isj.errors import InvalidParameter
    from isj.studies.uq import TransmissionEvaluator

    ev = TransmissionEvaluator(_FakeFastEar())
    dists = default_distributions()
    dists["gap_e_pa"] = Distribution.lognormal(8e6, factor=1.3, name="gap_e_pa")
    with pytest.raises(InvalidParameter, match="uq.gap_e_pa: lognormal"):
        ev.check(UQConfig(dists, **SMALL))
    dists = default_distributions()
    dists["incus_e_pa"] = Distribution.loguniform(5e9, 20e9, name="incus_e_pa")
    with pytest.raises(InvalidParameter, match="uq.incus_e_pa"):
        ev.check(UQConfig(dists, **SMALL))
    dists = default_distributions()
    dists["plate_e_pa"] = Distribution.loguniform(1e3, 1e9, name="plate_e_pa")
    with pytest.raises(InvalidParameter, match="outside the fast ear"):
        ev.check(UQConfig(dists, **SMALL))
    for bad in ({"transmission": "yes"}, {"transmission": 1}, {"transmission_samples": 10}):
        with pytest.raises(ConfigError, match="uq.transmission"):
            uq_config_from_dict(bad)
    with pytest.raises(ConfigError, match="power of 2"):
        uq_config_from_dict({"transmission_sobol_samples": 100})


@pytest.fixture()
def fake_fast_ear(monkeypatch):
    import isj._cli.uq

    fake = _FakeFastEar()
    monkeypatch.setattr(isj._cli.uq, "_fast_ear", lambda args: fake)  # no mesh, no build
    return fake


@pytest.mark.slow
def test_transmission_cli_json_csv_and_switch(fake_fast_ear, capsys, tmp_path):
    argv = ["uq", "--samples", "2000", "--sobol-samples", "64", "--bootstrap", "10"]
    targs = ["--transmission-samples", "3000", "--transmission-sobol-samples", "64"]
    assert main([*argv, "--json"]) == 0
    off = json.loads(capsys.readouterr().out)
    assert "transmission" not in off and fake_fast_ear.calls == 0  # off by default
    assert main([*argv, "--json", "--transmission", *targs]) == 0
    on = json.loads(capsys.readouterr().out)
    t = on.pop("transmission")
    off.pop("time_s"), on.pop("time_s")
    assert on == off  # the α/β results do not change
    assert t["samples"] == 3000 and t["sobol_evaluations"] == 64 * 7 and len(t["freq_hz"]) == 62
    assert set(t["summary"]) == set(t["sobol"]) == set(t["units"])
    assert set(t["summary"]["delta_h_v_db_1khz"]["quantiles"]) == set(
        off["summary"]["alpha_rad"]["quantiles"]
    )
    # [uq] transmission = true turns it on; --no-transmission wins over the file
    cfg = tmp_path / "uq.toml"
    cfg.write_text("[uq]\ntransmission = true\ntransmission_samples = 3000\n")
    out = tmp_path / "out"
    assert main([*argv, "--config", str(cfg), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "P(max |Delta H_V| to 10 kHz > 1 dB)" in text
    csv = (out / "transmission.csv").read_text().splitlines()
    assert csv[1] == "kind,output,modulus,probability,value,error"
    row = next(r for r in csv if r.startswith("probability,"))
    assert float(row.split(",")[4]) == pytest.approx(t["p_abs_delta_h_v_gt_1db"], rel=1e-8)  # same draws
    assert "transmission" in json.loads((out / "uq.json").read_text())["results"]
    calls = fake_fast_ear.calls
    assert main([*argv, "--config", str(cfg), "--json", "--no-transmission"]) == 0
    assert "transmission" not in json.loads(capsys.readouterr().out) and fake_fast_ear.calls == calls
    # a bad switch in the file: one line, exit 2, nothing built
    cfg.write_text('[uq]\ntransmission = "yes"\n')
    assert main([*argv, "--config", str(cfg), "--out", str(tmp_path / "new")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "uq.transmission" in err and not (tmp_path / "new").exists()
    # a lognormal with --transmission: refused before the fast ear is built
    cfg.write_text('[uq.gap_e_pa]\ndistribution = "lognormal"\nmedian_pa = 1e7\nfactor = 1.3\n')
    assert main([*argv, "--config", str(cfg), "--transmission"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "uq.gap_e_pa: lognormal" in err and fake_fast_ear.calls == calls


@pytest.mark.slow
def test_transmission_fixed_design_equals_the_fast_ear(coarse_fast_ear):
    """Every draw of one design gives the fast ear's single-design ΔH_V (isj ear sweep's summary,
    :func:`isj.responses.delta_columns`) at 1, 5, 10 kHz and its largest |ΔH_V| to 10 kHz;
    and a Monte Carlo draw's outputs equal that design's own single-design values."""
    from isj.fem.ear.fast_ear import fast_ear_sweep

    from isj.design import Materials
    from isj.studies.uq import TRANSMISSION_FREQ_HZ, TransmissionEvaluator

    ear = coarse_fast_ear  # build_fast_ear(MiddleEarModel(joint=coarse_model)), shared (tests/conftest.py)
    ev = TransmissionEvaluator(ear, block=7)  # blocks of 7: the blocking does not change a value
    base = Materials()
    one = fast_ear_sweep(TRANSMISSION_FREQ_HZ, base, ear=ear)["summary"]
    moduli = {k: np.full(20, getattr(base, k)) for k in MODULI}
    y = ev(moduli)
    single = ear.batch(TRANSMISSION_FREQ_HZ, base)["delta_db"][0]  # the fast ear, one design
    j = int(np.flatnonzero(TRANSMISSION_FREQ_HZ == 5e3)[0])
    assert np.all(np.abs(y["delta_h_v_db_5khz"] - single[j]) <= 1e-12)
    assert np.all(np.abs(y["max_abs_delta_h_v_db_to_10khz"] - np.abs(single).max()) <= 1e-12)
    for q in ("1", "5", "10"):
        ref = one["delta_h_v_at_hz"][f"{float(q) * 1000:g}"]
        assert np.ptp(y[f"delta_h_v_db_{q}khz"]) == 0 and np.ptp(y[f"delta_h_v_deg_{q}khz"]) == 0
        assert y[f"delta_h_v_db_{q}khz"][0] == pytest.approx(ref["db"], abs=1e-9)
        assert y[f"delta_h_v_deg_{q}khz"][0] == pytest.approx(ref["deg"], abs=1e-7)
    assert y["max_abs_delta_h_v_db_to_10khz"][0] == pytest.approx(
        one["max_abs_delta_h_v_db_to_10khz"], abs=1e-9
    )
    cfg = UQConfig.default(**SMALL, seed=2)
    m = sample_moduli(cfg, 5)
    y = ev(m)
    for i in range(5):
        mats = Materials(**{k: float(m[k][i]) for k in UNCERTAIN})
        s = fast_ear_sweep(TRANSMISSION_FREQ_HZ, mats, ear=ear)["summary"]
        assert y["delta_h_v_db_10khz"][i] == pytest.approx(s["delta_h_v_at_hz"]["10000"]["db"], abs=1e-9)
        assert y["max_abs_delta_h_v_db_to_10khz"][i] == pytest.approx(
            s["max_abs_delta_h_v_db_to_10khz"], abs=1e-9
        )


def test_report_page_carries_the_transmission_table():
    """With ΔH_V the page gains one text block (its figures those of the JSON); without it the page is
    as before (test_report_page)."""
    from isj.reports.uq import uq_figure

    from isj.studies.uq import TransmissionEvaluator

    cfg = UQConfig.default(**SMALL, transmission_samples=1_000, transmission_sobol_samples=64)
    r = run_uq(cfg, transmission=TransmissionEvaluator(_FakeFastEar()))
    fig = uq_figure(r)
    assert len(fig.axes) == 6
    text = " ".join(t.get_text() for t in fig.texts)
    t = r.transmission
    p, se = t["p_abs_delta_h_v_gt_1db"], t["p_abs_delta_h_v_gt_1db_se"]
    assert f"> 1 dB) = {p:.4f} +- {se:.4f}" in text
    assert f"{t['summary']['delta_h_v_db_5khz']['quantiles']['0.5']:+8.3f}" in text
    fig.canvas.draw()


@pytest.mark.slow
def test_report_uq_step_reads_no_design_key_but_the_pressure(tmp_path, monkeypatch):
    """The uq step's cache key holds only ``design.pressure_pa`` of [design] (reports/steps.py):
    every other [design] key changed at once leaves its result as it was, the pressure does not."""
    import isj.fem.batch
    import isj.fem.ear.fast_ear
    import isj.fem.ear.shared
    from isj.lumped.artifact import default_calibration
    from isj.reports.config import load_config
    from isj.reports.steps import Context
    from isj.reports.uq import uq_step

    # the fast ear of the report's ear, without FE: the step's own code is what is checked
    monkeypatch.setattr(
        isj.fem.ear.shared, "shared_ear", lambda settings, drum_mesh_size_m=None, rigid=False: None
    )
    monkeypatch.setattr(isj.fem.ear.fast_ear, "fast_ear", lambda *a, **kw: _FakeFastEar())
    case = tmp_path / "case.toml"
    counts = "samples = 1000\nsobol_samples = 64\nbootstrap = 10\n"
    case.write_text(f"[uq]\n{counts}transmission_samples = 1000\ntransmission_sobol_samples = 64\n")
    base = load_config(case)
    others = [k for k in base.design.CONFIG_KEYS if k != "pressure_pa"]
    assert len(others) >= 6 and "nu" in others
    changed = [f"design.{k}={getattr(base.design, k) * (0.9 if k == 'nu' else 1.5)!r}" for k in others]

    def result(config):
        return uq_step(Context(config, default_calibration(), tmp_path / "fe", progress=False))[0]

    reference = result(base)
    assert "transmission" in reference
    again = result(load_config(case, changed))
    assert json.dumps(again, sort_keys=True) == json.dumps(reference, sort_keys=True)
    pressure = [f"design.pressure_pa={base.design.pressure_pa * 2!r}"]
    assert result(load_config(case, pressure)) != reference
