"""``isj explore``: the lumped model over a grid or a sample, guarded by the surrogate and FE checks."""

from __future__ import annotations

import itertools
import sys

from isj.design import Materials
from isj.errors import UsageError

from . import _common as c

#: Files ``--out`` holds besides the maps.
OUT_FILES = ("designs.csv", "designs.npz", "guard.json", "config.json")

#: Most designs ``--out`` writes (one CSV row each: about 400 bytes).
MAX_OUT_DESIGNS = 1_000_000


def map_name(a: str, b: str) -> str:
    """The map of β/α over moduli ``a`` and ``b`` (``pedicle_e_pa``, ...): ``map_pedicle_gap.png``."""
    return f"map_{a.removesuffix('_e_pa')}_{b.removesuffix('_e_pa')}.png"


def out_entries() -> frozenset[str]:
    """Everything ``--out`` may hold: the files and every possible map."""
    names = [f"{r}_e_pa" for r in c.MODULUS_OPTIONS]
    return frozenset(OUT_FILES) | {map_name(a, b) for a, b in itertools.combinations(names, 2)}


def register(sub) -> None:
    """Add ``isj explore`` to the top-level subparsers ``sub``."""
    from isj.calibration.guard import DEFAULT_DENSE, MAX_DENSE

    p = sub.add_parser("explore", help="lumped model over many designs, guarded by the surrogate and FE")
    d = Materials()
    for r in c.MODULUS_OPTIONS:
        p.add_argument(
            f"--{r}-e",
            metavar="PA[:PA]",
            type=c.range_option(f"--{r}-e"),
            default=(d.youngs(r), d.youngs(r)),
            help=f"modulus of the {r} (Pa, in [{c.MODULUS_RANGE_PA[0]:g}, {c.MODULUS_RANGE_PA[1]:g}]), "
            "or a LOW:HIGH range explored log-uniformly",
        )
    c.pressure_option(p)
    p.add_argument("--n", type=int, default=5, help="grid points per ranged modulus (default 5)")
    p.add_argument("--sample", type=int, help="instead of a grid: N Latin-hypercube designs")
    c.seed_option(p, "--sample, the guard's dense sample and the unguarded spot checks")
    p.add_argument("--spot-checks", type=int, default=4, help="FE spot checks K (default 4)")
    p.add_argument(
        "--tolerance",
        type=c.float_option("--tolerance", lo=0.0),
        default=0.03,
        help="largest relative error of the lumped model, against FE in a spot check and "
        "(certified) against the surrogate in the guard (default 0.03)",
    )
    p.add_argument(
        "--no-guard", action="store_true", help="no surrogate: FE spot checks only, at the extreme corners"
    )
    p.add_argument(
        "--guard-sample",
        metavar="N",
        type=c.int_option("--guard-sample", 0, MAX_DENSE),
        default=DEFAULT_DENSE,
        help=f"Sobol designs of the calibrated domain the guard checks, in [0, {MAX_DENSE}] "
        f"(default {DEFAULT_DENSE})",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="write designs.csv, designs.npz, guard.json, config.json and the beta/alpha maps here "
        f"(replaced as a whole; at most {MAX_OUT_DESIGNS:.0e} designs)",
    )
    c.add_geometry_option(p)  # another geometry: the shipped geometry calibration (isj lumped solve's)
    c.add_calibration_option(p)
    c.add_cache_option(p)
    p.add_argument(
        "--order", type=int, choices=(1, 2), default=2, help="FE order of the surrogate and spot checks"
    )
    lo, hi = c.RESOLUTION_RANGE
    p.add_argument(
        "--resolution",
        metavar="R",
        type=c.resolution_option("--resolution"),
        default=1.0,
        help=f"FE mesh refinement of the surrogate and spot checks, in [{lo:g}, {hi:g}] (default 1)",
    )
    c.add_json_option(p)
    p.set_defaults(func=explore)


