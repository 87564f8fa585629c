"""The report's ``transmission`` and ``load_path`` steps (docs/transmission.md).

Per thesis case and for the rigid incus–stapes connection: the stapes velocity per
ear-canal pressure H_V, the umbo velocity, α, β and the pedicle's share, from one reduced
FE ear each (:func:`isj.fem.ear.reduced_ear.reduced_ear`), checked against direct harmonic
solves; ΔH_V = H_V / H_V,rigid; the lumped ear's ΔH_V beside it; how the ear drives the
joint (:func:`isj.lumped.transmission.load_path`) and how that changes when the cochlear
load, the ligaments and the drum are scaled; the comparison with the cat data that exist
(docs/measurements.md).

With ``[transmission] cavities`` the same reduced ears give the middle-ear cavities' states
(docs/circuit.md §13.3; no new reduction): H_V and ΔH_V per state, and the first case beside the
published cat circuit of Bruce, Sachs & Young (2003) in the same state, per octave band
(docs/circuit.md §13.4) — a published model fitted to cat measurements, not a measurement. These
are new keys; every other number is the open ear's, as before.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from isj.cases import case_by_name
from isj.responses import OCTAVE_BANDS_HZ, band_deviation

#: Scale factors of the load-path study (docs/transmission.md §12.4).
SCALES = (0.1, 10.0)

#: Frequencies (Hz) at which the report and the closing figures quote ΔH_V and the load path.
QUOTE_HZ = (1000.0, 5000.0, 10000.0)


#: How converged each measured drum is (docs/ear.md §5.15, benchmarks/drum_convergence.py): against
#: the finest drum measured (``against_m``), the highest frequency of the benchmark's grid (121
#: log-spaced, 100 Hz–20 kHz) up to which every point agrees, H_V within 1 dB, ΔH_V within 0.1 dB
#: and within 1°, by drum element size (m). The step states the band for the ear's drum when it
#: is one of these, and says it is unmeasured otherwise.
DRUM_CONVERGENCE = {
    "against_m": 0.075e-3,
    "source": "benchmarks/drum_convergence.py (docs/ear.md 5.15): against the finest drum measured, 0.075 mm",
    "drums": {
        0.25e-3: {"h_v_1db_hz": 2510.7, "delta_0p1db_hz": 3272.2, "delta_1deg_hz": 3735.7},
        0.18e-3: {"h_v_1db_hz": 3904.3, "delta_0p1db_hz": 4457.3, "delta_1deg_hz": 7244.3},
        0.125e-3: {"h_v_1db_hz": 19136.2, "delta_0p1db_hz": 9867.9, "delta_1deg_hz": 19136.2},
        0.09e-3: {"h_v_1db_hz": 20000.0, "delta_0p1db_hz": 20000.0, "delta_1deg_hz": 20000.0},
    },
}

#: The ``[transmission] cavities`` choices and the cavity states each computes beside the open ear.
CAVITY_CHOICES = {"open": ("open",), "intact": ("intact",), "both": ("open", "intact")}


def cavity_states(choice: str) -> tuple[str, ...]:
    """The cavity states (:data:`isj.cavities.CAVITY_STATES`) the ``[transmission] cavities`` choice names."""
    if choice not in CAVITY_CHOICES:
        raise ValueError(f"transmission.cavities = {choice!r}: must be one of {', '.join(CAVITY_CHOICES)}")
    return CAVITY_CHOICES[choice]


def quote_indices(freq_hz: np.ndarray) -> list[int]:
    """Indices of the band's frequencies nearest :data:`QUOTE_HZ` (those inside the band)."""
    f = np.asarray(freq_hz)
    return [int(np.argmin(np.abs(np.log(f / q)))) for q in QUOTE_HZ if f[0] <= q <= f[-1]]


def _ri(a) -> list:
    a = np.asarray(a)
    return np.stack([a.real, a.imag], axis=-1).tolist()


def _db(x) -> np.ndarray:
    return 20 * np.log10(np.abs(x))


def _deg(x) -> np.ndarray:
    return np.degrees(np.angle(x))


