"""``isj uq``: the moduli's uncertainty carried to α, β and β/α; P(β/α > 1); Sobol' indices (docs/uq.md)."""

from __future__ import annotations

import argparse

from . import _common as c

#: What ``isj uq --out DIR`` writes; the folder is replaced as a whole.
UQ_FILES = frozenset({"uq.json", "quantiles.csv", "histograms.csv", "sobol.csv", "uq.png"})


def _power_of_two(name: str, lo: int, hi: int):
    """argparse ``type`` for a power of 2 in [lo, hi]."""
    integer = c.int_option(name, lo, hi)

    def parse(text: str) -> int:
        v = integer(text)
        if v & (v - 1):
            raise argparse.ArgumentTypeError(f"{name} = {text}: must be a power of 2 in [{lo}, {hi}]")
        return v

    return parse


def register(sub) -> None:
    """Add ``isj uq`` to the top-level subparsers ``sub``."""
    from isj.calibration.uq_inputs import (
        BOOTSTRAP_RANGE,
        DEFAULT_BOOTSTRAP,
        DEFAULT_SAMPLES,
        DEFAULT_SOBOL_SAMPLES,
        SAMPLES_RANGE,
        SEED_RANGE,
        SOBOL_SAMPLES_RANGE,
    )

    p = sub.add_parser(
        "uq", help="uncertainty of the moduli: Monte Carlo of alpha, beta, beta/alpha; Sobol' indices"
    )
    p.add_argument(
        "--config",
        metavar="FILE",
        help="TOML file with a [uq] section: per modulus a [uq.<name>_e_pa] table (distribution = "
        "loguniform, lognormal or fixed), samples, sobol_samples, bootstrap, seed (default: every "
        "modulus log-uniform over the calibrated domain, docs/uq.md)",
    )
    p.add_argument(
        "--samples",
        metavar="N",
        type=c.int_option("--samples", *SAMPLES_RANGE),
        help=f"Monte Carlo draws, in [{SAMPLES_RANGE[0]}, {SAMPLES_RANGE[1]}] (default {DEFAULT_SAMPLES})",
    )
    p.add_argument(
        "--sobol-samples",
        metavar="N",
        type=_power_of_two("--sobol-samples", *SOBOL_SAMPLES_RANGE),
        help="Saltelli base samples, a power of 2 in "
        f"[{SOBOL_SAMPLES_RANGE[0]}, {SOBOL_SAMPLES_RANGE[1]}] (default {DEFAULT_SOBOL_SAMPLES})",
    )
    p.add_argument(
        "--bootstrap",
        metavar="R",
        type=c.int_option("--bootstrap", *BOOTSTRAP_RANGE),
        help=f"bootstrap resamples of the Sobol' indices, in [{BOOTSTRAP_RANGE[0]}, {BOOTSTRAP_RANGE[1]}] "
        f"(default {DEFAULT_BOOTSTRAP})",
    )
    p.add_argument(
        "--seed",
        type=c.int_option("--seed", *SEED_RANGE),
        help=f"seed of the draws, the Sobol' points and the bootstrap, in [0, {SEED_RANGE[1]}] (default 0)",
    )
    c.pressure_option(p)
    c.add_calibration_option(p)
    p.add_argument(
        "--out",
        metavar="DIR",
        help="also write uq.json, quantiles.csv, histograms.csv, sobol.csv and uq.png here (a new or "
        "empty folder, or one isj uq wrote; replaced as a whole)",
    )
    c.add_json_option(p)
    p.set_defaults(func=uq)


def _csv(header: str, rows) -> str:
    return header + "\n" + "\n".join(",".join(str(v) for v in row) for row in rows) + "\n"


