"""What every command shares: the parser class, option helpers, output-path checks, messages.

Bad input raises :class:`~isj.errors.UsageError` (or another ValueError-like
:class:`~isj.errors.IsjError`); :func:`isj._cli._main.main` prints it as one
line, ``isj: error: ...``, and returns exit code 2. Every check here runs
before any computation, so a refused command writes nothing.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import math
import sys
import warnings
from pathlib import Path

from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials
from isj.errors import IsjWarning, UsageError

#: Exit code of a refused command line.
EXIT_USAGE = 2

#: Regions with a ``--<region>-e`` option, in option order.
MODULUS_OPTIONS = ("pedicle", "gap", "capsule", "plate", "stapes", "incus")


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line (``isj: error: ...``) and exit 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise UsageError(message)


def float_option(name: str, lo: float = -math.inf, hi: float = math.inf, lo_open=True, hi_open=True):
    """argparse ``type`` for a finite float in an interval; the message names ``name`` and the range."""

    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: not a number") from None
        ok = math.isfinite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
        if not ok:
            rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
            raise argparse.ArgumentTypeError(f"{name} = {text}: must be a finite number in {rng}")
        return v

    return parse


def range_option(name: str):
    """argparse ``type`` for ``PA`` or ``LOW:HIGH`` (Pa, > 0, LOW <= HIGH) → (low, high)."""

    def parse(text: str) -> tuple[float, float]:
        lo_txt, sep, hi_txt = text.partition(":")
        lo = float_option(name, lo=0.0)(lo_txt)
        hi = float_option(name, lo=0.0)(hi_txt) if sep else lo
        if hi < lo:
            raise argparse.ArgumentTypeError(f"{name} = {text}: LOW:HIGH needs LOW <= HIGH")
        return lo, hi

    return parse


def nu_option(p: argparse.ArgumentParser, whose: str = "model") -> None:
    """``--nu``: Poisson's ratio in (-1, 0.5)."""
    p.add_argument(
        "--nu",
        type=float_option("--nu", -1.0, 0.5),
        default=Materials().nu,
        help=f"Poisson's ratio of the {whose}, in (-1, 0.5) (default {Materials().nu})",
    )


def pressure_option(p: argparse.ArgumentParser, where: str = "the incus's -x face") -> None:
    """``--pressure``: the static load (Pa)."""
    p.add_argument(
        "--pressure",
        metavar="PA",
        type=float_option("--pressure"),
        default=DEFAULT_PRESSURE_PA,
        help=f"pressure on {where} (Pa; default {DEFAULT_PRESSURE_PA:g})",
    )


def add_moduli_options(p: argparse.ArgumentParser, whose: str = "") -> None:
    """``--<region>-e`` for each region of the joint model, and ``--nu``."""
    d = Materials()
    for r in MODULUS_OPTIONS:
        p.add_argument(
            f"--{r}-e",
            metavar="PA",
            type=float_option(f"--{r}-e", lo=0.0),
            default=d.youngs(r),
            help=f"Young's modulus of the {whose}{r} (Pa, > 0; default {d.youngs(r):g})",
        )
    nu_option(p, whose.removesuffix("'s ") or "model")


def add_design_options(p: argparse.ArgumentParser) -> None:
    """The moduli, ``--nu`` and ``--pressure``."""
    add_moduli_options(p)
    pressure_option(p)


def add_order_resolution(p: argparse.ArgumentParser, what: str = "mesh") -> None:
    """``--order {1,2}`` and ``--resolution R``."""
    p.add_argument("--order", type=int, choices=(1, 2), default=2, help="P1 or P2 tetrahedra (default 2)")
    p.add_argument(
        "--resolution",
        metavar="R",
        type=float_option("--resolution", lo=0.0),
        default=1.0,
        help=f"{what} refinement factor, > 0: 2 halves every element size (default 1)",
    )


