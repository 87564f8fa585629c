"""``isj fem solve|cases|modes|mesh|convergence``: the finite-element verifier."""

from __future__ import annotations

import time

from isj.design import Materials
from isj.errors import UsageError

from . import _common as c

#: What ``isj fem modes --vtu-dir`` writes (``mode_01.vtu``, ... and ``modes.pvd``); a folder
#: holding anything else is refused.
MODES_FILES = frozenset({"modes.pvd", *(f"mode_{i:02d}.vtu" for i in range(1, 101))})


def add_joint_options(p) -> None:
    """``--joint`` and ``--layer-shear-pa`` (docs/model.md 2.12)."""
    from isj.fem.sliding import DEFAULT_LAYER_SHEAR_PA, JOINTS

    p.add_argument(
        "--joint",
        choices=JOINTS,
        default="bonded",
        help="the incudostapedial joint: bonded cartilage (the thesis's, default), a frictionless "
        "sliding interface on the gap-plate face, or a layer of low through-thickness shear modulus "
        "(docs/model.md 2.12)",
    )
    p.add_argument(
        "--layer-shear-pa",
        type=c.float_option("--layer-shear-pa", 0.0, 1e12),
        default=None,  # None: DEFAULT_LAYER_SHEAR_PA with --joint layer; refused with another joint
        metavar="PA",
        help="with --joint layer only: the layer's shear modulus G_xz = G_yz in Pa "
        f"(default {DEFAULT_LAYER_SHEAR_PA:g})",
    )


def check_joint_options(args) -> None:
    """``--layer-shear-pa`` only with ``--joint layer``: the other joints have no layer to use it."""
    if getattr(args, "layer_shear_pa", None) is not None and args.joint != "layer":
        raise UsageError(
            f"--layer-shear-pa = {args.layer_shear_pa:g}: only with --joint layer "
            f"(the {args.joint} joint has no layer; it would be unused)"
        )


def _joint_out(args, model, res) -> dict:
    """The joint and how its shear splits (JSON keys of fem solve and fem cases)."""
    from isj.fem.sliding import shear_split

    out = {"joint": model.joint, "layer_shear_pa": model.layer_shear_pa if model.joint == "layer" else None}
    return out | shear_split(model, res)


def register(sub) -> None:
    """Add ``isj fem`` and its commands to the top-level subparsers ``sub``."""
    fem = sub.add_parser("fem", help="the finite-element verifier")
    fsub = fem.add_subparsers(dest="fem_command", required=True, parser_class=c.Parser)
    _add_solve(fsub)
    _add_cases(fsub)
    _add_modes(fsub)
    _add_mesh(fsub)
    _add_convergence(fsub)


def _add_solve(fsub) -> None:
    """``isj fem solve`` and its options."""
    p = fsub.add_parser("solve", help="static solve of one design")
    c.add_design_options(p)
    c.add_mesh_options(p)
    p.add_argument(
        "--mesh",
        metavar="FILE",
        help="solve on your own mesh: a gmsh .msh or any volume mesh meshio reads, with groups named "
        "after the six regions and the faces loaded and clamped (docs/model.md 2.11); not with "
        "--geometry or --resolution",
    )
    p.add_argument(
        "--mesh-unit", choices=("m", "mm", "um"), default="m", help="length unit of --mesh (default m)"
    )
    p.add_argument(
        "--points",
        metavar="FILE",
        help="with --mesh: a TOML file of the point pairs and faces for alpha and beta (docs/model.md 2.11); "
        "without it alpha and beta are the least-squares rotations of the bodies",
    )
    p.add_argument("--vtu", metavar="PATH", help="write the deformed model for ParaView (.vtu)")
    add_joint_options(p)
    c.add_json_option(p)
    p.set_defaults(func=solve)


