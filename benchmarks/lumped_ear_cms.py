"""The lumped ear with the drum's component modes (docs/ear.md §5.10) against FE harmonic solves.

Usage: ``.venv/bin/python benchmarks/lumped_ear_cms.py [--drum-mesh-m H] [--joint-freq-hz F ...]
[--resolution R] [--json PATH]``

1. Rigid joint: FE harmonic solves (:mod:`fem.ear.dynamics`, published damping) at 14
   log-spaced frequencies from 200 Hz to 8 kHz; the lumped ear with n = none, 10, 20, 30, 40,
   60 and 80 drum modes, each mode count's worst error in dB and degrees (umbo and stapes per Pa)
   up to 5 kHz and the highest frequency below which both stay within 1 dB and 10°.
2. Joint inside (P2 at ``--resolution``): FE at the ``--joint-freq-hz`` frequencies (6 s each
   on the default meshes), lumped with no modes and with 40.
3. Evaluation time: 1000 frequencies for one design; 100 designs (gap modulus) × 1000
   frequencies, best of three, with no modes and with 40 and 120.

The drum's modes come from :func:`fem.ear.drum_modes.drum_modes` on the FE ear's drum mesh
(``--drum-mesh-m``; on the default mesh they are the shipped ones). Nothing is tuned.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np
from isj.fem.ear.drum_modes import drum_modes
from isj.fem.ear.lumped_params import eardrum_parameters
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.model import PedicleJointModel
from isj.lumped.ear import EardrumParameters, ear_model
from isj.lumped.ear_drum import DrumModes

MODE_COUNTS = (None, 10, 20, 30, 40, 60, 80)


def errors(lumped: np.ndarray, fe: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dB and degrees of lumped / FE, (n_freq, 2) for umbo and stapes."""
    r = lumped[:, :2] / fe[:, :2]
    return 20 * np.log10(np.abs(r)), np.degrees(np.angle(r))


def holds_below(f, db, deg, tol_db=1.0, tol_deg=10.0) -> float:
    """The first frequency (Hz) where |dB| > tol_db or |deg| > tol_deg (inf if none)."""
    bad = ((np.abs(db) > tol_db) | (np.abs(deg) > tol_deg)).any(axis=1)
    return float(f[np.argmax(bad)]) if bad.any() else float("inf")