def load_surrogate(
    order: int, resolution: float, geometry=None, incus_e_pa: float | None = None, progress=None
):
    """The surrogate of the FE model on one mesh: ``(rom, None)``, or ``(None, why)`` without one.

    Built the first time for a mesh (minutes on the default one), then read from the cache
    (:func:`isj.fem.rom.reduced_model`). Without gmsh (and no cached mesh) the reason says so and
    the command goes on unguarded.
    """
    from isj.errors import MeshError

    try:
        from isj.design_space import DesignSpace
        from isj.fem.rom import reduced_model

        space = DesignSpace(incus_e_pa=Materials().incus_e_pa if incus_e_pa is None else float(incus_e_pa))
        return reduced_model(geometry, order, resolution, space, progress=progress), None
    except (ImportError, MeshError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return None, f"no surrogate of the P{order} mesh at resolution {resolution:g}: {first}"


def _surrogate(args):
    """(rom, None) or (None, why); a first build of the mesh's surrogate, or none, says so on stderr."""
    told = []

    def progress(step):
        if not told:
            told.append(True)
            print(
                f"isj: building the surrogate of the P{args.order} mesh at resolution {args.resolution:g} "
                "(once per mesh; minutes; then cached)",
                file=sys.stderr,
            )

    lo, hi = args.incus_e
    geometry = c.geometry(args) if args.geometry else None
    rom, why = load_surrogate(args.order, args.resolution, geometry, lo if lo == hi else None, progress)
    if rom is None:
        print(f"isj: warning: {why}; the lumped model is NOT guarded (FE spot checks only)", file=sys.stderr)
    return rom, why


def _checked(args):
    """(calibration, geometry, space, out folder or None) of ``args``: UsageError for a bad option.

    Warns for a dimension outside the calibration's geometry; refuses a count of designs too
    large before anything of that size is allocated.
    """
    from isj.studies.explore import MAX_DESIGNS, ExploreSpace, count_designs

    from .lumped import calibration_and_geometry

    cal, geometry = calibration_and_geometry(args)
    if args.n < 1 or (args.sample is not None and args.sample < 1) or args.spot_checks < 0:
        raise UsageError("--n, --sample: must be >= 1; --spot-checks: must be >= 0")
    guarded = not args.no_guard
    out = c.check_out_dir(args.out, "--out", out_entries()) if args.out is not None else None
    if args.spot_checks or guarded:
        c.check_model_size(geometry, args.order, args.resolution)
        c.check_caches(args, "mesh", "fe", *(("rom",) if guarded else ()))
    space = ExploreSpace(**{f"{r}_e_pa": getattr(args, f"{r}_e") for r in c.MODULUS_OPTIONS})
    total = count_designs(space, args.n, args.sample)
    flag = f"--sample = {args.sample}" if args.sample is not None else f"--n = {args.n}"
    if total > MAX_DESIGNS:
        raise UsageError(f"{flag}: {total:.3g} designs is too many (at most {MAX_DESIGNS:.0e})")
    if out is not None and total > MAX_OUT_DESIGNS:
        raise UsageError(
            f"{flag}: {total:.3g} designs is too many to write with --out (at most {MAX_OUT_DESIGNS:.0e})"
        )
    return cal, geometry, space, out


def explore(args) -> int:
    """``isj explore``: check the options, run :func:`isj.studies.explore.run_explore`, write, print.

    Returns 0, or 1 when an explored design fails its FE spot check or the guard, or FE lies
    outside the surrogate's bound (one ``isj: error:`` line naming each).
    """
    from isj.studies.explore import run_explore

    from ..caches import fe_cache_dir

    cal, geometry, space, out = _checked(args)
    run = run_explore(
        cal,
        space,
        (lambda: (None, "--no-guard")) if args.no_guard else (lambda: _surrogate(args)),
        fe_cache_dir(args.cache),
        n=args.n,
        sample=args.sample,
        seed=args.seed,
        spot_checks=args.spot_checks,
        tolerance=args.tolerance,
        n_dense=args.guard_sample,
        geometry=geometry,
        pressure_pa=args.pressure,
        order=args.order,
        resolution=args.resolution,
        progress=not args.json,
    )
    c.check_finite(run.summary, f"--pressure {args.pressure:g}")
    if out is not None:
        write_outputs(out, args, run.exploration, space, run.guard, run.summary)
    if args.json:
        c.print_json(run.summary)
    else:
        _print(args, run.exploration, run.checks, run.guard, run.summary["region"])
    return c.fail("; ".join(run.failures)) if run.failures else 0


def _pct(x) -> str:
    return "n/a" if x is None else f"{100 * x:.2f} %"


def _print(args, ex, checks, g, region=None) -> None:
    lum, u = ex.lumped, c.urad
    print(
        f"lumped model: {ex.n_designs} designs in {ex.lumped_time_s * 1e3:.2f} ms; alpha "
        f"{u(lum.alpha_rad.min())} .. {u(lum.alpha_rad.max())} urad, beta {u(lum.beta_rad.min())} .. "
        f"{u(lum.beta_rad.max())} urad"
    )
    if g["available"]:
        s = g["surrogate"]
        print(
            f"guard (surrogate of the P{s.get('order')} mesh, {s.get('n_dofs')} dofs; certified error "
            f"of alpha, beta, beta/alpha within {100 * args.tolerance:g} %) in {g['time_s']:.2f} s:"
        )
        for name in ("explored", "corners", "dense"):
            r = g[name]
            w = r["worst"]
            where = ""
            if w and "pedicle_e_pa" in w:
                where = " at " + ", ".join(
                    f"{k.removesuffix('_e_pa')} {w[k]:.3g}" for k in w if k.endswith("_e_pa")
                )
            print(
                f"  {name:8}: {r['n_ok']}/{r['n']} ok, {r['n_fail']} fail, {r['n_outside']} outside; "
                f"worst {_pct(r['max_certified_error'])}{where}"
            )
        conf = g["fe_confirmations"]
        if conf:
            print(
                f"  FE confirms the surrogate's bound at {sum(r['confirmed'] for r in conf)}/{len(conf)} "
                "worst designs"
            )
    for ck in checks:
        print(
            f"  FE spot check ({ck['set']}): alpha {100 * ck['alpha_rel_error']:+6.2f} %, beta "
            f"{100 * ck['beta_rel_error']:+6.2f} % {'ok' if ck['passed'] else 'EXCEEDS tolerance'}"
        )
    n_ok = sum(ck["passed"] for ck in checks)
    n_other = sum(ck["set"] != "explored" for ck in checks)
    note = (
        f" ({n_other} of them outside the explored designs: reported, they fail nothing)" if n_other else ""
    )
    print(f"{n_ok}/{len(checks)} spot checks within {100 * args.tolerance:g} %{note}")
    if region and region["n_outside"]:
        r = region
        beside = "the surrogate's values beside the lumped ones" if g["available"] else "no surrogate"
        print(
            f"{r['n_outside']}/{r['n']} explored designs lie OUTSIDE the region where the lumped model holds "
            f"{100 * r['tolerance']:g} % (certified; in_region = false in designs.csv, {beside})"
        )


# ---- --out -----------------------------------------------------------------------------------------


def columns() -> list[str]:
    """Columns of designs.csv after the moduli, in order; units in :data:`UNITS`."""
    from isj.calibration.guard import GUARDED, short

    out = [f"lumped_{k}" for k in GUARDED]
    for k, kb in GUARDED.items():
        out += [f"surrogate_{k}", f"surrogate_{kb}"]
    out += [f"{short(k)}_rel_error" for k in GUARDED] + [f"{short(k)}_certified_error" for k in GUARDED]
    return out + ["max_certified_error", "verdict", "in_region"]


UNITS = (
    "*_e_pa Pa; *_rad rad; beta_over_alpha and its bound dimensionless; "
    "*_rel_error = lumped / surrogate - 1, "
    "*_certified_error = max |lumped / FE - 1| allowed by the surrogate's bound, both relative; "
    "verdict ok|fail|outside|unguarded; "
    "in_region true|false|n/a: inside the calibration's map of where the lumped model holds its tolerance"
)


def design_table(ex) -> dict:
    """designs.csv's columns: name → (n,) array (verdict: strings); NaN where the surrogate has none."""
    import numpy as np

    from isj.calibration.guard import short
    from isj.lumped.model import MODULI

    n = ex.n_designs
    if ex.guard is not None:
        s = ex.guard.sets["explored"]
        cols = {k: s.designs[k] for k in MODULI} | {f"lumped_{k}": v for k, v in s.lumped.items()}
        cols |= {f"surrogate_{k}": v for k, v in s.surrogate.items()}
        cols |= {f"{short(k)}_rel_error": v for k, v in s.error.items()}
        cols |= {f"{short(k)}_certified_error": v for k, v in s.certified.items()}
        cols |= {"max_certified_error": s.max_certified, "verdict": s.verdict}
    else:
        a, b = np.asarray(ex.lumped.alpha_rad, float), np.asarray(ex.lumped.beta_rad, float)
        m = Materials()
        cols = {k: np.broadcast_to(ex.designs.get(k, getattr(m, k)), (n,)) for k in MODULI}
        cols |= {"lumped_alpha_rad": a, "lumped_beta_rad": b, "lumped_beta_over_alpha": b / a}
        cols |= {k: np.full(n, np.nan) for k in columns() if k not in cols}
        cols["verdict"] = np.full(n, "unguarded")
    marks = {True: "true", False: "false"}
    cols["in_region"] = (
        np.full(n, "n/a") if ex.in_region is None else np.array([marks[bool(v)] for v in ex.in_region])
    )
    return {k: np.asarray(cols[k]) for k in [*MODULI, *columns()]}


def write_csv(path, table: dict, units: str) -> None:
    import numpy as np

    from ..atomic import atomic_write_text

    text = [
        np.asarray(v) if v.dtype.kind == "U" else np.char.mod("%.17g", np.asarray(v, dtype=float))
        for v in table.values()
    ]
    rows = "\n".join(",".join(r) for r in zip(*text, strict=True))
    atomic_write_text(path, f"# units: {units}\n{','.join(table)}\n{rows}\n")


def write_maps(out, args, ex, space, table) -> list[str]:
    """One PNG per pair of ranged moduli: lumped β/α (grid: a slice through the middle of the others)."""
    import numpy as np
    from matplotlib.figure import Figure

    from ..atomic import atomic_write

    ranged = list(space.ranged)
    ratio = table["lumped_beta_over_alpha"]
    fail = table["verdict"] == "fail"
    grid = args.sample is None
    written = []
    for a, b in itertools.combinations(ranged, 2):
        ia, ib = ranged.index(a), ranged.index(b)
        fig = Figure(figsize=(5.5, 4.5))
        ax = fig.subplots()
        if grid:
            shape = (args.n,) * len(ranged)
            idx = [slice(None) if j in (ia, ib) else args.n // 2 for j in range(len(ranged))]
            pick = np.arange(ex.n_designs).reshape(shape)[tuple(idx)]
            x, y, z = (np.asarray(v)[pick] for v in (table[a], table[b], ratio))  # (n, n) with a before b
            img = ax.pcolormesh(x, y, z, shading="nearest")
            ff = fail[pick]
            others = [k for k in ranged if k not in (a, b)]
            note = "others at their middle grid value" if others else ""
        else:
            x, y, z, ff = table[a], table[b], ratio, fail
            img = ax.scatter(x, y, c=z, s=6)
            note = f"{ex.n_designs} sampled designs, all others projected"
        if np.any(ff):
            ax.plot(np.asarray(x)[ff], np.asarray(y)[ff], "rx", ms=5, label="guard: fail")
            ax.legend(loc="best", fontsize=7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"{a} (Pa)")
        ax.set_ylabel(f"{b} (Pa)")
        ax.set_title(f"lumped beta/alpha{'; ' + note if note else ''}", fontsize=8)
        fig.colorbar(img, ax=ax, label="beta/alpha")
        name = map_name(a, b)
        atomic_write(out / name, lambda tmp, fig=fig: fig.savefig(tmp, dpi=110, format="png"))
        written.append(name)
    return written


def write_outputs(out, args, ex, space, guard: dict, summary: dict) -> None:
    """designs.csv, designs.npz, the maps, guard.json and config.json, all at once (replace_dir)."""
    import numpy as np

    from ..atomic import atomic_write_json, replace_dir
    from ..provenance import write_run_record
    from ._output import write_npz

    table = design_table(ex)
    units = f"{UNITS}; pressure {args.pressure:g} Pa; tolerance {args.tolerance:g}"
    with replace_dir(out) as staging:  # every file appears together or none does
        write_csv(staging / "designs.csv", table, units)
        write_npz(staging / "designs.npz", **table, units=np.array(units))
        maps = write_maps(staging, args, ex, space, table)
        atomic_write_json(staging / "guard.json", guard)
        write_run_record(
            staging / "config.json", args, summary | {"maps": maps, "files": [*OUT_FILES, *maps]}
        )
