"""Sparse direct solvers for symmetric positive definite stiffness matrices.

One function, :func:`make_solver`, picks a backend; every backend analyses the
sparsity pattern once (ordering, symbolic factorization) and then factors any
matrix with the same pattern, so a new set of moduli costs one numeric
factorization and load cases cost one triangular solve each. PARDISO's
ordering can also be kept on disk per pattern (``ordering_cache``), so that
another process skips METIS.

Backends, in order of preference, the fastest first on this model (timings:
docs/performance.md §8.2; the backends compared: docs/history.md):

- ``"pardiso"`` — Intel MKL PARDISO via pypardiso, SPD mode on the upper
  triangle (plain pip on x86-64; the default);
- ``"cholmod"`` — SuiteSparse CHOLMOD via scikit-sparse (optional: needs
  ``apt-get install libsuitesparse-dev libopenblas0-pthread`` and
  ``pip install scikit-sparse==0.4.16``);
- ``"superlu"`` — scipy's SuperLU (always available; LU, no reuse of the
  analysis; the slowest, ``benchmarks/fem_speed.py``).

For the dynamic stiffness (``fem.dynamics``): :func:`make_indefinite_solver`
(real symmetric indefinite, PARDISO mtype −2) and
:func:`make_complex_symmetric_solver` (complex symmetric, PARDISO mtype 6 on
the n × n complex matrix, complex128 through pypardiso's ctypes entry point;
its time: docs/performance.md §8.4), both with
SuperLU as the fallback. A PARDISO solver returns its fill-reducing ordering
in ``perm``; the others take it to skip their own.

Threads. PARDISO's parallel reductions make its results depend, in the last
bits, on its thread count and on MKL's threading layer, and a factorization
analysed with one thread count crashes (SIGSEGV) when factored again under
another. Both are therefore fixed once per process, at the first PARDISO
solver (:func:`pin_solver_threads`): MKL's GNU OpenMP layer (the runtime gmsh
brings, so one thread pool serves both) and :func:`solver_threads` threads,
set with ``mkl_set_num_threads``, which gmsh's own OpenMP setting (one thread,
``fem.mesh``) does not reach. Each solver also asks for conditional numerical
reproducibility at that count (iparm(34)): without it two solves of the same
right-hand side differed in the last bits, which made ``eigsh`` and the
harmonic response change from run to run. Its cost is within the timing noise
(docs/history.md).
"""

from __future__ import annotations

import ctypes
import hashlib
import importlib.util
import os
import threading
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from isj.errors import InvalidParameter, SolverFailed, SolverUnavailable

BACKENDS = ("pardiso", "cholmod", "superlu")

#: Environment variable fixing the number of threads of the PARDISO solver (an integer >= 1).
SOLVER_THREADS_ENV = "ISJ_SOLVER_THREADS"

#: MKL's code for its GNU OpenMP threading layer (``mkl_set_threading_layer``).
_MKL_THREADING_GNU = 3

#: Seed of :func:`lanczos_start`.
LANCZOS_SEED = 17

_PINNED: dict[str, int] = {}
_PIN_LOCK = threading.Lock()


def _env_threads(name: str) -> int | None:
    """The leading integer of an OpenMP-style thread variable ("4" or "4,2"), or None if unset/odd."""
    text = os.environ.get(name, "").split(",")[0].strip()
    return int(text) if text.isdigit() and int(text) >= 1 else None


