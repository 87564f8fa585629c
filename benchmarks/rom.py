"""The certified surrogate (isj.fem.rom): build time, throughput against the lumped model and FE, bounds.

Run:  .venv/bin/python benchmarks/rom.py [--order 2] [--resolution 1] [--n 1000000] [--fe 4]

Prints, for the surrogate of the given mesh (built here if the cache lacks it, else loaded):

- its build time (from the build's own record: the time of the build that made the cache entry)
  and the greedy's size (snapshots, basis sizes);
- designs per second of the surrogate (α, β, α + β, β/α with bounds) on ``--n`` random designs,
  against the lumped static model on the same designs and against FE (``--fe`` solves);
- the relative bound's distribution (max, 99th percentile, median) over the dense sample and the
  32 corners, for α, β, α + β and β/α;
- the effectivity (bound ÷ true error against FE on the same mesh) at the ``--fe`` designs and
  the seven thesis cases' time through the surrogate.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from isj.fem.rom import reduced_model

OUTPUTS = (
    ("alpha_rad", "alpha_bound_rad"),
    ("beta_rad", "beta_bound_rad"),
    ("alpha_plus_beta_rad", "alpha_plus_beta_bound_rad"),
    ("beta_over_alpha", "beta_over_alpha_bound"),
)


def _best(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order", type=int, choices=(1, 2), default=2)
    ap.add_argument("--resolution", type=float, default=1.0)
    ap.add_argument("--n", type=int, default=1_000_000, help="designs of the dense sample")
    ap.add_argument("--fe", type=int, default=4, help="FE solves for the FE throughput and effectivities")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    rom = reduced_model(order=args.order, resolution=args.resolution)
    got = time.perf_counter() - t0
    m = rom.meta
    print(
        f"surrogate of P{args.order} R={args.resolution:g} ({m['n_dofs']} dofs): built in "
        f"{m['build_time_s']:.1f} s ({m['n_snapshots']} FE snapshots, bases {rom.n_basis}); "
        f"this call {got:.2f} s"
    )
    print(f"  build timings: {', '.join(f'{k} {v:.1f} s' for k, v in m['timings_s'].items())}")

    E = rom.space.sample(args.n, seed=12345)
    t_rom = _best(lambda: rom.evaluate(E))
    ev = rom.evaluate(E)

    from isj.lumped.artifact import default_calibration
    from isj.lumped.model import static_response

    cal = default_calibration()
    moduli = {k: E[:, j] for j, k in enumerate(rom.space.bounds)}
    t_lumped = _best(lambda: static_response(cal.factor_array(), **moduli))

    from isj.fem.model import PedicleJointModel

    fe = PedicleJointModel(order=args.order, resolution=args.resolution)
    rng = np.random.default_rng(7)
    picks = np.concatenate(
        [rom.space.corners()[[0, 31]], rom.space.from_unit(rng.random((max(args.fe - 2, 0), 5)))]
    )
    picks = picks[: args.fe]
    t0 = time.perf_counter()
    truth = [fe.solve(rom.space.materials(e)) for e in picks]
    t_fe = (time.perf_counter() - t0) / max(len(picks), 1)
    print(
        f"throughput: surrogate {args.n / t_rom:.3g} designs/s ({args.n:.0e} designs in {t_rom:.2f} s, "
        f"bounds included); lumped {args.n / t_lumped:.3g} designs/s; FE {1 / t_fe:.3g} designs/s "
        f"({t_fe:.2f} s each, one assembly); surrogate/FE = {t_fe * args.n / t_rom:.3g}"
    )

    corners = rom.evaluate(rom.space.corners())
    for k, kb in OUTPUTS:
        rel = ev[kb] / np.abs(ev[k])
        relc = corners[kb] / np.abs(corners[k])
        print(
            f"relative bound {k:20s}: dense max {rel.max():.2e}, p99 {np.quantile(rel, 0.99):.2e}, "
            f"median {np.median(rel):.2e}; corners max {relc.max():.2e}"
        )

    if picks.size:
        at = rom.evaluate(picks)
        for k, kb in OUTPUTS:
            fe_val = np.array(
                [
                    getattr(
                        r,
                        {
                            "alpha_rad": "alpha_rad",
                            "beta_rad": "beta_rad",
                            "alpha_plus_beta_rad": "sum_rad",
                            "beta_over_alpha": "ratio",
                        }[k],
                    )
                    for r in truth
                ]
            )
            err = np.abs(fe_val - at[k])
            eff = at[kb] / np.maximum(err, 1e-300)
            print(
                f"effectivity {k:20s}: min {eff.min():.3g}, max {eff.max():.3g} (bound >= error: "
                f"{bool(np.all(err <= at[kb]))}; max relative error {np.max(err / np.abs(fe_val)):.2e})"
            )
    t_cases = _best(rom.cases, repeat=5)
    print(f"seven thesis cases through the surrogate: {t_cases * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
