"""``isj calibrate``: fit the lumped model's factors to FE results and write the artifact."""

from __future__ import annotations

from . import _common as c
from .lumped import add_joint_option

#: Largest --samples and --validation: FE designs take seconds each, so 10 000 is hours of FE on
#: a cluster, and the fit's matrices stay small.
MAX_SAMPLES = 10_000
#: Largest --modal-samples: each is an FE eigenvalue analysis.
MAX_MODAL_SAMPLES = 1_000


def register(sub) -> None:
    """Add ``isj calibrate`` to the top-level subparsers ``sub``."""
    p = sub.add_parser("calibrate", help="fit the lumped model to FE results")
    p.add_argument(
        "--samples",
        type=c.int_option("--samples", 16, MAX_SAMPLES),
        default=None,
        help=f"training designs, in [16, {MAX_SAMPLES}] (default 64; with --geometry-domain 480: every "
        "term's geometric exponents are fitted too)",
    )
    p.add_argument(
        "--validation",
        type=c.int_option("--validation", 0, MAX_SAMPLES),
        default=32,
        help=f"held-out designs, in [0, {MAX_SAMPLES}] (default 32)",
    )
    c.seed_option(p, "the design of experiments")
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="Dask scheduler, tcp://HOST:PORT, tried before any work (default: local processes)",
    )
    p.add_argument("--out", metavar="PATH", default="calibration.json", help="artifact to write (.json)")
    c.add_cache_option(p)
    c.add_order_resolution(p, "FE mesh")
    p.add_argument(
        "--modal-samples",
        type=c.int_option("--modal-samples", 0, MAX_MODAL_SAMPLES),
        default=16,
        help="FE modal analyses for the dynamic chain's joint shear factor, in "
        f"[0, {MAX_MODAL_SAMPLES}] (default 16; 0 = skip)",
    )
    p.add_argument(
        "--geometry-domain",
        action="store_true",
        help="sample the geometry (the dimensions and ranges of docs/lumped.md section 3.13) together "
        "with the moduli; FE on --workers local processes, or on a Dask cluster with --scheduler",
    )
    p.add_argument(
        "--workers",
        type=c.int_option("--workers", 1, 64),
        default=1,
        help="FE worker processes with --geometry-domain and no --scheduler (default 1)",
    )
    add_joint_option(p, default="bonded", what="the FE model's joint the factors are fitted on")
    _adaptive_options(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=calibrate)


def _adaptive_options(p) -> None:
    """``--adaptive`` and its loop's settings (docs/lumped.md section 3.15)."""
    from isj.calibration.adaptive import DEFAULT_MAX_ROUNDS, DEFAULT_PER_ROUND
    from isj.calibration.guard import DEFAULT_DENSE, MAX_DENSE

    p.add_argument(
        "--adaptive",
        action="store_true",
        help="then add training designs where the lumped model is worst (the certified surrogate of the "
        "FE mesh over the corners and a dense sample; FE there) and refit, until the tolerance holds",
    )
    p.add_argument(
        "--rounds",
        type=c.int_option("--rounds", 0, 100),
        default=DEFAULT_MAX_ROUNDS,
        help=f"with --adaptive: most rounds, in [0, 100] (default {DEFAULT_MAX_ROUNDS})",
    )
    p.add_argument(
        "--per-round",
        type=c.int_option("--per-round", 1, 100),
        default=DEFAULT_PER_ROUND,
        help=f"with --adaptive: designs added per round, in [1, 100] (default {DEFAULT_PER_ROUND})",
    )
    p.add_argument(
        "--guard-sample",
        metavar="N",
        type=c.int_option("--guard-sample", 0, MAX_DENSE),
        default=DEFAULT_DENSE,
        help=f"with --adaptive: dense Sobol designs guarded per round (default {DEFAULT_DENSE})",
    )
    p.add_argument(
        "--tolerance",
        type=c.float_option("--tolerance", lo=0.0),
        default=0.03,
        help="with --adaptive: largest certified relative error aimed at (default 0.03)",
    )


