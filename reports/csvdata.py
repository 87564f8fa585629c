"""The report's tables as CSV text, units in the column names and a ``#`` header line."""

from __future__ import annotations

import numpy as np

from .steps import STATIC_KEYS
from .transmission_step import cavity_tables


def _csv(header: str, columns: list[str], rows) -> str:
    lines = [f"# {header}", ",".join(columns)]
    for row in rows:
        lines.append(",".join(v if isinstance(v, str) else f"{v:.9g}" for v in row))
    return "\n".join(lines) + "\n"


def _cases(res: dict) -> dict[str, str]:
    cols = ["case", "pedicle_e_pa", "gap_e_pa", "capsule_e_pa"]
    cols += [f"fe_{k}" for k in STATIC_KEYS] + [f"lumped_{k}" for k in STATIC_KEYS]
    cols += [f"rel_diff_{k}" for k in STATIC_KEYS]
    rows = [
        [r["case"], r["pedicle_e_pa"], r["gap_e_pa"], r["capsule_e_pa"]]
        + [r["fe"][k] for k in STATIC_KEYS]
        + [r["lumped"][k] for k in STATIC_KEYS]
        + [r["rel_diff"][k] for k in STATIC_KEYS]
        for r in res["rows"]
    ]
    regions = list(res["rows"][0]["strain_energy_j"])
    energy = [[r["case"]] + [r["strain_energy_j"][g] for g in regions] for r in res["rows"]]
    return {
        "cases.csv": _csv("seven thesis cases, FE and lumped (rad; moduli Pa)", cols, rows),
        "strain_energy.csv": _csv(
            "FE strain energy per region (J)", ["case"] + [f"{g}_j" for g in regions], energy
        ),
    }


def _trends(res: dict, arr: dict) -> dict[str, str]:
    out = {}
    for name, r in res.items():
        x, a, b = arr[f"{name}_x"], arr[f"{name}_alpha_rad"], arr[f"{name}_beta_rad"]
        out[f"trend_{name}_lumped.csv"] = _csv(
            f"lumped model against {name} (Pa), other moduli at the base design",
            [name, "alpha_rad", "beta_rad", "beta_over_alpha"],
            zip(x, a, b, b / a, strict=True),
        )
        out[f"trend_{name}_fe.csv"] = _csv(
            f"FE and lumped points against {name} (Pa)",
            [name] + [f"fe_{k}" for k in STATIC_KEYS] + [f"lumped_{k}" for k in STATIC_KEYS],
            [
                [p["value_pa"]] + [p["fe"][k] for k in STATIC_KEYS] + [p["lumped"][k] for k in STATIC_KEYS]
                for p in r["fe_points"]
            ],
        )
    return out


def _convergence(res: dict) -> dict[str, str]:
    cols = ["order", "direction", "resolution", "n_tets", "n_dofs", "max_disp_m", "tip_mean_m"]
    cols += ["analytic_m", "rel_error"]
    rows = [
        [str(s["order"]), s["direction"]] + [r[c] for c in cols[2:]]
        for s in res["studies"]
        for r in s["rows"]
    ]
    return {"convergence.csv": _csv("pedicle cantilever against Timoshenko (m)", cols, rows)}


def _calibration(res: dict) -> dict[str, str]:
    if not res["points"]:
        return {}
    names = list(res["points"][0]["design"])
    keys = ("alpha_rad", "beta_rad", "beta_over_alpha")
    cols = names + [f"fe_{k}" for k in keys] + [f"lumped_{k}" for k in keys]
    rows = [
        [p["design"][n] for n in names] + [p["fe"][k] for k in keys] + [p["lumped"][k] for k in keys]
        for p in res["points"]
    ]
    return {"calibration_check.csv": _csv("fresh FE designs against the lumped model (Pa, rad)", cols, rows)}


def _sweep(res: dict, arr: dict) -> dict[str, str]:
    outs = res["outputs"]
    cols = ["freq_hz"]
    data = [arr["freq_hz"]]
    for k in outs:
        h = arr[f"{k}_re"] + 1j * arr[f"{k}_im"]
        cols += [f"{k}_abs", f"{k}_phase_deg"]
        data += [np.abs(h), np.degrees(np.unwrap(np.angle(h)))]
    modes = [[float(i + 1), f] for i, f in enumerate(res["fe_modes_hz"])]
    return {
        "sweep_lumped.csv": _csv(
            "lumped frequency response of the base design (Hz; rad, m; deg)", cols, zip(*data, strict=True)
        ),
        "modes_fe.csv": _csv("FE natural frequencies of the base design (Hz)", ["mode", "freq_hz"], modes),
    }


