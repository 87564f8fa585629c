"""The report's transmission pages (docs/transmission.md): H_V against the cat data, ΔH_V per case."""

from __future__ import annotations

import numpy as np

from .layout import text_block, wrap


def _db(x) -> np.ndarray:
    return 20 * np.log10(np.abs(x))


def _deg(x) -> np.ndarray:
    return np.degrees(np.unwrap(np.angle(x)))


def hv_page(fig, tr: dict, arrays: dict):
    """The whole ear's H_V and umbo velocity (fast ear and FE), the lumped ear beside it, the cat data."""
    f = arrays["freq_hz"]
    first = tr["cases"][0]
    ax_m = fig.add_axes([0.12, 0.70, 0.80, 0.21])
    ax_p = fig.add_axes([0.12, 0.55, 0.80, 0.12], sharex=ax_m)
    for name, style in ((first, "-"), ("rigid", "--")):
        for k, color, label in (
            ("stapes_velocity_m_s", "C0", "stapes H_V"),
            ("umbo_velocity_m_s", "C1", "umbo"),
        ):
            v = arrays[f"{name}_{k}"]
            ax_m.loglog(f, np.abs(v), style, color=color, lw=1, label=f"{label}, {name}")
            ax_p.semilogx(f, _deg(v), style, color=color, lw=1)
    for c in tr["fe_checks"].get("checks", []):
        s = c["direct_stapes_m"]
        w = 2 * np.pi * c["freq_hz"]
        ax_m.loglog([c["freq_hz"]], [w * np.hypot(*s)], "kx", ms=5)
    ax_m.set_ylabel("m/s per Pa", fontsize=7)
    ax_p.set_ylabel("phase (deg)", fontsize=7)
    ax_p.set_xlabel("frequency (Hz)", fontsize=7)
    ax_m.legend(fontsize=6, ncol=2)
    how = tr["fe_reductions"].get(first, {}).get("model", "fe")
    ax_m.set_title(
        f"whole ear, case {first} ({'fast ear' if how == 'fast' else 'FE reduced ear'}) and a rigid "
        "incus-stapes connection (FE reduced ear); x: direct FE checks",
        fontsize=8,
    )
    for ax in (ax_m, ax_p):
        ax.tick_params(labelsize=6)
        ax.grid(True, which="both", lw=0.3)
    ax_g = fig.add_axes([0.12, 0.36, 0.80, 0.14], sharex=ax_m)
    cat = [c for c in tr["cat"] if c["model"] == first]
    if cat:
        from isj.ear import EarGeometry

        v = arrays[f"{first}_stapes_velocity_m_s"]
        gain = tr["damping"]["cochlear_impedance_pa_s_m3"] * EarGeometry().footplate_area_m2 * v
        ax_g.semilogx(f, _db(gain), "C0", lw=1, label="model: Z_C A_fp H_V")
        ax_g.errorbar(
            [1000.0],
            [22.5],
            yerr=[[7.5], [7.5]],
            fmt="ks",
            ms=4,
            capsize=3,
            label="Nedzelnitsky 1980: maximum 15-30 dB near 1 kHz",
        )
        ax_g.legend(fontsize=6)
    ax_g.set_ylabel("vestibule / ear-canal\npressure (dB)", fontsize=7)
    ax_g.tick_params(labelsize=6)
    ax_g.grid(True, which="both", lw=0.3)
    chk = tr["fe_checks"]
    lines = fast_ear_lines(tr)
    if chk.get("checks"):
        what = "Fast ear" if chk.get("checked_model") == "fast" else "Reduction"
        lines.append(
            f"{what} checked against {len(chk['checks'])} direct FE harmonic solves (case {chk['case']}): "
            f"largest error {100 * chk['max_mag_rel_error']:.3f} % in magnitude, "
            f"{chk['max_phase_error_deg']:.3f} deg in phase ({'passed' if chk['passed'] else 'FAILED'})."
        )
    for c in cat:
        lines.append(
            f"Against {c['series']} ({c['model_quantity']}, model {c['model']}): deviation "
            + ", ".join(f"{d:+.1f} dB" for d in c["deviation_db"])
            + f" at {', '.join(f'{x:g} Hz' for x in c['freq_hz'])}; outside the stated range by "
            + ", ".join(f"{d:.1f} dB" for d in c["range_deviation_db"])
            + "."
        )
    lines += [
        "",
        "No cat H_V or umbo velocity series could be read for isj (Guinan & Peake 1967 and later "
        "papers: abstracts only, docs/measurements.md 9.5), so neither curve is overlaid on "
        "measured points; the one comparison with numbers is the vestibule pressure gain above, "
        "which needs the cochlear impedance (Lynch et al. 1982, an input of the model). Nothing is "
        "fitted to these data.",
    ]
    text_block(fig, 0.07, 0.31, wrap("\n".join(lines), 110), fontsize=7)


