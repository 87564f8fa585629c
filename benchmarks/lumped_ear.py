"""Lumped ossicular chain (lumped/ear.py) against the FE whole ear: static per Pa, sweep time, modes.

Usage: ``.venv/bin/python benchmarks/lumped_ear.py [--resolution R] [--json PATH]``

Prints the lumped and FE static umbo and stapes displacements per Pa of
ear-canal pressure (rigid joint; embedded joint at the given joint-mesh
resolution; the one-dof body about the nominal axis), α and β, the time of a
1000-frequency sweep (one design and 1000 designs × 100 frequencies), and the
lumped natural frequencies. Nothing is tuned.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.model import PedicleJointModel
from isj.lumped.ear import ear_model

NM, URAD = 1e9, 1e6


def _row(label, y, fe=None):
    s = f"{label:40s} umbo {y[0] * NM:7.3f}  stapes {y[1] * NM:7.3f} nm/Pa"
    if y[2]:
        s += f"  alpha {y[2] * URAD:.4f}  beta {y[3] * URAD:.4f} urad/Pa"
    if fe is not None:
        s += f"   rel. to FE: umbo {y[0] / fe[0] - 1:+.2%}, stapes {y[1] / fe[1] - 1:+.2%}"
        if fe[2]:
            s += f", alpha {y[2] / fe[2] - 1:+.2%}, beta {y[3] / fe[3] - 1:+.2%}"
    return s


def _fe(r):
    return [r.umbo_m_per_pa, r.footplate_piston_m_per_pa, r.alpha_rad_per_pa or 0.0, r.beta_rad_per_pa or 0.0]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=1.0, help="joint mesh refinement (1 = default mesh)")
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    report: dict = {}

    fe_rigid = _fe(MiddleEarModel().static())
    fe_joint = _fe(MiddleEarModel(joint=PedicleJointModel(order=2, resolution=args.resolution)).static())
    cases = {
        "rigid joint": (ear_model(rigid_joint=True), fe_rigid),
        f"embedded joint (FE resolution {args.resolution:g})": (ear_model(), fe_joint),
        "rigid joint, one-dof body (nominal axis)": (ear_model(rigid_joint=True, body="rotation"), fe_rigid),
        "joint, one-dof body (nominal axis)": (ear_model(body="rotation"), fe_joint),
    }
    print("-- static, per Pa of ear-canal pressure: lumped, and relative to the FE whole ear")
    for label, (ear, fe) in cases.items():
        y = ear.static().outputs
        print("FE " + _row(label, fe))
        print("   " + _row(label, y, fe))
        f_n, zeta = ear.system.poles()
        report[label] = {
            "lumped": y.tolist(),
            "fe": fe,
            "natural_freq_hz": f_n.tolist(),
            "zeta": zeta.tolist(),
        }

    ear = ear_model()
    f = np.geomspace(100, 20e3, 1000)
    ear._freq_resp(f)
    t0 = time.perf_counter()
    ear._freq_resp(f)
    t1 = time.perf_counter()
    gap = np.geomspace(1e6, 50e6, 1000)
    many = ear_model(gap_e_pa=gap)
    t2 = time.perf_counter()
    many._freq_resp(f[::10])
    t3 = time.perf_counter()
    print(
        f"\n-- sweep: 1000 frequencies, one design {1e3 * (t1 - t0):.2f} ms; 1000 designs: assembly "
        f"{1e3 * (t2 - t1):.1f} ms, x 100 frequencies {1e3 * (t3 - t2):.0f} ms"
    )
    f_n, zeta = ear.system.poles()
    print(
        "-- natural frequencies (embedded joint, estimated masses): "
        + ", ".join(f"{v:.0f} Hz (zeta {z:.2f})" for v, z in zip(f_n, zeta, strict=True))
    )
    print(f"   coordinates {ear.coordinates}")
    report["timing_s"] = {"sweep_1000": t1 - t0, "assemble_1000_designs": t2 - t1, "designs_x_freq": t3 - t2}
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
