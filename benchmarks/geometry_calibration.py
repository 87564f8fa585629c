"""Build the shipped geometry calibration and check it on FE designs it did not see (docs/lumped.md §3.16).

Run:  .venv/bin/python benchmarks/geometry_calibration.py [--workers N] [--write]

Training: the scrambled Sobol' designs over geometry and moduli of ``--train`` (``seed:n`` pairs,
the first n valid points of each seed's sequence, as ``isj calibrate --geometry-domain --seed S
--samples N`` draws them); validation: ``--validate`` (``seed:n:method``). FE (P2, resolution 1)
comes from the FE cache and runs where missing (``--workers`` processes). The fit is
:func:`calibration.pipeline.geometry_calibration_from_records`, every term's geometric
exponents fitted with the factors. Prints the errors (lumped/FE − 1) on each set and at the mixed
corners; ``--write`` writes lumped/data/geometry_calibration.json, its dynamics block the default
calibration's (fitted on the default geometry only).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from isj.calibration.doe import GeometrySpace, mixed_corners, sample_with_geometry
from isj.calibration.pipeline import (
    geometry_calibration_from_records,
    records_for_fit,
    support_limited_errors,
)
from isj.calibration.runner import run_geometry_designs
from isj.fem.batch import evaluate_design, fe_settings
from isj.lumped.artifact import default_calibration
from isj.lumped.model import PLATE_SUPPORT_LIMIT

from isj.caches import fe_cache_dir
from isj.design_space import DesignSpace

ARTIFACT = Path(__file__).parents[1] / "lumped" / "data" / "geometry_calibration.json"


def parse_sets(text: str, method: str = "sobol") -> list[tuple[int, int, str]]:
    """``"0:288,2:192:sobol"`` -> [(seed, n, method), ...]."""
    out = []
    for part in text.split(","):
        bits = part.split(":")
        out.append((int(bits[0]), int(bits[1]), bits[2] if len(bits) > 2 else method))
    return out


def draw(sets) -> list[tuple[dict, dict]]:
    space, geom = DesignSpace(), GeometrySpace()
    return [d for seed, n, m in sets for d in sample_with_geometry(space, geom, n, seed, method=m)]


def line(name: str, e: dict) -> str:
    out = (
        f"{name:28s} n {e['n']:4d}  alpha max {100 * e['max_alpha']:6.2f} % RMS {100 * e['rms_alpha']:5.2f} %"
        f"  beta max {100 * e['max_beta']:6.2f} % RMS {100 * e['rms_beta']:5.2f} %"
        f"  beta/alpha max {100 * e['max_ratio']:6.2f} %"
    )
    k = e.get("n_beyond_support_limit", 0)
    if k and "max_alpha_beyond_support_limit" in e:
        out += (
            f"\n{'':28s} beyond the plate-support limit: {k} more, alpha max "
            f"{100 * e['max_alpha_beyond_support_limit']:.2f} %, "
            f"beta max {100 * e['max_beta_beyond_support_limit']:.2f} %"
        )
    elif k:
        out += f"  ({k} beyond the plate-support limit, left out)"
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", default="0:288", help="training sets seed:n (Sobol'), comma-separated")
    ap.add_argument("--validate", default="1:64:lhs,2:192:sobol", help="validation sets seed:n:method")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--write", action="store_true", help="write lumped/data/geometry_calibration.json")
    args = ap.parse_args(argv)
    train_sets, val_sets = parse_sets(args.train), parse_sets(args.validate, "lhs")
    train, held = draw(train_sets), draw(val_sets[:1])
    rest = [(f"seed {s} {m} ({n})", draw([(s, n, m)])) for s, n, m in val_sets[1:]]
    corners = mixed_corners(DesignSpace(), GeometrySpace())
    settings = fe_settings()
    items = train + held + [(m, g) for _, m, g in corners] + [d for _, ds in rest for d in ds]
    recs = run_geometry_designs(items, evaluate_design, settings, fe_cache_dir(), max_workers=args.workers)
    n1, n3 = len(train), len(train) + len(held) + len(corners)
    cal = geometry_calibration_from_records(
        recs[:n3],
        n1,
        len(held),
        [c[0] for c in corners],
        DesignSpace(),
        GeometrySpace(),
        settings,
        n1,
        len(held),
        train_sets[0][0],
    )
    fit_rest = records_for_fit(recs[n3:], with_geometry=True)
    print(f"training {args.train}: IPOPT {cal.training['ipopt_iterations']} iterations")
    print(line("training", cal.training))
    print(line(f"held out, seed {val_sets[0][0]} {val_sets[0][2]}", cal.validation))
    i = 0
    everything = [cal.validation]
    for name, ds in rest:
        e = support_limited_errors(cal.factor_array(), fit_rest[i : i + len(ds)], cal.geometry_scaling)
        everything.append(e)
        print(line(name, e))
        i += len(ds)
    for label, e in cal.corners.items():
        beyond = "  beyond the limit" if e["plate_support"] > PLATE_SUPPORT_LIMIT else ""
        print(
            f"  corner {label:45s} alpha {100 * e['alpha']:7.2f} %  beta {100 * e['beta']:6.2f} %"
            f"  s {e['plate_support']:5.2f}{beyond}"
        )
    if args.write:
        d = json.loads(cal.to_json())
        base = default_calibration()
        d["dynamics"] = dict(base.dynamics) | {
            "note": "the default calibration's shear factor, fitted on the default geometry"
        }
        d["provenance"]["training_sets"] = [list(t) for t in train_sets]
        d["provenance"]["extra_validation"] = {
            name: e for (name, _), e in zip(rest, everything[1:], strict=True)
        }
        ARTIFACT.write_text(json.dumps(d, indent=2, sort_keys=True) + "\n")
        print(f"wrote {ARTIFACT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
