"""Lay the report out as an A4 PDF, one section per page (matplotlib, no creation date).

Numbers in the text are formatted by the helpers below (``urad``, ``pct``),
which the tests use too, so the PDF's text can be checked against the JSON.
"""

from __future__ import annotations

import numpy as np

from isj.design import REGIONS

from . import figures

A4 = (8.27, 11.69)  # inches
MONO = {"family": "monospace", "fontsize": 7.5}

#: Page titles, in order; the tests look for them in the PDF's text.
PAGE_TITLES = (
    "isj report",
    "1. The model",
    "2. The seven thesis cases",
    "3. Trends across the design space",
    "4. Strain energy per region",
    "5. Mesh convergence",
    "6. Calibration of the lumped model",
    "7. Frequency response",
    "8. The whole middle ear",
)


def urad(x: float) -> str:
    """rad → µrad, 4 decimals (the tables' format)."""
    return f"{x * 1e6:.4f}"


def ratio(x: float) -> str:
    return f"{x:.3f}"


def pct(x: float) -> str:
    return f"{100 * x:+.2f}"


def _page(title: str, number: int, total: int, footer: str):
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=A4)
    fig.text(0.07, 0.965, title, fontsize=15, weight="bold", va="top")
    fig.text(0.07, 0.02, footer, fontsize=6.5, color="0.4")
    fig.text(0.93, 0.02, f"{number} / {total}", fontsize=7, color="0.4", ha="right")
    return fig


def _text(fig, x: float, y: float, text: str, **kw):
    """Monospace block of text with its top-left corner at (x, y) in figure coordinates."""
    return fig.text(x, y, text, va="top", **(MONO | kw))


def _wrap(text: str, width: int = 100) -> str:
    import textwrap

    return "\n".join(textwrap.fill(p, width) if p else "" for p in text.split("\n"))


def title_page(fig, config, provenance: dict, model: dict):
    v = provenance["versions"]
    lines = [
        "Mechanics of the incus-stapes coupling in the cat: where does the flexibility",
        "between incus and stapes sit, in the bony pedicle or in the incudostapedial joint?",
        "",
        f"isj {v.get('isj', '?')}   git revision {provenance.get('git_revision') or 'n/a'}   "
        f"date {provenance['date']}",
        f"calibration: {provenance['calibration']}",
        f"FE mesh: P{model['order']}, resolution {model['resolution']:g}, {model['n_tets']} tets, "
        f"{model['n_dofs']} dofs, mesh {model['mesh_hash'][:12]}",
        "",
        "Package versions: " + ", ".join(f"{k} {val}" for k, val in v.items()),
    ]
    _text(fig, 0.07, 0.90, _wrap("\n".join(lines), 95), fontsize=8)
    fig.text(
        0.07, 0.74, "Resolved configuration (resolved_config.toml; SI units, unit in each key)", fontsize=9
    )
    toml = config.to_toml().split("\n", 1)[1].strip("\n")
    col = toml.split("\n\n")
    half = (len(col) + 1) // 2
    _text(fig, 0.07, 0.72, "\n\n".join(col[:half]), fontsize=7)
    _text(fig, 0.52, 0.72, "\n\n".join(col[half:]), fontsize=7)
    note = (
        "Spec: ../shared/spec/MODEL.md. alpha: rotation of the stapes head relative to the lenticular "
        "plate (the joint); beta: rotation of the plate relative to the incus (the pedicle), spec 2.4. "
        "FE: P2 tetrahedra, graded towards the singular edges; on the default mesh alpha and beta are "
        "about 2.5 % below their mesh-converged values. Lumped: the calibrated beam-and-spring model "
        "(lumped/). Every number in this report is also in data/ as JSON or CSV."
    )
    _text(fig, 0.07, 0.16, _wrap(note, 100), fontsize=7.5)


