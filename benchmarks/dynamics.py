"""Dynamics: lumped sweep speed, FE harmonic cost, and lumped against FE (spec §4 targets).

Run:  .venv/bin/python benchmarks/dynamics.py

- a 1000-frequency × 100-design lumped sweep (best of 5);
- one FE harmonic solve against one static solve on the default mesh;
- |α(f)|, |β(f)| lumped against FE below 0.8 × the first FE resonance, for a
  few designs of the calibrated domain, at frequencies the calibration never used;
- the first two in-plane natural frequencies, lumped against FE.
"""

from __future__ import annotations

import time

import numpy as np

from fem.dynamics import Damping, harmonic_outputs, modes
from fem.model import PedicleJointModel
from isj.design import Materials
from lumped.artifact import default_calibration
from lumped.dynamics import chain_model, frequency_response


def main():
    cal = default_calibration()
    f = cal.factor_array()
    h = cal.dynamics.get("hinge_fraction", 1 / 3)
    rng = np.random.default_rng(0)
    E = {k: np.exp(rng.uniform(np.log(lo), np.log(hi), 100)) for k, (lo, hi) in cal.domain.items()}
    freq = np.geomspace(100, 20e3, 1000)
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        frequency_response(chain_model(f, h, **E), freq)
        best = min(best, time.perf_counter() - t0)
    print(f"lumped sweep, 1000 frequencies x 100 designs: {best * 1e3:.1f} ms")

    model = PedicleJointModel(order=2)
    t0 = time.perf_counter()
    model.solve()
    t_static = time.perf_counter() - t0
    t0 = time.perf_counter()
    harmonic_outputs(model, [1000.0])
    t_harm = time.perf_counter() - t0
    print(
        f"FE on the default mesh ({model.n_dofs} dofs): static solve {t_static:.2f} s (analysis included), "
        f"harmonic at one frequency {t_harm:.2f} s = {t_harm / t_static:.1f}x"
    )

    designs = [
        Materials(),
        Materials(pedicle_e_pa=2e9, gap_e_pa=3e6, capsule_e_pa=20e6),
        Materials(pedicle_e_pa=20e9, gap_e_pa=40e6, capsule_e_pa=200e6, plate_e_pa=3e9),
    ]
    worst = {"alpha": 0.0, "beta": 0.0, "f1": 0.0, "f2": 0.0}
    for m in designs:
        fe_f, shapes = modes(model, m, 6)
        u = shapes.reshape(-1, 3, shapes.shape[1])
        fe_in = fe_f[(u[:, 1, :] ** 2).sum(axis=0) < 0.05 * (u[:, 0, :] ** 2).sum(axis=0)]
        moduli = {k: getattr(m, k) for k in cal.domain}
        chain = chain_model(f, h, **moduli)
        lf, _ = chain.poles()
        checks = np.array([0.1, 0.3, 0.55, 0.8]) * fe_in[0]
        fe = harmonic_outputs(model, checks, m, Damping())
        lum = frequency_response(chain, checks)
        ea = np.abs(np.abs(lum[:, 0]) / np.abs(fe["alpha_rad"]) - 1).max()
        eb = np.abs(np.abs(lum[:, 1]) / np.abs(fe["beta_rad"]) - 1).max()
        e1, e2 = lf[0] / fe_in[0] - 1, lf[1] / fe_in[1] - 1
        worst = {
            "alpha": max(worst["alpha"], ea),
            "beta": max(worst["beta"], eb),
            "f1": max(worst["f1"], abs(e1)),
            "f2": max(worst["f2"], abs(e2)),
        }
        print(
            f"  E_ped {m.pedicle_e_pa:.2g} E_gap {m.gap_e_pa:.2g} E_cap {m.capsule_e_pa:.2g}: FE in-plane "
            f"{fe_in[0]:.0f}, {fe_in[1]:.0f} Hz; lumped {lf[0]:.0f} ({100 * e1:+.1f} %), {lf[1]:.0f} Hz "
            f"({100 * e2:+.0f} %); |alpha|, |beta| below 0.8 f1: max error {100 * ea:.1f} %, {100 * eb:.1f} %"
        )
    print(
        f"worst: |alpha| {100 * worst['alpha']:.1f} %, |beta| {100 * worst['beta']:.1f} %, "
        f"f1 {100 * worst['f1']:.1f} %, f2 {100 * worst['f2']:.0f} %"
    )


if __name__ == "__main__":
    main()
