"""``isj ear sweep`` as one library call: the lumped ear over a band, checked against the FE ear.

:func:`run_ear_sweep` sweeps the lumped ear (:func:`isj.studies.sweeps.ear_sweep`), solves the
FE whole ear statically (the lumped sweep's 0 Hz limit is compared with it) and harmonically
at a few frequencies inside the band, and returns everything a caller writes or prints, with
the summary ``isj ear sweep`` writes to ``ear_sweep.json``. The caller checks the inputs before
it runs (the command line in :mod:`isj._cli.sweep`); nothing is written here.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from isj.design import Materials

from .sweeps import EarSweep, ear_sweep


def _pair(z) -> list[float]:
    return [float(z.real), float(z.imag)]


@dataclass(frozen=True)
class EarSweepRun:
    """What :func:`run_ear_sweep` computed.

    Attributes
    ----------
    sweep : isj.studies.sweeps.EarSweep
        The lumped ear's response per Pa.
    fe_static : dict
        The FE ear's static outputs per Pa: ``umbo_m``, ``stapes_m`` (m/Pa), ``alpha_rad``,
        ``beta_rad`` (rad/Pa; None with a rigid joint).
    static_errors : dict
        |lumped static / FE static − 1| per output.
    check : dict
        The static check as written (the FE values marked at the lowest frequency).
    fe_checks : list of dict
        Per harmonic check frequency: FE and lumped outputs (real, imaginary), the relative
        errors and whether it passed.
    summary : dict
        The JSON summary of ``ear_sweep.json`` (SI units; timings in s).
    delta : dict
        :func:`isj.responses.delta_columns` of the lumped ear: H_V and ΔH_V against the rigid
        connection of the same lumped ear (dB, degrees).
    """

    sweep: EarSweep
    fe_static: dict
    static_errors: dict
    check: dict
    fe_checks: list = field(default_factory=list)
    summary: dict = field(default_factory=dict)
    delta: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """The static check and every harmonic check within the tolerance."""
        return bool(self.summary["passed"])


def run_ear_sweep(
    calibration,
    freq_hz,
    materials: Materials,
    ear_materials,
    damping,
    fe_freq_hz,
    *,
    rigid_joint: bool = False,
    drum_modes: int = 40,
    tolerance: float = 0.1,
    order: int = 2,
    resolution: float = 1.0,
    check_lumped: Callable[[EarSweep], None] | None = None,
) -> EarSweepRun:
    """The lumped ear over ``freq_hz`` and its FE whole-ear checks, per Pa of ear-canal pressure.

    Parameters
    ----------
    calibration : isj.lumped.artifact.Calibration
        The joint's factors.
    freq_hz : numpy.ndarray
        The sweep's frequencies (Hz).
    materials : Materials
        The joint design (Pa).
    ear_materials : isj.ear.EarMaterials
        The eardrum and springs (Pa, N/m).
    damping : isj.damping.Damping
        The same in the lumped ear and in the FE checks.
    fe_freq_hz : numpy.ndarray
        The FE harmonic check frequencies (Hz); empty for none.
    rigid_joint : bool
        A rigid incus–stapes connection in both models (no α, β).
    drum_modes : int
        The lumped drum's component modes (0: its one static shape).
    tolerance : float
        Largest relative error of the umbo and the stapes, static and at each check.
    order, resolution : int, float
        The FE joint model's element order and mesh resolution.
    check_lumped : callable, optional
        Called with the lumped sweep before any FE model is built (the command line refuses a
        response that is not finite there).
    """
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.model import PedicleJointModel

    t0 = time.perf_counter()
    sw = ear_sweep(
        calibration,
        freq_hz,
        materials,
        ear_materials,
        rigid_joint=rigid_joint,
        damping=damping,
        drum_modes=drum_modes,
    )
    if check_lumped is not None:
        check_lumped(sw)
    delta = lumped_delta(sw, calibration, materials, ear_materials, damping, drum_modes, rigid_joint)
    t1 = time.perf_counter()
    # FE whole-ear static spot check (low frequency)
    joint = None if rigid_joint else PedicleJointModel(order=order, resolution=resolution)
    fe_model = MiddleEarModel(joint=joint)
    fe_vals = _fe_static(fe_model, materials, ear_materials)
    t2 = time.perf_counter()
    check, errors, passed = _static_check(sw, fe_vals, tolerance)
    fe_checks = _harmonic_checks(
        sw, fe_model, fe_freq_hz, materials, ear_materials, damping, tolerance, rigid_joint
    )
    t3 = time.perf_counter()
    head = {"n_freq": int(np.size(freq_hz)), "rigid_joint": bool(rigid_joint), "drum_modes": int(drum_modes)}
    summary = head | _summary(sw, fe_model, damping, delta, check, fe_checks, passed, tolerance)
    summary["timings_s"] = {"lumped": t1 - t0, "fe": t2 - t1, "fe_harmonic": t3 - t2}
    return EarSweepRun(sw, fe_vals, errors, check, fe_checks, summary, delta)


def _fe_static(fe_model, materials, ear_materials) -> dict[str, float]:
    """The FE whole ear's static response per Pa: umbo, stapes piston, α and β."""
    fe = fe_model.static(materials, ear_materials)
    return {
        "umbo_m": fe.umbo_m_per_pa,
        "stapes_m": fe.footplate_piston_m_per_pa,
        "alpha_rad": fe.alpha_rad_per_pa,
        "beta_rad": fe.beta_rad_per_pa,
    }


