"""The eardrum's component modes for the lumped ear (docs/ear.md §5.10): data, assembly, fast response.

The lumped ear (:mod:`lumped.ear`) condenses the drum onto the malleus–incus
body's six dofs (the Guyan part, :class:`lumped.ear.EardrumParameters`) and adds
coordinates for the drum's motion with the manubrium held. With no modes that is
one static shape, the drum's deflection under pressure with the manubrium held.
:class:`DrumModes` adds n fixed-interface modes (Craig–Bampton) and replaces that
shape by the static residual of the n modes, measured on the FE drum by
:func:`fem.ear.drum_modes.drum_modes` (a plain dict, since this package may not
import :mod:`isj.fem`). The reduced drum is then

    K = blockdiag(K_G, A_r²/C_n, ω_j² m_s),
    M = [[M_G, A_r ΨᵀM r̂, √m_s c_jᵀ], [·, m_r A_r², 0], [·, 0, m_s]],
    B = (Ψᵀf, A_r, √m_s b_j),

A_r the ring's outline area (the residual's coordinate is its mean displacement
over A_r, as the one-shape drum's), C_n, m_r, r̂ the residual's compliance, unit-volume
mass and shape, c_j = ΨᵀMφ_j, b_j = φ_jᵀf. Each modal coordinate is scaled to the
generalized mass m_s of the drum's Guyan translation (:func:`mode_scale`), so that it
is a displacement in metres like the body's and the dense solves stay well scaled.

The modes' block of M, K and of every damping term (the drum's η K, b K and a M,
which project onto the same blocks) is diagonal, so :func:`freq_resp` condenses the
modes exactly at each frequency onto the other coordinates (a diagonal Schur
complement, design-independent) and solves only a small system per design: the
cost grows with n, not with n³.

The residual is a coordinate with its own mass (a dynamic residual), as the one-shape drum's w.
Against the FE ear's rigid-joint harmonic solves on the default drum (published damping), 40
modes keep the umbo and the stapes within 1 dB and 10° up to 6.6 kHz; the agreement reaches
about the highest kept mode (the residual as a massless correction, and 20 modes, compared:
docs/history.md).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from importlib import resources

import numpy as np

from isj.errors import InvalidParameter
from isj.validate import check_frequencies

#: The shipped modes: :func:`fem.ear.drum_modes.drum_modes` on the default anatomy and drum mesh.
DEFAULT_DRUM_MODES_FILE = "default_drum_modes.json"


@dataclass(frozen=True)
class DrumModes:
    """The drum's fixed-interface modes and their static residual (SI; module docstring).

    Parameters
    ----------
    freq_hz : (N,) natural frequencies of the drum with the manubrium held (Hz), ascending
    coupling : (N, 6) ΨᵀMφ_j, the mass coupling of each mass-normalised mode with the body's
        unit (u, θ) at ``reference_m`` (kg^½, kg^½·m)
    load_per_pa : (N,) φ_jᵀf, each mode's generalized force per Pa (N·kg^-½/Pa)
    residual_compliance_m3_per_pa : volume displacement per Pa of the static residual of the N
        modes, manubrium held (m³/Pa)
    residual_mass_kg_m4 : that residual's mass scaled to unit volume (kg/m⁴)
    residual_cross_mass : (6,) its mass coupling with the body's (u, θ), unit volume (kg/m², kg/m)
    reference_m : (3,) the body's reference point (m)
    drum_e_pa : eardrum modulus they were measured with (Pa)
    mesh_size_m, density_kg_m3 : the FE drum's element size (m) and density (kg/m³), for information
    """

    freq_hz: tuple
    coupling: tuple
    load_per_pa: tuple
    residual_compliance_m3_per_pa: float
    residual_mass_kg_m4: float
    residual_cross_mass: tuple
    reference_m: tuple
    drum_e_pa: float
    mesh_size_m: float = float("nan")
    density_kg_m3: float = float("nan")

    def __post_init__(self) -> None:
        f = np.asarray(self.freq_hz, dtype=float).reshape(-1)
        n = f.size
        shapes = {"coupling": (n, 6), "load_per_pa": (n,), "residual_cross_mass": (6,), "reference_m": (3,)}
        if not np.all(np.isfinite(f)) or np.any(f <= 0) or np.any(np.diff(f) < 0):
            raise InvalidParameter("freq_hz: must be finite, > 0 and ascending")
        object.__setattr__(self, "freq_hz", tuple(f))
        for name, shape in shapes.items():
            a = np.asarray(getattr(self, name), dtype=float)
            if a.size == 0 and n == 0:
                a = a.reshape(shape)
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise InvalidParameter(f"{name}: must be finite numbers of shape {shape}")
            object.__setattr__(self, name, tuple(map(tuple, a)) if a.ndim == 2 else tuple(a))
        for name in ("residual_compliance_m3_per_pa", "residual_mass_kg_m4", "drum_e_pa"):
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0:
                raise InvalidParameter(f"{name} = {v!r}: must be a finite number > 0")

    @property
    def n_modes(self) -> int:
        return len(self.freq_hz)

    @classmethod
    def from_dict(cls, d: dict) -> DrumModes:
        """From :func:`fem.ear.drum_modes.drum_modes`' dict (extra keys ignored)."""
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in names})

    def truncated(self, n: int) -> DrumModes:
        """The lowest ``n`` modes and their residual, exact: the dropped modes go back into it.

        r_n = r_N + Σ_{j>n} φ_j b_j/ω_j², so C_n = C_N + Σ b_j²/ω_j², r_nᵀMr_n = r_NᵀMr_N +
        Σ b_j²/ω_j⁴ (the modes are M- and K-orthogonal to r_N and to each other) and ΨᵀMr_n =
        ΨᵀMr_N + Σ c_j b_j/ω_j²; sums of positive terms, so nothing cancels.
        """
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 0 <= n <= self.n_modes:
            raise InvalidParameter(f"n = {n!r}: must be an integer in [0, {self.n_modes}]")
        if n == self.n_modes:
            return self
        w2 = (2 * np.pi * np.asarray(self.freq_hz[n:])) ** 2
        b, c = np.asarray(self.load_per_pa[n:]), np.asarray(self.coupling).reshape(-1, 6)[n:]
        C_N = self.residual_compliance_m3_per_pa
        C = C_N + float(np.sum(b**2 / w2))
        # unnormalised residual's mass and cross mass, then scaled to unit volume again
        m = self.residual_mass_kg_m4 * C_N**2 + float(np.sum(b**2 / w2**2))
        cross = np.asarray(self.residual_cross_mass) * C_N + c.T @ (b / w2)
        return dataclasses.replace(
            self,
            freq_hz=self.freq_hz[:n],
            coupling=np.asarray(self.coupling).reshape(-1, 6)[:n],
            load_per_pa=self.load_per_pa[:n],
            residual_compliance_m3_per_pa=C,
            residual_mass_kg_m4=m / C**2,
            residual_cross_mass=cross / C,
        )

    def up_to(self, freq_hz: float) -> DrumModes:
        """The modes at or below ``freq_hz`` (Hz), with their residual (:meth:`truncated`)."""
        return self.truncated(int(np.searchsorted(self.freq_hz, freq_hz, side="right")))

    def with_modulus(self, drum_e_pa: float) -> DrumModes:
        """The same drum with modulus ``drum_e_pa`` (Pa): exact, K ∝ E so ω ∝ √E and C ∝ 1/E."""
        if not np.isfinite(drum_e_pa) or drum_e_pa <= 0:
            raise InvalidParameter(f"drum_e_pa = {drum_e_pa!r} Pa: must be a finite number > 0")
        s = drum_e_pa / self.drum_e_pa
        return dataclasses.replace(
            self,
            freq_hz=np.sqrt(s) * np.asarray(self.freq_hz),
            residual_compliance_m3_per_pa=self.residual_compliance_m3_per_pa / s,
            drum_e_pa=float(drum_e_pa),
        )


