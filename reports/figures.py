"""Plots of the report: each draws one step's numbers on given axes and returns its artists.

No computation here beyond unit scaling: the numbers come from
:mod:`reports.steps`. Frequencies in Hz on log axes, phases unwrapped.
"""

from __future__ import annotations

import numpy as np

from isj.design import REGIONS

#: One colour per region, fixed so that every picture reads the same.
REGION_COLORS = {
    "stapes": "#8c6d31",
    "gap": "#e6550d",
    "plate": "#bdbdbd",
    "pedicle": "#3182bd",
    "incus": "#d9d9d9",
    "capsule": "#31a354",
}

#: Axis labels and scale factors for moduli.
MODULUS_UNITS = {
    "pedicle_e_pa": ("pedicle E (GPa)", 1e-9),
    "plate_e_pa": ("plate E (GPa)", 1e-9),
    "stapes_e_pa": ("stapes E (GPa)", 1e-9),
    "gap_e_pa": ("gap E (MPa)", 1e-6),
    "capsule_e_pa": ("capsule E (MPa)", 1e-6),
}


def _log_axes(ax, which: str = "xy") -> None:
    """Log scale with plain labels at 1, 2, 5 × 10^k (the defaults crowd a short log axis)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    for name in which:
        axis = ax.xaxis if name == "x" else ax.yaxis
        (ax.set_xscale if name == "x" else ax.set_yscale)("log")
        axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        axis.set_minor_formatter(NullFormatter())


def _set_3d_equal(ax, pts: np.ndarray) -> None:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo)


def mesh_by_region(
    ax, points_m, triangles, triangle_region, region_names=REGIONS, displacement_m=None, scale=0.0
):
    """The half model y < 0 (cut face at the symmetry plane), faces coloured by region.

    With ``displacement_m`` and ``scale`` > 0 the points are moved by
    ``scale * displacement_m`` and faces are coloured by |u| instead.
    Returns the Poly3DCollection (rasterised, so the PDF stays small).
    """
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    p = np.asarray(points_m) * 1e6  # µm on the axes
    if displacement_m is not None and scale > 0:
        p = p + scale * np.asarray(displacement_m) * 1e6
    verts = p[triangles]
    if displacement_m is None or scale <= 0:
        colors = [REGION_COLORS.get(region_names[r], "#999999") for r in triangle_region]
        coll = Poly3DCollection(verts, facecolors=colors, edgecolors="k", linewidths=0.05)
    else:
        mag = np.linalg.norm(displacement_m, axis=1)[triangles].mean(axis=1) * 1e9  # nm
        coll = Poly3DCollection(verts, cmap="viridis", edgecolors="none")
        coll.set_array(mag)
    coll.set_rasterized(True)
    ax.add_collection3d(coll)
    _set_3d_equal(ax, p[np.unique(triangles)])
    ax.set_xlabel("x (µm)", fontsize=7)
    ax.set_ylabel("y (µm)", fontsize=7)
    ax.zaxis.set_rotate_label(False)  # else it reads upside down at this view
    ax.set_zlabel("z (µm)", fontsize=7, rotation=90)
    ax.tick_params(labelsize=6)
    from matplotlib.ticker import MaxNLocator

    ax.yaxis.set_major_locator(MaxNLocator(3))  # the y extent is short: default ticks overlap
    ax.view_init(elev=18, azim=55)
    return coll


def region_legend(ax, region_names=REGIONS):
    from matplotlib.patches import Patch

    handles = [Patch(facecolor=REGION_COLORS[r], edgecolor="k", label=r) for r in region_names]
    return ax.legend(handles=handles, loc="upper left", fontsize=7, frameon=False)


def case_bars(ax, rows, key: str, scale: float, ylabel: str):
    """FE and lumped values of one output per thesis case, side by side."""
    names = [r["case"] for r in rows]
    x = np.arange(len(names))
    a = ax.bar(x - 0.2, [r["fe"][key] * scale for r in rows], 0.4, label="FE", color="#3182bd")
    b = ax.bar(x + 0.2, [r["lumped"][key] * scale for r in rows], 0.4, label="lumped", color="#fd8d3c")
    ax.set_xticks(x, names, fontsize=7)
    ax.set_ylabel(ylabel, fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(True, axis="y", alpha=0.3)
    return [a, b]


def trend(ax, x_pa, y_lumped, fe_x_pa, fe_y, modulus: str, ylabel: str, scale: float = 1.0, base_pa=None):
    """Lumped curve against one modulus, FE points on it (log x)."""
    label, xs = MODULUS_UNITS.get(modulus, (modulus, 1.0))
    artists = ax.plot(
        np.asarray(x_pa) * xs, np.asarray(y_lumped) * scale, "-", color="#fd8d3c", label="lumped"
    )
    if len(fe_x_pa):
        artists += ax.plot(
            np.asarray(fe_x_pa) * xs, np.asarray(fe_y) * scale, "o", mfc="none", color="#3182bd", label="FE"
        )
    if base_pa is not None:
        artists.append(ax.axvline(base_pa * xs, color="k", lw=0.6, ls=":"))
    _log_axes(ax, "x")
    _min_span(ax, np.concatenate([np.asarray(y_lumped, float), np.asarray(fe_y, float)]) * scale, 0.10)
    ax.set_xlabel(label, fontsize=7)
    ax.set_ylabel(ylabel, fontsize=7)
    ax.tick_params(labelsize=6)
    ax.grid(True, which="both", alpha=0.3)
    return artists


def geometry_trend(ax, x_m, y_lumped, fe_x_m, fe_y, dimension: str, output: str, x0_m: float, exponent=None):
    """Lumped curve and FE points of ``output`` (rad, shown in urad) against a dimension (m, shown
    in um), log-log; with ``exponent`` the power law y ∝ x^exponent through the FE point at ``x0_m``."""
    x, fx = np.asarray(x_m) * 1e6, np.asarray(fe_x_m) * 1e6
    fy = np.asarray(fe_y) * 1e6
    lum = np.asarray(y_lumped) * 1e6
    artists = ax.plot(x, lum, "-", color="#fd8d3c", label="lumped (geometry calibration)")
    artists += ax.plot(fx, fy, "o", mfc="none", color="#3182bd", label="FE")
    if exponent is not None:
        y0 = fy[np.argmin(np.abs(fx - x0_m * 1e6))]
        label = f"{output.split('_')[0]} ∝ {dimension.split('_m')[0]}^{exponent:g} (Euler-Bernoulli bending)"
        artists += ax.plot(x, y0 * (x / (x0_m * 1e6)) ** exponent, "--", color="0.4", lw=0.8, label=label)
    artists.append(ax.axvline(x0_m * 1e6, color="k", lw=0.6, ls=":"))
    _log_axes(ax, "xy")
    ax.set_xticks(fx, [f"{v:.3g}" for v in fx])  # a short log axis: the FE points' values
    ax.set_xlabel(f"{dimension} (um)", fontsize=7)
    ax.set_ylabel(f"{output.split('_')[0]} (urad)", fontsize=7)
    ax.tick_params(labelsize=6, which="both")
    ax.grid(True, which="both", alpha=0.3)
    return artists


def _min_span(ax, values: np.ndarray, rel: float) -> None:
    """Widen the y axis to at least ``rel`` × the mean, so that tiny changes do not look large."""
    lo, hi = float(values.min()), float(values.max())
    mid, need = 0.5 * (lo + hi), rel * abs(float(values.mean()))
    if hi - lo < need:
        ax.set_ylim(mid - 0.6 * need, mid + 0.6 * need)


def energy_bars(ax, rows, region_names=REGIONS):
    """Stacked horizontal bars: each region's share of the strain energy, per case (%)."""
    names = [r["case"] for r in rows][::-1]
    left = np.zeros(len(names))
    artists = []
    for g in region_names:
        e = []
        for r in rows[::-1]:
            tot = sum(r["strain_energy_j"].values())
            e.append(100 * r["strain_energy_j"][g] / tot)
        artists.append(ax.barh(names, e, left=left, color=REGION_COLORS[g], edgecolor="k", lw=0.3, label=g))
        left += e
    ax.set_xlim(0, 100)
    ax.set_xlabel("share of the strain energy (%)", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(ncol=6, fontsize=7, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    return artists


def convergence(ax, studies, direction: str):
    """Maximum |u| against tets for each order, Timoshenko as a line."""
    artists = []
    for s in studies:
        if s["direction"] != direction:
            continue
        n = [r["n_tets"] for r in s["rows"]]
        artists += ax.plot(
            n, [r["max_disp_m"] * 1e9 for r in s["rows"]], "o-", label=f"P{s['order']} max |u|"
        )
        artists += ax.plot(
            n,
            [r["tip_mean_m"] * 1e9 for r in s["rows"]],
            "s--",
            ms=3,
            lw=0.8,
            label=f"P{s['order']} mean tip u",
        )
        analytic = s["rows"][0]["analytic_m"] * 1e9
    artists.append(ax.axhline(analytic, color="k", lw=1, label="Timoshenko"))
    ax.set_xscale("log")
    ax.set_xlabel("tetrahedra", fontsize=8)
    ax.set_ylabel("displacement (nm) at 1 µN", fontsize=8)
    ax.set_title(f"shear load in {direction}", fontsize=9)
    ax.tick_params(labelsize=7)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6)
    return artists


def parity(ax, fe, lumped, label: str, scale: float = 1.0):
    """Lumped against FE (log-log), with the ±3 % band."""
    fe, lumped = np.asarray(fe) * scale, np.asarray(lumped) * scale
    lo, hi = min(fe.min(), lumped.min()) / 1.1, max(fe.max(), lumped.max()) * 1.1
    x = np.geomspace(lo, hi, 2)
    artists = ax.plot(x, x, "k-", lw=0.8)
    artists += (ax.fill_between(x, x * 0.97, x * 1.03, color="0.85", label="±3 %"),)
    artists += ax.plot(fe, lumped, "o", ms=4, mfc="none", color="#3182bd", label="fresh FE designs")
    _log_axes(ax)
    ax.set_xlabel(f"FE {label}", fontsize=8)
    ax.set_ylabel(f"lumped {label}", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=6)
    ax.grid(True, which="both", alpha=0.3)
    return artists


def error_hist(ax, errors: dict[str, list[float]]):
    """Histogram of the relative errors (%) of each output."""
    allv = np.concatenate([np.asarray(v, dtype=float) for v in errors.values()]) * 100
    edges = np.linspace(min(allv.min(), -3.5), max(allv.max(), 3.5), 15)
    artists = []
    for k, v in errors.items():
        artists.append(ax.hist(np.asarray(v) * 100, bins=edges, histtype="step", lw=1.5, label=k)[2])
    for s in (-3, 3):
        ax.axvline(s, color="k", ls=":", lw=0.8)
    ax.set_xlabel("lumped / FE − 1 (%)", fontsize=8)
    ax.set_ylabel("designs", fontsize=8)
    ax.yaxis.get_major_locator().set_params(integer=True)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=6, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=2, frameon=False)
    return artists


