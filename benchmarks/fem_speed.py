"""Speed of the FE verifier on the base case, and isj against scikit-fem on the same mesh.

Run:  .venv/bin/python benchmarks/fem_speed.py [--order 2] [--resolution 1] [--skip-skfem]
      .venv/bin/python benchmarks/fem_speed.py --against /tmp/isj-base [--repeat 3]

With ``--against BASE`` (a checkout of older code, e.g. ``git worktree add
/tmp/isj-base <commit>``) it measures instead the three end-to-end figures of
docs/performance.md §8.2, each in a fresh process: ``isj fem solve`` with the
mesh cached, a new geometry (meshed, assembled, solved, α and β; an empty
cache), and ``isj fem cases``. The base and this checkout take turns, so that
a loaded, shared machine slows both alike; the least wall time of the rounds
is the least disturbed, the CPU time (user + system, all threads) the
steadiest. It prints medians, least times, the ratios of this checkout's to
the base's and the load average, checks that α and β agree (bit for bit,
else to 1e-10, inside the FE results' honesty tolerance of docs/developer/cache-keys.md §3:
PARDISO's thread count moves them by 8.5e-12, dropping its iterative refinement by 4.7e-11),
and writes ``benchmarks/results/fem_speed.json``.

Prints mesh, assembly and solve times and dofs; the end-to-end time of
``isj fem solve`` with the mesh cached (a fresh process, imports included); the
seven thesis cases with one assembly; and the ratio of isj's assembly + solve to
scikit-fem's default path (``asm`` per region, ``condense``, ``solve`` =
scipy's sparse direct solver) on the same mesh and order, measured in one run,
with the two solutions compared.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from isj.fem.assembly import assemble_regions, build_pattern, combine, lame_unit
from isj.fem.boundary import Reduction, clamped_dofs, pressure_load
from isj.fem.mesh import mesh_pedicle_joint
from isj.fem.model import PedicleJointModel
from isj.fem.solvers import make_solver
from isj.fem.space import build_space

from isj.cases import THESIS_CASES
from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials


def best_of(fn, repeat=3):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def isj_assemble_solve(mesh, order, materials):
    """isj's path from a mesh to the displacement: returns (timings, u)."""
    t = {}
    t0 = time.perf_counter()
    space = build_space(mesh, order)
    pattern = build_pattern(space)
    regions = assemble_regions(space, pattern)
    lam, mu = lame_unit(materials.nu)
    coef = {r: (materials.youngs(r) * lam, materials.youngs(r) * mu) for r in regions}
    data = combine(pattern, regions, coef)
    red = Reduction.build(pattern, clamped_dofs(space, "clamped"))
    f = pressure_load(space, "loaded", DEFAULT_PRESSURE_PA, (1, 0, 0))
    K = red.matrix(data)
    t1 = time.perf_counter()
    s = make_solver(K)
    s.factor(K)
    u = red.expand(np.ravel(s.solve(red.restrict(f))))
    t2 = time.perf_counter()
    t.update(assembly=t1 - t0, solve=t2 - t1, total=t2 - t0, solver=s.name)
    return t, u, space


def skfem_assemble_solve(mesh, order, materials):
    """scikit-fem's default path on the same mesh: returns (timings, u in isj's dof order)."""
    import skfem
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    t0 = time.perf_counter()
    m = skfem.MeshTet(mesh.points.T.copy(), mesh.tets.T.copy())
    elem = skfem.ElementVector(skfem.ElementTetP1() if order == 1 else skfem.ElementTetP2())
    K = None
    for rid, name in enumerate(mesh.region_names):
        basis = skfem.Basis(m, elem, elements=np.flatnonzero(mesh.region == rid))
        Kr = linear_elasticity(*lame_parameters(materials.youngs(name), materials.nu)).assemble(basis)
        K = Kr if K is None else K + Kr
    full = skfem.Basis(m, elem)
    # load: the same consistent nodal forces as isj (∫ N_i p dA), built on skfem's facets
    loaded = _facets_of(m, mesh.faces["loaded"])
    clamped = _facets_of(m, mesh.faces["clamped"])
    fb = skfem.FacetBasis(m, elem, facets=loaded)

    @skfem.LinearForm
    def pressure(v, w):
        return DEFAULT_PRESSURE_PA * v[0]

    f = pressure.assemble(fb)
    D = full.get_dofs(clamped).all()
    t1 = time.perf_counter()
    u = skfem.solve(*skfem.condense(K, f, D=D))
    t2 = time.perf_counter()
    return {"assembly": t1 - t0, "solve": t2 - t1, "total": t2 - t0}, _to_isj_order(u, full, m, order)


def _facets_of(m, tris):
    """skfem facet indices of the given triangles."""
    key = {tuple(sorted(f)): i for i, f in enumerate(m.facets.T)}
    return np.array([key[tuple(sorted(t))] for t in tris])


