"""``isj ear solve|cases|sweep``: the whole cat middle ear with the joint model inside."""

from __future__ import annotations

import argparse
import time

from isj.design import Materials
from isj.errors import InvalidParameter, UsageError

from . import _common as c
from .sweep import add_band_options, add_damping_options, check_sweep_finite, damping_from_args, sweep_setup

#: What ``isj ear sweep`` writes into --out; a folder holding anything else is refused.
EAR_SWEEP_FILES = frozenset({"ear_sweep.csv", "ear_sweep.npz", "ear_bode.png", "ear_sweep.json"})


def _add_ear_options(p: argparse.ArgumentParser) -> None:
    c.add_moduli_options(p, "joint model's ")
    lo, hi = c.MODULUS_RANGE_PA
    p.add_argument(
        "--drum-e",
        metavar="PA",
        type=c.modulus_option("--drum-e"),
        default=20e6,
        help=f"eardrum modulus (Pa, in [{lo:g}, {hi:g}]; default 20e6)",
    )
    p.add_argument("--rigid-joint", action="store_true", help="replace the joint model by a rigid connection")
    c.add_order_resolution(p, "joint mesh")
    c.add_json_option(p)


def register(sub) -> None:
    """Add ``isj ear`` and its commands to the top-level subparsers ``sub``."""
    ear = sub.add_parser("ear", help="the whole cat middle ear with the joint inside, static")
    esub = ear.add_subparsers(dest="ear_command", required=True, parser_class=c.Parser)
    p = esub.add_parser("solve", help="static response per Pa of ear-canal pressure")
    _add_ear_options(p)
    p.set_defaults(func=solve)
    p = esub.add_parser("cases", help="the seven thesis cases inside the ear")
    _add_ear_options(p)
    p.set_defaults(func=cases)
    p = esub.add_parser("sweep", help="lumped ear's frequency response per Pa, FE static and harmonic checks")
    _add_ear_options(p)
    # the FE ear's first modes are eardrum modes (1.66 kHz up): the lumped drum's 40 component
    # modes (to 6.1 kHz) hold within 1 dB and 10 deg of the FE ear to 5 kHz (docs/ear.md 5.10);
    # its single static shape (--drum-modes 0) only below 1.5 kHz
    add_band_options(
        p,
        5000.0,
        " with the drum's modes, 1500 with --drum-modes 0 (below the FE eardrum modes); higher "
        "bands up to the limit are allowed, the FE checks say how far off; 20000 with --fe",
        model="ear",
    )
    p.set_defaults(fmax_hz=None)  # resolved by sweep(): 5 kHz, 1.5 kHz without modes, 20 kHz --fe
    p.add_argument(
        "--drum-modes",
        type=c.int_option("--drum-modes", lo=0, hi=240),
        default=40,
        metavar="N",
        help="the lumped drum's lowest N fixed-interface modes (shipped for the default anatomy, "
        "docs/ear.md 5.10), in [0, 240]; 0: its one static shape (default 40, to 6.1 kHz)",
    )
    p.add_argument(
        "--fe-checks",
        type=int,
        default=2,
        help="FE whole-ear harmonic spot checks K, log-spaced inside the band, in [0, 50] (default 2)",
    )
    p.add_argument(
        "--tolerance",
        type=c.float_option("--tolerance", lo=0.0),
        default=0.1,
        help="largest relative error of the umbo and stapes against the FE ear, static and at each "
        "FE check (complex, |lumped/FE - 1|; default 0.1)",
    )
    add_damping_options(p)
    p.add_argument(
        "--fe",
        action="store_true",
        help="the FE whole ear with the joint inside at every frequency, through its reduced model "
        "(fem/ear/reduced_ear.py), instead of the lumped ear; checked against direct FE harmonic solves "
        "at max(--fe-checks, 3) frequencies, both band ends included, within 1 %% in magnitude and "
        "1 deg in phase (exit 1 otherwise)",
    )
    p.add_argument(
        "--fast",
        action="store_true",
        help="the fast ear (fem/ear/fast_ear.py, docs/fast_ear.md): the FE ear reduced once for every "
        "design of the calibrated domain (shipped for the default mesh), H_V and dH_V against the rigid "
        "connection in milliseconds; up to 20000 Hz, no FE checks (its agreement with the FE ear is "
        "measured in docs/fast_ear.md 14.3)",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        default="ear_sweep",
        help="output folder (default ./ear_sweep): new, empty or a previous ear sweep's, replaced as a whole",
    )
    p.set_defaults(func=sweep, nu=None)  # None: the calibration's (check_nu), the default with --fe