def model_page(fig, model: dict, arrays: dict):
    names = tuple(model["region_names"])
    ax = fig.add_axes([0.02, 0.50, 0.55, 0.42], projection="3d")
    figures.mesh_by_region(ax, arrays["points_m"], arrays["triangles"], arrays["triangle_region"], names)
    ax.set_title("mesh by region (half model, y < 0)", fontsize=9)
    figures.region_legend(
        fig.add_axes([0.58, 0.78, 0.12, 0.12], frameon=False, xticks=[], yticks=[], label="legend"), names
    )
    ax = fig.add_axes([0.02, 0.06, 0.55, 0.42], projection="3d")
    u = arrays["displacement_m"]
    p = arrays["points_m"]
    scale = 0.08 * np.ptp(p[:, 2]) / np.abs(u).max()
    coll = figures.mesh_by_region(
        ax, p, arrays["triangles"], arrays["triangle_region"], names, displacement_m=u, scale=scale
    )
    base = model["base"]
    ax.set_title(f"deformed, displacements x {scale:.3g}; colour |u| (nm)", fontsize=9)
    fig.colorbar(coll, ax=ax, shrink=0.5, pad=0.1).ax.tick_params(labelsize=6)
    q = model["quality"]
    lines = [
        f"P{model['order']} tetrahedra, resolution {model['resolution']:g}",
        f"{model['n_tets']} tets, {q['n_nodes']} vertices, {model['n_dofs']} dofs",
        "",
        "tets per region:",
        *[f"  {r:8s} {n:7d}" for r, n in q["tets_per_region"].items()],
        "",
        f"min dihedral angle  {q['min_dihedral_deg']:.1f} deg",
        f"max dihedral angle  {q['max_dihedral_deg']:.1f} deg",
        f"worst aspect ratio  {q['max_aspect_ratio']:.2f}",
        f"mean aspect ratio   {q['mean_aspect_ratio']:.3f}",
        "",
        f"base design at {base['pressure_pa']:g} Pa:",
        f"  alpha      {urad(base['alpha_rad'])} urad",
        f"  beta       {urad(base['beta_rad'])} urad",
        f"  beta/alpha {ratio(base['beta_over_alpha'])}",
        f"  max |u|    {base['max_disp_m'] * 1e9:.3f} nm",
        "",
        f"mesh hash {model['mesh_hash'][:16]}",
    ]
    _text(fig, 0.62, 0.74, "\n".join(lines), fontsize=7.5)


