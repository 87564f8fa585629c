"""ΔH_V = H_V / H_V,rigid at 1, 5 and 10 kHz: direct FE, the reduced FE ear, the lumped ear.

Usage: ``.venv/bin/python benchmarks/transmission.py [--cases base p3 p12 j5c20]
[--resolution R] [--json PATH]``

For the rigid incus–stapes connection and each case (docs/transmission.md §12.3): direct FE
harmonic solves of the whole ear (P2, published damping) at the three frequencies, the reduced
FE ear of each (``reduced_ear``, as the report) at the same frequencies, and the lumped ear
with the drum's 300 modes. Prints |H_V| of the rigid ear, each case's ΔH_V in dB and degrees,
the reduced ear's difference from the direct solve, and the seconds of each.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np
from isj.fem.ear import reduced_ear as es
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.model import PedicleJointModel
from isj.lumped.transmission import transmission

from isj.cases import case_by_name
from isj.design import Materials

FREQ_HZ = np.array([1000.0, 5000.0, 10000.0])


def db_deg(r) -> tuple[np.ndarray, np.ndarray]:
    return 20 * np.log10(np.abs(r)), np.degrees(np.angle(r))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["base", "p3", "p12", "j5c20"])
    ap.add_argument("--resolution", type=float, default=1.0)
    ap.add_argument("--json")
    args = ap.parse_args()
    w = 2j * np.pi * FREQ_HZ
    joint = MiddleEarModel(joint=PedicleJointModel(order=2, resolution=args.resolution))
    rigid = MiddleEarModel(geometry=joint.geometry)
    t0 = time.perf_counter()
    h_rigid = w * rigid.frequency_response(FREQ_HZ).response[..., 0][:, 1]
    t_rigid = time.perf_counter() - t0
    print(
        f"rigid connection, direct FE ({t_rigid:.1f} s): |H_V| "
        + ", ".join(
            f"{abs(v):.3e} m/s/Pa ({np.degrees(np.angle(v)):+.1f} deg) at {f:g} Hz"
            for v, f in zip(h_rigid, FREQ_HZ, strict=True)
        )
    )
    rigid_rom = es.reduced_ear(rigid, fmax_hz=20e3)
    h_rigid_rom = w * rigid_rom._outputs(FREQ_HZ)[:, 1]
    lumped = transmission(FREQ_HZ, [case_by_name(c) for c in args.cases])
    report = {"freq_hz": FREQ_HZ.tolist(), "rigid_hv_re_im": [[v.real, v.imag] for v in h_rigid], "cases": {}}
    for k, name in enumerate(args.cases):
        m = case_by_name(name).materials(Materials())
        t0 = time.perf_counter()
        h = w * joint.frequency_response(FREQ_HZ, materials=m).response[..., 0][:, 1]
        t_direct = time.perf_counter() - t0
        t0 = time.perf_counter()
        rom = es.reduced_ear(joint, m, fmax_hz=20e3)
        t_rom = time.perf_counter() - t0
        h_rom = w * rom._outputs(FREQ_HZ)[:, 1]
        d_db, d_deg = db_deg(h / h_rigid)
        r_db, r_deg = db_deg((h_rom / h_rigid_rom) / (h / h_rigid))
        l_db, l_deg = lumped.delta_db[:, k], lumped.delta_deg[:, k]
        print(f"\n{name}: direct FE {t_direct:.1f} s, reduction {t_rom:.1f} s")
        for i, f in enumerate(FREQ_HZ):
            print(
                f"  {f:6.0f} Hz  dH_V FE {d_db[i]:+6.2f} dB {d_deg[i]:+6.1f} deg | reduced - direct "
                f"{r_db[i]:+.1e} dB {r_deg[i]:+.1e} deg | lumped {l_db[i]:+6.2f} dB "
                f"{l_deg[i]:+6.1f} deg"
            )
        report["cases"][name] = {
            "delta_db": d_db.tolist(),
            "delta_deg": d_deg.tolist(),
            "reduced_minus_direct_db": r_db.tolist(),
            "reduced_minus_direct_deg": r_deg.tolist(),
            "lumped_delta_db": l_db.tolist(),
            "lumped_delta_deg": l_deg.tolist(),
            "direct_s": t_direct,
            "reduction_s": t_rom,
        }
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=1)
    return 0


if __name__ == "__main__":
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        raise SystemExit(main())
