"""Eardrum mesh convergence of H_V and ΔH_V (issue 24 item 3): a ladder of drum meshes.

Usage: ``.venv/bin/python benchmarks/drum_convergence.py [--drum-mm 0.25 0.18 0.125 0.09 0.075]
[--order 2] [--resolution 0.5] [--n 121] [--final-check] [--json PATH]``

For each drum element size (``fem.ear.middle_ear.MiddleEarModel(drum_mesh_size_m=...)``), on one
joint mesh (``--order``, ``--resolution``: a coarse one by default; the joint's own refinement is
not the question here), the reduced FE ear (``fem.ear.reduced_ear.reduced_ear``, published damping)
of the base case and of the rigid connection of the same ear give H_V (stapes velocity per
ear-canal pressure) at ``--n`` log-spaced frequencies over 100 Hz – 20 kHz, and ΔH_V = H_V / H_V,rigid
(same drum). Per mesh: triangles, dofs, build and sweep seconds, the process's peak resident memory.
For each pair of successive meshes, and each mesh against the finest: the largest |difference| of
H_V and ΔH_V in dB and degrees per band (≤ 2.6 kHz, 2.6–5, 5–10, 10–20 kHz); the issue's target
(H_V within 1 dB, ΔH_V within 0.1 dB and 1° up to 10 kHz) for the two finest meshes and the coarsest
mesh meeting it against the finest; the observed convergence order from each three successive
meshes (Richardson) and whether it holds steady (asymptotic range).

Results are written atomically to ``benchmarks/results/drum_convergence.json`` after every mesh; a
rerun with the same settings reuses the meshes already stored there (delete the file to start
over). ``--final-check`` adds the two finest drums on the default joint mesh (P2, resolution 1).
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.ear.reduced_ear import reduced_ear
from isj.fem.model import PedicleJointModel

from isj.atomic import atomic_write_json

OUT = Path(__file__).resolve().parent / "results" / "drum_convergence.json"

#: Bands (Hz) in which the largest differences are reported; the target applies up to 10 kHz.
BANDS_HZ = {"le_2.6k": (0.0, 2.6e3), "2.6k-5k": (2.6e3, 5e3), "5k-10k": (5e3, 10e3), "10k-20k": (10e3, 20e3)}
TARGET = {"f_max_hz": 10e3, "h_v_db": 1.0, "delta_db": 0.1, "delta_deg": 1.0}


def peak_rss_mib() -> float:
    """Peak resident memory of this process so far (MiB; Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def one_mesh(joint, size_m: float, freqs: np.ndarray) -> dict:
    """Base case and rigid connection on one drum mesh: H_V, ΔH_V and the cost."""
    t0 = time.perf_counter()
    ear = MiddleEarModel(joint=joint, drum_mesh_size_m=size_m)
    rigid = MiddleEarModel(geometry=ear.geometry, drum_mesh_size_m=size_m)
    t_model = time.perf_counter() - t0
    out = {
        "drum_mesh_size_m": size_m,
        "n_triangles": int(len(ear.drum.triangles)),
        "n_drum_nodes": int(len(ear.drum.nodes_m)),
        "n_dofs": int(ear.n_dofs),
        "n_dofs_rigid": int(rigid.n_dofs),
        "model_s": t_model,
    }
    h = {}
    for name, model in (("base", ear), ("rigid", rigid)):
        t0 = time.perf_counter()
        rom = reduced_ear(model, fmax_hz=float(freqs.max()))
        t1 = time.perf_counter()
        h[name] = rom.frequency_response(freqs)["stapes_velocity_m_s"]
        out[f"reduction_s_{name}"] = t1 - t0
        out[f"sweep_s_{name}"] = time.perf_counter() - t1
        out[f"reduced_dofs_{name}"] = int(rom.n_dofs)
        del rom
    out["build_s"] = t_model + out["reduction_s_base"] + out["reduction_s_rigid"]
    out["peak_rss_mib"] = peak_rss_mib()
    out["h_v_re_im"] = [[float(v.real), float(v.imag)] for v in h["base"]]
    out["h_v_rigid_re_im"] = [[float(v.real), float(v.imag)] for v in h["rigid"]]
    return out


def complex_of(pairs) -> np.ndarray:
    a = np.asarray(pairs, float)
    return a[:, 0] + 1j * a[:, 1]


def responses(row: dict) -> dict:
    hv, hr = complex_of(row["h_v_re_im"]), complex_of(row["h_v_rigid_re_im"])
    return {"h_v": hv, "delta": hv / hr}


def band_max(freqs, a, b) -> dict:
    """Largest |20 log10 |a/b|| (dB) and |angle(a/b)| (deg) per band, and up to 10 kHz and 20 kHz."""
    r = a / b
    d_db, d_deg = np.abs(20 * np.log10(np.abs(r))), np.abs(np.degrees(np.angle(r)))
    out = {}
    spans = BANDS_HZ | {"le_10k": (0.0, 10e3), "le_20k": (0.0, 20e3 * 1.0001)}
    for k, (lo, hi) in spans.items():
        sel = (freqs > lo) & (freqs <= hi) if lo > 0 else freqs <= hi
        out[k] = {"db": float(d_db[sel].max()), "deg": float(d_deg[sel].max())}
    return out


def compare(freqs, ra: dict, rb: dict) -> dict:
    """Mesh b against mesh a: per band for H_V and ΔH_V, and whether the issue's target holds."""
    c = {q: band_max(freqs, rb[q], ra[q]) for q in ("h_v", "delta")}
    t = c["h_v"]["le_10k"]["db"] <= TARGET["h_v_db"]
    t &= (
        c["delta"]["le_10k"]["db"] <= TARGET["delta_db"]
        and c["delta"]["le_10k"]["deg"] <= TARGET["delta_deg"]
    )
    return c | {"meets_target": bool(t)}


def observed_order(h, d1: float, d2: float) -> float | None:
    """Order p with d1/d2 = (h1^p − h2^p)/(h2^p − h3^p) (three sizes h1 > h2 > h3; bisection), or None."""
    if not (d1 > 0 and d2 > 0):
        return None
    h1, h2, h3 = h

    def g(p):
        return math.log((h1**p - h2**p) / (h2**p - h3**p)) - math.log(d1 / d2)

    lo, hi = 0.05, 12.0
    if g(lo) * g(hi) > 0:
        return None
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if g(lo) * g(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def richardson(freqs, sizes, resp) -> list[dict]:
    """Observed order from each three successive meshes, per band, from the largest differences.

    For quantity q (20 log10|H_V|, angle H_V, and the same of ΔH_V) the differences between successive
    meshes are d_i = max over the band of |q_{i+1} − q_i|; p solves d1/d2 = (h1^p − h2^p)/(h2^p − h3^p).
    Where p holds, the finest mesh's remaining error is about d2 h3^p / (h2^p − h3^p).
    """
    out = []
    for i in range(len(sizes) - 2):
        h = sizes[i : i + 3]
        row = {"drum_mesh_sizes_m": list(h), "bands": {}}
        for band, (lo, hi) in (BANDS_HZ | {"le_10k": (0.0, 10e3)}).items():
            sel = (freqs > lo) & (freqs <= hi) if lo > 0 else freqs <= hi
            row["bands"][band] = {}
            for q in ("h_v", "delta"):
                r1 = resp[i + 1][q][sel] / resp[i][q][sel]
                r2 = resp[i + 2][q][sel] / resp[i + 1][q][sel]
                for unit, f in (
                    ("db", lambda r: 20 * np.log10(np.abs(r))),
                    ("deg", lambda r: np.degrees(np.angle(r))),
                ):
                    d1, d2 = float(np.abs(f(r1)).max()), float(np.abs(f(r2)).max())
                    p = observed_order(h, d1, d2)
                    est = None if p is None else d2 * h[2] ** p / (h[1] ** p - h[2] ** p)
                    row["bands"][band][f"{q}_{unit}"] = {
                        "d_coarse": d1,
                        "d_fine": d2,
                        "order": p,
                        "finest_error_estimate": est,
                    }
        out.append(row)
    return out


def analyse(freqs, rows: list[dict]) -> dict:
    rows = sorted(rows, key=lambda r: -r["drum_mesh_size_m"])
    sizes = [r["drum_mesh_size_m"] for r in rows]
    resp = [responses(r) for r in rows]
    out = {"drum_mesh_sizes_m": sizes}
    out["successive"] = [
        {"coarse_m": sizes[i], "fine_m": sizes[i + 1]} | compare(freqs, resp[i], resp[i + 1])
        for i in range(len(rows) - 1)
    ]
    out["against_finest"] = [
        {"mesh_m": sizes[i], "finest_m": sizes[-1]} | compare(freqs, resp[-1], resp[i])
        for i in range(len(rows) - 1)
    ]
    if len(rows) >= 2:
        out["two_finest_meet_target"] = out["successive"][-1]["meets_target"]
        ok = [a["mesh_m"] for a in out["against_finest"] if a["meets_target"]]
        out["coarsest_meeting_target_against_finest_m"] = max(ok) if ok else None
    out["richardson"] = richardson(freqs, sizes, resp)
    return out


def converged_band_hz(freqs, ra, rb) -> dict:
    """Highest frequency below which every point agrees within the target (H_V 1 dB; ΔH_V 0.1 dB, 1°)."""

    def upto(bad):
        i = np.flatnonzero(bad)
        return float(freqs[-1]) if i.size == 0 else (float(freqs[i[0] - 1]) if i[0] > 0 else None)

    rh, rd = rb["h_v"] / ra["h_v"], rb["delta"] / ra["delta"]
    return {
        "h_v_1db_hz": upto(np.abs(20 * np.log10(np.abs(rh))) > TARGET["h_v_db"]),
        "delta_0.1db_hz": upto(np.abs(20 * np.log10(np.abs(rd))) > TARGET["delta_db"]),
        "delta_1deg_hz": upto(np.abs(np.degrees(np.angle(rd))) > TARGET["delta_deg"]),
    }


def print_rows(freqs, rows):
    rows = sorted(rows, key=lambda r: -r["drum_mesh_size_m"])
    for r in rows:
        print(
            f"  drum {1e3 * r['drum_mesh_size_m']:.4g} mm: {r['n_triangles']} triangles, {r['n_dofs']} dofs, "
            f"build {r['build_s']:.0f} s (reductions {r['reduction_s_base']:.0f} + "
            f"{r['reduction_s_rigid']:.0f} s), "
            f"peak RSS {r['peak_rss_mib']:.0f} MiB",
            flush=True,
        )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drum-mm", type=float, nargs="+", default=[0.25, 0.18, 0.125, 0.09, 0.075])
    ap.add_argument("--order", type=int, default=2)
    ap.add_argument("--resolution", type=float, default=0.5)
    ap.add_argument("--n", type=int, default=121)
    ap.add_argument("--final-check", action="store_true")
    ap.add_argument("--json", metavar="PATH", default=str(OUT))
    args = ap.parse_args(argv)
    if args.n < 2:
        print(f"--n = {args.n}: must be an integer >= 2", file=sys.stderr)
        return 2
    if any(not (0.02 <= d <= 0.5) for d in args.drum_mm):
        print(f"--drum-mm = {args.drum_mm}: each must lie in [0.02, 0.5] mm", file=sys.stderr)
        return 2
    path = Path(args.json)
    freqs = np.geomspace(100.0, 20e3, args.n)
    settings = {"order": args.order, "resolution": args.resolution, "n": args.n}
    store = {}
    if path.exists():
        old = json.loads(path.read_text())
        if old.get("settings") == settings:
            store = old
    store.setdefault("settings", settings)
    store.setdefault("rows", [])
    store.setdefault("final_check", {"order": 2, "resolution": 1.0, "rows": []})
    store["freq_hz"] = freqs.tolist()
    store["target"] = TARGET
    store["bands_hz"] = BANDS_HZ

    def save():
        rows = store["rows"]
        if len(rows) >= 2:
            store["analysis"] = analyse(freqs, rows)
            srt = sorted(rows, key=lambda r: -r["drum_mesh_size_m"])
            fin = responses(srt[-1])
            store["converged_band_against_finest_hz"] = {
                f"{r['drum_mesh_size_m']:.6g}": converged_band_hz(freqs, fin, responses(r)) for r in srt[:-1]
            }
        fc = store["final_check"]["rows"]
        if len(fc) == 2:
            store["final_check"]["analysis"] = analyse(freqs, fc)
        atomic_write_json(path, store)

    t0 = time.perf_counter()
    joint = PedicleJointModel(order=args.order, resolution=args.resolution)
    print(
        f"joint mesh P{args.order}, resolution {args.resolution:g} ({time.perf_counter() - t0:.0f} s)",
        flush=True,
    )
    done = {round(r["drum_mesh_size_m"], 12) for r in store["rows"]}
    for mm in args.drum_mm:
        size = mm * 1e-3
        if round(size, 12) in done:
            continue
        store["rows"].append(one_mesh(joint, size, freqs))
        save()
        print_rows(freqs, store["rows"][-1:])
    save()
    if args.final_check:
        del joint
        joint = PedicleJointModel(order=2, resolution=1.0)
        fine = sorted(args.drum_mm)[:2]
        done = {round(r["drum_mesh_size_m"], 12) for r in store["final_check"]["rows"]}
        for mm in sorted(fine, reverse=True):
            if round(mm * 1e-3, 12) in done:
                continue
            store["final_check"]["rows"].append(one_mesh(joint, mm * 1e-3, freqs))
            save()
            print("  (default joint mesh)", end="")
            print_rows(freqs, store["final_check"]["rows"][-1:])
    an = store.get("analysis")
    if an:
        for s in an["successive"]:
            print(
                f"  {1e3 * s['coarse_m']:.4g} -> {1e3 * s['fine_m']:.4g} mm: "
                + "; ".join(
                    f"{b}: H_V {s['h_v'][b]['db']:.2f} dB {s['h_v'][b]['deg']:.1f} deg, "
                    f"dH_V {s['delta'][b]['db']:.3f} dB {s['delta'][b]['deg']:.2f} deg"
                    for b in BANDS_HZ
                )
                + f" | target {'met' if s['meets_target'] else 'missed'}"
            )
        coarsest = an["coarsest_meeting_target_against_finest_m"]
        print(f"  coarsest meeting the target against the finest: {coarsest}")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        raise SystemExit(main())