def cases_page(fig, cases: dict, model: dict):
    rows = cases["rows"]
    head = (
        f"{'case':6} {'E_ped':>6} {'E_gap':>6} {'E_cap':>6} | {'alpha':>8} {'beta':>8} {'a+b':>8} "
        f"{'b/a':>6} | {'alpha':>8} {'beta':>8} {'a+b':>8} {'b/a':>6}"
    )
    unit = f"{'':6} {'GPa':>6} {'MPa':>6} {'MPa':>6} | {'FE, urad':^33} | {'lumped, urad':^33}"
    lines = [unit, head, "-" * len(head)]
    for r in rows:
        f, lu = r["fe"], r["lumped"]
        lines.append(
            f"{r['case']:6} {r['pedicle_e_pa'] / 1e9:6.3g} {r['gap_e_pa'] / 1e6:6.3g} "
            f"{r['capsule_e_pa'] / 1e6:6.3g}"
            f" | {urad(f['alpha_rad']):>8} {urad(f['beta_rad']):>8} {urad(f['alpha_plus_beta_rad']):>8} "
            f"{ratio(f['beta_over_alpha']):>6} | {urad(lu['alpha_rad']):>8} {urad(lu['beta_rad']):>8} "
            f"{urad(lu['alpha_plus_beta_rad']):>8} {ratio(lu['beta_over_alpha']):>6}"
        )
    t = cases["thesis_base"]
    lines += [
        "-" * len(head),
        f"{'thesis':6} {5:6.3g} {10:6.3g} {50:6.3g} | {urad(t['alpha_rad']):>8} {urad(t['beta_rad']):>8} "
        f"{urad(t['alpha_plus_beta_rad']):>8} {ratio(t['beta_over_alpha']):>6} |"
        "   (base case, thesis Table 7.2)",
    ]
    _text(fig, 0.05, 0.91, "\n".join(lines), fontsize=7.2)
    head2 = f"{'case':6} | {'d alpha %':>9} {'d beta %':>9} {'d(a+b) %':>9} {'d(b/a) %':>9} | trend as FE"
    lines2 = ["lumped / FE - 1:", head2, "-" * len(head2)]
    for r in rows:
        d = r["rel_diff"]
        agree = cases["trend_agrees"].get(r["case"])
        mark = (
            "-"
            if agree is None
            else ("yes" if all(agree.values()) else "NO: " + ",".join(k for k, v in agree.items() if not v))
        )
        lines2.append(
            f"{r['case']:6} | {pct(d['alpha_rad']):>9} {pct(d['beta_rad']):>9} "
            f"{pct(d['alpha_plus_beta_rad']):>9} {pct(d['beta_over_alpha']):>9} | {mark}"
        )
    _text(fig, 0.05, 0.70, "\n".join(lines2), fontsize=7.2)
    base = rows[0]["fe"]
    note = (
        f"The pressure ({model['base']['pressure_pa']:g} Pa on the incus) was set once so that the "
        "mesh-converged "
        f"alpha + beta of the base case equals the thesis's {urad(t['alpha_plus_beta_rad'])} urad; the other "
        "six cases are predictions. FE here is the default mesh (about 2.5 % below converged). "
        f"FE beta/alpha of the base case: {ratio(base['beta_over_alpha'])} "
        f"(thesis {ratio(t['beta_over_alpha'])}: "
        "a coarse P1 mesh, which locks in bending). A trend agrees when FE and lumped change in the same "
        "direction from the base case (FE changes under 1 % count as agreeing)."
    )
    _text(fig, 0.05, 0.555, _wrap(note, 105), fontsize=7)
    for i, (key, lab) in enumerate((("alpha_rad", "alpha (urad)"), ("beta_rad", "beta (urad)"))):
        ax = fig.add_axes([0.09 + 0.46 * i, 0.08, 0.38, 0.36])
        figures.case_bars(ax, rows, key, 1e6, lab)
        if i == 0:
            ax.legend(fontsize=7)


def trends_page(fig, trends: dict, arrays: dict, design: dict, moduli: tuple[str, ...]):
    names = [m for m in moduli if m in trends]  # config order (the JSON's keys are sorted)
    outs = (
        ("alpha_rad", "alpha (urad)", 1e6),
        ("beta_rad", "beta (urad)", 1e6),
        ("ratio", "beta/alpha", 1.0),
    )
    top, bottom = 0.90, 0.27
    h = (top - bottom) / max(len(names), 1)
    for i, name in enumerate(names):
        x = arrays[f"{name}_x"]
        a, b = arrays[f"{name}_alpha_rad"], arrays[f"{name}_beta_rad"]
        pts = trends[name]["fe_points"]
        fx = [p["value_pa"] for p in pts]
        for j, (key, lab, sc) in enumerate(outs):
            ax = fig.add_axes([0.08 + 0.31 * j, top - (i + 1) * h + 0.045, 0.24, h - 0.075])
            y = b / a if key == "ratio" else (a if key == "alpha_rad" else b)
            fy = [p["fe"]["beta_over_alpha"] if key == "ratio" else p["fe"][key] for p in pts]
            figures.trend(ax, x, y, fx, fy, name, lab, sc, base_pa=design.get(name))
            if i == 0 and j == 0:
                ax.legend(fontsize=6)
    lines = ["FE points (in brackets: lumped / FE - 1, %):"]
    for name in names:
        for p in trends[name]["fe_points"]:
            ea = p["lumped"]["alpha_rad"] / p["fe"]["alpha_rad"] - 1
            eb = p["lumped"]["beta_rad"] / p["fe"]["beta_rad"] - 1
            lines.append(
                f"  {name:13} {p['value_pa']:9.3g} Pa: alpha {urad(p['fe']['alpha_rad'])} urad ({pct(ea)}), "
                f"beta {urad(p['fe']['beta_rad'])} urad ({pct(eb)})"
            )
    _text(fig, 0.07, 0.215, "\n".join(lines), fontsize=6.5)
    fig.text(
        0.07, 0.925, _wrap(
            "One modulus varied over the calibrated domain, the others at the base design (dotted line). "
            "Curves: lumped model; circles: FE. Every y axis spans at least 10 % of its mean, so a flat "
            "curve means the output hardly depends on that modulus.", 120
        ), fontsize=7.5, va="top",
    )  # fmt: skip


