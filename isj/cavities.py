"""The middle-ear cavities as an acoustic load on the eardrum (docs/circuit.md §13.3).

The cavity network is that of the published cat circuit (Bruce, Sachs & Young 2003, Appendix A;
the cavities after Peake, Rosowski & Lynch 1992), read from ``isj/data/cat_middle_ear_circuit.json``:
the tympanic cavity's compliance C_tc in parallel with the foramen (inertance M_f, resistance R_f)
in series with the bulla cavity's compliance C_bc. It is a published model fitted to cat
measurements, not a measurement.

Sign convention. U is the drum's net volume velocity, positive when the drum moves medially (into
the cavities, the direction a positive ear-canal pressure pushes it). The air in the cavities is
then compressed, and its pressure p_cav = Z_cav U acts on the drum's medial face, so the drum
feels the uniform net pressure p_EC − Z_cav U. For a linear ear whose volume velocity per net
drum pressure is Y_U (the ear with the cavities open), U = Y_U (p_EC − Z_cav U), so

    U = Y_U p_EC / (1 + Z_cav Y_U),

and every output of the ear, being linear in the net drum pressure, is the open ear's output times
1 / (1 + Z_cav Y_U) (:func:`cavity_factor`). With X_U = U / (iω) the volume displacement per Pa,
Z_cav Y_U = K_cav X_U, where K_cav = iω Z_cav (Pa/m³, :func:`cavity_stiffness_pa_m3`) is finite at
0 Hz: 1 / (C_tc + C_bc), the two cavities' air springs in parallel.
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources

import numpy as np

from isj.errors import InvalidParameter
from isj.validate import check_frequencies

#: The ear's cavity states: "open" (no cavity load) or "intact" (the cavity network behind the drum).
CAVITY_STATES = ("open", "intact")

#: The default state of the ear's cavities: open, as in the cat measurements the ear's parameters
#: and its comparisons come from (docs/circuit.md §13.3).
DEFAULT_CAVITIES = "open"

#: The circuit's data file inside the package.
CIRCUIT_FILE = "cat_middle_ear_circuit.json"

#: The cavity elements of the circuit and the SI key of each value.
CAVITY_ELEMENTS = {
    "Ctc": "compliance_m3_pa",
    "Cbc": "compliance_m3_pa",
    "Rf": "resistance_pa_s_m3",
    "Mf": "inertance_kg_m4",
}


@cache
def _circuit_text() -> str:
    return (resources.files("isj") / "data" / CIRCUIT_FILE).read_text(encoding="utf-8")


def load_circuit_data() -> dict:
    """The published cat circuit's data file (``isj/data/cat_middle_ear_circuit.json``) as a new dict.

    Element values are SI (Pa·s/m³, kg/m⁴, m³/Pa); ``conversion`` says how they were converted from
    the published CGS acoustic units, ``citations`` and ``where_the_values_were_read`` their sources.
    """
    return json.loads(_circuit_text())


def check_cavities(cavities) -> str:
    """``cavities`` checked: one of :data:`CAVITY_STATES`; raises InvalidParameter otherwise."""
    if cavities not in CAVITY_STATES:
        raise InvalidParameter(f"cavities = {cavities!r}: must be one of {', '.join(CAVITY_STATES)}")
    return cavities


def cavity_values() -> dict:
    """The four cavity elements' values (SI), by name: C_tc, C_bc (m³/Pa), R_f (Pa·s/m³), M_f (kg/m⁴)."""
    els = {e["name"]: e for e in load_circuit_data()["elements"]}
    return {name: float(els[name][key]) for name, key in CAVITY_ELEMENTS.items()}


def cavity_stiffness_pa_m3(freq_hz, cavities: str = "intact") -> np.ndarray:
    """K_cav = iω Z_cav (Pa/m³): the cavity pressure per unit volume displacement of the drum.

    K_cav = 1 / (C_tc + C_bc / (1 + iω C_bc (R_f + iω M_f))), complex, (n_freq,); zeros when
    ``cavities`` is "open". Finite at 0 Hz, where it is 1 / (C_tc + C_bc).
    """
    f = check_frequencies(freq_hz)
    if check_cavities(cavities) == "open":
        return np.zeros(f.size, complex)
    v = cavity_values()
    iw = 2j * np.pi * f
    return 1.0 / (v["Ctc"] + v["Cbc"] / (1.0 + iw * v["Cbc"] * (v["Rf"] + iw * v["Mf"])))


def cavity_impedance_pa_s_m3(freq_hz, cavities: str = "intact") -> np.ndarray:
    """Z_cav (Pa·s/m³), complex (n_freq,): C_tc in parallel with R_f + iω M_f + 1/(iω C_bc).

    Every frequency must be > 0 Hz (Z_cav is a compliance's, infinite at 0 Hz); zeros when open.
    """
    f = check_frequencies(freq_hz)
    if np.any(f <= 0):
        raise InvalidParameter("freq_hz: the cavity impedance needs every frequency > 0 Hz")
    return cavity_stiffness_pa_m3(f, cavities) / (2j * np.pi * f)


def cavity_factor(freq_hz, volume_displacement_m3_per_pa, cavities: str = "intact") -> np.ndarray:
    """1 / (1 + Z_cav Y_U) = 1 / (1 + K_cav X_U): the intact ear's output over the open ear's.

    Parameters
    ----------
    freq_hz : (n_freq,) frequencies (Hz, ≥ 0)
    volume_displacement_m3_per_pa : X_U, the open ear's drum volume displacement per Pa of net
        drum pressure (m³/Pa), complex, (..., n_freq); positive medially (module docstring)
    cavities : "open" (the factor is 1) or "intact"

    Returns
    -------
    complex array of X_U's shape.
    """
    K = cavity_stiffness_pa_m3(freq_hz, cavities)
    X = np.asarray(volume_displacement_m3_per_pa, complex)
    if X.shape[-1:] != K.shape:
        raise InvalidParameter(
            f"volume_displacement_m3_per_pa: last axis {X.shape[-1:]} must match freq_hz ({K.size})"
        )
    return 1.0 / (1.0 + K * X)
