"""Accuracy of the shipped lumped calibration against FE: held-out points and the thesis cases.

Run:  .venv/bin/python benchmarks/lumped_accuracy.py [N_FRESH [SEED ...]]
      .venv/bin/python benchmarks/lumped_accuracy.py --domain [CALIBRATION.json ...]

``--domain`` instead guards each calibration (default: the shipped one) over the whole domain
with the certified surrogate of the default mesh (built the first time: minutes; then cached):
the worst certified error of α, β and β/α, and the count over 3 %, at the 32 corners, on 4096
and 65,536 Sobol designs (seed 0: the adaptive calibration's own sample starts with its first
4096) and on 65,536 others (seed 1), with the worst design; and, for a calibration with a
region map (docs/lumped.md §3.15), how many failing designs of the seed-1 sample it marks.

Prints the validation errors recorded in the shipped calibration (FE points
the fit never saw), then the errors on N_FRESH (default 64) further designs
that neither the fit nor its validation saw (a Latin hypercube of the
calibrated domain per SEED, default 12345; FE cached), then at the 2^d corners
of the domain (every modulus at a bound at once: the hardest points, outside
what a space-filling sample reaches), then runs the seven thesis cases through
FE (cached) and the lumped model and compares α, β, β/α and their trends (the
sign of each case's change from the base case).
"""

from __future__ import annotations

import sys

import numpy as np
from isj.calibration.checks import compare_static
from isj.fem.batch import evaluate_design, fe_settings
from isj.lumped.artifact import default_calibration

from isj.caches import fe_cache_dir
from isj.cases import THESIS_CASES


def _trend(a, b, i, threshold):
    """Sign of case i's change of α, β and β/α from the base case (0 below the threshold)."""
    rel = np.array([a[i] / a[0] - 1, b[i] / b[0] - 1, (b[i] / a[i]) / (b[0] / a[0]) - 1])
    return np.sign(rel) * (np.abs(rel) > threshold)


def _compare(cal, designs: list[dict], progress: bool = False):
    """FE (default mesh, cached) and the lumped model over ``designs``: a StaticComparison."""
    return compare_static(cal, designs, evaluate_design, fe_settings(), fe_cache_dir(), progress=progress)


def _errors(cal, designs: list[dict], progress: bool = False):
    """Relative errors lumped/FE − 1 of α, β and β/α over ``designs`` (FE cached)."""
    comp = _compare(cal, designs, progress)
    return tuple(comp.rel_error(k) for k in ("alpha_rad", "beta_rad", "beta_over_alpha"))


def fresh_check(cal, n: int, seed: int = 12345) -> None:
    """Errors on ``n`` designs that neither the fit nor its validation used."""
    from isj.calibration.doe import sample

    from isj.design_space import DesignSpace

    designs = sample(DesignSpace.from_dict(cal.domain), n, seed, method="lhs")
    ea, eb, er = _errors(cal, designs, progress=True)
    print(
        f"fresh FE points (LHS, seed {seed}): {n}; max error alpha {100 * np.abs(ea).max():.2f} %, beta "
        f"{100 * np.abs(eb).max():.2f} %, beta/alpha {100 * np.abs(er).max():.2f} %; RMS "
        f"{100 * np.sqrt(np.mean(ea**2)):.2f} / {100 * np.sqrt(np.mean(eb**2)):.2f} / "
        f"{100 * np.sqrt(np.mean(er**2)):.2f} %"
    )


def corner_check(cal) -> None:
    """Errors at the 2^d corners of the calibrated domain: every modulus at a bound at once."""
    import itertools

    keys = [k for k, (lo, hi) in cal.domain.items() if lo < hi]
    designs = [
        {k: cal.domain[k][i] for k, i in zip(keys, corner, strict=True)}
        for corner in itertools.product((0, 1), repeat=len(keys))
    ]
    ea, eb, _ = _errors(cal, designs)
    print(
        f"corners of the domain: {len(designs)}; max error alpha {100 * np.abs(ea).max():.2f} %, beta "
        f"{100 * np.abs(eb).max():.2f} %; over 3 %: alpha {int(np.sum(np.abs(ea) > 0.03))}, beta "
        f"{int(np.sum(np.abs(eb) > 0.03))}"
    )
    worst = np.argsort(-np.abs(ea))[:3]
    for i in worst:
        moduli = ", ".join(f"{k.removesuffix('_e_pa')} {designs[i][k]:.3g}" for k in keys)
        print(f"  alpha {100 * ea[i]:+.2f} %, beta {100 * eb[i]:+.2f} % at {moduli} Pa")