def solver_threads() -> int:
    """Threads PARDISO uses in this process.

    ``$ISJ_SOLVER_THREADS`` if set; else ``$MKL_NUM_THREADS`` or
    ``$OMP_NUM_THREADS`` (the usual ways to limit a worker); else the number
    of CPUs this process may run on. Read from the environment, never from
    the OpenMP runtime, whose count gmsh changes.

    Raises
    ------
    InvalidParameter
        If ``$ISJ_SOLVER_THREADS`` is not an integer in [1, 1024].
    """
    text = os.environ.get(SOLVER_THREADS_ENV)
    if text is not None:
        if not text.strip().isdigit() or not 1 <= int(text) <= 1024:
            raise InvalidParameter(f"{SOLVER_THREADS_ENV} = {text!r}: must be an integer in [1, 1024]")
        return int(text)
    for name in ("MKL_NUM_THREADS", "OMP_NUM_THREADS"):
        n = _env_threads(name)
        if n is not None:
            return n
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _mkl_rt_path() -> str | None:
    """MKL's runtime library as the ``mkl`` wheel lists it, or None (then pypardiso searches).

    Without ``$PYPARDISO_MKL_RT`` pypardiso looks for it with
    ``ctypes.util.find_library`` (which runs ``ldconfig`` and the compiler in
    subprocesses) and then with a recursive glob of the environment, at its
    import and again for every solver object, a noticeable part of every
    ``isj fem solve`` (docs/performance.md §8.2).
    """
    try:
        from importlib.metadata import PackageNotFoundError, files
    except ImportError:  # pragma: no cover
        return None
    try:
        found = [f for f in files("mkl") or () if f.name.startswith("libmkl_rt.so")]
    except PackageNotFoundError:
        return None
    paths = sorted(str(f.locate()) for f in found)
    return next((p for p in paths if os.path.exists(p)), None)


def _pypardiso():
    """pypardiso, imported with ``$PYPARDISO_MKL_RT`` pointing at MKL (see :func:`_mkl_rt_path`)."""
    if "PYPARDISO_MKL_RT" not in os.environ:
        path = _mkl_rt_path()
        if path is not None:
            # pypardiso's documented setting; inherited by child processes, which load the same MKL
            os.environ["PYPARDISO_MKL_RT"] = path
    import pypardiso

    return pypardiso


def pin_solver_threads(libmkl=None) -> dict[str, int]:
    """Fix MKL's threading layer and thread count for the rest of the process (idempotent).

    Called by every PARDISO solver before its first MKL call: the layer can only
    be chosen before MKL's first computation (afterwards MKL keeps the one it has
    and this reports it).

    Returns
    -------
    dict
        ``{"threads": n, "layer": MKL's layer code}`` (3: GNU OpenMP, 0: Intel).
    """
    with _PIN_LOCK:
        if not _PINNED:
            if libmkl is None:
                libmkl = _pypardiso().ps.libmkl
            n = solver_threads()
            layer = libmkl.MKL_Set_Threading_Layer(ctypes.c_int(_MKL_THREADING_GNU))
            libmkl.MKL_Set_Num_Threads(ctypes.c_int(n))
            # MKL may otherwise choose fewer threads than asked, which changes the bits
            libmkl.MKL_Set_Dynamic(ctypes.c_int(0))
            _PINNED.update(threads=n, layer=int(layer))
        return dict(_PINNED)


def on_solver_threads(fn, items) -> list:
    """``[fn(x) for x in items]``, computed on up to :func:`solver_threads` threads, in order.

    For work whose numbers do not depend on the thread that computes them (numpy lets go of the
    GIL in its large operations); callers that use BLAS hold it to one thread
    (:func:`fem.ear.joint_condensation.one_blas_thread`). One thread, or one item: no pool.
    """
    from concurrent.futures import ThreadPoolExecutor

    items = list(items)
    threads = min(solver_threads(), len(items))
    if threads <= 1:
        return [fn(x) for x in items]
    with ThreadPoolExecutor(threads) as pool:
        return list(pool.map(fn, items))


def lanczos_start(n: int) -> np.ndarray:
    """A fixed start vector for ``scipy.sparse.linalg.eigsh`` (``v0``) on ``n`` unknowns.

    Without one ARPACK starts from a random vector, so the modes' last bits
    (and the signs of the mode shapes) change from run to run. Uniform in
    [-1, 1) from a seeded generator: no mode is orthogonal to it in practice.
    """
    return np.random.default_rng(LANCZOS_SEED).uniform(-1.0, 1.0, int(n))


def available_backends() -> list[str]:
    """Backends importable here, in order of preference."""
    have = []
    if importlib.util.find_spec("pypardiso") is not None:
        try:
            _pypardiso()  # loads libmkl_rt; may fail on odd machines
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

    def missing_diagonal(self) -> np.ndarray:
        """Rows whose diagonal entry is not in the pattern (PARDISO needs every one stored)."""
        n = self.shape[0]
        first = np.full(n, -1, dtype=np.int64)
        stored = self.indptr[1:] > self.indptr[:-1]
        first[stored] = self.indices[self.indptr[:-1][stored]]
        return np.flatnonzero(first != np.arange(n))

    def __call__(self, A: sp.csr_matrix) -> sp.csr_matrix:
        return sp.csr_matrix((A.data[self.mask], self.indices, self.indptr), shape=self.shape)