def _columns(resp) -> dict:
    """The reduced ear's response as name → complex (n_freq,) array."""
    return {n: resp.response[:, i, 0] for i, n in enumerate(resp.output_names)}


#: Where the fast ear's agreement with the FE ear is quoted (Hz): its targets hold to 10 kHz
#: (docs/fast_ear.md §14); the band above is stated beside.
FAST_EAR_TARGET_BAND_HZ = 10e3


def fe_band(ctx, freq_hz: np.ndarray) -> tuple[dict, dict, dict, dict]:
    """H_V etc. per case and rigid over ``freq_hz``, the checks, and per ear the cavity states'
    data (:func:`cavity_columns`).

    The rigid connection is one FE reduction. With ``cases_from = "fast"`` each case comes from
    the fast ear (:mod:`isj.fem.ear.fast_ear`, built once per mesh and ear and cached) when the
    fast ear covers its materials, else (and with "fe") from its own FE reduction. The checks
    are :func:`fe_checks`'.
    """
    from isj.fem.batch import shared_model
    from isj.fem.ear import reduced_ear as es
    from isj.fem.ear.fast_ear import fast_ear, stored_fast_ear
    from isj.fem.ear.shared import shared_ear

    cfg, t = ctx.config, ctx.config.transmission
    damping = cfg.sweep.damping_model()
    states = cavity_states(t.cavities)
    base = cfg.design.materials()
    drum = cfg.mesh.drum_mesh_size_m
    ear = shared_ear(ctx.settings, drum)  # the ear step's ears, built once per report
    rigid_model = shared_ear(ctx.settings, drum, rigid=True)
    rigid = es.reduced_ear(rigid_model, base, cfg.ear, fmax_hz=t.fmax_hz)
    out = {"rigid": _columns(rigid.frequency_response(freq_hz, damping))}
    cav = {"rigid": cavity_columns(rigid, freq_hz, damping, states)}
    info = {"rigid": {"model": "fe", "n_dofs": rigid.n_dofs}}
    fast = fast_ear(ear, cfg.ear, fmax_hz=t.fmax_hz) if t.cases_from == "fast" else None
    from tqdm import tqdm

    bar = tqdm(t.cases, desc="whole ear over the band", unit="case", disable=not ctx.progress, leave=False)
    first_rom = None
    for i, name in enumerate(bar):
        mats = case_by_name(name).materials(base)
        if fast is not None and fast.covers(mats):
            out[name], cav[name] = fast_columns(fast, mats, freq_hz, damping, states)
            info[name] = {"model": "fast", "n_dofs": fast.n_dofs}  # no seconds: same inputs, same JSON
            continue
        rom = es.reduced_ear(ear, mats, cfg.ear, fmax_hz=t.fmax_hz)
        out[name] = _columns(rom.frequency_response(freq_hz, damping))
        cav[name] = cavity_columns(rom, freq_hz, damping, states)
        info[name] = {"model": "fe", "n_dofs": rom.n_dofs}
        first_rom = rom if i == 0 else first_rom
    checks = fe_checks(ctx, ear, fast, rigid, first_rom, freq_hz, out)
    if t.sliding_cases:  # the same ear with the sliding joint (docs/model.md §2.12)
        sliding_settings = ctx.settings | {"joint": "sliding"}
        fast_sliding = None
        if t.cases_from == "fast":
            # the sliding joint's own fast ear (shipped for the default report, docs/fast_ear.md
            # §14.7): when it is stored, its whole ear is not built (its joint is the sliding step's)
            sliding_joint, _ = shared_model(sliding_settings)
            fast_sliding = stored_fast_ear(ear, cfg.ear, fmax_hz=t.fmax_hz, joint=sliding_joint)
            if fast_sliding is None:
                fast_sliding = fast_ear(shared_ear(sliding_settings, drum), cfg.ear, fmax_hz=t.fmax_hz)
        for name in t.sliding_cases:
            mats, col = case_by_name(name).materials(base), f"{name}_sliding"
            if fast_sliding is not None and fast_sliding.covers(mats):
                out[col], cav[col] = fast_columns(fast_sliding, mats, freq_hz, damping, states)
                info[col] = {"model": "fast", "n_dofs": fast_sliding.n_dofs}
                continue
            rom = es.reduced_ear(shared_ear(sliding_settings, drum), mats, cfg.ear, fmax_hz=t.fmax_hz)
            out[col] = _columns(rom.frequency_response(freq_hz, damping))
            cav[col] = cavity_columns(rom, freq_hz, damping, states)
            info[col] = {"model": "fe", "n_dofs": rom.n_dofs}
    return out, info, checks, cav


