"""``isj report``: run the pipeline (cached steps) and write the PDF report with its data files."""

from __future__ import annotations

from pathlib import Path

from isj.errors import UsageError


def register(sub) -> None:
    """Add ``isj report`` to the top-level subparsers ``sub``."""
    p = sub.add_parser("report", help="run the pipeline and write the PDF report")
    p.add_argument("--config", metavar="CASE.toml", help="TOML case file (default: built-in defaults)")
    p.add_argument(
        "--out",
        metavar="DIR",
        default="report",
        help="output folder (default ./report): new, empty or a previous report, replaced as a whole",
    )
    p.add_argument(
        "--set",
        metavar="SECTION.KEY=VALUE",
        action="append",
        help="override one key of the case file, e.g. design.pedicle_e_pa=12e9 (repeatable)",
    )
    verb = p.add_mutually_exclusive_group()
    verb.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    verb.add_argument("-v", "--verbose", action="count", default=0, help="timings and cache keys")
    p.set_defaults(func=report)


def report(args) -> int:
    from isj.caches import check_cache_dirs
    from isj.errors import ConfigError, CorruptCalibration
    from isj.reports.config import load_config
    from isj.reports.run import check_out_dir, load_calibration, run_report

    # everything is validated before the output folder is created: the folder (new, empty or a
    # previous report; a place where a folder can be made), the configuration, the calibration
    check_out_dir(args.out, "--out")
    check_cache_dirs("mesh", "fe", "rom", "report")
    try:
        config = load_config(args.config, args.set or [])
        calibration = load_calibration(config)
    except (ConfigError, CorruptCalibration) as exc:
        raise UsageError(str(exc)) from None
    verbosity = 0 if args.quiet else 1 + args.verbose
    run_report(config, Path(args.out), verbosity=verbosity, calibration=calibration, out_name="--out")
    return 0