# MKL PARDISO's error codes (the ``error`` argument), as its reference names them
_PARDISO_ERRORS = {
    -1: "input inconsistent",
    -2: "not enough memory",
    -3: "reordering problem",
    -4: "zero pivot: the matrix is singular or, for a Cholesky factor, not positive definite",
    -5: "unclassified internal error",
    -6: "reordering failed",
    -7: "diagonal matrix is singular",
    -8: "32-bit integer overflow",
    -9: "not enough memory for the out-of-core solver",
    -10: "error opening the out-of-core files",
    -11: "read/write error with the out-of-core files",
    -12: "wrong PARDISO interface for this library",
    -13: "interrupted",
}
_PARDISO_PHASES = {11: "analysis", 22: "factorization", 33: "solve"}


def _pardiso_defaults(ps, mtype: int) -> None:
    """Fill ``ps.iparm`` with MKL's defaults for ``mtype`` (``pardisoinit``), so single entries can be set."""
    pt = np.zeros(64, dtype=ps.pt.dtype)  # scratch: pardisoinit zeroes the handle it gets
    iparm = np.zeros(64, dtype=np.int32)
    ps.libmkl.pardisoinit(
        pt.ctypes.data_as(ctypes.c_void_p),
        ctypes.byref(ctypes.c_int32(mtype)),
        iparm.ctypes.data_as(ctypes.c_void_p),
    )
    ps.iparm[:] = iparm