def _check_joint(args) -> None:
    """Before any model is built: the embedded joint model's estimated size (none if rigid)."""
    if not args.rigid_joint:
        c.check_model_size(None, args.order, args.resolution)
    c.check_caches(args, "mesh")


def _ear_model(args):
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.model import PedicleJointModel

    from ..ear import EarMaterials

    ear_materials = EarMaterials(drum_e_pa=args.drum_e)
    joint = None if args.rigid_joint else PedicleJointModel(order=args.order, resolution=args.resolution)
    return MiddleEarModel(joint=joint), ear_materials


def _ear_lines(name: str, r) -> list[str]:
    fp = r.footplate_m_per_pa
    lines = [
        f"{name}: umbo {r.umbo_m_per_pa * 1e9:.2f} nm/Pa, "
        f"eardrum max {r.eardrum_max_m_per_pa * 1e9:.2f} nm/Pa",
        f"  footplate (x, y, z) = ({fp[0] * 1e9:.3f}, {fp[1] * 1e9:.3f}, {fp[2] * 1e9:.3f}) nm/Pa, "
        f"piston {r.footplate_piston_m_per_pa * 1e9:.3f} nm/Pa",
    ]
    if r.alpha_rad_per_pa is not None:
        lines.append(
            f"  alpha = {r.alpha_rad_per_pa * 1e6:.4f} urad/Pa, beta = {r.beta_rad_per_pa * 1e6:.4f} urad/Pa"
        )
    return lines


def solve(args) -> int:
    materials = c.materials(args)
    _check_joint(args)
    model, ear_materials = _ear_model(args)
    res = model.static(materials, ear_materials)
    out = res.to_dict() | {"n_dofs": model.n_dofs, "rigid_joint": args.rigid_joint}
    c.check_finite(out, c.design_inputs(args))
    if args.json:
        c.print_json(out)
        return 0
    print("\n".join(_ear_lines("whole ear, per Pa of ear-canal pressure", res)))
    ax = res.rotation_axis
    print(
        f"  axis: point {[round(v * 1e3, 4) for v in ax['point_m']]} mm, "
        f"direction {[round(v, 4) for v in ax['direction']]}"
    )
    print(f"  {model.n_dofs} dofs, solve {res.timings_s['total']:.2f} s")
    return 0


def cases(args) -> int:
    from ..cases import THESIS_CASES

    base = Materials(nu=args.nu)
    _check_joint(args)
    model, ear_materials = _ear_model(args)
    res = {case.name: model.static(case.materials(base), ear_materials) for case in THESIS_CASES}
    rows = [{"case": k} | r.to_dict() for k, r in res.items()]
    c.check_finite(rows, f"--nu {args.nu:g}, --drum-e {args.drum_e:g}")
    if args.json:
        c.print_json(rows)
    else:
        for k, r in res.items():
            print("\n".join(_ear_lines(k, r)))
    return 0