def _summary(sw, fe_model, damping, delta, check, fe_checks, passed, tolerance) -> dict:
    """The sweep's JSON summary after its size, connection and drum modes: the lumped ear's modes
    and statics, the FE checks, ΔH_V."""
    return {
        "coordinates": list(sw.model.coordinates),
        "natural_freq_hz": [float(v) for v in sw.natural_freq_hz],
        "damping_ratio": [float(v) for v in sw.damping_ratio],
        "damping": damping.to_dict(),
        "static_per_pa": {k: float(sw.static[j]) for j, k in enumerate(sw.outputs)},
        "fe_check": check,
        "fe_checks": fe_checks,
        "fe_n_dofs": fe_model.n_dofs,
        "delta_h_v": delta["summary"] | {"against": "the rigid connection of the same lumped ear"},
        "passed": passed and all(ck["passed"] for ck in fe_checks),
        "tolerance": tolerance,
    }


def lumped_delta(sw, calibration, materials, ear_materials, damping, drum_modes, rigid_joint) -> dict:
    """H_V = iω x_stapes of the lumped sweep ``sw`` and ΔH_V against the rigid connection of the
    same lumped ear (:func:`isj.responses.delta_columns`); with ``rigid_joint`` the sweep is that
    connection, ΔH_V = 1. The lumped coupling carries α and β only, so its ΔH_V misses the joint's
    other compliances (docs/transmission.md)."""
    from isj.responses import delta_columns

    iw = 2j * np.pi * sw.freq_hz
    h_v = iw * sw.response[:, sw.outputs.index("stapes_m")]
    if rigid_joint:
        return delta_columns(sw.freq_hz, h_v, h_v)
    rigid = ear_sweep(
        calibration,
        sw.freq_hz,
        materials,
        ear_materials,
        rigid_joint=True,
        damping=damping,
        drum_modes=drum_modes,
    )
    return delta_columns(sw.freq_hz, h_v, iw * rigid.response[:, rigid.outputs.index("stapes_m")])


def _static_check(sw: EarSweep, fe_vals: dict, tolerance: float) -> tuple[dict, dict, bool]:
    """(check record, relative errors, passed) of the lumped sweep's 0 Hz limit against the FE
    ear's static outputs ``fe_vals``."""
    errors = sw.static_errors(fe_vals)
    passed = max(errors["umbo_m"], errors["stapes_m"]) <= tolerance
    check = {
        "freq_hz": float(sw.freq_hz[0]),
        "compared_with": "lumped static limit (0 Hz); FE values are static, marked at the lowest frequency",
        **{f"fe_{k}": [float(v), 0.0] for k, v in fe_vals.items() if v is not None},
        **{f"lumped_static_{k}": float(sw.static[j]) for j, k in enumerate(sw.outputs)},
        **{f"{k}_rel_error": e for k, e in errors.items()},
        "passed": passed,
    }
    return check, errors, passed


def _harmonic_checks(
    sw, fe_model, fe_freq_hz, materials, ear_materials, damping, tolerance, rigid_joint
) -> list:
    """The FE whole ear's harmonic spot checks inside the band (same masses and damping as the
    lumped ear): per frequency both responses, the relative errors and whether it passed."""
    from isj.fem.ear.dynamics import harmonic

    fe_checks = []
    if not np.size(fe_freq_hz):
        return fe_checks
    keys = sw.outputs if not rigid_joint else sw.outputs[:2]

    def fe_response(f):
        return harmonic(fe_model, f, materials, ear_materials, damping).outputs()

    comp = sw.fe_checks(fe_freq_hz, fe_response, keys)
    ok = comp.passed(tolerance, ("umbo_m", "stapes_m"))
    for i, fr in enumerate(comp.freq_hz):
        fe_checks.append(
            {
                "freq_hz": float(fr),
                **{f"fe_{k}": _pair(comp.fe[i, j]) for j, k in enumerate(keys)},
                **{f"lumped_{k}": _pair(comp.lumped[i, j]) for j, k in enumerate(keys)},
                **{f"{k}_rel_error": e for k, e in comp.errors(i).items()},
                "passed": bool(ok[i]),
            }
        )
    return fe_checks
