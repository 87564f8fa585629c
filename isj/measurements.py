"""Published cat measurements, and how far a model's frequency response is from them.

The numbers live in ``isj/data/cat_measurements.json`` (docs/measurements.md
lists each series, its source, its conditions and how sure it is). Every value
there is in SI units and records where it comes from: a sentence of the source
(``origin="from_text"``), a table, or points read off a figure
(``digitised=True``).

Nothing in isj is fitted to these data. :func:`compare` only reports the
deviation of a model from them, in dB, at the measured frequencies.

>>> series = {s.name: s for s in load_cat_measurements()}
>>> zc = series["lynch1982_cochlear_impedance"]
>>> zc.unit, float(zc.magnitude[0])
('Pa*s/m^3', 120000000000.0)
>>> r = compare(zc, [100.0, 10000.0], [1.2e11, 1.2e11])
>>> round(r["max_abs_db"], 9), r["bands_3db"]
(0.0, [(500.0, 5000.0)])

A model's stapes velocity per pressure (m/s/Pa) is compared with displacement
data (m/Pa) by passing ``model_unit="m/s/Pa"``: the model is divided by
i 2π f before the comparison (:func:`velocity_to_displacement`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path

import numpy as np

from .errors import InvalidParameter

__all__ = [
    "QUANTITY_UNITS",
    "MeasuredSeries",
    "load_cat_measurements",
    "load_cat_catalogue",
    "displacement_to_velocity",
    "velocity_to_displacement",
    "compare",
]

#: The data file inside the package.
DATA_FILE = "cat_measurements.json"

#: Every quantity a series may hold → its SI unit.
QUANTITY_UNITS: dict[str, str] = {
    "stapes_displacement_per_ear_canal_pressure": "m/Pa",
    "stapes_velocity_per_ear_canal_pressure": "m/s/Pa",
    "umbo_displacement_per_ear_canal_pressure": "m/Pa",
    "umbo_velocity_per_ear_canal_pressure": "m/s/Pa",
    "vestibule_pressure_per_ear_canal_pressure": "Pa/Pa",
    "cochlear_input_impedance": "Pa*s/m^3",
    "stapes_cochlea_input_impedance": "Pa*s/m^3",
}

_ORIGINS = ("from_text", "table", "digitised")
_DISPLACEMENT, _VELOCITY = "m/Pa", "m/s/Pa"

# Tolerance on the dB bands, so that an exact 3 or 6 dB offset counts as inside.
_BAND_EPS_DB = 1e-9


@dataclass(frozen=True, eq=False)  # arrays: no elementwise == pretending to be equality
class MeasuredSeries:
    """One published series: magnitudes (SI) and optional phases at a few frequencies.

    Parameters
    ----------
    name : unique key in the data file
    quantity : one of :data:`QUANTITY_UNITS`
    unit : the SI unit of ``magnitude`` (``QUANTITY_UNITS[quantity]``)
    freq_hz : (n,) frequencies (Hz), > 0 and increasing
    magnitude : (n,) magnitudes (``unit``), > 0
    phase_deg : (n,) phases (degrees) or None where the source gives none
    conditions : animal, anaesthesia, preparation, cavities (opened / intact), method
    source : the full citation
    digitised : True when the points were read off a figure
    origin : ``"from_text"``, ``"table"`` or ``"digitised"``
    magnitude_min, magnitude_max : (n,) the range the source states, or None
    figure : figure, table or part of the source the values come from
    evidence : the source's sentence for values taken from text
    uncertainty, notes : free text
    published : the values and unit as published, and the conversion to SI
    """

    name: str
    quantity: str
    unit: str
    freq_hz: np.ndarray
    magnitude: np.ndarray
    phase_deg: np.ndarray | None
    conditions: dict
    source: str
    digitised: bool
    origin: str = "from_text"
    magnitude_min: np.ndarray | None = None
    magnitude_max: np.ndarray | None = None
    figure: str = ""
    evidence: str = ""
    uncertainty: str = ""
    notes: str = ""
    published: dict = field(default_factory=dict)

    @property
    def kind(self) -> str:
        """``"displacement"``, ``"velocity"`` or ``"other"`` (pressures, impedances)."""
        return {_DISPLACEMENT: "displacement", _VELOCITY: "velocity"}.get(self.unit, "other")

    def as_velocity(self) -> MeasuredSeries:
        """The series as velocity per pressure (m/s/Pa): v = i 2π f x. A velocity series is returned as is."""
        if self.kind == "velocity":
            return self
        if self.kind != "displacement":
            raise InvalidParameter(f"{self.name}: {self.quantity} is not a displacement")
        return self._converted(_VELOCITY, "displacement", "velocity", +1)

    def as_displacement(self) -> MeasuredSeries:
        """The series as displacement per pressure (m/Pa): x = v / (i 2π f); displacement as is."""
        if self.kind == "displacement":
            return self
        if self.kind != "velocity":
            raise InvalidParameter(f"{self.name}: {self.quantity} is not a velocity")
        return self._converted(_DISPLACEMENT, "velocity", "displacement", -1)

    def _converted(self, unit: str, old: str, new: str, sign: int) -> MeasuredSeries:
        w = 2.0 * math.pi * self.freq_hz
        factor = w if sign > 0 else 1.0 / w

        def scale(a):
            return None if a is None else a * factor

        phase = None if self.phase_deg is None else self.phase_deg + sign * 90.0
        return replace(
            self,
            quantity=self.quantity.replace(old, new),
            unit=unit,
            magnitude=self.magnitude * factor,
            magnitude_min=scale(self.magnitude_min),
            magnitude_max=scale(self.magnitude_max),
            phase_deg=phase,
            notes=(self.notes + f" [converted from {old} by isj.measurements]").strip(),
        )


def displacement_to_velocity(freq_hz, x):
    """Velocity amplitudes v = i 2π f x (complex) from displacement amplitudes x at ``freq_hz`` (Hz)."""
    f = np.asarray(freq_hz, dtype=float)
    return 1j * 2.0 * math.pi * f * np.asarray(x)


def velocity_to_displacement(freq_hz, v):
    """Displacement amplitudes x = v / (i 2π f) (complex) from velocity amplitudes v; every f must be > 0."""
    f = np.asarray(freq_hz, dtype=float)
    if np.any(f <= 0):
        raise InvalidParameter("velocity_to_displacement: every frequency must be > 0 Hz")
    return np.asarray(v) / (1j * 2.0 * math.pi * f)


# -- loading -------------------------------------------------------------------


def _data_path(path):
    if path is not None:
        return Path(path)
    return resources.files("isj") / "data" / DATA_FILE


def load_cat_catalogue(path=None) -> dict:
    """The whole data file as a dict: ``series``, ``lumped_element_fits``, ``statements``, the rule and scope.

    ``statements`` are what the sources say without a number that can be compared
    (frequency ranges, the band where the chain moves rigidly, ...).
    """
    ref = _data_path(path)
    try:
        text = ref.read_text(encoding="utf-8")
    except OSError as exc:
        raise InvalidParameter(f"cat measurements: cannot read {ref}: {exc}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InvalidParameter(f"cat measurements: {ref} is not valid JSON: {exc}") from None
    if not isinstance(data, dict) or not isinstance(data.get("series"), list):
        raise InvalidParameter(f"cat measurements: {ref} has no list 'series'")
    return data


def _array(name: str, key: str, value, n: int | None) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidParameter(f"{name}: {key} must be a list of numbers") from None
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)):
        raise InvalidParameter(f"{name}: {key} must be a non-empty list of finite numbers")
    if n is not None and a.size != n:
        raise InvalidParameter(f"{name}: {key} has {a.size} values, freq_hz has {n}")
    return a


def _series(entry: dict) -> MeasuredSeries:
    name = str(entry.get("name") or "")
    if not name:
        raise InvalidParameter("cat measurements: a series has no name")
    quantity = entry.get("quantity")
    if quantity not in QUANTITY_UNITS:
        raise InvalidParameter(f"{name}: unknown quantity {quantity!r}")
    unit = entry.get("unit")
    if unit != QUANTITY_UNITS[quantity]:
        raise InvalidParameter(f"{name}: unit {unit!r}, but {quantity} is in {QUANTITY_UNITS[quantity]!r}")
    f = _array(name, "freq_hz", entry.get("freq_hz"), None)
    if np.any(f <= 0) or np.any(np.diff(f) <= 0):
        raise InvalidParameter(f"{name}: freq_hz must be > 0 and strictly increasing")
    n = f.size
    mag = _array(name, "magnitude", entry.get("magnitude"), n)
    if np.any(mag <= 0):
        raise InvalidParameter(f"{name}: magnitudes must be > 0")
    phase = None if entry.get("phase_deg") is None else _array(name, "phase_deg", entry["phase_deg"], n)
    lo, hi = (
        None if entry.get(key) is None else _array(name, key, entry[key], n)
        for key in ("magnitude_min", "magnitude_max")
    )
    if lo is not None and np.any(lo > mag * (1 + 1e-12)):
        raise InvalidParameter(f"{name}: magnitude_min exceeds magnitude")
    if hi is not None and np.any(hi < mag * (1 - 1e-12)):
        raise InvalidParameter(f"{name}: magnitude_max is below magnitude")
    origin = entry.get("origin")
    if origin not in _ORIGINS:
        raise InvalidParameter(f"{name}: origin must be one of {_ORIGINS}, not {origin!r}")
    digitised = entry.get("digitised")
    if not isinstance(digitised, bool) or digitised != (origin == "digitised"):
        raise InvalidParameter(f"{name}: 'digitised' must be true exactly when origin is 'digitised'")
    if digitised and not entry.get("digitised_by"):
        raise InvalidParameter(f"{name}: digitised points must say who digitised them ('digitised_by')")
    src = entry.get("source") or {}
    citation = src.get("citation", "") if isinstance(src, dict) else str(src)
    if not citation.strip():
        raise InvalidParameter(f"{name}: no source citation")
    if origin == "from_text" and not str(entry.get("evidence") or "").strip():
        raise InvalidParameter(f"{name}: values from text must quote the source's sentence ('evidence')")
    conditions = entry.get("conditions")
    if not isinstance(conditions, dict) or not conditions:
        raise InvalidParameter(f"{name}: conditions must be a non-empty object")
    return MeasuredSeries(
        name=name,
        quantity=quantity,
        unit=unit,
        freq_hz=f,
        magnitude=mag,
        phase_deg=phase,
        conditions=dict(conditions),
        source=citation.strip(),
        digitised=digitised,
        origin=origin,
        magnitude_min=lo,
        magnitude_max=hi,
        figure=str(src.get("figure_or_table", "")) if isinstance(src, dict) else "",
        evidence=str(entry.get("evidence") or ""),
        uncertainty=str(entry.get("uncertainty") or ""),
        notes=str(entry.get("notes") or ""),
        published=dict(entry.get("published") or {}),
    )


def load_cat_measurements(path=None) -> list[MeasuredSeries]:
    """Every series of the data file (default: the one shipped in ``isj/data``), checked.

    Raises
    ------
    InvalidParameter
        The file is unreadable, or a series breaks a rule: unknown quantity, unit
        not the quantity's SI unit, arrays of different lengths, frequencies not
        > 0 and increasing, magnitudes not > 0, no citation, a value from text
        without its sentence, ``digitised`` not matching ``origin``, a name used twice.
    """
    data = load_cat_catalogue(path)
    out = [_series(e) for e in data["series"]]
    names = [s.name for s in out]
    if len(set(names)) != len(names):
        raise InvalidParameter("cat measurements: series names must be unique")
    return out


# -- comparison ----------------------------------------------------------------


def _bands(freq: np.ndarray, ok: np.ndarray) -> list[tuple[float, float]]:
    """Runs of consecutive measured frequencies where ``ok`` holds, as (first, last) in Hz."""
    bands: list[tuple[float, float]] = []
    start = None
    for i, good in enumerate(ok):
        if good and start is None:
            start = i
        if start is not None and (not good or i == len(ok) - 1):
            end = i if good else i - 1
            bands.append((float(freq[start]), float(freq[end])))
            start = None
    return bands


def _model_in_series_unit(series: MeasuredSeries, freq_hz, model_values, model_unit) -> tuple:
    """The model's frequencies > 0 (Hz, increasing) and its values there in the series' unit."""
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    h = np.atleast_1d(np.asarray(model_values))
    if f.ndim != 1 or h.shape != f.shape:
        raise InvalidParameter(
            f"compare: freq_hz {f.shape} and model_values {h.shape} must be 1-D and of one length"
        )
    unit = series.unit if model_unit is None else model_unit
    keep = f > 0
    f, h = f[keep], h[keep]
    if unit != series.unit:
        if (unit, series.unit) == (_VELOCITY, _DISPLACEMENT):
            h = velocity_to_displacement(f, h)
        elif (unit, series.unit) == (_DISPLACEMENT, _VELOCITY):
            h = displacement_to_velocity(f, h)
        else:
            raise InvalidParameter(
                f"compare: cannot compare a model in {unit!r} with {series.name} in {series.unit!r}"
            )
    order = np.argsort(f)
    f, h = f[order], h[order]
    if f.size and np.any(np.diff(f) <= 0):
        raise InvalidParameter("compare: model frequencies must be distinct")
    return f, h


def _inside_model_range(series: MeasuredSeries, f: np.ndarray) -> np.ndarray:
    """Which measured frequencies lie in the model's [f[0], f[-1]] (relative slack 1e-12); at least one."""
    fm = series.freq_hz
    inside = (fm >= f[0] * (1 - 1e-12)) & (fm <= f[-1] * (1 + 1e-12))
    if not np.any(inside):
        raise InvalidParameter(
            f"compare: no frequency of {series.name} ({fm.min():g}-{fm.max():g} Hz) lies inside the model's "
            f"{f[0]:g}-{f[-1]:g} Hz"
        )
    return inside