class PardisoSolver:
    """MKL PARDISO, real symmetric positive definite (mtype 2), analysis reused.

    MKL's default settings for the matrix type, except iterative refinement
    (:meth:`_configure`) and that the fill-reducing
    ordering of the analysis is returned in ``perm`` (1-based, iparm(5) = 2), so
    that another PARDISO solver for a matrix of the same pattern (the complex
    dynamic stiffness) can skip the ordering: pass it as ``perm``, and the given
    ordering is used instead (iparm(5) = 1).
    """

    name = "pardiso"
    mtype = 2
    dtype = np.float64

    def __init__(
        self,
        A: sp.csr_matrix,
        perm: np.ndarray | None = None,
        upper: _Upper | None = None,
        ahead: bool = False,
        on_analysed=None,
    ):
        pypardiso = _pypardiso()
        n = A.shape[0]
        self._upper = upper if upper is not None else _Upper(A)
        missing = self._upper.missing_diagonal()
        if missing.size:  # MKL reads out of bounds on such a pattern (a crash, not an error code)
            raise SolverFailed(
                f"PARDISO needs every diagonal entry stored: {missing.size} of {n} rows lack theirs "
                f"(first: row {missing[0]}); an unknown that no element touches"
            )
        # a fresh solver object per pattern: pypardiso's own spsolve caches by hash
        self._ps = pypardiso.PyPardisoSolver(mtype=self.mtype)
        threads = pin_solver_threads(self._ps.libmkl)["threads"]  # before the first MKL call below
        _pardiso_defaults(self._ps, self.mtype)
        # iparm(34): conditional numerical reproducibility for this many threads. Without it
        # the parallel solve phase gave different last bits from call to call (two threads)
        self._ps.iparm[33] = threads
        self._configure(self._ps.iparm)
        if perm is not None and len(perm) == n:
            self._ps.perm = np.array(perm, dtype=np.int32)
            self._ps.iparm[4] = 1  # iparm(5) = 1: use the given ordering
        else:
            self._ps.perm = np.zeros(n, dtype=np.int32)
            self._ps.iparm[4] = 2  # iparm(5) = 2: return the ordering in perm
        # PARDISO's 1-based pattern, made once (pypardiso's own call converts it at every call)
        self._ia = self._upper.indptr + np.int32(1)
        self._ja = self._upper.indices + np.int32(1)
        self._data = self._upper_data(A)
        self._on_analysed = on_analysed
        self._analysis = None
        if ahead:
            # the analysis (ordering and symbolic factorization) reads the pattern only, so it can
            # run while the caller computes the values; ctypes releases the GIL for MKL's call
            self._analysis = threading.Thread(
                target=self._analyse_ahead, name="pardiso-analysis", daemon=True
            )
            self._analysis_error = None
            self._analysis.start()
        else:
            self._analyse()

    def _analyse(self) -> None:
        """Ordering and symbolic factorization (phase 11), once per pattern."""
        self._call(11, np.zeros((self._upper.shape[0], 1), dtype=self.dtype))
        if self._on_analysed is not None:
            self._on_analysed(self._ps.perm)

    @property
    def perm(self) -> np.ndarray:
        """The fill-reducing ordering of the analysis (1-based), once it is done."""
        self.ready()
        return self._ps.perm

    def _analyse_ahead(self) -> None:
        try:
            self._analyse()
        except BaseException as exc:  # handed to the caller's thread by ready()
            self._analysis_error = exc

    def ready(self) -> None:
        """Wait for an analysis started with ``ahead=True``; raise what it raised."""
        thread, self._analysis = self._analysis, None
        if thread is None:
            return
        thread.join()
        if self._analysis_error is not None:
            error, self._analysis_error = self._analysis_error, None
            raise error

    def _configure(self, iparm: np.ndarray) -> None:
        """Adjust MKL's defaults (0-based ``iparm``) for this matrix type.

        Iterative refinement only after perturbed pivots (iparm(8) = 0; MKL's default is two
        steps after every solve). A Cholesky factorization has no perturbed pivots, and on
        the default joint model the two steps left the relative residual where it was
        (1.3e-11) while tripling a solve's time (0.21 → 0.07 s, docs/performance.md §8.9);
        the solution moved by 2.5e-11 relative, below the results' honesty tolerance
        (docs/developer/cache-keys.md §3).
        """
        iparm[7] = 0

    @property
    def upper_mask(self) -> np.ndarray:
        """Which entries of the analysed (sorted CSR) matrix's data PARDISO reads: its upper triangle."""
        return self._upper.mask

    def _upper_data(self, A: sp.csr_matrix) -> np.ndarray:
        return np.ascontiguousarray(A.data[self._upper.mask], dtype=self.dtype)

    def _call(self, phase: int, b: np.ndarray) -> np.ndarray:
        """One call of MKL's ``pardiso`` on the stored upper triangle, as pypardiso makes it."""
        ps = self._ps
        x = np.zeros_like(b)
        error = ctypes.c_int32(0)
        i32 = ctypes.POINTER(ctypes.c_int32)
        one = ctypes.c_int32(1)
        ps._mkl_pardiso(
            ps.pt.ctypes.data_as(ctypes.POINTER(ps._pt_type[0])),
            ctypes.byref(one),  # maxfct
            ctypes.byref(one),  # mnum
            ctypes.byref(ctypes.c_int32(self.mtype)),
            ctypes.byref(ctypes.c_int32(phase)),
            ctypes.byref(ctypes.c_int32(self._upper.shape[0])),
            self._data.ctypes.data_as(ctypes.c_void_p),
            self._ia.ctypes.data_as(i32),
            self._ja.ctypes.data_as(i32),
            ps.perm.ctypes.data_as(i32),
            ctypes.byref(ctypes.c_int32(1 if b.ndim == 1 else b.shape[1])),
            ps.iparm.ctypes.data_as(i32),
            ctypes.byref(ctypes.c_int32(ps.msglvl)),
            b.ctypes.data_as(ctypes.c_void_p),
            x.ctypes.data_as(ctypes.c_void_p),
            ctypes.byref(error),
        )
        if error.value != 0:
            what = _PARDISO_ERRORS.get(error.value, "unknown error")
            stage = _PARDISO_PHASES.get(phase, f"phase {phase}")
            raise SolverFailed(
                f"PARDISO {stage} failed (error {error.value}: {what}), {self._upper.shape[0]} unknowns"
            )
        return np.ascontiguousarray(x)

    def factor(self, A: sp.csr_matrix) -> None:
        self.factor_upper(self._upper_data(A))

    def factor_upper(self, data: np.ndarray) -> None:
        """Factor the matrix whose upper triangle, in the analysed pattern's order, holds ``data``.

        For callers that gather those entries straight from their own storage
        (``ElasticModel``), skipping the full matrix.
        """
        self.ready()
        self.factored_for = None  # a caller that knows what it factored names it afterwards
        self._data = np.ascontiguousarray(data, dtype=self.dtype)  # kept: iterative refinement reads A
        self._call(22, np.zeros((self._upper.shape[0], 1), dtype=self.dtype))

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._call(33, np.asfortranarray(b, dtype=self.dtype))

    def free(self) -> None:
        """Release MKL's memory for this solver (phase −1); it cannot be used afterwards."""
        thread = getattr(self, "_analysis", None)
        if thread is not None:  # MKL's handle is busy until its analysis returns
            thread.join()
        ps, self._ps = getattr(self, "_ps", None), None
        if ps is not None:
            ps.free_memory(everything=True)

    def __del__(self):  # release MKL's memory for this factorization
        try:
            self.free()
        except Exception:
            pass