def _ear(res: dict) -> dict[str, str]:
    cols = ["case", "umbo_m_per_pa", "eardrum_max_m_per_pa", "footplate_x_m_per_pa", "footplate_y_m_per_pa"]
    cols += ["footplate_z_m_per_pa", "footplate_piston_m_per_pa", "alpha_rad_per_pa", "beta_rad_per_pa"]
    rows = []
    for c in [*res["cases"], {"case": "rigid_joint"} | res["rigid_joint"]]:
        a, b = c["alpha_rad_per_pa"], c["beta_rad_per_pa"]
        rows.append(
            [c["case"], c["umbo_m_per_pa"], c["eardrum_max_m_per_pa"], *c["footplate_m_per_pa"]]
            + [c["footplate_piston_m_per_pa"], "" if a is None else a, "" if b is None else b]
        )
    return {"ear.csv": _csv("whole ear, static, per Pa of ear-canal pressure (m/Pa, rad/Pa)", cols, rows)}


def _transmission(res: dict, arr: dict) -> dict[str, str]:
    f, cases = arr["freq_hz"], res["cases"]
    cols, data = ["freq_hz"], [f]
    for name in ["rigid", *cases]:
        v = arr[f"{name}_stapes_velocity_m_s"]
        cols += [f"{name}_stapes_velocity_re_m_s_per_pa", f"{name}_stapes_velocity_im_m_s_per_pa"]
        data += [v.real, v.imag]
    for k, name in enumerate(cases):
        d = arr["delta"][:, k]
        cols += [f"{name}_delta_hv_db", f"{name}_delta_hv_deg", f"{name}_pedicle_share_abs"]
        data += [20 * np.log10(np.abs(d)), np.degrees(np.angle(d)), np.abs(arr["pedicle_share"][:, k])]
    return {
        "transmission.csv": _csv(
            "FE whole ear: stapes velocity per ear-canal pressure H_V (m/s/Pa) and dH_V = H_V / H_V,rigid",
            cols,
            zip(*data, strict=True),
        )
    } | cavity_tables(res, _csv)


def tables(step: str, res: dict, arr: dict) -> dict[str, str]:
    """File name → CSV text for one step's result."""
    if step == "cases":
        return _cases(res)
    if step == "trends":
        return _trends(res, arr)
    if step == "convergence":
        return _convergence(res)
    if step == "calibration":
        return _calibration(res)
    if step == "sweep":
        return _sweep(res, arr)
    if step == "ear":
        return _ear(res)
    if step == "transmission":
        return _transmission(res, arr)
    if step == "uq" and res.get("transmission"):
        from isj.studies.uq import transmission_csv

        return {"uq_transmission.csv": transmission_csv(res["transmission"])}
    if step == "sliding":
        keys = [
            "alpha_rad",
            "beta_rad",
            "beta_over_alpha",
            "capsule_shear_share",
            "capsule_moment_share",
            "strain_energy_j",
        ]
        keys += ["lumped_alpha_rad", "lumped_beta_rad", "lumped_beta_over_alpha"]
        # the layer has no lumped calibration: its lumped columns are empty
        cell = lambda r, k: "" if r.get(k) is None else r[k]  # noqa: E731
        rows = [[r["case"], r["joint"]] + [cell(r, k) for k in keys] for r in res["rows"]]
        head = "seven thesis cases, bonded and sliding joint (FE; lumped_: the lumped model of each joint)"
        return {"sliding.csv": _csv(head, ["case", "joint", *keys], rows)}
    if step == "geometry_trends":
        cols = ["dimension", "value_m", "fe_alpha_rad", "fe_beta_rad", "lumped_alpha_rad", "lumped_beta_rad"]
        rows = [
            [
                dim,
                q["value_m"],
                q["fe"]["alpha_rad"],
                q["fe"]["beta_rad"],
                q["lumped"]["alpha_rad"],
                q["lumped"]["beta_rad"],
            ]
            for dim, tr in res["trends"].items()
            for q in tr["fe_points"]
        ]
        head = "one dimension varied, all else at the report's values (FE; lumped: the geometry calibration)"
        return {"geometry_trends.csv": _csv(head, cols, rows)}
    return {}
