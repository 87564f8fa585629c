"""Uncertainty and sensitivity: the moduli's uncertainty carried to α, β, α + β and β/α (docs/uq.md).

Each Young's modulus (Pa) has a :class:`Distribution` (:mod:`isj.studies.uq_inputs`):
log-uniform over a range (default: the calibrated domain of the lumped model, docs/lumped.md
§3.5, the thesis's plausible ranges §6.2.3–6.2.5), lognormal with a median and a spread, or
fixed. :func:`run_uq` then

- draws a Monte Carlo sample (``numpy.random.default_rng(seed)``, independent draws, so the
  binomial interval on P(β/α > 1) holds; bit for bit the same for the same seed),
- evaluates it with an *evaluator*, a callable mapping arrays of moduli to (α, β) in rad (default
  :func:`lumped_evaluator`, the calibrated lumped model; a surrogate plugs in the same way),
- gives P(β/α > 1) with a Wilson score interval, quantiles and histograms of the outputs, and
- Sobol' first-order and total indices with bootstrap intervals from SALib (Saltelli's scheme,
  ``SALib.sample.sobol`` / ``SALib.analyze.sobol``), on the unit cube mapped through each
  distribution's inverse CDF: uniform in log E for log-uniform inputs;
- optionally (``transmission=``, a :class:`TransmissionEvaluator` around the fast ear) the same
  for ΔH_V = H_V / H_V,rigid at 1, 5 and 10 kHz and its largest magnitude below 10 kHz, with
  P(|ΔH_V| > 1 dB) (:func:`transmission_uq`, docs/uq.md §11.10).

>>> cfg = UQConfig.default(samples=10_000, sobol_samples=256, bootstrap=50)
>>> r = run_uq(cfg)
>>> 0 < r.p_beta_over_alpha_gt_1 < 1
True
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from isj.design import DEFAULT_PRESSURE_PA
from isj.design_space import inside
from isj.errors import InvalidParameter
from isj.lumped.model import MODULI

from .uq_inputs import (
    BOOTSTRAP_RANGE,
    DEFAULT_BOOTSTRAP,
    DEFAULT_SAMPLES,
    DEFAULT_SOBOL_SAMPLES,
    KINDS,
    SAMPLES_RANGE,
    SEED_RANGE,
    SOBOL_SAMPLES_RANGE,
    Distribution,
    UQConfig,
    default_distributions,
    load_uq_config,
    uq_config_from_dict,
)

__all__ = [
    "BOOTSTRAP_RANGE",
    "CONFIDENCE",
    "DEFAULT_BOOTSTRAP",
    "DEFAULT_SAMPLES",
    "DEFAULT_SOBOL_SAMPLES",
    "KINDS",
    "OUTPUTS",
    "SAMPLES_RANGE",
    "SEED_RANGE",
    "SOBOL_SAMPLES_RANGE",
    "TRANSMISSION_FREQ_HZ",
    "TRANSMISSION_OUTPUTS",
    "TRANSMISSION_UNITS",
    "UNITS",
    "Distribution",
    "Evaluator",
    "TransmissionEvaluator",
    "UQConfig",
    "UQResult",
    "compare_evaluators",
    "default_distributions",
    "evaluate_outputs",
    "load_uq_config",
    "lumped_evaluator",
    "probability_interval",
    "run_uq",
    "sample_moduli",
    "sobol_indices",
    "summarise",
    "transmission_uq",
    "transmission_csv",
    "uq_config_from_dict",
]

#: Outputs of the Monte Carlo, SI (rad, rad, rad, dimensionless).
OUTPUTS = ("alpha_rad", "beta_rad", "alpha_plus_beta_rad", "beta_over_alpha")
UNITS = {"alpha_rad": "rad", "beta_rad": "rad", "alpha_plus_beta_rad": "rad", "beta_over_alpha": "1"}
#: Two-sided level of every interval.
CONFIDENCE = 0.95
#: Quantile probabilities reported for each output.
QUANTILES = (0.001, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.975, 0.99, 0.999)
HISTOGRAM_BINS = 60

#: (α, β) in rad from a mapping modulus name → array of moduli (Pa), all of one length.
Evaluator = Callable[[Mapping[str, np.ndarray]], tuple[np.ndarray, np.ndarray]]


def lumped_evaluator(model=None, pressure_pa: float = DEFAULT_PRESSURE_PA) -> Evaluator:
    """The calibrated lumped model (:class:`isj.lumped.api.LumpedModel`, default: shipped) at a
    pressure (Pa) as an :data:`Evaluator`."""
    from isj.lumped.api import LumpedModel

    model = model or LumpedModel.default()

    def evaluate(moduli):
        r = model.static(dict(moduli), pressure_pa=pressure_pa)
        return r.alpha_rad, r.beta_rad

    evaluate.name = "lumped"
    return evaluate


def sample_moduli(config: UQConfig, n: int | None = None, seed: int | None = None) -> dict[str, np.ndarray]:
    """``n`` independent draws (Pa) per modulus: ``default_rng(seed).random((n, d))``, one column
    per uncertain modulus in MODULI order, through its inverse CDF; fixed moduli repeated."""
    n = config.samples if n is None else n
    u = np.random.default_rng(config.seed if seed is None else seed).random((n, len(config.uncertain)))
    cols = dict(zip(config.uncertain, u.T, strict=True))
    return {k: config.distributions[k].ppf(cols.get(k, np.zeros(n))) for k in MODULI}


def evaluate_outputs(evaluator: Evaluator, moduli: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """α, β, α + β (rad) and β/α from ``evaluator``; refuses results that are not finite or α ≤ 0."""
    n = len(next(iter(moduli.values())))
    a, b = (np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in evaluator(moduli))
    bad = ~(np.isfinite(a) & np.isfinite(b) & (a > 0))
    if bad.any():
        i = int(np.argmax(bad))
        raise InvalidParameter(
            f"evaluator: alpha = {a[i]!r}, beta = {b[i]!r} rad at design {i} (need finite, alpha > 0); "
            f"{int(bad.sum())} of {n} designs"
        )
    return {"alpha_rad": a, "beta_rad": b, "alpha_plus_beta_rad": a + b, "beta_over_alpha": b / a}


def probability_interval(k: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion k/n at ``confidence`` (two-sided)."""
    from scipy.stats import binomtest

    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


