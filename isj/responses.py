"""Result types shared by the FE and the lumped models: one frequency response, computed apart from drawing.

:class:`FrequencyResponse` is what every frequency sweep of isj returns: the
lumped chain (:meth:`isj.lumped.api.LumpedModel.frequency_response`), the lumped ear
(:meth:`isj.lumped.ear.LumpedEar.frequency_response`), the FE joint model
(:meth:`isj.fem.model.PedicleJointModel.frequency_response`), the FE ear
(:meth:`isj.fem.ear.middle_ear.MiddleEarModel.frequency_response`) and the reduced FE ear
(:meth:`isj.fem.ear.reduced_ear.ReducedEar.frequency_response`): every model's
``frequency_response(freq_hz, ...)``. As in
python-control, the object holds the numbers and ``plot`` draws them on axes the
caller may supply; as in pyMOR's ``freq_resp``, the complex values have the
shape (n_freq, n_out, n_in).

>>> import numpy as np
>>> r = FrequencyResponse(np.array([10.0, 100.0]), np.ones((2, 1, 1)) * 1j, ("u_m",), ("m",))
>>> r["u_m"].shape, float(r.phase_deg("u_m")[0])
((2,), 90.0)

Drawing imports matplotlib only when asked, never selects a backend and never
imports ``matplotlib.pyplot``, so a notebook's backend is left alone.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InvalidParameter
from .validate import check_frequencies

_UNITS_PREFIX = "# units: "
_INPUT_PREFIX = "# input: "


@dataclass(frozen=True, eq=False)  # arrays: no elementwise == pretending to be equality
class FrequencyResponse:
    """Complex output amplitudes of a linear model at a list of frequencies (SI).

    Parameters
    ----------
    freq_hz : (n_freq,) frequencies (Hz), finite and >= 0, at least one
    response : (n_freq, n_out, n_in) complex output amplitudes (a 2-D (n_freq, n_out) array is
        taken as one input) for an input of amplitude ``input_amplitude``
    output_names : n_out names, e.g. ``"alpha_rad"``
    output_units : n_out units of the amplitudes, e.g. ``"rad"``
    input_names, input_units : n_in names and units of the inputs (default: the pressure, Pa)
    input_amplitude : the amplitude of the input the response is for (in ``input_units``);
        1 for a response per unit input (per Pa)

    Notes
    -----
    The arrays are stored as given (not copied); treat them as read-only.
    """

    freq_hz: np.ndarray
    response: np.ndarray
    output_names: tuple[str, ...]
    output_units: tuple[str, ...]
    input_names: tuple[str, ...] = ("pressure",)
    input_units: tuple[str, ...] = ("Pa",)
    input_amplitude: float = 1.0

    def __post_init__(self) -> None:
        f = check_frequencies(self.freq_hz)
        h = np.asarray(self.response, dtype=complex)
        if h.ndim == 2:
            h = h[:, :, None]
        names, units = tuple(self.output_names), tuple(self.output_units)
        ins, in_units = tuple(self.input_names), tuple(self.input_units)
        expected = (f.size, len(names), len(ins))
        if h.shape != expected:
            raise InvalidParameter(f"response: shape {h.shape}, expected (n_freq, n_out, n_in) = {expected}")
        if len(units) != len(names) or len(in_units) != len(ins):
            raise InvalidParameter("output_units/input_units: need one unit per output and per input")
        if len(set(names)) != len(names) or not all(isinstance(n, str) and n for n in names + ins):
            raise InvalidParameter("output_names/input_names: must be distinct, non-empty strings")
        amp = float(self.input_amplitude)
        if not math.isfinite(amp) or amp <= 0:
            raise InvalidParameter(f"input_amplitude = {self.input_amplitude!r}: must be a finite number > 0")
        for name, value in (
            ("freq_hz", f),
            ("response", h),
            ("output_names", names),
            ("output_units", units),
            ("input_names", ins),
            ("input_units", in_units),
            ("input_amplitude", amp),
        ):
            object.__setattr__(self, name, value)

    # ---- access -------------------------------------------------------------------

    @property
    def shape(self) -> tuple[int, int, int]:
        """(n_freq, n_out, n_in)."""
        return self.response.shape

    def _index(self, name: str) -> int:
        try:
            return self.output_names.index(name)
        except ValueError:
            raise KeyError(f"output = {name!r}: must be one of {', '.join(self.output_names)}") from None

    def __getitem__(self, name: str) -> np.ndarray:
        """One output's complex amplitudes: (n_freq,) for one input, else (n_freq, n_in)."""
        h = self.response[:, self._index(name), :]
        return h[:, 0] if h.shape[1] == 1 else h

    def __contains__(self, name: object) -> bool:
        return name in self.output_names

    def unit(self, name: str) -> str:
        """The unit of output ``name``'s amplitudes."""
        return self.output_units[self._index(name)]

    def magnitude(self, name: str | None = None) -> np.ndarray:
        """|response|, all outputs (n_freq, n_out, n_in) or one output (as :meth:`__getitem__`)."""
        return np.abs(self.response if name is None else self[name])

    def phase_deg(self, name: str | None = None) -> np.ndarray:
        """Phase (degrees), unwrapped along frequency, shaped as :meth:`magnitude`."""
        h = self.response if name is None else self[name]
        return np.degrees(np.unwrap(np.angle(h), axis=0))

    # ---- plain data and files -----------------------------------------------------

    def to_dict(self) -> dict:
        """JSON-able dict: frequencies, names, units, and ``<output>_re_im`` pairs per frequency.

        With one input each ``<output>_re_im`` is a list of [re, im]; with several, a list (per
        frequency) of such pairs per input.
        """
        out = {
            "freq_hz": [float(v) for v in self.freq_hz],
            "output_names": list(self.output_names),
            "output_units": list(self.output_units),
            "input_names": list(self.input_names),
            "input_units": list(self.input_units),
            "input_amplitude": self.input_amplitude,
        }
        for j, name in enumerate(self.output_names):
            h = self.response[:, j, :]
            pairs = [[[float(v.real), float(v.imag)] for v in row] for row in h]
            out[f"{name}_re_im"] = [p[0] for p in pairs] if h.shape[1] == 1 else pairs
        return out

    @classmethod
    def from_dict(cls, d: dict) -> FrequencyResponse:
        """Inverse of :meth:`to_dict`."""
        names = tuple(d["output_names"])
        n_in = len(d.get("input_names", ("pressure",)))
        cols = []
        for name in names:
            a = np.asarray(d[f"{name}_re_im"], dtype=float).reshape(-1, n_in, 2)
            cols.append(a[..., 0] + 1j * a[..., 1])
        h = np.stack(cols, axis=1) if cols else np.zeros((len(d["freq_hz"]), 0, n_in), complex)
        return cls(
            np.asarray(d["freq_hz"], dtype=float),
            h,
            names,
            tuple(d["output_units"]),
            tuple(d.get("input_names", ("pressure",))),
            tuple(d.get("input_units", ("Pa",))),
            float(d.get("input_amplitude", 1.0)),
        )

    def _columns(self) -> list[str]:
        one = len(self.input_names) == 1
        return [name if one else f"{name}/{inp}" for name in self.output_names for inp in self.input_names]

    def to_csv(self, path: str | os.PathLike, digits: int = 17) -> Path:
        """Write a CSV (atomically): two ``#`` lines of units and input, then one row per frequency.

        Columns: ``freq_hz``, then per output (``<output>/<input>`` with several inputs)
        ``_re``, ``_im``, ``_abs`` and the unwrapped ``_phase_deg``. ``digits`` significant
        digits (17: the numbers read back bit for bit with :meth:`read_csv`).
        """
        from .atomic import atomic_write_text

        if not isinstance(digits, int) or not 1 <= digits <= 17:
            raise InvalidParameter(f"digits = {digits!r}: must be an integer in [1, 17]")
        units = "; ".join(
            ["freq_hz Hz"] + [f"{n} {u}" for n, u in zip(self.output_names, self.output_units, strict=True)]
        )
        inputs = "; ".join(f"{n} {u}" for n, u in zip(self.input_names, self.input_units, strict=True))
        cols = self._columns()
        header = ",".join(["freq_hz"] + [f"{c}_{p}" for c in cols for p in ("re", "im", "abs", "phase_deg")])
        n = self.freq_hz.size
        h = self.response.reshape(n, -1)  # output-major, as _columns
        mag, ph = np.abs(h), np.degrees(np.unwrap(np.angle(h), axis=0))
        table = np.empty((n, 1 + 4 * h.shape[1]))
        table[:, 0] = self.freq_hz
        table[:, 1::4], table[:, 2::4], table[:, 3::4], table[:, 4::4] = h.real, h.imag, mag, ph
        rows = "\n".join(",".join(f"{v:.{digits}g}" for v in row) for row in table)
        text = (
            f"{_UNITS_PREFIX}{units}; phase deg\n"
            f"{_INPUT_PREFIX}{inputs}; amplitude {self.input_amplitude!r}\n"
            f"{header}\n{rows}\n"
        )
        return atomic_write_text(path, text)

    @classmethod
    def read_csv(cls, path: str | os.PathLike) -> FrequencyResponse:
        """Read a file written by :meth:`to_csv` (names and units from its ``#`` lines)."""
        lines = Path(path).read_text().splitlines()
        try:
            units_line, input_line, header = lines[0], lines[1], lines[2].split(",")
            if not (units_line.startswith(_UNITS_PREFIX) and input_line.startswith(_INPUT_PREFIX)):
                raise ValueError("missing '# units:' / '# input:' lines")
            pairs = [p.split(" ", 1) for p in units_line[len(_UNITS_PREFIX) :].split("; ")]
            units = dict(pairs[1:-1])  # drop freq_hz Hz and "phase deg"
            fields = input_line[len(_INPUT_PREFIX) :].split("; ")
            inputs = [p.split(" ", 1) for p in fields[:-1]]
            amplitude = float(fields[-1].removeprefix("amplitude "))
            table = np.loadtxt(lines[3:], delimiter=",", ndmin=2).reshape(-1, len(header))
        except (IndexError, ValueError) as exc:
            raise InvalidParameter(f"{str(path)!r}: not a FrequencyResponse CSV ({exc})") from None
        names = tuple(units)
        h = (table[:, 1::4] + 1j * table[:, 2::4]).reshape(table.shape[0], len(names), len(inputs))
        return cls(
            table[:, 0],
            h,
            names,
            tuple(units.values()),
            tuple(n for n, _ in inputs),
            tuple(u for _, u in inputs),
            amplitude,
        )

    # ---- drawing --------------------------------------------------------------------

    def plot(self, ax=None, outputs=None, input_index: int = 0, **line_kw) -> list:
        """Bode plot: magnitude on log–log axes and, below, the unwrapped phase in degrees.

        Parameters
        ----------
        ax : None (a new ``matplotlib.figure.Figure`` with two axes), one Axes (magnitude
            only) or a pair (magnitude axes, phase axes)
        outputs : output names to draw (default: all)
        input_index : which input's response to draw
        **line_kw : passed to every ``Axes.plot`` call

        Returns
        -------
        list of matplotlib Line2D artists, magnitude then phase for each output; the figure is
        ``artists[0].figure``
        """
        if ax is None:
            from matplotlib.figure import Figure

            ax_mag, ax_ph = Figure(figsize=(7, 6), layout="constrained").subplots(2, 1, sharex=True)
        elif isinstance(ax, tuple | list):
            ax_mag, ax_ph = ax
        else:
            ax_mag, ax_ph = ax, None
        names = self.output_names if outputs is None else tuple(outputs)
        artists = []
        for name in names:
            h = self.response[:, self._index(name), input_index]
            label = f"{name} ({self.unit(name)})"
            (line,) = ax_mag.plot(self.freq_hz, np.abs(h), label=label, **line_kw)
            artists.append(line)
            if ax_ph is not None:
                ph = np.degrees(np.unwrap(np.angle(h)))
                artists += ax_ph.plot(self.freq_hz, ph, color=line.get_color(), **line_kw)
        ax_mag.set_xscale("log")
        ax_mag.set_yscale("log")
        units = {self.unit(n) for n in names}
        ax_mag.set_ylabel("magnitude" + (f" ({units.pop()})" if len(units) == 1 else ""))
        ax_mag.legend(fontsize=8)
        for a in (ax_mag, ax_ph):
            if a is not None:
                a.grid(True, which="both", alpha=0.3)
        if ax_ph is not None:
            ax_ph.set_xscale("log")
            ax_ph.set_ylabel("phase (deg)")
        (ax_ph if ax_ph is not None else ax_mag).set_xlabel("frequency (Hz)")
        return artists


