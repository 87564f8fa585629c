"""The calibrated lumped model against FE: static spot checks and their error tables.

``isj explore``, the report's cases and calibration sections and the accuracy
benchmark all ask the same question of a list of designs: what do FE and the
lumped model give, and how far apart are they? :func:`compare_static` answers
it once. FE enters only through the evaluator the caller passes in (the
command line and the report pass ``isj.fem.batch.evaluate_design``), so this
package still imports without gmsh; results go through the FE result cache of
:func:`isj.calibration.runner.run_designs`.

The warnings a caller owes its user before trusting the lumped model (a
design outside the calibrated domain, FE checks on another mesh than the
calibration's) are here too, as :class:`~isj.errors.OutOfDomainWarning` and
:class:`~isj.errors.CalibrationWarning`.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from isj.lumped.model import StaticResponse, static_response

from isj.design import DEFAULT_PRESSURE_PA, Geometry
from isj.errors import CalibrationWarning, OutOfDomainWarning

from .runner import run_designs

#: Static outputs compared between FE and the lumped model, in table order.
STATIC_KEYS = ("alpha_rad", "beta_rad", "alpha_plus_beta_rad", "beta_over_alpha")

#: Outputs whose errors :meth:`StaticComparison.error_summary` reports (the sum follows from α, β).
SUMMARY_KEYS = ("alpha_rad", "beta_rad", "beta_over_alpha")


def static_row(alpha_rad: float, beta_rad: float) -> dict[str, float]:
    """α, β (rad), their sum (rad) and β/α as plain floats, keyed by :data:`STATIC_KEYS`."""
    a, b = float(alpha_rad), float(beta_rad)
    return {"alpha_rad": a, "beta_rad": b, "alpha_plus_beta_rad": a + b, "beta_over_alpha": b / a}


def lumped_static(
    calibration,
    designs: Sequence[Mapping] | Mapping[str, np.ndarray],
    geometry: Geometry | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
) -> StaticResponse:
    """The lumped static response over ``designs`` (vectorised).

    Parameters
    ----------
    calibration : isj.lumped.artifact.Calibration
    designs : list of dict, or dict of arrays
        Young's moduli (Pa) by name (``"gap_e_pa"``, ...); other keys (``"nu"``) are ignored, the
        static lumped model does not depend on them.
    geometry : Geometry, optional
        Dimensions (m); default geometry when None.
    pressure_pa : float
        Pressure on the incus (Pa).
    """
    if isinstance(designs, Mapping):
        moduli = {k: np.asarray(v, dtype=float) for k, v in designs.items() if k.endswith("_e_pa")}
    else:
        keys = [k for k in designs[0] if k.endswith("_e_pa")] if designs else []
        moduli = {k: np.array([float(d[k]) for d in designs]) for k in keys}
    return static_response(
        calibration.factor_array(),
        geometry,
        pressure_pa,
        joint=calibration.joint,
        scaling=calibration.geometry_scaling,
        **moduli,
    )


@dataclass(frozen=True)
class StaticComparison:
    """FE and lumped α, β over the same designs, with the lumped model's relative errors.

    Attributes
    ----------
    designs : list of dict
        The designs (moduli in Pa), in order.
    fe_results : list of dict
        The FE evaluator's result per design (``alpha_rad``, ``beta_rad``, ... in SI units).
    lumped_alpha_rad, lumped_beta_rad : numpy.ndarray
        Shape (n,), rad.
    """

    designs: list[dict]
    fe_results: list[dict]
    lumped_alpha_rad: np.ndarray
    lumped_beta_rad: np.ndarray

    @property
    def n(self) -> int:
        return len(self.designs)

    @property
    def fe_alpha_rad(self) -> np.ndarray:
        return np.array([r["alpha_rad"] for r in self.fe_results], dtype=float)

    @property
    def fe_beta_rad(self) -> np.ndarray:
        return np.array([r["beta_rad"] for r in self.fe_results], dtype=float)

    def fe_row(self, i: int) -> dict[str, float]:
        """:func:`static_row` of design ``i`` from FE."""
        return static_row(self.fe_results[i]["alpha_rad"], self.fe_results[i]["beta_rad"])

    def lumped_row(self, i: int) -> dict[str, float]:
        """:func:`static_row` of design ``i`` from the lumped model."""
        return static_row(self.lumped_alpha_rad[i], self.lumped_beta_rad[i])

    def rel_error(self, key: str) -> np.ndarray:
        """lumped / FE − 1 of one of :data:`STATIC_KEYS`, shape (n,)."""
        fa, fb = self.fe_alpha_rad, self.fe_beta_rad
        la, lb = self.lumped_alpha_rad, self.lumped_beta_rad
        pairs = {
            "alpha_rad": (la, fa),
            "beta_rad": (lb, fb),
            "alpha_plus_beta_rad": (la + lb, fa + fb),
            "beta_over_alpha": (lb / la, fb / fa),
        }
        if key not in pairs:
            raise ValueError(f"key = {key!r}: must be one of {STATIC_KEYS}")
        lum, fe = pairs[key]
        return lum / fe - 1

    def passed(self, tolerance: float) -> np.ndarray:
        """Which designs have both |α error| and |β error| <= ``tolerance`` (relative), shape (n,)."""
        return (np.abs(self.rel_error("alpha_rad")) <= tolerance) & (
            np.abs(self.rel_error("beta_rad")) <= tolerance
        )

    def max_abs_error(self) -> float:
        """Largest |relative error| of α or β over the designs; 0 when there are none."""
        if not self.n:
            return 0.0
        return float(max(np.abs(self.rel_error("alpha_rad")).max(), np.abs(self.rel_error("beta_rad")).max()))

    def error_summary(self, keys: Sequence[str] = SUMMARY_KEYS) -> dict[str, float | None]:
        """``max_abs_<key>`` and ``rms_<key>`` of the relative errors (None when there are no designs)."""
        out: dict[str, float | None] = {}
        errs = {k: self.rel_error(k) if self.n else None for k in keys}
        for k, e in errs.items():
            out[f"max_abs_{k}"] = float(np.max(np.abs(e))) if e is not None else None
        for k, e in errs.items():
            out[f"rms_{k}"] = float(np.sqrt(np.mean(np.square(e)))) if e is not None else None
        return out


def compare_static(
    calibration,
    designs: Sequence[Mapping],
    evaluate: Callable[[dict, dict], Mapping],
    settings: Mapping,
    cache_dir: str | os.PathLike,
    *,
    max_workers: int | None = None,
    progress: bool = True,
) -> StaticComparison:
    """FE (through ``evaluate``, cached) and the lumped model on the same designs.

    Parameters
    ----------
    calibration : isj.lumped.artifact.Calibration
    designs : list of dict
        Moduli (Pa) per design, optionally ``"nu"``.
    evaluate : callable
        ``evaluate(design, settings) -> dict`` with ``alpha_rad`` and ``beta_rad`` (rad), e.g.
        ``isj.fem.batch.evaluate_design``.
    settings : dict
        The evaluator's settings (``isj.fem.batch.fe_settings``); its ``geometry`` (m) and
        ``pressure_pa`` (Pa) are also the lumped model's.
    cache_dir : path
        FE result cache (:func:`isj.caches.fe_cache_dir`).
    max_workers, progress
        As for :func:`isj.calibration.runner.run_designs` (0: evaluate in this process).
    """
    designs = [dict(d) for d in designs]
    if not designs:
        empty = np.zeros(0)
        return StaticComparison([], [], empty, empty)
    records = run_designs(designs, evaluate, settings, cache_dir, max_workers=max_workers, progress=progress)
    geometry = Geometry(**settings["geometry"]) if settings.get("geometry") else None
    lum = lumped_static(calibration, designs, geometry, settings.get("pressure_pa", DEFAULT_PRESSURE_PA))
    return StaticComparison(
        designs=[r["design"] for r in records],
        fe_results=[r["result"] for r in records],
        lumped_alpha_rad=np.asarray(lum.alpha_rad, dtype=float),
        lumped_beta_rad=np.asarray(lum.beta_rad, dtype=float),
    )


def warn_outside_domain(calibration, designs: Mapping[str, np.ndarray], geometry=None) -> int:
    """Warn (:class:`~isj.errors.OutOfDomainWarning`) per modulus outside the calibrated domain.

    With a ``geometry`` and a calibration over geometry, also once for the designs whose plate
    support argument s exceeds the calibration's ``plate_support_limit`` (π/2,
    :func:`isj.lumped.model.plate_support_argument`): each modulus and dimension may lie inside
    its range while the combination (a thin, soft plate under a stiff gap) is one the
    calibration does not cover.

    Parameters
    ----------
    calibration : isj.lumped.artifact.Calibration
    designs : dict of arrays (or floats)
        Moduli (Pa) by name.
    geometry : isj.design.Geometry, optional
        Dimensions (m) of the designs.

    Returns
    -------
    int
        The largest number of designs outside the domain in any one modulus (0: all inside).
    """
    n_out = 0
    for k, mask in calibration.outside(designs).items():
        count = int(np.count_nonzero(mask))
        if count:
            lo, hi = calibration.domain[k]
            n_out = max(n_out, count)
            warnings.warn(
                f"{k} outside the calibrated domain [{lo:g}, {hi:g}] Pa for {count} design(s): "
                "the lumped model is extrapolating",
                OutOfDomainWarning,
                stacklevel=2,
            )
    s_max = calibration.training.get("plate_support_limit")
    if geometry is not None and s_max is not None:
        from isj.lumped.model import Lever, moduli_arrays, plate_support_argument

        E = moduli_arrays(**{k: v for k, v in designs.items() if k.endswith("_e_pa")})
        lever = Lever.from_geometry(geometry, calibration.geometry_scaling)
        f_s = calibration.factors["plate_support"]
        s = np.atleast_1d(
            plate_support_argument(f_s, lever, E["gap_e_pa"], E["plate_e_pa"], calibration.joint)
        )
        count = int(np.count_nonzero(s > s_max * (1 + 1e-9)))
        if count:
            n_out = max(n_out, count)
            warnings.warn(
                f"plate support argument s up to {float(s.max()):.3g}, beyond the calibration's limit "
                f"{s_max:.3g} (pi/2, where the plate face's weight changes sign) for {count} design(s): a "
                "thin, soft plate under a stiff gap; alpha may be off by several % (isj fem solve checks)",
                OutOfDomainWarning,
                stacklevel=2,
            )
    return n_out


def warn_fe_settings(calibration, order: int, resolution: float) -> bool:
    """Warn (:class:`~isj.errors.CalibrationWarning`) when FE checks use another mesh than the fit did.

    Returns True when it warned. The lumped model reproduces the FE model it was fitted to, with
    that mesh's discretisation error; an FE check on another mesh has a different one.
    """
    fs = calibration.fe_settings
    if fs and (fs.get("order") != order or fs.get("resolution") != resolution):
        warnings.warn(
            f"FE checks run at order {order}, resolution {resolution:g}; the calibration was fitted to "
            f"order {fs.get('order')}, resolution {fs.get('resolution')}: their discretisation errors differ",
            CalibrationWarning,
            stacklevel=2,
        )
        return True
    return False