def fast_ear_lines(tr: dict) -> list[str]:
    """Which model gave each case, and the fast ear against the FE reductions (step's checks)."""
    models = {n: r.get("model", "fe") for n, r in tr["fe_reductions"].items()}
    fast = [n for n, m in models.items() if m == "fast"]
    fe = [n for n, m in models.items() if m == "fe"]
    lines = [f"Fast ear (docs/fast_ear.md): {', '.join(fast) or 'none'}; FE reduced ears: {', '.join(fe)}."]
    chk = tr["fe_checks"].get("fast_ear")
    if chk:
        parts = []
        for key, label in (("h_v", "H_V"), ("delta_h_v", "dH_V"), ("rigid_h_v", "rigid H_V")):
            if key not in chk:  # the first case's band check is optional ([transmission] fast_ear_check)
                continue
            a, b = chk[key]["to_10khz"], chk[key]["band"]
            parts.append(
                f"{label} {a['max_db']:.2g} dB / {a['max_deg']:.2g} deg to 10 kHz "
                f"({b['max_db']:.2g} dB / {b['max_deg']:.2g} deg over the band)"
            )
        tg = chk["targets_to_10khz"]
        against = (
            f"the FE reduced ears, rigid and case {chk['case']}"
            if "h_v" in chk
            else "the FE reduced rigid ear"
        )
        lines.append(
            f"Fast ear against {against}: largest difference "
            + "; ".join(parts)
            + f". Targets to 10 kHz: H_V {tg['h_v_db']} dB and {tg['h_v_deg']} deg, dH_V "
            f"{tg['delta_db']} dB and {tg['delta_deg']} deg."
        )
    return lines


def delta_page(fig, tr: dict, arrays: dict, lumped: dict, lumped_arrays: dict):
    """ΔH_V for every case (fast ear or FE), the pedicle's share, how the ear drives the joint (lumped)."""
    axes = _delta_axes(fig, tr["cases"], arrays, lumped_arrays)
    axes += _case_ratio_axes(fig, tr["cases"], arrays)
    for ax in axes:
        ax.tick_params(labelsize=6)
        ax.grid(True, which="both", lw=0.3)
        ax.set_xlabel("frequency (Hz)", fontsize=6)
    text_block(fig, 0.04, 0.49, "\n".join(_delta_table(tr)), fontsize=5.6)
    lp = lumped["load_path"]
    text_block(fig, 0.04, 0.40, "\n".join(_load_path_table(lp)), fontsize=5.6)
    text_block(fig, 0.07, 0.22, wrap(_delta_note(tr, lp), 112), fontsize=7)


def _delta_axes(fig, cases: list[str], arrays: dict, lumped_arrays: dict) -> list:
    """ΔH_V in dB and degrees and the pedicle's share per case; the lumped ear's ΔH_V dotted."""
    f, d = arrays["freq_hz"], arrays["delta"]
    ax_m = fig.add_axes([0.12, 0.75, 0.36, 0.16])
    ax_p = fig.add_axes([0.58, 0.75, 0.36, 0.16])
    ax_s = fig.add_axes([0.12, 0.54, 0.36, 0.16])
    for k, c in enumerate(cases):
        ax_m.semilogx(f, _db(d[:, k]), lw=1, label=c, color=f"C{k}")
        ax_p.semilogx(f, _deg(d[:, k]), lw=1, color=f"C{k}")
        ax_s.semilogx(f, np.abs(arrays["pedicle_share"][:, k]), lw=1, color=f"C{k}")
    ld = lumped_arrays["lumped_delta"][:, 0]
    ax_m.semilogx(lumped_arrays["freq_hz"], _db(ld), "k:", lw=1, label=f"lumped, {cases[0]}")
    ax_p.semilogx(lumped_arrays["freq_hz"], _deg(ld), "k:", lw=1)
    ax_m.set_title("dH_V = H_V / H_V,rigid (dB), whole ear", fontsize=8)
    ax_p.set_title("dH_V phase (deg), whole ear", fontsize=8)
    ax_s.set_title("pedicle share |beta / (alpha + beta)|, whole ear", fontsize=8)
    ax_s.set_ylim(0, 1.5)
    ax_m.legend(fontsize=5.5, ncol=2)
    return [ax_m, ax_p, ax_s]


