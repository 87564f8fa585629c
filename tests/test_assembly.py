"""Assembly: symmetry, rigid-body modes, agreement with scikit-fem, per-region superposition."""

import numpy as np
import pytest
import scipy.sparse as sp
import skfem
from isj.fem.assembly import assemble_mass, assemble_regions, build_pattern, combine, lame_unit
from isj.fem.mesh import TetMesh
from isj.fem.space import build_space
from isj.fem.structured import box_mesh


def two_region_box():
    """A 2×2×3-cell box whose upper half is a second region."""
    m = box_mesh((1e-4, 2e-4, 3e-4), (2, 2, 4), origin_m=(-5e-5, -1e-4, 0))
    c = m.points[m.tets].mean(axis=1)
    region = (c[:, 2] > 1.5e-4).astype(np.int8)
    return TetMesh(m.points, m.tets, region, ("lower", "upper"), m.faces)


def stiffness(space, pattern, regions, youngs, nu=0.3):
    lam, mu = lame_unit(nu)
    return pattern.matrix(combine(pattern, regions, {r: (e * lam, e * mu) for r, e in youngs.items()}))


@pytest.mark.parametrize("order", [1, 2])
def test_symmetric_and_rigid_body_modes_have_zero_energy(order):
    space = build_space(two_region_box(), order)
    pattern = build_pattern(space)
    regions = assemble_regions(space, pattern)
    K = stiffness(space, pattern, regions, {"lower": 5e9, "upper": 1e7})
    scale = abs(K).max()
    assert abs(K - K.T).max() <= 1e-14 * scale
    x = space.points
    modes = [np.tile(np.eye(3)[a], space.n_nodes) for a in range(3)]
    modes += [np.cross(np.eye(3)[a], x).ravel() for a in range(3)]
    for u in modes:
        assert np.abs(K @ u).max() <= 1e-12 * scale * np.abs(u).max()
    # and exactly six: the seventh eigenvalue is well away from zero
    ev = np.linalg.eigvalsh(K.toarray())
    assert np.all(np.abs(ev[:6]) < 1e-10 * ev[-1])
    assert ev[6] > 1e-6 * ev[-1]


@pytest.mark.parametrize("order", [1, 2])
def test_matches_scikit_fem(order):
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    mesh = box_mesh((1.0, 2.0, 1.5), (2, 3, 2))
    space = build_space(mesh, order)
    pattern = build_pattern(space)
    regions = assemble_regions(space, pattern)
    K = stiffness(space, pattern, regions, {"box": 1.0}).toarray()
    m = skfem.MeshTet(mesh.points.T.copy(), mesh.tets.T.copy())
    elem = skfem.ElementTetP1() if order == 1 else skfem.ElementTetP2()
    basis = skfem.Basis(m, skfem.ElementVector(elem), intorder=2)
    Ks = linear_elasticity(*lame_parameters(1.0, 0.3)).assemble(basis).toarray()
    if order == 1:  # same dof numbering (node-interleaved)
        assert np.allclose(K, Ks, atol=1e-12 * abs(K).max())
    else:  # P2 numbers edge dofs differently: compare invariants
        assert np.allclose(np.linalg.eigvalsh(K), np.linalg.eigvalsh(Ks), atol=1e-11 * abs(K).max())


def test_moduli_superpose_without_reassembly():
    space = build_space(two_region_box(), 2)
    pattern = build_pattern(space)
    regions = assemble_regions(space, pattern)
    K1 = stiffness(space, pattern, regions, {"lower": 1.0, "upper": 0.0})
    K2 = stiffness(space, pattern, regions, {"lower": 0.0, "upper": 1.0})
    K = stiffness(space, pattern, regions, {"lower": 3.0, "upper": 7.0})
    assert abs(K - (3 * K1 + 7 * K2)).max() < 1e-12 * abs(K).max()
    # ν enters through λ and μ only: one assembly serves any ν
    lam, mu = lame_unit(0.1)
    Kl = pattern.matrix(combine(pattern, regions, {"lower": (1, 0), "upper": (1, 0)}))
    Km = pattern.matrix(combine(pattern, regions, {"lower": (0, 1), "upper": (0, 1)}))
    Knu = stiffness(space, pattern, regions, {"lower": 1.0, "upper": 1.0}, nu=0.1)
    assert abs(Knu - (lam * Kl + mu * Km)).max() < 1e-12 * abs(Knu).max()


@pytest.mark.parametrize("order", [1, 2])
def test_mass_integrates_density_exactly(order):
    space = build_space(two_region_box(), order)
    pattern = build_pattern(space)
    regions = assemble_regions(space, pattern)
    assemble_mass(space, pattern, regions)
    M = pattern.matrix(combine(pattern, regions, {"lower": (2000.0, 0), "upper": (1100.0, 0)}, "mass"))
    vol = 1e-4 * 2e-4 * 1.5e-4
    # a rigid translation's kinetic-energy form gives the total mass
    t = np.tile([1.0, 0.0, 0.0], space.n_nodes)
    assert t @ M @ t == pytest.approx(vol * (2000 + 1100), rel=1e-12)
    # and the second moment (exact for P2: the integrand is quadratic)
    x = np.zeros((space.n_nodes, 3))
    x[:, 0] = space.points[:, 2]
    z = x.ravel()
    exact = 2000 * 1e-4 * 2e-4 * (1.5e-4) ** 3 / 3 + 1100 * 1e-4 * 2e-4 * ((3e-4) ** 3 - (1.5e-4) ** 3) / 3
    if order == 2:
        assert z @ M @ z == pytest.approx(exact, rel=1e-12)
    assert sp.issparse(M)