def _range_deviation(series: MeasuredSeries, inside, measured, model_mag) -> np.ndarray | None:
    """dB from the model to the source's stated range (0 inside it); None when it states none."""
    if series.magnitude_min is None and series.magnitude_max is None:
        return None
    lo = series.magnitude_min[inside] if series.magnitude_min is not None else measured
    hi = series.magnitude_max[inside] if series.magnitude_max is not None else measured
    below = 20.0 * np.log10(model_mag / lo)
    above = 20.0 * np.log10(model_mag / hi)
    return np.where(below < 0, below, np.where(above > 0, above, 0.0))


def _phase_deviation(series: MeasuredSeries, inside, f, h, fi) -> np.ndarray | None:
    """Model minus measured phase (degrees, wrapped to (−180, 180]); None unless both have phases.

    The model's unwrapped phase is interpolated linearly against log frequency.
    """
    if series.phase_deg is None or not np.iscomplexobj(h):
        return None
    ph = np.unwrap(np.angle(h))
    model_ph = np.degrees(ph[0] if f.size == 1 else np.interp(np.log(fi), np.log(f), ph))
    d = model_ph - series.phase_deg[inside]
    return -((-d + 180.0) % 360.0 - 180.0)  # wrapped to (-180, 180]


def compare(series: MeasuredSeries, freq_hz, model_values, model_unit: str | None = None) -> dict:
    """The model's deviation from a measured series, in dB, at the measured frequencies.

    Parameters
    ----------
    series : the measurements
    freq_hz : (m,) frequencies (Hz) of the model's response, > 0 (zero is dropped); at least 2
        unless the single frequency coincides with the data
    model_values : (m,) the model's response there, complex (magnitude and phase) or real
        (magnitude only), in ``model_unit``
    model_unit : the unit of ``model_values``; default: the series' unit. A velocity
        model (m/s/Pa) is compared with displacement data (m/Pa) and the other way
        round by dividing or multiplying it by i 2π f.

    Returns
    -------
    dict
        ``freq_hz`` (the measured frequencies inside the model's range), ``measured``
        and ``model`` magnitudes there (series unit; the model interpolated linearly in
        log magnitude against log frequency), ``deviation_db`` = 20 log10(model/measured),
        ``max_abs_db``, ``median_abs_db``, ``bands_3db`` and ``bands_6db`` (runs of
        consecutive measured frequencies with |deviation| ≤ 3 or 6 dB, as (first, last)
        Hz: the data say nothing between their points), ``range_deviation_db`` (0 inside
        the range the source states, else the distance to its nearer end; None without a
        range), ``phase_deviation_deg`` (model minus measured, wrapped to (−180, 180];
        None unless both have phases), ``skipped_freq_hz`` (measured frequencies outside
        the model's range, not compared) and the series' ``name``, ``quantity``, ``unit``.

    Raises
    ------
    InvalidParameter
        Mismatched lengths, a unit that cannot be converted, no measured frequency
        inside the model's range, or a model magnitude that is zero or not finite.
    """
    f, h = _model_in_series_unit(series, freq_hz, model_values, model_unit)
    mag = np.abs(h)
    if f.size == 0 or not np.all(np.isfinite(mag)) or np.any(mag <= 0):
        raise InvalidParameter("compare: model magnitudes must be finite and > 0 at frequencies > 0")
    inside = _inside_model_range(series, f)
    fi = series.freq_hz[inside]
    if f.size == 1:
        model_mag = np.full(fi.shape, mag[0])
    else:
        model_mag = np.exp(np.interp(np.log(fi), np.log(f), np.log(mag)))
    measured = series.magnitude[inside]
    dev = 20.0 * np.log10(model_mag / measured)
    absdev = np.abs(dev)
    return {
        "name": series.name,
        "quantity": series.quantity,
        "unit": series.unit,
        "freq_hz": fi,
        "measured": measured,
        "model": model_mag,
        "deviation_db": dev,
        "max_abs_db": float(absdev.max()),
        "median_abs_db": float(np.median(absdev)),
        "bands_3db": _bands(fi, absdev <= 3.0 + _BAND_EPS_DB),
        "bands_6db": _bands(fi, absdev <= 6.0 + _BAND_EPS_DB),
        "range_deviation_db": _range_deviation(series, inside, measured, model_mag),
        "phase_deviation_deg": _phase_deviation(series, inside, f, h, fi),
        "skipped_freq_hz": series.freq_hz[~inside],
    }