def default_drum_modes() -> DrumModes:
    """The shipped modes (default anatomy, E = 20 MPa, 0.125 mm drum mesh, 1200 kg/m³)."""
    ref = resources.files("isj.lumped") / "data" / DEFAULT_DRUM_MODES_FILE
    return DrumModes.from_dict(json.loads(ref.read_text()))


def resolve_modes(drum_modes, drum_e_pa: float, default_drum: bool = True) -> DrumModes | None:
    """``ear_model``'s ``drum_modes``: None (no modes), an int n (the shipped lowest n), or data.

    ``default_drum``: whether the Guyan part is the shipped drum's; the shipped modes belong to it
    only (a drum measured on another mesh or anatomy needs its own :class:`DrumModes`).
    """
    if drum_modes is None:
        return None
    if isinstance(drum_modes, DrumModes):
        modes = drum_modes
    elif isinstance(drum_modes, int | np.integer) and not isinstance(drum_modes, bool):
        if not default_drum:
            raise InvalidParameter(
                f"drum_modes = {drum_modes!r}: the shipped modes belong to the shipped drum; with another "
                "eardrum pass its own DrumModes (fem.ear.drum_modes.drum_modes)"
            )
        modes = default_drum_modes().truncated(int(drum_modes))
    else:
        raise InvalidParameter(
            f"drum_modes = {drum_modes!r}: must be None, a number of modes or a lumped.ear_drum.DrumModes"
        )
    return modes.with_modulus(drum_e_pa)


