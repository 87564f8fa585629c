"""Dynamics: lumped sweep speed, FE harmonic cost, and lumped against FE (docs/performance.md §8.3).

Run:  .venv/bin/python benchmarks/dynamics.py

- a 1000-frequency × 100-design lumped sweep (best of 5);
- one FE harmonic solve against one static solve on the default mesh, as ratios
  taken back to back in this process (alternating, best of 3, so that other
  load on the machine cancels): static with and without a fresh analysis;
  harmonic by Lanczos (the default) and by complex PARDISO, each on a fresh
  model and after a static solve; the previous real 2n × 2n block solve; and
  the five frequencies of a default ``isj sweep`` in one call;
- |α(f)|, |β(f)| lumped against FE below 0.8 × the first FE resonance, for a
  few designs of the calibrated domain, at frequencies the calibration never used;
- the first two in-plane natural frequencies, lumped against FE, on those designs and on
  the shipped calibration's modal training and held-out designs (FE modes from the
  result cache, ``ISJ_FE_CACHE_DIR`` or ~/.cache/isj/fe; computed when missing).
"""

from __future__ import annotations

import time

import numpy as np
from isj.fem.dynamics import (
    _shifted_lanczos,
    _solve_block,
    damping_matrices,
    harmonic,
    harmonic_outputs,
    modes,
)
from isj.fem.model import PedicleJointModel
from isj.lumped.artifact import default_calibration
from isj.lumped.dynamics import chain_model, chain_outputs

from isj.damping import Damping
from isj.design import Materials


def calibration_frequencies(cal, samples=16, validation=8, seed=100):
    """f1, f2 errors (relative) of the chain against FE in-plane modes on the calibration's modal designs.

    The designs of ``isj calibrate`` (defaults: 16 Sobol training designs, seed 100; 8 Latin
    hypercube held-out ones, seed 101) from the calibration's domain and FE settings.
    """
    from isj.calibration.doe import sample
    from isj.calibration.runner import run_designs
    from isj.fem.batch import evaluate_modes, fe_settings

    from isj.caches import fe_cache_dir
    from isj.design_space import DesignSpace

    space = DesignSpace.from_dict(cal.domain)
    sets = {
        "training": sample(space, samples, seed, method="sobol"),
        "held-out": sample(space, validation, seed + 1, method="lhs"),
    }
    fs = cal.fe_settings
    settings = fe_settings(order=fs.get("order", 2), resolution=fs.get("resolution", 1.0))
    settings |= {"kind": "modes", "n_modes": 6}
    cache = fe_cache_dir()
    f = cal.factor_array()
    for name, designs in sets.items():
        recs = run_designs(designs, evaluate_modes, settings, cache, max_workers=0, progress=False)
        fe = np.array([r["result"]["in_plane_freq_hz"][:2] for r in recs])
        moduli = {k: np.array([d[k] for d in designs]) for k in designs[0]}
        lf, _ = chain_model(f, cal.shear_factor, rayleigh_b_s=0.0, **moduli).poles()
        e = lf[:, :2] / fe - 1
        mx, rms = np.abs(e).max(axis=0), np.sqrt((e**2).mean(axis=0))
        print(
            f"  {name:8s} ({len(designs):2d} designs): f1 max {100 * mx[0]:.1f} %, RMS {100 * rms[0]:.1f} %; "
            f"f2 max {100 * mx[1]:.1f} %, RMS {100 * rms[1]:.1f} %"
        )


