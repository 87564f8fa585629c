"""Element quality measures and bandwidth (docs/model.md §2.6)."""

import numpy as np
import pytest
import scipy.sparse as sp
from isj.fem.mesh import TetMesh
from isj.fem.quality import (
    bandwidth,
    mesh_quality,
    node_adjacency,
    rcm_bandwidth,
    rcm_permutation,
    tet_quality,
)
from isj.fem.structured import box_mesh

REGULAR = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float) * 1e-5
CORNER = np.vstack([np.zeros(3), np.eye(3)]) * 1e-5


def single(points, order=(0, 1, 2, 3)) -> TetMesh:
    return TetMesh(points, np.array([order], dtype=np.int64), np.zeros(1, np.int8), ("a",), {})


@pytest.mark.parametrize("order", [(0, 1, 2, 3), (1, 0, 2, 3)])
def test_regular_tet(order):
    q = tet_quality(REGULAR, np.array([order]))
    assert q["aspect_ratio"][0] == pytest.approx(1.0, rel=1e-12)
    assert q["min_dihedral"][0] == pytest.approx(np.arccos(1 / 3), rel=1e-12)
    assert q["max_dihedral"][0] == pytest.approx(np.arccos(1 / 3), rel=1e-12)
    assert abs(q["volume"][0]) == pytest.approx(8 / 3 * 1e-15, rel=1e-12)
    m = mesh_quality(single(REGULAR, order))
    assert m["max_aspect_ratio"] == pytest.approx(1.0, rel=1e-12)
    assert m["min_dihedral_deg"] == pytest.approx(np.degrees(np.arccos(1 / 3)), rel=1e-12)
    assert m["tets_per_region"] == {"a": 1}


def test_corner_tet():
    """Right-corner tet: three right dihedral angles, three of arccos(1/√3); R/3r = (√3+1)/2."""
    q = tet_quality(CORNER, np.array([[0, 1, 2, 3]]))
    assert q["min_dihedral"][0] == pytest.approx(np.arccos(1 / np.sqrt(3)), rel=1e-12)
    assert q["max_dihedral"][0] == pytest.approx(np.pi / 2, rel=1e-12)
    assert q["aspect_ratio"][0] == pytest.approx((np.sqrt(3) + 1) / 2, rel=1e-12)


def test_flat_tet_is_bad():
    flat = REGULAR * np.array([1, 1, 1e-3])
    q = tet_quality(flat, np.array([[0, 1, 2, 3]]))
    assert q["aspect_ratio"][0] > 100
    assert q["min_dihedral"][0] < 0.01
    degenerate = CORNER.copy()
    degenerate[3] = [0.5e-5, 0.5e-5, 0.0]
    assert np.isinf(tet_quality(degenerate, np.array([[0, 1, 2, 3]]))["aspect_ratio"][0])


def test_mesh_quality_of_a_box():
    m = box_mesh((1e-4, 1e-4, 1e-4), (2, 2, 2))
    q = mesh_quality(m)
    assert q["n_tets"] == 48 and q["tets_per_region"] == {"box": 48}
    # Kuhn tets: dihedral angles 45°, 60° and 90°
    assert q["min_dihedral_deg"] == pytest.approx(45.0)
    assert q["max_dihedral_deg"] == pytest.approx(90.0)
    assert q["min_volume_m3"] > 0


def test_bandwidth_of_known_matrices():
    assert bandwidth(sp.diags([1.0, 2.0, 1.0], [-1, 0, 1], shape=(5, 5))) == 1
    a = sp.lil_matrix((6, 6))
    a.setdiag(1.0)
    a[4, 1] = 3.0
    assert bandwidth(a) == 3
    a[0, 5] = 0.0  # an explicitly stored zero is not a non-zero
    assert bandwidth(a.tocsr()) == 3
    assert bandwidth(np.eye(3)) == 0
    assert bandwidth(sp.csr_matrix((4, 4))) == 0


def test_rcm_recovers_a_scrambled_band():
    n = 40
    band = sp.diags([1.0, 4.0, 1.0], [-1, 0, 1], shape=(n, n)).tocsr()
    perm = np.random.default_rng(0).permutation(n)
    scrambled = band[perm][:, perm]
    before, after = rcm_bandwidth(scrambled)
    assert before > 10 and after == 1
    p = rcm_permutation(scrambled)
    assert sorted(p) == list(range(n))


def test_rcm_does_not_increase_mesh_bandwidth():
    from isj.fem.mesh import mesh_cantilever

    m = mesh_cantilever(cache_dir=False)
    a = node_adjacency(m)
    assert abs(a - a.T).nnz == 0 and (a.diagonal() == 1).all()
    before, after = rcm_bandwidth(a)
    assert before == bandwidth(a)
    assert 0 < after <= before
