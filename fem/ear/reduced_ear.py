"""The FE whole ear over the audio band through a reduced model (docs/ear.md §5.14).

Two real reductions, both checked against full harmonic solves (:func:`check_against_direct`,
benchmarks/ear_sweep_fe.py):

1. the joint model condensed onto its two rigid bodies (:func:`fem.ear.joint_condensation.condense_joint`);
2. each shell (drum, footplate) condensed onto the dofs where anything else acts
   (:func:`shell_basis`): static constraint shapes Ψ_s plus a rational Krylov basis of the
   interior, real solutions (K_II − σ_j M_II)⁻¹ R₀ and (K_II − σ_j M_II)⁻¹ M_II (…) at shifts
   σ_j = (2π f_j)² evenly spaced in f up to 1.2 f_max and at σ = 0, from R₀ = [f_I, M_II Ψ + M_IB]
   (the pressure and the inertia of the constraint shapes).

Why not modes. The cochlea's dashpot (R = 0.19 N·s/m, ζ ≈ 6 on the stapes) and the joint's
loss factors (0.15 against the bone's 0.01) are far from proportional damping, and the ear's
free modes miss both. Keeping the dofs they act on and reducing only shells whose damping is
one loss factor each removes that error; the rational Krylov basis reaches the accuracy of the
shells' fixed-interface modes with their inertia corrections at a fraction of the cost (the
measurements, and the reduction's sizes, times and errors on the default mesh: docs/history.md).

The reduced parts are projected once; any damping (a dictionary of η, a, b per part, the
cochlear impedance, :class:`isj.damping.Damping`) is then a sum of projected parts and one
dense complex solve per frequency (:meth:`ReducedEar.frequency_response`).
"""

from __future__ import annotations

import hashlib
import time
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from isj.cavities import DEFAULT_CAVITIES, cavity_factor, check_cavities
from isj.design import Materials
from isj.ear import EarMasses, EarMaterials
from isj.errors import InvalidParameter
from isj.responses import FrequencyResponse
from isj.validate import check_frequencies

from ..solvers import available_backends, make_indefinite_solver, on_solver_threads, solver_threads
from .dynamics import harmonic
from .joint_condensation import (
    CondensedEar,
    condense_joint,
    dynamic_terms,
    ear_parts,
    lowest_frequency_hz,
    one_blas_thread,
    orthonormalize,
    part_coefficients,
)
from .middle_ear import MiddleEarModel
from .shell import NDOF

#: Shell parts condensed by :func:`shell_basis` (each one stiffness and one mass part, so one
#: loss factor, one Rayleigh pair: proportional damping inside it).
SHELLS = ("eardrum", "footplate")

#: Outputs of :meth:`ReducedEar.frequency_response`, per Pa of ear-canal pressure, and their units.
OUTPUTS = (
    "stapes_velocity_m_s",
    "umbo_velocity_m_s",
    "stapes_m",
    "umbo_m",
    "footplate_piston_m",
    "footplate_rocking_long_rad",
    "footplate_rocking_short_rad",
    "alpha_rad",
    "beta_rad",
    "pedicle_share",
)
UNITS = ("m/s", "m/s", "m", "m", "m", "rad", "rad", "rad", "rad", "1")

#: Shifts per kHz of f_max (:func:`shell_basis`): 20 shifts to 24 kHz gave 1e-6, 15 gave 3e-2.
SHIFTS_PER_KHZ = 1.0


def _touched(A, n: int) -> np.ndarray:
    A = sp.coo_matrix(A)
    t = np.zeros(n, bool)
    t[A.row] = t[A.col] = True
    return t


class ShiftedInterior:
    """K − σ M of one shell's interior for any shift σ, factored on one pattern analysed once.

    PARDISO (real symmetric indefinite, :func:`fem.solvers.make_indefinite_solver`) where it is
    installed: the pattern's ordering and symbolic factorization are made once, and each shift
    costs one numeric factorization. On the default drum that is about 25 times faster than
    SuperLU's LU per shift (docs/performance.md §8.7). Otherwise SuperLU, one LU per shift.
    A context manager: the solver's memory is released on leaving it.
    """

    def __init__(self, K: sp.csr_matrix, M: sp.csr_matrix):
        pattern = (abs(K) + abs(M)).tocsr()  # the union of both patterns, whatever σ cancels
        pattern.sort_indices()
        self._indptr, self._indices, self._shape = pattern.indptr, pattern.indices, pattern.shape
        self._k, self._m = _values_on(pattern, K), _values_on(pattern, M)
        self._solver = None
        if "pardiso" in available_backends():
            self._solver = make_indefinite_solver(self._matrix(0.0))

    def _matrix(self, sigma: float) -> sp.csr_matrix:
        data = self._k - sigma * self._m
        return sp.csr_matrix((data, self._indices, self._indptr), shape=self._shape)

    def factor(self, sigma: float):
        """A factor of K − σ M with a ``solve(b)``; it stays valid until the next ``factor``."""
        if self._solver is None:
            return spla.splu(self._matrix(sigma).tocsc())
        self._solver.factor(self._matrix(sigma))
        return self._solver

    def __enter__(self) -> ShiftedInterior:
        return self

    def __exit__(self, *exc) -> None:
        if self._solver is not None:
            self._solver.free()
            self._solver = None