def fast_columns(fast, mats, freq_hz, damping, states) -> tuple[dict, dict]:
    """One case's columns (as :func:`_columns`) and cavity data (as :func:`cavity_columns`) from
    the fast ear: H_V, the umbo's velocity, α, β and the pedicle's share β / (α + β)."""
    resp = fast.frequency_response(freq_hz, mats, damping)
    c = {n: resp.response[:, i, 0] for i, n in enumerate(resp.output_names)}
    a, b = c["alpha_rad"], c["beta_rad"]
    cols = {k: c[k] for k in ("stapes_velocity_m_s", "umbo_velocity_m_s", "alpha_rad", "beta_rad")}
    cols["pedicle_share"] = np.where(a + b != 0, b / np.where(a + b != 0, a + b, 1), np.nan)
    cav = {"drum_volume_m3": fast.drum_volume_m3(freq_hz, mats, damping)}
    if "intact" in states:
        resp = fast.frequency_response(freq_hz, mats, damping, cavities="intact")
        cav["intact"] = resp.response[:, resp.output_names.index("stapes_velocity_m_s"), 0]
    return cols, cav


def _agreement(freq_hz, a, b) -> dict:
    """Largest |20 log10 |a/b|| (dB) and |∠(a/b)| (deg), to :data:`FAST_EAR_TARGET_BAND_HZ` and
    over the whole band, with the frequencies where they occur."""
    f = np.asarray(freq_hz)
    r = np.asarray(a) / np.asarray(b)
    out = {}
    for band, sel in (("to_10khz", f <= FAST_EAR_TARGET_BAND_HZ), ("band", np.ones(f.size, bool))):
        db, deg = np.abs(_db(r[sel])), np.abs(_deg(r[sel]))
        out[band] = {
            "max_db": float(db.max()),
            "max_db_at_hz": float(f[sel][np.argmax(db)]),
            "max_deg": float(deg.max()),
            "max_deg_at_hz": float(f[sel][np.argmax(deg)]),
        }
    return out


def fe_checks(ctx, ear, fast, rigid, first_rom, freq_hz, out) -> dict:
    """The checks of the step's ears: the fast ear against the FE reduction of the rigid connection
    over the band, and the first case against ``fe_checks`` direct harmonic solves
    (:func:`isj.fem.ear.reduced_ear.check_against_direct`): the fast ear itself when it gave that
    case, else its FE reduction. With ``fast_ear_check = "band"`` the first case is also reduced
    with FE, the fast ear compared with that reduction over the band (H_V and ΔH_V) and the
    reduction checked against the direct solves."""
    from isj.fem.ear import reduced_ear as es

    cfg, t = ctx.config, ctx.config.transmission
    damping = cfg.sweep.damping_model()
    first = t.cases[0]
    mats = case_by_name(first).materials(cfg.design.materials())
    checks = {}
    if first_rom is None:  # the first case came from the fast ear
        fe_rigid = out["rigid"]["stapes_velocity_m_s"]
        fast_rigid = fast.rigid(freq_hz, damping)
        chk = {
            "what": "fast ear against the FE reduced ears: the rigid H_V, and with fast_ear_check = band the "
            "first case's H_V and dH_V (dB, deg)",
            "case": first,
            "rigid_h_v": _agreement(freq_hz, fast_rigid, fe_rigid),
            "targets_to_10khz": {"h_v_db": 0.5, "h_v_deg": 3.0, "delta_db": 0.1, "delta_deg": 1.0},
        }
        if t.fast_ear_check == "band":  # the first case's own FE reduction, over the band
            first_rom = es.reduced_ear(ear, mats, cfg.ear, fmax_hz=t.fmax_hz)
            fe_first = _columns(first_rom.frequency_response(freq_hz, damping))["stapes_velocity_m_s"]
            fast_first = out[first]["stapes_velocity_m_s"]
            chk["h_v"] = _agreement(freq_hz, fast_first, fe_first)
            chk["delta_h_v"] = _agreement(freq_hz, fast_first / fast_rigid, fe_first / fe_rigid)
        checks["fast_ear"] = chk
    if t.fe_checks:
        f_chk = es.check_frequencies_hz(t.fmin_hz, t.fmax_hz, t.fe_checks)
        checked = first_rom if first_rom is not None else fast
        checks |= es.check_against_direct(ear, checked, f_chk, damping, mats, cfg.ear)
        checks["case"] = first
        checks["checked_model"] = "fe" if first_rom is not None else "fast"
        for k in ("direct_seconds", "direct_seconds_per_frequency"):  # timings live in run.json
            checks.pop(k, None)
    return checks


