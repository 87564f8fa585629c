"""The lumped model's geometric scaling against FE, one dimension at a time (docs/lumped.md §3.13).

Run:  .venv/bin/python benchmarks/geometry_slices.py [--workers N] [--calibration PATH]

For each dimension of the calibration's geometric domain (``GEOMETRY_DOMAIN_M``), five values
over its range (the other dimensions at their defaults), at three sets of moduli (the default
design, a soft joint and a stiff joint), FE (P2, resolution 1, cached) and the lumped model
with a calibration's factors evaluated at that geometry. Prints, per dimension and moduli set,
the FE α and β relative to the default geometry's, and the lumped model's error
(lumped/FE − 1), raw and after removing the error at the default geometry (the scaling
error: what the geometric form gets wrong). Writes benchmarks/results/geometry_slices.json.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from isj.calibration.doe import GEOMETRY_DOMAIN_M
from isj.calibration.runner import run_geometry_designs
from isj.fem.batch import evaluate_design, fe_settings
from isj.lumped.artifact import Calibration, default_calibration
from isj.lumped.model import static_response

from isj.caches import fe_cache_dir
from isj.design import Geometry, Materials

#: Moduli sets of the slices (Pa), over the default design's.
MODULI_SETS = {
    "default": {},
    "soft joint": {"gap_e_pa": 2e6, "capsule_e_pa": 20e6},
    "stiff joint": {"gap_e_pa": 40e6, "capsule_e_pa": 200e6, "plate_e_pa": 0.5e9},
}

N_VALUES = 5
RESULT = Path(__file__).parent / "results" / "geometry_slices.json"


def slice_items() -> list[tuple[str, float, str, dict, dict]]:
    """(dimension, value (m), moduli label, moduli (Pa), dimensions (m)) of every slice point."""
    out = []
    for name, (lo, hi) in GEOMETRY_DOMAIN_M.items():
        for v in np.linspace(lo, hi, N_VALUES):
            dims = {name: float(v)}
            try:
                Geometry(**dims)
            except ValueError:
                continue
            for label, moduli in MODULI_SETS.items():
                out.append((name, float(v), label, dict(moduli), dims))
    return out


def lumped(factors, moduli: dict, dims: dict, scaling: dict | None = None) -> tuple[float, float]:
    """Lumped α, β (rad) at the default pressure for one design at ``dims`` (``scaling``: the
    calibration's geometry_scaling)."""
    full = {
        k: getattr(Materials(), k)
        for k in ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa", "plate_e_pa", "stapes_e_pa", "incus_e_pa")
    }
    r = static_response(factors, Geometry(**dims), scaling=scaling, **{**full, **moduli})
    return float(r.alpha_rad), float(r.beta_rad)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--calibration", help="calibration file (default: the shipped one)")
    ap.add_argument("--no-write", action="store_true", help="do not write the JSON result")
    args = ap.parse_args(argv)
    cal = Calibration.load(args.calibration) if args.calibration else default_calibration()
    factors = cal.factor_array()
    items = slice_items()
    base_items = [(label, m) for label, m in MODULI_SETS.items()]
    settings = fe_settings()  # cached results of earlier code stay valid while its results versions hold
    recs = run_geometry_designs(
        [(m, d) for *_, m, d in items] + [(m, {}) for _, m in base_items],
        evaluate_design,
        settings,
        fe_cache_dir(),
        max_workers=args.workers,
    )
    fe = [(r["result"]["alpha_rad"], r["result"]["beta_rad"]) for r in recs]
    base_fe = dict(zip([lab for lab, _ in base_items], fe[len(items) :], strict=True))
    base_lum = {lab: lumped(factors, m, {}, cal.geometry_scaling) for lab, m in base_items}
    rows = []
    for (name, v, label, moduli, dims), (a_fe, b_fe) in zip(items, fe, strict=False):
        a_l, b_l = lumped(factors, moduli, dims, cal.geometry_scaling)
        a0_fe, b0_fe = base_fe[label]
        a0_l, b0_l = base_lum[label]
        rows.append(
            {
                "dimension": name,
                "value_m": v,
                "moduli": label,
                "fe_alpha_rad": a_fe,
                "fe_beta_rad": b_fe,
                "lumped_alpha_rad": a_l,
                "lumped_beta_rad": b_l,
                "fe_alpha_rel_default": a_fe / a0_fe,
                "fe_beta_rel_default": b_fe / b0_fe,
                "alpha_error": a_l / a_fe - 1,
                "beta_error": b_l / b_fe - 1,
                "alpha_scaling_error": (a_l / a0_l) / (a_fe / a0_fe) - 1,
                "beta_scaling_error": (b_l / b0_l) / (b_fe / b0_fe) - 1,
            }
        )
    print(f"calibration: {args.calibration or 'shipped'}; FE P2, resolution 1")
    print(
        f"{'dimension':20s} {'um':>6s} {'moduli':12s} {'FE a/a0':>8s} {'FE b/b0':>8s} "
        f"{'err a':>7s} {'err b':>7s} {'scal a':>7s} {'scal b':>7s}"
    )
    for r in rows:
        print(
            f"{r['dimension']:20s} {1e6 * r['value_m']:6.1f} {r['moduli']:12s} "
            f"{r['fe_alpha_rel_default']:8.3f} {r['fe_beta_rel_default']:8.3f} "
            f"{100 * r['alpha_error']:6.2f}% {100 * r['beta_error']:6.2f}% "
            f"{100 * r['alpha_scaling_error']:6.2f}% {100 * r['beta_scaling_error']:6.2f}%"
        )
    ea = np.array([r["alpha_error"] for r in rows])
    eb = np.array([r["beta_error"] for r in rows])
    print(
        f"max |error|: alpha {100 * np.abs(ea).max():.2f} %, beta {100 * np.abs(eb).max():.2f} % "
        f"over {len(rows)} slice points"
    )
    if not args.no_write:
        RESULT.parent.mkdir(exist_ok=True)
        RESULT.write_text(
            json.dumps({"calibration": args.calibration or "shipped", "rows": rows}, indent=1) + "\n"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
