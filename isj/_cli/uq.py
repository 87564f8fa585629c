"""``isj uq``: the moduli's uncertainty carried to α, β and β/α; P(β/α > 1); Sobol' indices (docs/uq.md)."""

from __future__ import annotations

import argparse

from isj.errors import UsageError

from . import _common as c

#: What ``isj uq --out DIR`` writes; the folder is replaced as a whole.
UQ_FILES = frozenset(
    {"uq.json", "quantiles.csv", "histograms.csv", "sobol.csv", "uq.png", "transmission.csv"}
)


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
    p = sub.add_parser(
        "uq", help="uncertainty of the moduli: Monte Carlo of alpha, beta, beta/alpha; Sobol' indices"
    )
    _add_sampling_options(p)
    _add_model_options(p)
    _add_transmission_options(p)
    _add_output_options(p)
    p.set_defaults(func=uq)


def _add_sampling_options(p) -> None:
    """The distributions' file and the draws: ``--config``, ``--samples``, ``--sobol-samples``,
    ``--bootstrap``, ``--seed``."""
    from isj.studies.uq_inputs import (
        BOOTSTRAP_RANGE,
        DEFAULT_BOOTSTRAP,
        DEFAULT_SAMPLES,
        DEFAULT_SOBOL_SAMPLES,
        SAMPLES_RANGE,
        SEED_RANGE,
        SOBOL_SAMPLES_RANGE,
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


def _add_model_options(p) -> None:
    """The model the draws go through: ``--evaluator``, ``--compare-surrogate``."""
    p.add_argument(
        "--evaluator",
        choices=("lumped", "surrogate"),
        default="lumped",
        help="the model the draws go through: the calibrated lumped model (default) or the certified "
        "surrogate of the default FE mesh (isj rom build; built here, minutes, if not cached); the "
        "surrogate takes only distributions inside its domain",
    )
    p.add_argument(
        "--compare-surrogate",
        action="store_true",
        help="also run the Monte Carlo draws inside the surrogate's domain through both models and "
        "report P(beta/alpha > 1) for each and their largest differences",
    )


def _add_transmission_options(p) -> None:
    """ΔH_V through the fast ear: ``--transmission`` and its sample counts."""
    from isj.validate import TRANSMISSION_SAMPLES_RANGE, TRANSMISSION_SOBOL_SAMPLES_RANGE

    p.add_argument(
        "--transmission",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="also carry the distributions to Delta H_V (dB, degrees) at 1, 5 and 10 kHz and the "
        "largest |Delta H_V| below 10 kHz through the fast ear of the default mesh (built here, "
        "minutes, if not cached; docs/uq.md 11.10); default: [uq] transmission, else off",
    )
    p.add_argument(
        "--transmission-samples",
        metavar="N",
        type=c.int_option("--transmission-samples", *TRANSMISSION_SAMPLES_RANGE),
        help="Monte Carlo draws of Delta H_V (the first of the alpha/beta draws), in "
        f"[{TRANSMISSION_SAMPLES_RANGE[0]}, {TRANSMISSION_SAMPLES_RANGE[1]}] (default 20000)",
    )
    p.add_argument(
        "--transmission-sobol-samples",
        metavar="N",
        type=_power_of_two("--transmission-sobol-samples", *TRANSMISSION_SOBOL_SAMPLES_RANGE),
        help="Saltelli base samples of Delta H_V, a power of 2 in "
        f"[{TRANSMISSION_SOBOL_SAMPLES_RANGE[0]}, {TRANSMISSION_SOBOL_SAMPLES_RANGE[1]}] (default 1024)",
    )


def _add_output_options(p) -> None:
    """The load, the calibration and where the results go."""
    c.pressure_option(p)
    c.add_calibration_option(p)
    p.add_argument(
        "--out",
        metavar="DIR",
        help="also write uq.json, quantiles.csv, histograms.csv, sobol.csv and uq.png here (and "
        "transmission.csv with --transmission; a new or empty folder, or one isj uq wrote; replaced "
        "as a whole)",
    )
    c.add_json_option(p)


def _csv(header: str, rows) -> str:
    return header + "\n" + "\n".join(",".join(str(v) for v in row) for row in rows) + "\n"


def write_outputs(folder, args, result, summary: dict | None = None) -> None:
    """The files of :data:`UQ_FILES` into ``folder`` (each written atomically); ``summary``: the
    JSON for uq.json (default ``result.to_dict()``)."""
    from isj.atomic import atomic_write_text
    from isj.reports.uq import uq_figure
    from isj.studies.uq import OUTPUTS, QUANTILES, UNITS, transmission_csv

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
    summary = result.to_dict() if summary is None else summary
    write_run_record(folder / "uq.json", args, {**summary, "histograms": result.histogram_dict()})
    fig = uq_figure(result)
    fig.savefig(folder / "uq.png", dpi=110)
    if result.transmission is not None:
        atomic_write_text(folder / "transmission.csv", transmission_csv(result.transmission))


def surrogate_evaluator(rom, pressure_pa: float):
    """The surrogate (:class:`isj.fem.rom.ReducedModel`) as an evaluator of
    :mod:`isj.studies.uq`: moduli (Pa) → (α, β) in rad; a design outside its domain is refused."""
    from isj.design_space import RANGED

    def evaluate(moduli):
        r = rom.evaluate({k: moduli[k] for k in (*RANGED, "incus_e_pa")}, pressure_pa)
        return r["alpha_rad"], r["beta_rad"]

    evaluate.name = "surrogate"
    return evaluate


class _FixedSpace:
    """A stand-in holding only a design space: lets :meth:`TransmissionEvaluator.check` refuse
    distributions before the fast ear is built."""

    def __init__(self, space):
        self.space = space


def _support(space) -> dict[str, tuple[float, float]]:
    """Per modulus, the surrogate's [low, high] (Pa), the incus's a single value."""
    return dict(space.bounds) | {"incus_e_pa": (space.incus_e_pa, space.incus_e_pa)}


def inside_surrogate(space):
    """moduli → boolean mask of the draws inside the surrogate's domain (its edge slack included)."""
    from isj.design_space import inside

    def mask(moduli):
        ok = None
        for k, (lo, hi) in _support(space).items():
            kept = inside(moduli[k], lo, hi)
            ok = kept if ok is None else ok & kept
        return ok

    return mask


def check_surrogate_support(config, space) -> None:
    """Refuse, before the surrogate is built, a distribution that reaches outside its domain."""
    from isj.design_space import inside

    why = "--evaluator surrogate"
    for k, (lo, hi) in _support(space).items():
        d = config.distributions[k]
        rng = f"[{lo:g}, {hi:g}] Pa"
        if d.kind == "lognormal":
            raise UsageError(f"{why}: uq.{k} is lognormal (unbounded); the surrogate holds on {rng} only")
        a, b = (d.low_pa, d.high_pa) if d.kind == "loguniform" else (d.value_pa, d.value_pa)
        if not (inside(a, lo, hi) and inside(b, lo, hi)):
            raise UsageError(f"{why}: uq.{k} spans {a:g}..{b:g} Pa, outside the surrogate's {rng}")


def _surrogate(args):
    """The default mesh's surrogate (P2, resolution 1, default geometry): cached, else built."""
    import sys

    from isj.fem.rom import reduced_model

    def progress(step):
        if not args.json and step["n_snapshots"] % 10 == 0:
            print(f"  building the surrogate: {step['n_snapshots']} FE snapshots", file=sys.stderr)

    return reduced_model(progress=progress)


def _fast_ear(args):
    """The fast ear of the default mesh (P2, resolution 1, default drum): cached, else built."""
    import sys

    from isj.fem.ear import fast_ear as fe
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.model import PedicleJointModel

    if not args.json:
        print("  the fast ear of the default mesh (built once, minutes, then cached)", file=sys.stderr)
    return fe.fast_ear(MiddleEarModel(joint=PedicleJointModel(order=2, resolution=1.0)))


def uq(args) -> int:
    from isj.lumped.api import LumpedModel
    from isj.studies.uq import UQConfig, load_uq_config, lumped_evaluator, run_uq

    from ..atomic import replace_dir

    out = c.check_out_dir(args.out, "--out", UQ_FILES) if args.out is not None else None
    cal = c.load_calibration(args.calibration)
    counts = {
        "samples": args.samples,
        "sobol_samples": args.sobol_samples,
        "bootstrap": args.bootstrap,
        "seed": args.seed,
        "transmission_samples": args.transmission_samples,
        "transmission_sobol_samples": args.transmission_sobol_samples,
    }
    if args.config is not None:
        config = load_uq_config(args.config, cal.domain, **counts)
    else:
        config = UQConfig.default(cal.domain, **{k: v for k, v in counts.items() if v is not None})
    lumped = lumped_evaluator(LumpedModel(cal), args.pressure)
    rom = None
    if args.evaluator == "surrogate" or args.compare_surrogate:
        from isj.design_space import DesignSpace

        if args.evaluator == "surrogate":
            check_surrogate_support(config, DesignSpace())
        c.check_model_size(None, 2, 1.0)
        c.check_caches(args, "mesh", "rom")
        rom = _surrogate(args)
    evaluator = surrogate_evaluator(rom, args.pressure) if args.evaluator == "surrogate" else lumped
    transmission = None
    if args.transmission if args.transmission is not None else bool(config.transmission):
        from isj.design_space import DesignSpace
        from isj.studies.uq import TransmissionEvaluator

        TransmissionEvaluator(_FixedSpace(DesignSpace())).check(config)  # refused before the build
        c.check_model_size(None, 2, 1.0)
        c.check_caches(args, "mesh", "fe")
        transmission = TransmissionEvaluator(_fast_ear(args))
    result = run_uq(
        config, evaluator, pressure_pa=args.pressure, domain=cal.domain, transmission=transmission
    )
    summary = result.to_dict()
    if args.compare_surrogate:
        from isj.studies.uq import compare_evaluators

        surrogate = surrogate_evaluator(rom, args.pressure)
        where = inside_surrogate(rom.space)
        cmp = compare_evaluators(config, lumped, surrogate, where, ("lumped", "surrogate"))
        summary["surrogate_comparison"] = cmp | {"mesh_hash": rom.meta.get("mesh_hash")}
    c.check_finite(summary, f"--pressure {args.pressure:g}, the distributions of --config")
    if out is not None:
        with replace_dir(out) as staging:  # the five files appear together or not at all
            write_outputs(staging, args, result, summary)
    if args.json:
        c.print_json(summary)
        return 0
    _print_summary(config, result, summary)
    if out is not None:
        print(f"wrote {out}/ ({', '.join(sorted(UQ_FILES))})")
    return 0


def _print_summary(config, result, summary: dict) -> None:
    """The text summary: P(β/α > 1), quantiles, the largest Sobol' indices, ΔH_V, the comparison."""
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
    for k, label, scale, unit in (
        ("alpha_rad", "alpha", 1e6, " urad"),
        ("beta_rad", "beta", 1e6, " urad"),
        ("beta_over_alpha", "beta/alpha", 1.0, ""),
    ):
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
    tr = summary.get("transmission")
    if tr is not None:
        se = tr["p_abs_delta_h_v_gt_1db_se"]
        print(
            f"Delta H_V (fast ear, {tr['samples']} draws, {tr['time_s']['total']:.1f} s): "
            f"P(max |Delta H_V| to 10 kHz > 1 dB) = {tr['p_abs_delta_h_v_gt_1db']:.4f} +- {se:.4f} (s.e.)"
        )
        for k, s in tr["summary"].items():
            q, unit = s["quantiles"], tr["units"][k]
            top = sorted(tr["sobol"][k]["ST"].items(), key=lambda kv: -kv[1])[:2]
            print(
                f"  {k:30} median {q['0.5']:+.3f} {unit}, 2.5-97.5 % {q['0.025']:+.3f} .. {q['0.975']:+.3f}; "
                "ST " + ", ".join(f"{m.removesuffix('_e_pa')} {v:.2f}" for m, v in top)
            )
    cmp = summary.get("surrogate_comparison")
    if cmp and cmp["n"]:
        (a, b), (x, y) = (
            cmp["lumped"]["p_beta_over_alpha_gt_1_ci"],
            cmp["surrogate"]["p_beta_over_alpha_gt_1_ci"],
        )
        print(
            f"lumped against the surrogate on the {cmp['n']} draws inside its domain: P(beta/alpha > 1) "
            f"{cmp['lumped']['p_beta_over_alpha_gt_1']:.5f} [{a:.5f}, {b:.5f}] against "
            f"{cmp['surrogate']['p_beta_over_alpha_gt_1']:.5f} [{x:.5f}, {y:.5f}]; largest differences alpha "
            f"{100 * cmp['max_rel_diff_alpha_rad']:.2f} %, beta {100 * cmp['max_rel_diff_beta_rad']:.2f} %, "
            f"beta/alpha {100 * cmp['max_rel_diff_beta_over_alpha']:.2f} %; "
            f"{cmp['n_disagree']} draws disagree"
        )
    elif cmp is not None:
        print("lumped against the surrogate: no draw inside the surrogate's domain")
