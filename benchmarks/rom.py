"""The certified surrogate (isj.fem.rom): build time, throughput against the lumped model and FE, bounds.

Run:  .venv/bin/python benchmarks/rom.py [--order 2] [--resolution 1] [--n 1000000] [--fe 6]

Prints, for the surrogate of the given mesh (built here if the cache lacks it, else loaded),
and writes to ``benchmarks/results/rom.json`` (``--no-json`` to skip):

- its build time (from the build's own record: the time of the build that made the cache entry),
  the greedy's size (snapshots, basis sizes) and the local bases' sizes per sub-box;
- designs per second of the surrogate (α, β, α + β, β/α with bounds, vectorised) on ``--n``
  random designs, against the lumped static model on the same designs and against FE
  (``--fe`` solves), with the load average while measuring (the machine may be shared);
- the relative bound's distribution (max, 99th percentile, median) over the dense sample and the
  32 corners, for α, β, α + β and β/α, and whether the 0.1 % target holds;
- the effectivity (bound ÷ true error against FE on the same mesh) at the ``--fe`` designs
  (two corners, the rest random) and the seven thesis cases' time through the surrogate.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from isj.fem.rom import reduced_model

from isj.atomic import atomic_write_json

OUT = Path(__file__).resolve().parent / "results" / "rom.json"

#: (surrogate key, its bound, the FE result's attribute)
OUTPUTS = (
    ("alpha_rad", "alpha_bound_rad", "alpha_rad"),
    ("beta_rad", "beta_bound_rad", "beta_rad"),
    ("alpha_plus_beta_rad", "alpha_plus_beta_bound_rad", "sum_rad"),
    ("beta_over_alpha", "beta_over_alpha_bound", "ratio"),
)

TARGET_REL = 1e-3


def _best(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _dist(rel: np.ndarray) -> dict:
    return {
        "max": float(rel.max()),
        "p99": float(np.quantile(rel, 0.99)),
        "median": float(np.median(rel)),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order", type=int, choices=(1, 2), default=2)
    ap.add_argument("--resolution", type=float, default=1.0)
    ap.add_argument("--n", type=int, default=1_000_000, help="designs of the dense sample")
    ap.add_argument("--fe", type=int, default=6, help="FE solves for the FE throughput and effectivities")
    ap.add_argument("--no-json", action="store_true", help=f"do not write {OUT.name}")
    args = ap.parse_args(argv)
    res: dict = {"order": args.order, "resolution": args.resolution}

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
    if "local_sizes" in m:
        sizes = np.array(m["local_sizes"])
        print(
            f"  local bases per sub-box: {len(sizes)} sub-boxes, sizes min {sizes.min()}, median "
            f"{np.median(sizes):g}, max {sizes.max()} (made in {m['local_time_s']:.1f} s)"
        )
    res["build"] = {
        k: m.get(k)
        for k in (
            "n_dofs",
            "build_time_s",
            "timings_s",
            "n_snapshots",
            "local_sizes",
            "local_time_s",
            "validate_max_rel_bound",
            "local_validate_max_rel_bound",
        )
    } | {"n_basis": rom.n_basis}

    E = rom.space.sample(args.n, seed=12345)
    load0 = os.getloadavg()[0]
    t_rom = _best(lambda: rom.evaluate(E))
    ev = rom.evaluate(E)

    from isj.lumped.artifact import default_calibration
    from isj.lumped.model import static_response

    cal = default_calibration()
    moduli = {k: E[:, j] for j, k in enumerate(rom.space.bounds)}
    t_lumped = _best(lambda: static_response(cal.factor_array(), **moduli))
    load1 = os.getloadavg()[0]

    from isj.fem.model import PedicleJointModel

    fe = PedicleJointModel(order=args.order, resolution=args.resolution)
    rng = np.random.default_rng(7)
    picks = np.concatenate(
        [rom.space.corners()[[0, 31]], rom.space.from_unit(rng.random((max(args.fe - 2, 0), 5)))]
    )[: args.fe]
    t0 = time.perf_counter()
    truth = [fe.static(rom.space.materials(e)) for e in picks]
    t_fe = (time.perf_counter() - t0) / max(len(picks), 1)
    rate = args.n / t_rom
    print(
        f"throughput: surrogate {rate:.3g} designs/s ({args.n:.0e} designs in {t_rom:.2f} s, "
        f"bounds included); lumped {args.n / t_lumped:.3g} designs/s; FE {1 / t_fe:.3g} designs/s "
        f"({t_fe:.2f} s each, one assembly); surrogate/FE = {t_fe * rate:.3g}, "
        f"surrogate/lumped = {t_lumped / t_rom:.3g}; load average {load0:.1f}-{load1:.1f} on "
        f"{os.cpu_count()} cores"
    )
    res["throughput"] = {
        "n_designs": args.n,
        "surrogate_designs_per_s": rate,
        "lumped_designs_per_s": args.n / t_lumped,
        "fe_designs_per_s": 1 / t_fe,
        "surrogate_over_fe": t_fe * rate,
        "surrogate_over_lumped": t_lumped / t_rom,
        "load_average": [load0, load1],
        "cpu_count": os.cpu_count(),
    }

    corners = rom.evaluate(rom.space.corners())
    res["relative_bound"] = {}
    for k, kb, _ in OUTPUTS:
        rel = ev[kb] / np.abs(ev[k])
        relc = corners[kb] / np.abs(corners[k])
        ok = bool(rel.max() <= TARGET_REL and relc.max() <= TARGET_REL)
        print(
            f"relative bound {k:20s}: dense max {rel.max():.2e}, p99 {np.quantile(rel, 0.99):.2e}, "
            f"median {np.median(rel):.2e}; corners max {relc.max():.2e}, median {np.median(relc):.2e}"
            f" (<= {TARGET_REL:g}: {ok})"
        )
        res["relative_bound"][k] = {"dense": _dist(rel), "corners": _dist(relc), "within_target": ok}

    res["effectivity"] = {}
    if picks.size:
        at = rom.evaluate(picks)
        for k, kb, attr in OUTPUTS:
            fe_val = np.array([getattr(r, attr) for r in truth])
            err = np.abs(fe_val - at[k])
            eff = at[kb] / np.maximum(err, 1e-300)
            holds = bool(np.all(err <= at[kb]))
            print(
                f"effectivity {k:20s}: min {eff.min():.3g}, max {eff.max():.3g} (bound >= error: "
                f"{holds}; max relative error {np.max(err / np.abs(fe_val)):.2e})"
            )
            res["effectivity"][k] = {
                "min": float(eff.min()),
                "max": float(eff.max()),
                "bound_holds": holds,
                "max_rel_error": float(np.max(err / np.abs(fe_val))),
            }
    t_cases = _best(rom.cases, repeat=5)
    rows = rom.cases()
    print(
        f"seven thesis cases through the surrogate: {t_cases * 1e3:.1f} ms, largest relative bound "
        f"on beta/alpha {max(r['beta_over_alpha_bound'] / abs(r['beta_over_alpha']) for r in rows):.2e}"
    )
    res["thesis_cases_s"] = t_cases
    if not args.no_json:
        atomic_write_json(OUT, res)
        print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
