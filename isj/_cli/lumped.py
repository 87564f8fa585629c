"""``isj lumped solve``: static α and β of one design from the calibrated lumped model."""

from __future__ import annotations

from isj.design import Materials
from isj.errors import UsageError

from . import _common as c


def register(sub) -> None:
    """Add ``isj lumped`` and its command to the top-level subparsers ``sub``."""
    lum = sub.add_parser("lumped", help="the calibrated lumped model")
    lsub = lum.add_subparsers(dest="lumped_command", required=True, parser_class=c.Parser)
    p = lsub.add_parser("solve", help="static alpha and beta of one design (microseconds)")
    c.add_moduli_options(p, nu=False)
    # the lumped model is calibrated at one Poisson's ratio: --nu may only repeat it
    c.nu_option(
        p,
        default=None,
        help="Poisson's ratio: the lumped model is calibrated at one (0.3 for the shipped calibration); "
        "another is refused",
    )
    c.pressure_option(p)
    c.add_geometry_option(p)  # refused unless empty: calibrated for the default geometry only
    c.add_calibration_option(p)
    c.add_json_option(p)
    p.set_defaults(func=solve)


def calibrated_nu(cal) -> float:
    """The Poisson's ratio ``cal`` was fitted at: its FE settings' ``nu``, else the default design's."""
    nu = cal.fe_settings.get("nu", Materials().nu)
    return float(nu) if isinstance(nu, int | float) and not isinstance(nu, bool) else Materials().nu


def solve(args) -> int:
    from isj.calibration.checks import lumped_static, warn_outside_domain

    cal = c.load_calibration(args.calibration)
    if args.geometry:
        raise UsageError("--geometry: the lumped model is calibrated for the default geometry only")
    nu = calibrated_nu(cal)
    if args.nu is not None and args.nu != nu:
        raise UsageError(
            f"--nu = {args.nu:g}: the lumped model is calibrated at nu = {nu:g} only; "
            f"omit --nu or give {nu:g} (the FE model takes any nu: isj fem solve --nu)"
        )
    args.nu = nu
    designs = c.moduli(c.materials(args))
    warn_outside_domain(cal, designs)
    r = lumped_static(cal, designs, pressure_pa=args.pressure)
    out = {
        "alpha_rad": float(r.alpha_rad),
        "beta_rad": float(r.beta_rad),
        "alpha_plus_beta_rad": float(r.sum_rad),
        "beta_over_alpha": float(r.ratio),
        "pressure_pa": args.pressure,
        "calibration": args.calibration or "default",
        "validation": cal.validation,
    }
    c.check_finite(out, f"{c.design_inputs(args)}, --calibration {out['calibration']}")
    if args.json:
        c.print_json(out)
        return 0
    v = cal.validation
    print(
        f"lumped model ({out['calibration']} calibration, validated max error alpha "
        f"{100 * v.get('max_alpha', float('nan')):.1f} %, beta {100 * v.get('max_beta', float('nan')):.1f} %)"
    )
    print(f"alpha      = {c.urad(out['alpha_rad'])} urad")
    print(f"beta       = {c.urad(out['beta_rad'])} urad")
    print(
        f"alpha+beta = {c.urad(out['alpha_plus_beta_rad'])} urad   beta/alpha = {out['beta_over_alpha']:.3f}"
    )
    return 0