def _values_on(pattern: sp.csr_matrix, A: sp.csr_matrix) -> np.ndarray:
    """The entries of ``A`` in the order of ``pattern``'s data (canonical CSR holding A's entries)."""
    n = pattern.shape[1]
    rows = np.repeat(np.arange(pattern.shape[0], dtype=np.int64), np.diff(pattern.indptr))
    keys = rows * n + pattern.indices
    A = sp.coo_matrix(A)
    where = np.searchsorted(keys, A.row.astype(np.int64) * n + A.col)
    return np.bincount(where, weights=A.data, minlength=keys.size)


#: Interior bases of the shells made in this process (:func:`interior_basis`), by the sha256 of
#: what they are made from; the oldest is dropped past :data:`INTERIOR_BASES_KEPT`.
_INTERIOR_BASES: OrderedDict[str, tuple[np.ndarray, np.ndarray, float]] = OrderedDict()

#: How many interior bases the process keeps: the drum and the footplate of one ear (the rigid
#: connection, the joint's FE reductions and the fast ear share them) with room for a second.
INTERIOR_BASES_KEPT = 4


def _interior_key(arrays, numbers) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}|{a.shape}|".encode() + a.tobytes())
    h.update(repr(numbers).encode())
    return h.hexdigest()


def interior_basis(KII, MII, KIB, MIB, load, f_shift, fmax_hz: float, depth: int, tol: float):
    """(Ψ, Φ, f₁) of one shell's interior: its static constraint shapes Ψ = −K_II⁻¹ K_IB on the
    kept dofs it couples to (the columns of ``KIB`` and ``MIB``), its rational Krylov basis Φ
    (module docstring; orthonormal in the product weighted by M_II's diagonal, new vectors below
    ``tol`` dropped) at the shifts ``f_shift`` (Hz) with
    ``depth`` moments each, and its lowest fixed-interface frequency f₁ (Hz).

    Each ear model has the same drum and footplate, so the rigid connection, each FE reduction
    with the joint and the fast ear ask for the same bases: the process keeps the last
    :data:`INTERIOR_BASES_KEPT`, by the content of every input, and returns a kept one as it is
    (the same bits as making it again).
    """
    KII, MII = sp.csr_matrix(KII, copy=True), sp.csr_matrix(MII, copy=True)
    for A in (KII, MII):
        A.sum_duplicates()  # canonical (sorted, no duplicates): equal matrices, equal keys
    CSR = ("data", "indices", "indptr")
    key = _interior_key(
        [getattr(A, k) for A in (KII, MII) for k in CSR] + [KIB, MIB, load, np.asarray(f_shift, float)],
        (float(fmax_hz), int(depth), float(tol)),
    )
    if key in _INTERIOR_BASES:
        _INTERIOR_BASES.move_to_end(key)
        return _INTERIOR_BASES[key]
    with ShiftedInterior(KII, MII) as shifted:
        lu = shifted.factor(0.0)
        psi = -lu.solve(KIB)
        R0 = np.column_stack([load, MII @ psi + MIB])
        X = [lu.solve(R0)]
        X.append(lu.solve(MII @ X[-1]))  # static and first inertia correction
        # a stiff shell (the footplate: first interior mode far above the band) needs no shifts
        f1 = lowest_frequency_hz(KII, MII, lu)
        for fs in f_shift if f1 < 2 * 1.2 * fmax_hz else ():
            lus = shifted.factor((2 * np.pi * fs) ** 2)
            Y = lus.solve(R0)
            X.append(Y)
            for _ in range(depth - 1):
                Y = lus.solve(MII @ Y)
                X.append(Y)
    phi = orthonormalize(np.hstack(X), np.sqrt(np.abs(MII.diagonal())), tol)
    for a in (psi, phi):
        a.flags.writeable = False  # shared between models: nobody may change a kept basis
    kept = _INTERIOR_BASES[key] = (psi, phi, f1)
    while len(_INTERIOR_BASES) > INTERIOR_BASES_KEPT:
        _INTERIOR_BASES.popitem(last=False)
    return kept


