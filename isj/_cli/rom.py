"""``isj rom build|solve|cases``: the certified reduced-basis surrogate of the static FE model."""

from __future__ import annotations

import sys
import time

from isj.errors import InvalidParameter, UsageError

from . import _common as c


def register(sub) -> None:
    """Add ``isj rom`` and its commands to the top-level subparsers ``sub``."""
    rom = sub.add_parser("rom", help="certified reduced-basis surrogate of the static FE model")
    rsub = rom.add_subparsers(dest="rom_command", required=True, parser_class=c.Parser)

    p = rsub.add_parser("build", help="build the surrogate for a mesh (once; then it is cached)")
    _surrogate_options(p)
    c.add_json_option(p)
    p.set_defaults(func=build)

    p = rsub.add_parser("solve", help="one design through the surrogate: alpha, beta and their bounds")
    c.add_design_options(p)
    _mesh_options(p)
    c.add_json_option(p)
    p.set_defaults(func=solve)

    p = rsub.add_parser("cases", help="the seven thesis cases through the surrogate, with bounds")
    c.nu_option(p)
    p.add_argument(
        "--incus-e",
        metavar="PA",
        type=c.modulus_option("--incus-e"),
        default=12e9,
        help="Young's modulus of the incus (Pa; default 12e9): fixed per surrogate",
    )
    c.pressure_option(p, "the incus")
    _mesh_options(p)
    c.add_json_option(p, "a JSON list")
    p.set_defaults(func=cases)


def _mesh_options(p) -> None:
    c.add_geometry_option(p)
    c.add_order_resolution(p)


def _surrogate_options(p) -> None:
    c.nu_option(p)
    p.add_argument(
        "--incus-e",
        metavar="PA",
        type=c.modulus_option("--incus-e"),
        default=12e9,
        help="Young's modulus of the incus (Pa; default 12e9): fixed per surrogate",
    )
    _mesh_options(p)
    p.add_argument(
        "--tol",
        type=c.float_option("--tol", 1e-6, 0.5, lo_open=False, hi_open=False),
        default=1e-3,
        help="largest relative bound on alpha, beta and beta/alpha over the domain, in [1e-6, 0.5] "
        "(default 1e-3)",
    )


def _space(args):
    from isj.design_space import DesignSpace

    return DesignSpace(incus_e_pa=args.incus_e, nu=args.nu)


def _checked(args):
    """Geometry and model size checked before anything is meshed or built."""
    geometry = c.geometry(args)
    c.check_model_size(geometry, args.order, args.resolution)
    c.check_caches(args, "mesh", "rom")
    return geometry


def _surrogate(args, geometry, space, quiet: bool):
    from isj.fem.rom import reduced_model

    def progress(step):
        if not quiet and step["n_snapshots"] % 10 == 0:
            top = step["train_max_rel_bound"]
            shown = "inf" if top is None else f"{top:.2e}"
            print(f"  greedy: {step['n_snapshots']} snapshots, worst training bound {shown}", file=sys.stderr)

    return reduced_model(
        geometry, args.order, args.resolution, space, tol=getattr(args, "tol", 1e-3), progress=progress
    )


