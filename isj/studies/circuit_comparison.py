"""The ear beside the published cat circuit, per octave band, both cavity states (docs/circuit.md §13.4).

The reference is the cat middle-ear circuit of Bruce, Sachs & Young (2003, Appendix A;
:class:`isj.lumped.circuit.CatCircuit`): a published model fitted to cat measurements, not a
measurement. Nothing in the ear is tuned to it. Two quantities per Pa of ear-canal pressure:

- the stapes volume velocity U_S / P_EC (m³/(s·Pa)): the ear's footplate area × H_V, the
  circuit's volume velocity through its vestibule mass L_v;
- the vestibule-pressure gain P_V / P_EC: the ear's Z_C × A_fp × H_V, Z_C the cochlear input
  resistance its cochlear dashpot stands for (Lynch et al. 1982; docs/dynamics.md §4.3), the
  circuit's pressure at its cochlear load's input.

Each is compared in the same cavity state: the ear with ``cavities="open"`` against the circuit
with its cavity elements removed, the intact ear against the intact circuit. The circuit's drum
was fitted with the cavities present, so the intact pair is the comparison that means something;
the open circuit is shown only beside the open ear. The deviation Δ = ear / circuit is given in dB
and degrees (wrapped to ±180°), per octave band from 100 Hz (the last band stops at 20 kHz): the
mean and the largest |Δ| over the band's frequencies, and the mean signed Δ in dB.
"""

from __future__ import annotations

import numpy as np

from isj.cavities import CAVITY_STATES, DEFAULT_CAVITIES, load_circuit_data
from isj.damping import resolve
from isj.ear import EarGeometry
from isj.errors import InvalidParameter
from isj.lumped.circuit import CatCircuit
from isj.responses import OCTAVE_BANDS_HZ, band_deviation
from isj.validate import check_frequencies

#: The comparison's default frequencies: 200 log-spaced from 100 Hz to 20 kHz (Hz).
DEFAULT_FREQ_HZ = np.geomspace(100.0, 20e3, 200)

#: The quantities compared and their units.
QUANTITIES = {"stapes_volume_velocity": "m^3/s/Pa", "vestibule_gain": "Pa/Pa"}

#: What the circuit is, for every output that shows it.
STATEMENT = (
    "The published cat circuit (Bruce, Sachs & Young 2003, Appendix A; cavities after Peake, Rosowski "
    "& Lynch 1992; cochlear load after Lynch, Nedzelnitsky & Peake 1982) is a published model fitted "
    "to cat measurements, not a measurement. Nothing in the ear is tuned to it."
)


def _curve(x: np.ndarray, db: bool) -> dict:
    x = np.asarray(x, complex)
    mag = 20 * np.log10(np.abs(x)) if db else np.abs(x)
    key = "db" if db else "magnitude"
    return {key: mag.tolist(), "phase_deg": np.degrees(np.angle(x)).tolist()}


def compare_with_circuit(
    freq_hz,
    stapes_velocity_m_s: dict,
    footplate_area_m2: float,
    cochlear_impedance_pa_s_m3: float,
    ear: str = "",
) -> dict:
    """The ear's U_S/P_EC and P_V/P_EC against the circuit's, per cavity state (module docstring).

    Parameters
    ----------
    freq_hz : (n_freq,) frequencies (Hz, > 0)
    stapes_velocity_m_s : cavity state ("open", "intact") → the ear's H_V in that state, complex
        (n_freq,), m/s per Pa of ear-canal pressure
    footplate_area_m2 : the ear's footplate area (m²): U_S = A_fp H_V
    cochlear_impedance_pa_s_m3 : the ear's cochlear resistance Z_C (Pa·s/m³): P_V = Z_C U_S
    ear : a name for the ear ("lumped", "fe"), recorded

    Returns
    -------
    dict, JSON-able: ``what`` (:data:`STATEMENT`), ``citations``, ``ear``, ``bands_hz``,
    ``freq_hz``, ``footplate_area_m2``, ``cochlear_impedance_pa_s_m3`` and ``states``: per state
    ``circuit`` and ``ear`` curves (``stapes_volume_velocity``: magnitude (m³/s/Pa) and phase_deg;
    ``vestibule_gain``: db and phase_deg) and ``deviation_per_band`` per quantity
    (:func:`band_deviation`).
    """
    f = check_frequencies(freq_hz)
    if np.any(f <= 0):
        raise InvalidParameter("freq_hz: the circuit comparison needs every frequency > 0 Hz")
    if not (np.isfinite(footplate_area_m2) and footplate_area_m2 > 0):
        raise InvalidParameter(f"footplate_area_m2 = {footplate_area_m2!r} m^2: must be a finite number > 0")
    if not (np.isfinite(cochlear_impedance_pa_s_m3) and cochlear_impedance_pa_s_m3 > 0):
        raise InvalidParameter(
            f"cochlear_impedance_pa_s_m3 = {cochlear_impedance_pa_s_m3!r} Pa s/m^3: must be finite and > 0"
        )
    unknown = sorted(set(stapes_velocity_m_s) - set(CAVITY_STATES))
    if unknown or not stapes_velocity_m_s:
        raise InvalidParameter(
            f"stapes_velocity_m_s: keys {unknown} must be among {', '.join(CAVITY_STATES)}"
        )
    circuit = CatCircuit.load()
    states = {}
    for state, hv in stapes_velocity_m_s.items():
        c = circuit.frequency_response(f, state)
        u_ear = footplate_area_m2 * np.asarray(hv, complex)
        p_ear = cochlear_impedance_pa_s_m3 * u_ear
        states[state] = {
            "circuit": {
                "stapes_volume_velocity": _curve(c.stapes_volume_velocity_m3_s, db=False),
                "vestibule_gain": _curve(c.vestibule_gain, db=True),
            },
            "ear": {
                "stapes_volume_velocity": _curve(u_ear, db=False),
                "vestibule_gain": _curve(p_ear, db=True),
            },
            "deviation_per_band": {
                "stapes_volume_velocity": band_deviation(f, u_ear, c.stapes_volume_velocity_m3_s),
                "vestibule_gain": band_deviation(f, p_ear, c.vestibule_gain),
            },
        }
    return {
        "what": STATEMENT,
        "citations": load_circuit_data()["citations"],
        "ear": ear,
        "quantities": dict(QUANTITIES),
        "bands_hz": [list(b) for b in OCTAVE_BANDS_HZ],
        "freq_hz": f.tolist(),
        "footplate_area_m2": float(footplate_area_m2),
        "cochlear_impedance_pa_s_m3": float(cochlear_impedance_pa_s_m3),
        "default_cavities": DEFAULT_CAVITIES,
        "states": states,
    }