def _case_ratio_axes(fig, cases: list[str], arrays: dict) -> list:
    """The pedicle's and the joint's own effect, the ratio of two cases' H_V, where the cases allow it."""
    named = (
        ("p3", "p12", "pedicle: p3 / p12"),
        ("j5c20", "base", "joint: j5c20 / base"),
        ("base_sliding", "base", "sliding / bonded joint"),
    )
    pairs = [(a, b, lab) for a, b, lab in named if a in cases and b in cases]
    if not pairs:
        return []
    f, d = arrays["freq_hz"], arrays["delta"]
    ax_c = fig.add_axes([0.58, 0.54, 0.36, 0.16])
    for n, (a, b, lab) in enumerate(pairs):
        r = d[:, cases.index(a)] / d[:, cases.index(b)]
        ax_c.semilogx(f, _db(r), color=f"C{n}", lw=1, label=f"{lab} (dB)")
        ax_c.semilogx(f, _deg(r) / 10, color=f"C{n}", lw=1, ls="--", label=f"{lab} (deg / 10)")
    ax_c.set_title("softer pedicle, softer or sliding joint: ratio of their H_V", fontsize=8)
    ax_c.legend(fontsize=5.5)
    return [ax_c]


def _delta_table(tr: dict) -> list[str]:
    """ΔH_V per case at the quoted frequencies, and the worst over the band."""
    cases = tr["cases"]
    lines = [f"{'dH_V':15}" + "".join(f"{c:>15}" for c in cases)]
    for q in tr["quote"]:
        lines.append(
            f"{q['freq_hz']:8.0f} Hz    "
            + "".join(f"{q['delta_db'][c]:+7.2f}dB{q['delta_deg'][c]:+5.1f}d" for c in cases)
        )
    worst_db, worst_deg = tr["worst_delta_db"], tr["worst_delta_deg"]
    lines.append("worst |.|      " + "".join(f"{worst_db[c]:7.2f}dB{worst_deg[c]:5.1f}d " for c in cases))
    return lines


def _load_path_table(lp: list[dict]) -> list[str]:
    """The lumped ear's load path: how stiff the ear is against the joint, and β's sensitivity."""
    rows = [
        f"{'load path, lumped ear':19}{'|Z_env| / |Z_joint| along the motion':>38}   "
        f"{'d ln beta / d ln E_pedicle':^38}",
        f"{'':19}{'0 Hz':>8}{'1 kHz':>10}{'5 kHz':>10}{'10 kHz':>10}   "
        f"{'0 Hz':>7}{'1 kHz':>7}{'5 kHz':>7}{'10kHz':>7}{'Thev.':>7}{'force':>7}{'isol.':>7}",
    ]
    for r in lp:
        lab = "default" if r["scaled"] == "default" else f"{r['scaled']} x {r['factor']:g}"
        rows.append(
            f"{lab:19}"
            + "".join(f"{x:10.2f}" for x in r["env_ratio"])[2:]
            + "   "
            + "".join(f"{x:+7.3f}" for x in r["ear_beta_sensitivity"])
            + f"{r['thevenin_beta_sensitivity'][0]:+7.3f}{r['force_driven_beta_sensitivity'][0]:+7.3f}"
            + f"{r['isolated_beta_sensitivity']:+7.3f}"
        )
    return rows


def _delta_note(tr: dict, lp: list[dict]) -> str:
    """What ΔH_V compares, the first case's figure, and why β barely follows the pedicle in the ear."""
    base = lp[0]
    most = max(lp[1:], key=lambda r: abs(r["ear_beta_sensitivity"][0]))
    q0 = tr["quote"][0] if tr["quote"] else None
    cost = ""
    if q0 is not None:
        c0 = tr["cases"][0]
        cost = (
            f"At {q0['freq_hz']:.0f} Hz the {c0} case's dH_V is {q0['delta_db'][c0]:+.2f} dB, "
            f"{q0['delta_deg'][c0]:+.1f} deg. "
        )
    note = (
        "dH_V compares each case's stapes velocity with that of a rigid incus-stapes connection, both "
        "on the whole ear (fast ear, FE reductions beside it) with the same damping. "
        + cost
        + "Why beta barely follows the pedicle inside "
        "the ear: the ear's stiffness condensed onto the joint's (alpha, beta) is "
        f"{base['env_ratio'][0]:.0f} times the joint's own along the motion at 0 Hz, so the joint is "
        "displacement-driven: the pedicle takes the relative rotation the chain imposes, and alpha takes "
        f"up a change of its modulus (d ln beta / d ln E_pedicle = {base['ear_beta_sensitivity'][0]:+.3f} "
        f"in the ear; the Thevenin picture predicts {base['thevenin_beta_sensitivity'][0]:+.3f}; the "
        "same joint under the same force with nothing else holding it, "
        f"{base['force_driven_beta_sensitivity'][0]:+.3f}; the isolated model, "
        f"{base['isolated_beta_sensitivity']:+.3f}). Of the scalings in the table, {most['scaled']} x "
        f"{most['factor']:g} moves it most ({most['ear_beta_sensitivity'][0]:+.3f} at 0 Hz). "
        "The lumped ear's coupling has only alpha and beta; its dH_V (dotted) misses the FE joint's "
        "other compliances (docs/transmission.md)."
    )
    return note