def domain_check(cal, rom, label: str) -> None:
    """Worst certified lumped error over corners and dense samples of the domain (docs/lumped.md §3.15)."""
    from isj.calibration.guard import _base, corner_designs, dense_designs, guard_set
    from isj.calibration.region import in_region, region_of

    domain = {k: tuple(v) for k, v in cal.domain.items()}
    base = _base(rom)
    sets = {
        "corners": corner_designs(domain, base),
        "dense 4096 (seed 0)": dense_designs(domain, 4096, 0, base),
        "dense 65536 (seed 0)": dense_designs(domain, 65536, 0, base),
        "dense 65536 (seed 1)": dense_designs(domain, 65536, 1, base),
    }
    print(f"{label}:")
    for name, designs in sets.items():
        g = guard_set(name, cal, rom, designs)
        s = g.summary()
        w = s["worst"]
        where = ", ".join(f"{k.removesuffix('_e_pa')} {w[k]:.3g}" for k in w if k.endswith("_e_pa"))
        line = f"  {name:21}: worst certified {100 * s['max_certified_error']:.2f} %, {s['n_fail']} over 3 %"
        inside = in_region(region_of(cal), cal.domain, g.designs)
        if inside is not None:
            fail = g.verdict == "fail"
            line += (
                f"; region map: {int(np.sum(~inside))} marked outside, "
                f"{int(np.sum(fail & inside))} failing designs inside it"
            )
        print(f"{line}\n      worst at {where} Pa")


def main():
    if "--domain" in sys.argv[1:]:
        from isj.fem.rom import reduced_model
        from isj.lumped.artifact import Calibration

        rom = reduced_model()
        paths = [a for a in sys.argv[1:] if a != "--domain"]
        for path in paths or [None]:
            domain_check(
                default_calibration() if path is None else Calibration.load(path), rom, path or "shipped"
            )
        return
    cal = default_calibration()
    v = cal.validation
    print(
        f"held-out FE points: {v['n']}; max error alpha {100 * v['max_alpha']:.2f} %, beta "
        f"{100 * v['max_beta']:.2f} %, beta/alpha {100 * v['max_ratio']:.2f} %; RMS "
        f"{100 * v['rms_alpha']:.2f} / {100 * v['rms_beta']:.2f} / {100 * v['rms_ratio']:.2f} %"
    )
    n_fresh = int(sys.argv[1]) if len(sys.argv) > 1 else 64
    for seed in [int(a) for a in sys.argv[2:]] or [12345]:
        if n_fresh:
            fresh_check(cal, n_fresh, seed)
    corner_check(cal)
    designs = [
        {"pedicle_e_pa": c.pedicle_e_pa, "gap_e_pa": c.gap_e_pa, "capsule_e_pa": c.capsule_e_pa}
        for c in THESIS_CASES
    ]
    comp = _compare(cal, designs)
    fe_a, fe_b = comp.fe_alpha_rad, comp.fe_beta_rad
    lum_a, lum_b = comp.lumped_alpha_rad, comp.lumped_beta_rad
    print(
        f"{'case':7} {'FE alpha':>9} {'lumped':>9} {'err':>7} {'FE beta':>9} {'lumped':>9} {'err':>7} trend"
    )
    same = strict = 0
    for i, c in enumerate(THESIS_CASES):
        ok = bool(np.all(_trend(fe_a, fe_b, i, 1e-2) == _trend(lum_a, lum_b, i, 1e-2)))
        strict += bool(np.all(_trend(fe_a, fe_b, i, 1e-3) == _trend(lum_a, lum_b, i, 1e-3)))
        same += ok
        la, lb = lum_a[i], lum_b[i]
        print(
            f"{c.name:7} {fe_a[i] * 1e6:9.4f} {la * 1e6:9.4f} {100 * (la / fe_a[i] - 1):+6.2f}% "
            f"{fe_b[i] * 1e6:9.4f} {lb * 1e6:9.4f} {100 * (lb / fe_b[i] - 1):+6.2f}% "
            f"{'same' if ok else 'DIFFERENT'}"
        )
    print(
        f"trends (sign of each case's change of alpha, beta and beta/alpha from the base case): "
        f"{same}/7 cases identical counting changes > 1 %, {strict}/7 counting changes > 0.1 % "
        "(the lumped model has no coupling of beta to the capsule or of alpha to the pedicle, which "
        "move FE by < 0.5 %)"
    )


if __name__ == "__main__":
    main()