def summarise(outputs: Mapping[str, np.ndarray]) -> tuple[dict, dict]:
    """(summary, histograms): per output mean, std, min, max and :data:`QUANTILES`; and
    (bin edges, counts) over [min, max], log-spaced for positive outputs."""
    summary, hist = {}, {}
    for k, y in outputs.items():
        q = np.quantile(y, QUANTILES)
        summary[k] = {
            "mean": float(y.mean()),
            "std": float(y.std(ddof=1)),
            "min": float(y.min()),
            "max": float(y.max()),
            "quantiles": {f"{p:g}": float(v) for p, v in zip(QUANTILES, q, strict=True)},
        }
        lo, hi = float(y.min()), float(y.max())
        if hi <= lo:
            hi = lo + max(abs(lo), 1e-300) * 1e-9
        edges = (
            np.geomspace(lo, hi, HISTOGRAM_BINS + 1) if lo > 0 else np.linspace(lo, hi, HISTOGRAM_BINS + 1)
        )
        edges[0], edges[-1] = lo, hi
        hist[k] = (edges, np.histogram(y, edges)[0])
    return summary, hist


def sobol_indices(
    config: UQConfig,
    evaluator: Evaluator,
    outputs=("alpha_rad", "beta_rad", "beta_over_alpha"),
    confidence: float = CONFIDENCE,
    sobol_samples: int | None = None,
    evaluate=None,
) -> dict:
    """Sobol' first-order and total indices with bootstrap half-widths, by SALib.

    Saltelli's scheme (``SALib.sample.sobol.sample``, scrambled, seeded, no second order) on the
    unit cube of the uncertain moduli, mapped through each :meth:`Distribution.ppf`;
    ``SALib.analyze.sobol.analyze`` with ``config.bootstrap`` resamples at ``confidence``.
    ``sobol_samples`` (default ``config.sobol_samples``) is the base sample count N;
    ``evaluate(evaluator, moduli)`` → output name → array (default :func:`evaluate_outputs`).

    Returns
    -------
    dict : output → {"S1", "S1_conf", "ST", "ST_conf"} → modulus → value (``_conf``: the half-width
        of SALib's normal bootstrap interval); all 0 for an output that does not vary
    """
    from SALib.analyze import sobol as analyze
    from SALib.sample import sobol as sample

    names = list(config.uncertain)
    problem = {"num_vars": len(names), "names": names, "bounds": [[0.0, 1.0]] * len(names)}
    base = config.sobol_samples if sobol_samples is None else sobol_samples
    u = sample.sample(problem, base, calc_second_order=False, scramble=True, seed=config.seed)
    n = u.shape[0]
    cols = dict(zip(names, u.T, strict=True))
    moduli = {k: config.distributions[k].ppf(cols.get(k, np.zeros(n))) for k in MODULI}
    y = (evaluate or evaluate_outputs)(evaluator, moduli)
    out = {}
    for k in outputs:
        if np.ptp(y[k]) == 0:  # a constant output depends on no modulus: every index 0
            out[k] = {s: dict.fromkeys(names, 0.0) for s in ("S1", "S1_conf", "ST", "ST_conf")}
            continue
        r = analyze.analyze(
            problem,
            y[k],
            calc_second_order=False,
            num_resamples=config.bootstrap,
            conf_level=confidence,
            # SALib's analyze takes seed 0 for no seed (``if seed:``) and would then bootstrap from
            # the global generator: seed + 1 keeps the intervals the same from run to run
            seed=config.seed + 1,
        )
        out[k] = {
            s: {m: float(v) for m, v in zip(names, r[s], strict=True)}
            for s in ("S1", "S1_conf", "ST", "ST_conf")
        }
    return out


