"""The report's page on the published cat circuit beside the ear, both cavity states (docs/circuit.md §13).

The circuit of Bruce, Sachs & Young (2003, Appendix A) is a published model fitted to cat
measurements, not a measurement; every label on the page says so. The ear is the transmission
step's FE reduced ear (its first case) in the same cavity state as the circuit it is drawn beside.
"""

from __future__ import annotations

import numpy as np

from .layout import text_block, wrap
from .transmission_step import CIRCUIT_LABEL

#: Line colour per cavity state.
STATE_COLORS = {"open": "C0", "intact": "C3"}


def _deg(x) -> np.ndarray:
    """Phases (deg) unwrapped along frequency, for drawing."""
    return np.degrees(np.unwrap(np.radians(np.asarray(x, float))))


def band_rows(deviation: dict) -> list[str]:
    """The deviation table's lines: per octave band, U_S and P_V/P_EC mean/max |Δ| (dB, deg)."""
    us, pv = deviation["stapes_volume_velocity"], deviation["vestibule_gain"]
    rows = []
    for a, b in zip(us, pv, strict=True):
        lo, hi = a["band_hz"]
        band = f"{lo:7.0f}-{hi:<7.0f}"
        if not a["n_freq"]:
            rows.append(f"{band} (no frequency of the band)")
            continue
        cells = [
            f"{a['mean_abs_db']:8.2f}{a['max_abs_db']:8.2f}{a['mean_db']:+8.2f}"
            f"{a['mean_abs_deg']:8.1f}{a['max_abs_deg']:8.1f}",
            f"{b['mean_abs_db']:8.2f}{b['max_abs_db']:8.2f}{b['mean_abs_deg']:8.1f}{b['max_abs_deg']:8.1f}",
        ]
        rows.append(f"{band}{a['n_freq']:4d}" + "   |".join(cells))
    return rows


def band_header() -> list[str]:
    """The two header lines of :func:`band_rows`' table."""
    return [
        f"{'':19}{'U_S / P_EC':^40}   |{'P_V / P_EC':^32}",
        f"{'band (Hz)':15}{'n':>4}"
        + "".join(f"{h:>8}" for h in ("mean|d|", "max|d|", "mean d", "mean|d|", "max|d|"))
        + "   |"
        + "".join(f"{h:>8}" for h in ("mean|d|", "max|d|", "mean|d|", "max|d|")),
        f"{'':19}"
        + "".join(f"{u:>8}" for u in ("dB", "dB", "dB", "deg", "deg"))
        + "   |"
        + "".join(f"{u:>8}" for u in ("dB", "dB", "deg", "deg")),
    ]


def circuit_page(fig, tr: dict):
    """U_S = A_fp H_V and P_V / P_EC of the ear beside the published cat circuit, open and intact."""
    circ, cav, conv = tr["circuit"], tr["cavities"], tr["drum_convergence"]
    states = [s for s in cav["states"] if s in circ["states"]]  # the configured order
    _circuit_axes(fig, circ, states, conv["within_1db_up_to_hz"])
    text_block(fig, 0.07, 0.565, "\n".join(_circuit_table(circ, states)), fontsize=6.2)
    text_block(fig, 0.07, 0.285, wrap("\n".join(_circuit_notes(circ, cav, conv)), 112), fontsize=6.8)


def _circuit_axes(fig, circ: dict, states: list[str], conv_hz) -> None:
    """Magnitude and phase of U_S and P_V, ear solid and circuit dashed, per cavity state; the band
    above ``conv_hz`` (Hz), where the drum is not converged, grey."""
    f = np.asarray(circ["freq_hz"])
    top, h_mag, h_ph = 0.88, 0.17, 0.09
    ax_um = fig.add_axes([0.10, top - h_mag, 0.37, h_mag])
    ax_up = fig.add_axes([0.10, top - h_mag - 0.01 - h_ph, 0.37, h_ph], sharex=ax_um)
    ax_pm = fig.add_axes([0.59, top - h_mag, 0.37, h_mag], sharex=ax_um)
    ax_pp = fig.add_axes([0.59, top - h_mag - 0.01 - h_ph, 0.37, h_ph], sharex=ax_um)
    for s in states:
        st, color = circ["states"][s], STATE_COLORS.get(s, "k")
        for who, style, lab in (("ear", "-", f"ear (FE, {circ['case']})"), ("circuit", "--", "cat circuit")):
            us, pv = st[who]["stapes_volume_velocity"], st[who]["vestibule_gain"]
            ax_um.loglog(f, us["magnitude"], style, color=color, lw=1, label=f"{lab}, cavities {s}")
            ax_up.semilogx(f, _deg(us["phase_deg"]), style, color=color, lw=1)
            ax_pm.semilogx(f, pv["db"], style, color=color, lw=1)
            ax_pp.semilogx(f, _deg(pv["phase_deg"]), style, color=color, lw=1)
    ax_um.set_title("stapes volume velocity U_S / P_EC (m^3/s/Pa)", fontsize=7.5)
    ax_pm.set_title("vestibule-pressure gain P_V / P_EC (dB)", fontsize=7.5)
    ax_up.set_ylabel("phase (deg)", fontsize=6.5)
    ax_pp.set_ylabel("phase (deg)", fontsize=6.5)
    ax_um.legend(fontsize=5.5, loc="lower center")
    for ax in (ax_um, ax_up, ax_pm, ax_pp):
        ax.tick_params(labelsize=6)
        ax.grid(True, which="both", lw=0.3)
        if conv_hz is not None:
            ax.axvspan(conv_hz, f[-1], color="0.92", lw=0, zorder=0)
    for ax in (ax_up, ax_pp):
        ax.set_xlabel("frequency (Hz)", fontsize=6.5)
    for ax in (ax_um, ax_pm):
        ax.tick_params(labelbottom=False)
    fig.text(
        0.07,
        0.928,
        f"dashed: the cat circuit, {CIRCUIT_LABEL}; solid: the ear in the same cavity state"
        + ("; grey: the drum is not converged to 1 dB" if conv_hz is not None else ""),
        fontsize=6.5,
    )