def energy_page(fig, cases: dict):
    rows = cases["rows"]
    ax = fig.add_axes([0.12, 0.55, 0.8, 0.33])
    figures.energy_bars(ax, rows)
    head = f"{'case':6} " + " ".join(f"{r:>8}" for r in REGIONS) + f" {'total fJ':>9}"
    lines = ["share of the strain energy (%), FE", head, "-" * len(head)]
    for r in rows:
        tot = sum(r["strain_energy_j"].values())
        lines.append(
            f"{r['case']:6} "
            + " ".join(f"{100 * r['strain_energy_j'][g] / tot:8.2f}" for g in REGIONS)
            + f" {tot * 1e15:9.4f}"
        )
    _text(fig, 0.08, 0.47, "\n".join(lines), fontsize=7.5)

    def shares(r):
        e = r["strain_energy_j"]
        return {g: 100 * v / sum(e.values()) for g, v in e.items()}

    base = shares(rows[0])
    joint = {r["case"]: shares(r)["gap"] + shares(r)["capsule"] for r in rows}
    more_joint = [c for c, v in joint.items() if v > joint[rows[0]["case"]] + 0.5]
    note = (
        "Where the compliance sits: the work done by the load is stored as strain energy, and a region's "
        "share says how much of the motion between incus and stapes it allows. In the base case the pedicle "
        f"holds {base['pedicle']:.1f} %, the lenticular plate {base['plate']:.1f} %"
        f", the joint (gap + capsule) {base['gap'] + base['capsule']:.1f} %, the stapes head "
        f"and the incus {base['stapes'] + base['incus']:.1f} %. "
        "The joint's share rises above the base case's "
        f"in {', '.join(more_joint) or 'no case'}: "
        + ", ".join(f"{c} {v:.1f} %" for c, v in joint.items())
        + "."
    )
    _text(fig, 0.08, 0.30, _wrap(note, 100), fontsize=7.5)


def convergence_page(fig, conv: dict):
    studies = conv["studies"]
    dirs = sorted({s["direction"] for s in studies})
    for i, d in enumerate(dirs):
        ax = fig.add_axes([0.1 + 0.45 * i, 0.56, 0.37, 0.33])
        figures.convergence(ax, studies, d)
    head = (
        f"{'order':5} {'load':4} {'tets':>7} {'dofs':>7} {'max |u| nm':>11} {'Timoshenko nm':>13} "
        f"{'error %':>8}"
    )
    lines = [head, "-" * len(head)]
    for s in studies:
        for r in s["rows"]:
            lines.append(
                f"P{s['order']:<4} {s['direction']:4} {r['n_tets']:7d} {r['n_dofs']:7d} "
                f"{r['max_disp_m'] * 1e9:11.4f} "
                f"{r['analytic_m'] * 1e9:13.4f} {pct(r['rel_error']):>8}"
            )
    _text(fig, 0.08, 0.48, "\n".join(lines), fontsize=7)
    note = (
        "The pedicle alone as a cantilever (spec 2.6): one end clamped, a 1 uN shear force on the other. "
        "P1 tetrahedra lock in bending and converge slowly; P2 converge fast. With nu = 0.3 the 3-D solution "
        "settles a few per cent from Timoshenko's beam value, because the clamp also stops the Poisson "
        "contraction of a short beam (L/h = 1.5 in y); with nu = 0 the mean tip deflection matches within "
        "0.3 % (tests/test_verification.py). The maximum |u| also carries the warping of the loaded end "
        "section, which beam theory averages out: the mean tip deflection is the beam's quantity."
    )
    _text(fig, 0.08, 0.10 + 0.012 * max(0, 30 - len(lines)), _wrap(note, 100), fontsize=7.5)


