"""``isj sweep``: the lumped chain's damped frequency response, with FE harmonic spot checks.

The options shared with ``isj ear sweep`` (the band, the damping, the checks
before anything runs) are here too.
"""

from __future__ import annotations

import argparse
import math

from isj.errors import InvalidParameter, UsageError
from isj.validate import MAX_LOSS_FACTOR, MAX_RAYLEIGH_TERM  # noqa: F401 - re-exported, their old home

from . import _common as c

#: What ``isj sweep`` writes into --out; a folder holding anything else is refused.
SWEEP_FILES = frozenset({"sweep.csv", "sweep.npz", "bode.png", "sweep.json"})


def add_band_options(
    p: argparse.ArgumentParser, fmax_hz: float = 20e3, why: str = "", model: str = "chain"
) -> None:
    """``--fmin-hz``, ``--fmax-hz`` (at most ``model``'s limit, :data:`isj.validate.BAND_LIMITS`)
    and ``--n`` (log-spaced frequencies)."""
    from isj.validate import BAND_LIMITS

    limit, reason = BAND_LIMITS[model]
    p.add_argument(
        "--fmin-hz", type=c.float_option("--fmin-hz", lo=0.0), default=100.0, help="lowest frequency (Hz)"
    )
    p.add_argument(
        "--fmax-hz",
        type=c.float_option("--fmax-hz", lo=0.0),
        default=fmax_hz,
        help=f"highest frequency (Hz; default {fmax_hz:g}{why}; at most {limit:g}: {reason})",
    )
    p.add_argument(
        "--n",
        type=c.int_option("--n", 2, 100_000),
        default=200,
        help="frequencies, log-spaced, in [2, 100000] (default 200)",
    )


def _damping_value(option: str, names: tuple[str, ...], unit: str, hi: float = math.inf):
    """argparse ``type`` for ``VALUE`` (every name) or ``NAME=VALUE`` (one name): (name or None, value)."""

    def parse(text: str):
        name, eq, value = text.rpartition("=")
        if eq and not name:
            raise argparse.ArgumentTypeError(
                f"{option} {text}: empty name before '='; give VALUE or NAME=VALUE, NAME one of "
                f"{', '.join(names)}"
            )
        if name and name not in names:
            raise argparse.ArgumentTypeError(
                f"{option} {text}: unknown name {name!r}; must be one of {', '.join(names)}"
            )
        try:
            v = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} {text}: {value!r} is not a number") from None
        if not (math.isfinite(v) and 0 <= v <= hi):
            raise argparse.ArgumentTypeError(f"{option} {text}: must be a finite number in [0, {hi:g}]{unit}")
        return (name or None, v)

    return parse


def add_damping_options(p: argparse.ArgumentParser) -> None:
    """The damping (docs/dynamics.md §4.3): a preset, then changes by name, and the calibration."""
    from isj.damping import CAT_COCHLEAR_IMPEDANCE_PA_S_M3, MASS_PARTS, PRESETS, STIFFNESS_PARTS

    big = f"{MAX_RAYLEIGH_TERM:g}"
    p.add_argument(
        "--damping",
        choices=PRESETS,
        default="published",
        help="damping preset: published (default; a loss factor per material, docs/dynamics.md "
        "4.3), uniform-rayleigh (the old b = 1e-4 s on everything) or undamped",
    )
    each = "; NAME a region, ear part or spring set; repeatable, applied in order after --damping"
    p.add_argument(
        "--loss-factor",
        metavar="[NAME=]ETA",
        action="append",
        type=_damping_value("--loss-factor", STIFFNESS_PARTS, "", MAX_LOSS_FACTOR),
        help=f"loss factor eta in [0, {MAX_LOSS_FACTOR:g}] of everything or of NAME{each}",
    )
    p.add_argument(
        "--rayleigh-a",
        metavar="[NAME=]PER_S",
        action="append",
        type=_damping_value("--rayleigh-a", MASS_PARTS, " 1/s"),
        help=f"Rayleigh mass coefficient a (1/s, a/omega <= {big} at --fmin-hz) of everything or NAME{each}",
    )
    p.add_argument(
        "--rayleigh-b",
        metavar="[NAME=]S",
        action="append",
        type=_damping_value("--rayleigh-b", STIFFNESS_PARTS, " s"),
        help=f"Rayleigh stiffness coefficient b (s, omega b <= {big} at --fmax-hz; on a spring set a "
        f"dashpot c = b k) of everything or of NAME{each}",
    )
    p.add_argument(
        "--cochlear-impedance",
        metavar="PA_S_M3",
        type=c.float_option("--cochlear-impedance", lo=0.0, lo_open=False),
        default=None,
        help=f"cochlear input resistance Z_C (Pa s/m^3; default {CAT_COCHLEAR_IMPEDANCE_PA_S_M3:g}, cat, "
        "Lynch et al. 1982), on the footplate as R = Z_C A^2",
    )
    c.add_calibration_option(p)


