"""PARDISO's analysis started ahead, on a thread, from the pattern alone: the same factorization."""

import numpy as np
import pytest
import scipy.sparse as sp
from isj.fem import solvers
from isj.fem.model import PedicleJointModel
from isj.fem.solvers import PardisoSolver, available_backends, make_solver

from isj.design import Materials
from isj.errors import SolverFailed

pytestmark = pytest.mark.skipif("pardiso" not in available_backends(), reason="needs PARDISO (pypardiso)")


def _clamped_stiffness(model, materials):
    K = model.stiffness(materials).tocsr()
    K.sort_indices()
    return K


def test_analysis_of_the_pattern_alone_factors_to_the_same_bits(coarse_model):
    K = _clamped_stiffness(coarse_model, Materials(gap_e_pa=7e6))
    b = np.linspace(-1.0, 1.0, K.shape[0])
    plain = PardisoSolver(K)
    plain.factor(K)
    ones = sp.csr_matrix((np.ones_like(K.data), K.indices, K.indptr), shape=K.shape)
    ahead = PardisoSolver(ones, ahead=True)
    ahead.factor(K)  # waits for the analysis
    assert np.array_equal(plain.perm, ahead.perm)
    assert plain.solve(b).tobytes() == ahead.solve(b).tobytes()


def test_model_analysed_ahead_gives_the_same_static_result(coarse_model):
    materials = Materials(pedicle_e_pa=3e9)
    ahead = PedicleJointModel(order=2, resolution=0.35, analyse_ahead=True)
    assert isinstance(ahead._solver, PardisoSolver)  # started with the model, before any solve
    got, want = ahead.static(materials), coarse_model.static(materials)
    assert got.displacement_m.tobytes() == want.displacement_m.tobytes()
    assert (got.alpha_rad, got.beta_rad) == (want.alpha_rad, want.beta_rad)


def test_sliding_joint_analysed_ahead_after_its_ties_gives_the_same_result():
    materials = Materials(gap_e_pa=7e6)
    ahead = PedicleJointModel(order=1, resolution=0.35, joint="sliding", analyse_ahead=True)
    assert isinstance(ahead._solver, PardisoSolver)  # started once the ties were made
    plain = PedicleJointModel(order=1, resolution=0.35, joint="sliding")
    assert plain._solver is None
    got, want = ahead.static(materials), plain.static(materials)
    assert got.displacement_m.tobytes() == want.displacement_m.tobytes()


def test_an_error_in_the_analysis_reaches_the_caller(coarse_model, monkeypatch):
    K = _clamped_stiffness(coarse_model, Materials())
    real_call = PardisoSolver._call

    def failing(self, phase, b):
        if phase == 11:
            raise SolverFailed("PARDISO analysis failed (error -2: not enough memory), a test")
        return real_call(self, phase, b)

    monkeypatch.setattr(PardisoSolver, "_call", failing)
    solver = PardisoSolver(K, ahead=True)
    with pytest.raises(SolverFailed, match="not enough memory"):
        solver.factor(K)


def test_freeing_a_solver_waits_for_its_analysis(coarse_model):
    K = _clamped_stiffness(coarse_model, Materials())
    solver = PardisoSolver(K, ahead=True)
    solver.free()  # MKL's handle is released only after the analysis returns: no crash
    assert solver._ps is None


def test_ordering_made_ahead_is_cached_and_reused(coarse_model, tmp_path):
    K = _clamped_stiffness(coarse_model, Materials())
    first = make_solver(K, "pardiso", ordering_cache=tmp_path, ahead=True)
    first.ready()
    assert len(list(tmp_path.glob("ordering-*.npz"))) == 1
    second = make_solver(K, "pardiso", ordering_cache=tmp_path, ahead=True)
    assert second._ps.iparm[4] == 1  # handed the cached ordering
    assert np.array_equal(first.perm, second.perm)
    assert solvers.resolve_backend("auto") == available_backends()[0]