def circuit_check_values() -> dict:
    """The circuit's own check values as isj's solve gives them beside those the data file states."""
    c = CatCircuit.load()
    fine = np.geomspace(100.0, 20e3, 4001)
    g = c.frequency_response(fine).vestibule_gain_db()
    band = (fine > 3e3) & (fine < 6e3)
    notch = np.flatnonzero(band)[np.argmin(g[band])]
    at = c.frequency_response([100.0, 1e3, 10e3])
    return {
        "stated": load_circuit_data()["check_values"],
        "computed": {
            "vestibule_pressure_gain_db": dict(
                zip(("100", "1000", "10000"), at.vestibule_gain_db().tolist(), strict=True)
            ),
            "vestibule_pressure_gain_maximum": {"db": float(g.max()), "near_hz": float(fine[np.argmax(g)])},
            "vestibule_pressure_gain_notch": {"db": float(g[notch]), "near_hz": float(fine[notch])},
            "stapes_volume_velocity_m3_s_pa": {"100": float(abs(at.stapes_volume_velocity_m3_s[0]))},
        },
    }


def lumped_ear_comparison(freq_hz=DEFAULT_FREQ_HZ, drum_modes: int = 240, damping=None, **moduli) -> dict:
    """The lumped ear (base design unless ``moduli`` say otherwise; ``drum_modes`` component modes of
    the drum, docs/ear.md §5.10) against the circuit in both cavity states (:func:`compare_with_circuit`).

    Milliseconds; the lumped ear's coupling carries only α and β (docs/transmission.md §12.5).
    """
    from isj.lumped.ear import ear_model

    f = check_frequencies(freq_hz)
    dmp = resolve(damping)
    ear = ear_model(damping=dmp, drum_modes=drum_modes, **moduli)
    iw = 2j * np.pi * f
    hv = {s: iw * ear.with_cavities(s).frequency_response(f)["stapes_m"] for s in CAVITY_STATES}
    return compare_with_circuit(
        f,
        hv,
        EarGeometry().footplate_area_m2,
        dmp.cochlear_impedance_pa_s_m3,
        ear=f"lumped ({drum_modes} drum modes)",
    )


def fe_ear_comparison(rom, freq_hz=DEFAULT_FREQ_HZ, damping=None, footplate_area_m2=None) -> dict:
    """A reduced FE ear (:func:`isj.fem.ear.reduced_ear.reduced_ear`) against the circuit in both
    cavity states: its ``stapes_velocity_m_s`` open and intact (no new reduction)."""
    f = check_frequencies(freq_hz)
    dmp = resolve(damping)
    area = EarGeometry().footplate_area_m2 if footplate_area_m2 is None else footplate_area_m2
    hv = {s: rom.with_cavities(s).frequency_response(f, dmp)["stapes_velocity_m_s"] for s in CAVITY_STATES}
    return compare_with_circuit(f, hv, area, dmp.cochlear_impedance_pa_s_m3, ear="fe (reduced ear)")


def circuit_page(freq_hz=DEFAULT_FREQ_HZ, fe: dict | None = None, drum_modes: int = 240) -> dict:
    """Everything a report page on the circuit needs, JSON-able.

    ``statement`` (:data:`STATEMENT`), ``check_values`` (:func:`circuit_check_values`), the cavity
    impedance Z_cav (magnitude, phase) over ``freq_hz``, the lumped ear's comparison
    (:func:`lumped_ear_comparison`) and, when given, an FE comparison ``fe`` (from
    :func:`fe_ear_comparison`, e.g. ``benchmarks/results/circuit_comparison.json``'s ``fe``).
    """
    f = check_frequencies(freq_hz)
    z = CatCircuit.load().cavity_impedance_pa_s_m3(f)
    return {
        "statement": STATEMENT,
        "check_values": circuit_check_values(),
        "default_cavities": DEFAULT_CAVITIES,
        "cavity_impedance_pa_s_m3": {
            "freq_hz": f.tolist(),
            "magnitude": np.abs(z).tolist(),
            "phase_deg": np.degrees(np.angle(z)).tolist(),
        },
        "lumped": lumped_ear_comparison(f, drum_modes),
        "fe": fe,
    }