def calibrate(args) -> int:
    from isj.calibration.workflow import run_calibration
    from isj.fem.batch import evaluate_design, evaluate_modes, fe_settings

    from ..atomic import atomic_write_text
    from ..caches import fe_cache_dir

    # every input, the output path, the model's size and the scheduler: before any FE run
    out = c.check_out_path(args.out, "--out", ".json")
    c.check_model_size(None, args.order, args.resolution)
    c.check_caches(args, "mesh", "fe", *(("rom",) if args.adaptive else ()))
    c.check_scheduler(args.scheduler)
    settings = fe_settings(order=args.order, resolution=args.resolution, joint=args.joint)
    if args.samples is None:
        from isj.calibration.pipeline import GEOMETRY_SAMPLES

        args.samples = GEOMETRY_SAMPLES if args.geometry_domain else 64
    cache = fe_cache_dir(args.cache)
    rom = None
    if args.adaptive:
        from isj.errors import UsageError

        from .explore import load_surrogate

        if args.geometry_domain or args.joint != "bonded":
            raise UsageError(
                "--adaptive: the surrogate covers the bonded joint on one geometry; "
                "drop --geometry-domain and --joint"
            )
        rom, why = load_surrogate(args.order, args.resolution)  # minutes on a mesh's first build
        if rom is None:
            return c.fail(f"--adaptive needs the certified surrogate: {why}")
    cal = run_calibration(
        evaluate_design,
        evaluate_modes,
        settings,
        cache,
        samples=args.samples,
        validation=args.validation,
        seed=args.seed,
        modal_samples=args.modal_samples,
        geometry_domain=args.geometry_domain,
        max_workers=args.workers,
        scheduler=args.scheduler,
        progress=not args.quiet,
        surrogate=rom,
        tolerance=args.tolerance,
        n_dense=args.guard_sample,
        per_round=args.per_round,
        max_rounds=args.rounds,
        log=None if args.quiet else (lambda line: print(f"isj: adaptive {line}", flush=True)),
    )
    atomic_write_text(out, cal.to_json())
    _print_calibration(cal)
    print(f"wrote {out}")
    return 0


def _print_calibration(cal) -> None:
    """The calibration's report lines: training and validation errors, the chain's fit, the
    adaptive rounds."""
    t, v = cal.training, cal.validation
    print(
        f"calibrated on {t['n']} FE designs ({cal.joint} joint): max error "
        f"alpha {100 * t['max_alpha']:.2f} %, beta {100 * t['max_beta']:.2f} %"
    )
    if v.get("n"):
        print(
            f"validated on {v['n']} unseen FE designs: max error alpha {100 * v['max_alpha']:.2f} %, "
            f"beta {100 * v['max_beta']:.2f} %, beta/alpha {100 * v['max_ratio']:.2f} % "
            f"(RMS {100 * v['rms_alpha']:.2f} / {100 * v['rms_beta']:.2f} / {100 * v['rms_ratio']:.2f} %)"
        )
    if v.get("n_beyond_support_limit"):
        print(
            f"{v['n_beyond_support_limit']} more held-out designs lie beyond the plate-support limit "
            f"s = pi/2 (a thin, soft plate under a stiff gap; warned when solved): max error alpha "
            f"{100 * v['max_alpha_beyond_support_limit']:.2f} %, "
            f"beta {100 * v['max_beta_beyond_support_limit']:.2f} %"
        )
    if cal.dynamics:
        dv = cal.dynamics.get("validation") or cal.dynamics["training"]
        print(
            f"chain model joint shear factor {cal.dynamics['shear_factor']:.3f}: first two in-plane natural "
            f"frequencies within {100 * dv['max_f1']:.1f} % and {100 * dv['max_f2']:.1f} % of FE on "
            f"{dv['n']} {'held-out' if cal.dynamics.get('validation') else 'training'} designs"
        )
    if cal.provenance.get("adaptive"):
        from isj.calibration.region import region_summary

        a = cal.provenance["adaptive"]
        best = a["history"][a["best_round"]]
        print(
            f"adaptive: {a['n_added']} designs added in {a['best_round']} round(s) ({a['stop']}); worst "
            f"certified error {100 * best['max_certified_error']:.2f} % over the corners and "
            f"{a['n_dense']} dense designs; {region_summary(cal.region)}"
        )