def shell_basis(level1, fmax_hz: float, n_shifts: int | None = None, depth: int = 2, tol: float = 1e-10):
    """Real basis V (n × m) of the level-1 ear: unit vectors on the kept dofs, each shell's interior reduced.

    Parameters
    ----------
    level1 : :class:`fem.ear.joint_condensation.CondensedEar` (or its ``EarParts``)
    fmax_hz : highest frequency of interest (Hz); shifts reach 1.2 × it
    n_shifts : shifts (default :data:`SHIFTS_PER_KHZ` × 1.2 f_max in kHz, at least 4)
    depth : Krylov moments per shift
    tol : relative size below which a new vector counts as dependent

    Returns
    -------
    V (n, m) and a dict of sizes and seconds; ``interior``: each shell's columns (start, stop).
    """
    t0 = time.perf_counter()
    n = level1.load.size
    parts = {("k", p): A for p, A in level1.stiffness.items()}
    parts |= {("m", p): A for p, A in level1.mass.items()} | {("d", p): A for p, A in level1.dashpots.items()}
    touch = {key: _touched(A, n) for key, A in parts.items()}
    interior = {}
    for s in SHELLS:
        own = touch.get(("k", s), np.zeros(n, bool))
        other = np.zeros(n, bool)
        for key, t in touch.items():
            if key[1] != s:
                other |= t
        interior[s] = np.flatnonzero(own & ~other)  # dofs nothing but this shell acts on
    B = np.setdiff1d(np.arange(n), np.concatenate(list(interior.values())))
    if n_shifts is None:
        n_shifts = max(4, int(np.ceil(SHIFTS_PER_KHZ * 1.2 * fmax_hz / 1e3)))
    f_shift = np.linspace(0.0, 1.2 * fmax_hz, n_shifts + 1)[1:]
    blocks, info = [], {"kept_dofs": int(B.size), "n_shifts": int(n_shifts), "depth": int(depth)}
    for s, I in interior.items():
        if I.size == 0:
            continue
        Ks, Ms = sp.csr_matrix(level1.stiffness[s]), sp.csr_matrix(level1.mass.get(s, sp.csr_matrix((n, n))))
        KIB = Ks[I][:, B]
        live = np.asarray(abs(KIB).sum(axis=0)).ravel() > 0  # the kept dofs the shell couples to
        psi_live, phi, f1 = interior_basis(
            Ks[I][:, I].tocsr(),
            Ms[I][:, I].tocsr(),
            KIB[:, live].toarray(),
            Ms[I][:, B][:, live].toarray(),
            level1.load[I],
            f_shift,
            fmax_hz,
            depth,
            tol,
        )
        psi = np.zeros((I.size, B.size))
        psi[:, live] = psi_live
        info[f"{s}_first_interior_hz"] = f1
        blocks.append((s, I, psi, phi))
        info[f"{s}_interior_dofs"], info[f"{s}_vectors"] = int(I.size), int(phi.shape[1])
    m = B.size + sum(b[3].shape[1] for b in blocks)
    V = np.zeros((n, m))
    V[B, np.arange(B.size)] = 1.0
    c = B.size
    info["interior"] = {}
    for s, I, psi, phi in blocks:
        V[I, : B.size] = psi
        V[np.ix_(I, np.arange(c, c + phi.shape[1]))] = phi
        info["interior"][s] = (c, c + phi.shape[1])
        c += phi.shape[1]
    info["seconds"] = time.perf_counter() - t0
    return V, info


def output_rows(model) -> sp.csr_matrix:
    """Rows (k × n_dofs) giving, from q: the umbo's translation (3, m), the footplate centre's (3, m),
    the footplate's piston and rocking (3: m, rad, rad; :func:`footplate_fit`), α and β (rad)."""
    g, fp, T = model.geometry, model.footplate, model.T
    umbo = model.drum.node_sets["umbo"][0]
    centre = fp.node_sets["centre"][0]
    rows = [T[model.off_drum + NDOF * umbo + np.arange(3)], T[model.off_fp + NDOF * centre + np.arange(3)]]
    P = footplate_fit(fp, g)
    nrm, r = np.asarray(fp.normal), fp.nodes_m
    nd = model.off_fp + NDOF * np.arange(len(r))
    normal_rows = sum(nrm[k] * T[nd + k] for k in range(3))  # (nodes, n_q): n · u_i
    rows.append(sp.csr_matrix(P) @ normal_rows)
    if model.joint is not None:
        rows.append(sp.csr_matrix(model.joint.angles[:2]) @ T[model.off_joint : model.off_body])
    return sp.vstack(rows).tocsr()


