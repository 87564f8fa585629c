"""Sparse direct solvers for symmetric positive definite stiffness matrices.

One function, :func:`make_solver`, picks a backend; every backend analyses the
sparsity pattern once (ordering, symbolic factorization) and then factors any
matrix with the same pattern, so a new set of moduli costs one numeric
factorization and load cases cost one triangular solve each.

Backends, in order of preference as measured on this model (P2, default mesh,
113k dofs, 2 cores): analysis + numeric factorization

- ``"pardiso"`` — Intel MKL PARDISO via pypardiso, SPD mode on the upper
  triangle (plain pip on x86-64; the default): 1.5 s + 1.3 s;
- ``"cholmod"`` — SuiteSparse CHOLMOD via scikit-sparse (optional: needs
  ``apt-get install libsuitesparse-dev libopenblas0-pthread`` and
  ``pip install scikit-sparse==0.4.16``): 1.9 s + 3.1 s with OpenBLAS, 2.2 s +
  10.5 s with Debian's reference BLAS;
- ``"superlu"`` — scipy's SuperLU (always available; LU, no reuse of the
  analysis; scikit-fem's default solve through it took 18× PARDISO's time on the
  default mesh, ``benchmarks/fem_speed.py``).
"""

from __future__ import annotations

import importlib.util

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

BACKENDS = ("pardiso", "cholmod", "superlu")


class SolverUnavailable(RuntimeError):
    """The requested solver backend is not installed here."""


def available_backends() -> list[str]:
    """Backends importable here, in order of preference."""
    have = []
    if importlib.util.find_spec("pypardiso") is not None:
        try:
            import pypardiso  # noqa: F401  (loads libmkl_rt; may fail on odd machines)

            have.append("pardiso")
        except Exception:  # pragma: no cover - depends on the machine
            pass
    if importlib.util.find_spec("sksparse") is not None:
        have.append("cholmod")
    have.append("superlu")
    return have


class _Upper:
    """Selects the upper triangle of a fixed CSR pattern (indices sorted per row)."""

    def __init__(self, A: sp.csr_matrix):
        rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
        self.mask = A.indices >= rows
        counts = np.bincount(rows[self.mask], minlength=A.shape[0])
        self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        self.indices = A.indices[self.mask].astype(np.int32)
        self.shape = A.shape

    def __call__(self, A: sp.csr_matrix) -> sp.csr_matrix:
        return sp.csr_matrix((A.data[self.mask], self.indices, self.indptr), shape=self.shape)


class PardisoSolver:
    """MKL PARDISO, real symmetric positive definite (mtype 2), analysis reused."""

    name = "pardiso"
    mtype = 2

    def __init__(self, A: sp.csr_matrix):
        import pypardiso

        self._upper = _Upper(A)
        # a fresh solver object per pattern: pypardiso's own spsolve caches by hash
        self._ps = pypardiso.PyPardisoSolver(mtype=self.mtype)
        self._U = self._upper(A)
        self._ps.set_phase(11)  # ordering and symbolic factorization, once
        self._ps._call_pardiso(self._U, np.zeros((A.shape[0], 1)))

    def factor(self, A: sp.csr_matrix) -> None:
        self._U = self._upper(A)
        self._ps.set_phase(22)
        self._ps._call_pardiso(self._U, np.zeros((A.shape[0], 1)))

    def solve(self, b: np.ndarray) -> np.ndarray:
        self._ps.set_phase(33)
        b = np.asfortranarray(b, dtype=np.float64)
        return self._ps._call_pardiso(self._U, b)

    def __del__(self):  # release MKL's memory for this factorization
        try:
            self._ps.free_memory(everything=True)
        except Exception:
            pass


class PardisoIndefiniteSolver(PardisoSolver):
    """MKL PARDISO, real symmetric indefinite (mtype −2): dynamic stiffness K − ω²M."""

    name = "pardiso_indefinite"
    mtype = -2


class CholmodSolver:
    """CHOLMOD supernodal Cholesky; symbolic analysis reused."""

    name = "cholmod"

    def __init__(self, A: sp.csr_matrix):
        from sksparse.cholmod import analyze

        self._f = analyze(A.tocsc())

    def factor(self, A: sp.csr_matrix) -> None:
        self._f.cholesky_inplace(A.tocsc())

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._f(b)


class SuperLUSolver:
    """scipy SuperLU (LU, no reuse of the analysis)."""

    name = "superlu"

    def __init__(self, A: sp.csr_matrix):
        self._lu = None

    def factor(self, A: sp.csr_matrix) -> None:
        self._lu = spla.splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A")

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._lu.solve(np.asarray(b, dtype=np.float64))


_CLASSES = {"pardiso": PardisoSolver, "cholmod": CholmodSolver, "superlu": SuperLUSolver}


def make_indefinite_solver(A: sp.csr_matrix):
    """A solver for a real symmetric indefinite matrix (PARDISO mtype −2, else SuperLU)."""
    A = sp.csr_matrix(A)
    A.sort_indices()
    if "pardiso" in available_backends():
        return PardisoIndefiniteSolver(A)
    return SuperLUSolver(A)


def make_solver(A: sp.csr_matrix, backend: str = "auto"):
    """A solver analysed for the pattern of the SPD matrix ``A`` (not yet factored).

    Call ``factor(A)`` with any matrix of that pattern, then ``solve(b)``
    (``b`` of shape (n,) or (n, k)).
    """
    have = available_backends()
    if backend == "auto":
        backend = have[0]
    if backend not in BACKENDS:
        raise ValueError(f"solver backend = {backend!r}: must be one of auto, {', '.join(BACKENDS)}")
    if backend not in have:
        raise SolverUnavailable(f"solver backend {backend!r} is not installed here")
    A = sp.csr_matrix(A)
    A.sort_indices()
    return _CLASSES[backend](A)
