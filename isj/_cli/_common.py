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
import json
import math
import os
import socket
import sys
import warnings
from pathlib import Path
from urllib.parse import urlsplit

from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials
from isj.errors import InvalidParameter, IsjWarning, UsageError
from isj.validate import MODULUS_RANGE_PA, PRESSURE_RANGE_PA

#: Exit code of a refused command line.
EXIT_USAGE = 2

#: Regions with a ``--<region>-e`` option, in option order.
MODULUS_OPTIONS = ("pedicle", "gap", "capsule", "plate", "stapes", "incus")

#: ``--resolution`` (and ``--resolutions``) range: at 0.1 every element is ten times its default
#: size (coarser than the parts it meshes); 8 would give a P2 joint model of about 18 million
#: dofs. Inside the range, :func:`check_model_size` refuses a model whose estimated memory
#: exceeds :data:`isj.fem.sizing.MAX_MODEL_BYTES`.
RESOLUTION_RANGE = (0.1, 8.0)

#: Largest ``--seed``: numpy's generators take any integer >= 0; 32 bits is far beyond any use.
MAX_SEED = 2**32 - 1


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line (``isj: error: ...``) and exit 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        # "argument --n: --n = 0: ..." -> "--n = 0: ...": our option types name the option already
        head, sep, rest = message.partition(": ")
        if (
            sep
            and head.startswith("argument ")
            and rest.startswith(head.removeprefix("argument ").split("/")[0])
        ):
            message = rest
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


def int_option(name: str, lo: int, hi: int):
    """argparse ``type`` for an integer in [lo, hi]; the message names ``name`` and the range."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: not an integer") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{name} = {text}: must be an integer in [{lo}, {hi}]")
        return v

    return parse


def modulus_option(name: str):
    """argparse ``type`` for a Young's modulus (Pa) in :data:`isj.validate.MODULUS_RANGE_PA`."""
    return float_option(name, *MODULUS_RANGE_PA, lo_open=False, hi_open=False)


def seed_option(p: argparse.ArgumentParser, what: str) -> None:
    """``--seed``: an integer in [0, 2^32 - 1]."""
    p.add_argument(
        "--seed",
        type=int_option("--seed", 0, MAX_SEED),
        default=0,
        help=f"seed of {what}, an integer in [0, {MAX_SEED}] (default 0)",
    )


def range_option(name: str):
    """argparse ``type`` for ``PA`` or ``LOW:HIGH`` (Pa, in the modulus range, LOW <= HIGH) → (low, high)."""

    def parse(text: str) -> tuple[float, float]:
        lo_txt, sep, hi_txt = text.partition(":")
        lo = modulus_option(name)(lo_txt)
        hi = modulus_option(name)(hi_txt) if sep else lo
        if hi < lo:
            raise argparse.ArgumentTypeError(f"{name} = {text}: LOW:HIGH needs LOW <= HIGH")
        return lo, hi

    return parse


#: The default design's Poisson's ratio.
DEFAULT_NU = Materials().nu


def nu_option(p: argparse.ArgumentParser, whose: str = "model", default=DEFAULT_NU, help=None) -> None:
    """``--nu``: Poisson's ratio in (-1, 0.5)."""
    p.add_argument(
        "--nu",
        type=float_option("--nu", -1.0, 0.5),
        default=default,
        help=help or f"Poisson's ratio of the {whose}, in (-1, 0.5) (default {Materials().nu})",
    )


def pressure_option(p: argparse.ArgumentParser, where: str = "the incus's -x face") -> None:
    """``--pressure``: the static load (Pa), in :data:`isj.validate.PRESSURE_RANGE_PA`."""
    lo, hi = PRESSURE_RANGE_PA
    p.add_argument(
        "--pressure",
        metavar="PA",
        type=float_option("--pressure", lo, hi, lo_open=False, hi_open=False),
        default=DEFAULT_PRESSURE_PA,
        help=f"pressure on {where} (Pa, in [{lo:g}, {hi:g}]; default {DEFAULT_PRESSURE_PA:g})",
    )


def add_moduli_options(p: argparse.ArgumentParser, whose: str = "", nu: bool = True) -> None:
    """``--<region>-e`` for each region of the joint model, and ``--nu`` (unless ``nu`` is false)."""
    d = Materials()
    lo, hi = MODULUS_RANGE_PA
    for r in MODULUS_OPTIONS:
        p.add_argument(
            f"--{r}-e",
            metavar="PA",
            type=modulus_option(f"--{r}-e"),
            default=d.youngs(r),
            help=f"Young's modulus of the {whose}{r} (Pa, in [{lo:g}, {hi:g}]; default {d.youngs(r):g})",
        )
    if nu:
        nu_option(p, whose.removesuffix("'s ") or "model")


