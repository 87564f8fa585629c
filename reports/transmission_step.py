"""The report's ``transmission`` and ``load_path`` steps (docs/transmission.md).

Per thesis case and for the rigid incus–stapes connection: the stapes velocity per
ear-canal pressure H_V, the umbo velocity, α, β and the pedicle's share, from one reduced
FE ear each (:func:`isj.fem.ear.reduced_ear.reduced_ear`), checked against direct harmonic
solves; ΔH_V = H_V / H_V,rigid; the lumped ear's ΔH_V beside it; how the ear drives the
joint (:func:`isj.lumped.transmission.load_path`) and how that changes when the cochlear
load, the ligaments and the drum are scaled; the comparison with the cat data that exist
(docs/measurements.md).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from isj.cases import case_by_name

#: Scale factors of the load-path study (docs/transmission.md §12.4).
SCALES = (0.1, 10.0)

#: Frequencies (Hz) at which the report and the closing figures quote ΔH_V and the load path.
QUOTE_HZ = (1000.0, 5000.0, 10000.0)


def quote_indices(freq_hz: np.ndarray) -> list[int]:
    """Indices of the band's frequencies nearest :data:`QUOTE_HZ` (those inside the band)."""
    f = np.asarray(freq_hz)
    return [int(np.argmin(np.abs(np.log(f / q)))) for q in QUOTE_HZ if f[0] <= q <= f[-1]]


def _ri(a) -> list:
    a = np.asarray(a)
    return np.stack([a.real, a.imag], axis=-1).tolist()


def _columns(resp) -> dict:
    """The reduced ear's response as name → complex (n_freq,) array."""
    return {n: resp.response[:, i, 0] for i, n in enumerate(resp.output_names)}


def fe_band(ctx, freq_hz: np.ndarray) -> tuple[dict, dict, dict]:
    """FE H_V etc. per case and rigid over ``freq_hz``, and the reduction's direct checks."""
    from isj.fem.batch import shared_model
    from isj.fem.ear import reduced_ear as es
    from isj.fem.ear.middle_ear import MiddleEarModel

    cfg, t = ctx.config, ctx.config.transmission
    damping = cfg.sweep.damping_model()
    base = cfg.design.materials()
    joint, _ = shared_model(ctx.settings)
    ear = MiddleEarModel(joint=joint)
    rigid_model = MiddleEarModel(joint=None, geometry=ear.geometry)
    rigid = es.reduced_ear(rigid_model, base, cfg.ear, fmax_hz=t.fmax_hz)
    out = {"rigid": _columns(rigid.response(freq_hz, damping))}
    info = {"rigid": {"n_dofs": rigid.n_dofs}}
    checks = {}
    from tqdm import tqdm

    bar = tqdm(t.cases, desc="FE ear over the band", unit="case", disable=not ctx.progress, leave=False)
    for i, name in enumerate(bar):
        mats = case_by_name(name).materials(base)
        rom = es.reduced_ear(ear, mats, cfg.ear, fmax_hz=t.fmax_hz)
        out[name] = _columns(rom.response(freq_hz, damping))
        info[name] = {"n_dofs": rom.n_dofs}  # no seconds: the same inputs give the same JSON
        if i == 0 and t.fe_checks:
            f_chk = es.check_frequencies_hz(t.fmin_hz, t.fmax_hz, t.fe_checks)
            checks = es.check_against_direct(ear, rom, f_chk, damping, mats, cfg.ear)
            checks["case"] = name
            for k in ("direct_seconds", "direct_seconds_per_frequency"):  # timings live in run.json
                checks.pop(k, None)
    if t.sliding_cases:  # the same ear with the sliding joint (docs/model.md §2.12)
        from isj.fem.model import PedicleJointModel

        mesh = cfg.mesh
        jm = PedicleJointModel(cfg.geometry, order=mesh.order, resolution=mesh.resolution, joint="sliding")
        sliding = MiddleEarModel(joint=jm)
        for name in t.sliding_cases:
            rom = es.reduced_ear(sliding, case_by_name(name).materials(base), cfg.ear, fmax_hz=t.fmax_hz)
            out[f"{name}_sliding"] = _columns(rom.response(freq_hz, damping))
            info[f"{name}_sliding"] = {"n_dofs": rom.n_dofs}
    return out, info, checks


