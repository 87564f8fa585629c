"""FE whole ear over the audio band through the reduced model (fem/ear/reduced_ear.py): cost and accuracy.

Usage: ``.venv/bin/python benchmarks/ear_sweep_fe.py [--order 2] [--resolution R] [--n 200]
[--checks 3] [--refined-drum-m 0.125e-3 | --no-convergence] [--json PATH]``

On the whole ear with the joint model inside (P2, default resolution 1, the published damping):
the reduction's build time (joint condensation, shell bases, projection), the cost per frequency
and for ``--n`` log-spaced frequencies over 100 Hz – 20 kHz, direct FE harmonic solves at
``--checks`` frequencies (both band ends included), the ratio of ``--n`` direct solves' time to the
reduced model's (reduction included), and the largest magnitude and phase errors against the
direct solves. Then the eardrum mesh convergence: H_V on the default drum (0.25 mm) and a refined
one, and up to which frequency they agree within 1 dB.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.ear.reduced_ear import (
    check_against_direct,
    check_frequencies_hz,
    drum_mesh_convergence,
    reduced_ear,
)
from isj.fem.model import PedicleJointModel


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order", type=int, default=2)
    ap.add_argument("--resolution", type=float, default=1.0)
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--checks", type=int, default=3)
    ap.add_argument("--fmin-hz", type=float, default=100.0)
    ap.add_argument("--fmax-hz", type=float, default=20e3)
    ap.add_argument("--refined-drum-m", type=float, default=0.125e-3)
    ap.add_argument("--no-convergence", action="store_true")
    ap.add_argument("--json", metavar="PATH")
    args = ap.parse_args()

    t0 = time.perf_counter()
    joint = PedicleJointModel(order=args.order, resolution=args.resolution)
    model = MiddleEarModel(joint=joint)
    t_model = time.perf_counter() - t0
    freqs = np.geomspace(args.fmin_hz, args.fmax_hz, args.n)
    t0 = time.perf_counter()
    rom = reduced_ear(model, fmax_hz=args.fmax_hz)
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    H = rom.frequency_response(freqs)
    t_sweep = time.perf_counter() - t0
    chk = check_against_direct(model, rom, check_frequencies_hz(args.fmin_hz, args.fmax_hz, args.checks))
    t_direct = chk["direct_seconds_per_frequency"]
    ratio = args.n * t_direct / (t_build + t_sweep)
    steps = rom.info["timings_s"]
    print(
        f"FE ear P{args.order}, resolution {args.resolution:g}: {model.n_dofs} dofs "
        f"(built in {t_model:.1f} s)"
    )
    print(
        f"  reduced: {rom.info['level1_dofs']} dofs after the joint's condensation, "
        f"{rom.n_dofs} after the shells'"
    )
    print(
        f"  reduction {t_build:.1f} s (parts {steps['parts']:.1f}, joint {steps['joint']:.1f}, "
        f"shells {steps['shells']:.1f}, projection {steps['project']:.1f})"
    )
    print(
        f"  per frequency {1e3 * t_sweep / args.n:.2f} ms; {args.n} frequencies {t_sweep:.2f} s; "
        f"with the reduction {t_build + t_sweep:.1f} s"
    )
    print(
        f"  direct harmonic solve {t_direct:.2f} s per frequency: {args.n} of them "
        f"{args.n * t_direct:.0f} s, {ratio:.1f} x the reduced model's total"
    )
    tail = "_mag_rel_error"
    verdict = "passed" if chk["passed"] else "FAILED"
    for ck in chk["checks"]:
        errs = ", ".join(
            f"{k[: -len(tail)]} {v:.1e} / {ck[k.replace(tail, '_phase_error_deg')]:.1e} deg"
            for k, v in ck.items()
            if k.endswith(tail)
        )
        print(f"  check {ck['freq_hz']:8.0f} Hz (relative magnitude / phase): {errs}")
    print(
        f"  largest error against the direct solves: {chk['max_mag_rel_error']:.2e} in magnitude, "
        f"{chk['max_phase_error_deg']:.2e} deg in phase ({verdict})"
    )
    out = {
        "n_dofs": model.n_dofs,
        "reduced_dofs": rom.n_dofs,
        "level1_dofs": rom.info["level1_dofs"],
        "model_s": t_model,
        "reduction_s": t_build,
        "reduction_steps_s": steps,
        "per_frequency_s": t_sweep / args.n,
        "sweep_s": t_sweep,
        "direct_per_frequency_s": t_direct,
        "ratio_direct_to_reduced": ratio,
        "check": chk,
        "h_v_abs_m_s_pa": [float(v) for v in np.abs(H["stapes_velocity_m_s"])],
    }
    if not args.no_convergence:
        # the refined drum's reduced model is checked against its own direct solves at 20 kHz
        conv = drum_mesh_convergence(joint, freqs, (0.25e-3, args.refined_drum_m), check_hz=[args.fmax_hz])
        f_ok = conv["agree_up_to_hz"]
        where = f"{f_ok:.0f} Hz" if f_ok is not None else "nowhere"
        print(
            f"  drum meshes 0.25 mm ({conv['n_dofs'][0]} dofs) and {1e3 * args.refined_drum_m:g} mm "
            f"({conv['n_dofs'][1]} dofs): H_V within 1 dB up to {where} "
            f"(largest difference {np.abs(conv['diff_db']).max():.2f} dB; "
            f"{conv['seconds'][1]:.0f} s)"
        )
        ck = conv["checks"][1]
        print(
            f"  refined drum's reduced model at {args.fmax_hz:.0f} Hz against a direct solve: "
            f"{ck['max_mag_rel_error']:.2e} in magnitude, {ck['max_phase_error_deg']:.2e} deg"
        )
        out["convergence"] = {
            k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in conv.items() if k != "h_v"
        }
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