def calibration_page(fig, cal: dict):
    pts = cal["points"]
    if pts:
        for i, (key, lab) in enumerate((("alpha_rad", "alpha (urad)"), ("beta_rad", "beta (urad)"))):
            ax = fig.add_axes([0.11 + 0.31 * i, 0.68, 0.22, 0.22])
            figures.parity(ax, [p["fe"][key] for p in pts], [p["lumped"][key] for p in pts], lab, 1e6)
        ax = fig.add_axes([0.74, 0.68, 0.21, 0.20])
        errs = {
            k: [p["lumped"][k] / p["fe"][k] - 1 for p in pts]
            for k in ("alpha_rad", "beta_rad", "beta_over_alpha")
        }
        figures.error_hist(ax, errs)
        pairs = (("pedicle_e_pa", "gap_e_pa"), ("capsule_e_pa", "gap_e_pa"), ("plate_e_pa", "stapes_e_pa"))
        for i, (x, y) in enumerate(pairs):
            ax = fig.add_axes([0.11 + 0.31 * i, 0.43, 0.22, 0.17])
            figures.domain_points(ax, pts, cal["domain"], x, y)
        fig.text(0.07, 0.62, "the fresh check designs in the calibrated domain (box)", fontsize=8)
    c = cal["check"]
    t, v = cal["training"], cal["validation"]
    fs = cal["fe_settings"]
    lines = [
        f"calibration: {cal['source']}; trained on FE P{fs.get('order')}, resolution {fs.get('resolution')}, "
        f"{fs.get('pressure_pa')} Pa"
    ]
    rm = cal.get("report_mesh", {})
    if rm and (rm.get("order") != fs.get("order") or rm.get("resolution") != fs.get("resolution")):
        lines.append(
            f"NOTE: this report's FE mesh (P{rm['order']}, resolution {rm['resolution']}) is not the one the "
            "calibration was fitted on: the check's errors below include that mesh difference."
        )
    if c["n"]:
        lines.append(
            f"fresh check on {c['n']} FE designs (Sobol, seed {c['seed']}): "
            f"max |error| alpha {pct(c['max_abs_alpha_rad'])} %, "
            f"beta {pct(c['max_abs_beta_rad'])} %, beta/alpha {pct(c['max_abs_beta_over_alpha'])} %"
        )
        lines.append(
            f"  RMS alpha {100 * c['rms_alpha_rad']:.2f} %, beta {100 * c['rms_beta_rad']:.2f} %, "
            f"beta/alpha {100 * c['rms_beta_over_alpha']:.2f} %"
        )
        beyond = {k: sum(abs(e) > 0.03 for e in errs[k]) for k in errs}
        lines.append(
            "  beyond the 3 % guard tolerance of isj explore: "
            + ", ".join(f"{k} {n}/{c['n']}" for k, n in beyond.items())
        )
    if t:
        lines.append(
            f"recorded at fitting: training n = {t.get('n')}: max alpha {100 * t['max_alpha']:.2f} %, "
            f"beta {100 * t['max_beta']:.2f} %"
        )
    if v:
        lines.append(
            f"  validation n = {v.get('n')}: max alpha {100 * v['max_alpha']:.2f} %, "
            f"beta {100 * v['max_beta']:.2f} %, "
            f"beta/alpha {100 * v['max_ratio']:.2f} %"
        )
    lines += ["", f"{'calibrated domain (Pa)':40}fitted factors (dimensionless)"]
    dom = [f"  {k:13} {lo:9.3g} .. {hi:9.3g}" for k, (lo, hi) in cal["domain"].items()]
    fac = [f"  {k:18} {val:.4g}" for k, val in cal["factors"].items()]
    for i in range(max(len(dom), len(fac))):
        lines.append(f"{dom[i] if i < len(dom) else '':40}{fac[i] if i < len(fac) else ''}")
    _text(fig, 0.07, 0.36, _wrap("\n".join(lines), 118), fontsize=6.8)