#: Octave bands from 100 Hz to 20 kHz (Hz), the last one cut at 20 kHz.
OCTAVE_BANDS_HZ = tuple((100.0 * 2**k, min(100.0 * 2 ** (k + 1), 20e3)) for k in range(8))


def band_deviation(freq_hz, response, reference, bands=OCTAVE_BANDS_HZ) -> list[dict]:
    """Δ = ``response`` / ``reference`` (complex, (n_freq,)) per band: dB and degrees (±180°).

    Returns, per band (lo, hi) (Hz; a frequency f belongs to it when lo ≤ f < hi, the last band
    including hi), ``band_hz``, ``n_freq`` and, when it holds any frequency, ``mean_abs_db``,
    ``max_abs_db``, ``mean_db`` (signed), ``mean_abs_deg``, ``max_abs_deg``, ``max_abs_db_at_hz``.
    """
    f = check_frequencies(freq_hz)
    ratio = np.asarray(response, complex) / np.asarray(reference, complex)
    if ratio.shape != f.shape:
        raise InvalidParameter(f"response, reference: shape {ratio.shape} must match freq_hz ({f.size})")
    d_db = 20 * np.log10(np.abs(ratio))
    d_deg = (np.degrees(np.angle(ratio)) + 180.0) % 360.0 - 180.0
    out = []
    for j, (lo, hi) in enumerate(bands):
        last = j == len(bands) - 1
        m = (f >= lo) & ((f <= hi) if last else (f < hi))
        row = {"band_hz": [float(lo), float(hi)], "n_freq": int(m.sum())}
        if m.any():
            a, p = np.abs(d_db[m]), np.abs(d_deg[m])
            row |= {
                "mean_abs_db": float(a.mean()),
                "max_abs_db": float(a.max()),
                "max_abs_db_at_hz": float(f[m][np.argmax(a)]),
                "mean_db": float(d_db[m].mean()),
                "mean_abs_deg": float(p.mean()),
                "max_abs_deg": float(p.max()),
            }
        out.append(row)
    return out


