"""Whole cat middle ear, static (docs/ear.md §5.12): solve time, displacements per Pa against experiment.

Usage: ``.venv/bin/python benchmarks/ear.py [--resolution R] [--json PATH]``

Prints, for the default parameters (docs/ear.md §5.8): the umbo, maximum eardrum and footplate
displacements per Pa of ear-canal pressure against the cat experiments
(Guinan & Peake 1967; Decraemer et al. 2000), the malleus–incus axis, α and β
inside the ear for the seven thesis cases against the isolated joint model,
solve times, and a one-at-a-time sensitivity study (rigid-joint variant) of
the obvious suspects. Nothing is tuned.
"""

from __future__ import annotations

import argparse
import json
import time

from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.model import PedicleJointModel

from isj.cases import THESIS_CASES
from isj.design import DEFAULT_PRESSURE_PA
from isj.ear import (
    EXPERIMENT_STAPES_M_PER_PA,
    EXPERIMENT_UMBO_M_PER_PA,
    SPL_100DB_PEAK_PA,
    EarGeometry,
    EarMaterials,
)

NM = 1e9


def _row(label, r):
    fp = r.footplate_m_per_pa
    return (
        f"{label:34s} umbo {r.umbo_m_per_pa * NM:6.1f}  drum max {r.eardrum_max_m_per_pa * NM:6.1f}  "
        f"footplate piston {r.footplate_piston_m_per_pa * NM:6.2f}  (x, y, z) "
        f"({fp[0] * NM:6.2f}, {fp[1] * NM:6.2f}, {fp[2] * NM:6.2f}) nm/Pa"
    )