def sweep_page(fig, sweep: dict, arrays: dict):
    from isj.lumped.plots import bode

    freq = arrays["freq_hz"]
    outs = ("alpha_rad", "beta_rad")
    H = np.column_stack([arrays[f"{k}_re"] + 1j * arrays[f"{k}_im"] for k in outs])
    checks = []
    for c in sweep["fe_checks"]:
        row = {"freq_hz": c["freq_hz"]}
        for k in outs:
            mag, ph = c[k]["fe_abs"], np.radians(c[k]["fe_phase_deg"])
            row[f"fe_{k}"] = [mag * np.cos(ph), mag * np.sin(ph)]
        checks.append(row)
    ax_mag = fig.add_axes([0.12, 0.66, 0.8, 0.24])
    ax_ph = fig.add_axes([0.12, 0.47, 0.8, 0.16], sharex=ax_mag)
    bode(freq, H, checks, outs, axes=(ax_mag, ax_ph))
    for f in sweep["fe_in_plane_modes_hz"]:
        if freq[0] <= f <= freq[-1]:
            for ax in (ax_mag, ax_ph):
                ax.axvline(f, color="k", ls=":", lw=0.7)
    d = sweep["damping"]
    ax_mag.set_title(
        f"base design; Rayleigh a = {d['rayleigh_a_per_s']:g} 1/s, b = {d['rayleigh_b_s']:g} s; loss factor "
        f"{d['loss_factor']:g}; dotted: FE in-plane modes",
        fontsize=8,
    )
    lines = ["FE harmonic spot checks (lumped / FE):"]
    for c in sweep["fe_checks"]:
        lines.append(
            f"  {c['freq_hz']:9.1f} Hz: |alpha| FE {urad(c['alpha_rad']['fe_abs'])} urad, error "
            f"{100 * c['alpha_rad']['rel_error']:.2f} %; |beta| FE {urad(c['beta_rad']['fe_abs'])} urad, "
            f"error {100 * c['beta_rad']['rel_error']:.2f} %"
        )
    lines += ["", "natural frequencies (Hz)", f"  {'mode':5} {'FE':>10} {'y/x':>8}  in-plane   lumped chain"]
    inplane = sweep["fe_in_plane_modes_hz"]
    lum = sweep["lumped_natural_freq_hz"]
    k = 0
    for i, (f, yx) in enumerate(zip(sweep["fe_modes_hz"], sweep["fe_mode_y_to_x"], strict=True)):
        ip = f in inplane
        lum_txt = f"{lum[k]:10.0f} ({pct(lum[k] / f - 1)} %)" if ip and k < len(lum) else ""
        k += ip
        lines.append(f"  {i + 1:<5} {f:10.0f} {yx:8.3g}  {'yes' if ip else 'no ':8}  {lum_txt}")
    zeta = sweep["lumped_damping_ratio"]
    over = [i + 1 for i, z in enumerate(zeta) if z >= 1]
    lines += [
        "  y/x: the mode's out-of-plane (y) motion over its in-plane (x) motion; the pressure (along x)",
        "  drives the in-plane modes, which the lumped chain (eight degrees of freedom) represents.",
        "",
        f"lumped damping ratios: {', '.join(f'{z:.3g}' for z in zeta)}"
        + (f" (mode {', '.join(map(str, over))} overdamped with this damping)" if over else ""),
    ]
    if len(lum) > 1 and len(inplane) > 1 and abs(lum[1] / inplane[1] - 1) > 0.05:
        lines.append(
            "The chain's second natural frequency misses the FE model's second in-plane mode by more "
            "than 5 % here (outside the calibrated design space?). Trust the lumped curves below about "
            "0.8 x the first FE resonance, where the FE spot checks hold."
        )
    _text(fig, 0.07, 0.40, _wrap("\n".join(lines), 110), fontsize=7)