@dataclass
class UQResult:
    """What :func:`run_uq` found (SI); :meth:`to_dict` is ``isj uq --json``."""

    config: UQConfig
    p_beta_over_alpha_gt_1: float
    p_beta_over_alpha_gt_1_ci: tuple[float, float]
    n_beta_over_alpha_gt_1: int
    summary: dict
    histograms: dict
    sobol: dict
    evaluator: str
    pressure_pa: float
    n_outside_domain: int | None
    time_s: dict
    confidence: float = CONFIDENCE
    outputs: dict = field(default_factory=dict, repr=False)  # the Monte Carlo arrays
    transmission: dict | None = None  # :func:`transmission_uq`, when asked for

    def top_total(self, output: str, k: int = 3) -> list[tuple[str, float]]:
        """The ``k`` largest total indices of ``output``, (modulus, ST), largest first."""
        st = self.sobol[output]["ST"]
        return sorted(st.items(), key=lambda kv: -kv[1])[:k]

    def histogram_dict(self) -> dict:
        """Output → {"edges": bin edges (the output's unit), "counts": draws per bin}."""
        return {k: {"edges": e.tolist(), "counts": c.tolist()} for k, (e, c) in self.histograms.items()}

    def to_dict(self) -> dict:
        """The keys of ``isj uq --json`` (SI; distributions, counts, seed, indices, summary)."""
        c = self.config
        return {
            "p_beta_over_alpha_gt_1": self.p_beta_over_alpha_gt_1,
            "p_beta_over_alpha_gt_1_ci": list(self.p_beta_over_alpha_gt_1_ci),
            "ci_method": "wilson",
            "confidence": self.confidence,
            "n_beta_over_alpha_gt_1": self.n_beta_over_alpha_gt_1,
            "samples": c.samples,
            "seed": c.seed,
            "sobol_samples": c.sobol_samples,
            "sobol_evaluations": c.sobol_samples * (len(c.uncertain) + 2),
            "bootstrap": c.bootstrap,
            "distributions": {k: c.distributions[k].to_dict() for k in MODULI},
            "evaluator": self.evaluator,
            "pressure_pa": self.pressure_pa,
            "n_outside_domain": self.n_outside_domain,
            "summary": self.summary,
            "sobol": self.sobol,
            "time_s": self.time_s,
        } | ({} if self.transmission is None else {"transmission": self.transmission})


