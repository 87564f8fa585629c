"""The report's later pages: mesh convergence, calibration, frequency response, the whole ear."""

from __future__ import annotations

import numpy as np

from . import figures
from .geometry import draw_geometry_domain
from .layout import pct, ratio, text_block, urad, wrap


def damping_caption(sweep: dict) -> str:
    """The joint model's damping in a few words: its preset, loss factors and Rayleigh terms by value."""
    from isj.design import REGIONS

    d = sweep["damping"]
    parts = []
    for key, label, unit in (
        ("loss_factor", "eta", ""),
        ("rayleigh_a_per_s", "a", " 1/s"),
        ("rayleigh_b_s", "b", " s"),
    ):
        by_value: dict[float, list[str]] = {}
        for r in REGIONS:
            by_value.setdefault(d[key][r], []).append(r)
        if set(by_value) != {0.0}:
            parts.append(", ".join(f"{label} = {v:g}{unit} ({' '.join(rs)})" for v, rs in by_value.items()))
    preset = sweep.get("damping_preset", "")
    return (f"{preset}: " if preset else "") + ("; ".join(parts) or "none")


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
    text_block(fig, 0.08, 0.48, "\n".join(lines), fontsize=7)
    note = (
        "The pedicle alone as a cantilever (docs/model.md §2.6): one end clamped, a 1 uN shear force "
        "on the other. "
        "P1 tetrahedra lock in bending and converge slowly; P2 converge fast. With nu = 0.3 the 3-D solution "
        "settles a few per cent from Timoshenko's beam value, because the clamp also stops the Poisson "
        "contraction of a short beam (L/h = 1.5 in y); with nu = 0 the mean tip deflection matches within "
        "0.3 % (tests/test_verification.py). The maximum |u| also carries the warping of the loaded end "
        "section, which beam theory averages out: the mean tip deflection is the beam's quantity."
    )
    text_block(fig, 0.08, 0.10 + 0.012 * max(0, 30 - len(lines)), wrap(note, 100), fontsize=7.5)