def scaled_ear_options(cfg, what: str, factor: float) -> dict:
    """Lumped-ear options with ``what`` (cochlea, annular, ligaments, drum) scaled by ``factor``."""
    damping, ear = cfg.sweep.damping_model(), cfg.ear
    if what == "cochlea":
        damping = damping.replace(cochlear_impedance_pa_s_m3=damping.cochlear_impedance_pa_s_m3 * factor)
    elif what == "annular":
        ear = dataclasses.replace(
            ear,
            annular_out_of_plane_n_m=ear.annular_out_of_plane_n_m * factor,
            annular_in_plane_n_m=ear.annular_in_plane_n_m * factor,
        )
    elif what == "ligaments":
        ear = dataclasses.replace(
            ear,
            malleus_ligament_n_m=ear.malleus_ligament_n_m * factor,
            incudal_lateral_n_m=ear.incudal_lateral_n_m * factor,
            incudal_medial_n_m=ear.incudal_medial_n_m * factor,
        )
    elif what == "drum":
        ear = dataclasses.replace(ear, drum_e_pa=ear.drum_e_pa * factor)
    elif what != "default":
        raise ValueError(what)
    return {"damping": damping, "ear_materials": ear}


def load_path_study(ctx) -> list[dict]:
    """The lumped ear's load path and β's sensitivity to the pedicle, default and scaled."""
    from isj.lumped.api import LumpedModel
    from isj.lumped.transmission import ALL_DRUM_MODES, load_path, pedicle_sensitivity, thevenin_sensitivity

    cfg = ctx.config
    lm = LumpedModel(ctx.calibration, cfg.geometry)
    base = cfg.design.materials()
    f = np.array((0.0,) + QUOTE_HZ)
    rows = []
    variants = [("default", 1.0)] + [
        (w, s) for w in ("cochlea", "annular", "ligaments", "drum") for s in SCALES
    ]
    for what, factor in variants:
        opts = scaled_ear_options(cfg, what, factor)
        ear = lm.ear(base, drum_modes=ALL_DRUM_MODES, **opts)
        lp = load_path(ear, f)
        sens = pedicle_sensitivity(np.where(f > 0, f, 1e-3), model=lm, base=base, **opts)
        thev = thevenin_sensitivity(f, model=lm, base=base, **opts)
        rows.append(
            {
                "scaled": what,
                "factor": factor,
                "freq_hz": f.tolist(),
                "env_ratio": lp["env_ratio"].tolist(),
                "k_joint_n_m_per_rad_re_im": _ri(lp["k_joint"]),
                "k_env_n_m_per_rad_re_im": _ri(lp["k_env"]),
                "beta_rad_per_pa_re_im": _ri(lp["q"][:, 1]),
                "beta_force_driven_rad_per_pa_re_im": _ri(lp["q_force_driven"][:, 1]),
                "ear_beta_sensitivity": sens["ear_beta"].tolist(),
                "ear_alpha_sensitivity": sens["ear_alpha"].tolist(),
                "ear_stapes_sensitivity": sens["ear_stapes"].tolist(),
                "isolated_beta_sensitivity": sens["isolated_beta"],
                "thevenin_beta_sensitivity": thev["ear_beta"].tolist(),
                "force_driven_beta_sensitivity": thev["force_driven_beta"].tolist(),
            }
        )
    return rows


def vestibule_gain(cfg, freq_hz, stapes_velocity) -> np.ndarray:
    """Scala-vestibuli pressure per ear-canal pressure, Z_C A_fp H_V (Pa/Pa, complex)."""
    from isj.ear import EarGeometry

    z_c = cfg.sweep.damping_model().cochlear_impedance_pa_s_m3
    return z_c * EarGeometry().footplate_area_m2 * np.asarray(stapes_velocity)


def cat_comparison(cfg, freq_hz, fe: dict, first: str) -> list[dict]:
    """The model against every cat series it has a counterpart of (docs/measurements.md §9.6)."""
    # not plain "compare": the step cache's import tracer would take it for Context.compare
    from isj.measurements import compare as compare_series
    from isj.measurements import load_cat_measurements

    out = []
    series = {s.name: s for s in load_cat_measurements()}
    s = series.get("nedzelnitsky1980_vestibule_pressure_gain_max")
    if s is not None and cfg.sweep.damping_model().cochlear_impedance_pa_s_m3 > 0:
        for name in ("rigid", first):
            g = vestibule_gain(cfg, freq_hz, fe[name]["stapes_velocity_m_s"])
            r = compare_series(s, freq_hz, g)
            out.append(
                _plain(r) | {"series": s.name, "model": name, "model_quantity": "Z_C A_fp H_V (Pa/Pa)"}
            )
    return out