class PardisoIndefiniteSolver(PardisoSolver):
    """MKL PARDISO, real symmetric indefinite (mtype −2): dynamic stiffness K − ω²M."""

    name = "pardiso_indefinite"
    mtype = -2


class PardisoComplexSymmetricSolver(PardisoSolver):
    """MKL PARDISO, complex symmetric (mtype 6, not Hermitian): K(1 + iη) + iωC − ω²M.

    The n × n complex matrix's upper triangle, complex128, instead of the real
    2n × 2n block system, in less than half its time. Iterative refinement only
    after perturbed pivots, as every PARDISO solver here (:meth:`PardisoSolver._configure`):
    PARDISO's default two steps leave the residual as it is on this model and triple
    the solve's time (docs/history.md).
    """

    name = "pardiso_complex_symmetric"
    mtype = 6
    dtype = np.complex128


class CholmodSolver:
    """CHOLMOD supernodal Cholesky; symbolic analysis reused."""

    name = "cholmod"

    def __init__(self, A: sp.csr_matrix):
        from sksparse.cholmod import analyze

        self._f = analyze(A.tocsc())

    def factor(self, A: sp.csr_matrix) -> None:
        self.factored_for = None
        self._f.cholesky_inplace(A.tocsc())

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._f(b)


class SuperLUSolver:
    """scipy SuperLU (LU, no reuse of the analysis)."""

    name = "superlu"
    dtype = np.float64

    def __init__(self, A: sp.csr_matrix):
        self._lu = None

    def factor(self, A: sp.csr_matrix) -> None:
        self.factored_for = None
        self._lu = spla.splu(A.astype(self.dtype, copy=False).tocsc(), permc_spec="MMD_AT_PLUS_A")

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._lu.solve(np.asarray(b, dtype=self.dtype))

    def free(self) -> None:
        self._lu = None


class SuperLUComplexSolver(SuperLUSolver):
    """scipy SuperLU on a complex matrix (the fallback where PARDISO is missing)."""

    name = "superlu_complex"
    dtype = np.complex128

    def factor(self, A: sp.csr_matrix) -> None:
        self.factored_for = None
        self._lu = spla.splu(A.astype(self.dtype, copy=False).tocsc())


_CLASSES = {"pardiso": PardisoSolver, "cholmod": CholmodSolver, "superlu": SuperLUSolver}


def _indefinite_backend(backend: str) -> str:
    if backend not in ("auto",) + BACKENDS:
        raise ValueError(f"solver backend = {backend!r}: must be one of auto, {', '.join(BACKENDS)}")
    # CHOLMOD factors SPD matrices only: "auto" and "cholmod" mean PARDISO where it is installed
    return "pardiso" if backend != "superlu" and "pardiso" in available_backends() else "superlu"


def make_indefinite_solver(A: sp.csr_matrix, backend: str = "auto", perm: np.ndarray | None = None):
    """A solver for a real symmetric indefinite matrix (PARDISO mtype −2, else SuperLU).

    ``perm``: a fill-reducing ordering of the same pattern (a PARDISO solver's
    ``perm``), reused by PARDISO instead of computing one.
    """
    A = sp.csr_matrix(A)
    A.sort_indices()
    if _indefinite_backend(backend) == "pardiso":
        return PardisoIndefiniteSolver(A, perm)
    return SuperLUSolver(A)