def _to_isj_order(u, basis, m, order):
    """Reorder a skfem vector field to isj's node numbering (vertices, then edges)."""
    nodal = u[basis.nodal_dofs].T  # (n_vertices, 3)
    if order == 1:
        return nodal.ravel()
    edge_vals = u[basis.edge_dofs].T  # (n_edges, 3), skfem edge order
    nv = m.p.shape[1]
    keys = np.sort(m.edges, axis=0)
    order_idx = np.argsort(keys[0] * nv + keys[1])  # isj numbers edges by sorted key
    return np.vstack([nodal, edge_vals[order_idx]]).ravel()


def end_to_end_cli(order, resolution):
    cmd = [
        sys.executable,
        "-m",
        "isj",
        "fem",
        "solve",
        "--json",
        "--order",
        str(order),
        "--resolution",
        str(resolution),
    ]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return time.perf_counter() - t0, json.loads(out)


OUT = Path(__file__).resolve().parent / "results" / "fem_speed.json"
#: How far α and β may move from the base's (relative), inside the FE results' honesty tolerance.
AGREE_RTOL = 1e-10

#: Runs ``isj`` (argv after the checkout's path) from the checkout given first, whatever is installed.
_LAUNCH = """
import importlib.util, runpy, sys, tomllib
from pathlib import Path
root = Path(sys.argv.pop(1)).resolve()
dirs = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
class Finder:
    @classmethod
    def find_spec(cls, name, path=None, target=None):
        if name in dirs:
            d = root / dirs[name]
            return importlib.util.spec_from_file_location(name, d / "__init__.py",
                                                          submodule_search_locations=[str(d)])
        return None
sys.meta_path.insert(0, Finder)
runpy.run_module("isj", run_name="__main__", alter_sys=True)
"""

#: The new geometry of the second figure: the pedicle 10 µm thicker than the default's.
NEW_GEOMETRY = "pedicle_x_m=65e-6"


def _children_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _run_isj(checkout: Path, isj_args: list[str], env: dict) -> tuple[float, float, object]:
    """Wall time (s), CPU time (s, user + system, all threads) and parsed JSON of
    ``isj ISJ_ARGS --json`` run from ``checkout`` in a fresh process."""
    cmd = [sys.executable, "-c", _LAUNCH, str(checkout), *isj_args, "--json"]
    c0, t0 = _children_cpu_s(), time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env).stdout
    return time.perf_counter() - t0, _children_cpu_s() - c0, json.loads(out)