def write_outputs(folder, args, result) -> None:
    """The files of :data:`UQ_FILES` into ``folder`` (each written atomically)."""
    from isj.atomic import atomic_write_text
    from isj.calibration.uq import OUTPUTS, QUANTILES, UNITS
    from isj.reports.uq import uq_figure

    from ..provenance import write_run_record

    s = result.summary
    units = "# units: " + ", ".join(f"{k} {UNITS[k]}" for k in OUTPUTS) + "\n"
    rows = [[f"{q:g}", *(f"{s[k]['quantiles'][f'{q:g}']:.9g}" for k in OUTPUTS)] for q in QUANTILES]
    atomic_write_text(folder / "quantiles.csv", units + _csv("probability," + ",".join(OUTPUTS), rows))
    rows = []
    for k, (edges, counts) in result.histograms.items():
        n = counts.sum()
        for lo, hi, m in zip(edges[:-1], edges[1:], counts, strict=True):
            rows.append([k, f"{lo:.9g}", f"{hi:.9g}", int(m), f"{m / n / (hi - lo):.9g}"])
    atomic_write_text(
        folder / "histograms.csv",
        "# bin edges in the output's unit (rad for angles); density: per unit of the output\n"
        + _csv("output,bin_low,bin_high,count,density", rows),
    )
    rows = [
        [k, m, *(f"{ix[key][m]:.6g}" for key in ("S1", "S1_conf", "ST", "ST_conf"))]
        for k, ix in result.sobol.items()
        for m in ix["ST"]
    ]
    atomic_write_text(folder / "sobol.csv", _csv("output,modulus,S1,S1_conf,ST,ST_conf", rows))
    write_run_record(folder / "uq.json", args, {**result.to_dict(), "histograms": result.histogram_dict()})
    fig = uq_figure(result)
    fig.savefig(folder / "uq.png", dpi=110)


def uq(args) -> int:
    from isj.calibration.uq import UQConfig, load_uq_config, lumped_evaluator, run_uq
    from isj.lumped.api import LumpedModel

    from ..atomic import replace_dir

    out = c.check_out_dir(args.out, "--out", UQ_FILES) if args.out is not None else None
    cal = c.load_calibration(args.calibration)
    counts = {"samples": args.samples, "sobol_samples": args.sobol_samples, "bootstrap": args.bootstrap,
              "seed": args.seed}  # fmt: skip
    if args.config is not None:
        config = load_uq_config(args.config, cal.domain, **counts)
    else:
        config = UQConfig.default(cal.domain, **{k: v for k, v in counts.items() if v is not None})
    model = LumpedModel(cal)
    result = run_uq(
        config, lumped_evaluator(model, args.pressure), pressure_pa=args.pressure, domain=cal.domain
    )
    summary = result.to_dict()
    c.check_finite(summary, f"--pressure {args.pressure:g}, the distributions of --config")
    if out is not None:
        with replace_dir(out) as staging:  # the five files appear together or not at all
            write_outputs(staging, args, result)
    if args.json:
        c.print_json(summary)
        return 0
    lo, hi = summary["p_beta_over_alpha_gt_1_ci"]
    t = summary["time_s"]
    print(
        f"isj uq: {config.samples} draws through the {result.evaluator} model (seed {config.seed}) in "
        f"{t['monte_carlo']:.2f} s; Sobol' indices from {summary['sobol_evaluations']} runs in "
        f"{t['sobol']:.2f} s"
    )
    print(
        f"P(beta/alpha > 1) = {result.p_beta_over_alpha_gt_1:.5f}, 95 % Wilson interval [{lo:.5f}, {hi:.5f}]"
    )
    for k, label, scale, unit in (("alpha_rad", "alpha", 1e6, " urad"), ("beta_rad", "beta", 1e6, " urad"),
                                  ("beta_over_alpha", "beta/alpha", 1.0, "")):  # fmt: skip
        q = summary["summary"][k]["quantiles"]
        print(
            f"  {label:10} median {q['0.5'] * scale:.4g}{unit}, 2.5-97.5 % {q['0.025'] * scale:.4g} .. "
            f"{q['0.975'] * scale:.4g}{unit}"
        )
    print("largest total Sobol' indices (ST +- 95 % half-width):")
    for k in result.sobol:
        top = result.top_total(k)
        conf = result.sobol[k]["ST_conf"]
        print(f"  {k:16} " + ", ".join(f"{m.removesuffix('_e_pa')} {v:.3f} +- {conf[m]:.3f}" for m, v in top))
    if result.n_outside_domain:
        frac = result.n_outside_domain / config.samples
        print(f"  {result.n_outside_domain} draws ({100 * frac:.2f} %) outside the calibrated domain")
    if out is not None:
        print(f"wrote {out}/ ({', '.join(sorted(UQ_FILES))})")
    return 0