def make_complex_symmetric_solver(A: sp.csr_matrix, backend: str = "auto", perm: np.ndarray | None = None):
    """A solver for a complex symmetric (not Hermitian) matrix: PARDISO mtype 6, else SuperLU.

    Analysed for the pattern of ``A`` (not yet factored); ``factor(A)`` with any
    matrix of that pattern, then ``solve(b)``; ``free()`` releases the memory.
    ``perm`` as for :func:`make_indefinite_solver`.
    """
    A = sp.csr_matrix(A)
    A.sort_indices()
    if _indefinite_backend(backend) == "pardiso":
        return PardisoComplexSymmetricSolver(A, perm)
    return SuperLUComplexSolver(A)


def ordering_key(upper: _Upper, mtype: int) -> str:
    """sha256 (hex) of what PARDISO's fill-reducing ordering depends on.

    The pattern PARDISO sees (the upper triangle), the matrix type, the
    version of the MKL library loaded (as it reports itself, whichever way it
    was installed) and the thread count (METIS runs sequentially, but a cached
    ordering is reused only where it was made).
    """
    buf = ctypes.create_string_buffer(256)
    _pypardiso().ps.libmkl.MKL_Get_Version_String(buf, ctypes.c_int(len(buf)))
    mkl = buf.value.decode(errors="replace").strip()
    h = hashlib.sha256()
    h.update(f"mkl={mkl}|mtype={mtype}|iparm2=default|threads={solver_threads()}|".encode())
    h.update(f"n={upper.shape[0]}|".encode())
    h.update(np.ascontiguousarray(upper.indptr, dtype=np.int32).tobytes())
    h.update(np.ascontiguousarray(upper.indices, dtype=np.int32).tobytes())
    return h.hexdigest()


def resolve_backend(backend: str = "auto") -> str:
    """The backend ``backend`` names here ("auto": the fastest installed), checked.

    Raises
    ------
    ValueError
        For an unknown name.
    SolverUnavailable
        For a known backend that is not installed here.
    """
    have = available_backends()
    if backend == "auto":
        backend = have[0]
    if backend not in BACKENDS:
        raise ValueError(f"solver backend = {backend!r}: must be one of auto, {', '.join(BACKENDS)}")
    if backend not in have:
        raise SolverUnavailable(f"solver backend {backend!r} is not installed here")
    return backend


def make_solver(
    A: sp.csr_matrix, backend: str = "auto", ordering_cache: Path | None = None, ahead: bool = False
):
    """A solver analysed for the pattern of the SPD matrix ``A`` (not yet factored).

    Call ``factor(A)`` with any matrix of that pattern, then ``solve(b)``
    (``b`` of shape (n,) or (n, k)).

    ``ordering_cache``: a folder where PARDISO's fill-reducing ordering is kept
    per pattern (:func:`fem.cache.load_ordering`). Given its ordering, PARDISO
    skips METIS (about a third of the analysis) and factors to the same bits
    as when it computed the ordering itself (tests/test_fem_speed.py).

    ``ahead``: PARDISO analyses on a thread, and the first ``factor`` waits for it (``ready()``
    waits explicitly). Its analysis reads only the pattern, so ``A`` may hold any values of
    that pattern (ones); the factorization is the same bit for bit (tests/test_solver_ahead.py).
    The other backends analyse at once, as without it.
    """
    backend = resolve_backend(backend)
    A = sp.csr_matrix(A)
    A.sort_indices()
    if backend != "pardiso":
        return _CLASSES[backend](A)
    if ordering_cache is None:
        return PardisoSolver(A, ahead=ahead)
    from .cache import load_ordering, store_ordering

    upper = _Upper(A)
    key = ordering_key(upper, PardisoSolver.mtype)
    perm = load_ordering(ordering_cache, key, A.shape[0])
    store = None if perm is not None else (lambda made: store_ordering(ordering_cache, key, made))
    return PardisoSolver(A, perm, upper, ahead=ahead, on_analysed=store)
