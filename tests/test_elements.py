"""Reference elements and quadrature against exact integrals."""

from math import factorial

import numpy as np
import pytest
from isj.fem.elements import (
    barycentric,
    reference_mass,
    shape_functions,
    shape_gradients,
    tet_quadrature,
)

P2_NODES = np.array(
    [
        [0, 0, 0],
        [1, 0, 0],
        [0, 1, 0],
        [0, 0, 1],
        [0.5, 0, 0],
        [0.5, 0.5, 0],
        [0, 0.5, 0],
        [0, 0, 0.5],
        [0.5, 0, 0.5],
        [0, 0.5, 0.5],
    ]
)


def monomial_integral(a, b, c):
    """∫ ξ^a η^b ζ^c over the reference tetrahedron (Dirichlet integral)."""
    return factorial(a) * factorial(b) * factorial(c) / factorial(a + b + c + 3)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_quadrature_exact_to_degree_2n_minus_1(n):
    pts, w = tet_quadrature(n)
    deg = 2 * n - 1
    for a in range(deg + 1):
        for b in range(deg + 1 - a):
            for c in range(deg + 1 - a - b):
                q = w @ (pts[:, 0] ** a * pts[:, 1] ** b * pts[:, 2] ** c)
                assert q == pytest.approx(monomial_integral(a, b, c), rel=1e-12)
    # and not beyond: a degree-2n monomial is generally missed
    q = w @ pts[:, 0] ** (2 * n)
    assert abs(q - monomial_integral(2 * n, 0, 0)) > 1e-14


@pytest.mark.parametrize("order", [1, 2])
def test_partition_of_unity_and_kronecker(order):
    rng = np.random.default_rng(0)
    lam = rng.dirichlet(np.ones(4), size=20)
    assert np.allclose(shape_functions(order, lam).sum(axis=1), 1.0)
    assert np.allclose(shape_gradients(order, lam).sum(axis=1), 0.0)
    nodes = P2_NODES[: 4 if order == 1 else 10]
    assert np.allclose(shape_functions(order, barycentric(nodes)), np.eye(len(nodes)))


@pytest.mark.parametrize("order", [1, 2])
def test_gradients_match_finite_differences(order):
    rng = np.random.default_rng(1)
    x = rng.dirichlet(np.ones(4), size=5)[:, 1:]
    h = 1e-6
    g = shape_gradients(order, barycentric(x))
    for a in range(3):
        dx = np.zeros(3)
        dx[a] = h
        fd = shape_functions(order, barycentric(x + dx)) - shape_functions(order, barycentric(x - dx))
        assert np.allclose(g[:, :, a], fd / (2 * h), atol=1e-8)


def test_p2_reproduces_quadratics():
    """P2 interpolation of a quadratic is exact everywhere in the element."""
    f = lambda p: 1 + p[..., 0] - 2 * p[..., 1] * p[..., 2] + 3 * p[..., 0] ** 2  # noqa: E731
    rng = np.random.default_rng(2)
    x = rng.dirichlet(np.ones(4), size=7)[:, 1:]
    interp = shape_functions(2, barycentric(x)) @ f(P2_NODES)
    assert np.allclose(interp, f(x))


@pytest.mark.parametrize("order, total", [(1, 1 / 6), (2, 1 / 6)])
def test_reference_mass_sums_to_volume(order, total):
    m = reference_mass(order)
    assert m.sum() == pytest.approx(total, rel=1e-14)
    assert np.allclose(m, m.T)
    assert np.all(np.linalg.eigvalsh(m) > 0)