def sweep(args) -> int:
    """Lumped ear's frequency response per Pa (CSV, NPZ, Bode PNG, JSON), FE whole-ear spot checks.

    The options are checked here; :func:`isj.studies.ear_workflow.run_ear_sweep` computes.
    """
    import numpy as np

    from isj.calibration.checks import warn_outside_domain
    from isj.studies.ear_workflow import run_ear_sweep

    from ..atomic import replace_dir
    from ..ear import EarMaterials
    from ..provenance import write_run_record
    from .lumped import check_nu

    if args.fmax_hz is None:
        args.fmax_hz = 20e3 if args.fe or args.fast else (5000.0 if args.drum_modes else 1500.0)
    if args.fe and args.fast:
        raise UsageError("--fe and --fast: choose one ear (the reduced FE ear or the fast ear)")
    if args.fe:
        return _fe_sweep(args)
    if args.fast:
        return _fast_sweep(args)
    out, cal, m, fe_freq = sweep_setup(args, EAR_SWEEP_FILES, "ear")
    if not args.rigid_joint:  # the lumped joint inside the lumped ear holds at its calibration's ratio
        check_nu(cal, args.nu)
    _check_joint(args)
    if not args.rigid_joint:
        warn_outside_domain(cal, c.moduli(m))
    run = run_ear_sweep(
        cal,
        np.geomspace(args.fmin_hz, args.fmax_hz, args.n),
        m,
        EarMaterials(drum_e_pa=args.drum_e),
        damping_from_args(args),
        fe_freq,
        rigid_joint=args.rigid_joint,
        drum_modes=args.drum_modes,
        tolerance=args.tolerance,
        order=args.order,
        resolution=args.resolution,
        check_lumped=lambda sw: check_sweep_finite(sw, args, ("static", sw.static)),
    )
    sw, summary, errors, fe_vals = run.sweep, run.summary, run.static_errors, run.fe_static
    c.check_finite(summary, c.design_inputs(args))
    with replace_dir(out) as staging:  # the four files appear together or not at all
        _write(args, staging, sw, run.check, run.fe_checks, run.delta)
        write_run_record(staging / "ear_sweep.json", args, summary)
    if args.json:
        c.print_json(summary)
    else:
        s = sw.static
        print(
            f"lumped ear {args.fmin_hz:g}-{args.fmax_hz:g} Hz ({args.n} points); natural frequencies "
            + ", ".join(f"{v:.0f} Hz" for v in sw.natural_freq_hz)
        )
        print(
            f"  static: umbo {s[0] * 1e9:.2f} nm/Pa (FE {fe_vals['umbo_m'] * 1e9:.2f}, "
            f"{100 * errors['umbo_m']:.2f} %), stapes {s[1] * 1e9:.2f} nm/Pa "
            f"(FE {fe_vals['stapes_m'] * 1e9:.2f}, {100 * errors['stapes_m']:.2f} %) "
            f"{'ok' if run.check['passed'] else 'EXCEEDS tolerance'}"
        )
        for ck in run.fe_checks:
            verdict = "ok" if ck["passed"] else "EXCEEDS tolerance"
            print(
                f"  FE check at {ck['freq_hz']:.0f} Hz: umbo {100 * ck['umbo_m_rel_error']:.2f} %, "
                f"stapes {100 * ck['stapes_m_rel_error']:.2f} % {verdict}"
            )
        print(f"wrote {out}/ear_sweep.csv, ear_sweep.npz, ear_bode.png, ear_sweep.json")
    if not run.passed:
        return c.fail(f"an FE spot check exceeds the tolerance {args.tolerance:g}")
    return 0


def _write(args, out, sw, check, fe_checks, delta) -> None:
    """ear_sweep.csv, ear_sweep.npz and ear_bode.png (ear_sweep.json comes last, with the summary);
    ``delta``: :func:`isj.responses.delta_columns` of the lumped ear, plain columns at the end."""
    import numpy as np
    from matplotlib.figure import Figure

    from isj.lumped.ear import UNITS
    from isj.lumped.plots import bode

    from ..atomic import atomic_write
    from ._output import write_npz, write_response_csv

    joint_label = "rigid joint" if args.rigid_joint else "calibrated joint"
    delta_text = "; ".join(f"{k} {u}" for k, u in delta["units"].items())
    units = (
        "freq_hz Hz; umbo_m, stapes_m m per Pa of ear-canal pressure; "
        f"alpha_rad, beta_rad rad per Pa; phase deg; {delta_text} (ΔH_V against the rigid "
        f"connection of the same lumped ear); {joint_label}"
    )
    write_response_csv(
        out / "ear_sweep.csv", sw.freq_hz, sw.response, sw.outputs, units, extra=delta["columns"]
    )
    write_npz(
        out / "ear_sweep.npz",
        freq_hz=sw.freq_hz,
        response_per_pa=sw.response,
        static_per_pa=sw.static,
        outputs=np.array(sw.outputs),
        units=np.array([UNITS[k] for k in sw.outputs]),
        natural_freq_hz=sw.natural_freq_hz,
        damping_ratio=sw.damping_ratio,
        **delta["columns"],
    )
    # a Figure of its own: no pyplot state, no backend chosen for the caller
    fig = Figure(figsize=(7, 6))
    axes = fig.subplots(2, 1, sharex=True)
    bode(sw.freq_hz, sw.response[:, :2], [check, *fe_checks], outputs=("umbo_m", "stapes_m"), axes=axes)
    axes[0].set_ylabel("magnitude (m/Pa)")
    axes[0].set_title(
        "lumped cat middle ear per Pa; FE whole ear: static at the lowest frequency, "
        f"{len(fe_checks)} harmonic checks",
        fontsize=9,
    )
    fig.tight_layout()
    atomic_write(out / "ear_bode.png", lambda tmp: fig.savefig(tmp, format="png"))


