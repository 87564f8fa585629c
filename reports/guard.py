"""The report's guard step and page (docs/rom.md §10.10): the lumped model's error over the domain.

The certified surrogate of the report's mesh (:func:`isj.fem.rom.reduced_model`, built once
per mesh and code, then cached) checks the report's lumped model on the 2^d corners of the
calibrated domain and a dense Sobol sample of it (:func:`isj.calibration.guard.run_guard`);
true FE runs at the worst few designs and confirms the surrogate there. The page maps the
certified error over each pair of moduli and names the worst design.
"""

from __future__ import annotations

import numpy as np

from .layout import text_block, wrap


def guard_step(ctx) -> tuple[dict, dict]:
    """Corners and a dense sample through the surrogate; FE at the ``fe_checks`` worst designs."""
    from isj.calibration.guard import confirmations, run_guard, worst_picks
    from isj.fem.batch import free_solvers
    from isj.fem.rom import reduced_model

    from isj.design_space import DesignSpace

    # the FE checks are designs of their own: the factorizations the steps before kept (the
    # bonded and sliding joints', 0.45 GB each on the default mesh) would only be held beside them
    free_solvers()
    cfg, g = ctx.config, ctx.config.guard
    base = cfg.design.materials()
    rom = reduced_model(
        cfg.geometry, cfg.mesh.order, cfg.mesh.resolution, DesignSpace(incus_e_pa=base.incus_e_pa, nu=base.nu)
    )
    none = {k: np.zeros(0) for k in ctx.calibration.domain}
    guard = run_guard(
        ctx.calibration,
        rom,
        none,
        tolerance=g.tolerance,
        n_dense=g.dense_samples,
        seed=g.seed,
        pressure_pa=cfg.design.pressure_pa,
        geometry=cfg.geometry,
    )
    picks = worst_picks(guard, g.fe_checks)
    designs = [guard.sets[name].design(i) | {"nu": base.nu} for name, i in picks]
    confirmed = confirmations(guard, picks, ctx.compare(designs), g.tolerance) if designs else []
    summary = guard.summary(confirmed)
    summary.pop("time_s")  # the same inputs give the same JSON
    dense = guard.sets["dense"]
    arrays = {f"dense_{k}": v for k, v in dense.designs.items()} | {
        "dense_max_certified": dense.max_certified
    }
    return summary, arrays


def guard_page(fig, res: dict, arrays: dict):
    """Certified lumped error of the dense sample over each pair of moduli; the worst design."""
    from matplotlib.ticker import NullFormatter

    names = [k for k in res["domain_pa"] if f"dense_{k}" in arrays]
    err = 100 * np.asarray(arrays["dense_max_certified"])
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1 :]]
    ncol = 4
    w, h, gap = 0.165, 0.13, 0.055  # the four columns end at 0.905, left of the colour bar
    sc = None
    for n, (a, b) in enumerate(pairs[:12]):
        r, c = divmod(n, ncol)
        ax = fig.add_axes([0.08 + c * (w + gap), 0.76 - r * (h + 0.05), w, h])
        order = np.argsort(err)  # the worst on top
        sc = ax.scatter(
            arrays[f"dense_{a}"][order],
            arrays[f"dense_{b}"][order],
            c=err[order],
            s=3,
            cmap="viridis",
            vmin=0,
            vmax=max(float(err.max()), 1e-9),
            rasterized=True,  # thousands of markers per panel: as vectors they took 3 s to write
        )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"{a.removesuffix('_e_pa')} (Pa)", fontsize=6)
        ax.set_ylabel(f"{b.removesuffix('_e_pa')} (Pa)", fontsize=6)
        ax.tick_params(which="both", labelsize=5)
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_minor_formatter(NullFormatter())  # decades only: the panels are small
    if sc is not None:
        cb = fig.colorbar(sc, cax=fig.add_axes([0.93, 0.50, 0.012, 0.35], label="<colorbar>"))
        cb.set_label("largest certified lumped error (%)", fontsize=6)
        cb.ax.tick_params(labelsize=5)
    tol = 100 * res["tolerance"]
    lines = []
    for name in ("corners", "dense"):
        s = res[name]
        worst = s.get("worst") or {}
        d = {k: worst[k] for k in res["domain_pa"] if k in worst}
        worst_pct = 100 * (s["max_certified_error"] or float("nan"))
        lines.append(
            f"{name}: {s['n']} designs, {s['n_fail']} beyond {tol:g} %; worst {worst_pct:.2f} % at "
            + ", ".join(f"{k.removesuffix('_e_pa')} {v:.3g}" for k, v in d.items())
            + " Pa"
        )
    for c in res["fe_confirmations"]:
        e = {k: 100 * c[f"{k}_rel_error_vs_fe"] for k in ("alpha", "beta", "beta_over_alpha")}
        lines.append(
            f"FE at the {c['set']} design {c['index']}: lumped/FE - 1 = alpha {e['alpha']:+.2f} %, "
            f"beta {e['beta']:+.2f} %, beta/alpha {e['beta_over_alpha']:+.2f} %; "
            f"FE within the surrogate's bound: {'yes' if c['confirmed'] else 'NO'}"
        )
    s = res["surrogate"]
    note = (
        "The certified error is the largest |lumped / FE - 1| of alpha, beta and beta/alpha that the "
        f"surrogate's rigorous bound allows (docs/rom.md 10.10), on the P{s.get('order', '?')} mesh of this "
        "report. Each panel projects the dense Sobol sample of the calibrated domain onto one pair of moduli "
        "(the others vary); the worst designs are drawn on top."
    )
    text_block(fig, 0.07, 0.22, wrap("\n".join(lines), 115) + "\n\n" + wrap(note, 115), fontsize=6.5)