def _circuit_table(circ: dict, states: list[str]) -> list[str]:
    """The deviation ear / circuit per octave band, per cavity state."""
    lines = [
        "Deviation d = ear / cat circuit (" + CIRCUIT_LABEL + ") per octave band, same cavity state:",
    ]
    for s in states:
        lines += ["", f"cavities {s}:", *band_header(), *band_rows(circ["states"][s]["deviation_per_band"])]
    return lines


def _circuit_notes(circ: dict, cav: dict, conv: dict) -> list[str]:
    """The drum's converged band, ΔH_V in both cavity states, what the circuit is."""
    notes = []
    conv_hz, size_mm = conv["within_1db_up_to_hz"], conv["drum_mesh_size_m"] * 1e3
    if conv_hz is not None:
        notes.append(
            f"The ear's drum ({size_mm:.3g} mm) is converged up to {conv_hz / 1e3:.1f} kHz: there it and "
            f"the finest drum measured ({conv['against_m'] * 1e3:.3g} mm) agree within 1 dB in H_V; "
            f"dH_V agrees within 0.1 dB up to {conv['delta_within_0p1db_up_to_hz'] / 1e3:.1f} kHz and "
            f"within 1 deg up to {conv['delta_within_1deg_up_to_hz'] / 1e3:.1f} kHz ({conv['source']}). "
            "Above it (grey) the ear's own mesh error is of the order of the deviations shown."
        )
    else:
        notes.append(
            f"The band in which this drum (mesh size {size_mm:.3g} mm) is converged has not been "
            "measured (docs/ear.md 5.15 measured 0.25, 0.18, 0.125 and 0.09 mm)."
        )
    q = cav["quote"]
    first = circ["case"]
    if len(cav["states"]) == 2 and q:
        notes.append(
            f"dH_V of {first} against the rigid connection, cavities open / intact: "
            + "; ".join(
                f"{x['freq_hz']:.0f} Hz {x['open']['delta_db'][first]:+.2f} / "
                f"{x['intact']['delta_db'][first]:+.2f} dB, {x['open']['delta_deg'][first]:+.1f} / "
                f"{x['intact']['delta_deg'][first]:+.1f} deg"
                for x in q
            )
            + "."
        )
    notes.append(
        "U_S = A_fp H_V with the footplate area "
        f"A_fp = {circ['footplate_area_m2'] * 1e6:.2f} mm^2; P_V = Z_C U_S with the cochlear resistance "
        f"Z_C = {circ['cochlear_impedance_pa_s_m3']:.3g} Pa s/m^3 the ear's cochlear dashpot stands for. "
        "The circuit (Bruce, Sachs & Young 2003, Appendix A; cavities after Peake, Rosowski & Lynch "
        "1992; cochlear load after Lynch et al. 1982) is a " + CIRCUIT_LABEL.split(" (")[0] + " fitted "
        "to cat measurements, not a measurement: agreement says the two models agree, not that either "
        "matches a cat. Nothing in the ear is tuned to it. Its drum was fitted with the cavities intact, "
        "so the intact pair is the comparison that carries weight; the open circuit is the same network "
        "with its cavity elements removed (docs/circuit.md 13.2). The ear's default state is "
        f"cavities {cav['default_cavities']} (docs/circuit.md 13.3); every other page shows the open ear."
    )
    return notes