def footplate_fit(fp, geometry) -> np.ndarray:
    """(3, nodes) P: (w₀ (m), θ_L, θ_S (rad)) = P w, the area-weighted least-squares plane
    w ≈ w₀ + θ_L ζ − θ_S ξ through the nodes' displacements w along the piston direction, ξ and ζ
    the nodes' coordinates (m) along the footplate's long and short axes from its centre: the
    piston and the rotations about the long and short axes (right-handed, e_long × e_short = n)."""
    nrm, e_long = np.asarray(fp.normal), np.asarray(geometry.footplate_long_axis)
    r = fp.nodes_m - np.asarray(geometry.footplate_centre_m)
    p = fp.nodes_m[fp.triangles]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    w = np.bincount(fp.triangles.ravel(), np.repeat(area / 3, 3), minlength=len(r))  # nodal areas
    A = np.column_stack([np.ones(len(r)), r @ np.cross(nrm, e_long), -(r @ e_long)])
    return np.linalg.solve(A.T @ (w[:, None] * A), (w[:, None] * A).T)


@dataclass(eq=False)  # arrays: no elementwise == pretending to be equality
class ReducedEarStaticResult:
    """Undamped static response of the reduced ear per Pa of ear-canal pressure (SI).

    Attributes
    ----------
    umbo_vector_m_per_pa : (3,) the umbo's translation (m/Pa), ear frame
    footplate_m_per_pa : (3,) the footplate centre's translation (m/Pa), ear frame
    footplate_fit_per_pa : (3,) the footplate's piston (m/Pa) and rocking about its long and short
        axes (rad/Pa), :func:`footplate_fit`
    alpha_rad_per_pa, beta_rad_per_pa : the joint model's α and β (rad/Pa); None for the rigid joint
    """

    umbo_vector_m_per_pa: np.ndarray
    footplate_m_per_pa: np.ndarray
    footplate_fit_per_pa: np.ndarray
    alpha_rad_per_pa: float | None
    beta_rad_per_pa: float | None

    def to_dict(self) -> dict:
        """JSON-able: vectors as lists, α and β as floats (None for the rigid joint)."""

        def plain(v):
            return None if v is None else float(v)

        return {
            "umbo_vector_m_per_pa": [float(v) for v in self.umbo_vector_m_per_pa],
            "footplate_m_per_pa": [float(v) for v in self.footplate_m_per_pa],
            "footplate_fit_per_pa": [float(v) for v in self.footplate_fit_per_pa],
            "alpha_rad_per_pa": plain(self.alpha_rad_per_pa),
            "beta_rad_per_pa": plain(self.beta_rad_per_pa),
        }