def ear_page(fig, ear: dict, arrays: dict, cases: dict):
    ax = fig.add_axes([0.02, 0.52, 0.80, 0.38], projection="3d")
    drum = figures.ear_picture(ax, arrays)[0]
    ax.set_title("eardrum |u| per Pa (nm/Pa), base case; ossicular chain and footplate", fontsize=8)
    cb = fig.colorbar(drum, cax=fig.add_axes([0.86, 0.62, 0.015, 0.22], label="<colorbar>"))
    cb.ax.tick_params(labelsize=6)
    cb.set_label("nm/Pa", fontsize=7)
    exp = ear["experiment"]
    nm = 1e9
    head = f"{'per Pa of ear-canal pressure':30} {'joint model':>12} {'rigid joint':>12} {'experiment':>12}"
    by_case = {c["case"]: c for c in ear["cases"]}
    b, r = ear["cases"][0], ear["rigid_joint"]
    s_lo, s_hi = exp["stapes_m_per_pa"]
    rows = [
        ("umbo |u| (nm/Pa)", b["umbo_m_per_pa"], r["umbo_m_per_pa"], f"{exp['umbo_m_per_pa'] * nm:.0f}"),
        ("eardrum max |u| (nm/Pa)", b["eardrum_max_m_per_pa"], r["eardrum_max_m_per_pa"], "-"),
        ("footplate piston (nm/Pa)", b["footplate_piston_m_per_pa"], r["footplate_piston_m_per_pa"],
         f"{s_lo * nm:.0f}-{s_hi * nm:.0f}"),
    ]  # fmt: skip
    lines = [head, "-" * len(head)]
    lines += [f"{n:30} {v1 * nm:12.2f} {v2 * nm:12.2f} {e:>12}" for n, v1, v2, e in rows]
    for i, comp in enumerate("xyz"):
        lines.append(
            f"{'footplate centre u_' + comp + ' (nm/Pa)':30} {b['footplate_m_per_pa'][i] * nm:12.3f} "
            f"{r['footplate_m_per_pa'][i] * nm:12.3f} {'-':>12}"
        )
    ax_ = b["rotation_axis"]
    lines += [
        "",
        "malleus-incus axis of rotation: through "
        f"({', '.join(f'{v * 1e3:.2f}' for v in ax_['point_m'])}) mm, "
        f"direction ({', '.join(f'{v:.3f}' for v in ax_['direction'])})",
        f"lever ratio (umbo / stapes head about the nominal axis) {ear['lever_ratio']:.2f}; "
        f"{ear['n_dofs']} dofs with the joint model, {ear['n_dofs_rigid_joint']} with a rigid joint",
        f"experiment: {exp['source']}",
    ]
    _text(fig, 0.07, 0.52, "\n".join(lines), fontsize=7)
    iso = {row["case"]: row["fe"] for row in cases["rows"]}
    lines2 = [
        f"{'':6}   {'inside the ear, per Pa':^26}   {'isolated':^8}",
        f"{'case':6} | {'alpha urad':>10} {'beta urad':>10} {'b/a':>6} | {'b/a':>6}",
        "-" * 47,
    ]
    for c in ear["cases"]:
        a, bb, name = c["alpha_rad_per_pa"], c["beta_rad_per_pa"], c["case"]
        lines2.append(
            f"{name:6} | {urad(a):>10} {urad(bb):>10} {ratio(bb / a):>6} | "
            f"{ratio(iso[name]['beta_over_alpha']):>6}"
        )
    base_b = ear["cases"][0]
    spl = ear["spl_100db_peak_pa"]
    lines2 += [
        "",
        f"At 100 dB SPL ({spl:g} Pa peak) the base case gives "
        f"alpha {urad(base_b['alpha_rad_per_pa'] * spl)} urad "
        f"and beta {urad(base_b['beta_rad_per_pa'] * spl)} urad.",
    ]
    _text(fig, 0.07, 0.33, "\n".join(lines2), fontsize=7)
    m = ear["ear_materials"]

    def spread(values):
        return f"{100 * (min(values) / values[0] - 1):+.0f} % to {100 * (max(values) / values[0] - 1):+.0f} %"

    names = list(by_case)
    beta_ear = [by_case[n]["beta_rad_per_pa"] for n in names]
    beta_iso = [iso[n]["beta_rad"] for n in names]
    note = (
        "The whole ear (spec 5): the pars tensa as a flat-facet shell "
        f"(E = {m['drum_e_pa'] / 1e6:g} MPa, {m['drum_thickness_m'] * 1e6:g} um), clamped at the ring; "
        "malleus and incus as one rigid body on the anterior mallear and posterior incudal ligament "
        "springs; the stapes footplate as a shell with a thick rim on 40 annular-ligament and "
        "cochlear-load springs, its superstructure rigid and tied to the whole inner rim; the 3-D joint "
        "model between the long process and the stapes head, tied without penalties. "
        "All anatomical positions are estimates (isj/ear.py); the thesis's own whole-ear displacements are "
        "not in the spec, so they are not shown. Across the seven cases beta changes by "
        f"{spread(beta_ear)} from the base case inside the ear, against {spread(beta_iso)} in the isolated "
        "model, which is loaded by a fixed pressure on the incus."
    )
    _text(fig, 0.07, 0.12, _wrap(note, 110), fontsize=7)