def add_design_options(p: argparse.ArgumentParser) -> None:
    """The moduli, ``--nu`` and ``--pressure``."""
    add_moduli_options(p)
    pressure_option(p)


def add_order_resolution(p: argparse.ArgumentParser, what: str = "mesh") -> None:
    """``--order {1,2}`` and ``--resolution R``."""
    p.add_argument("--order", type=int, choices=(1, 2), default=2, help="P1 or P2 tetrahedra (default 2)")
    lo, hi = RESOLUTION_RANGE
    p.add_argument(
        "--resolution",
        metavar="R",
        type=resolution_option("--resolution"),
        default=1.0,
        help=f"{what} refinement factor in [{lo:g}, {hi:g}]: 2 halves every element size (default 1); "
        "a model whose estimated memory is over the limit (isj.fem.sizing, 16 GiB) is refused",
    )


def resolution_option(name: str):
    """argparse ``type`` for a mesh resolution factor in :data:`RESOLUTION_RANGE`."""
    return float_option(name, *RESOLUTION_RANGE, lo_open=False, hi_open=False)


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
    """The :class:`Geometry` of ``--geometry`` overrides; a dimension out of bounds is one line.

    A dimension given twice is refused: neither value would be the obvious one to use.
    """
    seen = {}
    for key, value in args.geometry:
        if key in seen:
            raise UsageError(
                f"--geometry {key}: given twice ({seen[key]:g} and {value:g} m); give each dimension once"
            )
        seen[key] = value
    try:
        return Geometry(**dict(args.geometry))
    except InvalidParameter as exc:  # names the field and its range (isj.design.GEOMETRY_BOUNDS_M)
        raise UsageError(f"--geometry {exc}") from None


def materials(args) -> Materials:
    """The :class:`Materials` of the ``--<region>-e`` options and ``--nu``."""
    return Materials(**{f"{r}_e_pa": getattr(args, f"{r}_e") for r in MODULUS_OPTIONS}, nu=args.nu)


def moduli(m: Materials) -> dict[str, float]:
    """The Young's moduli of ``m`` (Pa) by ``<region>_e_pa``, in option order."""
    return {f"{r}_e_pa": m.youngs(r) for r in MODULUS_OPTIONS}


def check_model_size(geometry: Geometry | None, order: int, resolution: float, flag: str = "--resolution"):
    """Refuse, before meshing, a joint model whose estimated memory exceeds the limit.

    The estimate is :func:`isj.fem.sizing.estimate_mesh_size` (no gmsh); the message names ``flag``,
    the estimate and the largest resolution that fits.
    """
    from isj.fem.sizing import check_mesh_size

    try:
        return check_mesh_size(geometry, order, resolution, name=flag)
    except InvalidParameter as exc:
        raise UsageError(str(exc)) from None


def check_caches(args, *kinds: str) -> None:
    """Refuse, before any work, a cache this command uses that cannot be used.

    ``kinds`` among :data:`isj.caches.CACHE_KINDS`; the FE result cache is ``--cache`` when the
    command has it and it is given (:func:`isj.caches.check_cache_dirs`).
    """
    from isj.caches import check_cache_dirs

    check_cache_dirs(*kinds, fe_path=getattr(args, "cache", None))


def check_solver(name: str) -> None:
    """``--solver``: refused before meshing unless it is ``auto`` or installed here."""
    from isj.fem.solvers import available_backends

    have = available_backends()
    if name != "auto" and name not in have:
        raise UsageError(f"--solver = {name!r}: not installed here; must be auto or one of {', '.join(have)}")


def check_writable_place(p: Path, flag: str, text: str) -> None:
    """Refuse ``p`` (absolute) unless its folder exists and is writable or can be created.

    The nearest existing folder above ``p`` must be a writable folder (:func:`os.access`), and
    since that says yes to root everywhere, an empty folder is also made there and removed at
    once (:func:`isj.atomic.check_writable_place`): nothing is left behind.
    """
    from isj.atomic import check_writable_place as check

    check(p, flag, text, error=UsageError)


def check_out_path(path: str | None, flag: str, suffixes: str | tuple[str, ...]) -> Path | None:
    """An output file, checked before anything runs; None stays None.

    Refused: an empty name, a name not ending in one of ``suffixes``, a folder, a place that
    cannot be written (:func:`check_writable_place`).
    """
    if path is None:
        return None
    suffixes = (suffixes,) if isinstance(suffixes, str) else tuple(suffixes)
    if not path.strip():
        raise UsageError(f"{flag} = {path!r}: must name a file ending in {' or '.join(suffixes)}")
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise UsageError(f"{flag} = {path!r}: must be a file ending in {' or '.join(suffixes)}")
    if p.is_dir():
        raise UsageError(f"{flag} = {path!r}: is a folder; must be a file ending in {' or '.join(suffixes)}")
    check_writable_place(Path(os.path.abspath(path)), flag, path)
    return p