@dataclass
class ReducedEar:
    """The whole ear projected on a real basis V, part by part (module docstring); SI units.

    Attributes
    ----------
    stiffness, mass, dashpots : part → VᵀA V (m × m, dense, symmetric)
    load : (m,) Vᵀ f for 1 Pa (N/Pa)
    rows : (k, m) outputs (:func:`output_rows`) on the reduced coordinates
    has_joint : whether α and β exist
    n_fe_dofs : dofs of the FE ear it reduces
    footplate_area_m2 : converts the cochlear impedance into its dashpot (m²)
    n_kept : coordinates before the shells' modal interior ones
    diagonal_interior : whether every part is diagonal on the interior coordinates (checked)
    info : sizes and seconds of the reduction
    cavities : "open" (default) or "intact": the middle-ear cavities' load on the drum, a uniform
        back pressure Z_cav U (:mod:`isj.cavities`, docs/circuit.md §13.3), applied to every
        frequency response; the static response is the open ear's
    """

    stiffness: dict
    mass: dict
    dashpots: dict
    load: np.ndarray
    rows: np.ndarray
    piston_direction: np.ndarray
    has_joint: bool
    n_fe_dofs: int
    footplate_area_m2: float = 0.0
    n_kept: int = 0
    diagonal_interior: bool = False
    info: dict = field(default_factory=dict)
    cavities: str = DEFAULT_CAVITIES

    def with_cavities(self, cavities: str) -> ReducedEar:
        """The same reduced ear with the cavities ``cavities`` ("open" or "intact"); no new reduction."""
        return replace(self, cavities=check_cavities(cavities))

    def drum_volume_m3(self, freq_hz, damping=None) -> np.ndarray:
        """The drum's net volume displacement fᵀu per Pa of ear-canal pressure (m³/Pa, medial
        positive; f the drum's nodal force per Pa), complex (n_freq,), with this ear's cavities."""
        return self._solve(freq_hz, damping) @ self.load

    @property
    def n_dofs(self) -> int:
        return self.load.size

    def total_stiffness(self) -> np.ndarray:
        return sum(self.stiffness.values())

    def total_mass(self) -> np.ndarray:
        return sum(self.mass.values())

    def _solve(self, freq_hz, damping=None, chunk: int = 16) -> np.ndarray:
        """Reduced coordinates (n_freq, m) of Z(ω) y = Vᵀ f, Z from ``damping``'s part factors.

        The shells' interior coordinates are modal (:func:`reduced_ear`): there Z is diagonal and
        each frequency costs one Schur complement on the ``n_kept`` other coordinates.
        """
        freqs = check_frequencies(freq_hz)
        coef = part_coefficients(damping, self)
        A0, A1, M = (
            np.asarray(X, complex) for X in dynamic_terms(self.stiffness, self.mass, self.dashpots, coef)
        )
        w = 2 * np.pi * freqs
        k = self.n_kept if self.diagonal_interior else self.n_dofs
        d = [np.diagonal(X)[k:] for X in (A0, A1, M)]
        y = np.zeros((freqs.size, self.n_dofs), complex)
        with one_blas_thread():
            self._solve_chunks(w, A0, A1, M, d, k, y, chunk)
        if check_cavities(self.cavities) != "open":  # Vᵀf · y: the drum's volume displacement
            y *= cavity_factor(freqs, y @ self.load, self.cavities)[:, None]
        return y

    def _solve_chunks(self, w, A0, A1, M, d, k, y, chunk) -> None:
        """Stacked solves, ``chunk`` frequencies in flight at a time (memory bounded), shared among the
        solver's threads: a chunk's numbers do not depend on which thread computed it, or on how
        many did (the caller holds BLAS to one thread; numpy lets go of the GIL in its solves)."""
        f1, f2 = self.load[:k], self.load[k:]

        def solve(i: int) -> None:
            wi = w[i : i + step, None, None]
            Z11 = A0[None, :k, :k] + 1j * wi * A1[None, :k, :k] - wi**2 * M[None, :k, :k]
            Z12 = A0[None, :k, k:] + 1j * wi * A1[None, :k, k:] - wi**2 * M[None, :k, k:]
            z = d[0][None] + 1j * wi[:, :, 0] * d[1][None] - wi[:, :, 0] ** 2 * d[2][None]  # (c, n_i)
            S = Z11 - (Z12 / z[:, None, :]) @ Z12.transpose(0, 2, 1)  # Z21 = Z12ᵀ: Z is symmetric
            r = f1[None] - (Z12 @ (f2[None] / z)[..., None])[..., 0]
            y1 = np.linalg.solve(S, r[..., None])[..., 0]
            y[i : i + step, :k] = y1
            y[i : i + step, k:] = (f2[None] - (y1[:, None, :] @ Z12)[:, 0]) / z

        # ``chunk`` frequencies in flight in all: each thread takes its share, so the threads hold
        # no more memory than one thread did (a chunk of the default ear is about 0.3 GB)
        step = max(1, chunk // solver_threads())
        on_solver_threads(solve, range(0, w.size, step))  # each fills its rows of y

    def static(self) -> ReducedEarStaticResult:
        """Undamped static response per Pa: umbo and footplate centre vectors, footplate fit, α, β."""
        y = np.linalg.solve(self.total_stiffness(), self.load)
        d = self._split(self.rows @ y)
        return ReducedEarStaticResult(d["umbo_vector"], d["footplate"], d["fit"], d["alpha"], d["beta"])

    def _split(self, out) -> dict:
        out = np.asarray(out)
        d = {"umbo_vector": out[..., 0:3], "footplate": out[..., 3:6], "fit": out[..., 6:9]}
        d["alpha"] = out[..., 9] if self.has_joint else None
        d["beta"] = out[..., 10] if self.has_joint else None
        return d

    def _outputs(self, freq_hz, damping=None) -> np.ndarray:
        """(n, 4) complex: umbo (along its static direction), stapes piston (m/Pa), α, β (rad/Pa),
        the columns of :meth:`fem.ear.dynamics.EarHarmonicResult.outputs`."""
        return self._columns(freq_hz, damping)[0][:, [3, 2, 7, 8]]

    def _columns(self, freq_hz, damping):
        freqs = check_frequencies(freq_hz)
        s = self.static().umbo_vector_m_per_pa
        d_umbo = s / np.linalg.norm(s)
        o = self._split(self._solve(freqs, damping) @ self.rows.T)
        x_st = o["footplate"] @ self.piston_direction
        x_um = o["umbo_vector"] @ d_umbo
        iw = 2j * np.pi * freqs
        zero = np.zeros(freqs.size, complex)
        a = zero if o["alpha"] is None else o["alpha"]
        b = zero if o["beta"] is None else o["beta"]
        with np.errstate(invalid="ignore", divide="ignore"):
            share = np.where(a + b != 0, b / (a + b), np.nan) if self.has_joint else zero * np.nan
        cols = [iw * x_st, iw * x_um, x_st, x_um, o["fit"][:, 0], o["fit"][:, 1], o["fit"][:, 2], a, b, share]
        return np.column_stack(cols), freqs

    def frequency_response(self, freq_hz, damping=None):
        """The field's quantities per Pa of ear-canal pressure (:data:`OUTPUTS`, :data:`UNITS`).

        H_V = ``stapes_velocity_m_s`` (the footplate centre's velocity along the piston direction,
        m/s per Pa), the umbo's velocity along its static direction, both displacements, the
        footplate's piston and rocking components (:func:`output_rows`), the joint model's α and β
        (zero for the rigid joint) and the pedicle's share β/(α+β) of the incus-to-stapes
        relative rotation (NaN for the rigid joint). An :class:`isj.responses.FrequencyResponse`.
        """
        H, freqs = self._columns(freq_hz, damping)
        return FrequencyResponse(freqs, H, OUTPUTS, UNITS)

    def natural_frequencies_hz(self, n: int | None = None) -> np.ndarray:
        """Undamped natural frequencies (Hz) of the reduced model, ascending (the ``n`` lowest)."""
        w2 = sla.eigh(self.total_stiffness(), self.total_mass(), eigvals_only=True)
        f = np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi)
        return f if n is None else f[:n]