def cavity_columns(rom, freq_hz, damping, states) -> dict:
    """One reduced ear's cavity data (docs/circuit.md §13.3), no new reduction.

    ``drum_volume_m3``: the open ear's drum volume displacement per Pa (m³/Pa, complex), from
    which the cavity factor follows; ``intact``: H_V with the cavities intact (m/s per Pa), when
    ``states`` holds "intact". The open ear's H_V is the step's own column.
    """
    out = {"drum_volume_m3": rom.with_cavities("open").drum_volume_m3(freq_hz, damping)}
    if "intact" in states:
        resp = rom.with_cavities("intact").frequency_response(freq_hz, damping)
        out["intact"] = _columns(resp)["stapes_velocity_m_s"]
    return out


def _stapes(fe: dict, cav: dict, name: str, state: str) -> np.ndarray:
    return fe[name]["stapes_velocity_m_s"] if state == "open" else cav[name][state]


def cavity_section(cfg, freq_hz, fe: dict, cav: dict, cases: list[str]) -> tuple[dict, dict]:
    """H_V and ΔH_V (against the rigid connection in the same state) per cavity state, JSON and arrays.

    The open ear's numbers are those of the step's other keys; "intact" adds the cavity load of
    :mod:`isj.cavities` (the ear's default state is :data:`isj.cavities.DEFAULT_CAVITIES`).
    """
    from isj.cavities import DEFAULT_CAVITIES

    states = cavity_states(cfg.transmission.cavities)
    iw = 2j * np.pi * np.asarray(freq_hz)
    names = ["rigid", *cases]
    per_state, arrays, quote = {}, {}, []
    for state in states:
        rigid = _stapes(fe, cav, "rigid", state)
        rows = {}
        for name in names:
            v = _stapes(fe, cav, name, state)
            row = {"stapes_velocity_db": _db(v).tolist(), "stapes_velocity_deg": _deg(v).tolist()}
            if name != "rigid":
                d = v / rigid
                row |= {"delta_hv_db": _db(d).tolist(), "delta_hv_deg": _deg(d).tolist()}
            rows[name] = row
            arrays[f"{state}_{name}_stapes_velocity_m_s"] = v
        per_state[state] = rows
    for i in quote_indices(freq_hz):
        q = {"freq_hz": float(freq_hz[i])}
        for state in states:
            q[state] = {
                "delta_db": {c: per_state[state][c]["delta_hv_db"][i] for c in cases},
                "delta_deg": {c: per_state[state][c]["delta_hv_deg"][i] for c in cases},
            }
        quote.append(q)
    volume = {}
    for name in names:
        u = iw * cav[name]["drum_volume_m3"]
        volume[name] = _ri(u)
        arrays[f"{name}_drum_volume_velocity_m3_s"] = u
    section = {
        "what": (
            "H_V per cavity state: open (no cavity load) and intact (the cavity network of the published "
            "cat circuit behind the drum, docs/circuit.md 13.3); dH_V against the rigid connection in "
            "the same state"
        ),
        "choice": cfg.transmission.cavities,
        "states": list(states),
        "default_cavities": DEFAULT_CAVITIES,
        "ears": names,
        "per_state": per_state,
        "quote": quote,
        "worst_delta_db": {
            s: {c: float(np.max(np.abs(per_state[s][c]["delta_hv_db"]))) for c in cases} for s in states
        },
        "worst_delta_deg": {
            s: {c: float(np.max(np.abs(per_state[s][c]["delta_hv_deg"]))) for c in cases} for s in states
        },
        "open_drum_volume_velocity_m3_s_per_pa_re_im": volume,
    }
    return section, arrays


