"""The calibration artifact: fitted factors and where they hold (JSON).

Written by ``calibration`` (``isj calibrate``), read here so that the lumped
model works without the calibration package. A default calibration ships in
``lumped/data/default_calibration.json``.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from isj.design_space import inside
from isj.errors import CorruptCalibration

from .model import FACTOR_NAMES, SCALED_TERMS, SCALING_DIMENSIONS

#: 2: plate_support; 3: load_sharing; 4: root_plate; 5: pedicle_face; 6: geometry_scaling
#: (lumped.model)
FORMAT_VERSION = 6

#: Factors a file of an older format lacks, with the value that makes the current
#: equations those of that format exactly (on the default geometry, where every geometric
#: scaling of lumped.model.GEOMETRY_EXPONENTS is 1).
_ADDED_FACTORS = {
    2: {"load_sharing": 0.0, "root_plate": 0.0, "pedicle_face": 0.0},
    3: {"root_plate": 0.0, "pedicle_face": 0.0},
    4: {"pedicle_face": 0.0},
    5: {},  # format 6 added the optional geometry_scaling block only
}

#: Smallest clearance (m) between the capsule's levels, reach − bond (its free strip beyond the
#: gap) and plate thickness − reach, in the designs of a calibration over geometry
#: (calibration.doe.sample_with_geometry): at 5 µm the meshes keep the default geometry's
#: quality (the bound of the thin layers, isj.design.GEOMETRY_BOUNDS_M).
GEOMETRY_CLEARANCE_M = 5e-6

#: Joints a calibration may be fitted for (:data:`isj.fem.sliding.JOINTS` less the thin layer,
#: whose shear modulus no calibration samples). A file without a ``joint`` is bonded: every
#: calibration before the sliding joint (docs/lumped.md §3.14) was fitted on the bonded FE model.
CALIBRATED_JOINTS: tuple[str, ...] = ("bonded", "sliding")


@dataclass(frozen=True)
class Calibration:
    """Fitted factors, their domain of validity, their errors and provenance.

    ``domain`` maps a modulus name to its [low, high] bounds (Pa);
    ``training``/``validation`` hold error statistics (relative, e.g.
    ``max_alpha``); ``fe_settings`` the FE model the factors were fitted to;
    ``dynamics`` the dynamic chain's calibration (``shear_factor`` and its f1, f2
    errors, :func:`calibration.pipeline.calibrate_dynamics`), optional; ``joint`` the FE
    model's incudostapedial joint the factors were fitted on (:data:`CALIBRATED_JOINTS`);
    ``region`` the map of where the factors hold their tolerance against the certified surrogate
    (:mod:`calibration.region`, docs/lumped.md §3.15), optional; ``geometry_scaling`` the fitted
    geometric exponents of the terms (term of :data:`~isj.lumped.model.SCALED_TERMS` → dimension →
    exponent, :meth:`~isj.lumped.model.Lever.from_geometry`; docs/lumped.md §3.16), optional.
    """

    factors: dict[str, float]
    domain: dict[str, list[float]]
    training: dict = field(default_factory=dict)
    validation: dict = field(default_factory=dict)
    fe_settings: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict)
    dynamics: dict = field(default_factory=dict)
    format: int = FORMAT_VERSION
    geometry_domain: dict[str, list[float]] = field(default_factory=dict)
    corners: dict = field(default_factory=dict)
    joint: str = "bonded"
    region: dict = field(default_factory=dict)
    geometry_scaling: dict = field(default_factory=dict)

    def factor_array(self) -> np.ndarray:
        return np.array([self.factors[n] for n in FACTOR_NAMES], dtype=float)

    @property
    def shear_factor(self) -> float:
        """The chain's joint shear factor (dimensionless) for :func:`lumped.dynamics.chain_model`.

        A calibration without one in ``dynamics`` (none fitted, or an older file whose
        dynamics held the former two-hinge chain's ``hinge_fraction``) still loads: the
        physical estimate 1.0 (:data:`lumped.dynamics.DEFAULT_SHEAR_FACTOR`) is used then, with
        the chain's second natural frequency ≈ 15 % high on the default design.
        """
        from .dynamics import DEFAULT_SHEAR_FACTOR

        return float(self.dynamics.get("shear_factor", DEFAULT_SHEAR_FACTOR))

    def outside(self, designs: dict) -> dict[str, np.ndarray]:
        """Per modulus, a boolean array: which designs lie outside the calibrated domain."""
        out = {}
        for k, (lo, hi) in self.domain.items():
            if k in designs:
                v = np.atleast_1d(np.asarray(designs[k], dtype=float))
                out[k] = ~inside(v, lo, hi)
        return out

    def outside_geometry(self, geometry) -> dict[str, tuple[float, float, float]]:
        """The dimensions of ``geometry`` outside the calibrated geometry: ``{name: (value, low, high)}`` (m).

        A calibration with a ``geometry_domain`` holds inside that box; one without holds only
        for the geometry it was fitted on (its ``fe_settings``' geometry, else the default one),
        and every dimension that differs from it counts as outside (low = high = the fitted value).
        """
        import dataclasses

        from isj.design import Geometry

        values = dataclasses.asdict(geometry)
        fitted = {**dataclasses.asdict(Geometry()), **(self.fe_settings.get("geometry") or {})}
        box = {k: (float(lo), float(hi)) for k, (lo, hi) in self.geometry_domain.items()}
        out = {}
        for k, v in values.items():
            lo, hi = box.get(k, (fitted[k], fitted[k]))
            if not inside(v, lo, hi):
                out[k] = (float(v), lo, hi)
        # the sampler keeps the capsule's levels GEOMETRY_CLEARANCE_M apart: a geometry closer
        # than that lies inside the box but outside what the calibration was fitted on
        if "capsule_reach_m" in box:
            levels = (("capsule_bond_m", "capsule_reach_m"), ("capsule_reach_m", "plate_thickness_m"))
            for lower, upper in levels:
                gap = values[upper] - values[lower]
                if gap < GEOMETRY_CLEARANCE_M * (1 - 1e-9):
                    out[f"{upper} - {lower}"] = (float(gap), GEOMETRY_CLEARANCE_M, math.inf)
        return out

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=2, sort_keys=True) + "\n"

    @classmethod
    def from_dict(cls, d: dict, source: str = "calibration") -> Calibration:
        try:
            fmt = d.get("format")
            if fmt != FORMAT_VERSION and fmt not in _ADDED_FACTORS:
                known = ", ".join(str(v) for v in sorted({*_ADDED_FACTORS, FORMAT_VERSION}))
                raise CorruptCalibration(f"{source}: format {fmt!r}, expected one of {known}")
            given = {**_ADDED_FACTORS.get(fmt, {}), **d["factors"]}
            factors = {n: float(given[n]) for n in FACTOR_NAMES}
            domain = {k: [float(v[0]), float(v[1])] for k, v in d["domain"].items()}
        except CorruptCalibration:
            raise
        except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
            raise CorruptCalibration(f"{source}: not a valid isj calibration ({exc!r})") from None
        bad = [n for n, v in factors.items() if not (math.isfinite(v) and v >= 0)]
        if bad:
            raise CorruptCalibration(f"{source}: factor(s) {', '.join(bad)} not finite and >= 0")
        if any(not (0 < lo <= hi) for lo, hi in domain.values()):
            raise CorruptCalibration(f"{source}: domain bounds must satisfy 0 < low <= high")
        names = ("training", "validation", "fe_settings", "provenance", "dynamics", "corners", "region")
        sections = {k: d.get(k, {}) for k in names}
        for k, v in sections.items():
            if not isinstance(v, dict):
                raise CorruptCalibration(f"{source}: {k} = {type(v).__name__}, must be a JSON object")
        dynamics = sections["dynamics"]
        shear = dynamics.get("shear_factor", 1.0)
        number = isinstance(shear, int | float) and not isinstance(shear, bool)
        if not number or not (math.isfinite(shear) and shear > 0):
            raise CorruptCalibration(f"{source}: dynamics.shear_factor = {shear!r}, must be finite and > 0")
        try:
            gdomain = {k: [float(v[0]), float(v[1])] for k, v in (d.get("geometry_domain") or {}).items()}
        except (TypeError, ValueError, IndexError, AttributeError) as exc:
            raise CorruptCalibration(f"{source}: geometry_domain not a valid box ({exc!r})") from None
        if any(not (0 < lo <= hi) for lo, hi in gdomain.values()):
            raise CorruptCalibration(f"{source}: geometry_domain bounds must satisfy 0 < low <= high")
        joint = d.get("joint", "bonded")
        if joint not in CALIBRATED_JOINTS:
            raise CorruptCalibration(
                f"{source}: joint = {joint!r}, must be one of {', '.join(CALIBRATED_JOINTS)}"
            )
        return cls(
            joint=joint,
            factors=factors,
            domain=domain,
            geometry_domain=gdomain,
            corners=dict(sections["corners"]),
            training=dict(sections["training"]),
            validation=dict(sections["validation"]),
            fe_settings=dict(sections["fe_settings"]),
            provenance=dict(sections["provenance"]),
            dynamics=dict(dynamics),
            region=_checked_region(sections["region"], domain, source),
            geometry_scaling=_checked_scaling(d.get("geometry_scaling") or {}, source),
        )

    @classmethod
    def load(cls, path: str | Path) -> Calibration:
        """Read a calibration file; raise :class:`CorruptCalibration` with a one-line reason."""
        path = Path(path)
        try:
            d = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise CorruptCalibration(f"calibration {str(path)!r}: cannot be read ({exc})") from None
        if not isinstance(d, dict):
            raise CorruptCalibration(f"calibration {str(path)!r}: not a JSON object")
        return cls.from_dict(d, source=f"calibration {str(path)!r}")


def _checked_scaling(scaling, source: str) -> dict:
    """The ``geometry_scaling`` block if well formed: known terms and dimensions, finite exponents."""

    def number(c) -> bool:
        return isinstance(c, int | float) and not isinstance(c, bool) and math.isfinite(c)

    ok = isinstance(scaling, dict) and all(
        t in SCALED_TERMS
        and isinstance(e, dict)
        and all(d in SCALING_DIMENSIONS and number(c) for d, c in e.items())
        for t, e in scaling.items()
    )
    if not ok:
        raise CorruptCalibration(
            f"{source}: geometry_scaling must map terms of lumped.model.SCALED_TERMS to finite exponents "
            "of lumped.model.SCALING_DIMENSIONS"
        )
    return {t: {d: float(c) for d, c in e.items()} for t, e in scaling.items()}


def _checked_region(region: dict, domain: dict, source: str) -> dict:
    """The ``region`` block (calibration.region) if well formed: cells, ranged moduli, a full bit mask."""
    if not region:
        return {}
    try:
        cells, names = int(region["cells"]), list(region["moduli"])
        bits = len(bytes.fromhex(region["outside"])) * 8
        tol = float(region["tolerance"])
        ok = cells >= 1 and all(k in domain for k in names) and bits >= cells ** len(names) and tol > 0
    except (KeyError, TypeError, ValueError) as exc:
        raise CorruptCalibration(f"{source}: region not a valid map ({exc!r})") from None
    if not ok:
        raise CorruptCalibration(f"{source}: region not a valid map (cells, moduli or bit mask)")
    return dict(region)


DEFAULT_CALIBRATION = "default_calibration.json"

#: The shipped calibration over geometry and moduli together (docs/lumped.md §3.13).
GEOMETRY_CALIBRATION = "geometry_calibration.json"

#: The shipped calibration for the sliding joint, on the default geometry (docs/lumped.md §3.14).
SLIDING_CALIBRATION = "sliding_calibration.json"


def default_calibration() -> Calibration:
    """The calibration that ships with the package."""
    ref = resources.files("isj.lumped") / "data" / DEFAULT_CALIBRATION
    d = json.loads(ref.read_text())
    return Calibration.from_dict(d, source="default calibration")


def geometry_calibration() -> Calibration:
    """The shipped calibration over geometry and moduli (``geometry_domain``), for other geometries."""
    ref = resources.files("isj.lumped") / "data" / GEOMETRY_CALIBRATION
    d = json.loads(ref.read_text())
    return Calibration.from_dict(d, source="geometry calibration")


def sliding_calibration() -> Calibration:
    """The shipped calibration for the sliding joint (default geometry; moduli as the default one's)."""
    ref = resources.files("isj.lumped") / "data" / SLIDING_CALIBRATION
    d = json.loads(ref.read_text())
    return Calibration.from_dict(d, source="sliding calibration")


def check_joint(joint) -> str:
    """``joint`` if the shipped calibrations cover it, else InvalidParameter naming the valid ones."""
    if joint not in CALIBRATED_JOINTS:
        from isj.errors import InvalidParameter

        raise InvalidParameter(
            f"joint = {joint!r}: the lumped model is calibrated for {' and '.join(CALIBRATED_JOINTS)} "
            "joints only (the thin layer has no lumped calibration; isj fem solve --joint layer)"
        )
    return joint


def calibration_for(geometry=None, joint: str = "bonded") -> Calibration:
    """The shipped calibration for ``geometry`` and ``joint``.

    Bonded: the default one for the default geometry (or None), the geometry calibration
    (:func:`geometry_calibration`) for any other. Sliding: :func:`sliding_calibration`, fitted on
    the default geometry only (another is outside it: :meth:`Calibration.outside_geometry`).
    """
    from isj.design import Geometry

    if check_joint(joint) == "sliding":
        return sliding_calibration()
    if geometry is None or geometry == Geometry():
        return default_calibration()
    return geometry_calibration()
