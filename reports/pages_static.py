"""The report's first pages: title, the model, the seven cases, trends, strain energy."""

from __future__ import annotations

import numpy as np

from isj.design import REGIONS

from . import figures
from .geometry import geometry_trend_lines, geometry_trend_panels
from .layout import pct, ratio, text_block, urad, wrap


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
    text_block(fig, 0.07, 0.90, wrap("\n".join(lines), 95), fontsize=8)
    fig.text(
        0.07, 0.74, "Resolved configuration (resolved_config.toml; SI units, unit in each key)", fontsize=9
    )
    toml = config.to_toml().split("\n", 1)[1].strip("\n")
    col = toml.split("\n\n")
    half = (len(col) + 1) // 2
    text_block(fig, 0.07, 0.72, "\n\n".join(col[:half]), fontsize=7)
    text_block(fig, 0.52, 0.72, "\n\n".join(col[half:]), fontsize=7)
    note = (
        "Definitions: docs/ in the isj repository. alpha: rotation of the stapes head relative to "
        "the lenticular plate (the joint); beta: rotation of the plate relative to the incus (the pedicle), "
        "docs/model.md §2.4. "
        "FE: P2 tetrahedra, graded towards the singular edges; on the default mesh alpha and beta are "
        "about 2.5 % below their mesh-converged values. Lumped: the calibrated beam-and-spring model "
        "(lumped/). Every number in this report is also in data/ as JSON or CSV."
    )
    text_block(fig, 0.07, 0.16, wrap(note, 100), fontsize=7.5)


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
    text_block(fig, 0.62, 0.74, "\n".join(lines), fontsize=7.5)


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
    text_block(fig, 0.05, 0.91, "\n".join(lines), fontsize=7.2)
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
    text_block(fig, 0.05, 0.70, "\n".join(lines2), fontsize=7.2)
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
    text_block(fig, 0.05, 0.555, wrap(note, 105), fontsize=7)
    for i, (key, lab) in enumerate((("alpha_rad", "alpha (urad)"), ("beta_rad", "beta (urad)"))):
        ax = fig.add_axes([0.09 + 0.46 * i, 0.08, 0.38, 0.36])
        figures.case_bars(ax, rows, key, 1e6, lab)
        if i == 0:
            ax.legend(fontsize=7)


def trends_page(fig, trends: dict, arrays: dict, design: dict, moduli: tuple[str, ...], geometry=None):
    """The moduli's trends; with ``geometry`` ((result, arrays) of the geometry_trends step) a last
    row of β against the pedicle's thickness and α against the gap's (:mod:`reports.geometry`)."""
    names = [m for m in moduli if m in trends]  # config order (the JSON's keys are sorted)
    outs = (
        ("alpha_rad", "alpha (urad)", 1e6),
        ("beta_rad", "beta (urad)", 1e6),
        ("ratio", "beta/alpha", 1.0),
    )
    top, bottom = 0.90, (0.47 if geometry else 0.27)
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
    if geometry:
        geometry_trend_panels(fig, *geometry, y0=0.29, height=0.14)
        lines += geometry_trend_lines(geometry[0])
    text_block(fig, 0.07, 0.235 if geometry else 0.215, "\n".join(lines), fontsize=6.5)
    fig.text(
        0.07,
        0.925,
        wrap(
            "One modulus varied over the calibrated domain, the others at the base design (dotted line). "
            "Curves: lumped model; circles: FE. Every y axis spans at least 10 % of its mean, so a flat "
            "curve means the output hardly depends on that modulus. Last row: one dimension varied over "
            "the geometry calibration's range, log-log; dashed: the cubic law of the pedicle's bending "
            "through the FE point at the report's geometry.",
            120,
        ),
        fontsize=7.5,
        va="top",
    )


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
    text_block(fig, 0.08, 0.47, "\n".join(lines), fontsize=7.5)

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
    text_block(fig, 0.08, 0.30, wrap(note, 100), fontsize=7.5)