def _fe_sweep(args) -> int:
    """``--fe``: the FE ear's reduced model at every frequency, checked against direct FE solves."""
    import numpy as np

    from isj.fem.ear import reduced_ear as es
    from isj.responses import delta_columns

    out, _, m, _ = sweep_setup(args, EAR_SWEEP_FILES, "ear", lumped=False)
    _check_joint(args)
    damping = damping_from_args(args)
    freqs = np.geomspace(args.fmin_hz, args.fmax_hz, args.n)
    t0 = time.perf_counter()
    model, ear_materials = _ear_model(args)
    t1 = time.perf_counter()
    rom = es.reduced_ear(model, m, ear_materials, fmax_hz=args.fmax_hz)
    t2 = time.perf_counter()
    resp = rom.frequency_response(freqs, damping)
    t3 = time.perf_counter()
    check_hz = es.check_frequencies_hz(args.fmin_hz, args.fmax_hz, max(args.fe_checks, 3))
    tol = es.CHECK_TOLERANCE  # read here, at the call: 1 % and 1 deg
    chk = es.check_against_direct(model, rom, check_hz, damping, m, ear_materials, tolerance=tol)
    t4 = time.perf_counter()
    names = es.OUTPUTS if not args.rigid_joint else es.OUTPUTS[:7]  # no α, β, share without the joint
    H = np.column_stack([resp[k] for k in names])
    static = rom.static()
    # ΔH_V against the rigid connection of the same ear (one more reduction; none if rigid already)
    h_v = resp["stapes_velocity_m_s"]
    h_v_rigid = h_v
    if not args.rigid_joint:
        rigid_model = model.rigid_connection()
        rigid = es.reduced_ear(rigid_model, m, ear_materials, fmax_hz=args.fmax_hz)
        h_v_rigid = rigid.frequency_response(freqs, damping)["stapes_velocity_m_s"]
    delta = delta_columns(freqs, h_v, h_v_rigid)
    t5 = time.perf_counter()
    summary = {
        "fe": True,
        "n_freq": int(args.n),
        "band_hz": [float(args.fmin_hz), float(args.fmax_hz)],
        "rigid_joint": bool(args.rigid_joint),
        "method": "reduced FE ear (fem/ear/reduced_ear.py): joint condensed onto its rigid bodies, "
        "shells by a rational Krylov basis, damping per part on the projected parts",
        "outputs": list(names),
        "units": [resp.unit(k) for k in names],
        "fe_n_dofs": model.n_dofs,
        "reduced_n_dofs": rom.n_dofs,
        "reduction": {k: v for k, v in rom.info.items() if k not in ("interior", "timings_s")},
        "natural_freq_hz": [float(v) for v in rom.natural_frequencies_hz(6)],
        "damping": damping.to_dict(),
        "static_stapes_m_per_pa": float(static.footplate_m_per_pa @ rom.piston_direction),
        "checks": chk,
        "passed": chk["passed"],
        "delta_h_v": delta["summary"] | {"against": "the rigid connection of the same ear (reduced FE)"},
        "timings_s": {
            "model": t1 - t0,
            "reduction": t2 - t1,
            "sweep": t3 - t2,
            "per_frequency": (t3 - t2) / args.n,
            "checks": t4 - t3,
            "rigid_connection": t5 - t4,
            "total": t5 - t0,
        },
    }
    _write_sweep(args, out, summary, freqs, H, names, chk, delta, "FE ear")
    if args.json:
        c.print_json(summary)
    else:
        _print_fe_sweep(args, out, summary, model, rom, chk)
    if not chk["passed"]:
        return c.fail("the reduced FE ear differs from a direct FE solve by more than 1 % or 1 deg")
    return 0


def _write_sweep(args, out, summary, freqs, H, names, chk, delta, model_label: str) -> None:
    """The FE or fast ear sweep's four files, together or not at all (ear_sweep.json last), once
    every number of ``summary`` and ``H`` is finite."""
    from ..atomic import replace_dir
    from ..provenance import write_run_record

    c.check_finite(summary | {"response": H}, c.design_inputs(args))
    with replace_dir(out) as staging:
        _write_fe(args, staging, freqs, H, names, summary["units"], chk, delta, model_label=model_label)
        write_run_record(staging / "ear_sweep.json", args, summary)


