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


def check_band(fmin_hz: float, fmax_hz: float, names: tuple[str, str] = ("fmin_hz", "fmax_hz")) -> None:
    """A frequency band: both ends finite with 0 < fmin < fmax (Hz).

    Parameters
    ----------
    fmin_hz, fmax_hz : float
        Lowest and highest frequency (Hz).
    names : (str, str)
        Parameter names for the message (``("--fmin-hz", "--fmax-hz")`` on the command line).
    """
    ok = all(isinstance(v, int | float) and not isinstance(v, bool) for v in (fmin_hz, fmax_hz))
    if not ok or not (math.isfinite(fmin_hz) and math.isfinite(fmax_hz) and 0 < fmin_hz < fmax_hz):
        raise InvalidParameter(
            f"{names[0]}/{names[1]} = {fmin_hz!r}/{fmax_hz!r}: need finite 0 < fmin < fmax (Hz)"
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


def read_toml(path, option: str = "--config") -> dict:
    """The TOML file at ``path`` as a dict, or a ConfigError naming ``option`` in one line."""
    import tomllib
    from pathlib import Path

    from isj.errors import ConfigError

    try:
        return tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        where = f"{option} {str(path)!r}"
        raise ConfigError(f"{where}: not a TOML file (not UTF-8 at byte {exc.start})") from None
    except OSError as exc:
        raise ConfigError(f"{option} {str(path)!r}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{option} {str(path)!r}: not valid TOML ({exc})") from None