def run_uq(
    config: UQConfig | None = None,
    evaluator: Evaluator | None = None,
    *,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    domain=None,
    confidence: float = CONFIDENCE,
    transmission: TransmissionEvaluator | None = None,
) -> UQResult:
    """Monte Carlo, P(β/α > 1) and Sobol' indices of α, β, α + β and β/α (and of ΔH_V).

    Parameters
    ----------
    config : distributions and counts (default :meth:`UQConfig.default`)
    evaluator : moduli (Pa) → (α, β) in rad (default :func:`lumped_evaluator` at ``pressure_pa``)
    pressure_pa : the default evaluator's pressure (Pa); β/α does not depend on it
    domain : modulus → (low, high) Pa, for counting draws outside it (default: the shipped
        calibration's when the evaluator is the default)
    confidence : of every interval
    transmission : a :class:`TransmissionEvaluator` (the fast ear): also ΔH_V under the same
        distributions (:func:`transmission_uq`, in ``UQResult.transmission``); the α/β results
        do not change
    """
    t0 = time.perf_counter()
    config = config or UQConfig.default()
    if evaluator is None:
        evaluator = lumped_evaluator(pressure_pa=pressure_pa)
        if domain is None:
            from isj.lumped.artifact import default_calibration

            domain = default_calibration().domain
    moduli = sample_moduli(config)
    y = evaluate_outputs(evaluator, moduli)
    outside = None
    if domain is not None:
        mask = np.zeros(config.samples, dtype=bool)
        for k, (lo, hi) in domain.items():
            mask |= ~inside(moduli[k], lo, hi)
        outside = int(mask.sum())
    del moduli
    k = int(np.count_nonzero(y["beta_over_alpha"] > 1))
    summary, hist = summarise(y)
    t1 = time.perf_counter()
    sobol = sobol_indices(config, evaluator, confidence=confidence)
    t2 = time.perf_counter()
    times = {"monte_carlo": t1 - t0, "sobol": t2 - t1}
    trans = None
    if transmission is not None:
        trans = transmission_uq(config, transmission, confidence)
        times["transmission"] = trans["time_s"]["total"]
    times["total"] = time.perf_counter() - t0
    return UQResult(
        config,
        k / config.samples,
        probability_interval(k, config.samples, confidence),
        k,
        summary,
        hist,
        sobol,
        getattr(evaluator, "name", getattr(evaluator, "__name__", "custom")),
        float(pressure_pa),
        outside,
        times,
        confidence,
        y,
        trans,
    )


# ---- ΔH_V under the moduli's uncertainty (the fast ear, docs/uq.md §11.10) -------------------------

#: The frequency grid of the ΔH_V outputs (Hz): 60 log-spaced points 100 Hz–10 kHz and the
#: quoted frequencies 1, 5 and 10 kHz, sorted.
TRANSMISSION_QUOTE_HZ = (1000.0, 5000.0, 10000.0)
TRANSMISSION_FREQ_HZ = np.unique(np.concatenate([np.geomspace(100.0, 10e3, 60), TRANSMISSION_QUOTE_HZ]))
#: ΔH_V outputs: dB and degrees at each quoted frequency, and the largest |ΔH_V| (dB) on the grid.
TRANSMISSION_OUTPUTS = (
    *(f"delta_h_v_{u}_{q / 1000:g}khz" for q in TRANSMISSION_QUOTE_HZ for u in ("db", "deg")),
    "max_abs_delta_h_v_db_to_10khz",
)
TRANSMISSION_UNITS = {k: ("deg" if "_deg_" in k else "dB") for k in TRANSMISSION_OUTPUTS}
#: The threshold of P(|ΔH_V| > 1 dB) (dB), on the largest |ΔH_V| below 10 kHz.
DELTA_H_V_THRESHOLD_DB = 1.0