#: Columns :func:`delta_columns` adds to a sweep, and their units.
DELTA_COLUMNS = {"h_v_db": "dB re 1 m/s/Pa", "h_v_deg": "deg", "delta_h_v_db": "dB", "delta_h_v_deg": "deg"}

#: Frequencies (Hz) a sweep's summary quotes ΔH_V at (those inside the band).
QUOTE_HZ = (1000.0, 5000.0, 10000.0)


def delta_columns(freq_hz, h_v, h_v_rigid) -> dict:
    """H_V and ΔH_V = H_V / H_V,rigid in dB and degrees (:data:`DELTA_COLUMNS`), and a summary.

    For any ear's H_V (m/s per Pa) and that of the rigid connection of the same ear at the same
    frequencies (``isj ear sweep``, lumped or ``--fe``, and the fast ear). Returns ``columns``
    (name → (n_f,) float), ``units`` and ``summary``: ΔH_V (dB, degrees) at the :data:`QUOTE_HZ`
    inside the band (interpolated in log f) and the largest |ΔH_V| (dB) at or below 10 kHz with
    its frequency.
    """
    f = check_frequencies(freq_hz)
    hv, hr = np.asarray(h_v, complex), np.asarray(h_v_rigid, complex)
    if hv.shape != f.shape or hr.shape != f.shape:
        raise InvalidParameter(f"h_v, h_v_rigid: must have the shape of freq_hz {f.shape}")
    d = hv / hr
    cols = {
        "h_v_db": 20 * np.log10(np.abs(hv)),
        "h_v_deg": np.degrees(np.angle(hv)),
        "delta_h_v_db": 20 * np.log10(np.abs(d)),
        "delta_h_v_deg": np.degrees(np.angle(d)),
    }
    summary: dict = {"delta_h_v_at_hz": {}}
    lf = np.log(np.maximum(f, 1e-300))
    for q in QUOTE_HZ:
        if f.size > 1 and f[0] <= q <= f[-1]:
            summary["delta_h_v_at_hz"][f"{q:g}"] = {
                "db": float(np.interp(np.log(q), lf, cols["delta_h_v_db"])),
                "deg": float(
                    np.interp(np.log(q), lf, np.unwrap(np.radians(cols["delta_h_v_deg"])) * 180 / np.pi)
                ),
            }
    low = np.flatnonzero(f <= 10e3)
    if low.size:
        i = low[np.argmax(np.abs(cols["delta_h_v_db"][low]))]
        summary["max_abs_delta_h_v_db_to_10khz"] = float(abs(cols["delta_h_v_db"][i]))
        summary["max_abs_delta_h_v_at_hz"] = float(f[i])
    return {"columns": cols, "units": dict(DELTA_COLUMNS), "summary": summary}