def add_mesh_options(p: argparse.ArgumentParser) -> None:
    """``--geometry``, ``--order``, ``--resolution`` and ``--solver``."""
    add_geometry_option(p)
    add_order_resolution(p)
    p.add_argument(
        "--solver",
        choices=("auto", "cholmod", "pardiso", "superlu"),
        default="auto",
        help="sparse direct solver (default: fastest installed)",
    )


def _geometry_option(text: str) -> tuple[str, float]:
    names = [f.name for f in dataclasses.fields(Geometry)]
    key, sep, value = text.partition("=")
    if not sep or key not in names:
        raise argparse.ArgumentTypeError(
            f"--geometry {text!r}: must be NAME=METRES with NAME one of {', '.join(names)}"
        )
    try:
        return key, float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--geometry {key} = {value!r}: not a number") from None


def add_geometry_option(p: argparse.ArgumentParser) -> None:
    """``--geometry NAME=M`` (repeatable)."""
    p.add_argument(
        "--geometry",
        metavar="NAME=M",
        type=_geometry_option,
        action="append",
        default=[],
        help="override a dimension (m), e.g. pedicle_x_m=60e-6; repeatable",
    )


def add_json_option(p: argparse.ArgumentParser, what: str = "one JSON object") -> None:
    p.add_argument("--json", action="store_true", help=f"print {what}")


def add_calibration_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--calibration", metavar="PATH", help="calibration file (default: the shipped one)")


def add_cache_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--cache", metavar="DIR", help="FE result cache (default ~/.cache/isj/fe)")


def geometry(args) -> Geometry:
    """The :class:`Geometry` of ``--geometry`` overrides."""
    return Geometry(**dict(args.geometry))


def materials(args) -> Materials:
    """The :class:`Materials` of the ``--<region>-e`` options and ``--nu``."""
    return Materials(**{f"{r}_e_pa": getattr(args, f"{r}_e") for r in MODULUS_OPTIONS}, nu=args.nu)


def moduli(m: Materials) -> dict[str, float]:
    """The Young's moduli of ``m`` (Pa) by ``<region>_e_pa``, in option order."""
    return {f"{r}_e_pa": m.youngs(r) for r in MODULUS_OPTIONS}


def check_out_path(path: str | None, flag: str, suffix: str) -> Path | None:
    """``path`` as a Path (None stays None), refused unless it ends in ``suffix`` and is no folder."""
    if path is None:
        return None
    p = Path(path)
    if p.suffix.lower() != suffix:
        raise UsageError(f"{flag} = {path!r}: must end in {suffix}")
    if p.exists() and p.is_dir():
        raise UsageError(f"{flag} = {path!r}: is a directory")
    return p


def check_out_dir(path: str, flag: str = "--out") -> Path:
    """An output folder: refused when something that is not a folder is there."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise UsageError(f"{flag} = {path!r}: exists and is not a directory")
    return out


def load_calibration(path: str | None):
    """The calibration at ``path`` (default: the shipped one); a bad file is a usage error."""
    from isj.lumped.artifact import Calibration, CorruptCalibration, default_calibration

    try:
        return Calibration.load(path) if path else default_calibration()
    except CorruptCalibration as exc:
        raise UsageError(str(exc)) from None


def urad(x: float) -> str:
    """An angle (rad) in µrad, fixed width."""
    return f"{x * 1e6:9.4f}"


def fail(message: str) -> int:
    """Print ``isj: error: message`` (a check that ran and failed) and return exit code 1."""
    print(f"isj: error: {message}", file=sys.stderr)
    return 1


@contextlib.contextmanager
def isj_warnings_as_lines():
    """Show every :class:`~isj.errors.IsjWarning` as one ``isj: warning: ...`` line on stderr.

    Always, not once per place: a second command run in the same process (a test, a notebook)
    must warn again. Other warnings keep Python's format.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("always", IsjWarning)
        shown = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, IsjWarning):
                print(f"isj: warning: {message}", file=sys.stderr)
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield
