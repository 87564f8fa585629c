"""Checks of inputs shared by every model: frequencies and Poisson's ratios.

Each check raises :class:`~isj.errors.InvalidParameter` with one line naming
the parameter and its valid range, and returns the value in the form the
models compute with. The FE chain, the lumped chain, the FE ear and the lumped
ear all check frequencies here, so they agree on what they refuse (an empty
list included).
"""

from __future__ import annotations

import math

import numpy as np

from isj.errors import InvalidParameter


def check_frequencies(freq_hz, name: str = "freq_hz") -> np.ndarray:
    """Frequencies (Hz) as a 1-D float array, refusing anything a response cannot be computed at.

    Parameters
    ----------
    freq_hz : float or sequence of float
        One frequency or several (Hz), each finite and >= 0 (0 Hz is the static response).
    name : str
        Parameter name for the message.

    Returns
    -------
    numpy.ndarray
        Shape (n,), n >= 1, float.

    Raises
    ------
    InvalidParameter
        Empty input, more than one dimension, a non-number, a non-finite or negative value.
    """
    rule = "must be one or more finite numbers >= 0 (Hz)"
    try:
        f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    except (TypeError, ValueError):
        raise InvalidParameter(f"{name}: {type(freq_hz).__name__} {rule}") from None
    if f.ndim != 1 or f.size == 0 or not np.all(np.isfinite(f)) or np.any(f < 0):
        # the offending value, not the whole array: the message stays one short line
        bad = f.ravel()[~(np.isfinite(f.ravel()) & (f.ravel() >= 0))]
        shown = "empty" if f.size == 0 else f"shape {f.shape}" if f.ndim != 1 else f"holds {float(bad[0])!r}"
        raise InvalidParameter(f"{name} {shown}: {rule}")
    return f


#: Highest frequency of the whole ear, FE and lumped (Hz): the lumped drum's 300 shipped
#: fixed-interface modes end at 26.4 kHz (docs/ear.md §5.10), and a drum agrees with the FE ear
#: only to about its highest kept mode; the FE ear's reduction is checked against direct solves
#: to 20 kHz, and its default drum (0.125 mm) agrees with the finest drum measured (0.075 mm)
#: within 1 dB in H_V only to 19.1 kHz (docs/ear.md §5.15). The report's transmission stops here
#: too (docs/transmission.md §12.7).
EAR_FMAX_HZ = 24e3

#: Range [lo, hi] of the FE eardrum's element size (m) the report accepts: above 0.4 mm the
#: default anatomy's manubrium gap (0.4 mm) is not resolved (fem.ear.eardrum's own check); below
#: 0.05 mm the drum has about 38,000 triangles, past the finest drum measured (0.075 mm, 16,824
#: triangles, docs/ear.md §5.15).
DRUM_MESH_SIZE_RANGE_M = (0.05e-3, 0.4e-3)

#: Ranges [lo, hi] of the counts of ΔH_V's uncertainty through the fast ear (docs/uq.md §11.10):
#: Monte Carlo draws, and Saltelli base samples (also a power of 2); ``isj uq`` and the report.
TRANSMISSION_SAMPLES_RANGE = (100, 1_000_000)
TRANSMISSION_SOBOL_SAMPLES_RANGE = (2**6, 2**14)
#: Highest frequency of the isolated joint model's lumped chain (Hz). Its first two in-plane
#: natural frequencies were compared with FE (19.9 and 120 kHz on the base design, the second
#: within 0.6 %, docs/dynamics.md §4.9); nothing of it above the second. 100 kHz lies below
#: that second one on the base design: an estimate of where the comparison still holds.
CHAIN_FMAX_HZ = 100e3
#: Each band's top (Hz) and why it stops there, for the messages.
BAND_LIMITS = {
    "ear": (
        EAR_FMAX_HZ,
        "the lumped drum's shipped modes end at 26.4 kHz and the FE ear is checked to 20 kHz "
        "(docs/ear.md 5.10, 5.14)",
    ),
    "chain": (
        CHAIN_FMAX_HZ,
        "the lumped chain was compared with FE up to its second natural frequency, 120 kHz on "
        "the base design (docs/dynamics.md 4.9)",
    ),
}


def check_band(
    fmin_hz: float,
    fmax_hz: float,
    names: tuple[str, str] = ("fmin_hz", "fmax_hz"),
    model: str | None = None,
) -> None:
    """A frequency band: both ends finite with 0 < fmin < fmax (Hz), fmax within the model's band.

    Parameters
    ----------
    fmin_hz, fmax_hz : float
        Lowest and highest frequency (Hz).
    names : (str, str)
        Parameter names for the message (``("--fmin-hz", "--fmax-hz")`` on the command line).
    model : ``"ear"`` or ``"chain"`` (:data:`BAND_LIMITS`), or None for no upper limit.
    """
    ok = all(isinstance(v, int | float) and not isinstance(v, bool) for v in (fmin_hz, fmax_hz))
    if not ok or not (math.isfinite(fmin_hz) and math.isfinite(fmax_hz) and 0 < fmin_hz < fmax_hz):
        raise InvalidParameter(
            f"{names[0]}/{names[1]} = {fmin_hz!r}/{fmax_hz!r}: need finite 0 < fmin < fmax (Hz)"
        )
    if model is not None:
        limit, why = BAND_LIMITS[model]
        if fmax_hz > limit:
            raise InvalidParameter(f"{names[1]} = {fmax_hz:g}: must be <= {limit:g} Hz; {why}")


#: Largest Rayleigh term over a band: ωb at its highest frequency and a/ω at its lowest. At 100
#: the damping force is a hundred times the elastic (or inertial) one, so the response is the
#: damping law's, not the structure's (the defaults give ωb = 12.6 at 20 kHz); far past it
#: (b = 1e300) the damped stiffness overflows and the damping ratios come out NaN.
MAX_RAYLEIGH_TERM = 100.0
#: Largest structural loss factor: the lossiest solids (polymers in their glass transition) reach
#: about 2, the middle ear's soft tissues about 0.3.
MAX_LOSS_FACTOR = 10.0


def check_damping(damping, fmin_hz: float, fmax_hz: float, names: dict[str, str] | None = None) -> None:
    """Every loss factor <= :data:`MAX_LOSS_FACTOR`, every Rayleigh term <= :data:`MAX_RAYLEIGH_TERM`
    over [fmin_hz, fmax_hz].

    Parameters
    ----------
    damping : :class:`isj.damping.Damping`
    fmin_hz, fmax_hz : the band (Hz)
    names : how the message names ``loss_factor``, ``rayleigh_a``, ``rayleigh_b``, ``fmin`` and
        ``fmax`` (default: the command line's ``--loss-factor``, ..., ``--fmax-hz``).
    """
    n = {
        "loss_factor": "--loss-factor",
        "rayleigh_a": "--rayleigh-a",
        "rayleigh_b": "--rayleigh-b",
        "fmin": "--fmin-hz",
        "fmax": "--fmax-hz",
    } | dict(names or {})
    name, eta = max(damping.loss_factor.items(), key=lambda kv: kv[1])
    if eta > MAX_LOSS_FACTOR:
        raise InvalidParameter(f"{n['loss_factor']} {name}={eta:g}: must be in [0, {MAX_LOSS_FACTOR:g}]")
    w_min, w_max = 2 * math.pi * fmin_hz, 2 * math.pi * fmax_hz
    name, b = max(damping.rayleigh_b_s.items(), key=lambda kv: kv[1])
    if b * w_max > MAX_RAYLEIGH_TERM:
        raise InvalidParameter(
            f"{n['rayleigh_b']} {name}={b:g} s: omega b = {b * w_max:.3g} at {n['fmax']} "
            f"{fmax_hz:g}; must be <= {MAX_RAYLEIGH_TERM:g} over the band, i.e. {n['rayleigh_b']} "
            f"<= {MAX_RAYLEIGH_TERM / w_max:.3g} s"
        )
    name, a = max(damping.rayleigh_a_per_s.items(), key=lambda kv: kv[1])
    if a / w_min > MAX_RAYLEIGH_TERM:
        raise InvalidParameter(
            f"{n['rayleigh_a']} {name}={a:g} 1/s: a/omega = {a / w_min:.3g} at {n['fmin']} "
            f"{fmin_hz:g}; must be <= {MAX_RAYLEIGH_TERM:g} over the band, i.e. {n['rayleigh_a']} "
            f"<= {MAX_RAYLEIGH_TERM * w_min:.3g} 1/s"
        )


def check_poisson(nu, name: str = "nu") -> float:
    """Poisson's ratio as a float, refusing booleans, non-numbers and values outside (-1, 0.5).

    Parameters
    ----------
    nu : float
        Poisson's ratio (dimensionless); -1 and 0.5 bound the ratios of a stable isotropic solid.
    name : str
        Parameter name for the message.

    Returns
    -------
    float
    """
    number = isinstance(nu, int | float) and not isinstance(nu, bool)
    if not number or not math.isfinite(nu) or not -1.0 < nu < 0.5:
        raise InvalidParameter(f"{name} = {nu!r}: Poisson's ratio must be a finite number in (-1, 0.5)")
    return float(nu)


#: Young's moduli any region may take (Pa): 1 kPa, softer than any tissue of the middle ear (its
#: softest, the gap's cartilage and the ligaments, are about 1 MPa), to 1 TPa, about diamond's, so
#: stiffer than any solid. Outside it a solve has no physical meaning, and past about 1e150 or
#: below 1e-150 the stiffness matrix overflows or underflows.
MODULUS_RANGE_PA: tuple[float, float] = (1e3, 1e12)
#: Static pressures on the incus (Pa): 1 µPa, below the threshold of hearing (20 µPa), to 10 kPa
#: (174 dB SPL), far past the levels at which the middle ear stays linear; the models are linear
#: and small-strain, so α and β scale with the pressure and a larger one means nothing.
PRESSURE_RANGE_PA: tuple[float, float] = (1e-6, 1e4)


def _check_in(name: str, value, lo: float, hi: float, unit: str) -> float:
    number = isinstance(value, int | float) and not isinstance(value, bool)
    if not number or not math.isfinite(value) or not lo <= value <= hi:
        raise InvalidParameter(f"{name} = {value!r}: must be a finite number in [{lo:g}, {hi:g}] {unit}")
    return float(value)


def check_modulus(value, name: str = "modulus") -> float:
    """A Young's modulus (Pa) within :data:`MODULUS_RANGE_PA`, as a float.

    Raises
    ------
    InvalidParameter
        One line naming ``name`` and the range: booleans, non-numbers, non-finite values, and
        values outside the range.
    """
    return _check_in(name, value, *MODULUS_RANGE_PA, "Pa")


def check_pressure(value, name: str = "pressure_pa") -> float:
    """A static pressure (Pa) within :data:`PRESSURE_RANGE_PA`, as a float (see :func:`check_modulus`)."""
    return _check_in(name, value, *PRESSURE_RANGE_PA, "Pa")


#: Deepest nesting of arrays and tables a TOML input may hold: far beyond any isj file (4
#: levels); deeper input is refused in one line, as is input so deep that Python's parser
#: exhausts its recursion.
MAX_TOML_DEPTH = 32


def _depth(obj, limit: int, level: int = 0) -> int:
    """Nesting depth of dicts and lists in ``obj``, counting stops past ``limit`` (no recursion)."""
    deepest, stack = level, [(obj, level)]
    while stack:
        o, d = stack.pop()
        if isinstance(o, dict | list):
            deepest = max(deepest, d + 1)
            if deepest > limit:
                return deepest
            stack.extend((v, d + 1) for v in (o.values() if isinstance(o, dict) else o))
    return deepest


def loads_toml(text: str, where: str) -> dict:
    """``text`` parsed as TOML, refusing nesting deeper than :data:`MAX_TOML_DEPTH`.

    Raises
    ------
    tomllib.TOMLDecodeError
        Not valid TOML.
    ConfigError
        Nested too deep: one line naming ``where`` and the limit.
    """
    import tomllib

    from isj.errors import ConfigError

    deep = ConfigError(f"{where}: nested more than {MAX_TOML_DEPTH} levels deep (arrays or tables)")
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise deep from None
    if _depth(data, MAX_TOML_DEPTH) > MAX_TOML_DEPTH:
        raise deep
    return data


def read_toml(path, option: str = "--config") -> dict:
    """The TOML file at ``path`` as a dict, or a ConfigError naming ``option`` in one line.

    Nesting deeper than :data:`MAX_TOML_DEPTH` is refused (:func:`loads_toml`).
    """
    import tomllib
    from pathlib import Path

    from isj.errors import ConfigError

    where = f"{option} {str(path)!r}"
    try:
        return loads_toml(Path(path).read_text(encoding="utf-8"), where)
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{where}: not a TOML file (not UTF-8 at byte {exc.start})") from None
    except OSError as exc:
        raise ConfigError(f"{where}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{where}: not valid TOML ({exc})") from None
