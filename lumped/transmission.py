"""What the pedicle and the joint do to sound transmission (docs/transmission.md).

Two questions, answered on the lumped ear with the drum's component modes
(:func:`isj.lumped.ear.ear_model`, docs/ear.md §5.10), microseconds per design and
frequency, and checked against the FE ear by the report and ``benchmarks/transmission.py``:

- :func:`transmission`: the stapes velocity per ear-canal pressure H_V (m/s/Pa) of each
  thesis case and of a rigid incus–stapes connection, and ΔH_V = H_V / H_V,rigid;
- :func:`load_path`: how the ear drives the joint. The ear's dynamic stiffness condensed
  onto the joint's coordinates (α, β) is the joint's own plus the environment's,
  S(ω) = Z_joint(ω) + Z_env(ω), and the pressure becomes a generalised force f₀ (the Thévenin
  equivalent of everything but the joint, exact). With Z_env ≪ Z_joint the joint is
  force-driven, as in the isolated model (β follows the pedicle's modulus); with
  Z_env ≫ Z_joint it is displacement-driven (its angles are set by the ear, and its moduli
  only decide how the imposed motion splits).
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import replace as dataclasses_replace

import numpy as np

from isj.cases import THESIS_CASES
from isj.design import Materials
from isj.errors import InvalidParameter
from isj.validate import check_frequencies

from .ear import LumpedEar
from .model import MODULI

#: The drum's shipped component modes reach 26.4 kHz: all of them, for a band to 20 kHz.
ALL_DRUM_MODES = 300


def _velocity(freq_hz: np.ndarray, x: np.ndarray) -> np.ndarray:
    """v = iω x along the first axis (x per Pa → m/s per Pa)."""
    w = 2j * np.pi * freq_hz
    return w.reshape((-1,) + (1,) * (x.ndim - 1)) * x


@dataclass(frozen=True)
class TransmissionResult:
    """H_V of each case and of the rigid connection, per Pa of ear-canal pressure (SI).

    Attributes
    ----------
    freq_hz : (n_freq,)
    cases : case names (columns)
    stapes_velocity : (n_freq, n_case) complex H_V (m/s/Pa)
    umbo_velocity : (n_freq, n_case) complex umbo velocity per pressure (m/s/Pa)
    alpha_rad, beta_rad : (n_freq, n_case) complex joint and pedicle angles per Pa (rad/Pa)
    rigid_stapes_velocity, rigid_umbo_velocity : (n_freq,) complex, the rigid connection's
    """

    freq_hz: np.ndarray
    cases: tuple[str, ...]
    stapes_velocity: np.ndarray
    umbo_velocity: np.ndarray
    alpha_rad: np.ndarray
    beta_rad: np.ndarray
    rigid_stapes_velocity: np.ndarray
    rigid_umbo_velocity: np.ndarray

    @property
    def delta(self) -> np.ndarray:
        """ΔH_V = H_V / H_V,rigid, (n_freq, n_case) complex."""
        return self.stapes_velocity / self.rigid_stapes_velocity[:, None]

    @property
    def delta_db(self) -> np.ndarray:
        return 20 * np.log10(np.abs(self.delta))

    @property
    def delta_deg(self) -> np.ndarray:
        return np.degrees(np.angle(self.delta))

    @property
    def pedicle_share(self) -> np.ndarray:
        """β / (α + β), complex: the share of the incus-to-stapes relative rotation the pedicle takes."""
        return self.beta_rad / (self.alpha_rad + self.beta_rad)

    def at(self, freq_hz: float) -> int:
        """Index of the frequency nearest ``freq_hz``."""
        return int(np.argmin(np.abs(np.log(self.freq_hz / freq_hz))))

    def to_dict(self) -> dict:
        def ri(a):
            return np.stack([a.real, a.imag], axis=-1).tolist()

        return {
            "freq_hz": self.freq_hz.tolist(),
            "cases": list(self.cases),
            "stapes_velocity_m_s_per_pa_re_im": ri(self.stapes_velocity),
            "umbo_velocity_m_s_per_pa_re_im": ri(self.umbo_velocity),
            "rigid_stapes_velocity_m_s_per_pa_re_im": ri(self.rigid_stapes_velocity),
            "rigid_umbo_velocity_m_s_per_pa_re_im": ri(self.rigid_umbo_velocity),
            "delta_db": self.delta_db.tolist(),
            "delta_deg": self.delta_deg.tolist(),
            "pedicle_share_abs": np.abs(self.pedicle_share).tolist(),
        }


def transmission(
    freq_hz,
    cases=THESIS_CASES,
    *,
    model=None,
    base: Materials | None = None,
    drum_modes: int | None = ALL_DRUM_MODES,
    **ear_options,
) -> TransmissionResult:
    """H_V and ΔH_V of ``cases`` (:class:`isj.cases.ThesisCase`) on the lumped ear.

    Parameters
    ----------
    freq_hz : frequencies (Hz), > 0
    cases : the designs (default the seven thesis cases), each applied to ``base``
    model : :class:`isj.lumped.api.LumpedModel` (default: the shipped calibration)
    base : the moduli the cases change (default :class:`isj.design.Materials`)
    drum_modes : the drum's component modes (default all 300 shipped, to 26.4 kHz)
    **ear_options : :meth:`isj.lumped.api.LumpedModel.ear` options (damping, ear_materials, …),
        the same for the cases and the rigid connection
    """
    from .api import LumpedModel

    f = check_frequencies(freq_hz)
    if np.any(f <= 0):
        raise InvalidParameter("freq_hz: must be > 0 (H_V is a velocity)")
    lm = model or LumpedModel.default()
    base = base or Materials()
    mats = [c.materials(base) for c in cases]
    moduli = {k: np.array([getattr(m, k) for m in mats]) for k in MODULI}
    H = lm.ear(drum_modes=drum_modes, **ear_options, **moduli)._freq_resp(f)  # (n_case, n_freq, 4)
    rigid = lm.ear(rigid_joint=True, drum_modes=drum_modes, **ear_options)._freq_resp(f)
    H = np.moveaxis(H, 0, 1)  # (n_freq, n_case, 4)
    return TransmissionResult(
        freq_hz=f,
        cases=tuple(c.name for c in cases),
        stapes_velocity=_velocity(f, H[..., 1]),
        umbo_velocity=_velocity(f, H[..., 0]),
        alpha_rad=H[..., 2],
        beta_rad=H[..., 3],
        rigid_stapes_velocity=_velocity(f, rigid[:, 1]),
        rigid_umbo_velocity=_velocity(f, rigid[:, 0]),
    )


def _dynamic(ear: LumpedEar, w: float) -> np.ndarray:
    s = ear.system
    return s.stiffness()[0] + 1j * w * s.E - w**2 * s.M


def load_path(ear: LumpedEar, freq_hz=(0.0,)) -> dict:
    """The joint's Thévenin view of the ear at each frequency (one design; SI).

    Returns a dict of arrays over ``freq_hz``:

    - ``q``: (n, 2) the joint's (α, β) per Pa, equal to the full solve's;
    - ``force``: (n, 2) f₀, the generalised force (N·m per Pa) the ear applies with the joint
      held rigid; ``q_force_driven``: (n, 2) Z_joint⁻¹ f₀, the angles if nothing but the joint
      resisted that force (the isolated model's situation);
    - ``k_joint``, ``k_env``: (n,) complex stiffness along the actual motion q,
      q̂ᴴ Z q̂ (N·m/rad), of the joint and of the environment, and ``env_ratio`` = |k_env| / |k_joint|;
    - ``k_joint_beta``, ``k_env_beta``: (n,) the ββ entries (N·m/rad);
    - ``k_env_matrix``: (n, 2, 2) Z_env itself.
    """
    if ear.joint is None:
        raise InvalidParameter("load_path: the ear has a rigid joint; there is no joint to load")
    if ear.batched:
        raise InvalidParameter("load_path: one design only")
    f = check_frequencies(freq_hz)
    j = [ear.coordinates.index("alpha"), ear.coordinates.index("beta")]
    r = [i for i in range(len(ear.coordinates)) if i not in j]
    Kj, Ej, Lj = ear.joint
    B = ear.system.B[:, 0]
    keys = ("q", "force", "q_force_driven", "k_joint", "k_env", "k_joint_beta", "k_env_beta", "k_env_matrix")
    out = {k: [] for k in keys}
    for fi in f:
        w = 2 * np.pi * fi
        D = _dynamic(ear, w)
        X = np.linalg.solve(D[np.ix_(r, r)], np.column_stack([D[np.ix_(r, j)], B[r]]))
        S = D[np.ix_(j, j)] - D[np.ix_(j, r)] @ X[:, :2]
        f0 = B[j] - D[np.ix_(j, r)] @ X[:, 2]
        Zj = Kj + 1j * Lj + 1j * w * Ej
        Ze = S - Zj
        q = np.linalg.solve(S, f0)
        u = q / np.linalg.norm(q)
        out["q"].append(q)
        out["force"].append(f0)
        out["q_force_driven"].append(np.linalg.solve(Zj, f0))
        out["k_joint"].append(u.conj() @ Zj @ u)
        out["k_env"].append(u.conj() @ Ze @ u)
        out["k_joint_beta"].append(Zj[1, 1])
        out["k_env_beta"].append(Ze[1, 1])
        out["k_env_matrix"].append(Ze)
    res = {k: np.array(v) for k, v in out.items()}
    res["freq_hz"] = f
    res["env_ratio"] = np.abs(res["k_env"]) / np.abs(res["k_joint"])
    return res


def pedicle_sensitivity(
    freq_hz,
    *,
    model=None,
    base: Materials | None = None,
    step: float = 0.05,
    drum_modes: int | None = ALL_DRUM_MODES,
    **ear_options,
) -> dict:
    """d ln|y| / d ln E_pedicle of the ear's α, β and H_V, and of the isolated model's α, β.

    Central differences in ln E (E × e^±step) on the lumped ear and on the lumped isolated
    model (:meth:`isj.lumped.api.LumpedModel.static`, a fixed load on the incus). Returns
    ``ear_alpha``, ``ear_beta``, ``ear_stapes`` (n_freq,) and ``isolated_alpha``,
    ``isolated_beta`` (floats).
    """
    from .api import LumpedModel

    f = check_frequencies(freq_hz)
    lm = model or LumpedModel.default()
    base = base or Materials()
    moduli = {k: np.full(2, getattr(base, k)) for k in MODULI}
    moduli["pedicle_e_pa"] = base.pedicle_e_pa * np.exp([-step, step])
    H = lm.ear(drum_modes=drum_modes, **ear_options, **moduli)._freq_resp(f)  # (2, n_freq, 4)
    d = (np.log(np.abs(H[1])) - np.log(np.abs(H[0]))) / (2 * step)
    st = lm.static(**moduli)
    return {
        "freq_hz": f,
        "ear_alpha": d[:, 2],
        "ear_beta": d[:, 3],
        "ear_stapes": d[:, 1],
        "isolated_alpha": float(np.diff(np.log(st.alpha_rad))[0] / (2 * step)),
        "isolated_beta": float(np.diff(np.log(st.beta_rad))[0] / (2 * step)),
    }


def thevenin_sensitivity(
    freq_hz,
    *,
    model=None,
    base: Materials | None = None,
    step: float = 0.05,
    drum_modes: int | None = ALL_DRUM_MODES,
    **ear_options,
) -> dict:
    """β's sensitivity to the pedicle as the Thévenin picture predicts it, ear and force-driven.

    With the environment's Z_env and force f₀ held, a change dZ_joint of the joint's own dynamic
    stiffness (central differences in ln E_pedicle) moves the angles by dq = −S⁻¹ dZ_joint q
    (S = Z_joint + Z_env); held by nothing but the joint (Z_env = 0) by −Z_joint⁻¹ dZ_joint q_f.
    Returns ``ear_beta`` and ``force_driven_beta`` (n_freq,), Re(dβ/β) per unit ln E; the first
    matches :func:`pedicle_sensitivity` where the pedicle's modulus changes only Z_joint (the
    coupling's kinematics move with it too, which the difference measures).
    """
    from .api import LumpedModel

    f = check_frequencies(freq_hz)
    lm = model or LumpedModel.default()
    base = base or Materials()
    ears = [
        lm.ear(
            dataclasses_replace(base, pedicle_e_pa=base.pedicle_e_pa * np.exp(s)),
            drum_modes=drum_modes,
            **ear_options,
        )
        for s in (-step, 0.0, step)
    ]
    lp = load_path(ears[1], f)
    out = {"freq_hz": f, "ear_beta": [], "force_driven_beta": []}
    for i, fi in enumerate(f):
        w = 2 * np.pi * fi
        Z = [K + 1j * L + 1j * w * E for K, E, L in (e.joint for e in ears)]
        dZ = (Z[2] - Z[0]) / (2 * step)
        S = Z[1] + (lp["k_env_matrix"][i])
        q, qf = lp["q"][i], lp["q_force_driven"][i]
        out["ear_beta"].append((-np.linalg.solve(S, dZ @ q)[1] / q[1]).real)
        out["force_driven_beta"].append((-np.linalg.solve(Z[1], dZ @ qf)[1] / qf[1]).real)
    return {k: np.asarray(v) for k, v in out.items()}