def sensitivity(base: EarGeometry) -> list[tuple[str, dict]]:
    """One-at-a-time changes on the rigid-joint variant (fast); returns (label, result dict)."""
    m = EarMaterials()
    springs = dict(malleus_ligament_n_m=m.malleus_ligament_n_m, incudal_lateral_n_m=m.incudal_lateral_n_m)
    springs["incudal_medial_n_m"] = m.incudal_medial_n_m
    cases = [
        ("default parameters", base, m),
        ("drum E x 0.5", base, m.replace(drum_e_pa=0.5 * m.drum_e_pa)),
        ("drum E x 2", base, m.replace(drum_e_pa=2 * m.drum_e_pa)),
        ("drum thickness x 0.5", base, m.replace(drum_thickness_m=0.5 * m.drum_thickness_m)),
        ("drum thickness x 2", base, m.replace(drum_thickness_m=2 * m.drum_thickness_m)),
        ("ligaments x 0.5", base, m.replace(**{k: 0.5 * v for k, v in springs.items()})),
        ("ligaments x 2", base, m.replace(**{k: 2 * v for k, v in springs.items()})),
        ("ligaments x 0 (drum+cochlea only)", base, m.replace(**{k: 0.0 for k in springs})),
        (
            "annular/cochlear springs x 2",
            base,
            m.replace(annular_out_of_plane_n_m=22.0, annular_in_plane_n_m=19.8),
        ),
        (
            "annular/cochlear springs x 0.5",
            base,
            m.replace(annular_out_of_plane_n_m=5.5, annular_in_plane_n_m=4.95),
        ),
        (
            "long process 0.5 mm longer (lever)",
            base.replace(long_process_end_m=(2.0e-3, -0.8e-3, -0.845e-3)),
            m,
        ),
        (
            "long process 0.5 mm shorter (lever)",
            base.replace(long_process_end_m=(3.0e-3, -0.8e-3, -0.845e-3)),
            m,
        ),
        (
            "axis 1.3 mm more lateral (z=-1.2 mm)",
            base.replace(
                body_reference_m=(4.3e-3, 0.0, -1.2e-3),
                malleus_ligament_m=(4.3e-3, 1.5e-3, -1.2e-3),
                incudal_lateral_m=(4.3e-3, -1.2e-3, -1.1e-3),
                incudal_medial_m=(4.3e-3, -1.2e-3, -1.3e-3),
            ),
            m,
        ),
        (
            "incudal bundles on the axis (dz=0)",
            base.replace(
                incudal_lateral_m=(4.3e-3, -1.2e-3, -2.5e-3), incudal_medial_m=(4.3e-3, -1.2e-3, -2.5e-3)
            ),
            m,
        ),
    ]
    out = []
    cache: dict[EarGeometry, MiddleEarModel] = {}
    for label, g, mat in cases:
        model = cache.setdefault(g, MiddleEarModel(g))
        r = model.static(ear_materials=mat)
        print(_row(label, r) + f"  lever {g.lever_ratio:.2f}")
        out.append((label, r.to_dict() | {"lever_ratio": g.lever_ratio}))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=1.0, help="joint mesh refinement (1 = default mesh)")
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    report: dict = {}

    t0 = time.perf_counter()
    joint = PedicleJointModel(order=2, resolution=args.resolution)
    t1 = time.perf_counter()
    ear = MiddleEarModel(joint=joint)
    t2 = time.perf_counter()
    print(
        f"joint model: {joint.n_dofs} free dofs, built in {t1 - t0:.1f} s; whole ear: {ear.n_dofs} dofs, "
        f"pattern nnz {ear.pattern.nnz}, built in {t2 - t1:.1f} s ({ear.timings_s})"
    )
    first = ear.static()
    again = ear.static()
    print(
        f"first whole-ear solve (analysis included) {first.timings_s['total']:.2f} s; "
        f"next solve {again.timings_s['total']:.2f} s {again.timings_s}"
    )
    rigid = MiddleEarModel()
    rigid.static()
    rr = rigid.static()
    print(f"rigid-joint variant: {rigid.n_dofs} dofs, solve {rr.timings_s['total']:.3f} s")
    report["timing"] = {
        "joint_build_s": t1 - t0,
        "ear_build_s": t2 - t1,
        "first_solve_s": first.timings_s["total"],
        "solve_s": again.timings_s["total"],
        "rigid_solve_s": rr.timings_s["total"],
        "n_dofs": ear.n_dofs,
        "rigid_n_dofs": rigid.n_dofs,
    }

    print("\n-- default parameters, per Pa of ear-canal pressure (100 dB SPL = 2.828 Pa peak)")
    print(_row("embedded joint (base case)", again))
    print(_row("rigid joint", rr))
    lo, hi = EXPERIMENT_STAPES_M_PER_PA
    print(
        f"experiment: umbo {EXPERIMENT_UMBO_M_PER_PA * NM:.0f} nm/Pa, "
        f"stapes {lo * NM:.0f}-{hi * NM:.0f} nm/Pa; "
        f"model/experiment: umbo {again.umbo_m_per_pa / EXPERIMENT_UMBO_M_PER_PA:.2f}, "
        f"stapes {again.footplate_piston_m_per_pa / hi:.2f}-{again.footplate_piston_m_per_pa / lo:.2f}"
    )
    ax = again.rotation_axis
    point = [round(v * 1e3, 3) for v in ax["point_m"]]
    direction = [round(v, 3) for v in ax["direction"]]
    print(
        f"malleus-incus axis: point {point} mm, direction {direction}, "
        f"rotation {ax['rotation_rad'] * 1e6:.2f} µrad/Pa"
    )
    report["base"] = again.to_dict()
    report["rigid"] = rr.to_dict()

    print(
        f"\n-- alpha, beta: in the ear (µrad per Pa, and at {SPL_100DB_PEAK_PA} Pa) vs the isolated model "
        f"({DEFAULT_PRESSURE_PA} Pa on the incus face)"
    )
    print(
        f"{'case':6s} {'a/Pa':>8s} {'b/Pa':>8s} {'b/a':>6s} | {'a@100dB':>8s} {'b@100dB':>8s} | "
        f"{'a iso':>7s} {'b iso':>7s} {'b/a':>6s} | stapes piston nm/Pa | solve s"
    )
    report["cases"] = {}
    for case in THESIS_CASES:
        mat = case.materials()
        r = ear.static(mat)
        iso = joint.static(mat)
        a, b = r.alpha_rad_per_pa * 1e6, r.beta_rad_per_pa * 1e6
        print(
            f"{case.name:6s} {a:8.3f} {b:8.3f} {b / a:6.2f} | {a * SPL_100DB_PEAK_PA:8.3f} "
            f"{b * SPL_100DB_PEAK_PA:8.3f} | {iso.alpha_rad * 1e6:7.3f} {iso.beta_rad * 1e6:7.3f} "
            f"{iso.ratio:6.2f} | {r.footplate_piston_m_per_pa * NM:6.2f} | {r.timings_s['total']:.2f}"
        )
        report["cases"][case.name] = {"ear": r.to_dict(), "isolated": iso.to_dict()}

    print("\n-- sensitivity (rigid-joint variant, one change at a time)")
    report["sensitivity"] = dict(sensitivity(EarGeometry()))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
