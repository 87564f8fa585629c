"""Solve one design with the FE pedicle-and-joint model and print α and β.

The design is the thesis case j5c20 (a soft joint: gap 5 MPa, capsule 20 MPa),
loaded by the default pressure on the incus's face. The lumped model's values are
printed beside the FE ones.

    python examples/solve_design.py                    # coarse mesh, seconds
    python examples/solve_design.py --resolution 1     # the calibration's mesh

The coarse default mesh (P2, resolution 0.35) is stiffer than a converged one:
β comes out about 10 % low there (docs/ has the mesh convergence study).
"""

import argparse

import isj


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=float, default=0.35, help="mesh refinement factor")
    parser.add_argument("--order", type=int, default=2, choices=(1, 2), help="P1 or P2 tetrahedra")
    args = parser.parse_args(argv)

    design = isj.case_by_name("j5c20").materials()
    model = isj.PedicleJointModel(order=args.order, resolution=args.resolution)  # the mesh is cached
    fe = model.static(design)
    lumped = isj.LumpedModel.default().static(design)

    print(f"mesh: P{args.order}, resolution {args.resolution:g}, {model.n_tets} tets, {model.n_dofs} dofs")
    print(f"pressure_pa = {fe.pressure_pa!r}")
    print(f"fe alpha_rad = {fe.alpha_rad!r}")
    print(f"fe beta_rad = {fe.beta_rad!r}")
    print(f"fe beta_over_alpha = {fe.ratio!r}")
    print(f"lumped alpha_rad = {float(lumped.alpha_rad)!r}")
    print(f"lumped beta_rad = {float(lumped.beta_rad)!r}")
    share = fe.energy_fraction()
    print("strain energy: " + ", ".join(f"{k} {100 * v:.1f} %" for k, v in share.items()))


if __name__ == "__main__":
    main()