def _add_cases(fsub) -> None:
    """``isj fem cases`` and its options."""
    p = fsub.add_parser("cases", help="the seven thesis cases")
    c.nu_option(p)
    c.pressure_option(p, "the incus")
    c.add_mesh_options(p)
    p.add_argument("--vtu", metavar="PATH", help="write the base case for ParaView (.vtu)")
    add_joint_options(p)
    c.add_json_option(p, "a JSON list")
    p.set_defaults(func=cases)


def _add_modes(fsub) -> None:
    """``isj fem modes`` and its options."""
    p = fsub.add_parser("modes", help="lowest natural frequencies and mode shapes")
    c.add_design_options(p)
    c.add_mesh_options(p)
    p.add_argument(
        "--n", type=c.int_option("--n", 1, 100), default=6, help="number of modes, in [1, 100] (default 6)"
    )
    p.add_argument("--vtu-dir", metavar="DIR", help="write mode shapes (VTU + modes.pvd)")
    add_joint_options(p)
    c.add_json_option(p)
    p.set_defaults(func=modes)


def _add_mesh(fsub) -> None:
    """``isj fem mesh`` and its options."""
    p = fsub.add_parser("mesh", help="mesh quality and stiffness bandwidth (thesis 6.5)")
    c.add_mesh_options(p)
    p.add_argument(
        "--msh",
        metavar="FILE",
        help="also write the mesh as gmsh 2.2 (.msh) with physical groups named after the regions and "
        "faces, the input of isj fem solve --mesh",
    )
    p.add_argument(
        "--points-out",
        metavar="FILE",
        help="also write the built-in point pairs as an isj fem solve --points file (.toml)",
    )
    p.add_argument(
        "--mesh",
        metavar="FILE",
        help="report (and with --msh convert) your own mesh instead of the built-in one (as for fem solve)",
    )
    p.add_argument(
        "--mesh-unit", choices=("m", "mm", "um"), default="m", help="length unit of --mesh (default m)"
    )
    c.add_json_option(p)
    p.set_defaults(func=mesh)


def _add_convergence(fsub) -> None:
    """``isj fem convergence`` and its options."""
    p = fsub.add_parser("convergence", help="pedicle cantilever against Timoshenko")
    p.add_argument("--direction", choices=("x", "y"), help="direction of the shear load (cantilever)")
    p.add_argument(
        "--model",
        choices=("cantilever", "joint"),
        default="cantilever",
        help="the pedicle cantilever (default) or the base case of the joint model",
    )
    p.add_argument("--order", type=int, choices=(1, 2), default=2, help="P1 or P2 (default 2)")
    c.nu_option(p)
    p.add_argument(
        "--resolutions",
        metavar="R",
        type=c.resolution_option("--resolutions"),
        nargs="+",
        default=None,
        help=f"mesh resolution factors, each in [{c.RESOLUTION_RANGE[0]:g}, {c.RESOLUTION_RANGE[1]:g}] "
        "(default: a preset ladder)",
    )
    p.add_argument("--plot", metavar="PATH", help="write a plot (.png, .pdf or .svg)")
    c.add_json_option(p, "a JSON list")
    p.set_defaults(func=convergence)


def _checked_geometry(args):
    """The geometry, the solver and the model's estimated size, all checked before meshing."""
    geometry = c.geometry(args)
    check_joint_options(args)
    c.check_solver(args.solver)
    c.check_model_size(geometry, args.order, args.resolution)
    c.check_caches(args, "mesh")
    return geometry


def _model(args, geometry, analyse_ahead: bool = True):
    from isj.fem.model import PedicleJointModel
    from isj.fem.sliding import DEFAULT_LAYER_SHEAR_PA

    return PedicleJointModel(
        geometry,
        args.order,
        args.resolution,
        solver=args.solver,
        joint=getattr(args, "joint", "bonded"),
        layer_shear_pa=getattr(args, "layer_shear_pa", None) or DEFAULT_LAYER_SHEAR_PA,
        analyse_ahead=analyse_ahead,  # a model to be solved: its analysis runs while it is assembled
    )


