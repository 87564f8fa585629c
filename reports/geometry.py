"""The report's geometry: trends of β and α with the pedicle's and the gap's thickness, and the
geometry calibration's domain (docs/lumped.md §3.13).

The trends vary one dimension at a time over the geometry calibration's range, every other
dimension and the moduli at the report's values. FE: the report's geometry and ``fe_points``
more values of each dimension, through the FE result cache (:func:`calibration.runner.
run_geometry_designs`, in this process: each geometry meshed once, on the report's mesh).
Lumped: the geometry calibration as curves. β is plotted with the Euler–Bernoulli law of the
pedicle's bending, β ∝ 1/b_x³ (its second moment of area is b_y b_x³/12), drawn through the FE
point at the report's geometry.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from . import figures
from .layout import pct, text_block, urad

#: (dimension, the output plotted against it, the exponent of the reference power law or None).
GEOMETRY_TRENDS = (("pedicle_x_m", "beta_rad", -3.0), ("gap_thickness_m", "alpha_rad", None))


def geometry_lumped_calibration(ctx):
    """(calibration, its name): the report's own if it covers geometry (``geometry_domain``), else
    the shipped geometry calibration."""
    from isj.lumped.artifact import geometry_calibration

    if ctx.calibration.geometry_domain:
        return ctx.calibration, ctx.config.calibration.file or "the shipped calibration"
    return geometry_calibration(), "the shipped geometry calibration"


def _slope(x0: float, y0: float, x1: float, y1: float) -> float:
    """d ln y / d ln x between two points."""
    return float(np.log(y1 / y0) / np.log(x1 / x0))


def _trend_points(ctx, cal) -> list[tuple]:
    """Per trend of :data:`GEOMETRY_TRENDS`: (dimension, output, law, the report's value x0, the
    domain's lo and hi, the FE points' values, ascending, x0 among them), all in m."""
    t, geom = ctx.config.geometry_trends, ctx.config.geometry
    plan = []
    for dim, output, law in GEOMETRY_TRENDS:
        x0 = float(getattr(geom, dim))
        lo, hi = (float(v) for v in cal.geometry_domain[dim])
        lo, hi = min(lo, x0), max(hi, x0)
        # the report's own value among the FE points: the reference law goes through it
        xf = sorted({x0, *(float(v) for v in np.geomspace(lo, hi, t.fe_points))} if t.fe_points else {x0})
        plan.append((dim, output, law, x0, lo, hi, xf))
    return plan


def _new_geometries(plan) -> list[dict]:
    """The FE points' dimensions other than the report's own, in the order they are solved."""
    return [{dim: v} for dim, *_, x0, _, _, xf in plan for v in xf if v != x0]


def geometry_trend_geometries(ctx) -> list:
    """The geometries the geometry trends step meshes besides the report's own, in its order
    (for :func:`isj.fem.mesh_ahead.meshes_ahead`)."""
    cal, _ = geometry_lumped_calibration(ctx)
    geom = ctx.config.geometry
    return [dataclasses.replace(geom, **dims) for dims in _new_geometries(_trend_points(ctx, cal))]


def geometry_trends_step(ctx) -> tuple[dict, dict]:
    """β against the pedicle's thickness and α against the gap's: FE points, lumped curves, slopes."""
    from isj.calibration.checks import lumped_static
    from isj.calibration.runner import run_geometry_designs
    from isj.fem.batch import evaluate_design, transient_models
    from isj.fem.mesh_ahead import meshes_ahead

    cfg = ctx.config
    t = cfg.geometry_trends
    cal, cal_name = geometry_lumped_calibration(ctx)
    base, geom, p = ctx.base_design(), cfg.geometry, cfg.design.pressure_pa
    out, arrays = {}, {}
    plan = _trend_points(ctx, cal)
    for dim, _, _, _, lo, hi, _ in plan:
        x = np.geomspace(lo, hi, t.n_lumped)
        lum = [lumped_static(cal, [base], dataclasses.replace(geom, **{dim: float(v)}), p) for v in x]
        arrays[f"{dim}_x_m"] = x
        arrays[f"{dim}_alpha_rad"] = np.array([r.alpha_rad[0] for r in lum])
        arrays[f"{dim}_beta_rad"] = np.array([r.beta_rad[0] for r in lum])
    # the report's geometry last
    new = _new_geometries(plan)
    items = [(base, dims) for dims in new] + [(base, {})]
    # a second process meshes the next geometries while this one solves (fem.mesh_ahead; the
    # report's runner has usually made them ahead already, during the steps before)
    ahead = [dataclasses.replace(geom, **dims) for dims in new]
    with transient_models(), meshes_ahead(ahead, cfg.mesh.resolution):
        records = run_geometry_designs(
            items, evaluate_design, ctx.settings, ctx.fe_cache_dir, max_workers=0, progress=ctx.progress
        )
    fe = {tuple(sorted(r["settings"]["geometry"].items())): r["result"] for r in records}
    for dim, output, law, x0, lo, hi, xf in plan:
        points = []
        for v in xf:
            g = dataclasses.replace(geom, **{dim: v})
            r = fe[tuple(sorted(dataclasses.asdict(g).items()))]
            lu = lumped_static(cal, [base], g, p)
            points.append(
                {
                    "value_m": v,
                    "fe": {"alpha_rad": r["alpha_rad"], "beta_rad": r["beta_rad"]},
                    "lumped": {"alpha_rad": float(lu.alpha_rad[0]), "beta_rad": float(lu.beta_rad[0])},
                }
            )
        i = xf.index(x0)
        y = [q["fe"][output] for q in points]
        out[dim] = {
            "output": output,
            "reference_exponent": law,
            "domain_m": [lo, hi],
            "value_m": x0,
            "fe_points": points,
            # d ln(output) / d ln(dimension) from the report's value to its FE neighbours
            "fe_slope_below": _slope(xf[i - 1], y[i - 1], x0, y[i]) if i > 0 else None,
            "fe_slope_above": _slope(x0, y[i], xf[i + 1], y[i + 1]) if i + 1 < len(xf) else None,
        }
    return {"calibration": cal_name, "geometry_domain": dict(cal.geometry_domain), "trends": out}, arrays


def geometry_trend_panels(fig, res: dict, arrays: dict, y0: float, height: float) -> None:
    """One panel per dimension of :data:`GEOMETRY_TRENDS`, side by side, from ``y0`` up ``height``."""
    for j, (dim, output, _law) in enumerate(GEOMETRY_TRENDS):
        tr = res["trends"][dim]
        ax = fig.add_axes([0.08 + 0.47 * j, y0, 0.38, height])
        pts = tr["fe_points"]
        figures.geometry_trend(
            ax,
            arrays[f"{dim}_x_m"],
            arrays[f"{dim}_{output}"],
            [q["value_m"] for q in pts],
            [q["fe"][output] for q in pts],
            dim,
            output,
            tr["value_m"],
            tr["reference_exponent"],
        )
        if j == 0:
            ax.legend(fontsize=6)


def geometry_trend_lines(res: dict) -> list[str]:
    """The FE points and slopes as text lines (lumped / FE − 1 in brackets)."""
    lines = [f"Geometry (lumped: {res['calibration']}; FE slope: d ln y / d ln x to the next points):"]
    for dim, output, _ in GEOMETRY_TRENDS:
        tr = res["trends"][dim]
        name = output.replace("_rad", "")
        cells = [
            f"{q['value_m'] * 1e6:.3g} um {urad(q['fe'][output])} "
            f"({pct(q['lumped'][output] / q['fe'][output] - 1)})"
            for q in tr["fe_points"]
        ]
        slopes = [f"{s:+.2f}" for s in (tr["fe_slope_below"], tr["fe_slope_above"]) if s is not None]
        slope = f"; FE slope {' / '.join(slopes)}" if slopes else ""  # none with fe_points = 0
        lines.append(f"  {name} (urad) vs {dim}: " + ", ".join(cells) + slope)
    return lines


def geometry_domain_lines(geo: dict, design_geometry: dict) -> list[str]:
    """The geometry calibration's box, its held-out errors and worst corner: lines of <= 58 characters."""
    v, t = geo["validation"], geo["training"]
    lines = [
        "geometry calibration, for dimensions other than the",
        f"default ({geo['source']}):",
        f"  {t['n']} training, {v['n']} held-out FE designs (geometry and",
        "  moduli sampled together)",
        f"  held out: max |error| alpha {100 * v['max_alpha']:.1f} %, beta {100 * v['max_beta']:.1f} %,",
        f"    beta/alpha {100 * v['max_ratio']:.1f} %; RMS {100 * v['rms_alpha']:.1f} / "
        f"{100 * v['rms_beta']:.1f} / {100 * v['rms_ratio']:.1f} %",
    ]
    k = v.get("n_beyond_support_limit", 0)
    if k:  # docs/lumped.md section 3.16: the claim holds below s = pi/2 (warned beyond)
        lines += [
            "  (below the plate-support limit s = pi/2; warned beyond:",
            f"    {k} more held out, alpha {100 * v['max_alpha_beyond_support_limit']:.1f} %, "
            f"beta {100 * v['max_beta_beyond_support_limit']:.1f} %)",
        ]
    if geo["corners"]:
        name, worst = max(geo["corners"].items(), key=lambda kv: max(kv[1]["alpha"], kv[1]["beta"]))
        s = worst.get("plate_support")
        where = "" if s is None else f" (s {s:.2f}{', beyond' if s > math.pi / 2 else ''})"
        lines += [
            f"  {len(geo['corners'])} mixed corners, the worst:",
            f"    {name}:",
            f"      alpha {100 * worst['alpha']:.1f} %, beta {100 * worst['beta']:.1f} %{where}",
        ]
    lines += ["", f"  {'dimension (um)':20} {'low':>7} {'high':>7} {'report':>7}"]
    for k, (lo, hi) in geo["domain_m"].items():
        here = design_geometry.get(k)
        cell = "" if here is None else f"{here * 1e6:7.2f}" + ("" if lo <= here <= hi else " outside")
        lines.append(f"  {k:20} {lo * 1e6:7.2f} {hi * 1e6:7.2f} {cell}")
    return lines


def geometry_calibration_summary() -> dict:
    """The shipped geometry calibration's domain (m), errors and corners, for the calibration step."""
    from isj.lumped.artifact import geometry_calibration

    g = geometry_calibration()
    return {
        "source": "lumped/data/geometry_calibration.json",
        "domain_m": {k: [float(lo), float(hi)] for k, (lo, hi) in g.geometry_domain.items()},
        "training": g.training,
        "validation": g.validation,
        "corners": g.corners,
    }


def draw_geometry_domain(fig, geo: dict, design_geometry: dict, y: float) -> None:
    """The calibration page's block on the geometry domain, its top at ``y``."""
    text_block(fig, 0.56, y, "\n".join(geometry_domain_lines(geo, design_geometry)), fontsize=6.8)
