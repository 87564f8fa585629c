"""``isj calibrate``: fit the lumped model's factors to FE results and write the artifact."""

from __future__ import annotations

from pathlib import Path

from isj.errors import UsageError

from . import _common as c


def register(sub) -> None:
    """Add ``isj calibrate`` to the top-level subparsers ``sub``."""
    p = sub.add_parser("calibrate", help="fit the lumped model to FE results")
    p.add_argument("--samples", type=int, default=64, help="training designs (default 64)")
    p.add_argument("--validation", type=int, default=32, help="held-out designs (default 32)")
    p.add_argument("--seed", type=int, default=0, help="seed of the design of experiments")
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address (default: local processes)")
    p.add_argument("--out", metavar="PATH", default="calibration.json", help="artifact to write (.json)")
    c.add_cache_option(p)
    c.add_order_resolution(p, "FE mesh")
    p.add_argument(
        "--modal-samples",
        type=int,
        default=16,
        help="FE modal analyses for the dynamic chain's joint shear factor (default 16; 0 = skip)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=calibrate)


def calibrate(args) -> int:
    from isj.calibration.pipeline import calibrate as fit
    from isj.calibration.pipeline import calibrate_dynamics
    from isj.fem.batch import evaluate_design, evaluate_modes, fe_settings

    from ..atomic import atomic_write_text
    from ..caches import fe_cache_dir

    out = Path(args.out)
    if out.suffix.lower() != ".json" or out.is_dir():
        raise UsageError(f"--out = {args.out!r}: must be a file ending in .json")
    if args.samples < 16 or args.validation < 0 or args.modal_samples < 0:
        raise UsageError("--samples: must be >= 16 (ten factors); --validation, --modal-samples: >= 0")
    if args.seed < 0:
        raise UsageError(f"--seed = {args.seed}: must be an integer >= 0")
    settings = fe_settings(order=args.order, resolution=args.resolution)
    cache = fe_cache_dir(args.cache)
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
        f"calibrated on {t['n']} FE designs: max error alpha {100 * t['max_alpha']:.2f} %, "
        f"beta {100 * t['max_beta']:.2f} %"
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
