"""A sparse solver's failure is a clear isj error, never a crash or an AttributeError."""

import numpy as np
import pytest
import scipy.sparse as sp
from isj.fem.solvers import PardisoIndefiniteSolver, PardisoSolver, available_backends

from isj.errors import IsjError, SolverFailed

pytestmark = pytest.mark.skipif("pardiso" not in available_backends(), reason="needs PARDISO (pypardiso)")


def test_indefinite_matrix_in_a_cholesky_factor_names_the_zero_pivot():
    A = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))  # eigenvalues 3 and -1
    solver = PardisoSolver(A)
    with pytest.raises(SolverFailed, match=r"factorization failed \(error -4: zero pivot"):
        solver.factor(A)


def test_the_same_matrix_factors_where_indefinite_is_allowed():
    A = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))
    solver = PardisoIndefiniteSolver(A)
    solver.factor(A)
    np.testing.assert_allclose(solver.solve(np.array([3.0, 3.0])), [1.0, 1.0], rtol=1e-14)


def test_pattern_without_a_diagonal_entry_is_refused_before_mkl_sees_it():
    # MKL reads out of bounds on such a pattern: the process died with a segmentation fault
    A = sp.csr_matrix(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 2.0]]))
    with pytest.raises(SolverFailed, match=r"1 of 3 rows lack theirs \(first: row 1\)"):
        PardisoSolver(A)


def test_solver_failed_is_an_isj_runtime_error():
    assert issubclass(SolverFailed, IsjError) and issubclass(SolverFailed, RuntimeError)
