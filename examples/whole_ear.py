"""The whole cat middle ear: FE static response per Pa, the lumped ear beside it, and a short sweep.

The FE ear holds the 3-D pedicle-and-joint model inside (coarse mesh by
default); the lumped ear reduces the eardrum onto the malleus–incus body and
carries the calibrated joint. Both are per pascal of ear-canal pressure.

    python examples/whole_ear.py [--resolution 0.35]
"""

import argparse

import numpy as np

import isj
from isj.ear import EXPERIMENT_UMBO_M_PER_PA


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=float, default=0.35, help="joint mesh refinement factor")
    args = parser.parse_args(argv)

    design = isj.Materials()
    joint = isj.PedicleJointModel(order=2, resolution=args.resolution)
    ear = isj.MiddleEarModel(joint=joint)
    fe = ear.static(design)
    lumped = isj.LumpedModel.default()
    lumped_ear = lumped.ear(design)
    static = dict(zip(("umbo", "stapes", "alpha", "beta"), lumped_ear.static().outputs, strict=True))

    print(f"FE ear: {ear.n_dofs} dofs; experiment umbo {EXPERIMENT_UMBO_M_PER_PA * 1e9:g} nm/Pa")
    rows = (
        ("umbo_m_per_pa", fe.umbo_m_per_pa, static["umbo"]),
        ("stapes_m_per_pa", fe.footplate_piston_m_per_pa, static["stapes"]),
        ("alpha_rad_per_pa", fe.alpha_rad_per_pa, static["alpha"]),
        ("beta_rad_per_pa", fe.beta_rad_per_pa, static["beta"]),
    )
    for name, v_fe, v_lumped in rows:
        diff = v_lumped / v_fe - 1
        print(f"static {name}: fe = {v_fe!r}, lumped = {float(v_lumped)!r}, difference {diff:+.4f}")

    sweep = lumped_ear.frequency_response(np.geomspace(100.0, 5000.0, 8))
    print("lumped ear sweep: freq_hz, |umbo| nm/Pa, |stapes| nm/Pa")
    for f, u, s in zip(sweep.freq_hz, sweep.magnitude("umbo_m"), sweep.magnitude("stapes_m"), strict=True):
        print(f"  {f:8.1f} {u * 1e9:8.3f} {s * 1e9:8.3f}")

    check = ear.frequency_response([500.0], design)
    lu = lumped_ear.frequency_response([500.0])
    for name in ("umbo_m", "stapes_m"):
        print(f"FE check at 500 Hz: {name} relative difference = {abs(lu[name][0] / check[name][0] - 1):.4e}")


if __name__ == "__main__":
    main()
