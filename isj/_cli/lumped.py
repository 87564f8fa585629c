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
    c.add_geometry_option(p)  # another geometry takes the shipped geometry calibration
    c.add_calibration_option(p)
    add_joint_option(p)
    c.add_json_option(p)
    p.set_defaults(func=solve)


def add_joint_option(p, default=None, what="the shipped calibration fitted with that joint") -> None:
    """``--joint {bonded,sliding}``: the lumped model's joint (docs/lumped.md 3.14); layer is refused."""
    import argparse

    from isj.lumped.artifact import CALIBRATED_JOINTS

    def joint(text: str) -> str:
        if text not in CALIBRATED_JOINTS:
            raise argparse.ArgumentTypeError(
                f"--joint = {text}: must be one of {', '.join(CALIBRATED_JOINTS)} (the lumped model has "
                "no calibration for the thin layer; isj fem solve --joint layer)"
            )
        return text

    p.add_argument(
        "--joint",
        type=joint,
        default=default,
        metavar="{" + ",".join(CALIBRATED_JOINTS) + "}",
        help=f"the incudostapedial joint: {what} (default: bonded, or --calibration's joint)",
    )


def calibrated_nu(cal) -> float:
    """The Poisson's ratio ``cal`` was fitted at: its FE settings' ``nu``, else the default design's."""
    nu = cal.fe_settings.get("nu", Materials().nu)
    return float(nu) if isinstance(nu, int | float) and not isinstance(nu, bool) else Materials().nu


def check_nu(cal, nu: float | None) -> float:
    """``--nu`` against the Poisson's ratio ``cal`` was fitted at: None or that ratio, else refused.

    The lumped model holds at its calibration's ratio only; every command that runs it (``isj
    lumped solve``, ``isj sweep``, ``isj ear sweep``) refuses another before any work.
    """
    fitted = calibrated_nu(cal)
    if nu is not None and nu != fitted:
        raise UsageError(
            f"--nu = {nu:g}: the lumped model is calibrated at nu = {fitted:g} only; "
            f"omit --nu or give {fitted:g} (the FE model takes any nu: isj fem solve --nu)"
        )
    return fitted


def calibration_and_geometry(args):
    """(calibration, geometry) of ``--calibration`` and ``--geometry``; warns outside the calibrated geometry.

    Without ``--calibration``, a geometry other than the default takes the shipped calibration
    over geometry and moduli (:func:`isj.lumped.artifact.calibration_for`). Each dimension outside
    the calibration's geometric domain is one :class:`~isj.errors.OutOfDomainWarning`.
    """
    from isj.design import Geometry

    g = c.geometry(args) if args.geometry else Geometry()
    joint = getattr(args, "joint", None)
    if args.calibration:
        cal = c.load_calibration(args.calibration)
        if joint is not None and joint != cal.joint:
            raise UsageError(f"--joint = {joint}: --calibration was fitted with the {cal.joint} joint")
    else:
        from isj.errors import CorruptCalibration
        from isj.lumped.artifact import calibration_for

        try:
            cal = calibration_for(g, joint or "bonded")
        except CorruptCalibration as exc:
            raise UsageError(str(exc)) from None
    warn_outside_geometry(cal, g)
    return cal, g


def warn_outside_geometry(cal, geometry) -> int:
    """One :class:`~isj.errors.OutOfDomainWarning` per dimension outside ``cal``'s geometry; their count."""
    import warnings

    from isj.errors import OutOfDomainWarning

    out = cal.outside_geometry(geometry)
    for name, (v, lo, hi) in out.items():
        where = f"[{lo:g}, {hi:g}] m" if lo != hi else f"{lo:g} m (the geometry it was fitted on)"
        warnings.warn(
            f"{name} = {v:g} m outside the calibrated geometry {where}: the lumped model is extrapolating",
            OutOfDomainWarning,
            stacklevel=2,
        )
    return len(out)


def _shipped_name(cal) -> str:
    """The name of a shipped calibration: sliding, geometry or default."""
    return "sliding" if cal.joint == "sliding" else ("geometry" if cal.geometry_domain else "default")


def solve(args) -> int:
    from isj.calibration.checks import lumped_static, warn_outside_domain

    from ._region import print_region, region_marks

    cal, geometry = calibration_and_geometry(args)
    args.nu = check_nu(cal, args.nu)
    designs = c.moduli(c.materials(args))
    warn_outside_domain(cal, designs, geometry)
    r = lumped_static(cal, designs, geometry, pressure_pa=args.pressure)
    out = {
        "alpha_rad": float(r.alpha_rad),
        "beta_rad": float(r.beta_rad),
        "alpha_plus_beta_rad": float(r.sum_rad),
        "beta_over_alpha": float(r.ratio),
        "pressure_pa": args.pressure,
        "calibration": args.calibration or _shipped_name(cal),
        "joint": cal.joint,
        "validation": cal.validation,
    }
    out |= region_marks(cal, designs, geometry, args.pressure)  # docs/lumped.md section 3.15
    c.check_finite(out, f"{c.design_inputs(args)}, --calibration {out['calibration']}")
    if args.json:
        c.print_json(out)
        return 0
    v = cal.validation
    print(
        f"lumped model ({out['calibration']} calibration, {cal.joint} joint, validated max error alpha "
        f"{100 * v.get('max_alpha', float('nan')):.1f} %, beta {100 * v.get('max_beta', float('nan')):.1f} %)"
    )
    print(f"alpha      = {c.urad(out['alpha_rad'])} urad")
    print(f"beta       = {c.urad(out['beta_rad'])} urad")
    print(
        f"alpha+beta = {c.urad(out['alpha_plus_beta_rad'])} urad   beta/alpha = {out['beta_over_alpha']:.3f}"
    )
    print_region(out)
    return 0