def modal_interiors(groups: dict, load: np.ndarray, rows: np.ndarray, interior: dict) -> None:
    """Make each shell's interior coordinates modal, in place: ``groups`` (kind → part → matrix
    on the shells' basis), ``load`` and the output ``rows``, for ``interior`` (shell → its columns
    (start, stop), :func:`shell_basis`). Only that shell's parts act on them, so every part, and Z
    for any damping, is diagonal there."""
    for name, (a, b) in interior.items():
        U = sla.eigh(groups["stiffness"][name][a:b, a:b], groups["mass"][name][a:b, a:b])[1]
        for P in (P for g in groups.values() for P in g.values()):
            P[:, a:b] = P[:, a:b] @ U
            P[a:b, :] = U.T @ P[a:b, :]
        load[a:b] = U.T @ load[a:b]
        rows[:, a:b] = rows[:, a:b] @ U


def reduced_ear(
    model,
    materials: Materials | None = None,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
    fmax_hz: float = 20e3,
    n_shifts: int | None = None,
    joint_enrich: tuple[str, ...] = ("mass", "damping", "cross"),
) -> ReducedEar:
    """Reduce the FE ear for responses up to ``fmax_hz`` (Hz), for any damping (module docstring).

    Parameters
    ----------
    model : :class:`fem.ear.middle_ear.MiddleEarModel` (with the joint model or rigid)
    materials, ear_materials, masses : as :func:`fem.ear.dynamics.harmonic` (the basis is
        built for these; a change of them needs a new reduction)
    fmax_hz : highest frequency the basis is built for (Hz)
    n_shifts : Krylov shifts (:func:`shell_basis`)
    joint_enrich : interior vectors of the joint (:func:`fem.ear.joint_condensation.condense_joint`)

    Returns
    -------
    :class:`ReducedEar`; ``info`` holds the sizes and the seconds of each step.
    """
    if not (np.isfinite(fmax_hz) and fmax_hz > 0):
        raise InvalidParameter(f"fmax_hz = {fmax_hz!r} Hz: must be a finite number > 0")
    t0 = time.perf_counter()
    parts = ear_parts(model, materials, ear_materials, masses)
    t1 = time.perf_counter()
    level1 = _level1(parts, model, joint_enrich)
    t2 = time.perf_counter()
    V, info = shell_basis(level1, fmax_hz, n_shifts)
    t3 = time.perf_counter()
    groups, load, rows, asym = _projected(level1, V, info, model)
    k = info["kept_dofs"]
    off = _interior_off_diagonal(groups, k)
    out = ReducedEar(
        **groups,
        load=load,
        rows=rows,
        piston_direction=np.asarray(model.geometry.piston_direction, float),
        has_joint=model.joint is not None,
        n_fe_dofs=model.n_dofs,
        footplate_area_m2=parts.footplate_area_m2,
        n_kept=k,
        diagonal_interior=bool(off <= 1e-10),
    )
    t4 = time.perf_counter()
    out.info = info | {
        "level1_dofs": int(level1.n_dofs),
        "n_dofs": out.n_dofs,
        "interior_off_diagonal": float(off),
        "asymmetry": float(asym),
        "timings_s": {
            "parts": t1 - t0,
            "joint": t2 - t1,
            "shells": t3 - t2,
            "project": t4 - t3,
            "total": t4 - t0,
        },
    }
    return out


