"""``isj explore``: the lumped model over a grid or a sample, guarded by FE spot checks."""

from __future__ import annotations

from isj.design import Materials
from isj.errors import UsageError

from . import _common as c


def register(sub) -> None:
    """Add ``isj explore`` to the top-level subparsers ``sub``."""
    p = sub.add_parser("explore", help="lumped model over many designs, guarded by FE spot checks")
    d = Materials()
    for r in c.MODULUS_OPTIONS:
        p.add_argument(
            f"--{r}-e",
            metavar="PA[:PA]",
            type=c.range_option(f"--{r}-e"),
            default=(d.youngs(r), d.youngs(r)),
            help=f"modulus of the {r} (Pa, in [{c.MODULUS_RANGE_PA[0]:g}, {c.MODULUS_RANGE_PA[1]:g}]), "
            "or a LOW:HIGH range explored log-uniformly",
        )
    c.pressure_option(p)
    p.add_argument("--n", type=int, default=5, help="grid points per ranged modulus (default 5)")
    p.add_argument("--sample", type=int, help="instead of a grid: N Latin-hypercube designs")
    c.seed_option(p, "--sample and the spot checks")
    p.add_argument("--spot-checks", type=int, default=4, help="FE spot checks K (default 4)")
    p.add_argument(
        "--tolerance",
        type=c.float_option("--tolerance", lo=0.0),
        default=0.03,
        help="largest relative error of a spot check (default 0.03)",
    )
    c.add_calibration_option(p)
    c.add_cache_option(p)
    p.add_argument("--order", type=int, choices=(1, 2), default=2, help="FE order of the spot checks")
    lo, hi = c.RESOLUTION_RANGE
    p.add_argument(
        "--resolution",
        metavar="R",
        type=c.resolution_option("--resolution"),
        default=1.0,
        help=f"FE mesh refinement of the spot checks, in [{lo:g}, {hi:g}] (default 1)",
    )
    c.add_json_option(p)
    p.set_defaults(func=explore)


def explore(args) -> int:
    import numpy as np

    from isj.calibration.explore import MAX_DESIGNS, ExploreSpace, count_designs, explore_designs
    from isj.calibration.explore import explore as run
    from isj.fem.batch import evaluate_design, fe_settings

    from ..caches import fe_cache_dir

    cal = c.load_calibration(args.calibration)
    if args.n < 1 or (args.sample is not None and args.sample < 1) or args.spot_checks < 0:
        raise UsageError("--n, --sample: must be >= 1; --spot-checks: must be >= 0")
    if args.spot_checks:
        c.check_model_size(None, args.order, args.resolution)
    space = ExploreSpace(**{f"{r}_e_pa": getattr(args, f"{r}_e") for r in c.MODULUS_OPTIONS})
    total = count_designs(space, args.n, args.sample)  # before anything of that size is allocated
    if total > MAX_DESIGNS:
        flag = f"--sample = {args.sample}" if args.sample is not None else f"--n = {args.n}"
        raise UsageError(f"{flag}: {total:.3g} designs is too many (at most {MAX_DESIGNS:.0e})")
    designs = explore_designs(space, args.n, args.sample, args.seed)
    settings = fe_settings(order=args.order, resolution=args.resolution, pressure_pa=args.pressure)
    ex = run(cal, designs, args.spot_checks, evaluate_design, settings, fe_cache_dir(args.cache),
             seed=args.seed, progress=not args.json)  # fmt: skip
    lum, comp = ex.lumped, ex.checks
    passed = comp.passed(args.tolerance)
    ea, eb = comp.rel_error("alpha_rad"), comp.rel_error("beta_rad")
    checks = [
        {
            "design": comp.designs[i],
            "fe_alpha_rad": comp.fe_results[i]["alpha_rad"],
            "fe_beta_rad": comp.fe_results[i]["beta_rad"],
            "lumped_alpha_rad": float(comp.lumped_alpha_rad[i]),
            "lumped_beta_rad": float(comp.lumped_beta_rad[i]),
            "alpha_rel_error": float(ea[i]),
            "beta_rel_error": float(eb[i]),
            "passed": bool(passed[i]),
        }
        for i in range(comp.n)
    ]
    n_failed = int(np.count_nonzero(~passed))
    summary = {
        "n_designs": ex.n_designs,
        "lumped_time_s": ex.lumped_time_s,
        "outside_domain": ex.outside_domain,
        "alpha_rad_range": [float(lum.alpha_rad.min()), float(lum.alpha_rad.max())],
        "beta_rad_range": [float(lum.beta_rad.min()), float(lum.beta_rad.max())],
        "tolerance": args.tolerance,
        "spot_checks": checks,
        "max_spot_error": comp.max_abs_error(),
        "passed": not n_failed,
    }
    c.check_finite(summary, f"--pressure {args.pressure:g}")
    if args.json:
        c.print_json(summary)
    else:
        u = c.urad
        print(
            f"lumped model: {ex.n_designs} designs in {ex.lumped_time_s * 1e3:.2f} ms; alpha "
            f"{u(lum.alpha_rad.min())} .. {u(lum.alpha_rad.max())} urad, beta {u(lum.beta_rad.min())} .. "
            f"{u(lum.beta_rad.max())} urad"
        )
        for ck in checks:
            print(
                f"  FE spot check: alpha {100 * ck['alpha_rel_error']:+6.2f} %, beta "
                f"{100 * ck['beta_rel_error']:+6.2f} % {'ok' if ck['passed'] else 'EXCEEDS tolerance'}"
            )
        print(f"{len(checks) - n_failed}/{len(checks)} spot checks within {100 * args.tolerance:g} %")
    if n_failed:
        return c.fail(f"{n_failed} FE spot check(s) exceed the tolerance {args.tolerance:g}")
    return 0