def damping_from_args(args):
    """The :class:`isj.damping.Damping` of the options: ``--damping``, then each change in order."""
    from isj.damping import Damping

    d = Damping.preset(args.damping)
    for option, field in (
        ("loss_factor", "loss_factor"),
        ("rayleigh_a", "rayleigh_a_per_s"),
        ("rayleigh_b", "rayleigh_b_s"),
    ):
        for name, v in getattr(args, option) or ():
            d = d.replace(**{field: v if name is None else {name: v}})
    if args.cochlear_impedance is not None:
        d = d.replace(cochlear_impedance_pa_s_m3=args.cochlear_impedance)
    return d


def damping_inputs(args) -> str:
    """The damping options as given, for messages: ``--damping published --loss-factor gap=0.2``."""
    out = [f"--damping {args.damping}"]
    for option in ("loss_factor", "rayleigh_a", "rayleigh_b"):
        for name, v in getattr(args, option) or ():
            out.append(f"--{option.replace('_', '-')} {'' if name is None else name + '='}{v:g}")
    if args.cochlear_impedance is not None:
        out.append(f"--cochlear-impedance {args.cochlear_impedance:g}")
    return " ".join(out)


def check_rayleigh(args) -> None:
    """Every loss factor within :data:`MAX_LOSS_FACTOR` and every Rayleigh a and b within
    :data:`MAX_RAYLEIGH_TERM` over the band [--fmin-hz, --fmax-hz] (:func:`isj.validate.check_damping`,
    the same limits as the report's ``[sweep]``)."""
    from isj.validate import check_damping

    try:
        check_damping(damping_from_args(args), args.fmin_hz, args.fmax_hz)
    except InvalidParameter as exc:
        raise UsageError(str(exc)) from None


def sweep_setup(args, files: frozenset[str], model: str = "chain", lumped: bool = True):
    """Checks shared by ``isj sweep`` and ``isj ear sweep``: (out dir, calibration, materials, fe freq).

    Everything is checked here, before any model is built: the band (its top within ``model``'s,
    ``"chain"`` or ``"ear"``: :data:`isj.validate.BAND_LIMITS`), the damping over it, the
    counts, the output folder (new, empty, or one holding only ``files``: it is replaced as a
    whole) and the calibration. Without ``--nu``, ν is the calibration's (``lumped``: the lumped
    model runs, :func:`isj._cli.lumped.check_nu`), else the default design's.
    """
    from isj.studies.sweeps import fe_check_frequencies
    from isj.validate import check_band

    check_band(args.fmin_hz, args.fmax_hz, ("--fmin-hz", "--fmax-hz"), model)
    check_rayleigh(args)
    if not 0 <= args.fe_checks <= 50:
        raise UsageError(f"--fe-checks = {args.fe_checks}: must be an integer in [0, 50]")
    out = c.check_out_dir(args.out, "--out", files)
    cal = c.load_calibration(args.calibration)
    if args.nu is None:
        from .lumped import calibrated_nu

        args.nu = calibrated_nu(cal) if lumped else c.DEFAULT_NU
    fe_freq = fe_check_frequencies(args.fmin_hz, args.fmax_hz, args.fe_checks)
    return out, cal, c.materials(args), fe_freq


def check_sweep_finite(sw, args, *extra) -> None:
    """The lumped sweep's response, natural frequencies and damping ratios are finite (else exit 2)."""
    inputs = f"{c.design_inputs(args)}, {damping_inputs(args)}"
    values = {"natural_freq_hz": sw.natural_freq_hz, "damping_ratio": sw.damping_ratio}
    c.check_finite(values | {"response": sw.response, **dict(extra)}, inputs)


def register(sub) -> None:
    """Add ``isj sweep`` to the top-level subparsers ``sub``."""
    p = sub.add_parser("sweep", help="damped frequency response: lumped curves, FE spot checks")
    c.add_design_options(p)
    c.add_mesh_options(p)
    add_band_options(p)
    p.add_argument(
        "--fe-checks", type=int, default=2, help="FE harmonic spot checks K, in [0, 50] (default 2)"
    )
    p.add_argument(
        "--tolerance",
        type=c.float_option("--tolerance", lo=0.0),
        default=0.05,
        help="largest relative error of an FE check (default 0.05)",
    )
    add_damping_options(p)
    p.add_argument(
        "--out",
        metavar="DIR",
        default="sweep",
        help="output folder (default ./sweep): new, empty or a previous sweep's, replaced as a whole",
    )
    from .lumped import add_joint_option

    add_joint_option(p)
    c.add_json_option(p)
    p.set_defaults(func=sweep, nu=None)  # None: the calibration's (check_nu)