def build(args) -> int:
    space = _space(args)
    geometry = _checked(args)
    t0 = time.perf_counter()
    rom = _surrogate(args, geometry, space, args.json)
    m = rom.meta
    out = {
        "n_snapshots": m["n_snapshots"],
        "n_basis": rom.n_basis,
        "converged": m["converged"],
        "tol": m["tol"],
        "validate_max_rel_bound": m["validate_max_rel_bound"],
        "local_validate_max_rel_bound": m.get("local_validate_max_rel_bound"),
        "local_sizes": m.get("local_sizes"),
        "n_validate": m["n_validate"],
        "build_time_s": m["build_time_s"],
        "time_s": time.perf_counter() - t0,
        "domain_pa": {k: list(v) for k, v in space.bounds.items()},
        "incus_e_pa": space.incus_e_pa,
        "nu": space.nu,
    } | rom.sizes()
    if args.json:
        c.print_json(out)
        return 0
    print(
        f"surrogate for P{args.order} mesh {m['mesh_hash'][:12]} ({m['n_dofs']} dofs): "
        f"{m['n_snapshots']} FE snapshots, bases {rom.n_basis}"
    )
    print(
        f"largest relative bound over {m['n_validate']} validation designs (corners included): "
        f"{m['validate_max_rel_bound']:.2e} (target {m['tol']:g}{'' if m['converged'] else ', NOT reached'})"
    )
    if m.get("local_sizes"):
        sizes = m["local_sizes"]
        print(
            f"local bases in {len(sizes)} sub-boxes: sizes {min(sizes)}-{max(sizes)} "
            f"of {rom.n_basis['primal']}; "
            f"largest relative bound over the validation designs through them "
            f"{m['local_validate_max_rel_bound']:.2e}"
        )
    print(f"built in {m['build_time_s']:.1f} s; this call {out['time_s']:.2f} s")
    return 0 if m["converged"] else c.fail(f"the target bound {m['tol']:g} was not reached")


def solve(args) -> int:
    from isj.design_space import DesignSpace

    materials = c.materials(args)
    space = DesignSpace(incus_e_pa=args.incus_e, nu=args.nu)
    try:  # refused before anything is built
        space.designs_from(materials)
    except InvalidParameter as exc:  # "pedicle_e_pa = ... Pa: outside ..." → also name the option
        name = str(exc).split(" ", 1)[0]
        flag = f"--{name.removesuffix('_e_pa')}-e: " if name.endswith("_e_pa") else ""
        raise UsageError(f"{flag}{exc}") from None
    geometry = _checked(args)
    t0 = time.perf_counter()
    rom = _surrogate(args, geometry, space, args.json)
    out = rom.static(materials, args.pressure).to_dict()
    out["timings_s"] = {"total": time.perf_counter() - t0}
    c.check_finite(out, c.design_inputs(args))
    if args.json:
        c.print_json(out)
        return 0
    u = c.urad
    print(f"surrogate of the P{args.order} mesh ({out['n_dofs']} dofs), bases {out['n_basis']}")
    print(f"alpha      = {u(out['alpha_rad'])} urad  +- {out['alpha_bound_rad'] * 1e6:.2e}")
    print(f"beta       = {u(out['beta_rad'])} urad  +- {out['beta_bound_rad'] * 1e6:.2e}")
    print(
        f"alpha+beta = {u(out['alpha_plus_beta_rad'])} urad  +- {out['alpha_plus_beta_bound_rad'] * 1e6:.2e}"
    )
    print(f"beta/alpha = {out['beta_over_alpha']:9.4f}       +- {out['beta_over_alpha_bound']:.2e}")
    return 0


def cases(args) -> int:
    space = _space(args)
    geometry = _checked(args)
    rom = _surrogate(args, geometry, space, args.json)
    t0 = time.perf_counter()
    rows = rom.cases(args.pressure)
    elapsed = time.perf_counter() - t0
    c.check_finite(rows, f"--nu {args.nu:g}, --pressure {args.pressure:g}")
    if args.json:
        c.print_json(rows)
        return 0
    print(
        f"Seven thesis cases through the surrogate (P{args.order}, {rom.meta['n_dofs']} dofs): "
        f"{elapsed * 1e3:.1f} ms"
    )
    print(f"{'case':7} {'alpha urad':>10} {'+-':>8} {'beta urad':>10} {'+-':>8} {'beta/alpha':>10} {'+-':>8}")
    for r in rows:
        print(
            f"{r['case']:7} {r['alpha_rad'] * 1e6:10.4f} {r['alpha_bound_rad'] * 1e6:8.1e} "
            f"{r['beta_rad'] * 1e6:10.4f} {r['beta_bound_rad'] * 1e6:8.1e} "
            f"{r['beta_over_alpha']:10.4f} {r['beta_over_alpha_bound']:8.1e}"
        )
    return 0