def mode_scale(guyan_mass) -> float:
    """m_s (kg): the drum's Guyan translational mass, trace(M_G[:3, :3])/3, each mode's generalized mass."""
    return float(np.trace(np.asarray(guyan_mass)[:3, :3]) / 3)


def mode_blocks(modes: DrumModes | None, body_map, first: int, m_s: float):
    """The modal coordinates' share of the drum's K, M and load: (n, n), (n, n), (n,) arrays (SI).

    Modal coordinates ``first`` … ``first + N − 1`` of a model of n coordinates; ``body_map``
    (6, n) the body's (u, θ) per coordinate; coordinate j is φ_j √m_s (generalized mass m_s, kg),
    so its stiffness is ω_j² m_s, its mass coupling with the body √m_s c_j, its load √m_s b_j.
    ``modes`` None: zeros.
    """
    body_map = np.asarray(body_map, dtype=float)
    n = body_map.shape[1]
    K, M, B = np.zeros((n, n)), np.zeros((n, n)), np.zeros(n)
    idx = np.arange(first, first + (0 if modes is None else modes.n_modes))
    if idx.size == 0:
        return K, M, B
    K[idx, idx] = (2 * np.pi * np.asarray(modes.freq_hz)) ** 2 * m_s
    M[idx, idx] = m_s
    cross = np.sqrt(m_s) * (np.asarray(modes.coupling) @ body_map)  # (N, n)
    M[idx, :] += cross
    M[:, idx] += cross.T
    B[idx] = np.sqrt(m_s) * np.asarray(modes.load_per_pa)
    return K, M, B


def _batched(a):
    return a if a.ndim == 3 else a[None]