def sweep(args) -> int:
    import numpy as np

    from isj.calibration.checks import warn_outside_domain
    from isj.studies.sweeps import chain_sweep

    from ..atomic import replace_dir
    from ..provenance import write_run_record
    from .lumped import check_nu

    out, cal, m, fe_freq = sweep_setup(args, SWEEP_FILES)
    geometry = c.geometry(args)
    if args.joint is not None and args.joint != cal.joint:  # the chain of the sliding joint's calibration
        if args.calibration:
            raise UsageError(f"--joint = {args.joint}: --calibration was fitted with the {cal.joint} joint")
        from isj.lumped.artifact import calibration_for

        cal = calibration_for(None, args.joint)
    check_nu(cal, args.nu)
    if fe_freq.size:  # the FE model of the spot checks, before any is built
        c.check_solver(args.solver)
        c.check_model_size(geometry, args.order, args.resolution)
        c.check_caches(args, "mesh")
    warn_outside_domain(cal, c.moduli(m))
    damping = damping_from_args(args)
    sw = chain_sweep(
        cal,
        np.geomspace(args.fmin_hz, args.fmax_hz, args.n),
        m,
        geometry,
        damping=damping,
        pressure_pa=args.pressure,
    )
    check_sweep_finite(sw, args)
    keys = sw.outputs[:2]  # α and β: the incus face's u_x follows from them
    checks = _fe_checks(args, cal, geometry, m, damping, sw, fe_freq, keys) if fe_freq.size else []
    summary = {
        "n_freq": int(args.n),
        "joint": cal.joint,
        "natural_freq_hz": [float(v) for v in sw.natural_freq_hz],
        "damping_ratio": [float(v) for v in sw.damping_ratio],
        "damping": damping.to_dict(),
        "fe_checks": checks,
        # a check that is not finite never passes (check_sweep_finite refused the lumped side)
        "passed": all(ck["passed"] for ck in checks),
        "tolerance": args.tolerance,
    }
    c.check_finite(summary, c.design_inputs(args))
    with replace_dir(out) as staging:  # the four files appear together or not at all
        _write(args, staging, sw, fe_freq, checks)
        write_run_record(staging / "sweep.json", args, summary)
    if args.json:
        c.print_json(summary)
    else:
        _print_sweep(args, out, sw, checks)
    if not summary["passed"]:
        return c.fail(f"an FE check exceeds the tolerance {args.tolerance:g}")
    return 0


def _fe_checks(args, cal, geometry, m, damping, sw, fe_freq, keys) -> list[dict]:
    """The FE harmonic spot checks of the lumped chain at ``fe_freq`` (Hz), one row each."""
    from isj.calibration.checks import warn_fe_settings
    from isj.fem.dynamics import harmonic_outputs
    from isj.fem.model import PedicleJointModel

    warn_fe_settings(cal, args.order, args.resolution)
    fem_model = PedicleJointModel(geometry, args.order, args.resolution, solver=args.solver, joint=cal.joint)

    def fe_response(f):
        return harmonic_outputs(fem_model, f, m, damping, args.pressure)

    comp = sw.fe_checks(fe_freq, fe_response, keys)
    passed = comp.passed(args.tolerance)
    checks = []
    for i, f in enumerate(comp.freq_hz):
        fe = comp.fe[i]
        checks.append(
            {
                "freq_hz": float(f),
                **{f"fe_{k}": [float(fe[j].real), float(fe[j].imag)] for j, k in enumerate(keys)},
                **{f"{k}_rel_error": e for k, e in comp.errors(i).items()},
                "passed": bool(passed[i]),
            }
        )
    return checks


def _print_sweep(args, out, sw, checks) -> None:
    """The sweep's report lines: the chain's modes, each FE check, the files written."""
    modes = zip(sw.natural_freq_hz, sw.damping_ratio, strict=True)
    print(
        f"lumped sweep {args.fmin_hz:g}-{args.fmax_hz:g} Hz ({args.n} points); natural frequencies "
        + ", ".join(f"{v:.0f} Hz (zeta {z:.2f})" for v, z in modes)
    )
    for ck in checks:
        print(
            f"  FE check at {ck['freq_hz']:.0f} Hz: alpha {100 * ck['alpha_rad_rel_error']:.2f} %, "
            f"beta {100 * ck['beta_rad_rel_error']:.2f} % {'ok' if ck['passed'] else 'EXCEEDS tolerance'}"
        )
    print(f"wrote {out}/sweep.csv, sweep.npz, bode.png, sweep.json")


def _write(args, out, sw, fe_freq, checks) -> None:
    """sweep.csv, sweep.npz and bode.png (sweep.json comes last, with the summary)."""
    import numpy as np

    from isj.lumped.plots import save_bode

    from ._output import write_npz, write_response_csv

    units = f"freq_hz Hz; alpha_rad, beta_rad rad; incus_ux_m m; phase deg; pressure {args.pressure:g} Pa"
    write_response_csv(out / "sweep.csv", sw.freq_hz, sw.response, sw.outputs, units)
    write_npz(
        out / "sweep.npz",
        freq_hz=sw.freq_hz,
        response=sw.response,
        outputs=np.array(sw.outputs),
        fe_freq_hz=np.asarray(fe_freq),
        units=np.array("freq_hz: Hz; alpha_rad, beta_rad: rad; incus_ux_m: m"),
    )
    save_bode(out / "bode.png", sw.freq_hz, sw.response, checks)
