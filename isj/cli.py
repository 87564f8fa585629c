"""Command line: ``isj fem ...``, ``isj lumped solve``, ``calibrate``, ``explore``, ``sweep``, ``report``.

``main(argv=None) -> int`` so that tests call it directly. Bad input gives one
line on stderr naming the parameter and its valid range, exit code 2, and no
output file.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from pathlib import Path

from . import __version__
from .design import DEFAULT_PRESSURE_PA, Geometry, InvalidParameter, Materials
from .errors import UsageError

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line (``isj: error: ...``) and exit 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise UsageError(message)


def _float(name: str, lo: float = -math.inf, hi: float = math.inf, lo_open=True, hi_open=True):
    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: not a number") from None
        ok = math.isfinite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
        if not ok:
            rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
            raise argparse.ArgumentTypeError(f"{name} = {text}: must be a finite number in {rng}")
        return v

    return parse


_MODULUS_OPTIONS = ("pedicle", "gap", "capsule", "plate", "stapes", "incus")


def _add_moduli_options(p: argparse.ArgumentParser, whose: str = "") -> None:
    """--<region>-e for each region of the joint model, and --nu."""
    d = Materials()
    for r in _MODULUS_OPTIONS:
        p.add_argument(
            f"--{r}-e",
            metavar="PA",
            type=_float(f"--{r}-e", lo=0.0),
            default=d.youngs(r),
            help=f"Young's modulus of the {whose}{r} (Pa, > 0; default {d.youngs(r):g})",
        )
    p.add_argument(
        "--nu",
        type=_float("--nu", -1.0, 0.5),
        default=d.nu,
        help=f"Poisson's ratio of the {whose or 'model'}, in (-1, 0.5) (default {d.nu})",
    )


def _add_design_options(p: argparse.ArgumentParser) -> None:
    _add_moduli_options(p)
    p.add_argument(
        "--pressure",
        metavar="PA",
        type=_float("--pressure"),
        default=DEFAULT_PRESSURE_PA,
        help=f"pressure on the incus's -x face (Pa; default {DEFAULT_PRESSURE_PA:g})",
    )


def _add_order_resolution(p: argparse.ArgumentParser, what: str = "mesh") -> None:
    p.add_argument("--order", type=int, choices=(1, 2), default=2, help="P1 or P2 tetrahedra (default 2)")
    p.add_argument(
        "--resolution",
        metavar="R",
        type=_float("--resolution", lo=0.0),
        default=1.0,
        help=f"{what} refinement factor, > 0: 2 halves every element size (default 1)",
    )


def _add_mesh_options(p: argparse.ArgumentParser) -> None:
    _add_geometry_option(p)
    _add_order_resolution(p)
    p.add_argument(
        "--solver",
        choices=("auto", "cholmod", "pardiso", "superlu"),
        default="auto",
        help="sparse direct solver (default: fastest installed)",
    )


def _geometry_option(text: str) -> tuple[str, float]:
    names = [f.name for f in dataclasses.fields(Geometry)]
    key, sep, value = text.partition("=")
    if not sep or key not in names:
        raise argparse.ArgumentTypeError(
            f"--geometry {text!r}: must be NAME=METRES with NAME one of {', '.join(names)}"
        )
    try:
        return key, float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--geometry {key} = {value!r}: not a number") from None


def _add_geometry_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--geometry",
        metavar="NAME=M",
        type=_geometry_option,
        action="append",
        default=[],
        help="override a dimension (m), e.g. pedicle_x_m=60e-6; repeatable",
    )


def _geometry(args) -> Geometry:
    return Geometry(**dict(args.geometry))


def _materials(args) -> Materials:
    return Materials(**{f"{r}_e_pa": getattr(args, f"{r}_e") for r in _MODULUS_OPTIONS}, nu=args.nu)


def _check_out_path(path: str | None, flag: str, suffix: str) -> Path | None:
    if path is None:
        return None
    p = Path(path)
    if p.suffix.lower() != suffix:
        raise UsageError(f"{flag} = {path!r}: must end in {suffix}")
    if p.exists() and p.is_dir():
        raise UsageError(f"{flag} = {path!r}: is a directory")
    return p


def _urad(x: float) -> str:
    return f"{x * 1e6:9.4f}"


def _cmd_solve(args) -> int:
    from isj.fem.export import write_model_vtu
    from isj.fem.model import PedicleJointModel

    from .provenance import write_run_record

    vtu = _check_out_path(args.vtu, "--vtu", ".vtu")
    materials = _materials(args)
    t0 = time.perf_counter()
    model = PedicleJointModel(_geometry(args), args.order, args.resolution, solver=args.solver)
    res = model.solve(materials, args.pressure)
    timings = dict(model.timings_s, total=time.perf_counter() - t0)
    out = res.to_dict() | {
        "n_tets": model.n_tets,
        "n_dofs": model.n_dofs,
        "order": args.order,
        "resolution": args.resolution,
        "solver": model.solver_name,
        "mesh_hash": model.mesh.content_hash(),
        "timings_s": timings,
    }
    if vtu is not None:
        write_model_vtu(vtu, model, res)
        write_run_record(vtu.with_suffix(".json"), args, out)
    if args.json:
        print(json.dumps(out))
    else:
        print(f"P{args.order} mesh: {model.n_tets} tets, {model.n_dofs} dofs, solver {model.solver_name}")
        print(f"alpha      = {_urad(res.alpha_rad)} urad   (least squares {_urad(res.alpha_ls_rad)})")
        print(f"beta       = {_urad(res.beta_rad)} urad   (least squares {_urad(res.beta_ls_rad)})")
        print(f"alpha+beta = {_urad(res.sum_rad)} urad   beta/alpha = {res.ratio:.3f}")
        print(f"max |u|    = {res.max_disp_m:.4e} m at {args.pressure:g} Pa")
        frac = res.energy_fraction()
        print("strain energy: " + ", ".join(f"{k} {100 * v:.1f}%" for k, v in frac.items()))
        print(f"time: {timings['total']:.2f} s")
        if vtu is not None:
            print(f"wrote {vtu}")
    return 0


def _cmd_cases(args) -> int:
    from isj.fem.export import write_model_vtu
    from isj.fem.model import PedicleJointModel

    from .cases import THESIS_BASE_ALPHA_RAD, THESIS_BASE_BETA_RAD, THESIS_CASES
    from .provenance import write_run_record

    vtu = _check_out_path(args.vtu, "--vtu", ".vtu")
    base = Materials(nu=args.nu)
    geometry = _geometry(args)
    t0 = time.perf_counter()
    model = PedicleJointModel(geometry, args.order, args.resolution, solver=args.solver)
    rows, results = [], {}
    for case in THESIS_CASES:
        res = model.solve(case.materials(base), args.pressure)
        results[case.name] = res
        rows.append(
            {
                "case": case.name,
                "pedicle_e_pa": case.pedicle_e_pa,
                "gap_e_pa": case.gap_e_pa,
                "capsule_e_pa": case.capsule_e_pa,
            }
            | res.to_dict()
        )
    elapsed = time.perf_counter() - t0
    if vtu is not None:
        write_model_vtu(vtu, model, results["base"])
        write_run_record(
            vtu.with_suffix(".json"),
            args,
            {"cases": rows, "n_tets": model.n_tets, "n_dofs": model.n_dofs},
        )
    if args.json:
        print(json.dumps(rows))
        return 0
    print(
        f"Seven thesis cases: P{args.order}, {model.n_tets} tets, {model.n_dofs} dofs, "
        f"{args.pressure:g} Pa on the incus, solver {model.solver_name}, {elapsed:.1f} s"
    )
    print(
        f"{'case':7} {'E_ped GPa':>9} {'E_gap MPa':>9} {'E_cap MPa':>9} {'alpha urad':>10} "
        f"{'beta urad':>10} {'a+b urad':>9} {'beta/alpha':>10} {'ped. energy':>11}"
    )
    for r in rows:
        print(
            f"{r['case']:7} {r['pedicle_e_pa'] / 1e9:9.3g} {r['gap_e_pa'] / 1e6:9.3g} "
            f"{r['capsule_e_pa'] / 1e6:9.3g} {r['alpha_rad'] * 1e6:10.4f} "
            f"{r['beta_rad'] * 1e6:10.4f} "
            f"{r['alpha_plus_beta_rad'] * 1e6:9.4f} {r['beta_over_alpha']:10.3f} "
            f"{100 * r['strain_energy_fraction']['pedicle']:10.1f}%"
        )
    print(
        f"thesis base case (Table 7.2): alpha {THESIS_BASE_ALPHA_RAD * 1e6:.3f}, "
        f"beta {THESIS_BASE_BETA_RAD * 1e6:.2f}, alpha+beta "
        f"{(THESIS_BASE_ALPHA_RAD + THESIS_BASE_BETA_RAD) * 1e6:.3f} urad"
    )
    if args.resolution == 1.0 and args.order == 2:
        print(
            "discretisation: on this default mesh alpha and beta sit about 2.5 % below their mesh-converged "
            "values (--resolution 2: about 1 %; README, Accuracy)"
        )
    if vtu is not None:
        print(f"wrote {vtu} (base case)")
    return 0


def _cmd_convergence(args) -> int:
    from isj.fem.convergence import cantilever_study, joint_study, plot_study

    plot = Path(args.plot) if args.plot else None
    if plot is not None and (plot.suffix.lower() not in (".png", ".pdf", ".svg") or plot.is_dir()):
        raise UsageError(f"--plot = {args.plot!r}: must be a file ending in .png, .pdf or .svg")
    if args.model == "joint":
        if plot is not None:
            raise UsageError("--plot: only for --model cantilever")
        rows = joint_study(args.order, args.resolutions or (0.71, 1.0, 1.41))
        if args.json:
            print(json.dumps(rows))
            return 0
        print(f"Base case (spec 2.5) at the default pressure, P{args.order}:")
        print(f"{'R':>5} {'n_tets':>8} {'n_dofs':>8} {'alpha urad':>10} {'beta urad':>10} {'time s':>7}")
        for r in rows:
            print(
                f"{r['resolution']:5.2f} {r['n_tets']:8d} {r['n_dofs']:8d} {r['alpha_rad'] * 1e6:10.4f} "
                f"{r['beta_rad'] * 1e6:10.4f} {r['time_s']:7.1f}"
            )
        return 0
    if args.direction is None:
        raise UsageError("--direction: required for --model cantilever (x or y)")
    rows = cantilever_study(
        direction=args.direction, order=args.order, nu=args.nu, resolutions=args.resolutions
    )
    if plot is not None:
        plot_study(rows, plot, title=f"Pedicle cantilever, load in {args.direction}, P{args.order}")
    if args.json:
        print(json.dumps(rows))
        return 0
    print(
        f"Pedicle cantilever (spec 2.6), shear load in {args.direction}, P{args.order}: "
        f"max |u| against Timoshenko {rows[0]['analytic_m']:.4e} m"
    )
    print(f"{'n_tets':>8} {'n_dofs':>8} {'max_disp_m':>12} {'rel_error':>10} {'tip_mean_m':>12}")
    for r in rows:
        print(
            f"{r['n_tets']:8d} {r['n_dofs']:8d} {r['max_disp_m']:12.4e} {r['rel_error']:+10.4f} "
            f"{r['tip_mean_m']:12.4e}"
        )
    if plot is not None:
        print(f"wrote {plot}")
    return 0


def _cmd_modes(args) -> int:
    from isj.fem.dynamics import modes
    from isj.fem.export import write_modes
    from isj.fem.model import PedicleJointModel

    if args.n < 1 or args.n > 100:
        raise UsageError(f"--n = {args.n}: must be between 1 and 100")
    out_dir = Path(args.vtu_dir) if args.vtu_dir else None
    if out_dir is not None and out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"--vtu-dir = {args.vtu_dir!r}: exists and is not a directory")
    materials = _materials(args)
    t0 = time.perf_counter()
    model = PedicleJointModel(_geometry(args), args.order, args.resolution, solver=args.solver)
    freq_hz, shapes = modes(model, materials, args.n)
    elapsed = time.perf_counter() - t0
    if out_dir is not None:
        write_modes(out_dir, model, freq_hz, shapes)
    if args.json:
        print(
            json.dumps(
                {
                    "freq_hz": [float(f) for f in freq_hz],
                    "n_dofs": model.n_dofs,
                    "n_tets": model.n_tets,
                    "time_s": elapsed,
                }
            )
        )
        return 0
    print(f"lowest {args.n} natural frequencies (P{args.order}, {model.n_dofs} dofs, {elapsed:.1f} s):")
    for i, f in enumerate(freq_hz, 1):
        print(f"  mode {i}: {f:10.1f} Hz")
    if out_dir is not None:
        print(f"wrote {out_dir / 'modes.pvd'} and {args.n} VTU files")
    return 0


def _write_response_csv(path: Path, freq, H, outputs, units: str) -> None:
    """Frequency response as CSV: re, im, |.|, unwrapped phase (deg) per output; units in a # line."""
    import numpy as np

    from .atomic import atomic_write_text

    header = "freq_hz," + ",".join(f"{k}_re,{k}_im,{k}_abs,{k}_phase_deg" for k in outputs)
    cols = [freq]
    for j in range(len(outputs)):
        h = H[:, j]
        cols += [h.real, h.imag, np.abs(h), np.degrees(np.unwrap(np.angle(h)))]
    rows = "\n".join(",".join(f"{v:.9g}" for v in row) for row in np.column_stack(cols))
    atomic_write_text(path, f"# units: {units}\n{header}\n{rows}\n")