#: Octave bands of the circuit comparison, from 100 Hz, the last cut at 20 kHz (Hz); the same as
#: How the circuit is labelled wherever it appears.
CIRCUIT_LABEL = "published model (Bruce et al. 2003), not a measurement"


def _curves(u, p) -> dict:
    return {
        "stapes_volume_velocity": {"magnitude": np.abs(u).tolist(), "phase_deg": _deg(u).tolist()},
        "vestibule_gain": {"db": _db(p).tolist(), "phase_deg": _deg(p).tolist()},
    }


def circuit_section(cfg, freq_hz, fe: dict, cav: dict, case: str) -> dict:
    """The ear (``case``) beside the published cat circuit in each cavity state (docs/circuit.md §13.4).

    U_S = A_fp H_V and P_V = Z_C A_fp H_V of the FE ear against the circuit's
    (:class:`isj.lumped.circuit.CatCircuit`) in the same cavity state, per octave band
    (:func:`band_deviation`). The circuit is a published model fitted to cat measurements, not a
    measurement. (Not :mod:`isj.studies.circuit_comparison` itself: that module also holds the
    lumped ear's comparison, and this step reads the FE ear only.)
    """
    from isj.lumped.circuit import CatCircuit

    from isj.cavities import load_circuit_data
    from isj.ear import EarGeometry

    states = cavity_states(cfg.transmission.cavities)
    area = EarGeometry().footplate_area_m2
    z_c = cfg.sweep.damping_model().cochlear_impedance_pa_s_m3
    circuit = CatCircuit.load()
    out = {}
    for s in states:
        c = circuit.frequency_response(freq_hz, s)
        u = area * _stapes(fe, cav, case, s)
        p = z_c * u
        out[s] = {
            "circuit": _curves(c.stapes_volume_velocity_m3_s, c.vestibule_gain),
            "ear": _curves(u, p),
            "deviation_per_band": {
                "stapes_volume_velocity": band_deviation(freq_hz, u, c.stapes_volume_velocity_m3_s),
                "vestibule_gain": band_deviation(freq_hz, p, c.vestibule_gain),
            },
        }
    return {
        "label": CIRCUIT_LABEL,
        "citations": load_circuit_data()["citations"],
        "case": case,
        "ear": f"fe (reduced ear), case {case}",
        "quantities": {"stapes_volume_velocity": "m^3/s/Pa", "vestibule_gain": "Pa/Pa"},
        "bands_hz": [list(b) for b in OCTAVE_BANDS_HZ],
        "freq_hz": np.asarray(freq_hz, float).tolist(),
        "footplate_area_m2": float(area),
        "cochlear_impedance_pa_s_m3": float(z_c),
        "states": out,
    }