def _level1(parts, model, joint_enrich) -> CondensedEar:
    """The ear with its joint condensed onto the bodies, or the rigid ear's parts as they are."""
    if model.joint is not None:
        return condense_joint(parts, model, joint_enrich)
    n = model.n_dofs
    z = np.zeros((0, 0))
    return CondensedEar(
        parts.stiffness,
        parts.mass,
        parts.dashpots,
        parts.load,
        np.arange(n),
        np.zeros(0, int),
        np.zeros(0, int),
        z,
        z,
        n,
    )


def _projected(level1, V, info, model) -> tuple[dict, np.ndarray, np.ndarray, float]:
    """(parts, load, output rows, largest relative asymmetry) on the basis ``V``: each shell's
    interior made modal and every part symmetrised (its asymmetry was rounding)."""

    def project(A, W):
        t = np.flatnonzero(_touched(A, W.shape[0]))  # most parts act on few dofs: only those rows
        A = sp.csr_matrix(A)[t][:, t]
        return W[t].T @ np.asarray(A @ W[t])

    groups = {
        g: {k: project(A, V) for k, A in getattr(level1, g).items()}
        for g in ("stiffness", "mass", "dashpots")
    }
    load, rows = V.T @ level1.load, level1.restrict(output_rows(model)) @ V
    modal_interiors(groups, load, rows, info["interior"])
    asym = 0.0
    for g in groups.values():
        for name, P in g.items():
            asym = max(asym, abs(P - P.T).max() / max(abs(P).max(), 1e-300))
            g[name] = 0.5 * (P + P.T)  # symmetric to rounding, as every part
    return groups, load, rows, asym


def _interior_off_diagonal(groups: dict, k: int) -> float:
    """The largest off-diagonal entry of the modal interiors (past the ``k`` kept dofs), relative
    to each part's largest: 0 to rounding when the interiors are diagonal."""
    return max(
        np.abs(P[k:, k:] - np.diag(np.diagonal(P[k:, k:]))).max(initial=0.0) / max(abs(P).max(), 1e-300)
        for g in groups.values()
        for P in g.values()
    )


# ---------------------------------------------------------------------------- checks


#: Largest magnitude error (relative) and phase error (degrees) the self-checks accept.
CHECK_TOLERANCE = (0.01, 1.0)


def check_frequencies_hz(fmin_hz: float, fmax_hz: float, n: int = 3) -> np.ndarray:
    """``n`` check frequencies log-spaced over the band, both ends included (so one above 10 kHz
    whenever the band reaches past it)."""
    return np.geomspace(fmin_hz, fmax_hz, n) if n > 1 else np.array([fmax_hz], float)[:n]