def best_of(fn, k=3) -> float:
    times = []
    for _ in range(k):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drum-mesh-m", type=float, default=0.25e-3, help="eardrum element size (m)")
    ap.add_argument("--resolution", type=float, default=1.0, help="joint mesh refinement")
    ap.add_argument("--joint-freq-hz", type=float, nargs="*", default=[500.0, 2000.0, 3500.0, 5000.0])
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    h = args.drum_mesh_m
    report: dict = {"drum_mesh_m": h}
    drum = EardrumParameters.from_dict(eardrum_parameters(mesh_size_m=h))
    t0 = time.perf_counter()
    modes = DrumModes.from_dict(drum_modes(n_modes=max(c or 0 for c in MODE_COUNTS) + 40, mesh_size_m=h))
    report["drum_modes_s"] = time.perf_counter() - t0
    print(
        f"drum mesh {h * 1e3:g} mm: {modes.n_modes} fixed-interface modes, {modes.freq_hz[0]:.0f} to "
        f"{modes.freq_hz[-1]:.0f} Hz, in {report['drum_modes_s']:.2f} s"
    )

    # ---- 1. rigid joint
    f = np.geomspace(200.0, 8000.0, 14)
    fe_model = MiddleEarModel(drum_mesh_size_m=h)
    t0 = time.perf_counter()
    fe = fe_model.frequency_response(f).response[..., 0]
    t_fe = (time.perf_counter() - t0) / f.size
    print(
        f"\n-- rigid joint: FE {t_fe:.2f} s per frequency; lumped/FE at " + ", ".join(f"{v:.0f}" for v in f)
    )
    rows = {}
    for n in MODE_COUNTS:
        ear = ear_model(rigid_joint=True, eardrum=drum, drum_modes=None if n is None else modes.truncated(n))
        db, deg = errors(ear._freq_resp(f), fe)
        lim = holds_below(f, db, deg)
        to5 = f <= 5000
        label = "no modes" if n is None else f"{n} modes (to {modes.freq_hz[n - 1]:.0f} Hz)"
        rows[str(n)] = {
            "holds_below_hz": lim,
            "worst_db_to_5khz": float(np.abs(db[to5]).max()),
            "worst_deg_to_5khz": float(np.abs(deg[to5]).max()),
            "umbo_db": db[:, 0].tolist(),
            "umbo_deg": deg[:, 0].tolist(),
            "stapes_db": db[:, 1].tolist(),
            "stapes_deg": deg[:, 1].tolist(),
        }
        w_db, w_deg = rows[str(n)]["worst_db_to_5khz"], rows[str(n)]["worst_deg_to_5khz"]
        print(
            f"{label:28s} within 1 dB, 10 deg below {lim:7.0f} Hz; worst to 5 kHz {w_db:6.2f} dB "
            f"{w_deg:6.1f} deg"
        )
        print("    umbo dB  " + " ".join(f"{v:6.2f}" for v in db[:, 0]))
        print("    umbo deg " + " ".join(f"{v:6.1f}" for v in deg[:, 0]))
    report["rigid"] = {"freq_hz": f.tolist(), "fe_s_per_freq": t_fe, "lumped": rows}

    # ---- 2. the joint inside
    if args.joint_freq_hz:
        fj = np.asarray(args.joint_freq_hz, dtype=float)
        joint = MiddleEarModel(
            joint=PedicleJointModel(order=2, resolution=args.resolution), drum_mesh_size_m=h
        )
        t0 = time.perf_counter()
        fe_j = joint.frequency_response(fj).response[..., 0]
        t_j = (time.perf_counter() - t0) / fj.size
        print(f"\n-- joint inside (P2, resolution {args.resolution:g}): FE {t_j:.1f} s per frequency")
        out = {"freq_hz": fj.tolist(), "fe_s_per_freq": t_j}
        for n in (None, 40):
            ear = ear_model(eardrum=drum, drum_modes=None if n is None else modes.truncated(n))
            H = ear._freq_resp(fj)
            db, deg = errors(H, fe_j)
            ab = H[:, 2:] / fe_j[:, 2:]
            out[str(n)] = {
                "umbo_stapes_db": db.tolist(),
                "umbo_stapes_deg": deg.tolist(),
                "alpha_beta_db": (20 * np.log10(np.abs(ab))).tolist(),
                "alpha_beta_deg": np.degrees(np.angle(ab)).tolist(),
            }
            lab = "no modes" if n is None else f"{n} modes"
            for i, fi in enumerate(fj):
                a_db, b_db = out[str(n)]["alpha_beta_db"][i]
                print(
                    f"  {lab:9s} {fi:6.0f} Hz: umbo {db[i, 0]:+6.2f} dB {deg[i, 0]:+6.1f} deg, stapes "
                    f"{db[i, 1]:+6.2f} dB {deg[i, 1]:+6.1f} deg, alpha {a_db:+6.2f} dB, "
                    f"beta {b_db:+6.2f} dB"
                )
        report["joint"] = out

    # ---- 3. evaluation time (the default drum's shipped modes)
    ff = np.geomspace(100.0, 20e3, 1000)
    gap = np.geomspace(1e6, 50e6, 100)
    timing = {}
    print("\n-- evaluation (best of 3)")
    for n in (None, 40, 120):
        one = ear_model(drum_modes=n)
        many = ear_model(gap_e_pa=gap, drum_modes=n)
        t_one = best_of(lambda e=one: e.freq_resp(ff))
        t_many = best_of(lambda e=many: e.freq_resp(ff))
        t_asm = best_of(lambda n=n: ear_model(gap_e_pa=gap, drum_modes=n))
        timing[str(n)] = {
            "one_design_1000_freq_s": t_one,
            "assemble_100_designs_s": t_asm,
            "100_designs_1000_freq_s": t_many,
        }
        lab = "no modes" if n is None else f"{n} modes"
        print(
            f"  {lab:9s} one design x 1000 frequencies {t_one * 1e3:6.1f} ms "
            f"({t_one * 1e3:.1f} us each); 100 designs: assembly {t_asm * 1e3:6.1f} ms, x 1000 frequencies "
            f"{t_many * 1e3:6.0f} ms ({t_many * 1e6 / 1e5:.1f} us per design and frequency)"
        )
    report["timing"] = timing
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=1)
    return 0


if __name__ == "__main__":
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        raise SystemExit(main())