class TransmissionEvaluator:
    """Moduli (Pa) → the ΔH_V outputs (:data:`TRANSMISSION_OUTPUTS`) through a fast ear.

    Parameters
    ----------
    ear : :class:`isj.fem.ear.fast_ear.FastEar`; every draw must lie in its calibrated domain
        (``ear.space``) and the incus must be fixed at ``ear.space.incus_e_pa``
    damping : :class:`isj.damping.Damping`, a preset name or None (published)
    cavities : "open" or "intact", or None (the fast ear's default)
    freq_hz : the grid (default :data:`TRANSMISSION_FREQ_HZ`); must hold the quoted frequencies
    block : designs per call of ``ear.batch`` (memory)
    """

    name = "fast_ear"

    def __init__(self, ear, damping=None, cavities=None, freq_hz=None, block: int = 4096):
        self.ear, self.damping, self.cavities, self.block = ear, damping, cavities, int(block)
        self.freq_hz = TRANSMISSION_FREQ_HZ if freq_hz is None else np.asarray(freq_hz, dtype=float)
        self._quote = [int(np.flatnonzero(self.freq_hz == q)[0]) for q in TRANSMISSION_QUOTE_HZ]
        self._low = self.freq_hz <= 10e3

    def check(self, config: UQConfig) -> None:
        """Refuse, before any draw, distributions the fast ear does not hold: an uncertain incus, an
        incus other than the fast ear's, or a range (lognormal: unbounded) outside its domain."""
        from isj.design_space import RANGED

        space = self.ear.space
        d = config.distributions["incus_e_pa"]
        if d.kind != "fixed" or not np.isclose(d.value_pa, space.incus_e_pa, rtol=1e-12, atol=0):
            raise InvalidParameter(
                f"uq.incus_e_pa: the transmission (fast ear) needs it fixed at {space.incus_e_pa:g} Pa"
            )
        for k in RANGED:
            d, (lo, hi) = config.distributions[k], getattr(space, k)
            if d.kind == "lognormal":
                raise InvalidParameter(
                    f"uq.{k}: lognormal (unbounded); the transmission (fast ear) holds on "
                    f"[{lo:g}, {hi:g}] Pa only"
                )
            a, b = (d.low_pa, d.high_pa) if d.kind == "loguniform" else (d.value_pa, d.value_pa)
            if not (inside(a, lo, hi) and inside(b, lo, hi)):
                raise InvalidParameter(
                    f"uq.{k}: spans {a:g}..{b:g} Pa, outside the fast ear's [{lo:g}, {hi:g}] Pa"
                )

    def __call__(self, moduli: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        from isj.design_space import RANGED

        designs = np.column_stack([np.asarray(moduli[k], dtype=float) for k in RANGED])
        kw = {} if self.cavities is None else {"cavities": self.cavities}
        db = np.empty((designs.shape[0], self.freq_hz.size))
        deg = np.empty_like(db)
        for i in range(0, designs.shape[0], self.block):
            r = self.ear.batch(self.freq_hz, designs[i : i + self.block], self.damping, **kw)
            db[i : i + self.block] = r["delta_db"]
            deg[i : i + self.block] = np.degrees(np.unwrap(np.angle(r["delta_h_v"]), axis=1))
        out = {}
        for q, j in zip(TRANSMISSION_QUOTE_HZ, self._quote, strict=True):
            out[f"delta_h_v_db_{q / 1000:g}khz"] = db[:, j]
            out[f"delta_h_v_deg_{q / 1000:g}khz"] = deg[:, j]
        out["max_abs_delta_h_v_db_to_10khz"] = np.abs(db[:, self._low]).max(axis=1)
        bad = ~np.all([np.isfinite(v) for v in out.values()], axis=0)
        if bad.any():
            raise InvalidParameter(f"fast ear: ΔH_V not finite at design {int(np.argmax(bad))}")
        return out


def transmission_uq(
    config: UQConfig, evaluator: TransmissionEvaluator, confidence: float = CONFIDENCE
) -> dict:
    """ΔH_V under the moduli's distributions: percentiles, P(|ΔH_V| > 1 dB), Sobol' indices.

    The Monte Carlo takes the first ``config.transmission_samples`` draws of :func:`sample_moduli`
    (the same seed: the first rows of the α/β draws); the Sobol' indices reuse
    :func:`sobol_indices` with ``config.transmission_sobol_samples`` base samples.

    Returns
    -------
    dict (JSON-able): ``freq_hz`` (the grid), ``quote_hz``, ``units``, ``samples``,
    ``sobol_samples``, ``sobol_evaluations``, ``summary`` (per output as
    :func:`summarise`: the same :data:`QUANTILES`), ``p_abs_delta_h_v_gt_1db`` with its Monte
    Carlo standard error ``p_abs_delta_h_v_gt_1db_se`` = √(p(1 − p)/n) and Wilson interval,
    ``n_abs_delta_h_v_gt_1db``, ``sobol`` (output → S1, S1_conf, ST, ST_conf → modulus) and
    ``time_s``
    """
    t0 = time.perf_counter()
    evaluator.check(config)
    n = config.transmission_samples
    y = evaluator(sample_moduli(config, n))
    summary, _ = summarise(y)
    k = int(np.count_nonzero(y["max_abs_delta_h_v_db_to_10khz"] > DELTA_H_V_THRESHOLD_DB))
    p = k / n
    t1 = time.perf_counter()
    sobol = sobol_indices(
        config,
        evaluator,
        outputs=TRANSMISSION_OUTPUTS,
        confidence=confidence,
        sobol_samples=config.transmission_sobol_samples,
        evaluate=lambda ev, m: ev(m),
    )
    t2 = time.perf_counter()
    return {
        "evaluator": evaluator.name,
        "freq_hz": [float(f) for f in evaluator.freq_hz],
        "quote_hz": list(TRANSMISSION_QUOTE_HZ),
        "units": dict(TRANSMISSION_UNITS),
        "samples": n,
        "sobol_samples": config.transmission_sobol_samples,
        "sobol_evaluations": config.transmission_sobol_samples * (len(config.uncertain) + 2),
        "threshold_db": DELTA_H_V_THRESHOLD_DB,
        "p_abs_delta_h_v_gt_1db": p,
        "p_abs_delta_h_v_gt_1db_se": float(np.sqrt(p * (1 - p) / n)),
        "p_abs_delta_h_v_gt_1db_ci": list(probability_interval(k, n, confidence)),
        "n_abs_delta_h_v_gt_1db": k,
        "summary": summary,
        "sobol": sobol,
        "time_s": {"monte_carlo": t1 - t0, "sobol": t2 - t1, "total": t2 - t0},
    }


def transmission_csv(t: dict) -> str:
    """``transmission.csv``: per ΔH_V output its quantiles, mean and std, then P(|ΔH_V| > 1 dB)
    with its standard error, then the Sobol' indices (one table, ``kind`` column)."""
    head = (
        f"# Delta H_V = H_V / H_V(rigid connection) through the fast ear; {t['samples']} draws; "
        f"grid {len(t['freq_hz'])} frequencies {t['freq_hz'][0]:g}..{t['freq_hz'][-1]:g} Hz; units: "
        + ", ".join(f"{k} {u}" for k, u in t["units"].items())
        + "\n"
    )
    rows = []
    for k, s in t["summary"].items():
        rows += [["quantile", k, "", f"{q:g}", f"{s['quantiles'][f'{q:g}']:.9g}", ""] for q in QUANTILES]
        rows += [["mean", k, "", "", f"{s['mean']:.9g}", ""], ["std", k, "", "", f"{s['std']:.9g}", ""]]
    rows.append(
        [
            "probability",
            "max_abs_delta_h_v_db_to_10khz",
            "",
            f"> {t['threshold_db']:g} dB",
            f"{t['p_abs_delta_h_v_gt_1db']:.9g}",
            f"{t['p_abs_delta_h_v_gt_1db_se']:.3g}",
        ]
    )
    for k, ix in t["sobol"].items():
        for key in ("S1", "ST"):
            rows += [[key, k, m, "", f"{ix[key][m]:.6g}", f"{ix[key + '_conf'][m]:.3g}"] for m in ix[key]]
    body = "".join(",".join(map(str, r)) + "\n" for r in rows)
    return head + "kind,output,modulus,probability,value,error\n" + body


def compare_evaluators(
    config: UQConfig, first: Evaluator, second: Evaluator, where=None, names=("first", "second")
) -> dict:
    """The same Monte Carlo draws through two evaluators (e.g. the lumped model and a surrogate).

    Parameters
    ----------
    config : the draws (``config.samples``, ``config.seed``), as in :func:`run_uq`
    first, second : evaluators; relative differences are second / first − 1
    where : optional callable moduli → boolean mask, the draws to compare (e.g. those outside the
        lumped model's 3 % region, or inside a surrogate's domain); default all
    names : the keys of the two evaluators in the result

    Returns
    -------
    dict : ``n`` (draws compared), per name P(β/α > 1) with its Wilson interval over those draws,
        ``max_rel_diff_*`` and ``rms_rel_diff_*`` of α, β and β/α, and ``n_disagree``: draws on
        which the two disagree about β/α > 1
    """
    moduli = sample_moduli(config)
    if where is not None:
        mask = np.asarray(where(moduli), dtype=bool)
        moduli = {k: v[mask] for k, v in moduli.items()}
    n = len(moduli[MODULI[0]])
    if n == 0:
        return {"n": 0}
    ya, yb = evaluate_outputs(first, moduli), evaluate_outputs(second, moduli)
    out = {"n": n}
    for tag, y in zip(names, (ya, yb), strict=True):
        k = int(np.count_nonzero(y["beta_over_alpha"] > 1))
        out[tag] = {
            "p_beta_over_alpha_gt_1": k / n,
            "p_beta_over_alpha_gt_1_ci": list(probability_interval(k, n)),
        }
    for key in ("alpha_rad", "beta_rad", "beta_over_alpha"):
        d = yb[key] / ya[key] - 1
        out[f"max_rel_diff_{key}"] = float(np.max(np.abs(d)))
        out[f"rms_rel_diff_{key}"] = float(np.sqrt(np.mean(d**2)))
    out["n_disagree"] = int(np.count_nonzero((ya["beta_over_alpha"] > 1) != (yb["beta_over_alpha"] > 1)))
    return out