def domain_points(ax, points, domain, x: str, y: str):
    """The calibrated box of two moduli (log axes) with the check designs inside it."""
    lx, sx = MODULUS_UNITS[x]
    ly, sy = MODULUS_UNITS[y]
    (x0, x1), (y0, y1) = domain[x], domain[y]
    artists = ax.plot(
        [x0 * sx, x1 * sx, x1 * sx, x0 * sx, x0 * sx], [y0 * sy, y0 * sy, y1 * sy, y1 * sy, y0 * sy], "k-"
    )
    artists += ax.plot(
        [p["design"][x] * sx for p in points], [p["design"][y] * sy for p in points], "o", ms=3
    )
    _log_axes(ax)
    ax.set_xlabel(lx, fontsize=7)
    ax.set_ylabel(ly, fontsize=7)
    ax.tick_params(labelsize=6)
    return artists


def ear_picture(ax, arrays: dict):
    """The eardrum coloured by |u| (nm/Pa), the footplate, the ossicular chain as a line (3-D, mm)."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    x = np.asarray(arrays["drum_nodes_m"]) * 1e3
    tri = np.asarray(arrays["drum_triangles"])
    mag = np.linalg.norm(arrays["drum_u_m_per_pa"], axis=1)[tri].mean(axis=1) * 1e9
    drum = Poly3DCollection(x[tri], cmap="viridis", edgecolors="k", linewidths=0.05)
    drum.set_array(mag)
    drum.set_rasterized(True)
    ax.add_collection3d(drum)
    xf = np.asarray(arrays["footplate_nodes_m"]) * 1e3
    fp = Poly3DCollection(
        xf[np.asarray(arrays["footplate_triangles"])], facecolors="#8c6d31", edgecolors="none"
    )
    ax.add_collection3d(fp)
    c = np.asarray(arrays["chain_m"]) * 1e3
    artists = [drum, fp]
    artists += ax.plot(c[:, 0], c[:, 1], c[:, 2], "-", color="#d62728", lw=2.5, label="ossicular chain")
    lig = np.asarray(arrays["ligaments_m"]) * 1e3
    artists += ax.plot(lig[:, 0], lig[:, 1], lig[:, 2], "ks", ms=3, label="ligament attachments")
    pts = np.vstack([x, xf, c, lig])
    _set_3d_equal(ax, pts)
    for lab, f in (("x (mm)", ax.set_xlabel), ("y (mm)", ax.set_ylabel), ("z (mm), lateral", ax.set_zlabel)):
        f(lab, fontsize=7)
    ax.tick_params(labelsize=6)
    ax.view_init(elev=8, azim=-70)  # low, so the cone's depth and the chain below it show
    ax.legend(fontsize=6, loc="upper right", bbox_to_anchor=(1.0, 0.95))
    return artists
