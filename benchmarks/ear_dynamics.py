"""Whole cat middle ear, dynamics (docs/ear.md §5.11): FE natural frequencies, lumped vs FE per Pa, timings.

Usage: ``.venv/bin/python benchmarks/ear_dynamics.py [--resolution R] [--json PATH]``

For the rigid-joint variant and the embedded joint (P2, default resolution 1):
the lowest FE natural frequencies and how much of each mode's kinetic energy
is in the eardrum, then FE and lumped |umbo|, |stapes| (nm/Pa) and their phases
at 100 Hz, 1 kHz, the first FE natural frequency and 5 kHz (docs/dynamics.md §4.3 damping,
:class:`isj.ear.EarMasses`), with the time of one harmonic solve. Nothing is tuned.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from isj.fem.ear import dynamics as ed
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.model import PedicleJointModel
from isj.lumped.ear import ear_model


def run(label: str, model: MiddleEarModel, rigid_joint: bool, n_modes: int = 6) -> dict:
    t0 = time.perf_counter()
    modes = ed.natural_frequencies(model, n_modes)
    t_modes = time.perf_counter() - t0
    Mf = ed.full_mass(model)
    drum = []
    for i in range(n_modes):
        u = modes.shapes[:, i]
        v = np.zeros_like(u)
        v[model.off_drum : model.off_fp] = u[model.off_drum : model.off_fp]
        drum.append(float(v @ (Mf @ u)))
    lumped = ear_model(rigid_joint=rigid_joint)
    f1 = float(modes.freq_hz[0])
    freq = np.array([100.0, 1000.0, f1, 5000.0])
    t0 = time.perf_counter()
    fe = model.frequency_response(freq[:1]).response[..., 0]
    t_one = time.perf_counter() - t0
    fe = model.frequency_response(freq).response[..., 0]
    lum = lumped._freq_resp(freq)
    print(f"{label}: {model.n_dofs} dofs; natural frequencies (Hz, drum share of kinetic energy):")
    print("  " + ", ".join(f"{f:.0f} ({d:.2f})" for f, d in zip(modes.freq_hz, drum, strict=True)))
    print("  lumped: " + ", ".join(f"{f:.0f}" for f in lumped.natural_frequencies_hz(4)) + " Hz")
    rows = []
    for i, f in enumerate(freq):
        row = {"freq_hz": float(f)}
        for j, k in enumerate(("umbo_m", "stapes_m")):
            row[f"fe_{k}_abs"], row[f"lumped_{k}_abs"] = float(abs(fe[i, j])), float(abs(lum[i, j]))
            row[f"fe_{k}_phase_deg"] = float(np.degrees(np.angle(fe[i, j])))
            row[f"lumped_{k}_phase_deg"] = float(np.degrees(np.angle(lum[i, j])))
        rows.append(row)
        r = {k: v * 1e9 if k.endswith("_abs") else v for k, v in row.items()}
        print(
            f"  {f:7.0f} Hz  umbo FE {r['fe_umbo_m_abs']:6.2f} nm/Pa {r['fe_umbo_m_phase_deg']:7.1f} deg,"
            f" lumped {r['lumped_umbo_m_abs']:6.2f} {r['lumped_umbo_m_phase_deg']:7.1f} | stapes FE "
            f"{r['fe_stapes_m_abs']:6.2f} {r['fe_stapes_m_phase_deg']:7.1f}, lumped "
            f"{r['lumped_stapes_m_abs']:6.2f} {r['lumped_stapes_m_phase_deg']:7.1f}"
        )
    print(f"  one harmonic solve (with the static one) {t_one:.2f} s; {n_modes} modes {t_modes:.2f} s")
    return {
        "label": label,
        "n_dofs": model.n_dofs,
        "natural_freq_hz": [float(f) for f in modes.freq_hz],
        "drum_energy_share": drum,
        "lumped_natural_freq_hz": [float(f) for f in lumped.natural_frequencies_hz()],
        "response": rows,
        "timings_s": {"one_harmonic": t_one, "modes": t_modes},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=1.0, help="joint mesh resolution (default 1)")
    ap.add_argument("--json", metavar="PATH", help="write the results as JSON")
    args = ap.parse_args()
    out = [run("rigid joint", MiddleEarModel(), True)]
    t0 = time.perf_counter()
    ear = MiddleEarModel(joint=PedicleJointModel(order=2, resolution=args.resolution))
    print(f"embedded joint model built in {time.perf_counter() - t0:.1f} s")
    out.append(run(f"embedded joint (P2, resolution {args.resolution:g})", ear, False))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
