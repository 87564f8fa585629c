"""The calibrated lumped model as one object: static α and β, the chain's and the ear's dynamics.

:class:`LumpedModel` holds a calibration (:class:`isj.lumped.artifact.Calibration`) and the
joint model's geometry, and threads the calibrated factors and the joint shear factor
into :mod:`isj.lumped.model`, :mod:`isj.lumped.dynamics` and :mod:`isj.lumped.ear`
exactly as the command line does (``isj lumped solve``, ``isj sweep``, ``isj ear sweep``),
so the numbers are the same, bit for bit.

>>> import numpy as np
>>> lm = LumpedModel.default()
>>> r = lm.static(gap_e_pa=np.geomspace(1e6, 50e6, 5))   # five designs at once
>>> r.alpha_rad.shape
(5,)

The equations and their derivation are in ``docs/`` (the lumped model's page).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials
from isj.errors import InvalidParameter
from isj.responses import FrequencyResponse
from isj.validate import check_frequencies

from .artifact import Calibration, calibration_for, check_joint, default_calibration
from .dynamics import OUTPUTS, UNITS, chain_model
from .ear import LumpedEar, ear_model
from .model import MODULI, StaticResponse, moduli_arrays, static_response
from .second_order import SecondOrderModel

_DEFAULT = Materials()


@dataclass(frozen=True)
class LumpedStaticResult(StaticResponse):
    """Static α and β (rad) of the lumped model over designs, at ``pressure_pa`` (Pa).

    Arrays broadcast over the designs (0-d for one design); ``sum_rad`` and ``ratio`` as in
    :class:`isj.lumped.model.StaticResponse`.
    """

    pressure_pa: float | np.ndarray = DEFAULT_PRESSURE_PA

    def to_dict(self) -> dict:
        """The keys of ``isj lumped solve --json``: floats for one design, lists for many."""

        def plain(v):
            a = np.asarray(v, dtype=float)
            return float(a) if a.ndim == 0 else a.tolist()

        return {
            "alpha_rad": plain(self.alpha_rad),
            "beta_rad": plain(self.beta_rad),
            "alpha_plus_beta_rad": plain(self.sum_rad),
            "beta_over_alpha": plain(self.ratio),
            "pressure_pa": plain(self.pressure_pa),
        }


def _pressure(pressure_pa):
    """A pressure (Pa), float or array, every value finite and non-zero (the model is linear)."""
    try:
        if isinstance(pressure_pa, bool):
            raise TypeError
        p = np.asarray(pressure_pa, dtype=float)
    except (TypeError, ValueError):
        p = np.array(np.nan)
    if p.size == 0 or not np.all(np.isfinite(p)) or np.any(p == 0):
        raise InvalidParameter(f"pressure_pa = {pressure_pa!r} Pa: every value must be finite and non-zero")
    return float(p) if p.ndim == 0 else p


def _chain_response(model: SecondOrderModel, freq_hz, pressure_pa: float = DEFAULT_PRESSURE_PA):
    """One design's chain response at ``freq_hz`` (Hz) to a pressure amplitude (Pa), as a FrequencyResponse.

    The numbers of :func:`isj.lumped.dynamics.chain_outputs`, bit for bit.

    Parameters
    ----------
    model : one design's :func:`isj.lumped.dynamics.chain_model` (no design axis)
    freq_hz : frequencies (Hz), >= 0
    pressure_pa : pressure amplitude on the incus's face (Pa)

    Returns
    -------
    isj.responses.FrequencyResponse : outputs :data:`isj.lumped.dynamics.OUTPUTS` (rad, rad, m)
    """
    if model.M.ndim != 2:
        raise InvalidParameter("model: one design only (no design axis); use model.freq_resp for many")
    f = check_frequencies(freq_hz)
    H = model.freq_resp(f) * pressure_pa
    return FrequencyResponse(f, H, OUTPUTS, tuple(UNITS[k] for k in OUTPUTS), input_amplitude=pressure_pa)


def _fitted_geometry(calibration: Calibration) -> Geometry:
    """The geometry (m) in a calibration's FE settings, else the default one."""
    fields = calibration.fe_settings.get("geometry")
    if not fields:
        return Geometry()
    try:
        return Geometry(**fields)
    except (TypeError, ValueError) as exc:  # InvalidParameter is a ValueError
        raise InvalidParameter(f"calibration fe_settings.geometry: not a valid geometry ({exc})") from None


