"""Speed of the FE verifier on the base case, and isj against scikit-fem on the same mesh.

Run:  .venv/bin/python benchmarks/fem_speed.py [--order 2] [--resolution 1] [--skip-skfem]

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
import subprocess
import sys
import tempfile
import time

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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order", type=int, default=2, choices=(1, 2))
    ap.add_argument("--resolution", type=float, default=1.0)
    ap.add_argument("--skip-skfem", action="store_true")
    args = ap.parse_args(argv)
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
        model.solve(c.materials())
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
