"""The uncertainty page: histograms of α, β and β/α, Sobol' bars with intervals, P(β/α > 1).

Draws what :func:`isj.studies.uq.run_uq` found; :func:`uq_step` is the report's step that
runs it on the report's lumped model. Two ways in:

- :func:`uq_page` ``(fig, uq, histograms)`` with the JSON of ``isj uq`` (``UQResult.to_dict()``)
  and ``UQResult.histogram_dict()``, for the report's pipeline (a page from
  :func:`reports.layout.new_page`);
- :func:`uq_figure` ``(result)``: a new A4 :class:`matplotlib.figure.Figure` (Agg canvas, no
  pyplot) with that page on it, for ``isj uq --out`` and for Python.
"""

from __future__ import annotations

import numpy as np

from .figures import _log_axes
from .layout import text_block, wrap

#: Histogram panels: output, axis label, scale.
_HISTS = (
    ("alpha_rad", "alpha (urad)", 1e6),
    ("beta_rad", "beta (urad)", 1e6),
    ("beta_over_alpha", "beta / alpha", 1.0),
)
#: Sobol' panels: output and title.
_SOBOL = (("alpha_rad", "alpha"), ("beta_rad", "beta"), ("beta_over_alpha", "beta / alpha"))


def _short(name: str) -> str:
    return name.removesuffix("_e_pa")


def histogram_panel(ax, edges, counts, label: str, scale: float = 1.0, mark=None):
    """One output's histogram (density per log-decade for positive edges, log x axis)."""
    e = np.asarray(edges, dtype=float) * scale
    c = np.asarray(counts, dtype=float)
    log = e[0] > 0
    width = np.diff(np.log10(e)) if log else np.diff(e)
    artists = ax.stairs(c / c.sum() / width, e, fill=True, color="#9ecae1", edgecolor="#3182bd")
    if log:
        _log_axes(ax, "x")
    if mark is not None:
        ax.axvline(mark, color="k", ls="--", lw=0.9)
    ax.set_xlabel(label, fontsize=8)
    ax.set_ylabel("probability per decade" if log else "probability density", fontsize=7)
    ax.tick_params(labelsize=7)
    return artists


def sobol_panel(ax, indices: dict, title: str):
    """First-order (S1) and total (ST) indices per modulus, bars with their bootstrap half-widths."""
    names = list(indices["ST"])
    x = np.arange(len(names))
    w = 0.38
    artists = []
    for dx, key, colour in ((-w / 2, "S1", "#3182bd"), (w / 2, "ST", "#e6550d")):
        v = np.array([indices[key][n] for n in names])
        err = np.array([indices[f"{key}_conf"][n] for n in names])
        artists.append(ax.bar(x + dx, v, w, yerr=err, capsize=2, color=colour, label=key))
    ax.set_xticks(x, [_short(n) for n in names], fontsize=7, rotation=30)
    ax.set_ylim(0, max(1.0, max(indices["ST"].values()) * 1.1))
    ax.set_title(title, fontsize=9)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=6, frameon=False)
    ax.grid(True, axis="y", alpha=0.3)
    return artists


def _distribution_text(d: dict) -> str:
    if d["distribution"] == "loguniform":
        return f"log-uniform {d['low_pa']:.3g}..{d['high_pa']:.3g} Pa"
    if d["distribution"] == "lognormal":
        return f"lognormal median {d['median_pa']:.3g} Pa, sigma(ln E) {d['sigma_ln']:.3g}"
    return f"fixed {d['value_pa']:.3g} Pa"


def uq_page(fig, uq: dict, histograms: dict):
    """Draw the uncertainty page on ``fig`` (an A4 figure).

    Parameters
    ----------
    fig : matplotlib Figure
    uq : ``UQResult.to_dict()`` (the JSON of ``isj uq``)
    histograms : ``UQResult.histogram_dict()``: output → {"edges", "counts"}
    """
    p, (lo, hi) = uq["p_beta_over_alpha_gt_1"], uq["p_beta_over_alpha_gt_1_ci"]
    for i, (key, label, scale) in enumerate(_HISTS):
        ax = fig.add_axes([0.08 + 0.31 * i, 0.70, 0.25, 0.2])
        h = histograms[key]
        histogram_panel(
            ax, h["edges"], h["counts"], label, scale, mark=1.0 if key == "beta_over_alpha" else None
        )
        if key == "beta_over_alpha":
            ax.set_title(f"P(beta/alpha > 1) = {p:.4f}", fontsize=8)
    for i, (key, title) in enumerate(_SOBOL):
        sobol_panel(
            fig.add_axes([0.08 + 0.31 * i, 0.40, 0.25, 0.2]), uq["sobol"][key], f"Sobol' indices: {title}"
        )
    level = 100 * uq["confidence"]
    lines = [
        f"P(beta/alpha > 1) = {p:.4f}, {level:g} % {uq['ci_method'].capitalize()} interval "
        f"[{lo:.4f}, {hi:.4f}] ({uq['n_beta_over_alpha_gt_1']} of {uq['samples']} draws; "
        f"evaluator: {uq['evaluator']}; seed {uq['seed']}).",
        f"Sobol' indices: SALib, Saltelli scheme, {uq['sobol_samples']} base samples "
        f"({uq['sobol_evaluations']} model runs), {uq['bootstrap']} bootstrap resamples; error bars: "
        f"{level:g} % half-widths.",
        "",
        "Distributions:",
        *(f"  {_short(k):8} {_distribution_text(d)}" for k, d in uq["distributions"].items()),
    ]
    if uq.get("n_outside_domain"):
        lines.append(f"{uq['n_outside_domain']} draws lie outside the calibrated domain (extrapolated).")
    text_block(fig, 0.07, 0.30, wrap("\n".join(lines), 105), fontsize=7.5)
    if uq.get("transmission") is not None:
        text_block(fig, 0.07, 0.125, transmission_table(uq["transmission"]), fontsize=6.5)


