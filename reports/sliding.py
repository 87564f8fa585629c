"""The report's sliding-joint step and page (docs/model.md §2.12): the seven cases bonded and sliding."""

from __future__ import annotations

import dataclasses

import numpy as np

from .layout import text_block, urad, wrap


def lumped_calibration(ctx, joint: str):
    """The lumped calibration for ``joint``: the report's own if it was fitted with that joint,
    else the shipped one (:func:`isj.lumped.artifact.calibration_for`); None for the layer."""
    from isj.lumped.artifact import CALIBRATED_JOINTS, calibration_for

    if joint not in CALIBRATED_JOINTS:
        return None
    if ctx.calibration.joint == joint:
        return ctx.calibration
    return calibration_for(ctx.config.geometry, joint)


def sliding_step(ctx) -> tuple[dict, dict]:
    """α, β, β/α and the capsule's share of the joint's shear, per case and joint (FE), and the
    lumped model's α, β, β/α with the calibration of each joint (none for the layer)."""
    from isj.calibration.checks import lumped_static
    from isj.fem.batch import shared_model
    from isj.fem.model import compare_cases

    from isj.cases import THESIS_CASES

    cfg = ctx.config
    # the bonded and sliding models of the other steps (and their kept static results: the
    # cases step's seven bonded solves are these), built once per report
    models = {j: shared_model(ctx.settings | {"joint": j})[0] for j in cfg.sliding.joints if j != "layer"}
    rows = compare_cases(
        order=cfg.mesh.order,
        resolution=cfg.mesh.resolution,
        joints=cfg.sliding.joints,
        nu=cfg.design.nu,
        pressure_pa=cfg.design.pressure_pa,
        layer_shear_pa=cfg.sliding.layer_shear_pa,
        geometry=cfg.geometry,
        base=cfg.design.materials(),
        models=models,
    )
    designs = [dataclasses.asdict(c.materials(cfg.design.materials())) for c in THESIS_CASES]
    for j in cfg.sliding.joints:
        cal = lumped_calibration(ctx, j)
        r = lumped_static(cal, designs, cfg.geometry, cfg.design.pressure_pa) if cal else None
        by_case = [row for row in rows if row["joint"] == j]  # in THESIS_CASES order
        for i, row in enumerate(by_case):
            for key, v in (
                ("alpha_rad", "alpha_rad"),
                ("beta_rad", "beta_rad"),
                ("beta_over_alpha", "ratio"),
            ):
                row[f"lumped_{key}"] = float(getattr(r, v)[i]) if r is not None else None
    return {
        "joints": list(cfg.sliding.joints),
        "layer_shear_pa": cfg.sliding.layer_shear_pa,
        "rows": rows,
    }, {}


def sliding_page(fig, res: dict):
    joints = res["joints"]
    by = {(r["case"], r["joint"]): r for r in res["rows"]}
    cases = list(dict.fromkeys(r["case"] for r in res["rows"]))
    ax = fig.add_axes([0.12, 0.66, 0.80, 0.24])
    x = np.arange(len(cases))
    w = 0.8 / len(joints)
    for k, j in enumerate(joints):
        xk = x + (k - (len(joints) - 1) / 2) * w
        ax.bar(xk, [by[c, j]["beta_over_alpha"] for c in cases], w, label=j)
        lumped = [by[c, j].get("lumped_beta_over_alpha") for c in cases]
        if all(v is not None for v in lumped):
            ax.plot(xk, lumped, "k_", ms=7, mew=1.2, label="lumped" if k == 0 else None)
    ax.set_xticks(x, cases, fontsize=7)
    ax.set_ylabel("beta / alpha", fontsize=7)
    ax.axhline(1.0, color="k", lw=0.6)
    ax.legend(fontsize=7)
    ax.tick_params(labelsize=7)
    ax.set_title(
        "beta / alpha of the seven thesis cases, bonded and sliding joint (FE; lumped: dashes)", fontsize=8
    )
    head = (
        f"{'case':6} {'joint':8} {'alpha urad':>11} {'beta urad':>10} {'b/a':>7} {'capsule shear':>14} "
        f"{'capsule moment':>15} {'lumped alpha':>13} {'beta':>9} {'b/a':>7}"
    )
    lines = [head, "-" * len(head)]
    for c in cases:
        for j in joints:
            r = by[c, j]
            if r.get("lumped_alpha_rad") is None:  # the layer: no lumped calibration
                lumped = f"{'-':>13} {'-':>9} {'-':>7}"
            else:
                lumped = f"{urad(r['lumped_alpha_rad']):>13} {urad(r['lumped_beta_rad']):>9} "
                lumped += f"{r['lumped_beta_over_alpha']:7.3f}"
            lines.append(
                f"{c:6} {j:8} {urad(r['alpha_rad']):>11} {urad(r['beta_rad']):>10} "
                f"{r['beta_over_alpha']:7.3f} {r['capsule_shear_share']:14.3f} "
                f"{r['capsule_moment_share']:15.3f} {lumped}"
            )
    text_block(fig, 0.07, 0.60, "\n".join(lines), fontsize=6.5)
    note = (
        "sliding: the gap's face against the plate is frictionless (normal displacement continuous, "
        "tangential free; exact master-slave constraints). layer: the gap's through-thickness shear modulus "
        f"lowered to {res['layer_shear_pa']:g} Pa (an estimate). The shares are the fractions of the joint's "
        "shear force and bending moment that the capsule carries across a plane at the gap's mid-height; "
        "the gap carries the rest. alpha and beta are the thesis's point-pair angles "
        "(docs/model.md 2.4, 2.12). Lumped: the calibrated lumped model of each joint, fitted on FE "
        "with that joint (docs/lumped.md 3.14; the layer has none)."
    )
    text_block(fig, 0.07, 0.60 - 0.0125 * (len(lines) + 2), wrap(note, 110), fontsize=7)