def _plain(d: dict) -> dict:
    def conv(v):
        if isinstance(v, np.ndarray):
            return v.tolist()
        if isinstance(v, np.generic):
            return v.item()
        if isinstance(v, dict):
            return {k: conv(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [conv(x) for x in v]
        return v

    return {k: conv(v) for k, v in d.items()}


def transmission_step(ctx) -> tuple[dict, dict]:
    """FE H_V per case and rigid over the band, ΔH_V, the direct checks, the cat data (FE only)."""
    cfg, t = ctx.config, ctx.config.transmission
    f = np.geomspace(t.fmin_hz, t.fmax_hz, t.n_freq)
    fe, info, checks = fe_band(ctx, f)
    cases = list(t.cases) + [f"{c}_sliding" for c in t.sliding_cases]
    rigid_v = fe["rigid"]["stapes_velocity_m_s"]
    delta = np.column_stack([fe[c]["stapes_velocity_m_s"] / rigid_v for c in cases])
    share = np.column_stack([fe[c]["pedicle_share"] for c in cases])
    quote = []
    for i in quote_indices(f):
        quote.append(
            {
                "freq_hz": float(f[i]),
                "rigid_stapes_velocity_m_s_per_pa": [float(rigid_v[i].real), float(rigid_v[i].imag)],
                "delta_db": {c: float(20 * np.log10(abs(delta[i, k]))) for k, c in enumerate(cases)},
                "delta_deg": {c: float(np.degrees(np.angle(delta[i, k]))) for k, c in enumerate(cases)},
                "pedicle_share_abs": {c: float(abs(share[i, k])) for k, c in enumerate(cases)},
            }
        )
    worst = np.abs(20 * np.log10(np.abs(delta)))
    worst_deg = np.abs(np.degrees(np.angle(delta)))
    result = {
        "cases": cases,
        "freq_hz": f.tolist(),
        "fe_reductions": info,
        "fe_checks": checks,
        "quote": quote,
        "worst_delta_db": {c: float(worst[:, k].max()) for k, c in enumerate(cases)},
        "worst_delta_deg": {c: float(worst_deg[:, k].max()) for k, c in enumerate(cases)},
        "cat": cat_comparison(cfg, f, fe, cases[0]),
        "damping": cfg.sweep.damping_model().to_dict(),
    }
    arrays = {"freq_hz": f, "delta": delta, "pedicle_share": share}
    for name, cols in fe.items():
        for k in ("stapes_velocity_m_s", "umbo_velocity_m_s", "alpha_rad", "beta_rad"):
            arrays[f"{name}_{k}"] = cols[k]
    return result, arrays


def load_path_step(ctx) -> tuple[dict, dict]:
    """The lumped ear beside the FE one: its ΔH_V per case, and how the ear drives the joint.

    A step of its own, so that a change of the lumped model recomputes only this, not the
    FE reductions of :func:`transmission_step`.
    """
    from isj.lumped.api import LumpedModel
    from isj.lumped.transmission import transmission

    cfg, t = ctx.config, ctx.config.transmission
    f = np.geomspace(t.fmin_hz, t.fmax_hz, t.n_freq)
    cases = list(t.cases)
    lumped = transmission(
        f,
        [case_by_name(c) for c in cases],
        model=LumpedModel(ctx.calibration, cfg.geometry),
        base=cfg.design.materials(),
        damping=cfg.sweep.damping_model(),
        ear_materials=cfg.ear,
    )
    quote = []
    for i in quote_indices(f):
        quote.append(
            {
                "freq_hz": float(f[i]),
                "lumped_delta_db": {c: float(lumped.delta_db[i, k]) for k, c in enumerate(cases)},
                "lumped_delta_deg": {c: float(lumped.delta_deg[i, k]) for k, c in enumerate(cases)},
            }
        )
    result = {"cases": cases, "quote": quote, "load_path": load_path_study(ctx)}
    return result, {"freq_hz": f, "lumped_delta": lumped.delta}