def fe_harmonic_cost(model, freq_hz=1000.0, rounds=3):
    """Seconds (best of ``rounds``) and ratios: one harmonic solve against one static solve."""
    # the proportional (old uniform) damping, whose shifted Lanczos path these timings measure; the
    # default per-region damping takes the projected path (docs/dynamics.md §4.5)
    m, d = Materials(), Damping.preset("uniform-rayleigh")
    b_s = d.rayleigh_b_s["pedicle"]
    red = model.reduction
    f = red.restrict(model.unit_load)
    sweep = np.geomspace(100.0, 20e3, 7)[1:-1]  # the FE checks of `isj sweep --fe-checks 5`

    def static_fresh():  # a static spot check on a model not solved before: analysis + factor + solve
        model._solver = None
        model.displacement(m, 1.0)

    def static_reused():  # the analysis of the pattern reused: factor + solve
        model.displacement(m, 1.0)

    def fresh(method, freqs=(freq_hz,)):
        def run():
            model._solver = None
            return harmonic(model, freqs, m, d, 1.0, method=method)[0]

        return run

    def reused(method):  # after a static solve (run untimed just before): its analysis reused
        return lambda: harmonic(model, [freq_hz], m, d, 1.0, method=method)[0]

    def block():  # the previous path: the real 2n × 2n symmetric indefinite block system
        w = 2 * np.pi * freq_hz
        K, L, C, M = damping_matrices(model, m, d)
        return red.expand(_solve_block((K - w**2 * M).tocsr(), (L + w * C).tocsr(), f))

    cases = {
        "static, analysis + factor + solve": static_fresh,
        "static, factor + solve (analysis reused)": static_reused,
        "harmonic, Lanczos (default), fresh model": fresh("auto"),
        "harmonic, Lanczos (default), after a static solve": reused("auto"),
        "harmonic, complex PARDISO direct, fresh model": fresh("direct"),
        "harmonic, complex PARDISO direct, after a static solve": reused("direct"),
        "harmonic, previous real 2n block system": block,
        f"harmonic at {sweep.size} frequencies, Lanczos, fresh model": fresh("auto", sweep),
    }
    fresh("auto")()  # assembles the mass once, outside the timings
    names = list(cases)
    best, out = dict.fromkeys(names, np.inf), {}
    for _ in range(rounds):
        for name in names:
            if "after a static solve" in name:
                static_reused()  # untimed: a static solver exists, as after a static spot check
            t0 = time.perf_counter()
            out[name] = cases[name]()
            best[name] = min(best[name], time.perf_counter() - t0)
    M = red.matrix(model.mass_data(m))
    model.displacement(m, 1.0)  # K factored, for counting Lanczos iterations

    def iterations(freqs):
        w = 2 * np.pi * np.asarray(freqs)
        return _shifted_lanczos(model._solver.solve, M, f, -(w**2) / (1 + 1j * w * b_s))[2]

    sf, sr = best[names[0]], best[names[1]]
    print(
        f"FE on the default mesh ({model.n_dofs} dofs), {freq_hz:g} Hz, uniform b = {b_s:g} s, "
        f"best of {rounds}:"
    )
    for name in names:
        t = best[name]
        print(f"  {name:58s} {t:6.2f} s = {t / sf:.2f}x static, {t / sr:.2f}x static with analysis reused")
    ref = out[names[6]]
    for name in names[2:6]:
        rel = np.linalg.norm(out[name] - ref) / np.linalg.norm(ref)
        print(f"  {name:58s} against the block system: {rel:.1e}")
    hz = np.round(sweep).astype(int).tolist()
    print(f"  Lanczos iterations: {iterations([freq_hz])} at {freq_hz:g} Hz, {iterations(sweep)} for {hz} Hz")
    return best


def main():
    cal = default_calibration()
    f = cal.factor_array()
    h = cal.shear_factor
    rng = np.random.default_rng(0)
    E = {k: np.exp(rng.uniform(np.log(lo), np.log(hi), 100)) for k, (lo, hi) in cal.domain.items()}
    freq = np.geomspace(100, 20e3, 1000)
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        chain_outputs(chain_model(f, h, **E), freq)
        best = min(best, time.perf_counter() - t0)
    print(f"lumped sweep, 1000 frequencies x 100 designs: {best * 1e3:.1f} ms")

    model = PedicleJointModel(order=2)
    fe_harmonic_cost(model)

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
        lum = chain_outputs(chain, checks)
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
            f"({100 * e2:+.1f} %); |alpha|, |beta| below 0.8 f1: max error {100 * ea:.1f} %, {100 * eb:.1f} %"
        )
    print(
        f"worst: |alpha| {100 * worst['alpha']:.1f} %, |beta| {100 * worst['beta']:.1f} %, "
        f"f1 {100 * worst['f1']:.1f} %, f2 {100 * worst['f2']:.1f} %"
    )
    print(f"chain (joint shear factor {h:.3f}) against FE in-plane modes, the calibration's modal designs:")
    calibration_frequencies(cal)


if __name__ == "__main__":
    main()
