"""The report's transmission step alone: cold, after a design change, and the all-FE path.

Usage: ``nice -n 10 .venv/bin/python benchmarks/transmission_step.py [--resolution 1]
[--json PATH]``

Runs :func:`isj.reports.transmission_step.transmission_step` on the built-in defaults (the
mesh's ``--resolution``), each run in a fresh FE cache folder unless stated:

1. ``fast_cold``: ``cases_from = "fast"``, empty cache (the fast ear is built);
2. ``fast_changed``: the same cache, ``design.gap_e_pa = 7e6`` (the fast ear is read; the
   rigid connection, the first case's FE check and the sliding case are reduced again, as the
   step's own cache entry would not hold);
3. ``fe_cold``: ``cases_from = "fe"``, empty cache (one FE reduction per case, the previous
   step).

Prints each run's seconds and their ratios, and the fast ear's agreement with the FE check;
writes them to ``--json`` (default ``benchmarks/results/transmission_step.json``).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

from isj.atomic import atomic_write_json

OUT = Path(__file__).resolve().parent / "results" / "transmission_step.json"


def run_step(config, fe_cache: Path) -> tuple[float, dict]:
    """(seconds, result) of the transmission step for ``config`` with ``fe_cache`` as the FE cache."""
    from isj.lumped.artifact import default_calibration
    from isj.reports.steps import Context
    from isj.reports.transmission_step import transmission_step

    os.environ["ISJ_FE_CACHE_DIR"] = str(fe_cache)
    ctx = Context(config, default_calibration(), fe_cache, progress=False)
    t0 = time.perf_counter()
    result, _ = transmission_step(ctx)
    return time.perf_counter() - t0, result


def main(argv=None) -> int:
    from isj.reports.config import ReportConfig

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=1.0)
    ap.add_argument("--json", type=Path, default=OUT)
    args = ap.parse_args(argv)
    base = ReportConfig()
    base = dataclasses.replace(base, mesh=dataclasses.replace(base.mesh, resolution=args.resolution))
    changed = dataclasses.replace(base, design=dataclasses.replace(base.design, gap_e_pa=7e6))
    fe_only = dataclasses.replace(base, transmission=dataclasses.replace(base.transmission, cases_from="fe"))
    out = {"resolution": args.resolution, "load_average_start": list(os.getloadavg()), "runs": {}}
    with tempfile.TemporaryDirectory(prefix="isj-transmission-") as tmp:
        fast_cache, fe_cache = Path(tmp) / "fast", Path(tmp) / "fe"
        for label, cfg, cache in (
            ("fast_cold", base, fast_cache),
            ("fast_changed", changed, fast_cache),
            ("fe_cold", fe_only, fe_cache),
        ):
            seconds, result = run_step(cfg, cache)
            out["runs"][label] = {
                "seconds": seconds,
                "models": {k: v["model"] for k, v in result["fe_reductions"].items()},
                "fast_ear_check": result["fe_checks"].get("fast_ear"),
                "delta_db_at_quote": [q["delta_db"] for q in result["quote"]],
            }
            print(f"{label}: {seconds:.1f} s", flush=True)
    r = out["runs"]
    out["ratios"] = {
        "fast_cold_over_fe_cold": r["fast_cold"]["seconds"] / r["fe_cold"]["seconds"],
        "fast_changed_over_fe_cold": r["fast_changed"]["seconds"] / r["fe_cold"]["seconds"],
    }
    out["load_average_end"] = list(os.getloadavg())
    print({k: round(v, 3) for k, v in out["ratios"].items()})
    atomic_write_json(args.json, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
