"""Solver paths against exact solutions: patch tests and the Timoshenko cantilever."""

import numpy as np
import pytest
from isj.fem.assembly import assemble_regions, build_pattern, combine, lame_unit
from isj.fem.boundary import Reduction, traction_load
from isj.fem.convergence import solve_cantilever, timoshenko_tip_deflection
from isj.fem.solvers import available_backends, make_solver
from isj.fem.space import build_space
from isj.fem.structured import box_mesh

B, H, L = 55e-6, 160e-6, 240e-6  # pedicle: x, y, z (m)


def boundary_nodes(space):
    """Nodes on the boundary: those of tetrahedron faces that belong to one tet only."""
    faces = np.sort(space.cells[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3), axis=1)
    uniq, count = np.unique(faces, axis=0, return_counts=True)
    verts = np.unique(uniq[count == 1])
    on = np.zeros(space.n_nodes, dtype=bool)
    on[verts] = True
    if space.order == 2:  # a mid-edge node is on the boundary iff the edge is a boundary edge
        x = space.points
        bmin, bmax = x[verts].min(axis=0), x[verts].max(axis=0)
        on |= np.any(np.isclose(x, bmin, atol=1e-12) | np.isclose(x, bmax, atol=1e-12), axis=1)
    return np.flatnonzero(on)


def stiffness(space, youngs, nu):
    pattern = build_pattern(space)
    regions = assemble_regions(space, pattern)
    lam, mu = lame_unit(nu)
    return pattern, combine(pattern, regions, {r: (youngs * lam, youngs * mu) for r in regions})


def gmsh_box(resolution=3.0):
    """An unstructured gmsh mesh of the pedicle box (irregular tetrahedra)."""
    from isj.fem.mesh import mesh_cantilever

    return mesh_cantilever(resolution=resolution, cache_dir=False)


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("mesh_kind", ["structured", "gmsh"])
def test_dirichlet_patch_test(order, mesh_kind):
    """A linear field imposed on the boundary is reproduced exactly inside."""
    mesh = box_mesh((B, H, L), (2, 3, 4)) if mesh_kind == "structured" else gmsh_box()
    space = build_space(mesh, order)
    pattern, data = stiffness(space, 5e9, 0.3)
    grad = np.array([[1.0, 2.0, -0.5], [0.3, -1.0, 0.7], [2.0, 0.1, 0.4]]) * 1e-3
    exact = space.points @ grad.T + np.array([1e-7, -2e-7, 3e-7])
    fixed = (3 * boundary_nodes(space)[:, None] + np.arange(3)).ravel()
    red = Reduction.build(pattern, fixed)
    K = pattern.matrix(data)
    u_fix = np.zeros(space.n_dofs)
    u_fix[fixed] = exact.ravel()[fixed]
    rhs = -(K @ u_fix)[red.free]
    Kf = red.matrix(data)
    s = make_solver(Kf, "superlu")
    s.factor(Kf)
    u = red.expand(s.solve(rhs)) + u_fix
    assert red.n_free > 0
    assert np.abs(u - exact.ravel()).max() < 1e-9 * np.abs(exact).max()


@pytest.mark.parametrize("order", [1, 2])
def test_uniaxial_tension_is_exact(order):
    """Traction σ on z = L with symmetry planes x = y = z = 0: the exact field is linear."""
    mesh = gmsh_box()
    space = build_space(mesh, order)
    E, nu, sigma = 5e9, 0.3, 1e3
    pattern, data = stiffness(space, E, nu)
    x = space.points
    lo = x.min(axis=0)
    fixed = np.concatenate([3 * np.flatnonzero(np.isclose(x[:, a], lo[a], atol=1e-12)) + a for a in range(3)])
    red = Reduction.build(pattern, fixed)
    f = traction_load(space, "loaded", [0.0, 0.0, sigma])
    Kf = red.matrix(data)
    s = make_solver(Kf)
    s.factor(Kf)
    u = red.expand(np.ravel(s.solve(red.restrict(f)))).reshape(-1, 3)
    exact = np.stack(
        [
            -nu * sigma / E * (x[:, 0] - lo[0]),
            -nu * sigma / E * (x[:, 1] - lo[1]),
            sigma / E * x[:, 2],
        ],
        axis=1,
    )
    assert np.abs(u - exact).max() < 1e-9 * np.abs(exact).max()


@pytest.mark.parametrize("direction, tol", [("x", 1e-3), ("y", 5e-3)])
def test_cantilever_p2_matches_timoshenko(direction, tol):
    """With ν = 0 the 3-D mean tip deflection is Timoshenko's (κ = 5/6 exact)."""
    depth, width = (B, H) if direction == "x" else (H, B)
    exact = timoshenko_tip_deflection(1e-6, L, depth, width, 5e9, 0.0)
    mesh = box_mesh((B, H, L), (4, 12, 16), origin_m=(-B / 2, -H / 2, 0))
    r = solve_cantilever(mesh, 2, direction, 5e9, 0.0, 1e-6)
    assert r["tip_mean_m"] / exact - 1 == pytest.approx(0, abs=tol)


def test_cantilever_convergence_rates():
    """P1 approaches its O(h²) rate for the tip deflection; P2 is far ahead of it."""
    exact = timoshenko_tip_deflection(1e-6, L, B, H, 5e9, 0.0)

    def err(order, n):
        mesh = box_mesh((B, H, L), (n, 3 * n, 4 * n), origin_m=(-B / 2, -H / 2, 0))
        return abs(solve_cantilever(mesh, order, "x", 5e9, 0.0, 1e-6)["tip_mean_m"] / exact - 1)

    e1 = [err(1, n) for n in (2, 4, 8)]
    assert e1[0] > e1[1] > e1[2]
    rate = np.log2(e1[1] / e1[2])
    assert 1.5 < rate < 2.5  # bending-locked P1 is pre-asymptotic; 2 in the limit
    e2 = [err(2, n) for n in (1, 2)]
    assert np.log2(e2[0] / e2[1]) > 2.5  # P2 converges faster than P1
    assert e2[1] < e1[2] / 10  # 3120 P2 dofs beat 21600 P1 dofs tenfold


@pytest.mark.parametrize("backend", available_backends())
def test_solver_backends_agree(backend):
    mesh = box_mesh((B, H, L), (2, 3, 4), origin_m=(-B / 2, -H / 2, 0))
    ref = solve_cantilever(mesh, 2, "x", 5e9, 0.3, 1e-6, solver="superlu")
    r = solve_cantilever(mesh, 2, "x", 5e9, 0.3, 1e-6, solver=backend)
    assert r["max_disp_m"] == pytest.approx(ref["max_disp_m"], rel=1e-10)
