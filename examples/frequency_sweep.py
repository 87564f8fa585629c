"""A frequency sweep of the lumped chain, checked against one FE harmonic solve.

The lumped chain (eight coordinates, calibrated) gives α, β and the incus's
displacement at 200 frequencies in milliseconds; one damped FE harmonic solve
at ``--check-hz`` checks it. Both use the same damping (the default: a loss
factor per material, docs/dynamics.md §4.3) and the default design.

On the coarse default mesh the FE model is too stiff (β about 10 % low), so
the raw difference is mostly the mesh's; the dynamic amplification
H(f)/H(0), which that error cancels from, is compared too.

    python examples/frequency_sweep.py [--check-hz 5000] [--csv sweep.csv] [--plot bode.png]
"""

import argparse

import numpy as np

import isj


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check-hz", type=float, default=5000.0, help="FE check frequency (Hz)")
    parser.add_argument("--resolution", type=float, default=0.35, help="FE mesh refinement factor")
    parser.add_argument("--csv", help="write the lumped sweep as CSV")
    parser.add_argument("--plot", help="write a Bode plot (PNG, PDF, SVG)")
    args = parser.parse_args(argv)
    if not 0 < args.check_hz <= 1e6:
        parser.error(f"--check-hz = {args.check_hz:g}: must be in (0, 1e6] Hz")

    design = isj.Materials()
    lumped = isj.LumpedModel.default()
    freq_hz = np.geomspace(100.0, 30e3, 200)
    sweep = lumped.frequency_response(freq_hz, design)  # at the default pressure amplitude
    f_nat, zeta = lumped.chain(design).poles()  # ζ1 ≈ 0.02: mostly bone (η = 0.01), some joint (0.15)
    print(f"lumped: first natural frequency {f_nat[0]:.1f} Hz, damping ratio {zeta[0]:.2f}")
    print(
        f"lumped: |alpha| from {sweep.magnitude('alpha_rad')[0]:.4e} rad at {freq_hz[0]:g} Hz "
        f"to {sweep.magnitude('alpha_rad')[-1]:.4e} rad at {freq_hz[-1]:g} Hz"
    )

    model = isj.PedicleJointModel(order=2, resolution=args.resolution)
    at = [0.0, args.check_hz]  # 0 Hz: the static response, for the amplification
    fe = model.frequency_response(at, design)
    lu = lumped.frequency_response(at, design)
    print(f"FE check at {args.check_hz:g} Hz (P2, resolution {args.resolution:g}, {model.n_dofs} dofs):")
    for name in ("alpha_rad", "beta_rad"):
        err = abs(lu[name][1] / fe[name][1] - 1)
        amp_err = abs((lu[name][1] / lu[name][0]) / (fe[name][1] / fe[name][0]) - 1)
        print(f"  fe {name} = {complex(fe[name][1])!r}")
        print(f"  lumped {name} = {complex(lu[name][1])!r}")
        print(f"  {name} relative difference = {err:.4e}, of the amplification = {amp_err:.4e}")

    if args.csv:
        sweep.to_csv(args.csv)
        print(f"wrote {args.csv}")
    if args.plot:
        artists = sweep.plot(outputs=("alpha_rad", "beta_rad"))
        artists[0].figure.savefig(args.plot)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