def _angles(out) -> list[float]:
    rows = out if isinstance(out, list) else [out]
    return [v for r in rows for v in (r["alpha_rad"], r["beta_rad"])]


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def against(base: Path, repeat: int, cache_dir: Path) -> dict:
    """The three end-to-end figures, base and this checkout interleaved; see the module docstring."""
    here = Path(__file__).resolve().parents[1]
    sides = {"base": base.resolve(), "new": here}
    env = dict(os.environ, ISJ_CACHE_DIR=str(cache_dir))
    figures = {
        "solve_cached_s": ["fem", "solve"],
        "new_geometry_s": ["fem", "solve", "--geometry", NEW_GEOMETRY],
        "cases_s": ["fem", "cases"],
    }
    for root in sides.values():  # warm the mesh (and ordering) cache of each side's code
        _run_isj(root, figures["solve_cached_s"], env)
    times = {f: {s: [] for s in sides} for f in figures}
    cpu = {f: {s: [] for s in sides} for f in figures}
    steps = {f: {} for f in figures}
    angles = {f: {} for f in figures}
    load = [_load()]
    for rep in range(repeat):
        for figure, isj_args in figures.items():
            for side, root in sides.items():
                run_env = env
                if figure == "new_geometry_s":  # an empty cache: gmsh, assembly, METIS, all of it
                    run_env = dict(env, ISJ_CACHE_DIR=tempfile.mkdtemp(dir=cache_dir))
                t, c, out = _run_isj(root, isj_args, run_env)
                times[figure][side].append(t)
                cpu[figure][side].append(c)
                angles[figure].setdefault(side, _angles(out))
                if isinstance(out, dict):  # isj fem solve's own split of its time, the last run's
                    steps[figure][side] = out["timings_s"]
                print(f"  rep {rep} {figure:15s} {side:4s} {t:6.2f} s wall, {c:6.2f} s CPU", flush=True)
        load.append(_load())
    rows = {}
    for figure in figures:
        b, n = (statistics.median(times[figure][s]) for s in ("base", "new"))
        cb, cn = (statistics.median(cpu[figure][s]) for s in ("base", "new"))
        a_b, a_n = (angles[figure][s] for s in ("base", "new"))
        rel = max(abs(x - y) / abs(x) for x, y in zip(a_b, a_n, strict=True))
        rows[figure] = {
            "base_s": times[figure]["base"],
            "new_s": times[figure]["new"],
            "median_base_s": b,
            "median_new_s": n,
            "ratio_new_to_base": n / b,
            "min_base_s": min(times[figure]["base"]),
            "min_new_s": min(times[figure]["new"]),
            "min_ratio_new_to_base": min(times[figure]["new"]) / min(times[figure]["base"]),
            "base_cpu_s": cpu[figure]["base"],
            "new_cpu_s": cpu[figure]["new"],
            "cpu_ratio_new_to_base": cn / cb,
            "alpha_beta_bitwise_equal": a_b == a_n,
            "alpha_beta_max_rel_diff": rel,
            "steps_s": steps[figure],
        }
        print(
            f"{figure:15s} median base {b:6.2f} s  new {n:6.2f} s  ratio {n / b:.2f}; "
            f"least {min(times[figure]['base']):.2f} s, {min(times[figure]['new']):.2f} s; "
            f"CPU {cb:.2f} s, {cn:.2f} s, ratio {cn / cb:.2f}  "
            f"alpha, beta {'bit for bit' if a_b == a_n else f'within {rel:.1e}'}"
        )
    print(f"load average (1, 5, 15 min) before and after each round: {load}")
    return {"figures": rows, "load_average": load, "repeat": repeat, "cpus": os.cpu_count()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order", type=int, default=2, choices=(1, 2))
    ap.add_argument("--resolution", type=float, default=1.0)
    ap.add_argument("--skip-skfem", action="store_true")
    ap.add_argument("--against", type=Path, metavar="BASE", help="a checkout of older code to compare with")
    ap.add_argument("--repeat", type=int, default=3, help="rounds with --against (default 3)")
    ap.add_argument("--json", type=Path, default=OUT, help=f"where --against writes (default {OUT.name})")
    args = ap.parse_args(argv)
    if args.against is not None:
        with tempfile.TemporaryDirectory() as tmp:
            result = against(args.against, args.repeat, Path(tmp))
        result["base_commit"] = subprocess.run(
            ["git", "-C", str(args.against), "rev-parse", "HEAD"], capture_output=True, text=True
        ).stdout.strip()
        args.json.write_text(json.dumps(result, indent=2, sort_keys=True) + "\n")
        print(f"wrote {args.json}")
        worst = max(f["alpha_beta_max_rel_diff"] for f in result["figures"].values())
        if worst > AGREE_RTOL:  # faster, but not the same answers: a failure, not a figure
            sys.exit(f"alpha, beta differ from the base's by {worst:.1e} (relative) > {AGREE_RTOL:g}")
        return
    g, mat = Geometry(), Materials()

    with tempfile.TemporaryDirectory() as tmp:
        t_mesh, mesh = best_of(lambda: mesh_pedicle_joint(g, args.resolution, cache_dir=False), 1)
        mesh_pedicle_joint(g, args.resolution, cache_dir=tmp)
        t_cached, _ = best_of(lambda: mesh_pedicle_joint(g, args.resolution, cache_dir=tmp), 3)
    print(f"mesh: {mesh.n_tets} tets; gmsh {t_mesh:.2f} s, from cache {t_cached * 1e3:.0f} ms")

    mesh_pedicle_joint(g, args.resolution)  # make sure the default cache holds it
    t_isj, (ti, u_isj, space) = best_of(lambda: isj_assemble_solve(mesh, args.order, mat), 3)
    print(
        f"isj P{args.order}: {3 * space.n_nodes} dofs; assembly {ti['assembly']:.3f} s, "
        f"solve ({ti['solver']}) {ti['solve']:.3f} s, total {ti['total']:.3f} s"
    )

    t_e2e, out = end_to_end_cli(args.order, args.resolution)
    print(
        f"end to end `isj fem solve` (fresh process, mesh cached): {t_e2e:.2f} s wall; "
        f"alpha {out['alpha_rad'] * 1e6:.4f} urad, beta {out['beta_rad'] * 1e6:.4f} urad"
    )

    t0 = time.perf_counter()
    model = PedicleJointModel(order=args.order, resolution=args.resolution)
    for c in THESIS_CASES:
        model.static(c.materials())
    t_cases = time.perf_counter() - t0
    print(f"seven thesis cases, one assembly: {t_cases:.2f} s")

    if not args.skip_skfem:
        t_sk, (ts, u_sk) = best_of(lambda: skfem_assemble_solve(mesh, args.order, mat), 1)
        diff = np.abs(u_sk - u_isj).max() / np.abs(u_isj).max()
        print(
            f"scikit-fem P{args.order}: assembly {ts['assembly']:.3f} s, solve {ts['solve']:.3f} s, "
            f"total {ts['total']:.3f} s"
        )
        print(
            f"ratio scikit-fem / isj (assembly + solve): {ts['total'] / ti['total']:.1f}x "
            f"(assembly {ts['assembly'] / ti['assembly']:.1f}x, solve {ts['solve'] / ti['solve']:.1f}x); "
            f"max |u_skfem - u_isj| / max |u| = {diff:.1e}"
        )


if __name__ == "__main__":
    main()
