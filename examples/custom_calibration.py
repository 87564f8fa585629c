"""A small custom calibration: fit the lumped model to a few coarse FE points on a reduced design space.

The design space keeps the pedicle, the gap and the capsule free over narrower
ranges than the shipped calibration's and pins the plate and the stapes head
at 1 GPa. Eight training designs (Sobol) and four held-out ones (Latin
hypercube, another seed) are solved with the FE model (cached: a second run
takes no FE time), the twelve factors are fitted with CasADi and IPOPT, and the
held-out errors are printed, beside those of the shipped calibration on the
same FE points (which was fitted on a finer mesh, so it is off by that mesh's
difference).

    python examples/custom_calibration.py [--out my_calibration.json]
"""

import argparse
import dataclasses

import numpy as np
from isj.calibration.doe import sample
from isj.calibration.fit import fit_factors
from isj.calibration.pipeline import error_stats, records_for_fit
from isj.calibration.runner import run_designs
from isj.fem.batch import evaluate_design, fe_settings
from isj.lumped.model import FACTOR_NAMES

import isj
from isj.caches import fe_cache_dir
from isj.design_space import DesignSpace

SPACE = DesignSpace(
    pedicle_e_pa=(3e9, 12e9),
    gap_e_pa=(5e6, 20e6),
    capsule_e_pa=(20e6, 100e6),
    plate_e_pa=(1e9, 1e9),
    stapes_e_pa=(1e9, 1e9),
)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=float, default=0.35, help="FE mesh refinement factor")
    parser.add_argument("--out", help="write the calibration (JSON), readable by isj.LumpedModel.load")
    args = parser.parse_args(argv)

    seeds = {"training": 0, "validation": 1}
    train = sample(SPACE, 8, seed=seeds["training"], method="sobol")
    held = sample(SPACE, 4, seed=seeds["validation"], method="lhs")
    settings = fe_settings(order=2, resolution=args.resolution)
    cache = fe_cache_dir()  # $ISJ_FE_CACHE_DIR, else ~/.cache/isj/fe
    # max_workers=0: in this process, one FE model built once for all twelve designs
    records = run_designs(train + held, evaluate_design, settings, cache, max_workers=0, progress=False)
    points = records_for_fit(records)  # α, β per Pa
    fit_points, held_points = points[: len(train)], points[len(train) :]

    shipped = isj.LumpedModel.default()
    fit = fit_factors(fit_points, x0=shipped.factors, max_iter=3000)  # from the shipped factors
    training, validation = error_stats(fit.factors, fit_points), error_stats(fit.factors, held_points)
    calibration = dataclasses.replace(  # the chain's shear factor stays the shipped one (no FE modes here)
        shipped.calibration,
        factors={n: float(v) for n, v in zip(FACTOR_NAMES, fit.factors, strict=True)},
        domain=SPACE.to_dict(),
        training=training | {"ipopt_iterations": fit.iterations},
        validation=validation,
        fe_settings=settings,
        provenance={"samples": len(train), "validation_samples": len(held), "seeds": seeds},
        region={},  # the shipped map of where 3 % holds is the shipped factors', not these
    )
    custom = isj.LumpedModel(calibration)

    print(f"FE points: {len(train)} training, {len(held)} held out (P2, resolution {args.resolution:g})")
    print(f"IPOPT: {fit.status}, {fit.iterations} iterations")
    for label, stats in (("training", training), ("held-out", validation)):
        print(f"{label} max error: alpha {stats['max_alpha']:.4e}, beta {stats['max_beta']:.4e}")
    before = error_stats(shipped.factors, held_points)
    print(
        f"shipped calibration, held-out max error: alpha {before['max_alpha']:.4e}, "
        f"beta {before['max_beta']:.4e}"
    )
    mid = custom.static(SPACE.mid())
    print(
        f"custom model at the space's centre: alpha_rad = {float(mid.alpha_rad)!r}, "
        f"beta_rad = {float(mid.beta_rad)!r}"
    )
    print(
        f"inside its domain: the centre {bool(custom.in_domain(SPACE.mid()))}, "
        f"a 1 MPa gap {bool(custom.in_domain(gap_e_pa=1e6))}"
    )
    if args.out:
        from isj.atomic import atomic_write_text

        atomic_write_text(args.out, calibration.to_json())
        print(f"wrote {args.out}")
    assert np.all(np.isfinite(fit.factors))


if __name__ == "__main__":
    main()
