"""The calibrated lumped model over a million designs at once.

Draws 10⁶ designs log-uniformly from the calibration's domain (the five moduli),
evaluates α and β for all of them in one vectorised call and prints the
throughput and what the designs share.

    python examples/lumped_million.py [--n 1000000] [--seed 0]
"""

import argparse
import time

import numpy as np

import isj


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000, help="number of designs (default 10^6)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    args = parser.parse_args(argv)
    if not 1 <= args.n <= 10_000_000:
        parser.error(f"--n = {args.n}: must be in [1, 10000000]")

    model = isj.LumpedModel.default()
    rng = np.random.default_rng(args.seed)
    designs = {
        name: np.exp(rng.uniform(np.log(lo), np.log(hi), args.n)) for name, (lo, hi) in model.domain.items()
    }
    t0 = time.perf_counter()
    r = model.static(designs)
    seconds = time.perf_counter() - t0

    print(f"designs = {args.n}")
    print(f"time_s = {seconds:.4f}")
    print(f"throughput = {args.n / seconds:.4g} designs/s")
    for name, v in (("alpha_rad", r.alpha_rad), ("beta_rad", r.beta_rad)):
        lo, mid, hi = np.quantile(v, [0.0, 0.5, 1.0])
        print(f"{name}: min {lo:.4e}, median {mid:.4e}, max {hi:.4e}")
    print(f"beta > alpha in {100 * np.mean(r.beta_rad > r.alpha_rad):.2f} % of the designs")
    print("design 0: " + ", ".join(f"{k} = {float(v[0])!r}" for k, v in designs.items()))
    print(f"design 0: alpha_rad = {float(r.alpha_rad[0])!r}, beta_rad = {float(r.beta_rad[0])!r}")


if __name__ == "__main__":
    main()
