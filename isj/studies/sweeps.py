"""Frequency sweeps of the lumped chain and the lumped ear, checked against FE harmonic solves.

``isj sweep``, ``isj ear sweep`` and the report's sweep section build a lumped
model, sweep it over a band, and compare it with a few FE harmonic solves
inside the band. The sweeps and the comparison live here once; the FE solve
is a callable the caller passes in (``fe_response(freq_hz)`` returning the
complex outputs), so this package still imports without gmsh. The command
line passes a direct solve on its model; the report passes one that goes
through the FE result cache.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from isj.damping import resolve, warn_rayleigh_band
from isj.design import DEFAULT_PRESSURE_PA, REGIONS, Geometry, Materials
from isj.lumped.dynamics import OUTPUTS as CHAIN_OUTPUTS
from isj.lumped.dynamics import SecondOrderModel, chain_model, chain_outputs
from isj.validate import check_band, check_frequencies

#: What an FE harmonic solve hands back: per output name a complex array over the
#: frequencies, or one (n_freq, n_outputs) complex array in the lumped model's output order.
FeResponse = Callable[[np.ndarray], Mapping[str, np.ndarray] | np.ndarray]


def fe_check_frequencies(fmin_hz: float, fmax_hz: float, k: int) -> np.ndarray:
    """``k`` frequencies (Hz) log-spaced strictly inside the band (the ends are left out); empty for 0.

    The ends are left out because the lumped curves are plotted there anyway, and the
    band's top is where the lumped model is least trusted.
    """
    check_band(fmin_hz, fmax_hz)
    if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 0:
        raise ValueError(f"k = {k!r}: must be an integer >= 0")
    return np.geomspace(fmin_hz, fmax_hz, int(k) + 2)[1:-1] if k else np.zeros(0)


@dataclass(frozen=True)
class HarmonicComparison:
    """Lumped and FE complex outputs at the same frequencies.

    Attributes
    ----------
    freq_hz : numpy.ndarray
        Shape (k,), Hz.
    outputs : tuple of str
        Output names, the column order of ``fe`` and ``lumped``.
    fe, lumped : numpy.ndarray
        Shape (k, len(outputs)), complex, SI units of each output.
    """

    freq_hz: np.ndarray
    outputs: tuple[str, ...]
    fe: np.ndarray
    lumped: np.ndarray

    @property
    def rel_error(self) -> np.ndarray:
        """|lumped / FE − 1| (complex: amplitude and phase together), shape (k, n_outputs)."""
        return np.abs(self.lumped / self.fe - 1)

    def errors(self, i: int) -> dict[str, float]:
        """Relative errors at frequency ``i`` by output name."""
        return {k: float(e) for k, e in zip(self.outputs, self.rel_error[i], strict=True)}

    def passed(self, tolerance: float, keys: Sequence[str] | None = None) -> np.ndarray:
        """Per frequency: every error of ``keys`` (default all outputs) <= ``tolerance``, shape (k,)."""
        cols = [self.outputs.index(k) for k in (keys or self.outputs)]
        return np.all(self.rel_error[:, cols] <= tolerance, axis=1)


def compare_harmonic(
    freq_hz,
    outputs: Sequence[str],
    lumped: Callable[[np.ndarray], np.ndarray],
    fe_response: FeResponse,
) -> HarmonicComparison:
    """Evaluate the lumped model and FE at ``freq_hz`` and pair their outputs.

    Parameters
    ----------
    freq_hz : sequence of float
        Frequencies (Hz), at least one.
    outputs : sequence of str
        The outputs compared, a leading part of the lumped model's outputs.
    lumped : callable
        ``lumped(freq_hz) -> (k, n)`` complex array, n >= len(outputs).
    fe_response : callable
        ``fe_response(freq_hz)``: a dict of complex arrays by output name, or a (k, n) array in
        the lumped model's output order.
    """
    f = check_frequencies(freq_hz)
    outputs = tuple(outputs)
    fe = fe_response(f)
    if isinstance(fe, Mapping):
        fe = np.column_stack([np.asarray(fe[k], dtype=complex) for k in outputs])
    fe = np.asarray(fe, dtype=complex)[:, : len(outputs)]
    lum = np.asarray(lumped(f), dtype=complex)[:, : len(outputs)]
    return HarmonicComparison(freq_hz=f, outputs=outputs, fe=fe, lumped=lum)


def harmonic_record_response(result: Mapping, outputs: Sequence[str]) -> dict[str, np.ndarray]:
    """Complex outputs from a result of ``isj.fem.batch.evaluate_harmonic`` (``{k}_re``, ``{k}_im``)."""
    return {
        k: np.asarray(result[f"{k}_re"], dtype=float) + 1j * np.asarray(result[f"{k}_im"], dtype=float)
        for k in outputs
    }


def region_moduli(materials: Materials) -> dict[str, float]:
    """Every region's Young's modulus (Pa) of ``materials``, keyed ``<region>_e_pa``."""
    return {f"{r}_e_pa": float(materials.youngs(r)) for r in REGIONS}


@dataclass(frozen=True)
class ChainSweep:
    """The lumped chain's damped frequency response of one design.

    Attributes
    ----------
    model : isj.lumped.dynamics.SecondOrderModel
    freq_hz : numpy.ndarray
        Shape (n,), Hz.
    response : numpy.ndarray
        Shape (n, 3), complex: α (rad), β (rad), incus u_x (m) at ``pressure_pa``.
    pressure_pa : float
        Pressure amplitude on the incus (Pa).
    natural_freq_hz, damping_ratio : numpy.ndarray
        The chain's undamped natural frequencies (Hz) and modal damping ratios.
    """

    model: SecondOrderModel
    freq_hz: np.ndarray
    response: np.ndarray
    pressure_pa: float
    natural_freq_hz: np.ndarray
    damping_ratio: np.ndarray

    outputs = CHAIN_OUTPUTS

    def fe_checks(self, freq_hz, fe_response: FeResponse, outputs: Sequence[str] = CHAIN_OUTPUTS):
        """:class:`HarmonicComparison` of this chain with FE at ``freq_hz`` (Hz)."""
        return compare_harmonic(
            freq_hz, outputs, lambda f: chain_outputs(self.model, f, self.pressure_pa), fe_response
        )


def chain_sweep(
    calibration,
    freq_hz,
    materials: Materials | None = None,
    geometry: Geometry | None = None,
    rayleigh_a_per_s=None,
    rayleigh_b_s=None,
    loss_factor=None,
    damping=None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
) -> ChainSweep:
    """Sweep the calibrated lumped chain of one design over ``freq_hz``.

    Parameters
    ----------
    calibration : isj.lumped.artifact.Calibration
        Static factors and the joint shear factor.
    freq_hz : sequence of float
        Frequencies (Hz).
    materials : Materials
        The design: moduli (Pa), ν, densities (kg/m³).
    geometry : Geometry
        Dimensions (m).
    rayleigh_a_per_s, rayleigh_b_s, loss_factor
        Changes to ``damping``: Rayleigh a (1/s), b (s) and loss factors η, numbers for every
        region or mappings region → value (None: unchanged).
    damping : isj.damping.Damping or str
        Damping per region, or a preset name (default: the published loss factors). A Rayleigh
        term with ωb or a/ω above 0.5 inside the band draws an ``isj.errors.DampingWarning``.
    pressure_pa : float
        Pressure amplitude on the incus (Pa).
    """
    materials = materials or Materials()
    freq = check_frequencies(freq_hz)
    damping = resolve(
        damping, rayleigh_a_per_s=rayleigh_a_per_s, rayleigh_b_s=rayleigh_b_s, loss_factor=loss_factor
    )
    warn_rayleigh_band(damping, float(freq.min()), float(freq.max()), REGIONS)
    model = chain_model(
        calibration.factor_array(),
        calibration.shear_factor,
        geometry,
        materials,
        damping=damping,
        joint=calibration.joint,
        scaling=calibration.geometry_scaling,
        **region_moduli(materials),
    )
    poles_hz, zeta = model.poles()
    return ChainSweep(
        model=model,
        freq_hz=freq,
        response=chain_outputs(model, freq, pressure_pa),
        pressure_pa=float(pressure_pa),
        natural_freq_hz=poles_hz,
        damping_ratio=zeta,
    )


@dataclass(frozen=True)
class EarSweep:
    """The lumped ear's damped frequency response per Pa of ear-canal pressure, one design.

    Attributes
    ----------
    model : isj.lumped.ear.LumpedEar
    freq_hz : numpy.ndarray
        Shape (n,), Hz.
    response : numpy.ndarray
        Shape (n, 4), complex, per Pa: umbo and stapes (m/Pa), α and β (rad/Pa).
    static : numpy.ndarray
        Shape (4,), the static (0 Hz) outputs per Pa.
    natural_freq_hz, damping_ratio : numpy.ndarray
        Undamped natural frequencies (Hz) and modal damping ratios.
    """

    model: object
    freq_hz: np.ndarray
    response: np.ndarray
    static: np.ndarray
    natural_freq_hz: np.ndarray
    damping_ratio: np.ndarray

    @property
    def outputs(self) -> tuple[str, ...]:
        from isj.lumped.ear import OUTPUTS

        return OUTPUTS

    def static_errors(self, fe_static: Mapping[str, float | None]) -> dict[str, float]:
        """|lumped static / FE static − 1| per output; None in FE (α of a rigid joint) skipped."""
        return {
            k: float(abs(self.static[j] / fe_static[k] - 1))
            for j, k in enumerate(self.outputs)
            if fe_static.get(k) is not None
        }

    def fe_checks(self, freq_hz, fe_response: FeResponse, outputs: Sequence[str] | None = None):
        """:class:`HarmonicComparison` of this ear with FE at ``freq_hz`` (Hz), per Pa."""
        return compare_harmonic(freq_hz, outputs or self.outputs, self.model._freq_resp, fe_response)


def ear_sweep(
    calibration,
    freq_hz,
    materials: Materials | None = None,
    ear_materials=None,
    rigid_joint: bool = False,
    rayleigh_a_per_s=None,
    rayleigh_b_s=None,
    loss_factor=None,
    damping=None,
    drum_modes=None,
) -> EarSweep:
    """Sweep the lumped cat middle ear of one joint design over ``freq_hz``, per Pa.

    Parameters
    ----------
    calibration : isj.lumped.artifact.Calibration
        The joint's static factors.
    freq_hz : sequence of float
        Frequencies (Hz).
    materials : Materials
        The joint design: moduli (Pa).
    ear_materials : isj.ear.EarMaterials
        The eardrum and the springs of the ear (Pa, N/m).
    rigid_joint : bool
        A rigid incus–stapes connection instead of the calibrated joint (no α, β).
    rayleigh_a_per_s, rayleigh_b_s, loss_factor
        Changes to ``damping`` (1/s, s, dimensionless; None: unchanged).
    damping : isj.damping.Damping or str
        Damping per part, or a preset name (default: the published loss factors); warns as
        :func:`chain_sweep` does.
    drum_modes : int or isj.lumped.ear_drum.DrumModes
        The drum's component modes (:func:`isj.lumped.ear.ear_model`); None or 0: its one
        static shape, valid below the first drum mode (1.7 kHz).
    """
    from isj.lumped.ear import ear_model

    freq = check_frequencies(freq_hz)
    damping = resolve(
        damping, rayleigh_a_per_s=rayleigh_a_per_s, rayleigh_b_s=rayleigh_b_s, loss_factor=loss_factor
    )
    warn_rayleigh_band(damping, float(freq.min()), float(freq.max()))
    lumped = ear_model(
        calibration.factor_array(),
        ear_materials=ear_materials,
        rigid_joint=rigid_joint,
        joint=calibration.joint,
        damping=damping,
        drum_modes=drum_modes or None,
        **region_moduli(materials or Materials()),
    )
    poles_hz, zeta = lumped.system.poles()
    return EarSweep(
        model=lumped,
        freq_hz=freq,
        response=lumped._freq_resp(freq),
        static=lumped.static().outputs,
        natural_freq_hz=poles_hz,
        damping_ratio=zeta,
    )
