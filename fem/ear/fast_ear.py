"""A fast FE ear for many joint designs: H_V and ΔH_V, microseconds a design and frequency.

Method, choice and measurements: docs/fast_ear.md.

The FE ear (:mod:`fem.ear.reduced_ear`) needs one reduction per set of joint moduli (16–34 s on
the default mesh). Here the reduction is done once per (ear geometry, mesh) and the joint's
moduli enter afterwards, through the affine structure of its matrices:

1. **One joint basis for the whole design space.** The joint's interior J is written
   u_J = Ψ₀ x_B + Φ z, x_B the twelve dofs of the malleus–incus body and the stapes
   superstructure, Ψ₀ the exact static condensation at the reference design (the base case) and
   Φ a proper orthogonal decomposition of snapshots taken at a few designs of the calibrated
   domain (:func:`snapshot_designs`): at each, the static shapes of the stapes's six unit
   motions, their first-order change with each region's loss factor and the inertia of all
   twelve static shapes (at the reference design also the inertia of the loss-factor vectors,
   as :func:`fem.ear.joint_condensation.condense_joint`). Each region's stiffness is Eᵣ times a
   fixed matrix (ν fixed), so the projected joint is Σᵣ (Eᵣ/Eᵣ₀) Kᵣ for any design.
2. **The rest of the ear as the FE ear reduces it.** The drum and the footplate come in through
   :func:`fem.ear.reduced_ear.shell_basis`: static constraint shapes and a rational Krylov basis
   up to 1.2 f_max, made modal (their natural modes in the band); the ligaments, the rigid
   bodies' masses and the cochlear dashpot stay as they are. None of it depends on the joint's
   moduli: per frequency the rest is condensed exactly onto x_B once, for all designs
   (:meth:`FastEar.rest`): a 12 × 12 dynamic stiffness, a load and the outputs' maps.
3. **The joint condensed per design.** For a design, the projected joint's interior z is
   condensed onto x_B with the complex static condensation W = [I; −A₀,zz⁻¹ A₀,zB] (A₀ the
   stiffness with every region's loss factor), plus the second-order dynamic correction
   −(ΔW)ᵀ A₀,zz⁻¹ (ΔW) with ΔW = (iω A₁ − ω² M) W: the joint's condensed stiffness, damping and
   mass on the two bodies, every coupling between them, not only α and β. Each design and
   frequency then costs one 12 × 12 complex solve (:meth:`FastEar.batch`).

The damping is the FE ear's: an :class:`isj.damping.Damping` (or a preset name), part by part
(:func:`fem.ear.joint_condensation.part_coefficients`). ΔH_V is against the rigid connection of
the same ear: the two bodies tied rigidly (x_stapes = G x_body), the rest condensed the same way,
which is the FE ear of :class:`fem.ear.middle_ear.MiddleEarModel` with ``joint=None`` (checked in
tests/test_fast_ear.py).

Built once per (ear geometry, meshes, ear materials, masses, settings) and kept in
``$ISJ_FE_CACHE_DIR/fast_ear`` as one checksummed NPZ entry (:mod:`isj.cachefile`), keyed as the
surrogate's (:mod:`fem.rom.model`): the meshes' contents, the settings and the ``ear`` results version.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
import warnings
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from isj.cachefile import DamagedEntry, canonical_json, discard, read_npz_entry, write_npz_entry
from isj.cavities import DEFAULT_CAVITIES, cavity_factor, check_cavities
from isj.design import REGIONS, Materials
from isj.design_space import RANGED, DesignSpace
from isj.ear import EarMasses, EarMaterials
from isj.errors import CacheWarning, InvalidParameter
from isj.responses import delta_columns
from isj.validate import check_frequencies

from ..solvers import on_solver_threads, solver_threads
from .constraints import rigid_body_modes
from .joint_condensation import (
    CondensedEar,
    dynamic_terms,
    ear_parts,
    one_blas_thread,
    orthonormalize,
    part_coefficients,
)
from .reduced_ear import modal_interiors, output_rows, shell_basis

#: Bump when the stored arrays change meaning or value (it is part of the cache key): 2, eight
#: snapshot designs (were 13) and the snapshots' solves batched.
FAST_EAR_FORMAT_VERSION = 2

#: Relative singular value below which the joint snapshots' POD drops a direction: on the coarse
#: test ear about 80 directions, ΔH_V within 1.3e-3 dB and 0.03° of the FE ear to 10 kHz
#: (docs/fast_ear.md §14.2).
DEFAULT_POD_TOL = 3e-3

#: Outputs of :meth:`FastEar.frequency_response`, per Pa of ear-canal pressure, and their units.
OUTPUTS = (
    "stapes_velocity_m_s",
    "umbo_velocity_m_s",
    "stapes_m",
    "umbo_m",
    "alpha_rad",
    "beta_rad",
    "delta_h_v",
)
UNITS = ("m/s", "m/s", "m", "m", "rad", "rad", "1")

#: Designs per block of :meth:`FastEar.batch` (memory: block × n_freq × 144 complex numbers).
BLOCK = 64


#: Where the fast ears shipped with isj lie (package data): the default report's, so that a new
#: user's first report does not build it (docs/fast_ear.md §14.7, scripts/ship_fast_ear.py).
SHIPPED_DIR = Path(__file__).with_name("data")


def fast_ear_cache_dir() -> Path:
    """``$ISJ_FE_CACHE_DIR/fast_ear``, else ``~/.cache/isj/fe/fast_ear``: beside the surrogate's."""
    from isj.caches import fe_cache_dir

    return fe_cache_dir() / "fast_ear"


def snapshot_designs(space: DesignSpace | None = None, reference: Materials | None = None) -> np.ndarray:
    """(8, 5) ranged moduli (Pa, :data:`isj.design_space.RANGED` order) the joint basis is built from.

    The reference design first (its static condensation is Ψ₀), then the centres of the box's five
    low faces in log coordinates (each modulus at its low end, the others at the log-centre), then
    the two corners with every modulus low and every modulus high; the high faces add little
    that the corners miss (docs/fast_ear.md §14.2 measures the choice).
    """
    space = space or DesignSpace()
    ref = reference or Materials()
    d = len(RANGED)
    t = [np.full(d, 0.5)]
    for j in range(d):
        x = np.full(d, 0.5)
        x[j] = 0.0
        t.append(x)
    t += [np.zeros(d), np.ones(d)]
    out = space.from_unit(np.array(t))
    out[0] = [ref.youngs(k[: -len("_e_pa")]) for k in RANGED]
    return out


def region_moduli(designs, space: DesignSpace, regions) -> np.ndarray:
    """(n, len(regions)) Young's moduli (Pa) per joint region of designs: Materials, a list of
    them, or an (n, 5) array of the ranged moduli; each checked against the calibrated domain."""
    if isinstance(designs, Materials):
        designs = [designs]
    if isinstance(designs, list | tuple) and designs and isinstance(designs[0], Materials):
        E = np.concatenate([space.designs_from(m) for m in designs])
    else:
        E = space.check(designs)
    theta = space.theta(E)  # isj.design.REGIONS order
    return theta[:, [REGIONS.index(r) for r in regions]]