def _user_model(args):
    """The model on ``--mesh`` (and ``--points``), every file checked before anything is built."""
    from isj.errors import InvalidMesh
    from isj.fem.user_mesh import read_mesh
    from isj.fem.user_model import UserMeshModel, read_points

    if args.geometry or args.resolution != 1.0:
        raise UsageError("--geometry, --resolution: not with --mesh (the mesh file is the geometry)")
    c.check_solver(args.solver)
    c.check_caches(args, "mesh")  # the solver's ordering is kept there
    points_file = getattr(args, "points", None)
    try:
        points = read_points(points_file) if points_file is not None else None
    except InvalidMesh as exc:
        raise UsageError(f"--points {exc}") from None
    try:
        t0 = time.perf_counter()
        mesh = read_mesh(args.mesh, order=args.order, unit=args.mesh_unit)
        t1 = time.perf_counter()
    except InvalidMesh as exc:
        raise UsageError(f"--mesh {exc}") from None
    try:
        model = UserMeshModel(mesh, args.order, args.solver, points, f"--points {points_file}")
    except InvalidMesh as exc:  # a point outside its region: the message names --points
        raise UsageError(str(exc)) from None
    model.timings_s["read"] = t1 - t0
    return model


def solve(args) -> int:
    from isj.fem.export import write_model_vtu

    from ..provenance import write_run_record

    vtu = c.check_out_path(args.vtu, "--vtu", ".vtu")
    materials = c.materials(args)
    check_joint_options(args)
    if args.mesh is not None:
        if args.joint != "bonded":
            raise UsageError(f"--joint {args.joint}: only on the built-in mesh, not with --mesh")
        return _solve_user_mesh(args, vtu, materials)
    if args.points is not None:
        raise UsageError("--points: only with --mesh FILE (the built-in model has its own points)")
    geometry = _checked_geometry(args)
    t0 = time.perf_counter()
    model = _model(args, geometry)
    res = model.static(materials, args.pressure)
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
    out |= _joint_out(args, model, res)
    c.check_finite({k: v for k, v in out.items() if v is not None}, c.design_inputs(args))
    if vtu is not None:
        write_model_vtu(vtu, model, res)
        write_run_record(vtu.with_suffix(".json"), args, out)
    if args.json:
        c.print_json(out)
        return 0
    print(f"P{args.order} mesh: {model.n_tets} tets, {model.n_dofs} dofs, solver {model.solver_name}")
    _print_static(args, res, timings, vtu)
    print(
        f"joint {out['joint']}: the shear across the gap's mid-plane is carried "
        f"{100 * out['capsule_shear_share']:.1f}% by the capsule, "
        f"{100 * out['gap_shear_share']:.1f}% by the gap"
    )
    return 0


def _solve_user_mesh(args, vtu, materials) -> int:
    from isj.fem.export import write_model_vtu

    from ..provenance import write_run_record

    t0 = time.perf_counter()
    model = _user_model(args)
    res = model.static(materials, args.pressure)
    timings = dict(model.timings_s, total=time.perf_counter() - t0)
    out = res.to_dict() | {
        "angle_definition": model.angle_definition,
        "mesh_file": str(args.mesh),
        "points_file": None if args.points is None else str(args.points),
        "n_tets": model.n_tets,
        "n_dofs": model.n_dofs,
        "order": args.order,
        "resolution": None,
        "solver": model.solver_name,
        "mesh_hash": model.mesh.content_hash(),
        "timings_s": timings,
    }
    c.check_finite(out, c.design_inputs(args))
    if vtu is not None:
        write_model_vtu(vtu, model, res)
        write_run_record(vtu.with_suffix(".json"), args, out)
    if args.json:
        c.print_json(out)
        return 0
    print(
        f"{args.mesh}: P{args.order}, {model.n_tets} tets, {model.n_dofs} dofs, solver {model.solver_name}; "
        f"alpha and beta from {model.angle_definition}"
    )
    _print_static(args, res, timings, vtu)
    return 0