class LumpedModel:
    """The calibrated lumped model of the pedicle and the joint (static, chain dynamics, whole ear).

    Parameters
    ----------
    calibration : fitted factors, domain and joint shear factor (default: the shipped one)
    geometry : the joint model's dimensions (m); default: the geometry the calibration was
        fitted on (its ``fe_settings``; the default geometry for the shipped calibration). Without
        ``calibration``, a geometry other than the default takes the shipped calibration over
        geometry and moduli (:func:`isj.lumped.artifact.geometry_calibration`); whether it lies
        inside the calibrated geometry: :attr:`outside_geometry`
    joint : "bonded" or "sliding" (docs/lumped.md §3.14); without ``calibration``, it picks the
        shipped calibration fitted on FE with that joint; with one, it must be the calibration's
        joint. Default: the calibration's joint, else bonded

    Notes
    -----
    Designs are given as Young's moduli in Pa (:data:`isj.lumped.model.MODULI`): one
    :class:`isj.design.Materials`, a mapping of floats or arrays, or keyword arguments
    (``gap_e_pa=...``), which override the first two; missing moduli take
    :class:`isj.design.Materials`' defaults. Arrays broadcast against each other.
    """

    def __init__(
        self,
        calibration: Calibration | None = None,
        geometry: Geometry | None = None,
        joint: str | None = None,
    ):
        if calibration is not None and not isinstance(calibration, Calibration):
            raise InvalidParameter(
                f"calibration: must be an isj.lumped.artifact.Calibration, not {type(calibration).__name__}"
            )
        if geometry is not None and not isinstance(geometry, Geometry):
            raise InvalidParameter(f"geometry: must be an isj.design.Geometry, not {type(geometry).__name__}")
        if joint is not None:
            check_joint(joint)
            if calibration is not None and calibration.joint != joint:
                raise InvalidParameter(
                    f"joint = {joint!r}: the calibration was fitted with the {calibration.joint} joint"
                )
        # another geometry than the default takes the calibration over geometry and moduli
        self.calibration = calibration or calibration_for(geometry, joint or "bonded")
        self.geometry = geometry or _fitted_geometry(self.calibration)

    @classmethod
    def default(cls, joint: str = "bonded") -> LumpedModel:
        """The model with the calibration that ships with isj for ``joint`` ("bonded" or "sliding")."""
        return cls(default_calibration() if check_joint(joint) == "bonded" else None, joint=joint)

    @classmethod
    def load(cls, path: str | os.PathLike, geometry: Geometry | None = None) -> LumpedModel:
        """The model with a calibration file written by ``isj calibrate``.

        Raises :class:`isj.lumped.artifact.CorruptCalibration` with a one-line reason.
        """
        return cls(Calibration.load(path), geometry)

    def __repr__(self) -> str:
        v = self.calibration.validation
        return (
            f"LumpedModel({self.joint} joint, held-out max error alpha {v.get('max_alpha', math.nan):.3g}, "
            f"beta {v.get('max_beta', math.nan):.3g}; shear factor {self.shear_factor:.4g})"
        )

    # ---- the calibration -------------------------------------------------------------

    @property
    def factors(self) -> np.ndarray:
        """The calibrated static factors (dimensionless), in :data:`isj.lumped.model.FACTOR_NAMES` order."""
        return self.calibration.factor_array()

    @property
    def shear_factor(self) -> float:
        """The chain's joint shear factor (dimensionless)."""
        return self.calibration.shear_factor

    @property
    def joint(self) -> str:
        """The joint the calibration was fitted with: "bonded" or "sliding"."""
        return self.calibration.joint

    @property
    def outside_geometry(self) -> dict[str, tuple[float, float, float]]:
        """The model's dimensions outside the calibrated geometry: ``{name: (value, low, high)}`` (m).

        Empty inside it. See :meth:`isj.lumped.artifact.Calibration.outside_geometry`.
        """
        return self.calibration.outside_geometry(self.geometry)

    @property
    def domain(self) -> dict[str, tuple[float, float]]:
        """Per modulus, the [low, high] bounds (Pa) of the designs the calibration was fitted on."""
        return {k: (float(lo), float(hi)) for k, (lo, hi) in self.calibration.domain.items()}

    def in_domain(self, materials=None, **moduli) -> np.ndarray:
        """Which designs lie inside :attr:`domain` (a boolean array over the broadcast designs)."""
        E = moduli_arrays(self._moduli(materials, moduli))  # the defaults count too
        shape = np.broadcast_shapes(*(np.shape(v) for v in E.values()))
        outside = self.calibration.outside({k: np.broadcast_to(v, shape) for k, v in E.items()})
        inside = np.ones(shape, dtype=bool)
        for mask in outside.values():
            inside &= ~mask.reshape(shape)
        return inside

    # ---- designs ------------------------------------------------------------------------

    @staticmethod
    def _moduli(materials, moduli: dict) -> dict:
        """Moduli (Pa) from a Materials, a mapping and keywords (keywords win); the rest default."""
        if materials is None:
            base = {}
        elif isinstance(materials, Materials):
            base = {k: getattr(materials, k) for k in MODULI}
        elif isinstance(materials, Mapping):
            base = dict(materials)
        elif isinstance(materials, Sequence) and materials and all(isinstance(d, Mapping) for d in materials):
            # a list of designs, as isj.calibration.sample gives: one array per modulus
            keys = set().union(*materials)
            base = {k: np.array([d.get(k, getattr(_DEFAULT, k, np.nan)) for d in materials]) for k in keys}
        else:
            raise InvalidParameter(
                "materials: must be an isj.design.Materials, a mapping of moduli (Pa) or a list of such "
                f"mappings, not {type(materials).__name__}"
            )
        out = {**base, **moduli}
        unknown = set(out) - set(MODULI)
        if unknown:
            raise InvalidParameter(f"unknown modulus {sorted(unknown)}: must be among {', '.join(MODULI)}")
        return out

    # ---- statics ----------------------------------------------------------------------------

    def static(self, materials=None, *, pressure_pa=DEFAULT_PRESSURE_PA, **moduli) -> LumpedStaticResult:
        """α and β (rad) at ``pressure_pa`` (Pa, float or array) for one design or arrays of designs.

        Parameters
        ----------
        materials : Materials or mapping of moduli (Pa), floats or arrays
        pressure_pa : pressure on the incus's −x face (Pa), finite and non-zero; broadcasts
        **moduli : Young's moduli (Pa), e.g. ``gap_e_pa=np.geomspace(1e6, 5e7, 100)``

        Returns
        -------
        LumpedStaticResult : ``isj.lumped.model.static_response`` with the calibrated factors
        """
        p = _pressure(pressure_pa)
        r = static_response(
            self.factors,
            self.geometry,
            p,
            joint=self.joint,
            scaling=self.calibration.geometry_scaling,
            **self._moduli(materials, moduli),
        )
        return LumpedStaticResult(alpha_rad=r.alpha_rad, beta_rad=r.beta_rad, pressure_pa=p)

    # ---- the chain's dynamics --------------------------------------------------------------

    def chain(
        self,
        materials=None,
        *,
        rayleigh_a_per_s=None,
        rayleigh_b_s=None,
        loss_factor=None,
        damping=None,
        **moduli,
    ) -> SecondOrderModel:
        """The eight-coordinate chain (:func:`isj.lumped.dynamics.chain_model`), one or many designs.

        ``materials`` as in :meth:`static`; a :class:`Materials` also gives ν and the densities
        (kg/m³). Damping: an :class:`isj.damping.Damping` or a preset name (default: the published
        loss factors per region), changed by Rayleigh a (1/s), b (s) and loss factors η (numbers
        for every region or mappings region → value; None leaves them).
        """
        mat = materials if isinstance(materials, Materials) else None
        return chain_model(
            self.factors,
            self.shear_factor,
            self.geometry,
            mat,
            joint=self.joint,
            scaling=self.calibration.geometry_scaling,
            rayleigh_a_per_s=rayleigh_a_per_s,
            rayleigh_b_s=rayleigh_b_s,
            loss_factor=loss_factor,
            damping=damping,
            **self._moduli(materials, moduli),
        )

    def frequency_response(
        self,
        freq_hz,
        materials=None,
        *,
        pressure_pa: float = DEFAULT_PRESSURE_PA,
        rayleigh_a_per_s=None,
        rayleigh_b_s=None,
        loss_factor=None,
        damping=None,
        **moduli,
    ):
        """The chain's α, β (rad) and incus u_x (m) at ``freq_hz`` (Hz) for one design.

        Returns an :class:`isj.responses.FrequencyResponse` at the pressure amplitude
        ``pressure_pa`` (Pa); the numbers of ``isj sweep``. For many designs at once:
        :func:`isj.lumped.dynamics.chain_outputs` on :meth:`chain`.
        """
        model = self.chain(
            materials,
            rayleigh_a_per_s=rayleigh_a_per_s,
            rayleigh_b_s=rayleigh_b_s,
            loss_factor=loss_factor,
            damping=damping,
            **moduli,
        )
        return _chain_response(model, freq_hz, _pressure(pressure_pa))

    def natural_frequencies_hz(self, n: int | None = None, materials=None, **moduli) -> np.ndarray:
        """The chain's undamped natural frequencies (Hz), ascending (the ``n`` lowest of 8; per design)."""
        f = self.chain(materials, rayleigh_b_s=0.0, **moduli).poles()[0]
        return f if n is None else f[..., :n]

    # ---- the whole ear ------------------------------------------------------------------------

    def ear(
        self,
        materials=None,
        *,
        ear_geometry=None,
        ear_materials=None,
        eardrum=None,
        masses=None,
        rigid_joint: bool = False,
        body: str = "rigid",
        rayleigh_a_per_s=None,
        rayleigh_b_s=None,
        loss_factor=None,
        damping=None,
        drum_modes=None,
        **moduli,
    ) -> LumpedEar:
        """The lumped ear (:func:`isj.lumped.ear.ear_model`) with this calibration's joint.

        Its response: ``ear(...).static()``, ``ear(...).frequency_response(freq_hz)`` (the numbers
        of ``isj ear sweep``) and ``ear(...).natural_frequencies_hz()``.

        Parameters
        ----------
        materials, **moduli : the joint's moduli (Pa), as in :meth:`static`
        ear_geometry, ear_materials : :class:`isj.ear.EarGeometry` (m) and
            :class:`isj.ear.EarMaterials` (Pa, N/m); defaults: the cat ear
        eardrum, masses, body : see :func:`isj.lumped.ear.ear_model`
        rigid_joint : no joint and pedicle compliance (α = β = 0)
        damping : :class:`isj.damping.Damping` or a preset name (default: published loss factors)
        rayleigh_a_per_s, rayleigh_b_s, loss_factor : changes to it (1/s, s, dimensionless)
        drum_modes : the drum's component modes past its first mode (an int: the lowest n of the
            shipped ones; see :func:`isj.lumped.ear.ear_model`); None, the one-shape drum
        """
        return ear_model(
            self.factors,
            geometry=ear_geometry,
            joint_geometry=self.geometry,
            ear_materials=ear_materials,
            eardrum=eardrum,
            masses=masses,
            rigid_joint=rigid_joint,
            joint=self.joint,
            body=body,
            rayleigh_a_per_s=rayleigh_a_per_s,
            rayleigh_b_s=rayleigh_b_s,
            loss_factor=loss_factor,
            damping=damping,
            drum_modes=drum_modes,
            **self._moduli(materials, moduli),
        )