def _joint_operators(parts, model) -> dict:
    """The joint interior's blocks: per region KJJ (sparse) and KJB (dense, to the 12 body dofs),
    the mass's MJJ and MJB, and the weights √|diag MJJ| of the POD's inner product."""
    fq = model.free
    inJ = (fq >= model.off_joint) & (fq < model.off_body)
    J = np.flatnonzero(inJ)
    if J.size == 0:
        raise InvalidParameter("model: its joint model has no interior dofs to condense")
    B = np.searchsorted(fq, np.concatenate([model.body_dofs, model.stapes_dofs]))
    regions = tuple(model.joint.regions)
    KJ = {r: sp.csr_matrix(parts.stiffness[r])[J] for r in regions}
    MJ = sp.csr_matrix(parts.total_mass())[J]
    MJJ = MJ[:, J].tocsr()
    return {
        "n": J.size,
        "regions": regions,
        "KJJ": {r: KJ[r][:, J].tocsr() for r in regions},
        "KJB": {r: KJ[r][:, B].toarray() for r in regions},
        "MJJ": MJJ,
        "MJB": MJ[:, B].toarray(),
        "w": np.sqrt(np.abs(MJJ.diagonal())),
    }


def _snapshots(ops: dict, solver, scale: np.ndarray, reference: bool) -> tuple[np.ndarray, np.ndarray]:
    """(Ψ, X): the static condensation (n_J, 12) at one design (each region's stiffness times
    ``scale``) and its snapshot vectors (module docstring, step 1), from ``solver`` (analysed for
    the joint's pattern) factored for that design."""
    regions, KJJ, KJB, MJJ = ops["regions"], ops["KJJ"], ops["KJB"], ops["MJJ"]
    n = ops["n"]
    K = sum(s * KJJ[r] for s, r in zip(scale, regions, strict=True)).tocsr()
    solver.factor(K)

    def solve(rhs):
        return np.asarray(solver.solve(rhs)).reshape(n, -1)

    psi = -solve(sum(s * KJB[r] for s, r in zip(scale, regions, strict=True)))
    # one solve for the loss factors' changes (six columns a region: the stapes's motions, as
    # rigid motions of both bodies strain nothing) and the inertia of the twelve static shapes
    rhs = [s * (KJJ[r] @ psi[:, 6:] + KJB[r][:, 6:]) for s, r in zip(scale, regions, strict=True)]
    X = solve(np.hstack([*rhs, MJJ @ psi + ops["MJB"]]))
    n_dam = 6 * len(regions)
    if reference:  # Ψ₀ itself is the static part: the interior vectors of condense_joint
        return psi, np.hstack([X, solve(MJJ @ X[:, :n_dam])])  # and the loss vectors' inertia
    return psi, np.hstack([psi[:, 6:], X])  # elsewhere the static shapes differ from Ψ₀'s


def _pod(blocks, pod_tol: float) -> tuple[np.ndarray, np.ndarray, int]:
    """(U, singular values, rank) of the snapshots' coefficient blocks on their orthonormal basis."""
    C = np.zeros((blocks[-1].shape[0], sum(c.shape[1] for c in blocks)))
    j = 0
    for c in blocks:
        C[: c.shape[0], j : j + c.shape[1]] = c
        j += c.shape[1]
    U, sv, _ = np.linalg.svd(C, full_matrices=False)
    rank = int(np.sum(sv > pod_tol * sv[0])) if pod_tol > 0 else C.shape[0]
    return U, sv, rank