def check_out_dir(path: str, flag: str = "--out", entries: frozenset[str] | None = None) -> Path:
    """An output folder, checked before anything runs.

    Refused: an empty name, something that is not a folder, a place where no folder can be made;
    and when ``entries`` is given (the folder is replaced as a whole, :func:`isj.atomic.replace_dir`)
    also the current folder or one above it, a symbolic link, and a folder holding anything else
    (one check for every command and the report: :func:`isj.atomic.check_out_folder`).
    """
    from isj.atomic import check_out_folder

    check_out_folder(path, flag, entries, error=UsageError)
    return Path(path)


def print_json(obj) -> None:
    """Print ``obj`` as JSON; a NaN or infinity is a bug here (:func:`check_finite` runs first)."""
    print(json.dumps(obj, allow_nan=False))


def _non_finite(obj, where: str = ""):
    """The first (path, value) in ``obj`` (dicts, lists, numbers) that is a non-finite number."""
    if isinstance(obj, dict):
        items = ((f"{where}.{k}" if where else str(k), v) for k, v in obj.items())
    elif isinstance(obj, list | tuple):
        items = ((f"{where}[{i}]", v) for i, v in enumerate(obj))
    elif isinstance(obj, float) and not math.isfinite(obj):
        return where, obj
    else:
        try:  # numpy arrays and scalars
            import numpy as np

            a = np.asarray(obj)
            if a.dtype.kind in "fc" and not np.all(np.isfinite(a)):
                return where, a.ravel()[~np.isfinite(a.ravel())][0]
        except (TypeError, ValueError):
            pass
        return None
    for k, v in items:
        bad = _non_finite(v, k)
        if bad is not None:
            return bad
    return None


def check_finite(result, inputs: str) -> None:
    """Refuse a result holding NaN or infinity: one line naming the value and the inputs (exit 2).

    The second line of defence behind the input ranges: a result that is not finite is never
    printed or written. ``inputs`` names the options the result came from.
    """
    bad = _non_finite(result)
    if bad is not None:
        raise UsageError(
            f"the result {bad[0]} = {bad[1]} is not finite: the inputs ({inputs}) are outside what "
            "the model can compute; nothing was written"
        )


def design_inputs(args) -> str:
    """The design options of ``args`` as ``--pedicle-e 5e+09, ...`` for :func:`check_finite`."""
    names = [f"{r}-e" for r in MODULUS_OPTIONS] + ["nu", "pressure", "drum-e"]
    values = {n: getattr(args, n.replace("-", "_"), None) for n in names}
    return ", ".join(f"--{n} {v:g}" for n, v in values.items() if isinstance(v, int | float)) or "defaults"


#: Seconds :func:`check_scheduler` waits for a Dask scheduler to accept a connection.
SCHEDULER_TIMEOUT_S = 3.0


def check_scheduler(address: str | None, timeout_s: float = SCHEDULER_TIMEOUT_S) -> None:
    """``--scheduler``: a ``tcp://HOST:PORT`` (or ``tls://``, or bare ``HOST:PORT``) that accepts a
    connection within ``timeout_s``; checked before any work, so a wrong address is one line."""
    if address is None:
        return
    rule = "must be tcp://HOST:PORT (or tls://HOST:PORT) of a running Dask scheduler"
    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host = port = None
    if parts.scheme not in ("tcp", "tls") or not host or port is None:
        raise UsageError(f"--scheduler = {address!r}: {rule}")
    try:
        socket.create_connection((host, port), timeout=timeout_s).close()
    except OSError as exc:
        why = "no answer" if isinstance(exc, TimeoutError) else (exc.strerror or str(exc))
        raise UsageError(
            f"--scheduler = {address!r}: no scheduler reachable at {host}:{port} within {timeout_s:g} s "
            f"({why}); {rule}"
        ) from None


def load_calibration(path: str | None):
    """The calibration at ``path`` (default: the shipped one); a bad file is a usage error."""
    from isj.errors import CorruptCalibration
    from isj.lumped.artifact import Calibration, default_calibration

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
    """Show every warning as one ``isj: warning: ...`` line on stderr.

    An :class:`~isj.errors.IsjWarning` always, not once per place: a second command run in the
    same process (a test, a notebook) must warn again. A library's warning (scipy's, numpy's)
    keeps Python's filters but is shown on one line too, its category after it, instead of
    Python's two lines (file, line number and source).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("always", IsjWarning)

        def show(message, category, filename, lineno, file=None, line=None):
            text = " ".join(str(message).split())
            if not issubclass(category, IsjWarning):
                text = f"{text} ({category.__name__})"
            print(f"isj: warning: {text}", file=sys.stderr)

        warnings.showwarning = show
        yield
