"""The FE ear beside the published cat circuit, per octave band, cavities open and intact.

Usage: ``.venv/bin/python benchmarks/circuit_comparison.py [--resolution R] [--n-freq N]
[--json PATH]`` (default ``benchmarks/results/circuit_comparison.json``).

The reduced FE ear (``reduced_ear``, P2, default meshes, base case, published damping; docs/ear.md
§5.14) is compared with the circuit of Bruce, Sachs & Young (2003, App. A), a published model
fitted to cat measurements, not a measurement, in the same cavity state
(:func:`isj.studies.circuit_comparison.fe_ear_comparison`): its stapes volume velocity A_fp H_V and
vestibule-pressure gain Z_C A_fp H_V against the circuit's, magnitude and phase, per octave band.
Also: the circuit's check values, the lumped ear's comparison, and two checks of the cavity factor
1/(1 + Z_cav Y_U): against a dense monolithic solve of the reduced ear with the back pressure
coupled in, and the reduced ear against direct FE harmonic solves, both with the cavities intact.
Prints the per-band table and the seconds of each step.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from isj.fem.ear.dynamics import harmonic
from isj.fem.ear.joint_condensation import dynamic_terms, part_coefficients
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.ear.reduced_ear import reduced_ear
from isj.fem.model import PedicleJointModel

from isj.atomic import atomic_write_json
from isj.cavities import cavity_stiffness_pa_m3
from isj.studies.circuit_comparison import (
    circuit_check_values,
    fe_ear_comparison,
    lumped_ear_comparison,
)

RESULTS = Path(__file__).resolve().parent / "results" / "circuit_comparison.json"
MONOLITHIC_HZ = np.array([150.0, 1500.0, 4400.0, 12e3, 20e3])
DIRECT_HZ = np.array([1500.0, 4400.0])


def monolithic_check(rom, freq_hz) -> float:
    """Largest relative difference, over the reduced ear's output rows, between the cavity factor
    and the dense solve of (Z(ω) + K_cav(ω) l lᵀ) y = l, l = Vᵀf the drum's load per Pa."""
    A0, A1, M = (
        np.asarray(X, complex)
        for X in dynamic_terms(rom.stiffness, rom.mass, rom.dashpots, part_coefficients(None, rom))
    )
    w = 2 * np.pi * freq_hz
    Z = A0[None] + 1j * w[:, None, None] * A1[None] - w[:, None, None] ** 2 * M[None]
    Z = Z + cavity_stiffness_pa_m3(freq_hz)[:, None, None] * np.outer(rom.load, rom.load)[None]
    y = np.linalg.solve(Z, np.broadcast_to(rom.load.astype(complex), (w.size, rom.n_dofs))[..., None])[..., 0]
    mono = y @ rom.rows.T
    fac = rom.with_cavities("intact")._solve(freq_hz) @ rom.rows.T
    return float(np.max(np.abs(fac - mono) / np.abs(mono).max(axis=0)))


def print_table(name: str, result: dict) -> None:
    print(f"\n{name}: ear against the published cat circuit (a model fitted to cat data, not a measurement)")
    for state, s in result["states"].items():
        for q, rows in s["deviation_per_band"].items():
            print(f"  cavities {state}, {q}: band (Hz)  mean|d| max|d| mean d (dB) | mean|d| max|d| (deg)")
            for r in rows:
                lo, hi = r["band_hz"]
                db = f"{r['mean_abs_db']:6.2f} {r['max_abs_db']:6.2f} {r['mean_db']:+7.2f}"
                print(f"    {lo:7.0f}-{hi:7.0f}  {db}   | {r['mean_abs_deg']:6.1f} {r['max_abs_deg']:6.1f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=1.0, help="joint mesh resolution (default 1)")
    ap.add_argument("--n-freq", type=int, default=200, help="log-spaced frequencies, 100 Hz-20 kHz")
    ap.add_argument("--json", default=str(RESULTS))
    args = ap.parse_args()
    if not 2 <= args.n_freq <= 2000:
        ap.error(f"--n-freq {args.n_freq}: must be 2-2000")
    freq_hz = np.geomspace(100.0, 20e3, args.n_freq)
    t = {}
    t0 = time.perf_counter()
    model = MiddleEarModel(joint=PedicleJointModel(order=2, resolution=args.resolution))
    t["model_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    rom = reduced_ear(model, fmax_hz=20e3)
    t["reduction_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    fe = fe_ear_comparison(rom, freq_hz)
    t["fe_comparison_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    lumped = lumped_ear_comparison(freq_hz)
    t["lumped_comparison_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    mono = monolithic_check(rom, MONOLITHIC_HZ)
    t["monolithic_check_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    direct = harmonic(model, DIRECT_HZ, cavities="intact").stapes_m_per_pa
    red = rom.with_cavities("intact").frequency_response(DIRECT_HZ)["stapes_m"]
    t["direct_check_s"] = time.perf_counter() - t0
    direct_err = {
        "freq_hz": DIRECT_HZ.tolist(),
        "stapes_magnitude_rel": np.abs(np.abs(red) / np.abs(direct) - 1).tolist(),
        "stapes_phase_deg": np.abs(np.degrees(np.angle(red / direct))).tolist(),
    }
    out = {
        "what": fe["what"],
        "ear": {
            "model": "reduced FE ear, P2 joint mesh",
            "joint_resolution": args.resolution,
            "case": "base",
            "damping": "published (docs/dynamics.md §4.3)",
            "n_fe_dofs": int(model.n_dofs),
            "n_reduced": int(rom.n_dofs),
        },
        "circuit_check_values": circuit_check_values(),
        "cavity_factor_checks": {
            "monolithic_reduced_ear": {"freq_hz": MONOLITHIC_HZ.tolist(), "max_rel_diff": mono},
            "reduced_vs_direct_fe_intact": direct_err,
        },
        "fe": fe,
        "lumped": lumped,
        "timings_s": t,
    }
    atomic_write_json(args.json, out)
    print_table("FE reduced ear", fe)
    print_table("lumped ear", lumped)
    print(f"\ncavity factor against the monolithic reduced solve: {mono:.1e} (largest relative difference)")
    print(f"reduced against direct FE, cavities intact: {direct_err}")
    print("seconds: " + ", ".join(f"{k} {v:.1f}" for k, v in t.items()))
    print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