def build_pages(config, results: dict, arrays: dict, provenance: dict):
    """Yield ``(title, figure)`` for each page; the caller saves and closes the figures."""
    total = len(PAGE_TITLES)
    footer = (
        f"isj {provenance['versions'].get('isj', '?')} ({provenance.get('git_revision') or 'no git'}), "
        f"{provenance['date']}; data behind every figure: data/*.json, data/*.csv"
    )
    builders = (
        lambda f: title_page(f, config, provenance, results["model"]),
        lambda f: model_page(f, results["model"], arrays["model"]),
        lambda f: cases_page(f, results["cases"], results["model"]),
        lambda f: trends_page(
            f, results["trends"], arrays["trends"], config.design.moduli(), config.trends.moduli
        ),
        lambda f: energy_page(f, results["cases"]),
        lambda f: convergence_page(f, results["convergence"]),
        lambda f: calibration_page(f, results["calibration"]),
        lambda f: sweep_page(f, results["sweep"], arrays["sweep"]),
        lambda f: ear_page(f, results["ear"], arrays["ear"], results["cases"]),
    )
    for i, (title, build) in enumerate(zip(PAGE_TITLES, builders, strict=True), 1):
        fig = _page(title, i, total, footer)
        build(fig)
        yield title, fig


def write_report(path, config, results: dict, arrays: dict, provenance: dict) -> list[str]:
    """Write the PDF atomically; returns the page titles."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    from isj.atomic import atomic_write

    titles = []

    def write(tmp):
        # no creation date: the same inputs give the same bytes
        with PdfPages(tmp, metadata={"CreationDate": None, "Title": "isj report"}) as pdf:
            for title, fig in build_pages(config, results, arrays, provenance):
                pdf.savefig(fig)
                plt.close(fig)
                titles.append(title)

    atomic_write(path, write)
    return titles