def _print_static(args, res, timings, vtu) -> None:
    u = c.urad
    print(f"alpha      = {u(res.alpha_rad)} urad   (least squares {u(res.alpha_ls_rad)})")
    print(f"beta       = {u(res.beta_rad)} urad   (least squares {u(res.beta_ls_rad)})")
    print(f"alpha+beta = {u(res.sum_rad)} urad   beta/alpha = {res.ratio:.3f}")
    print(f"max |u|    = {res.max_disp_m:.4e} m at {args.pressure:g} Pa")
    frac = res.energy_fraction()
    print("strain energy: " + ", ".join(f"{k} {100 * v:.1f}%" for k, v in frac.items()))
    print(f"time: {timings['total']:.2f} s")
    if vtu is not None:
        print(f"wrote {vtu}")


def cases(args) -> int:
    from isj.fem.export import write_model_vtu

    from ..cases import THESIS_BASE_ALPHA_RAD, THESIS_BASE_BETA_RAD, THESIS_CASES
    from ..provenance import write_run_record

    vtu = c.check_out_path(args.vtu, "--vtu", ".vtu")
    base = Materials(nu=args.nu)
    geometry = _checked_geometry(args)
    t0 = time.perf_counter()
    model = _model(args, geometry)
    rows, results = [], {}
    for case in THESIS_CASES:
        res = model.static(case.materials(base), args.pressure)
        results[case.name] = res
        moduli = {k: getattr(case, k) for k in ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa")}
        rows.append({"case": case.name} | moduli | res.to_dict() | _joint_out(args, model, res))
    elapsed = time.perf_counter() - t0
    c.check_finite(
        [{k: v for k, v in r.items() if v is not None} for r in rows],
        f"--nu {args.nu:g}, --pressure {args.pressure:g}",
    )
    if vtu is not None:
        write_model_vtu(vtu, model, results["base"])
        record = {"cases": rows, "n_tets": model.n_tets, "n_dofs": model.n_dofs}
        write_run_record(vtu.with_suffix(".json"), args, record)
    if args.json:
        c.print_json(rows)
        return 0
    print(
        f"Seven thesis cases: P{args.order}, {model.n_tets} tets, {model.n_dofs} dofs, "
        f"{args.pressure:g} Pa on the incus, solver {model.solver_name}, {elapsed:.1f} s, joint {model.joint}"
    )
    print(
        f"{'case':7} {'E_ped GPa':>9} {'E_gap MPa':>9} {'E_cap MPa':>9} {'alpha urad':>10} "
        f"{'beta urad':>10} {'a+b urad':>9} {'beta/alpha':>10} {'ped. energy':>11} {'cap. shear':>10}"
    )
    for r in rows:
        print(
            f"{r['case']:7} {r['pedicle_e_pa'] / 1e9:9.3g} {r['gap_e_pa'] / 1e6:9.3g} "
            f"{r['capsule_e_pa'] / 1e6:9.3g} {r['alpha_rad'] * 1e6:10.4f} "
            f"{r['beta_rad'] * 1e6:10.4f} "
            f"{r['alpha_plus_beta_rad'] * 1e6:9.4f} {r['beta_over_alpha']:10.3f} "
            f"{100 * r['strain_energy_fraction']['pedicle']:10.1f}% "
            f"{100 * r['capsule_shear_share']:9.1f}%"
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


def convergence(args) -> int:
    from isj.fem.convergence import cantilever_study, joint_study, plot_study

    if args.model == "joint":
        if args.plot is not None:
            raise UsageError("--plot: only for --model cantilever")
        resolutions = args.resolutions or (0.71, 1.0, 1.41)
        for r in resolutions:
            c.check_model_size(None, args.order, r, "--resolutions")
        c.check_caches(args, "mesh")
        rows = joint_study(args.order, resolutions)
        c.check_finite(rows, f"--order {args.order}")
        if args.json:
            c.print_json(rows)
            return 0
        print(f"Base case at the default pressure, P{args.order}:")
        print(f"{'R':>5} {'n_tets':>8} {'n_dofs':>8} {'alpha urad':>10} {'beta urad':>10} {'time s':>7}")
        for r in rows:
            print(
                f"{r['resolution']:5.2f} {r['n_tets']:8d} {r['n_dofs']:8d} {r['alpha_rad'] * 1e6:10.4f} "
                f"{r['beta_rad'] * 1e6:10.4f} {r['time_s']:7.1f}"
            )
        return 0
    if args.direction is None:
        raise UsageError("--direction: required for --model cantilever (x or y)")
    plot = c.check_out_path(args.plot, "--plot", (".png", ".pdf", ".svg"))
    c.check_caches(args, "mesh")
    rows = cantilever_study(
        direction=args.direction, order=args.order, nu=args.nu, resolutions=args.resolutions
    )
    c.check_finite(rows, f"--nu {args.nu:g}")
    if plot is not None:
        plot_study(rows, plot, title=f"Pedicle cantilever, load in {args.direction}, P{args.order}")
    if args.json:
        c.print_json(rows)
        return 0
    print(
        f"Pedicle cantilever, shear load in {args.direction}, P{args.order}: "
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


def modes(args) -> int:
    from isj.fem.dynamics import modes as fe_modes
    from isj.fem.export import write_modes

    out_dir = None
    if args.vtu_dir is not None:  # a new or empty folder, or one holding only what modes writes
        out_dir = c.check_out_dir(args.vtu_dir, "--vtu-dir", MODES_FILES)
    materials = c.materials(args)
    geometry = _checked_geometry(args)
    t0 = time.perf_counter()
    model = _model(args, geometry)
    freq_hz, shapes = fe_modes(model, materials, args.n)
    elapsed = time.perf_counter() - t0
    out = {
        "freq_hz": [float(f) for f in freq_hz],
        "n_dofs": model.n_dofs,
        "n_tets": model.n_tets,
        "joint": model.joint,
    }
    c.check_finite(out, c.design_inputs(args))
    if out_dir is not None:
        write_modes(out_dir, model, freq_hz, shapes)
    if args.json:
        c.print_json(out | {"time_s": elapsed})
        return 0
    print(f"lowest {args.n} natural frequencies (P{args.order}, {model.n_dofs} dofs, {elapsed:.1f} s):")
    for i, f in enumerate(freq_hz, 1):
        print(f"  mode {i}: {f:10.1f} Hz")
    if out_dir is not None:
        print(f"wrote {out_dir / 'modes.pvd'} and {args.n} VTU files")
    return 0


def mesh(args) -> int:
    from isj.atomic import atomic_write_text
    from isj.fem.quality import mesh_quality, rcm_bandwidth
    from isj.fem.user_mesh import write_mesh
    from isj.fem.user_model import default_points, points_toml

    msh = c.check_out_path(args.msh, "--msh", ".msh")
    points_out = c.check_out_path(args.points_out, "--points-out", ".toml")
    if args.mesh is not None:
        if points_out is not None:
            raise UsageError("--points-out: not with --mesh (it writes the built-in point pairs)")
        model = _user_model(args)
    else:
        geometry = _checked_geometry(args)
        model = _model(args, geometry, analyse_ahead=False)  # nothing is solved
    if msh is not None:
        write_mesh(model.mesh, msh)
    if points_out is not None:
        atomic_write_text(points_out, points_toml(default_points(geometry)))
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
        c.print_json(out)
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
    for written in (msh, points_out):
        if written is not None:
            print(f"wrote {written}")
    return 0
