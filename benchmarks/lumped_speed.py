"""Speed of the vectorised lumped model and of calibration from cached FE results.

Run:  .venv/bin/python benchmarks/lumped_speed.py [--cache DIR]

Prints designs per second for the lumped static model on 1e6 random designs
(best of 5), and, if the FE cache of the default calibration is present, the
time to refit the default calibration from it (no FE solves).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from isj.lumped.artifact import default_calibration
from isj.lumped.model import MODULI, static_response


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", help="FE result cache of the default calibration (default ~/.cache/isj/fe)")
    args = ap.parse_args(argv)
    cal = default_calibration()
    f = cal.factor_array()
    rng = np.random.default_rng(0)
    n = 1_000_000
    E = {k: np.exp(rng.uniform(np.log(lo), np.log(hi), n)) for k, (lo, hi) in cal.domain.items()}
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        static_response(f, **E)
        best = min(best, time.perf_counter() - t0)
    print(
        f"lumped static model: {n:.0e} designs in {best * 1e3:.0f} ms = {n / best:.2e} designs/s "
        f"({len(MODULI)} moduli each)"
    )

    from pathlib import Path

    from isj.calibration.pipeline import calibrate
    from isj.fem.batch import evaluate_design, fe_settings

    cache = Path(args.cache) if args.cache else Path.home() / ".cache" / "isj" / "fe"
    prov = cal.provenance
    t0 = time.perf_counter()
    refit = calibrate(
        evaluate_design,
        fe_settings(),
        cache,
        samples=prov["samples"],
        validation=prov["validation_samples"],
        seed=prov["seed"],
        progress=False,
    )
    t = time.perf_counter() - t0
    same = np.allclose([refit.factors[k] for k in cal.factors], list(cal.factors.values()), rtol=1e-6)
    print(
        f"calibration from cached FE results ({prov['samples']} + {prov['validation_samples']} designs): "
        f"{t:.1f} s; factors {'identical to' if same else 'DIFFER from'} the shipped calibration"
    )


if __name__ == "__main__":
    main()