def _write_npz(path: Path, **arrays) -> None:
    import numpy as np

    from .atomic import atomic_write

    def write(tmp):
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    atomic_write(path, write)


def _sweep_setup(args):
    """Checks shared by ``isj sweep`` and ``isj ear sweep``: (out dir, calibration, materials, moduli)."""
    if not 0 < args.fmin_hz < args.fmax_hz:
        raise UsageError(f"--fmin-hz/--fmax-hz = {args.fmin_hz:g}/{args.fmax_hz:g}: need 0 < fmin < fmax")
    if not 2 <= args.n <= 100_000:
        raise UsageError(f"--n = {args.n}: must be an integer in [2, 100000]")
    if not 0 <= args.fe_checks <= 50:
        raise UsageError(f"--fe-checks = {args.fe_checks}: must be an integer in [0, 50]")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out = {args.out!r}: exists and is not a directory")
    cal = _load_calibration(args.calibration)
    m = _materials(args)
    return out, cal, m, {f"{r}_e_pa": getattr(m, f"{r}_e_pa") for r in _MODULUS_OPTIONS}


def _cmd_sweep(args) -> int:
    import numpy as np

    from isj.fem.dynamics import Damping, harmonic_outputs
    from isj.fem.model import PedicleJointModel
    from isj.lumped.dynamics import OUTPUTS, chain_model, frequency_response
    from isj.lumped.plots import save_bode

    from .provenance import write_run_record

    out, cal, m, designs = _sweep_setup(args)
    _warn_outside(cal, designs)
    damping = Damping(args.rayleigh_a, args.rayleigh_b, args.loss_factor)
    freq = np.geomspace(args.fmin_hz, args.fmax_hz, args.n)
    model = chain_model(
        cal.factor_array(),
        cal.shear_factor,
        materials=m,
        rayleigh_a_per_s=damping.rayleigh_a_per_s,
        rayleigh_b_s=damping.rayleigh_b_s,
        loss_factor=damping.loss_factor,
        **designs,
    )
    H = frequency_response(model, freq, args.pressure)  # (n_freq, 3)
    fe_freq = np.geomspace(args.fmin_hz, args.fmax_hz, args.fe_checks + 2)[1:-1] if args.fe_checks else []
    checks = []
    if len(fe_freq):
        _warn_fe_settings(cal, args.order, args.resolution)
        fem_model = PedicleJointModel(_geometry(args), args.order, args.resolution, solver=args.solver)
        fe = harmonic_outputs(fem_model, fe_freq, m, damping, args.pressure)
        lum = frequency_response(model, fe_freq, args.pressure)
        for i, f in enumerate(fe_freq):
            errs = {k: float(abs(lum[i, j] / fe[k][i] - 1)) for j, k in enumerate(OUTPUTS[:2])}
            checks.append(
                {
                    "freq_hz": float(f),
                    **{f"fe_{k}": [float(fe[k][i].real), float(fe[k][i].imag)] for k in OUTPUTS[:2]},
                    **{f"{k}_rel_error": e for k, e in errs.items()},
                    "passed": max(errs.values()) <= args.tolerance,
                }
            )
    poles_hz, zeta = model.poles()
    units = f"freq_hz Hz; alpha_rad, beta_rad rad; incus_ux_m m; phase deg; pressure {args.pressure:g} Pa"
    _write_response_csv(out / "sweep.csv", freq, H, OUTPUTS, units)
    _write_npz(
        out / "sweep.npz",
        freq_hz=freq,
        response=H,
        outputs=np.array(OUTPUTS),
        fe_freq_hz=np.asarray(fe_freq),
        units=np.array("freq_hz: Hz; alpha_rad, beta_rad: rad; incus_ux_m: m"),
    )
    save_bode(out / "bode.png", freq, H, checks)
    summary = {
        "n_freq": int(args.n),
        "natural_freq_hz": [float(v) for v in poles_hz],
        "damping_ratio": [float(v) for v in zeta],
        "fe_checks": checks,
        "passed": all(c["passed"] for c in checks),
        "tolerance": args.tolerance,
    }
    write_run_record(out / "sweep.json", args, summary)
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"lumped sweep {args.fmin_hz:g}-{args.fmax_hz:g} Hz ({args.n} points); natural frequencies "
            + ", ".join(f"{v:.0f} Hz (zeta {z:.2f})" for v, z in zip(poles_hz, zeta, strict=True))
        )
        for c in checks:
            print(
                f"  FE check at {c['freq_hz']:.0f} Hz: alpha {100 * c['alpha_rad_rel_error']:.2f} %, "
                f"beta {100 * c['beta_rad_rel_error']:.2f} % {'ok' if c['passed'] else 'EXCEEDS tolerance'}"
            )
        print(f"wrote {out}/sweep.csv, sweep.npz, bode.png, sweep.json")
    if not summary["passed"]:
        print(f"isj: error: an FE check exceeds the tolerance {args.tolerance:g}", file=sys.stderr)
        return 1
    return 0


