"""Uncertainty and sensitivity on the lumped model: time, P(β/α > 1), Sobol' indices and their stability.

Run:  .venv/bin/python benchmarks/uq.py [--quick]

Prints, for the default inputs (every modulus log-uniform over the calibrated domain,
docs/uq.md §11.2):

- the time of ``isj.studies.uq.run_uq`` at its defaults (10^6 draws, 2^14 Saltelli base
  samples, 100 bootstrap resamples), stage by stage;
- P(β/α > 1) with its 95 % Wilson interval, and its spread over five seeds;
- the three largest total Sobol' indices of α, β and β/α, with their bootstrap half-widths, and
  how far they move from 2^12 to 2^15 base samples;
- P(β/α > 1) and the indices for lognormal moduli about the default design (isj.design.Materials)
  with a factor 1.3 (σ of ln E = ln 1.3: the thesis's "more than 30 %").

``--quick``: 10^5 draws and 2^12 base samples, for a smoke run.
"""

from __future__ import annotations

import argparse
import time

from isj.lumped.model import MODULI

from isj.design import Materials
from isj.studies.uq import Distribution, UQConfig, default_distributions, run_uq


def _top(r, out: str) -> str:
    conf = r.sobol[out]["ST_conf"]
    return ", ".join(f"{m.removesuffix('_e_pa')} {v:.3f} ± {conf[m]:.3f}" for m, v in r.top_total(out))


def _report(r, label: str) -> None:
    lo, hi = r.p_beta_over_alpha_gt_1_ci
    t = r.time_s
    print(
        f"{label}: P(beta/alpha > 1) = {r.p_beta_over_alpha_gt_1:.5f} [{lo:.5f}, {hi:.5f}] (95 % Wilson, "
        f"{r.n_beta_over_alpha_gt_1} of {r.config.samples} draws); time {t['total']:.2f} s "
        f"(Monte Carlo {t['monte_carlo']:.2f} s, "
        f"Sobol' {t['sobol']:.2f} s)"
    )
    for out in ("alpha_rad", "beta_rad", "beta_over_alpha"):
        print(f"    largest ST of {out:16}: {_top(r, out)}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1e5 draws, 2^12 base samples")
    args = ap.parse_args(argv)
    counts = {"samples": 100_000, "sobol_samples": 2**12} if args.quick else {}

    t0 = time.perf_counter()
    r = run_uq(UQConfig.default(**counts))
    print(f"run_uq at its defaults{' (quick)' if args.quick else ''}: {time.perf_counter() - t0:.2f} s wall")
    _report(r, "log-uniform over the calibrated domain")

    ps = [run_uq(UQConfig.default(**counts, seed=s)).p_beta_over_alpha_gt_1 for s in range(1, 6)]
    print(f"P(beta/alpha > 1) over seeds 1-5: {min(ps):.5f} .. {max(ps):.5f}")

    for n in (2**12, 2**14, 2**15):
        rn = run_uq(UQConfig.default(samples=1_000, sobol_samples=n))
        line = "; ".join(
            f"{out}: " + ", ".join(f"{m.removesuffix('_e_pa')} {v:.3f}" for m, v in rn.top_total(out))
            for out in ("alpha_rad", "beta_rad", "beta_over_alpha")
        )
        print(f"  ST at {n:6d} base samples ({rn.time_s['sobol']:.2f} s): {line}")

    m = Materials()
    dists = default_distributions()
    for k in MODULI[:5]:
        dists[k] = Distribution.lognormal(getattr(m, k), factor=1.3, name=k)
    r30 = run_uq(UQConfig(dists, **counts))
    _report(r30, "lognormal, factor 1.3 about the default design")
    print(f"    draws outside the calibrated domain: {r30.n_outside_domain} of {r30.config.samples}")


if __name__ == "__main__":
    main()
