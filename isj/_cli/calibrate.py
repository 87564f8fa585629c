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
        default=64,
        help=f"training designs, in [16, {MAX_SAMPLES}] (ten factors; default 64)",
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
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=calibrate)


def calibrate(args) -> int:
    from isj.calibration.pipeline import calibrate as fit
    from isj.calibration.pipeline import calibrate_dynamics, calibrate_geometry
    from isj.fem.batch import evaluate_design, evaluate_modes, fe_settings

    from ..atomic import atomic_write_text
    from ..caches import fe_cache_dir

    # every input, the output path, the model's size and the scheduler: before any FE run
    out = c.check_out_path(args.out, "--out", ".json")
    c.check_model_size(None, args.order, args.resolution)
    c.check_scheduler(args.scheduler)
    settings = fe_settings(order=args.order, resolution=args.resolution, joint=args.joint)
    cache = fe_cache_dir(args.cache)
    if args.geometry_domain:
        cal = calibrate_geometry(
            evaluate_design,
            settings,
            cache,
            samples=args.samples,
            validation=args.validation,
            seed=args.seed,
            max_workers=args.workers,
            progress=not args.quiet,
            scheduler=args.scheduler,
        )
    else:
        cal = fit(
            evaluate_design,
            settings,
            cache,
            samples=args.samples,
            validation=args.validation,
            seed=args.seed,
            scheduler=args.scheduler,
            progress=not args.quiet,
        )
    if args.modal_samples:
        cal = calibrate_dynamics(
            cal,
            evaluate_modes,
            settings,
            cache,
            samples=args.modal_samples,
            validation=max(args.modal_samples // 2, 2),
            seed=args.seed + 100,
            progress=not args.quiet,
        )
    atomic_write_text(out, cal.to_json())
    t, v = cal.training, cal.validation
    print(
        f"calibrated on {t['n']} FE designs ({cal.joint} joint): max error "
        f"alpha {100 * t['max_alpha']:.2f} %, beta {100 * t['max_beta']:.2f} %"
    )
    if v:
        print(
            f"validated on {v['n']} unseen FE designs: max error alpha {100 * v['max_alpha']:.2f} %, "
            f"beta {100 * v['max_beta']:.2f} %, beta/alpha {100 * v['max_ratio']:.2f} % "
            f"(RMS {100 * v['rms_alpha']:.2f} / {100 * v['rms_beta']:.2f} / {100 * v['rms_ratio']:.2f} %)"
        )
    if cal.dynamics:
        dv = cal.dynamics.get("validation") or cal.dynamics["training"]
        print(
            f"chain model joint shear factor {cal.dynamics['shear_factor']:.3f}: first two in-plane natural "
            f"frequencies within {100 * dv['max_f1']:.1f} % and {100 * dv['max_f2']:.1f} % of FE on "
            f"{dv['n']} {'held-out' if cal.dynamics.get('validation') else 'training'} designs"
        )
    print(f"wrote {out}")
    return 0