def _cmd_mesh(args) -> int:
    from isj.fem.model import PedicleJointModel
    from isj.fem.quality import mesh_quality, rcm_bandwidth

    model = PedicleJointModel(_geometry(args), args.order, args.resolution, solver=args.solver)
    q = mesh_quality(model.mesh)
    K = model.stiffness(Materials(), reduced=False)
    before, after = rcm_bandwidth(K)
    out = q | {
        "order": args.order,
        "n_dofs": model.n_dofs,
        "mesh_hash": model.mesh.content_hash(),
        "stiffness_bandwidth": before,
        "stiffness_bandwidth_rcm": after,
    }
    if args.json:
        print(json.dumps(out))
        return 0
    print(
        f"mesh {out['mesh_hash'][:12]}: {q['n_tets']} tets, {q['n_nodes']} vertices; "
        f"P{args.order}: {model.n_dofs} free dofs"
    )
    print("tets per region: " + ", ".join(f"{k} {v}" for k, v in q["tets_per_region"].items()))
    print(
        f"minimum dihedral angle {q['min_dihedral_deg']:.1f} deg, "
        f"worst aspect ratio {q['max_aspect_ratio']:.2f} (1 = regular)"
    )
    print(f"stiffness bandwidth {before} -> {after} after reverse Cuthill-McKee")
    return 0