#: ΔH_V rows of the page's table: output key and label.
_TRANSMISSION_ROWS = (
    ("delta_h_v_db_1khz", "dH_V 1 kHz (dB)"),
    ("delta_h_v_db_5khz", "dH_V 5 kHz (dB)"),
    ("delta_h_v_db_10khz", "dH_V 10 kHz (dB)"),
    ("delta_h_v_deg_1khz", "dH_V 1 kHz (deg)"),
    ("delta_h_v_deg_5khz", "dH_V 5 kHz (deg)"),
    ("delta_h_v_deg_10khz", "dH_V 10 kHz (deg)"),
    ("max_abs_delta_h_v_db_to_10khz", "max |dH_V| <= 10 kHz (dB)"),
)


def transmission_table(t: dict) -> str:
    """The page's ΔH_V table (monospace text): per output its median, 2.5–97.5 % and 0.1–99.9 %
    ranges and the two largest total Sobol' indices, then P(max |ΔH_V| > 1 dB) with its standard
    error; ``t``: the ``transmission`` of ``isj uq --json``."""
    f = t["freq_hz"]
    lines = [
        f"Delta H_V = H_V / H_V(rigid connection), fast ear, {t['samples']} draws, Sobol' from "
        f"{t['sobol_evaluations']} runs; grid {len(f)} frequencies {f[0]:g}..{f[-1]:g} Hz:",
        f"  {'output':27} {'median':>8} {'2.5..97.5 %':>18} {'0.1..99.9 %':>18}   largest ST",
    ]
    for key, label in _TRANSMISSION_ROWS:
        q = t["summary"][key]["quantiles"]
        st = t["sobol"][key]["ST"]
        top = sorted(st.items(), key=lambda kv: -kv[1])[:2]
        lines.append(
            f"  {label:27} {q['0.5']:+8.3f} {q['0.025']:+8.3f}..{q['0.975']:+8.3f} "
            f"{q['0.001']:+8.3f}..{q['0.999']:+8.3f}   " + ", ".join(f"{_short(m)} {v:.2f}" for m, v in top)
        )
    p, se = t["p_abs_delta_h_v_gt_1db"], t["p_abs_delta_h_v_gt_1db_se"]
    lines.append(
        f"  P(max |Delta H_V| to 10 kHz > {t['threshold_db']:g} dB) = {p:.4f} +- {se:.4f} (Monte Carlo s.e.)"
    )
    return "\n".join(lines)


def uq_figure(result, title: str = "Uncertainty of the moduli: alpha, beta and beta/alpha"):
    """A new A4 Figure (Agg canvas, no pyplot) with :func:`uq_page` for a ``UQResult``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from .layout import A4

    fig = Figure(figsize=A4)
    FigureCanvasAgg(fig)
    fig.text(0.07, 0.965, title, fontsize=15, weight="bold", va="top")
    uq_page(fig, result.to_dict(), result.histogram_dict())
    return fig


def transmission_evaluator(ctx):
    """ΔH_V of the report's whole ear through its fast ear (the transmission step's, from the
    cache), or None when ``[uq] transmission_samples`` is 0."""
    cfg = ctx.config
    if not cfg.uq.transmission_samples:
        return None
    from isj.fem.ear.fast_ear import fast_ear
    from isj.fem.ear.shared import shared_ear

    from isj.studies.uq import TRANSMISSION_FREQ_HZ, TransmissionEvaluator

    # the transmission step's fast ear when its band holds the evaluator's grid, else one to 20 kHz
    fmax_hz = cfg.transmission.fmax_hz if cfg.transmission.fmax_hz >= TRANSMISSION_FREQ_HZ[-1] else 20e3
    fast = fast_ear(shared_ear(ctx.settings, cfg.mesh.drum_mesh_size_m), cfg.ear, fmax_hz=fmax_hz)
    return TransmissionEvaluator(fast, damping=cfg.sweep.damping_model())


def uq_step(ctx) -> tuple[dict, dict]:
    """The moduli's uncertainty carried to α, β and β/α on the lumped model, and to ΔH_V on the
    fast ear (docs/uq.md §11)."""
    from isj.fem.batch import free_solvers
    from isj.lumped.api import LumpedModel

    from isj.studies.uq import lumped_evaluator, run_uq
    from isj.studies.uq_inputs import UQConfig

    free_solvers()  # no FE solve here: the joint models' factorizations would only be held
    cfg, u = ctx.config, ctx.config.uq
    lm = LumpedModel(ctx.calibration, cfg.geometry)
    domain = dict(ctx.calibration.domain)
    counts = {"samples": u.samples, "sobol_samples": u.sobol_samples, "bootstrap": u.bootstrap}
    counts["seed"] = u.seed
    if u.transmission_samples:
        counts |= {
            "transmission_samples": min(u.transmission_samples, u.samples),
            "transmission_sobol_samples": u.transmission_sobol_samples,
        }
    config = UQConfig.default(domain, **counts)
    r = run_uq(
        config,
        lumped_evaluator(lm, cfg.design.pressure_pa),
        pressure_pa=cfg.design.pressure_pa,
        domain=domain,
        transmission=transmission_evaluator(ctx),
    )
    out = r.to_dict()
    out.pop("time_s")  # the same inputs give the same JSON
    if "transmission" in out:
        out["transmission"].pop("time_s", None)
    out["top_total"] = {k: r.top_total(k) for k in ("alpha_rad", "beta_rad", "beta_over_alpha")}
    return out | {"histograms": r.histogram_dict()}, {}