def calibration_page(fig, cal: dict, design_geometry: dict | None = None):
    """The calibration's check and record; with ``cal["geometry"]``, the geometry calibration's
    domain (``design_geometry``: the report's dimensions, m, marked against it)."""
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
    head = text_block(fig, 0.07, 0.36, wrap("\n".join(lines), 118), fontsize=6.8)
    # the tables below the head, whose height depends on its wrapped lines
    top = head.get_window_extent(fig.canvas.get_renderer()).transformed(fig.transFigure.inverted()).y0 - 0.012
    table = [f"{'calibrated domain (Pa)':40}fitted factors (dimensionless)"]
    dom = [f"  {k:13} {lo:9.3g} .. {hi:9.3g}" for k, (lo, hi) in cal["domain"].items()]
    fac = [f"  {k:18} {val:.4g}" for k, val in cal["factors"].items()]
    for i in range(max(len(dom), len(fac))):
        table.append(f"{dom[i] if i < len(dom) else '':40}{fac[i] if i < len(fac) else ''}")
    text_block(fig, 0.07, top, "\n".join(table), fontsize=6.8)
    if cal.get("geometry"):  # beside the factors
        draw_geometry_domain(fig, cal["geometry"], design_geometry or {}, top)


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
    ax_mag.set_title(
        f"base design; damping {damping_caption(sweep)}; dotted: FE in-plane modes", fontsize=8, wrap=True
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
    text_block(fig, 0.07, 0.40, wrap("\n".join(lines), 110), fontsize=7)


def ear_page(fig, ear: dict, arrays: dict, cases: dict):
    """The whole ear: its picture, its static response beside the experiment, the seven cases'
    α and β inside it beside the isolated model's, and what the model is."""
    ax = fig.add_axes([0.02, 0.52, 0.80, 0.38], projection="3d")
    drum = figures.ear_picture(ax, arrays)[0]
    ax.set_title("eardrum |u| per Pa (nm/Pa), base case; ossicular chain and footplate", fontsize=8)
    cb = fig.colorbar(drum, cax=fig.add_axes([0.86, 0.62, 0.015, 0.22], label="<colorbar>"))
    cb.ax.tick_params(labelsize=6)
    cb.set_label("nm/Pa", fontsize=7)
    iso = {row["case"]: row["fe"] for row in cases["rows"]}
    text_block(fig, 0.07, 0.52, "\n".join(_ear_response_lines(ear)), fontsize=7)
    text_block(fig, 0.07, 0.33, "\n".join(_ear_case_lines(ear, iso)), fontsize=7)
    text_block(fig, 0.07, 0.12, wrap(_ear_note(ear, iso), 110), fontsize=7)


def _ear_response_lines(ear: dict) -> list[str]:
    """The base case's and the rigid joint's static response per Pa beside the experiment; the
    axis of rotation, the lever ratio and the model's size."""
    exp = ear["experiment"]
    nm = 1e9
    head = f"{'per Pa of ear-canal pressure':30} {'joint model':>12} {'rigid joint':>12} {'experiment':>12}"
    b, r = ear["cases"][0], ear["rigid_joint"]
    s_lo, s_hi = exp["stapes_m_per_pa"]
    rows = [
        ("umbo |u| (nm/Pa)", b["umbo_m_per_pa"], r["umbo_m_per_pa"], f"{exp['umbo_m_per_pa'] * nm:.0f}"),
        ("eardrum max |u| (nm/Pa)", b["eardrum_max_m_per_pa"], r["eardrum_max_m_per_pa"], "-"),
        (
            "footplate piston (nm/Pa)",
            b["footplate_piston_m_per_pa"],
            r["footplate_piston_m_per_pa"],
            f"{s_lo * nm:.0f}-{s_hi * nm:.0f}",
        ),
    ]
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
    return lines


def _ear_case_lines(ear: dict, iso: dict) -> list[str]:
    """α, β and β/α of each case inside the ear beside β/α of the isolated model, and the base
    case at 100 dB SPL."""
    lines = [
        f"{'':6}   {'inside the ear, per Pa':^26}   {'isolated':^8}",
        f"{'case':6} | {'alpha urad':>10} {'beta urad':>10} {'b/a':>6} | {'b/a':>6}",
        "-" * 47,
    ]
    for c in ear["cases"]:
        a, bb, name = c["alpha_rad_per_pa"], c["beta_rad_per_pa"], c["case"]
        lines.append(
            f"{name:6} | {urad(a):>10} {urad(bb):>10} {ratio(bb / a):>6} | "
            f"{ratio(iso[name]['beta_over_alpha']):>6}"
        )
    base_b = ear["cases"][0]
    spl = ear["spl_100db_peak_pa"]
    lines += [
        "",
        f"At 100 dB SPL ({spl:g} Pa peak) the base case gives "
        f"alpha {urad(base_b['alpha_rad_per_pa'] * spl)} urad "
        f"and beta {urad(base_b['beta_rad_per_pa'] * spl)} urad.",
    ]
    return lines


def _ear_note(ear: dict, iso: dict) -> str:
    """What the whole-ear model is, and how far β moves across the cases inside it and isolated."""
    m = ear["ear_materials"]

    def spread(values):
        return f"{100 * (min(values) / values[0] - 1):+.0f} % to {100 * (max(values) / values[0] - 1):+.0f} %"

    by_case = {c["case"]: c for c in ear["cases"]}
    names = list(by_case)
    beta_ear = [by_case[n]["beta_rad_per_pa"] for n in names]
    beta_iso = [iso[n]["beta_rad"] for n in names]
    return (
        "The whole ear (docs/ear.md §5): the pars tensa as a flat-facet shell "
        f"(E = {m['drum_e_pa'] / 1e6:g} MPa, {m['drum_thickness_m'] * 1e6:g} um), clamped at the ring; "
        "malleus and incus as one rigid body on the anterior mallear and posterior incudal ligament "
        "springs; the stapes footplate as a shell with a thick rim on 40 annular-ligament and "
        "cochlear-load springs, its superstructure rigid and tied to the whole inner rim; the 3-D joint "
        "model between the long process and the stapes head, tied without penalties. "
        "All anatomical positions are estimates (isj/ear.py); the thesis's own whole-ear displacements are "
        "not available to isj, so they are not shown. Across the seven cases beta changes by "
        f"{spread(beta_ear)} from the base case inside the ear, against {spread(beta_iso)} in the isolated "
        "model, which is loaded by a fixed pressure on the incus."
    )