def _fe_cache_dir(path: str | None) -> Path:
    import os

    if path:
        return Path(path)
    env = os.environ.get("ISJ_FE_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "isj" / "fe"


def _load_calibration(path: str | None):
    from isj.lumped.artifact import Calibration, CorruptCalibration, default_calibration

    try:
        return Calibration.load(path) if path else default_calibration()
    except CorruptCalibration as exc:
        raise UsageError(str(exc)) from None


def _warn_outside(cal, designs: dict) -> int:
    import numpy as np

    n_out = 0
    for k, mask in cal.outside(designs).items():
        if mask.any():
            lo, hi = cal.domain[k]
            n_out = max(n_out, int(np.count_nonzero(mask)))
            print(
                f"isj: warning: {k} outside the calibrated domain [{lo:g}, {hi:g}] Pa for "
                f"{int(np.count_nonzero(mask))} design(s): the lumped model is extrapolating",
                file=sys.stderr,
            )
    return n_out


def _warn_fe_settings(cal, order: int, resolution: float) -> None:
    fs = cal.fe_settings
    if fs and (fs.get("order") != order or fs.get("resolution") != resolution):
        print(
            f"isj: warning: FE checks run at order {order}, resolution {resolution:g}; the calibration "
            f"was fitted to order {fs.get('order')}, resolution {fs.get('resolution')}: their "
            "discretisation errors differ",
            file=sys.stderr,
        )


def _cmd_lumped_solve(args) -> int:
    from isj.lumped.model import static_response

    cal = _load_calibration(args.calibration)
    if args.geometry:
        raise UsageError("--geometry: the lumped model is calibrated for the default geometry only")
    m = _materials(args)
    designs = {f"{r}_e_pa": getattr(m, f"{r}_e_pa") for r in _MODULUS_OPTIONS}
    _warn_outside(cal, designs)
    r = static_response(cal.factor_array(), pressure_pa=args.pressure, **designs)
    out = {
        "alpha_rad": float(r.alpha_rad),
        "beta_rad": float(r.beta_rad),
        "alpha_plus_beta_rad": float(r.sum_rad),
        "beta_over_alpha": float(r.ratio),
        "pressure_pa": args.pressure,
        "calibration": args.calibration or "default",
        "validation": cal.validation,
    }
    if args.json:
        print(json.dumps(out))
        return 0
    print(
        f"lumped model ({out['calibration']} calibration, validated max error alpha "
        f"{100 * cal.validation.get('max_alpha', float('nan')):.1f} %, beta "
        f"{100 * cal.validation.get('max_beta', float('nan')):.1f} %)"
    )
    print(f"alpha      = {_urad(out['alpha_rad'])} urad")
    print(f"beta       = {_urad(out['beta_rad'])} urad")
    print(
        f"alpha+beta = {_urad(out['alpha_plus_beta_rad'])} urad   beta/alpha = {out['beta_over_alpha']:.3f}"
    )
    return 0


def _cmd_calibrate(args) -> int:
    from isj.calibration.pipeline import calibrate, calibrate_dynamics
    from isj.fem.batch import evaluate_design, evaluate_modes, fe_settings
    from isj.fem.export import atomic_write_text

    out = Path(args.out)
    if out.suffix.lower() != ".json" or out.is_dir():
        raise UsageError(f"--out = {args.out!r}: must be a file ending in .json")
    if args.samples < 16 or args.validation < 0 or args.modal_samples < 0:
        raise UsageError("--samples: must be >= 16 (ten factors); --validation, --modal-samples: >= 0")
    settings = fe_settings(order=args.order, resolution=args.resolution)
    cal = calibrate(
        evaluate_design,
        settings,
        _fe_cache_dir(args.cache),
        samples=args.samples,
        validation=args.validation,
        seed=args.seed,
        scheduler=args.scheduler,
        progress=not args.quiet,
    )
    if args.modal_samples:
        cal = calibrate_dynamics(
            cal,
            evaluate_modes,
            settings,
            _fe_cache_dir(args.cache),
            samples=args.modal_samples,
            validation=max(args.modal_samples // 2, 2),
            seed=args.seed + 100,
            progress=not args.quiet,
        )
    atomic_write_text(out, cal.to_json())
    t, v = cal.training, cal.validation
    print(
        f"calibrated on {t['n']} FE designs: max error alpha {100 * t['max_alpha']:.2f} %, "
        f"beta {100 * t['max_beta']:.2f} %"
    )
    if v:
        print(
            f"validated on {v['n']} unseen FE designs: max error alpha {100 * v['max_alpha']:.2f} %, "
            f"beta {100 * v['max_beta']:.2f} %, beta/alpha {100 * v['max_ratio']:.2f} % "
            f"(RMS {100 * v['rms_alpha']:.2f} / {100 * v['rms_beta']:.2f} / {100 * v['rms_ratio']:.2f} %)"
        )
    if cal.dynamics:
        dv = cal.dynamics.get("validation") or cal.dynamics["training"]
        print(
            f"chain model joint shear factor {cal.dynamics['shear_factor']:.3f}: first two in-plane natural "
            f"frequencies within {100 * dv['max_f1']:.1f} % and {100 * dv['max_f2']:.1f} % of FE on "
            f"{dv['n']} {'held-out' if cal.dynamics.get('validation') else 'training'} designs"
        )
    print(f"wrote {out}")
    return 0


def _range_option(name: str):
    def parse(text: str) -> tuple[float, float]:
        lo_txt, sep, hi_txt = text.partition(":")
        lo = _float(name, lo=0.0)(lo_txt)
        hi = _float(name, lo=0.0)(hi_txt) if sep else lo
        if hi < lo:
            raise argparse.ArgumentTypeError(f"{name} = {text}: LOW:HIGH needs LOW <= HIGH")
        return lo, hi

    return parse


def _explore_designs(args) -> dict:
    import numpy as np

    ranges = {f"{r}_e_pa": getattr(args, f"{r}_e") for r in _MODULUS_OPTIONS}
    ranged = [k for k, (lo, hi) in ranges.items() if hi > lo]
    if args.sample:
        from scipy.stats import qmc

        u = qmc.LatinHypercube(d=max(len(ranged), 1), seed=args.seed).random(args.sample)
        cols = {k: u[:, i] for i, k in enumerate(ranged)}
        n = args.sample
    else:
        axes = [np.linspace(0, 1, args.n) for _ in ranged]
        mesh = np.meshgrid(*axes, indexing="ij") if axes else []
        cols = {k: m.ravel() for k, m in zip(ranged, mesh, strict=True)}
        n = args.n ** len(ranged)
    out = {}
    for k, (lo, hi) in ranges.items():
        t = cols.get(k, np.zeros(n))
        out[k] = np.exp(np.log(lo) + t * (np.log(hi) - np.log(lo)))
    return out


def _cmd_explore(args) -> int:
    import numpy as np

    from isj.calibration.runner import run_designs
    from isj.fem.batch import evaluate_design, fe_settings
    from isj.lumped.model import static_response

    cal = _load_calibration(args.calibration)
    if args.n < 1 or (args.sample is not None and args.sample < 1) or args.spot_checks < 0:
        raise UsageError("--n, --sample: must be >= 1; --spot-checks: must be >= 0")
    designs = _explore_designs(args)
    n = len(next(iter(designs.values())))
    if n > 50_000_000:
        raise UsageError(f"--n/--sample: {n} designs is too many (at most 5e7)")
    n_out = _warn_outside(cal, designs)
    t0 = time.perf_counter()
    lum = static_response(cal.factor_array(), pressure_pa=args.pressure, **designs)
    t_lumped = time.perf_counter() - t0
    # spot checks: the two extreme corners of the explored box, then random designs
    lo_idx, hi_idx = (
        int(np.argmin(sum(np.log(v) for v in designs.values()))),
        int(np.argmax(sum(np.log(v) for v in designs.values()))),
    )
    rng = np.random.default_rng(args.seed)
    picks = list(dict.fromkeys([lo_idx, hi_idx] + list(rng.permutation(n)[: args.spot_checks])))
    picks = picks[: args.spot_checks]
    checks = []
    if picks:
        _warn_fe_settings(cal, args.order, args.resolution)
        fe_designs = [{k: float(v[i]) for k, v in designs.items()} for i in picks]
        settings = fe_settings(order=args.order, resolution=args.resolution, pressure_pa=args.pressure)
        records = run_designs(
            fe_designs, evaluate_design, settings, _fe_cache_dir(args.cache), progress=not args.json
        )
        for i, rec in zip(picks, records, strict=True):
            fe = rec["result"]
            ea = float(lum.alpha_rad[i] / fe["alpha_rad"] - 1)
            eb = float(lum.beta_rad[i] / fe["beta_rad"] - 1)
            checks.append(
                {
                    "design": rec["design"],
                    "fe_alpha_rad": fe["alpha_rad"],
                    "fe_beta_rad": fe["beta_rad"],
                    "lumped_alpha_rad": float(lum.alpha_rad[i]),
                    "lumped_beta_rad": float(lum.beta_rad[i]),
                    "alpha_rel_error": ea,
                    "beta_rel_error": eb,
                    "passed": abs(ea) <= args.tolerance and abs(eb) <= args.tolerance,
                }
            )
    failed = [c for c in checks if not c["passed"]]
    summary = {
        "n_designs": n,
        "lumped_time_s": t_lumped,
        "outside_domain": n_out,
        "alpha_rad_range": [float(lum.alpha_rad.min()), float(lum.alpha_rad.max())],
        "beta_rad_range": [float(lum.beta_rad.min()), float(lum.beta_rad.max())],
        "tolerance": args.tolerance,
        "spot_checks": checks,
        "max_spot_error": max(
            (max(abs(c["alpha_rel_error"]), abs(c["beta_rel_error"])) for c in checks), default=0.0
        ),
        "passed": not failed,
    }
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"lumped model: {n} designs in {t_lumped * 1e3:.2f} ms; alpha {_urad(lum.alpha_rad.min())} .. "
            f"{_urad(lum.alpha_rad.max())} urad, beta {_urad(lum.beta_rad.min())} .. "
            f"{_urad(lum.beta_rad.max())} urad"
        )
        for c in checks:
            print(
                f"  FE spot check: alpha {100 * c['alpha_rel_error']:+6.2f} %, beta "
                f"{100 * c['beta_rel_error']:+6.2f} % {'ok' if c['passed'] else 'EXCEEDS tolerance'}"
            )
        print(f"{len(checks) - len(failed)}/{len(checks)} spot checks within {100 * args.tolerance:g} %")
    if failed:
        print(
            f"isj: error: {len(failed)} FE spot check(s) exceed the tolerance {args.tolerance:g}",
            file=sys.stderr,
        )
        return 1
    return 0


def _cmd_report(args) -> int:
    from isj.lumped.artifact import CorruptCalibration
    from isj.reports.config import ConfigError, load_config
    from isj.reports.run import load_calibration, run_report

    # everything is validated before the output folder is created
    try:
        config = load_config(args.config, args.set or [])
        calibration = load_calibration(config)
    except (ConfigError, CorruptCalibration) as exc:
        raise UsageError(str(exc)) from None
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {args.out!r}: exists and is not a folder")
    verbosity = 0 if args.quiet else 1 + args.verbose
    run_report(config, out, verbosity=verbosity, calibration=calibration)
    return 0


def _add_ear_options(p: argparse.ArgumentParser) -> None:
    _add_moduli_options(p, "joint model's ")
    p.add_argument(
        "--drum-e", metavar="PA", type=_float("--drum-e", lo=0.0), default=20e6, help="eardrum modulus (Pa)"
    )
    p.add_argument("--rigid-joint", action="store_true", help="replace the joint model by a rigid connection")
    _add_order_resolution(p, "joint mesh")
    p.add_argument("--json", action="store_true", help="print JSON")


def _ear_model(args):
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.model import PedicleJointModel

    from .ear import EarMaterials

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


def _cmd_ear_solve(args) -> int:
    model, ear_materials = _ear_model(args)
    res = model.solve(_materials(args), ear_materials)
    out = res.to_dict() | {"n_dofs": model.n_dofs, "rigid_joint": args.rigid_joint}
    if args.json:
        print(json.dumps(out))
    else:
        print("\n".join(_ear_lines("whole ear, per Pa of ear-canal pressure", res)))
        ax = res.rotation_axis
        print(f"  axis: point {[round(v * 1e3, 4) for v in ax['point_m']]} mm, "
              f"direction {[round(v, 4) for v in ax['direction']]}")  # fmt: skip
        print(f"  {model.n_dofs} dofs, solve {res.timings_s['total']:.2f} s")
    return 0


def _cmd_ear_cases(args) -> int:
    from .cases import THESIS_CASES

    model, ear_materials = _ear_model(args)
    base = Materials(nu=args.nu)
    res = {c.name: model.solve(c.materials(base), ear_materials) for c in THESIS_CASES}
    if args.json:
        print(json.dumps([{"case": k} | r.to_dict() for k, r in res.items()]))
    else:
        for k, r in res.items():
            print("\n".join(_ear_lines(k, r)))
    return 0


def _cmd_ear_sweep(args) -> int:
    """Lumped ear's frequency response per Pa (CSV, NPZ, Bode PNG, JSON), FE whole-ear static spot check."""
    import numpy as np

    from isj.lumped.ear import OUTPUTS, UNITS, ear_model
    from isj.lumped.plots import bode

    from .atomic import atomic_write
    from .ear import EarMaterials
    from .provenance import write_run_record

    out, cal, m, designs = _sweep_setup(args)
    if not args.rigid_joint:
        _warn_outside(cal, designs)
    t0 = time.perf_counter()
    lumped = ear_model(
        cal.factor_array(),
        ear_materials=EarMaterials(drum_e_pa=args.drum_e),
        rigid_joint=args.rigid_joint,
        rayleigh_a_per_s=args.rayleigh_a,
        rayleigh_b_s=args.rayleigh_b,
        loss_factor=args.loss_factor,
        **designs,
    )
    freq = np.geomspace(args.fmin_hz, args.fmax_hz, args.n)
    H = lumped.freq_resp(freq)  # (n_freq, 4), per Pa
    static = lumped.static_response()
    poles_hz, zeta = lumped.natural_frequencies_hz()
    t1 = time.perf_counter()
    # FE whole-ear static spot check (low frequency), before anything is written
    fe_model, ear_materials = _ear_model(args)
    fe = fe_model.solve(m, ear_materials)
    t2 = time.perf_counter()
    fe_vals = {
        "umbo_m": fe.umbo_m_per_pa,
        "stapes_m": fe.footplate_piston_m_per_pa,
        "alpha_rad": fe.alpha_rad_per_pa,
        "beta_rad": fe.beta_rad_per_pa,
    }
    errors = {
        k: float(abs(static[j] / fe_vals[k] - 1)) for j, k in enumerate(OUTPUTS) if fe_vals[k] is not None
    }
    passed = max(errors["umbo_m"], errors["stapes_m"]) <= args.tolerance
    check = {
        "freq_hz": float(freq[0]),
        "compared_with": "lumped static limit (0 Hz); FE values are static, marked at the lowest frequency",
        **{f"fe_{k}": [float(v), 0.0] for k, v in fe_vals.items() if v is not None},
        **{f"lumped_static_{k}": float(static[j]) for j, k in enumerate(OUTPUTS)},
        **{f"{k}_rel_error": e for k, e in errors.items()},
        "passed": passed,
    }
    # FE whole-ear harmonic spot checks inside the band (same masses and damping as the lumped ear)
    from isj.fem.ear.ear_dynamics import EarDamping

    fe_freq = np.geomspace(args.fmin_hz, args.fmax_hz, args.fe_checks + 2)[1:-1] if args.fe_checks else []
    fe_checks = []
    if len(fe_freq):
        damping = EarDamping(args.rayleigh_a, args.rayleigh_b, args.loss_factor)
        fe_h = fe_model.harmonic(fe_freq, m, ear_materials, damping).outputs()
        lum_h = lumped.freq_resp(fe_freq)
        keys = OUTPUTS if not args.rigid_joint else OUTPUTS[:2]
        for i, fr in enumerate(fe_freq):
            errs = {k: float(abs(lum_h[i, j] / fe_h[i, j] - 1)) for j, k in enumerate(keys)}
            fe_checks.append(
                {
                    "freq_hz": float(fr),
                    **{
                        f"fe_{k}": [float(fe_h[i, j].real), float(fe_h[i, j].imag)]
                        for j, k in enumerate(keys)
                    },
                    **{
                        f"lumped_{k}": [float(lum_h[i, j].real), float(lum_h[i, j].imag)]
                        for j, k in enumerate(keys)
                    },
                    **{f"{k}_rel_error": e for k, e in errs.items()},
                    "passed": max(errs["umbo_m"], errs["stapes_m"]) <= args.tolerance,
                }
            )
    t3 = time.perf_counter()
    all_passed = passed and all(c["passed"] for c in fe_checks)

    joint_label = "rigid joint" if args.rigid_joint else "calibrated joint"
    units = (
        "freq_hz Hz; umbo_m, stapes_m m per Pa of ear-canal pressure; "
        f"alpha_rad, beta_rad rad per Pa; phase deg; {joint_label}"
    )
    _write_response_csv(out / "ear_sweep.csv", freq, H, OUTPUTS, units)

    _write_npz(
        out / "ear_sweep.npz",
        freq_hz=freq,
        response_per_pa=H,
        static_per_pa=static,
        outputs=np.array(OUTPUTS),
        units=np.array([UNITS[k] for k in OUTPUTS]),
        natural_freq_hz=poles_hz,
        damping_ratio=zeta,
    )

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    bode(freq, H[:, :2], [check, *fe_checks], outputs=("umbo_m", "stapes_m"), axes=axes)
    axes[0].set_ylabel("magnitude (m/Pa)")
    axes[0].set_title(
        "lumped cat middle ear per Pa; FE whole ear: static at the lowest frequency, "
        f"{len(fe_checks)} harmonic checks",
        fontsize=9,
    )
    fig.tight_layout()
    atomic_write(out / "ear_bode.png", lambda tmp: fig.savefig(tmp, format="png"))
    plt.close(fig)

    summary = {
        "n_freq": int(args.n),
        "rigid_joint": bool(args.rigid_joint),
        "coordinates": list(lumped.coordinates),
        "natural_freq_hz": [float(v) for v in poles_hz],
        "damping_ratio": [float(v) for v in zeta],
        "static_per_pa": {k: float(static[j]) for j, k in enumerate(OUTPUTS)},
        "fe_check": check,
        "fe_checks": fe_checks,
        "fe_n_dofs": fe_model.n_dofs,
        "passed": all_passed,
        "tolerance": args.tolerance,
        "timings_s": {"lumped": t1 - t0, "fe": t2 - t1, "fe_harmonic": t3 - t2},
    }
    write_run_record(out / "ear_sweep.json", args, summary)
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"lumped ear {args.fmin_hz:g}-{args.fmax_hz:g} Hz ({args.n} points); natural frequencies "
            + ", ".join(f"{v:.0f} Hz" for v in poles_hz)
        )
        print(
            f"  static: umbo {static[0] * 1e9:.2f} nm/Pa (FE {fe_vals['umbo_m'] * 1e9:.2f}, "
            f"{100 * errors['umbo_m']:.2f} %), stapes {static[1] * 1e9:.2f} nm/Pa "
            f"(FE {fe_vals['stapes_m'] * 1e9:.2f}, {100 * errors['stapes_m']:.2f} %) "
            f"{'ok' if passed else 'EXCEEDS tolerance'}"
        )
        for c in fe_checks:
            print(
                f"  FE check at {c['freq_hz']:.0f} Hz: umbo {100 * c['umbo_m_rel_error']:.2f} %, "
                f"stapes {100 * c['stapes_m_rel_error']:.2f} % {'ok' if c['passed'] else 'EXCEEDS tolerance'}"
            )
        print(f"wrote {out}/ear_sweep.csv, ear_sweep.npz, ear_bode.png, ear_sweep.json")
    if not all_passed:
        print(f"isj: error: an FE spot check exceeds the tolerance {args.tolerance:g}", file=sys.stderr)
        return 1
    return 0