def check_against_direct(
    model,
    rom: ReducedEar,
    freq_hz,
    damping=None,
    materials=None,
    ear_materials=None,
    masses=None,
    tolerance=CHECK_TOLERANCE,
) -> dict:
    """The reduced model against direct FE harmonic solves (:func:`fem.ear.dynamics.harmonic`).

    ``rom``: a :class:`ReducedEar` (reduced at ``materials``) or a
    :class:`fem.ear.fast_ear.FastEar`, which is evaluated at ``materials``.

    Returns
    -------
    dict: ``checks`` (per frequency: both responses as [re, im] per output, ``{output}_mag_rel_error``
    = ||reduced|/|direct| − 1|, ``{output}_phase_error_deg``, ``passed``), the largest errors
    ``max_mag_rel_error`` and ``max_phase_error_deg``, ``passed`` and the direct solves' seconds.
    Outputs: umbo, stapes (m/Pa), and α, β (rad/Pa) with the joint.
    """
    freqs = check_frequencies(freq_hz)
    t0 = time.perf_counter()
    direct = harmonic(model, freqs, materials, ear_materials, damping, masses).outputs()
    t1 = time.perf_counter()
    if isinstance(rom, ReducedEar):
        red, has_joint = rom._outputs(freqs, damping), rom.has_joint
    else:  # a fast ear: the columns of the same outputs at ``materials``
        resp = rom.frequency_response(freqs, materials, damping)
        red = np.column_stack([resp[k] for k in ("umbo_m", "stapes_m", "alpha_rad", "beta_rad")])
        has_joint = True
    names = ("umbo_m", "stapes_m", "alpha_rad", "beta_rad")[: 4 if has_joint else 2]
    red, direct = red[:, : len(names)], direct[:, : len(names)]  # α, β are zero without the joint
    mag = np.abs(np.abs(red) / np.abs(direct) - 1)
    ph = np.abs(np.degrees(np.angle(red / direct)))
    ok = (mag <= tolerance[0]) & (ph <= tolerance[1])
    checks = []
    for i, f in enumerate(freqs):
        row = {"freq_hz": float(f)}
        for j, k in enumerate(names):
            row[f"direct_{k}"] = [float(direct[i, j].real), float(direct[i, j].imag)]
            row[f"reduced_{k}"] = [float(red[i, j].real), float(red[i, j].imag)]
            row[f"{k}_mag_rel_error"], row[f"{k}_phase_error_deg"] = float(mag[i, j]), float(ph[i, j])
        checks.append(row | {"passed": bool(ok[i].all())})
    return {
        "checks": checks,
        "max_mag_rel_error": float(mag.max()),
        "max_phase_error_deg": float(ph.max()),
        "tolerance": {"mag_rel": tolerance[0], "phase_deg": tolerance[1]},
        "passed": bool(ok.all()),
        "direct_seconds": t1 - t0,
        "direct_seconds_per_frequency": (t1 - t0) / freqs.size,
    }


def agreement_limit_hz(freq_hz, a, b, tol_db: float = 1.0) -> tuple[float | None, np.ndarray]:
    """Up to which frequency two responses agree within ``tol_db`` in magnitude.

    Returns (f, diff): f the highest frequency (Hz) below which every point of the ascending
    ``freq_hz`` agrees (None if the first does not), diff = 20 log10 |a/b| (dB) at each point.
    """
    f = np.asarray(freq_hz, float)
    diff = 20 * np.log10(np.abs(np.asarray(a)) / np.abs(np.asarray(b)))
    bad = np.flatnonzero(~(np.abs(diff) <= tol_db))
    if bad.size == 0:
        return float(f[-1]), diff
    return (float(f[bad[0] - 1]) if bad[0] > 0 else None), diff


def drum_mesh_convergence(
    joint,
    freq_hz,
    drum_mesh_sizes_m=(0.25e-3, 0.125e-3),
    damping=None,
    tol_db: float = 1.0,
    check_hz=(),
    **reduce_kw,
) -> dict:
    """H_V on two eardrum meshes (the joint model the same) and up to where they agree within ``tol_db``.

    Returns
    -------
    dict: ``freq_hz``, ``h_v`` (one complex array per mesh size, m/s/Pa), ``diff_db`` (second
    against first), ``agree_up_to_hz``, ``tol_db``, ``drum_mesh_sizes_m``, ``n_dofs`` and
    ``seconds`` per mesh; with ``check_hz``, ``checks``: :func:`check_against_direct` per mesh.
    """
    freqs = check_frequencies(freq_hz)
    h, n_dofs, secs, checks = [], [], [], []
    for size in drum_mesh_sizes_m:
        t0 = time.perf_counter()
        model = MiddleEarModel(joint=joint, drum_mesh_size_m=size)
        rom = reduced_ear(model, fmax_hz=float(freqs.max()), **reduce_kw)
        h.append(rom.frequency_response(freqs, damping)["stapes_velocity_m_s"])
        n_dofs.append(model.n_dofs)
        secs.append(time.perf_counter() - t0)
        if len(check_hz):  # each mesh's reduced model against its own direct solves
            checks.append(check_against_direct(model, rom, check_hz, damping))
        del model, rom
    f_ok, diff = agreement_limit_hz(freqs, h[1], h[0], tol_db)
    return {
        "freq_hz": freqs,
        "h_v": h,
        "diff_db": diff,
        "agree_up_to_hz": f_ok,
        "tol_db": tol_db,
        "drum_mesh_sizes_m": tuple(drum_mesh_sizes_m),
        "n_dofs": n_dofs,
        "seconds": secs,
        "checks": checks,
    }