def drum_convergence(size_m: float) -> dict:
    """The band in which a drum of element size ``size_m`` (m) is converged (:data:`DRUM_CONVERGENCE`);
    None in each band when that drum was not measured."""
    measured = next((v for k, v in DRUM_CONVERGENCE["drums"].items() if abs(k - size_m) <= 1e-12), None)
    return {
        "drum_mesh_size_m": float(size_m),
        "against_m": DRUM_CONVERGENCE["against_m"],
        "within_1db_up_to_hz": measured["h_v_1db_hz"] if measured else None,
        "delta_within_0p1db_up_to_hz": measured["delta_0p1db_hz"] if measured else None,
        "delta_within_1deg_up_to_hz": measured["delta_1deg_hz"] if measured else None,
        "source": DRUM_CONVERGENCE["source"] if measured else "not measured for this drum",
    }


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
    fe, info, checks, cav = fe_band(ctx, f)
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
    # the cavity states and the published cat circuit: new keys, the ones above unchanged
    cavities, cav_arrays = cavity_section(cfg, f, fe, cav, cases)
    result |= {
        "cavities": cavities,
        "circuit": circuit_section(cfg, f, fe, cav, cases[0]),
        "drum_convergence": drum_convergence(cfg.mesh.drum_mesh_size_m),
    }
    arrays = {"freq_hz": f, "delta": delta, "pedicle_share": share}
    for name, cols in fe.items():
        for k in ("stapes_velocity_m_s", "umbo_velocity_m_s", "alpha_rad", "beta_rad"):
            arrays[f"{name}_{k}"] = cols[k]
    arrays |= {f"cavities_{k}": v for k, v in cav_arrays.items()}
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


def cavity_tables(res: dict, csv) -> dict[str, str]:
    """The cavity states' and the circuit's CSV files from the step's JSON (``csv``: the writer
    ``(header, columns, rows) → text`` of :mod:`reports.csvdata`); none when the result has no cavities."""
    cav, circ = res.get("cavities"), res.get("circuit")
    if not cav or not circ:
        return {}
    f = res["freq_hz"]
    cols, data = ["freq_hz"], [f]
    for state in cav["states"]:
        for name in cav["ears"]:
            row = cav["per_state"][state][name]
            for k in ("stapes_velocity_db", "stapes_velocity_deg", "delta_hv_db", "delta_hv_deg"):
                if k in row:
                    cols.append(f"{state}_{name}_{k}")
                    data.append(row[k])
    for name in cav["ears"]:
        u = np.asarray(cav["open_drum_volume_velocity_m3_s_per_pa_re_im"][name])
        cols += [
            f"open_{name}_drum_volume_velocity_re_m3_s_per_pa",
            f"open_{name}_drum_volume_velocity_im_m3_s_per_pa",
        ]
        data += [u[:, 0], u[:, 1]]
    ccols, cdata = ["freq_hz"], [f]
    order = [s for s in cav["states"] if s in circ["states"]]  # the configured order, not the JSON's
    for state in order:
        st = circ["states"][state]
        for who in ("circuit", "ear"):
            us, pv = st[who]["stapes_volume_velocity"], st[who]["vestibule_gain"]
            ccols += [
                f"{state}_{who}_stapes_volume_velocity_m3_s_per_pa",
                f"{state}_{who}_stapes_volume_velocity_deg",
                f"{state}_{who}_vestibule_gain_db",
                f"{state}_{who}_vestibule_gain_deg",
            ]
            cdata += [us["magnitude"], us["phase_deg"], pv["db"], pv["phase_deg"]]
    keys = [
        "n_freq",
        "mean_abs_db",
        "max_abs_db",
        "max_abs_db_at_hz",
        "mean_db",
        "mean_abs_deg",
        "max_abs_deg",
    ]
    bands = [
        [state, q, *b["band_hz"]] + [b.get(k, "") for k in keys]
        for state in order
        for q, rows in circ["states"][state]["deviation_per_band"].items()
        for b in rows
    ]
    what = "published model (Bruce et al. 2003), not a measurement"
    return {
        "transmission_cavities.csv": csv(
            "FE whole ear per cavity state: H_V (dB re 1 m/s/Pa, deg) and dH_V against the rigid "
            "connection in the same state; the open ear's drum volume velocity (m^3/s/Pa)",
            cols,
            zip(*data, strict=True),
        ),
        "circuit.csv": csv(
            f"the ear (case {circ['case']}) and the cat circuit ({what}): U_S = A_fp H_V, P_V / P_EC",
            ccols,
            zip(*cdata, strict=True),
        ),
        "circuit_bands.csv": csv(
            f"deviation ear / cat circuit ({what}) per octave band, same cavity state",
            ["cavities", "quantity", "band_lo_hz", "band_hi_hz", *keys],
            bands,
        ),
    }