def _print_fe_sweep(args, out, summary, model, rom, chk) -> None:
    ts = summary["timings_s"]
    print(
        f"FE ear {args.fmin_hz:g}-{args.fmax_hz:g} Hz ({args.n} points): {model.n_dofs} dofs reduced to "
        f"{rom.n_dofs}; reduction {ts['reduction']:.1f} s, {1e3 * ts['per_frequency']:.1f} ms per "
        f"frequency, direct solve {chk['direct_seconds_per_frequency']:.1f} s per frequency"
    )
    for ck in chk["checks"]:
        worst = max(v for k, v in ck.items() if k.endswith("_mag_rel_error"))
        ph = max(v for k, v in ck.items() if k.endswith("_phase_error_deg"))
        verdict = "ok" if ck["passed"] else "EXCEEDS 1 % / 1 deg"
        print(
            f"  check at {ck['freq_hz']:.0f} Hz against a direct FE solve: {100 * worst:.2g} %, "
            f"{ph:.2g} deg {verdict}"
        )
    print(f"wrote {out}/ear_sweep.csv, ear_sweep.npz, ear_bode.png, ear_sweep.json")


#: The band of ``--fast`` ends where the fast ear's shells were reduced for (Hz).
FAST_FMAX_HZ = 20e3


def _fast_sweep(args) -> int:
    """``--fast``: one design through the fast ear at every frequency, with ΔH_V against the rigid
    connection of the same ear; the fast ear is read from the cache or the shipped file, else built."""
    import numpy as np

    from isj.fem.ear.fast_ear import fast_ear, fast_ear_sweep

    from ..design_space import DesignSpace

    if args.rigid_joint:
        raise UsageError(
            "--rigid-joint: the fast ear has the joint inside (its dH_V is against the rigid "
            "connection); use --fe --rigid-joint for the rigid ear alone"
        )
    if args.fmax_hz > FAST_FMAX_HZ:
        raise UsageError(f"--fmax-hz = {args.fmax_hz:g}: with --fast must be at most {FAST_FMAX_HZ:g} Hz")
    out, _, m, _ = sweep_setup(args, EAR_SWEEP_FILES, "ear", lumped=False)
    try:
        DesignSpace().designs_from(m)  # the fast ear's domain, before anything is built
    except InvalidParameter as exc:
        raise UsageError(f"--fast: {exc}") from None
    _check_joint(args)
    damping = damping_from_args(args)
    freqs = np.geomspace(args.fmin_hz, args.fmax_hz, args.n)
    t0 = time.perf_counter()
    model, ear_materials = _ear_model(args)
    ear = fast_ear(model, ear_materials, fmax_hz=FAST_FMAX_HZ)
    t1 = time.perf_counter()
    sw = fast_ear_sweep(freqs, m, damping, ear=ear)
    t2 = time.perf_counter()
    resp = sw["response"]
    names = [k for k in resp.output_names if k != "delta_h_v"]
    H = np.column_stack([resp[k] for k in names])
    units = [resp.unit(k) for k in names]
    delta = {k: sw[k] for k in ("columns", "units", "summary")}
    summary = {
        "fast": True,
        "n_freq": int(args.n),
        "band_hz": [float(args.fmin_hz), float(args.fmax_hz)],
        "method": "fast ear (fem/ear/fast_ear.py): the FE ear reduced once for the calibrated domain, "
        "the joint condensed per design through its affine structure (docs/fast_ear.md)",
        "outputs": names,
        "units": units,
        "fe_n_dofs": model.n_dofs,
        "fast_ear_n_dofs": sw["n_dofs"],
        "n_joint_basis": sw["n_joint_basis"],
        "shipped": bool(ear.meta.get("shipped", False)),
        "damping": damping.to_dict(),
        "delta_h_v": delta["summary"] | {"against": "the rigid connection of the same ear (fast ear)"},
        "timings_s": {"model_and_fast_ear": t1 - t0, "sweep": t2 - t1, "total": t2 - t0},
    }
    _write_sweep(args, out, summary, freqs, H, names, None, delta, "fast ear")
    if args.json:
        c.print_json(summary)
    else:
        ds = delta["summary"]
        print(
            f"fast ear {args.fmin_hz:g}-{args.fmax_hz:g} Hz ({args.n} points): {sw['n_dofs']} coordinates "
            f"({sw['n_joint_basis']} of the joint) for {model.n_dofs} FE dofs; ready in "
            f"{summary['timings_s']['model_and_fast_ear']:.1f} s, swept in {1e3 * (t2 - t1):.1f} ms"
        )
        at = ", ".join(
            f"{f} Hz {v['db']:+.3f} dB {v['deg']:+.2f} deg" for f, v in ds["delta_h_v_at_hz"].items()
        )
        print(f"  dH_V against the rigid connection: {at}")
        if "max_abs_delta_h_v_db_to_10khz" in ds:
            print(
                f"  largest |dH_V| to 10 kHz: {ds['max_abs_delta_h_v_db_to_10khz']:.3f} dB at "
                f"{ds['max_abs_delta_h_v_at_hz']:.0f} Hz"
            )
        print(f"wrote {out}/ear_sweep.csv, ear_sweep.npz, ear_bode.png, ear_sweep.json")
    return 0