def freq_resp(system, modal: slice, freq_hz, chunk: int = 2000) -> np.ndarray:
    """C Z(ω)⁻¹ B of ``system`` with the coordinates ``modal`` condensed exactly at each frequency.

    Z = K(1 + iη) + iK_loss + iωE − ω²M partitioned into the other coordinates c and the modes m,
    whose block Z_mm = diag z_j(ω) is diagonal (checked): (Z_cc − Z_cm Z_mm⁻¹ Z_mc) x_c = B_c −
    Z_cm Z_mm⁻¹ B_m, then x_m = Z_mm⁻¹ (B_m − Z_mc x_c). Z_cm = Σ_p s_p(ω) X_p with s = (1, iω, −ω²)
    and X = (K, E, M)_cm, so the Schur complement is Σ_pq s_p s_q (1/z) @ P_pq with P_pq[j] =
    X_p[:, j] Y_q[j, :] formed once: one matrix product over the modes per frequency, then a small
    solve per design. Couplings that are the same for every design (the drum's) are condensed once
    for all designs. Returns what ``system.freq_resp`` does, (n_freq, n_out, n_in) or (n_design,
    n_freq, n_out, n_in), to rounding.
    """
    f = check_frequencies(freq_hz)
    w = 2 * np.pi * f
    batched = system.M.ndim == 3
    M, E, B, C = (_batched(np.asarray(x)) for x in (system.M, system.E, system.B, system.C))
    Kc = system.stiffness()  # (d, n, n) complex
    n = M.shape[-1]
    m_idx = np.arange(n)[modal]
    c_idx = np.setdiff1d(np.arange(n), m_idx)
    nm, nc = m_idx.size, c_idx.size

    def block(A, rows, cols):
        A = A[:, rows[:, None], cols[None, :]]
        return A[:1] if np.all(A == A[:1]) else A  # one for all designs when they share it

    def diagonal(A):
        Amm = block(A, m_idx, m_idx)
        d = np.diagonal(Amm, axis1=-2, axis2=-1)
        if np.any(Amm - d[..., None] * np.eye(nm) != 0):
            raise ValueError("the modal block of the system is not diagonal")
        return d

    k_m, e_m, m_m = diagonal(Kc), diagonal(E), diagonal(M)  # (d', nm)
    # the couplings' terms in (1, iω, −ω²): K, E and M blocks, the zero ones dropped
    terms = [(p, block(A, c_idx, m_idx), block(A, m_idx, c_idx)) for p, A in enumerate((Kc, E, M))]
    terms = [t for t in terms if np.any(t[1] != 0) or np.any(t[2] != 0)]
    B_m = block(B, m_idx, np.arange(B.shape[-1])).astype(complex)  # (d', nm, n_in)

    def outer(X, Y):  # (d', nm, nc·k): X[:, :, j] Y[j, :] for each mode j, designs broadcast
        P = np.swapaxes(X, 1, 2)[:, :, :, None] * Y[:, :, None, :]
        return P.reshape(P.shape[0], nm, -1)

    schur = {(p, q): outer(Xp, Yq) for p, Xp, _ in terms for q, _, Yq in terms}
    load = {p: outer(Xp, B_m) for p, Xp, _ in terms}
    K_cc, E_cc, M_cc = (A[:, c_idx[:, None], c_idx[None, :]] for A in (Kc, E, M))
    B_c = B[:, c_idx].astype(complex)
    C_m = C[:, :, m_idx]
    C_c = C[:, :, c_idx]
    has_cm = np.any(C_m != 0)
    nd = M.shape[0]
    step = max(1, chunk // nd)
    out = np.empty((nd, f.size, C.shape[1], B.shape[-1]), dtype=complex)
    for s0 in range(0, f.size, step):
        ws = w[s0 : s0 + step]
        sv = (np.ones_like(ws, dtype=complex), 1j * ws, -(ws**2) + 0j)  # s_p(ω)
        wf, w2f = ws[None, :, None], (ws**2)[None, :, None]  # (1, f, 1)
        inv_z = 1 / (k_m[:, None] + 1j * wf * e_m[:, None] - w2f * m_m[:, None])  # (d', f, nm)
        Z = K_cc[:, None] + 1j * wf[..., None] * E_cc[:, None] - w2f[..., None] * M_cc[:, None]
        rhs = np.broadcast_to(B_c[:, None], (nd, ws.size) + B_c.shape[1:]).copy()
        for (p, q), P in schur.items():
            Z = Z - (sv[p] * sv[q])[None, :, None, None] * (inv_z @ P).reshape(-1, ws.size, nc, nc)
        for p, P in load.items():
            rhs = rhs - sv[p][None, :, None, None] * (inv_z @ P).reshape(-1, ws.size, nc, B.shape[-1])
        x_c = np.linalg.solve(Z, rhs)
        y = C_c[:, None] @ x_c
        if has_cm:
            Z_mc = sum(sv[p][None, :, None, None] * Yp[:, None] for p, _, Yp in terms)
            x_m = (B_m[:, None] - Z_mc @ x_c) * inv_z[..., None]
            y = y + C_m[:, None] @ x_m
        out[:, s0 : s0 + step] = y
    return out if batched else out[0]
