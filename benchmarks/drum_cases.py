"""ΔH_V of the thesis's pedicle and joint cases on today's drum and on the converged drum.

Usage: ``nice -n 10 .venv/bin/python benchmarks/drum_cases.py [--drum-mm 0.25 0.125]
[--cases base p3 p12 j5c20] [--resolution 1] [--json PATH]``

On one joint mesh (P2, ``--resolution``; 1 is the default mesh) and each drum element size
(``MiddleEarModel(drum_mesh_size_m=...)``; 0.25 mm is the default drum, 0.125 mm the coarsest that
meets the convergence target of ``benchmarks/drum_convergence.py``, docs/ear.md §5.15), the reduced
FE ear (:func:`isj.fem.ear.reduced_ear.reduced_ear`, published damping) of each case and of the
rigid connection of the same ear: ΔH_V = H_V / H_V,rigid in dB and degrees at 1, 5 and 10 kHz, and
the largest |ΔH_V| to 10 kHz, with the change from the coarsest to the finest drum given. Written
atomically to ``--json`` after every reduction (a rerun with the same settings reuses them).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.ear.reduced_ear import reduced_ear
from isj.fem.model import PedicleJointModel

from isj.atomic import atomic_write_json
from isj.cases import case_by_name
from isj.design import Materials

OUT = Path(__file__).resolve().parent / "results" / "drum_cases.json"
QUOTE_HZ = (1000.0, 5000.0, 10000.0)
FREQ_HZ = np.unique(np.concatenate([np.geomspace(100.0, 20e3, 81), QUOTE_HZ]))


def stapes_velocity(model, materials) -> tuple[np.ndarray, float]:
    """H_V (m/s per Pa) over :data:`FREQ_HZ` from one reduction, and its seconds."""
    t0 = time.perf_counter()
    rom = reduced_ear(model, materials, fmax_hz=20e3)
    hv = rom.frequency_response(FREQ_HZ)["stapes_velocity_m_s"]
    return hv, time.perf_counter() - t0


def delta_row(hv, hv_rigid) -> dict:
    d = hv / hv_rigid
    db, deg = 20 * np.log10(np.abs(d)), np.degrees(np.angle(d))
    at = [int(np.flatnonzero(FREQ_HZ == q)[0]) for q in QUOTE_HZ]
    low = FREQ_HZ <= 10e3
    return {
        "delta_db_at_1_5_10_khz": [float(db[i]) for i in at],
        "delta_deg_at_1_5_10_khz": [float(deg[i]) for i in at],
        "max_abs_delta_db_to_10khz": float(np.abs(db[low]).max()),
        "max_abs_delta_deg_to_10khz": float(np.abs(deg[low]).max()),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drum-mm", type=float, nargs="+", default=[0.25, 0.125])
    ap.add_argument("--cases", nargs="+", default=["base", "p3", "p12", "j5c20"])
    ap.add_argument("--resolution", type=float, default=1.0)
    ap.add_argument("--json", metavar="PATH", default=str(OUT))
    args = ap.parse_args(argv)
    path = Path(args.json)
    settings = {"drum_mm": args.drum_mm, "cases": args.cases, "resolution": args.resolution, "order": 2}
    old = json.loads(path.read_text()) if path.exists() else {}
    res = old if old.get("settings") == settings else {"settings": settings, "drums": {}}
    joint = PedicleJointModel(order=2, resolution=args.resolution)
    for mm in args.drum_mm:
        key = f"{mm:g}"
        row = res["drums"].setdefault(key, {"cases": {}, "seconds": {}})
        if len(row["cases"]) == len(args.cases):
            continue
        ear = MiddleEarModel(joint=joint, drum_mesh_size_m=mm * 1e-3)
        rigid = MiddleEarModel(geometry=ear.geometry, drum_mesh_size_m=mm * 1e-3)
        hv_r, row["seconds"]["rigid"] = stapes_velocity(rigid, Materials())
        row["triangles"] = int(len(ear.drum.triangles))
        for name in args.cases:
            hv, row["seconds"][name] = stapes_velocity(ear, case_by_name(name).materials(Materials()))
            row["cases"][name] = delta_row(hv, hv_r)
            atomic_write_json(path, res)
            q = row["cases"][name]
            print(
                f"drum {key} mm  {name:6s} dH_V at 1, 5, 10 kHz: "
                + ", ".join(
                    f"{a:+.3f} dB {b:+.2f} deg"
                    for a, b in zip(q["delta_db_at_1_5_10_khz"], q["delta_deg_at_1_5_10_khz"], strict=True)
                ),
                flush=True,
            )
    keys = [f"{mm:g}" for mm in args.drum_mm]
    res["change_coarsest_to_finest_db"] = {
        c: [
            b - a
            for a, b in zip(
                res["drums"][keys[0]]["cases"][c]["delta_db_at_1_5_10_khz"],
                res["drums"][keys[-1]]["cases"][c]["delta_db_at_1_5_10_khz"],
                strict=True,
            )
        ]
        for c in args.cases
    }
    res["complete"] = True
    atomic_write_json(path, res)
    print(json.dumps(res["change_coarsest_to_finest_db"], indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