def _write_fe(args, out, freqs, H, names, units, chk, delta, model_label: str = "FE ear") -> None:
    """ear_sweep.csv, ear_sweep.npz and ear_bode.png of ``--fe`` and ``--fast`` (ear_sweep.json comes
    last). ``chk``: the direct FE checks (:func:`isj.fem.ear.reduced_ear.check_against_direct`), None
    for the fast ear (no checks: empty check arrays, no markers).

    ``delta``: :func:`isj.responses.delta_columns`, H_V and ΔH_V in dB and degrees, as
    plain columns after the complex ones."""
    import numpy as np
    from matplotlib.figure import Figure

    from ..atomic import atomic_write
    from ._output import write_npz, write_response_csv

    joint_label = "rigid joint" if args.rigid_joint else "joint model inside"
    text = "; ".join(f"{k} {u}" for k, u in zip(names, units, strict=True))
    delta_text = "; ".join(f"{k} {u}" for k, u in delta["units"].items())
    header = (
        f"freq_hz Hz; per Pa of ear-canal pressure: {text}; phase deg; {delta_text} "
        f"(ΔH_V against the rigid connection of the same ear); {model_label}, {joint_label}"
    )
    write_response_csv(out / "ear_sweep.csv", freqs, H, names, header, extra=delta["columns"])
    checks = chk["checks"] if chk is not None else []  # the fast ear has no direct checks
    keys = [
        k for k in ("umbo_m", "stapes_m", "alpha_rad", "beta_rad") if checks and f"direct_{k}" in checks[0]
    ]
    direct = np.array([[complex(*ck[f"direct_{k}"]) for k in keys] for ck in checks], complex).reshape(
        len(checks), len(keys)
    )
    f_chk = np.array([ck["freq_hz"] for ck in checks], float)
    write_npz(
        out / "ear_sweep.npz",
        freq_hz=freqs,
        response_per_pa=H,
        outputs=np.array(names),
        units=np.array(units),
        check_freq_hz=f_chk,
        check_outputs=np.array(keys),
        check_direct_per_pa=direct,
        **{k: v for k, v in delta["columns"].items()},
    )
    fig = Figure(figsize=(7, 6))  # a Figure of its own: no pyplot state, no backend chosen
    ax_mag, ax_ph = fig.subplots(2, 1, sharex=True)
    curve_label = "reduced FE" if checks else model_label
    for key, direct_key, label in (
        ("stapes_velocity_m_s", "stapes_m", "stapes H_V"),
        ("umbo_velocity_m_s", "umbo_m", "umbo"),
    ):
        h = H[:, names.index(key)]
        (line,) = ax_mag.loglog(freqs, np.abs(h), label=f"{label}, {curve_label}")
        ph = np.unwrap(np.angle(h))
        ax_ph.semilogx(freqs, np.degrees(ph), color=line.get_color())
        if not checks:
            continue
        v = 2j * np.pi * f_chk * direct[:, keys.index(direct_key)]
        ax_mag.plot(f_chk, np.abs(v), "o", mfc="none", color=line.get_color(), label=f"{label}, direct FE")
        ref = np.interp(f_chk, freqs, ph)  # the direct phase on the curve's branch
        ax_ph.plot(
            f_chk,
            np.degrees(np.angle(v) + 2 * np.pi * np.round((ref - np.angle(v)) / (2 * np.pi))),
            "o",
            mfc="none",
            color=line.get_color(),
        )
    ax_mag.set_ylabel("velocity per pressure (m/s/Pa)")
    ax_ph.set_ylabel("phase (deg)")
    ax_ph.set_xlabel("frequency (Hz)")
    ax_mag.legend(fontsize=8)
    title = "reduced model, direct FE checks" if checks else model_label
    ax_mag.set_title(f"FE cat middle ear ({joint_label}) per Pa: {title}", fontsize=9)
    fig.tight_layout()
    atomic_write(out / "ear_bode.png", lambda tmp: fig.savefig(tmp, format="png"))