def joint_basis(
    parts,
    model,
    designs_pa: np.ndarray,
    space: DesignSpace,
    reference: Materials,
    pod_tol: float = DEFAULT_POD_TOL,
    solver: str = "auto",
    tol: float = 1e-10,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """(Ψ₀, Φ, info): the reference design's static condensation (n_J, 12) and the POD basis
    (n_J, m) of the joint snapshots at ``designs_pa`` (module docstring, step 1).

    ``pod_tol`` = 0 keeps every independent snapshot direction (no truncation). One symbolic
    analysis serves every design (the pattern is the same); each design is one factorization
    and three solves.
    """
    from isj.fem.solvers import make_solver

    t0 = time.perf_counter()
    ops = _joint_operators(parts, model)
    regions, w = ops["regions"], ops["w"]
    E0 = np.array([reference.youngs(r) for r in regions])
    theta = region_moduli(designs_pa, space, regions)
    Q = np.zeros((ops["n"], 0))
    blocks, psi0 = [], None
    slv = make_solver(sum(ops["KJJ"].values()).tocsr(), solver)
    try:
        for k, e in enumerate(theta):
            psi, X = _snapshots(ops, slv, e / E0, reference=k == 0)
            psi0 = psi if k == 0 else psi0
            X = X / np.linalg.norm(X * w[:, None], axis=0)  # each snapshot of unit weighted norm
            Q = np.hstack([Q, orthonormalize(X, w, tol, against=Q)])
            # coefficients on Q (orthonormal in the weighted product); on Q's later vectors they
            # are below ``tol`` (those were orthogonalised against this block): taken as zero
            blocks.append((Q * w[:, None] ** 2).T @ X)
    finally:
        if hasattr(slv, "free"):
            slv.free()
    U, sv, rank = _pod(blocks, pod_tol)
    phi = Q @ U[:, :rank] if pod_tol > 0 else Q  # no truncation: every independent direction
    info = {
        "n_snapshot_designs": int(theta.shape[0]),
        "n_snapshot_vectors": int(sum(c.shape[1] for c in blocks)),
        "n_independent": int(Q.shape[1]),
        "n_joint_basis": rank,
        "pod_tol": float(pod_tol),
        "singular_values": (sv / sv[0]).tolist(),
        "seconds": time.perf_counter() - t0,
    }
    return psi0, phi, info


def condensed_ear(parts, model, psi: np.ndarray, phi: np.ndarray) -> CondensedEar:
    """The ear with its joint's interior on u_J = Ψ x_B + Φ z: the level-1 model of
    :func:`fem.ear.reduced_ear.shell_basis` (as :func:`fem.ear.joint_condensation.condense_joint`
    builds it, for a given Ψ and Φ)."""
    fq = model.free
    inJ = (fq >= model.off_joint) & (fq < model.off_body)
    J, R = np.flatnonzero(inJ), np.flatnonzero(~inJ)
    B = np.searchsorted(fq, np.concatenate([model.body_dofs, model.stapes_dofs]))
    b = np.searchsorted(R, B)
    nR, m = R.size, phi.shape[1]
    W = np.block([[psi, phi], [np.eye(12), np.zeros((12, m))]])
    idx = np.concatenate([J, B])
    n1 = nR + m
    pos = np.concatenate([b, nR + np.arange(m)])
    rr, cc = (x.ravel() for x in np.meshgrid(pos, pos, indexing="ij"))
    joint_parts = set(model.joint.regions)

    def level1(name, A):
        if name in joint_parts:
            D = W.T @ np.asarray(sp.csr_matrix(A)[idx][:, idx] @ W)
            D = 0.5 * (D + D.T)
            return sp.csr_matrix((D.ravel(), (rr, cc)), shape=(n1, n1))
        S = sp.csr_matrix(A)[R][:, R].tocoo()
        return sp.csr_matrix((S.data, (S.row, S.col)), shape=(n1, n1))

    load = np.concatenate([parts.load[R], phi.T @ parts.load[J]])
    load[b] += psi.T @ parts.load[J]
    return CondensedEar(
        stiffness={k: level1(k, A) for k, A in parts.stiffness.items()},
        mass={k: level1(k, A) for k, A in parts.mass.items()},
        dashpots={k: level1(k, A) for k, A in parts.dashpots.items()},
        load=load,
        R=R,
        J=J,
        b=b,
        psi=psi,
        phi=phi,
        n_q=fq.size,
    )


def _project(level1, V):
    def one(A):
        t = np.flatnonzero(np.asarray(abs(sp.csr_matrix(A)).sum(axis=1)).ravel() > 0)
        A = sp.csr_matrix(A)[t][:, t]
        return V[t].T @ np.asarray(A @ V[t])

    return {g: {k: one(A) for k, A in getattr(level1, g).items()} for g in ("stiffness", "mass", "dashpots")}


class FastEar:
    """The FE ear reduced once for every joint design of a domain (module docstring); SI units.

    Build with :func:`fast_ear` (cached) or :func:`build_fast_ear`.

    Attributes
    ----------
    arrays : the stored arrays: the projected parts (``k:``, ``m:``, ``d:`` + part name, m × m),
        ``load`` (m,), ``rows`` (11, m) (:func:`fem.ear.reduced_ear.output_rows`), the index sets
        ``jb`` (12: x_B), ``jz`` (the joint basis), ``kr`` (the rest's kept coordinates), ``ii``
        (the shells' modal coordinates), ``region_e0_pa``, ``piston_direction``, ``rigid_map``
        (12 × 6: x_B of a rigid connection, body and stapes moving as one)
    space : the calibrated domain the designs must lie in
    meta : sizes, settings, seconds of the build (JSON-able)
    """

    def __init__(self, arrays: dict, space: DesignSpace, meta: dict):
        self.arrays = {k: np.asarray(v) for k, v in arrays.items()}
        self.space = space
        self.meta = dict(meta)
        self.regions = tuple(self.meta["regions"])
        a = self.arrays
        self.parts_k = {k[2:]: a[k] for k in a if k.startswith("k:")}
        self.parts_m = {k[2:]: a[k] for k in a if k.startswith("m:")}
        self.parts_d = {k[2:]: a[k] for k in a if k.startswith("d:")}
        self.footplate_area_m2 = float(a["footplate_area_m2"])
        self.jb, self.jz, self.kr, self.ii = (a[k].astype(np.int64) for k in ("jb", "jz", "kr", "ii"))
        self.jset = np.concatenate([self.jb, self.jz])
        self._rest_memo: dict = {}

    # ---- parts ---------------------------------------------------------------------------

    @property
    def stiffness(self):  # for part_coefficients
        return self.parts_k

    @property
    def mass(self):
        return self.parts_m

    @property
    def n_dofs(self) -> int:
        return int(self.arrays["load"].size)

    @property
    def n_joint_basis(self) -> int:
        return int(self.jz.size)

    def __repr__(self) -> str:
        return (
            f"FastEar({self.n_dofs} coordinates, joint basis {self.n_joint_basis}, "
            f"f_max {self.meta.get('fmax_hz', 0):g} Hz)"
        )

    def truncated(self, n_joint: int) -> FastEar:
        """The same fast ear with the joint basis cut to its ``n_joint`` leading POD directions
        (Galerkin on the subspace: the drum's and footplate's bases do not depend on it)."""
        if not (isinstance(n_joint, int | np.integer) and 0 <= n_joint <= self.n_joint_basis):
            raise InvalidParameter(f"n_joint = {n_joint!r}: must be an integer in [0, {self.n_joint_basis}]")
        drop = self.jz[n_joint:]
        keep = np.setdiff1d(np.arange(self.n_dofs), drop)
        new = np.full(self.n_dofs, -1, np.int64)
        new[keep] = np.arange(keep.size)
        a = {}
        for k, v in self.arrays.items():
            if k[:2] in ("k:", "m:", "d:"):
                a[k] = v[np.ix_(keep, keep)]
            elif k == "load":
                a[k] = v[keep]
            elif k == "rows":
                a[k] = v[:, keep]
            elif k in ("jb", "kr", "ii"):
                a[k] = new[v]
            elif k == "jz":
                a[k] = new[v[:n_joint]]
            else:
                a[k] = v
        meta = self.meta | {"n_dofs": int(keep.size), "n_joint_basis": int(n_joint)}
        return FastEar(a, self.space, meta)

    def _rows(self) -> np.ndarray:
        """(12, m): the outputs' rows (:func:`fem.ear.reduced_ear.output_rows`) and the drum's volume
        displacement per Pa (m³/Pa), the load's row (fᵀu = (Vᵀf)ᵀ y)."""
        return np.vstack([self.arrays["rows"], self.arrays["load"][None]])

    # ---- the rest of the ear, once per frequency -------------------------------------------

    def rest(self, freq_hz, damping=None) -> dict:
        """The ear without its joint condensed exactly onto x_B, per frequency (module docstring, 2).

        Returns
        -------
        dict of complex arrays: ``S`` (n_f, 12, 12) dynamic stiffness on x_B, ``g`` (n_f, 12)
        load (N/Pa), ``o0`` (n_f, 12) and ``ob`` (n_f, 12, 12): the outputs' rows
        (:func:`fem.ear.reduced_ear.output_rows`, then the drum's volume displacement fᵀu) are
        o0 + ob x_B + rows_z z (:meth:`_rows`).
        """
        freqs = check_frequencies(freq_hz)
        from isj.damping import resolve

        d = resolve(damping)
        key = (freqs.tobytes(), d)
        if key in self._rest_memo:
            return self._rest_memo[key]
        coef = part_coefficients(d, self)
        rest = [p for p in self.parts_k if p not in self.regions]
        rest_m = [p for p in self.parts_m if p not in self.regions]
        A0, A1, M = (
            np.asarray(X, complex)
            for X in dynamic_terms(
                {p: self.parts_k[p] for p in rest},
                {p: self.parts_m[p] for p in rest_m},
                self.parts_d,
                coef,
            )
        )
        f, C = self.arrays["load"], self._rows()
        B, K, I = self.jb, self.kr, self.ii
        X = np.concatenate([K, I])
        nk = K.size
        dI = [np.diagonal(Y)[I] for Y in (A0, A1, M)]
        w_all = 2 * np.pi * freqs

        # 16 frequencies in flight in all, each thread its share: no more memory than one thread
        step = max(1, 16 // solver_threads())

        def chunk(i: int) -> dict:  # frequencies i to i + step: the same arithmetic on any thread
            w = w_all[i : i + step, None, None]

            def Z(rows, cols):
                ix = np.ix_(rows, cols)
                return A0[ix][None] + 1j * w * A1[ix][None] - w**2 * M[ix][None]

            zi = dI[0][None] + 1j * w[:, :, 0] * dI[1][None] - w[:, :, 0] ** 2 * dI[2][None]
            Zkk, Zki, ZXB, ZBB = Z(K, K), Z(K, I), Z(X, B), Z(B, B)
            # right-hand sides on the rest X: its coupling to x_B, the load, the output rows
            R = np.concatenate(
                [ZXB, np.broadcast_to(f[X][None, :, None], (w.shape[0], X.size, 1)) + 0j], axis=2
            )
            R = np.concatenate(
                [R, np.broadcast_to(C[:, X].T[None], (w.shape[0], X.size, C.shape[0]))], axis=2
            )
            Sk = Zkk - (Zki / zi[:, None, :]) @ Zki.transpose(0, 2, 1)
            rk = R[:, :nk] - Zki @ (R[:, nk:] / zi[:, :, None])
            yk = np.linalg.solve(Sk, rk)
            yi = (R[:, nk:] - Zki.transpose(0, 2, 1) @ yk) / zi[:, :, None]
            Y = np.concatenate([yk, yi], axis=1)  # Z_XX⁻¹ R
            YB, yf, YC = Y[:, :, :12], Y[:, :, 12], Y[:, :, 13:]
            ZBX = ZXB.transpose(0, 2, 1)
            return {
                "S": ZBB - ZBX @ YB,
                "g": f[B][None] - (ZBX @ yf[..., None])[..., 0],
                # C_X Z_XX⁻¹ = (Z_XX⁻¹ C_Xᵀ)ᵀ: Z is symmetric
                "o0": (YC.transpose(0, 2, 1) @ f[X][None, :, None])[..., 0],
                "ob": C[:, B][None] - YC.transpose(0, 2, 1) @ ZXB,
            }

        with one_blas_thread():  # the chunks on the solver's threads, one BLAS thread each
            chunks = on_solver_threads(chunk, range(0, w_all.size, step))
        res = {k: np.concatenate([c[k] for c in chunks]) for k in ("S", "g", "o0", "ob")}
        if len(self._rest_memo) > 8:
            self._rest_memo.clear()
        self._rest_memo[key] = res
        return res

    # ---- the joint, once per design --------------------------------------------------------

    def joint(self, theta: np.ndarray, damping=None, order: int = 2) -> dict:
        """The joint condensed onto x_B for designs ``theta`` (n, regions) (Pa): module docstring, 3.

        Returns
        -------
        dict: ``J0``, ``J1``, ``JM`` (n, 12, 12) complex with the joint's Z ≈ J0 + iω J1 − ω² JM,
        ``C2``, ``C3``, ``C4`` (n, 12, 12) the dynamic correction ω² C2 + iω³ C3 − ω⁴ C4 (zero
        with ``order`` = 1), ``Wz``, ``GP1``, ``GPM`` (n, m, 12): z = (Wz − iω GP1 + ω² GPM) x_B.
        """
        coef = part_coefficients(damping, self)
        js = np.ix_(self.jset, self.jset)
        Kr = np.stack([self.parts_k[r][js] for r in self.regions])  # (6, N, N)
        eta = np.array([coef["eta"][r] for r in self.regions])
        b = np.array([coef["b_s"][r] for r in self.regions])
        s = np.asarray(theta, float) / self.arrays["region_e0_pa"][None]
        N = self.jset.size
        A0 = ((s * (1 + 1j * eta)) @ Kr.reshape(len(self.regions), -1)).reshape(-1, N, N)
        A1 = ((s * b) @ Kr.reshape(len(self.regions), -1)).reshape(-1, N, N) + 0j
        A1 += sum(coef["a_per_s"][r] * self.parts_m[r][js] for r in self.regions)
        M = sum(self.parts_m[r][js] for r in self.regions)
        M = np.broadcast_to(M, A0.shape) + 0j
        z = slice(12, N)
        lu_A = A0[:, z, z]
        with one_blas_thread():
            Wz = -np.linalg.solve(lu_A, A0[:, z, :12])
            tr = lambda X: X.transpose(0, 2, 1)  # noqa: E731

            def wxw(X):  # Wᵀ X W
                XW_B = X[:, :12, :12] + X[:, :12, z] @ Wz
                XW_z = X[:, z, :12] + X[:, z, z] @ Wz
                return XW_B + tr(Wz) @ XW_z

            J0 = A0[:, :12, :12] + A0[:, :12, z] @ Wz  # the complex Schur complement
            J1, JM = wxw(A1), wxw(M)
            P1 = A1[:, z, :12] + A1[:, z, z] @ Wz
            PM = M[:, z, :12] + M[:, z, z] @ Wz
            if order >= 2 and N > 12:
                G = np.linalg.solve(lu_A, np.concatenate([P1, PM], axis=2))
                GP1, GPM = G[..., :12], G[..., 12:]
                C2 = tr(P1) @ GP1
                C3 = tr(P1) @ GPM + tr(PM) @ GP1
                C4 = tr(PM) @ GPM
            else:
                GP1 = GPM = np.zeros_like(Wz)
                C2 = C3 = C4 = np.zeros_like(J0)
        return {"J0": J0, "J1": J1, "JM": JM, "C2": C2, "C3": C3, "C4": C4, "Wz": Wz, "GP1": GP1, "GPM": GPM}

    # ---- responses -------------------------------------------------------------------------

    def _solve(self, rest, jt, w, sel=slice(None)):
        """x_B (n_d, n_f, 12) for joint terms ``jt`` (designs) and the rest (frequencies)."""
        iw = 1j * w[None, :, None, None]
        w2 = (w**2)[None, :, None, None]
        Z = (
            rest["S"][None]
            + jt["J0"][sel][:, None]
            + iw * jt["J1"][sel][:, None]
            - w2 * jt["JM"][sel][:, None]
            + w2 * jt["C2"][sel][:, None]
            + iw * w2 * jt["C3"][sel][:, None]
            - w2 * w2 * jt["C4"][sel][:, None]
        )
        g = np.broadcast_to(rest["g"][None, :, :, None], Z.shape[:3] + (1,))
        return np.linalg.solve(Z, g)[..., 0]

    def _hv_rows(self, rest):
        """Rows (n_f, 12) and offsets (n_f,) of the stapes's displacement along the piston direction."""
        p = self.arrays["piston_direction"]
        return np.einsum("k,fkj->fj", p, rest["ob"][:, 3:6]), rest["o0"][:, 3:6] @ p

    def rigid(self, freq_hz, damping=None, cavities: str = DEFAULT_CAVITIES) -> np.ndarray:
        """H_V (n_f,) of the rigid connection (m/s per Pa): x_B = G x_body (``rigid_map``)."""
        freqs = check_frequencies(freq_hz)
        rest = self.rest(freqs, damping)
        L = self.arrays["rigid_map"]
        Zr = L.T @ rest["S"] @ L
        x = L @ np.linalg.solve(Zr, (rest["g"] @ L)[..., None])[..., 0].T  # (12, n_f)
        rows, off = self._hv_rows(rest)
        hv = 2j * np.pi * freqs * (off + np.einsum("fj,jf->f", rows, x))
        if check_cavities(cavities) != "open":
            hv = hv * cavity_factor(
                freqs, rest["o0"][:, 11] + np.einsum("fj,jf->f", rest["ob"][:, 11], x), cavities
            )
        return hv

    def batch(self, freq_hz, designs, damping=None, order: int = 2, cavities: str = DEFAULT_CAVITIES) -> dict:
        """H_V and ΔH_V for many designs × many frequencies (vectorised).

        Parameters
        ----------
        freq_hz : (n_f,) frequencies (Hz)
        designs : (n, 5) ranged moduli (Pa, :data:`isj.design_space.RANGED` order), a
            :class:`isj.design.Materials` or a list of them; inside :attr:`space`
        damping : :class:`isj.damping.Damping`, a preset name or None (published)
        order : 2 with the joint's dynamic correction, 1 the quasi-static condensation alone
        cavities : "open" or "intact" (:mod:`isj.cavities`: every output times
            1 / (1 + K_cav X_U), X_U the drum's volume displacement), the rigid connection too

        Returns
        -------
        dict: ``freq_hz``; ``h_v`` (n, n_f) complex (m/s per Pa); ``h_v_rigid`` (n_f,);
        ``delta_h_v`` (n, n_f) complex; ``delta_db``, ``delta_deg`` (n, n_f); ``h_v_db``
        (dB re 1 m/s/Pa) and ``h_v_deg``.
        """
        freqs = check_frequencies(freq_hz)
        theta = region_moduli(designs, self.space, self.regions)
        rest = self.rest(freqs, damping)
        rows, off = self._hv_rows(rest)
        w = 2 * np.pi * freqs
        hv = np.empty((theta.shape[0], freqs.size), complex)
        intact = check_cavities(cavities) != "open"

        def block(i: int) -> None:  # designs i to i + BLOCK: the same arithmetic on any thread
            jt = self.joint(theta[i : i + BLOCK], damping, order)
            x = self._solve(rest, jt, w)
            hv[i : i + BLOCK] = 1j * w * (off[None] + np.einsum("fj,dfj->df", rows, x))
            if intact:  # the pressure acts on the drum only: the volume has no part on z
                vol = rest["o0"][None, :, 11] + np.einsum("fj,dfj->df", rest["ob"][:, 11], x)
                hv[i : i + BLOCK] *= cavity_factor(freqs, vol, cavities)

        # blocks on every core, each with one BLAS thread (numpy lets go of the GIL in its solves
        # and products): a block's numbers do not depend on which thread or how many computed it
        with one_blas_thread():
            on_solver_threads(block, range(0, theta.shape[0], BLOCK))  # each fills its rows of hv
        hr = self.rigid(freqs, damping, cavities)
        d = hv / hr[None]
        return {
            "freq_hz": freqs,
            "h_v": hv,
            "h_v_rigid": hr,
            "delta_h_v": d,
            "delta_db": 20 * np.log10(np.abs(d)),
            "delta_deg": np.degrees(np.angle(d)),
            "h_v_db": 20 * np.log10(np.abs(hv)),
            "h_v_deg": np.degrees(np.angle(hv)),
        }

    def _outputs(self, freqs, theta, damping, joint: str, order: int):
        """(n_f, 11) output rows' values for one design (theta (1, regions))."""
        rest = self.rest(freqs, damping)
        w = 2 * np.pi * freqs
        Cz = self._rows()[:, self.jz]
        if joint == "full":  # the projected joint's interior kept: one (12 + m) solve a frequency
            coef = part_coefficients(damping, self)
            js = np.ix_(self.jset, self.jset)
            s = theta[0] / self.arrays["region_e0_pa"]
            A0 = sum(
                si * (1 + 1j * coef["eta"][r]) * self.parts_k[r][js]
                for si, r in zip(s, self.regions, strict=True)
            )
            A1 = sum(si * coef["b_s"][r] * self.parts_k[r][js] for si, r in zip(s, self.regions, strict=True))
            A1 = A1 + sum(coef["a_per_s"][r] * self.parts_m[r][js] for r in self.regions)
            M = sum(self.parts_m[r][js] for r in self.regions)
            Z = A0[None] + 1j * w[:, None, None] * A1[None] - (w**2)[:, None, None] * M[None] + 0j
            Z[:, :12, :12] += rest["S"]
            rhs = np.zeros((freqs.size, self.jset.size), complex)
            rhs[:, :12] = rest["g"]
            y = np.linalg.solve(Z, rhs[..., None])[..., 0]
            xb, z = y[:, :12], y[:, 12:]
        else:
            jt = self.joint(theta, damping, order)
            xb = self._solve(rest, jt, w)[0]
            Wf = jt["Wz"][0][None] - 1j * w[:, None, None] * jt["GP1"][0][None]
            Wf = Wf + (w**2)[:, None, None] * jt["GPM"][0][None]
            z = np.einsum("fmj,fj->fm", Wf, xb)
        return rest["o0"] + np.einsum("fkj,fj->fk", rest["ob"], xb) + z @ Cz.T

    def covers(self, materials: Materials) -> bool:
        """Whether this fast ear answers for ``materials``: its ranged moduli inside :attr:`space`
        and everything else (ν, the incus's modulus, the densities) the reference design's."""
        reference = self.space.materials(self.arrays["snapshot_designs_pa"][0])
        ranged = {k: getattr(materials, k) for k in RANGED}
        if materials != reference.replace(**ranged):
            return False
        return bool(self.space.contains([ranged])[0])

    def drum_volume_m3(self, freq_hz, materials: Materials | None = None, damping=None) -> np.ndarray:
        """The drum's net volume displacement per Pa of ear-canal pressure (m³/Pa, complex, open
        cavities), as :meth:`fem.ear.reduced_ear.ReducedEar.drum_volume_m3`."""
        freqs = check_frequencies(freq_hz)
        theta = region_moduli(materials or Materials(), self.space, self.regions)
        return self._outputs(freqs, theta, damping, "condensed", 2)[:, 11]

    def static(self, materials: Materials | None = None) -> dict:
        """Undamped static response per Pa of one design (exact for a snapshot design, module
        docstring): ``umbo_vector`` (3,), ``footplate`` (3,), ``fit`` (3,), ``alpha``, ``beta``."""
        theta = region_moduli(materials or Materials(), self.space, self.regions)
        out = self._outputs(np.array([0.0]), theta, "undamped", "condensed", 1)[0].real
        return {
            "umbo_vector": out[0:3],
            "footplate": out[3:6],
            "fit": out[6:9],
            "alpha": out[9],
            "beta": out[10],
        }

    def frequency_response(
        self,
        freq_hz,
        materials: Materials | None = None,
        damping=None,
        joint: str = "condensed",
        order: int = 2,
        cavities: str = DEFAULT_CAVITIES,
    ):
        """One design's response per Pa (:data:`OUTPUTS`, :data:`UNITS`), an
        :class:`isj.responses.FrequencyResponse`.

        H_V = ``stapes_velocity_m_s``: the footplate centre's velocity along the piston direction;
        the umbo's along its static direction (as :meth:`fem.ear.reduced_ear.ReducedEar.frequency_response`);
        both displacements; α and β; ``delta_h_v`` = H_V / H_V,rigid (complex).

        ``joint``: ``"condensed"`` (the fast path, :meth:`batch`'s) or ``"full"`` (the projected
        joint's interior solved with the rest at each frequency: the reference the condensation
        is checked against). ``cavities``: as :meth:`batch`.
        """
        from isj.responses import FrequencyResponse

        if joint not in ("condensed", "full"):
            raise InvalidParameter(f"joint = {joint!r}: must be 'condensed' or 'full'")
        freqs = check_frequencies(freq_hz)
        materials = materials or Materials()
        theta = region_moduli(materials, self.space, self.regions)
        o = self._outputs(freqs, theta, damping, joint, order)
        if check_cavities(cavities) != "open":
            o = o * cavity_factor(freqs, o[:, 11], cavities)[:, None]
        s = self.static(materials)
        d_umbo = s["umbo_vector"] / np.linalg.norm(s["umbo_vector"])
        iw = 2j * np.pi * freqs
        x_st = o[:, 3:6] @ self.arrays["piston_direction"]
        x_um = o[:, 0:3] @ d_umbo
        hv = iw * x_st
        cols = [hv, iw * x_um, x_st, x_um, o[:, 9], o[:, 10], hv / self.rigid(freqs, damping, cavities)]
        return FrequencyResponse(freqs, np.column_stack(cols), OUTPUTS, UNITS)

    # ---- storage ---------------------------------------------------------------------------

    def save(self, path: str | Path) -> None:
        meta = self.meta | {"format": FAST_EAR_FORMAT_VERSION, "space": self.space.to_record()}
        write_npz_entry(path, self.arrays | {"meta_json": np.array(json.dumps(meta))})

    @classmethod
    def load(cls, path: str | Path) -> FastEar:
        """Read an entry written by :meth:`save`; :class:`DamagedEntry` if it cannot be trusted."""
        arrays, _ = read_npz_entry(path)
        try:
            meta = json.loads(str(arrays.pop("meta_json")))
            if meta.get("format") != FAST_EAR_FORMAT_VERSION:
                raise DamagedEntry(f"format {meta.get('format')} != {FAST_EAR_FORMAT_VERSION}")
            spc = meta.pop("space")
            space = DesignSpace.from_record(spc)
        except (KeyError, TypeError, ValueError) as exc:
            raise DamagedEntry(f"{type(exc).__name__}: {exc}") from exc
        return cls(arrays, space, meta)


def _modal_projection(level1, V, info, model) -> tuple[dict, np.ndarray, np.ndarray]:
    """(parts, load, output rows) on the shells' basis V, each shell's interior made modal (as
    :func:`fem.ear.reduced_ear.reduced_ear`) and every part symmetric to rounding."""
    groups = _project(level1, V)
    load = V.T @ level1.load
    rows = level1.restrict(output_rows(model)) @ V
    modal_interiors(groups, load, rows, info["interior"])
    for g in groups.values():
        for name, P in g.items():
            g[name] = 0.5 * (P + P.T)
    return groups, load, rows


def _joint_columns(V, level1, m: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The reduced coordinates that are x_B's and z's level-1 coordinates (each kept as a unit
    column among the first ``k``): (jb, jz)."""

    def column_of(pos):
        c = np.argmax(np.abs(V[pos, :k]), axis=1)
        if not np.allclose(V[pos, c], 1.0) or not np.allclose(np.abs(V[pos]).sum(axis=1), 1.0):
            raise RuntimeError("fast ear: a joint coordinate is not kept by the shells' basis")
        return c

    return column_of(level1.b), column_of(level1.R.size + np.arange(m))


def _check_structure(groups, joint_regions, jb, jz, k: int) -> None:
    """The structure the fast ear's algebra relies on: the shells' modal coordinates uncoupled,
    the joint's parts acting on x_B and z only, the rest of the ear never on z."""
    off = max(
        np.abs(P[k:, k:] - np.diag(np.diagonal(P[k:, k:]))).max(initial=0.0) / max(abs(P).max(), 1e-300)
        for g in groups.values()
        for P in g.values()
    )
    if off > 1e-8:
        raise RuntimeError(f"fast ear: the shells' modal coordinates are coupled ({off:.2g})")
    joint = np.concatenate([jb, jz])
    for g in groups.values():
        for name, P in g.items():
            if name in joint_regions:
                rest = np.setdiff1d(np.arange(P.shape[0]), joint)
                if np.abs(P[rest]).max(initial=0.0) > 1e-10 * np.abs(P).max():
                    raise RuntimeError(f"fast ear: the joint part {name} acts outside the joint")
            elif np.abs(P[jz]).max(initial=0.0) > 1e-10 * np.abs(P).max():
                raise RuntimeError(f"fast ear: the part {name} acts on the joint's interior")


def build_fast_ear(
    model,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
    fmax_hz: float = 20e3,
    space: DesignSpace | None = None,
    designs_pa: np.ndarray | None = None,
    pod_tol: float = DEFAULT_POD_TOL,
    n_shifts: int | None = None,
    solver: str = "auto",
) -> FastEar:
    """Build the fast ear of ``model`` (a :class:`fem.ear.middle_ear.MiddleEarModel` with its joint
    model inside) for responses up to ``fmax_hz`` (Hz); no cache (:func:`fast_ear` caches).

    Parameters
    ----------
    model : the FE ear (geometry, meshes) the fast ear reduces
    ear_materials, masses : the ear's drum, footplate and spring constants, masses (defaults)
    fmax_hz : highest frequency of the shells' basis (Hz)
    space : the domain of the joint's moduli (default: the calibrated domain, ν and the incus fixed)
    designs_pa : (n, 5) snapshot designs (default :func:`snapshot_designs`); the first is the
        reference, whose static condensation is Ψ₀
    pod_tol : relative singular value the joint basis keeps (0: all, no truncation)
    n_shifts : Krylov shifts of the shells (:func:`fem.ear.reduced_ear.shell_basis`)
    solver : sparse solver backend for the snapshots
    """
    _check_build_inputs(model, fmax_hz, pod_tol)
    t0 = time.perf_counter()
    space = space or DesignSpace()
    designs = snapshot_designs(space) if designs_pa is None else space.check(designs_pa)
    reference = space.materials(designs[0])
    parts = ear_parts(model, reference, ear_materials, masses)
    t1 = time.perf_counter()
    psi, phi, jinfo = joint_basis(parts, model, designs, space, reference, pod_tol, solver)
    t2 = time.perf_counter()
    level1 = condensed_ear(parts, model, psi, phi)
    V, info = shell_basis(level1, fmax_hz, n_shifts)
    t3 = time.perf_counter()
    groups, load, rows = _modal_projection(level1, V, info, model)
    k = info["kept_dofs"]
    jb, jz = _joint_columns(V, level1, phi.shape[1], k)
    kr = np.setdiff1d(np.arange(k), np.concatenate([jb, jz]))
    ii = np.arange(k, V.shape[1])
    _check_structure(groups, model.joint.regions, jb, jz, k)
    index = {"jb": jb, "jz": jz, "kr": kr, "ii": ii}
    arrays = _fast_ear_arrays(model, parts, groups, load, rows, index, reference, designs)
    t4 = time.perf_counter()
    meta = {
        "regions": list(model.joint.regions),
        "fmax_hz": float(fmax_hz),
        "n_fe_dofs": int(model.n_dofs),
        "n_dofs": int(load.size),
        "n_kept": int(k),
        "joint": {k_: v for k_, v in jinfo.items() if k_ != "seconds"},
        "shells": {k_: v for k_, v in info.items() if k_ not in ("seconds", "interior")},
        "timings_s": {
            "parts": t1 - t0,
            "joint_basis": t2 - t1,
            "shells": t3 - t2,
            "project": t4 - t3,
            "total": t4 - t0,
        },
    }
    return FastEar(arrays, space, meta)


def _check_build_inputs(model, fmax_hz: float, pod_tol: float) -> None:
    """The ear must hold its joint model; f_max finite and positive, the POD tolerance in [0, 1)."""
    if model.joint is None:
        raise InvalidParameter(
            "model: the fast ear needs the joint model inside (joint=None is the rigid ear)"
        )
    if not (np.isfinite(fmax_hz) and fmax_hz > 0):
        raise InvalidParameter(f"fmax_hz = {fmax_hz!r} Hz: must be a finite number > 0")
    if not (np.isfinite(pod_tol) and 0 <= pod_tol < 1):
        raise InvalidParameter(f"pod_tol = {pod_tol!r}: must lie in [0, 1)")


def _fast_ear_arrays(model, parts, groups: dict, load, rows, index: dict, reference, designs) -> dict:
    """What a fast ear stores: its parts by group, in the order they are summed (which decides
    the last bits), the load and output rows, the coordinates' index sets ``index`` (jb, jz, kr,
    ii) and the data its outputs need."""
    g_ = model.geometry
    arrays = {f"k:{n}": P for n, P in groups["stiffness"].items()}
    arrays |= {f"m:{n}": P for n, P in groups["mass"].items()}
    arrays |= {f"d:{n}": P for n, P in groups["dashpots"].items()}
    arrays |= {"load": load, "rows": rows, **index}
    arrays |= {
        "region_e0_pa": np.array([reference.youngs(r) for r in model.joint.regions]),
        "piston_direction": np.asarray(g_.piston_direction, float),
        "footplate_area_m2": np.array(parts.footplate_area_m2),
        "rigid_map": np.vstack(
            [np.eye(6), rigid_body_modes(np.asarray(g_.stapes_head_m)[None], g_.body_reference_m)]
        ),
        "snapshot_designs_pa": designs,
    }
    return arrays


def _code_digest() -> dict:
    # the results versions of the FE ear (docs/developer/cache-keys.md), not the code's text
    from isj.results_version import versions

    return versions("ear")


def cache_key(model, ear_materials, masses, settings: dict, joint=None) -> str:
    """sha256 (hex) of everything a fast ear depends on: meshes, geometry, ear data, settings, code.

    ``joint``: a joint model to key in place of ``model``'s own (the key of the ear with
    ``model``'s drum, footplate and anatomy around that joint, without building that ear).
    """
    joint = model.joint if joint is None else joint
    h = hashlib.sha256()
    for a in (model.drum.nodes_m, model.drum.triangles, model.footplate.nodes_m, model.footplate.triangles):
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}|{a.shape}|".encode() + a.tobytes())
    payload = {
        "meshes": h.hexdigest(),
        "joint_mesh": joint.mesh.content_hash(),
        "order": int(getattr(joint, "order", 0)),
        "sliding": str(getattr(joint, "joint", "bonded")),
        "geometry": dataclasses.asdict(model.geometry),
        "ear_materials": dataclasses.asdict(ear_materials or EarMaterials()),
        "masses": dataclasses.asdict(masses or EarMasses()),
        "settings": settings,
        "versions": _code_digest(),
        "format": FAST_EAR_FORMAT_VERSION,
    }
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()


def fast_ear(
    model,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
    fmax_hz: float = 20e3,
    pod_tol: float = DEFAULT_POD_TOL,
    cache: bool = True,
    shipped: bool = True,
    **settings,
) -> FastEar:
    """The fast ear of ``model``: from the cache (``$ISJ_FE_CACHE_DIR/fast_ear``) if there, else
    shipped or built (:func:`build_fast_ear`, ``settings`` its other keywords), and stored.

    On a cache miss the fast ear shipped with isj under the same full key (the default report's,
    :data:`SHIPPED_DIR`) is taken when ``shipped`` is true: a second instead of about a minute,
    the arrays of a build on the machine that made it.
    """
    keyed = _keyed_settings(fmax_hz, pod_tol, settings)
    key = cache_key(model, ear_materials, masses, keyed)
    out = _stored(key, cache, shipped)
    if out is None:
        out = build_fast_ear(model, ear_materials, masses, fmax_hz, pod_tol=pod_tol, **settings)
        if cache:
            _store(key, out)
    return out


def stored_fast_ear(
    model,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
    fmax_hz: float = 20e3,
    pod_tol: float = DEFAULT_POD_TOL,
    joint=None,
) -> FastEar | None:
    """The fast ear :func:`fast_ear` gives these arguments when it is cached or shipped, else None
    (nothing is built).

    ``joint``: the fast ear of the ear with ``model``'s drum, footplate and anatomy around this
    joint model instead (the report's sliding joint: its fast ear is shipped, and its whole ear,
    2–3 s to build and hundreds of MB, is then not needed).
    """
    key = cache_key(model, ear_materials, masses, _keyed_settings(fmax_hz, pod_tol, {}), joint=joint)
    return _stored(key, cache=True, shipped=True)


def _keyed_settings(fmax_hz, pod_tol, settings: dict) -> dict:
    keyed = {"fmax_hz": float(fmax_hz), "pod_tol": float(pod_tol)}
    return keyed | {
        k: (np.asarray(v).tolist() if v is not None else None) for k, v in settings.items() if k != "solver"
    }


def _cache_path(key: str) -> Path:
    return fast_ear_cache_dir() / f"fast-ear-{key[:32]}.npz"


def _stored(key: str, cache: bool, shipped: bool) -> FastEar | None:
    """The cache's fast ear under ``key`` (a damaged one is reported and dropped), else the shipped
    one, which the cache then keeps; None where neither is."""
    path = _cache_path(key)
    if cache and path.exists():
        try:
            return FastEar.load(path)
        except DamagedEntry as exc:
            discard(path, "fast ear", str(exc), stacklevel=3)
    out = load_shipped(key) if shipped else None
    if out is not None and cache:
        _store(key, out)
    return out


def _store(key: str, fast: FastEar) -> None:
    path = _cache_path(key)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fast.save(path)
    except OSError as exc:
        warnings.warn(f"could not write fast-ear cache entry {path}: {exc}", CacheWarning, stacklevel=3)


def cache_key_of(
    model,
    ear_materials: EarMaterials | None = None,
    masses: EarMasses | None = None,
    fmax_hz: float = 20e3,
    pod_tol: float = DEFAULT_POD_TOL,
) -> str:
    """The cache key :func:`fast_ear` gives these arguments (no other settings)."""
    return cache_key(model, ear_materials, masses, {"fmax_hz": float(fmax_hz), "pod_tol": float(pod_tol)})


def _pack_symmetric(name: str, a: np.ndarray) -> dict:
    """A square part as the rows of its upper triangle (CSR) when it is symmetric bit for bit,
    else all of it: most of a part is zero, and the parts are symmetric (the ear's are)."""
    sym = bool(np.array_equal(a, a.T))
    m = sp.csr_matrix(np.triu(a) if sym else a)
    if np.count_nonzero(np.signbit(a) & (a == 0)):  # −0.0 would come back as +0.0
        return {name: a}
    return {
        f"{name}|data": m.data,
        f"{name}|indices": m.indices.astype(np.int32),
        f"{name}|indptr": m.indptr.astype(np.int64),
        f"{name}|shape": np.array(a.shape, np.int64),
        f"{name}|symmetric": np.array(sym),
    }


def _unpack_symmetric(arrays: dict) -> dict:
    """The arrays :func:`_pack_symmetric` packed, as they were and in the order they were stored:
    the parts are summed in that order (:meth:`FastEar.joint`), so it decides the last bits."""
    out = {}
    for key in arrays:
        name = key.split("|")[0]
        if name in out:
            continue
        if name == key:
            out[name] = arrays[key]
            continue
        m = sp.csr_matrix(
            (arrays[f"{name}|data"], arrays[f"{name}|indices"], arrays[f"{name}|indptr"]),
            shape=tuple(arrays[f"{name}|shape"]),
        )
        a = m.toarray()
        if bool(arrays[f"{name}|symmetric"]):
            a = a + np.triu(a, 1).T  # the lower triangle is zero: each entry is one number, exact
        out[name] = a
    return out


def ship(ear: FastEar, key: str, folder: Path | None = None) -> Path:
    """Store a built fast ear under its cache ``key`` for :func:`load_shipped`; return the file.

    The m × m parts are mostly zero and symmetric: they are kept as their upper triangles' nonzeros
    (compressed, checksummed), about 1/50 of the cache entry.
    """
    packed = {}
    for k, v in ear.arrays.items():
        packed |= _pack_symmetric(k, v) if k[:2] in ("k:", "m:", "d:") else {k: v}
    meta = ear.meta | {"format": FAST_EAR_FORMAT_VERSION, "space": ear.space.to_record(), "key": key}
    path = Path(folder or SHIPPED_DIR) / f"fast-ear-{key[:32]}.npz"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_npz_entry(path, packed | {"meta_json": np.array(canonical_json(meta))}, compressed=True)
    return path


def load_shipped(key: str, folder: Path | None = None) -> FastEar | None:
    """The fast ear shipped under cache ``key``; None if none ships.

    A file is taken only when the full key it records is ``key``: the same meshes (contents),
    geometry, ear materials, masses, settings and results versions. A damaged one is reported
    (:class:`isj.errors.CacheWarning`) and passed over, so the fast ear is built.
    """
    path = Path(folder or SHIPPED_DIR) / f"fast-ear-{key[:32]}.npz"
    if not path.exists():
        return None
    try:
        arrays, _ = read_npz_entry(path)
        meta = json.loads(str(arrays.pop("meta_json")))
        if meta.pop("key") != key or meta.pop("format") != FAST_EAR_FORMAT_VERSION:
            return None
        space = DesignSpace.from_record(meta.pop("space"))
        arrays = _unpack_symmetric(arrays)
    except (DamagedEntry, KeyError, TypeError, ValueError) as exc:
        warnings.warn(f"shipped fast ear {path} is damaged ({exc}); building it", CacheWarning, stacklevel=3)
        return None
    ear = FastEar(arrays, space, meta)
    ear.meta["shipped"] = True
    return ear


def fast_ear_sweep(
    freq_hz,
    materials: Materials | None = None,
    damping=None,
    cavities: str = DEFAULT_CAVITIES,
    model=None,
    ear: FastEar | None = None,
) -> dict:
    """One design's sweep through the fast ear, for ``isj ear sweep``: its response and ΔH_V.

    Parameters
    ----------
    freq_hz : frequencies (Hz), within the fast ear's f_max
    materials : the joint's moduli (default: the base case), inside the calibrated domain
    damping : :class:`isj.damping.Damping`, a preset name or None (published)
    cavities : "open" or "intact"
    model : the FE ear to reduce (default: the default joint mesh, P2, in the default drum)
    ear : a fast ear already built (then ``model`` is not used)

    Returns
    -------
    dict: ``response`` (:meth:`FastEar.frequency_response`), ``columns``, ``units`` and
    ``summary`` of :func:`delta_columns`, ``n_dofs`` and ``n_joint_basis`` of the fast ear.
    """
    freqs = check_frequencies(freq_hz)
    if ear is None:
        if model is None:
            from ..model import PedicleJointModel
            from .middle_ear import MiddleEarModel

            model = MiddleEarModel(joint=PedicleJointModel(order=2, resolution=1.0))
        ear = fast_ear(model)
    if freqs.max() > ear.meta["fmax_hz"] * (1 + 1e-12):
        raise InvalidParameter(
            f"freq_hz = {freqs.max():g} Hz: the fast ear is built up to fmax_hz = {ear.meta['fmax_hz']:g} Hz"
        )
    r = ear.frequency_response(freqs, materials, damping, cavities=cavities)
    hv = r["stapes_velocity_m_s"]
    out = delta_columns(freqs, hv, hv / r["delta_h_v"])
    return {"response": r, **out, "n_dofs": ear.n_dofs, "n_joint_basis": ear.n_joint_basis}


__all__ = [
    "SHIPPED_DIR",
    "stored_fast_ear",
    "cache_key_of",
    "fast_ear_sweep",
    "load_shipped",
    "ship",
    "FastEar",
    "build_fast_ear",
    "fast_ear",
    "joint_basis",
    "snapshot_designs",
]