def _add_band_options(p: argparse.ArgumentParser, fmax_hz: float = 20e3, why: str = "") -> None:
    p.add_argument("--fmin-hz", type=_float("--fmin-hz", lo=0.0), default=100.0, help="lowest frequency (Hz)")
    p.add_argument(
        "--fmax-hz",
        type=_float("--fmax-hz", lo=0.0),
        default=fmax_hz,
        help=f"highest frequency (Hz; default {fmax_hz:g}{why})",
    )
    p.add_argument("--n", type=int, default=200, help="frequencies, log-spaced, in [2, 100000] (default 200)")


def _add_damping_options(p: argparse.ArgumentParser) -> None:
    """Damping of spec 4 (Rayleigh a, b; loss factor) and the lumped model's calibration."""
    p.add_argument(
        "--rayleigh-a",
        metavar="PER_S",
        type=_float("--rayleigh-a", lo=0.0, lo_open=False),
        default=0.0,
        help="Rayleigh mass coefficient a (1/s; default 0)",
    )
    p.add_argument(
        "--rayleigh-b",
        metavar="S",
        type=_float("--rayleigh-b", lo=0.0, lo_open=False),
        default=1e-4,
        help="Rayleigh stiffness coefficient b (s; default 1e-4)",
    )
    p.add_argument(
        "--loss-factor",
        type=_float("--loss-factor", lo=0.0, lo_open=False),
        default=0.0,
        help="structural loss factor eta (default 0)",
    )
    p.add_argument("--calibration", metavar="PATH", help="calibration file (default: the shipped one)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="isj", description="Mechanics of the incus-stapes coupling.")
    parser.add_argument("--version", action="version", version=f"isj {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    fem = sub.add_parser("fem", help="the finite-element verifier")
    fsub = fem.add_subparsers(dest="fem_command", required=True, parser_class=_Parser)

    p = fsub.add_parser("solve", help="static solve of one design")
    _add_design_options(p)
    _add_mesh_options(p)
    p.add_argument("--vtu", metavar="PATH", help="write the deformed model for ParaView (.vtu)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_solve)

    p = fsub.add_parser("cases", help="the seven thesis cases (spec 2.5)")
    p.add_argument(
        "--nu",
        type=_float("--nu", -1.0, 0.5),
        default=Materials().nu,
        help="Poisson's ratio, in (-1, 0.5)",
    )
    p.add_argument(
        "--pressure",
        metavar="PA",
        type=_float("--pressure"),
        default=DEFAULT_PRESSURE_PA,
        help=f"pressure on the incus (Pa; default {DEFAULT_PRESSURE_PA:g})",
    )
    _add_mesh_options(p)
    p.add_argument("--vtu", metavar="PATH", help="write the base case for ParaView (.vtu)")
    p.add_argument("--json", action="store_true", help="print a JSON list")
    p.set_defaults(func=_cmd_cases)

    lum = sub.add_parser("lumped", help="the calibrated lumped model")
    lsub = lum.add_subparsers(dest="lumped_command", required=True, parser_class=_Parser)
    p = lsub.add_parser("solve", help="static alpha and beta of one design (microseconds)")
    _add_design_options(p)
    _add_mesh_options(p)
    p.add_argument("--calibration", metavar="PATH", help="calibration file (default: the shipped one)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_lumped_solve)

    p = sub.add_parser("calibrate", help="fit the lumped model to FE results (spec 3)")
    p.add_argument("--samples", type=int, default=64, help="training designs (default 64)")
    p.add_argument("--validation", type=int, default=32, help="held-out designs (default 32)")
    p.add_argument("--seed", type=int, default=0, help="seed of the design of experiments")
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address (default: local processes)")
    p.add_argument("--out", metavar="PATH", default="calibration.json", help="artifact to write (.json)")
    p.add_argument("--cache", metavar="DIR", help="FE result cache (default ~/.cache/isj/fe)")
    _add_order_resolution(p, "FE mesh")
    p.add_argument(
        "--modal-samples",
        type=int,
        default=16,
        help="FE modal analyses for the dynamic chain's joint shear factor (default 16; 0 = skip)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_calibrate)

    p = sub.add_parser("explore", help="lumped model over many designs, guarded by FE spot checks")
    d = Materials()
    for r in _MODULUS_OPTIONS:
        p.add_argument(
            f"--{r}-e",
            metavar="PA[:PA]",
            type=_range_option(f"--{r}-e"),
            default=(d.youngs(r), d.youngs(r)),
            help=f"modulus of the {r} (Pa), or a LOW:HIGH range explored log-uniformly",
        )
    p.add_argument("--pressure", metavar="PA", type=_float("--pressure"), default=DEFAULT_PRESSURE_PA)
    p.add_argument("--n", type=int, default=5, help="grid points per ranged modulus (default 5)")
    p.add_argument("--sample", type=int, help="instead of a grid: N Latin-hypercube designs")
    p.add_argument("--seed", type=int, default=0, help="seed for --sample and the spot checks")
    p.add_argument("--spot-checks", type=int, default=4, help="FE spot checks K (default 4)")
    p.add_argument(
        "--tolerance",
        type=_float("--tolerance", lo=0.0),
        default=0.03,
        help="largest relative error of a spot check (default 0.03)",
    )
    p.add_argument("--calibration", metavar="PATH", help="calibration file (default: the shipped one)")
    p.add_argument("--cache", metavar="DIR", help="FE result cache (default ~/.cache/isj/fe)")
    p.add_argument("--order", type=int, choices=(1, 2), default=2, help="FE order of the spot checks")
    p.add_argument("--resolution", metavar="R", type=_float("--resolution", lo=0.0), default=1.0)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_explore)

    p = fsub.add_parser("modes", help="lowest natural frequencies and mode shapes (spec 4)")
    _add_design_options(p)
    _add_mesh_options(p)
    p.add_argument("--n", type=int, default=6, help="number of modes (default 6)")
    p.add_argument("--vtu-dir", metavar="DIR", help="write mode shapes (VTU + modes.pvd)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_modes)

    p = sub.add_parser("sweep", help="damped frequency response: lumped curves, FE spot checks (spec 4)")
    _add_design_options(p)
    _add_mesh_options(p)
    _add_band_options(p)
    p.add_argument("--fe-checks", type=int, default=2, help="FE harmonic spot checks K (default 2)")
    p.add_argument(
        "--tolerance",
        type=_float("--tolerance", lo=0.0),
        default=0.05,
        help="largest relative error of an FE check (default 0.05)",
    )
    _add_damping_options(p)
    p.add_argument("--out", metavar="DIR", default="sweep", help="output folder (default ./sweep)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_sweep)

    p = fsub.add_parser("mesh", help="mesh quality and stiffness bandwidth (thesis 6.5)")
    _add_mesh_options(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_mesh)

    p = fsub.add_parser("convergence", help="pedicle cantilever against Timoshenko (spec 2.6)")
    p.add_argument("--direction", choices=("x", "y"), help="direction of the shear load (cantilever)")
    p.add_argument(
        "--model",
        choices=("cantilever", "joint"),
        default="cantilever",
        help="the pedicle cantilever (default) or the base case of the joint model",
    )
    p.add_argument("--order", type=int, choices=(1, 2), default=2, help="P1 or P2 (default 2)")
    p.add_argument(
        "--nu",
        type=_float("--nu", -1.0, 0.5),
        default=Materials().nu,
        help="Poisson's ratio, in (-1, 0.5)",
    )
    p.add_argument(
        "--resolutions",
        metavar="R",
        type=_float("--resolutions", lo=0.0),
        nargs="+",
        default=None,
        help="mesh resolution factors (default: a preset ladder)",
    )
    p.add_argument("--plot", metavar="PATH", help="write a plot (.png, .pdf or .svg)")
    p.add_argument("--json", action="store_true", help="print a JSON list")
    p.set_defaults(func=_cmd_convergence)

    p = sub.add_parser("report", help="run the pipeline and write the PDF report (spec 2-4)")
    p.add_argument("--config", metavar="CASE.toml", help="TOML case file (default: built-in defaults)")
    p.add_argument("--out", metavar="DIR", default="report", help="output folder (default ./report)")
    p.add_argument(
        "--set",
        metavar="SECTION.KEY=VALUE",
        action="append",
        help="override one key of the case file, e.g. design.pedicle_e_pa=12e9 (repeatable)",
    )
    verb = p.add_mutually_exclusive_group()
    verb.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    verb.add_argument("-v", "--verbose", action="count", default=0, help="timings and cache keys")
    p.set_defaults(func=_cmd_report)

    ear = sub.add_parser("ear", help="the whole cat middle ear with the joint inside (spec 5), static")
    esub = ear.add_subparsers(dest="ear_command", required=True, parser_class=_Parser)
    p = esub.add_parser("solve", help="static response per Pa of ear-canal pressure")
    _add_ear_options(p)
    p.set_defaults(func=_cmd_ear_solve)
    p = esub.add_parser("cases", help="the seven thesis cases inside the ear")
    _add_ear_options(p)
    p.set_defaults(func=_cmd_ear_cases)
    p = esub.add_parser("sweep", help="lumped ear's frequency response per Pa, FE static and harmonic checks")
    _add_ear_options(p)
    # the FE ear's first modes are eardrum modes (1.66 kHz up) that the lumped drum's single shape
    # lacks: above about 0.9 x that frequency the FE checks show the lumped curves 5-15 % off
    _add_band_options(
        p, 1500.0, ": below the FE eardrum modes; higher bands are allowed, the FE checks say how far off"
    )
    p.add_argument(
        "--fe-checks",
        type=int,
        default=2,
        help="FE whole-ear harmonic spot checks K, log-spaced inside the band, in [0, 50] (default 2)",
    )
    p.add_argument(
        "--tolerance",
        type=_float("--tolerance", lo=0.0),
        default=0.1,
        help="largest relative error of the umbo and stapes against the FE ear, static and at each "
        "FE check (complex, |lumped/FE - 1|; default 0.1)",
    )
    _add_damping_options(p)
    p.add_argument("--out", metavar="DIR", default="ear_sweep", help="output folder (default ./ear_sweep)")
    p.set_defaults(func=_cmd_ear_sweep)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    try:
        args = build_parser().parse_args(argv)
        return args.func(args)
    except (UsageError, InvalidParameter) as exc:
        print(f"isj: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except RuntimeError as exc:  # MeshError, SolverUnavailable: the input was fine, the run failed
        print(f"isj: error: {str(exc).splitlines()[0]}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("isj: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
