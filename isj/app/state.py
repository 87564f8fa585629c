"""The explorer's state → outputs layer: pure Python and numpy, no web framework (docs/app.md).

A :class:`Design` is what the page's controls set: the five calibrated Young's moduli (Pa), the
eight dimensions of the geometry calibration (m), the joint and the pressure (Pa). Every output
the page shows is a function of it here, so the numbers can be tested without a browser:

- :func:`static_outputs`: α, β and β/α of the calibrated lumped model (the numbers of
  ``isj lumped solve``), the marks for a design outside the calibrated domain, the region where
  the lumped model holds its tolerance (docs/lumped.md §3.15) or the geometry calibration, and
  the certified surrogate's values and bounds when its build is in the cache;
- :func:`chain_bode`: the isolated chain's frequency response (docs/dynamics.md §4);
- :func:`ear_velocity`: the whole ear's stapes velocity H_V and ΔH_V, from
  :func:`fast_ear_response` when a fast FE ear is there, else the lumped ear in its valid band;
- :func:`ratio_map`: β/α over two moduli; :func:`uncertainty`: the histogram of β/α and
  P(β/α > 1) for distributions set in the page;
- :func:`case_toml`: the design as a case file for ``isj report --config``.

Typed values go through :func:`parse_value`, which raises :class:`~isj.errors.InvalidParameter`
with one line naming the field and its valid range.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from isj.cases import THESIS_CASES
from isj.design import DEFAULT_PRESSURE_PA, GEOMETRY_BOUNDS_M, Geometry, Materials
from isj.errors import InvalidParameter
from isj.validate import MODULUS_RANGE_PA, PRESSURE_RANGE_PA

#: The five calibrated moduli, in the page's order (the incus keeps its default, 12 GPa).
MODULI = ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa", "plate_e_pa", "stapes_e_pa")

#: The dimensions the geometry calibration ranges over (lumped/data/geometry_calibration.json).
GEOMETRY_FIELDS = (
    "pedicle_x_m",
    "pedicle_y_m",
    "pedicle_length_m",
    "gap_thickness_m",
    "plate_thickness_m",
    "capsule_thickness_m",
    "capsule_reach_m",
    "capsule_bond_m",
)

JOINTS = ("bonded", "sliding")

#: The lumped ear's valid band (Hz): with 40 drum modes it follows the FE ear within 0.03 dB and
#: 0.9° up to 5 kHz (rigid joint) and within 0.45 dB and 6.4° from 500 Hz to 3.5 kHz with the
#: joint inside (docs/ear.md §5.10).
LUMPED_EAR_BAND_HZ = (100.0, 5000.0)

#: Drum modes of the lumped ear for that band (the 40 lowest, to 6.1 kHz; docs/ear.md §5.10).
LUMPED_EAR_DRUM_MODES = 40

#: The chain's Bode plot band (Hz): the report's sweep band (docs/user-guide.md §6.5, [sweep]).
BODE_BAND_HZ = (100.0, 40000.0)

#: Moduli the uncertainty view may give: log-uniform over the calibrated domain, lognormal about
#: the current value, or fixed at it.
UQ_KINDS = ("loguniform", "lognormal", "fixed")

#: Largest uncertainty sample the page draws per update (about 10 ms of the lumped model).
MAX_UQ_SAMPLES = 200_000


@functools.cache
def _shipped(joint: str, geometry: Geometry | None):
    """The shipped :class:`isj.lumped.api.LumpedModel` for a joint and geometry (cached: read once)."""
    from isj.lumped.api import LumpedModel

    return LumpedModel(geometry=geometry, joint=joint)


@functools.cache
def calibrated_domain() -> dict[str, tuple[float, float]]:
    """[low, high] (Pa) of each calibrated modulus: the shipped calibration's domain."""
    return {k: tuple(float(v) for v in _shipped("bonded", None).domain[k]) for k in MODULI}


@functools.cache
def geometry_domain() -> dict[str, tuple[float, float]]:
    """[low, high] (m) of each dimension of :data:`GEOMETRY_FIELDS`: the geometry calibration's."""
    from isj.lumped.artifact import calibration_for

    cal = calibration_for(Geometry(pedicle_x_m=Geometry().pedicle_x_m * 1.01), "bonded")
    return {k: (float(cal.geometry_domain[k][0]), float(cal.geometry_domain[k][1])) for k in GEOMETRY_FIELDS}


@dataclass(frozen=True)
class FieldSpec:
    """One control: its name, label, unit, slider range and the range a typed value may take."""

    name: str
    label: str
    unit: str
    slider: tuple[float, float]
    valid: tuple[float, float]
    log: bool


def field_specs() -> dict[str, FieldSpec]:
    """Every numeric control by name: moduli, dimensions and the pressure."""
    out = {}
    for k in MODULI:
        out[k] = FieldSpec(
            k, f"E {k.removesuffix('_e_pa')}", "Pa", calibrated_domain()[k], MODULUS_RANGE_PA, True
        )
    for k in GEOMETRY_FIELDS:
        out[k] = FieldSpec(
            k, k.removesuffix("_m").replace("_", " "), "m", geometry_domain()[k], GEOMETRY_BOUNDS_M[k], False
        )
    out["pressure_pa"] = FieldSpec("pressure_pa", "pressure", "Pa", (1.0, 100.0), PRESSURE_RANGE_PA, False)
    return out


def parse_value(name: str, text: str) -> float:
    """The number typed into field ``name``; one-line :class:`InvalidParameter` otherwise.

    The valid range is the physical one (:data:`isj.validate.MODULUS_RANGE_PA`,
    :data:`isj.design.GEOMETRY_BOUNDS_M`, :data:`isj.validate.PRESSURE_RANGE_PA`), wider than the
    calibrated one: a value outside the calibration is shown, and marked.
    """
    spec = field_specs().get(name)
    if spec is None:
        raise InvalidParameter(f"{name}: not a field of the page")
    lo, hi = spec.valid
    try:
        v = float(str(text).strip())
    except ValueError:
        raise InvalidParameter(
            f"{name} = {str(text)[:40]!r}: not a number ({spec.unit}, in [{lo:g}, {hi:g}])"
        ) from None
    if not (math.isfinite(v) and lo <= v <= hi):
        raise InvalidParameter(
            f"{name} = {str(text)[:40]}: must be a finite number in [{lo:g}, {hi:g}] {spec.unit}"
        )
    return v


@dataclass(frozen=True)
class Design:
    """What the page's controls set (SI units).

    Attributes
    ----------
    moduli : the five calibrated Young's moduli (Pa) by :data:`MODULI` name
    dims : the dimensions of :data:`GEOMETRY_FIELDS` (m); the others keep the default geometry's
    joint : "bonded" or "sliding"
    pressure_pa : the static load on the incus's −x face (Pa)
    """

    moduli: Mapping[str, float] = field(
        default_factory=lambda: {k: Materials().youngs(k[:-5]) for k in MODULI}
    )
    dims: Mapping[str, float] = field(
        default_factory=lambda: {k: getattr(Geometry(), k) for k in GEOMETRY_FIELDS}
    )
    joint: str = "bonded"
    pressure_pa: float = DEFAULT_PRESSURE_PA

    def __post_init__(self):
        if self.joint not in JOINTS:
            raise InvalidParameter(f"joint = {self.joint!r}: must be one of {', '.join(JOINTS)}")
        self.geometry()  # a dimension out of its bounds, or inconsistent ones: one line now

    @classmethod
    def case(cls, name: str) -> Design:
        """The defaults, or one of the seven thesis cases (docs/model.md §2.5) by name."""
        if name == "defaults":
            return cls()
        for c in THESIS_CASES:
            if c.name == name:
                m = c.materials()
                return cls(moduli={k: m.youngs(k[:-5]) for k in MODULI})
        raise InvalidParameter(
            f"case = {name!r}: must be defaults or one of {', '.join(c.name for c in THESIS_CASES)}"
        )

    def replace(self, name: str, value) -> Design:
        """This design with one field changed (a modulus, a dimension, ``joint`` or ``pressure_pa``)."""
        if name in MODULI:
            return dataclasses.replace(self, moduli={**self.moduli, name: float(value)})
        if name in GEOMETRY_FIELDS:
            return dataclasses.replace(self, dims={**self.dims, name: float(value)})
        if name in ("joint", "pressure_pa"):
            return dataclasses.replace(self, **{name: value})
        raise InvalidParameter(f"{name}: not a field of the design")

    def geometry(self) -> Geometry:
        """The joint model's :class:`Geometry` (m); raises one line for an invalid combination."""
        return Geometry(**dict(self.dims))

    def is_default_geometry(self) -> bool:
        return self.geometry() == Geometry()

    def model(self):
        """The shipped lumped model for this joint and geometry (the geometry calibration off the default)."""
        g = self.geometry()
        return _shipped(self.joint, None if g == Geometry() else g)

    def materials(self) -> Materials:
        return Materials(**dict(self.moduli))


def static_outputs(design: Design, rom=None) -> dict:
    """α, β (rad), β/α and the marks of ``design`` from the lumped model (``isj lumped solve``'s keys).

    Parameters
    ----------
    design : the page's design
    rom : the certified surrogate (:class:`isj.fem.rom.ReducedModel`) for this geometry, or None

    Returns
    -------
    dict : ``alpha_rad``, ``beta_rad``, ``alpha_plus_beta_rad``, ``beta_over_alpha``;
        ``outside_domain`` ({modulus: (value, low, high)} Pa), ``outside_geometry``
        ({dimension: (value, low, high)} m), ``region`` (None, or ``tolerance`` and ``inside``),
        ``surrogate`` (its values and bounds, rad) or None
    """
    from isj.calibration.region import in_region, region_of

    lm = design.model()
    r = lm.static(dict(design.moduli), pressure_pa=design.pressure_pa)
    out = {
        "alpha_rad": float(r.alpha_rad),
        "beta_rad": float(r.beta_rad),
        "alpha_plus_beta_rad": float(r.sum_rad),
        "beta_over_alpha": float(r.ratio),
    }
    dom = lm.domain
    out["outside_domain"] = {
        k: (v, *dom[k]) for k, v in design.moduli.items() if k in dom and not dom[k][0] <= v <= dom[k][1]
    }
    out["outside_geometry"] = dict(lm.outside_geometry)
    region = region_of(lm.calibration)
    inside = in_region(region, lm.calibration.domain, {k: np.atleast_1d(v) for k, v in design.moduli.items()})
    out["region"] = (
        None if inside is None else {"tolerance": float(region["tolerance"]), "inside": bool(inside[0])}
    )
    out["surrogate"] = surrogate_values(rom, design) if rom is not None else None
    return out


def surrogate_values(rom, design: Design) -> dict | None:
    """The certified surrogate's α, β, β/α and their bounds (rad) at ``design``; None outside its domain."""
    full = dataclasses.asdict(Materials().replace(**dict(design.moduli)))
    names = list(rom.space.bounds)
    for k in names:
        lo, hi = rom.space.bounds[k]
        if not lo <= full[k] <= hi:
            return None
    ev = rom.evaluate(np.array([[full[k] for k in names]]), design.pressure_pa)
    keys = (
        "alpha_rad",
        "beta_rad",
        "beta_over_alpha",
        "alpha_bound_rad",
        "beta_bound_rad",
        "beta_over_alpha_bound",
    )
    return {k: float(np.asarray(ev[k])[0]) for k in keys if k in ev}


def chain_bode(design: Design, n: int = 120) -> dict:
    """The isolated chain's |α|, |β| (rad) and phases (deg) over :data:`BODE_BAND_HZ` at the design's load."""
    f = np.geomspace(*BODE_BAND_HZ, n)
    lm = design.model()
    fr = lm.frequency_response(f, pressure_pa=design.pressure_pa, **design.moduli)
    H = np.asarray(fr.response)
    H = H.reshape(len(f), -1)
    names = list(fr.output_names)
    out = {"freq_hz": f}
    for k in ("alpha_rad", "beta_rad"):
        h = H[:, names.index(k)]
        out[f"{k}_abs"] = np.abs(h)
        out[f"{k}_phase_deg"] = np.degrees(np.unwrap(np.angle(h)))
    return out


def fast_ear_response(design: Design, freq_hz: np.ndarray):
    """Where the fast FE ear (``isj.fem.ear.fast_ear``) plugs in: H_V (m/s/Pa) of the design and rigid.

    Returns ``None`` until that ear exists; then ``(h_v, h_v_rigid)``, complex arrays over
    ``freq_hz`` up to 20 kHz, and :func:`ear_velocity` uses them in place of the lumped ear.
    """
    return None


@functools.lru_cache(maxsize=8)
def _rigid_ear(joint: str, geometry: Geometry | None, f_key: tuple) -> np.ndarray:
    lm = _shipped(joint, geometry)
    f = np.array(f_key)
    x = lm.ear(rigid_joint=True, drum_modes=LUMPED_EAR_DRUM_MODES).frequency_response(f).response
    return 2j * np.pi * f * np.asarray(x).reshape(len(f), -1)[:, 1]


def ear_velocity(design: Design, n: int = 60) -> dict:
    """The stapes velocity per ear-canal pressure H_V (m/s/Pa) and ΔH_V = H_V / H_V,rigid.

    From :func:`fast_ear_response` when it answers, else the lumped ear with
    :data:`LUMPED_EAR_DRUM_MODES` drum modes over :data:`LUMPED_EAR_BAND_HZ` (``source``
    says which, ``band_hz`` the band it holds in).
    """
    g = design.geometry()
    g = None if g == Geometry() else g
    f = np.geomspace(100.0, 20000.0, n)
    fast = fast_ear_response(design, f)
    if fast is not None:
        hv, rigid = (np.asarray(a) for a in fast)
        source, band = "FE ear (fast)", (100.0, 20000.0)
    else:
        f = np.geomspace(*LUMPED_EAR_BAND_HZ, n)
        lm = design.model()
        ear = lm.ear(drum_modes=LUMPED_EAR_DRUM_MODES, **design.moduli)
        x = np.asarray(ear.frequency_response(f).response).reshape(len(f), -1)[:, 1]
        hv = 2j * np.pi * f * x
        rigid = _rigid_ear(design.joint, g, tuple(f.tolist()))
        source, band = "lumped ear", LUMPED_EAR_BAND_HZ
    delta = hv / rigid
    return {
        "freq_hz": f,
        "h_v_abs": np.abs(hv),
        "delta_db": 20 * np.log10(np.abs(delta)),
        "delta_deg": np.degrees(np.angle(delta)),
        "source": source,
        "band_hz": band,
    }


def ratio_map(design: Design, x: str, y: str, n: int = 60) -> dict:
    """β/α over an n × n log grid of moduli ``x`` and ``y`` (calibrated domain), the rest as designed."""
    if x == y or x not in MODULI or y not in MODULI:
        raise InvalidParameter(f"map axes = {x}, {y}: must be two different moduli of {', '.join(MODULI)}")
    dom = calibrated_domain()
    xs, ys = np.geomspace(*dom[x], n), np.geomspace(*dom[y], n)
    X, Y = np.meshgrid(xs, ys)
    r = design.model().static({**design.moduli, x: X, y: Y}, pressure_pa=design.pressure_pa)
    return {"x": xs, "y": ys, "ratio": np.asarray(r.ratio), "current": (design.moduli[x], design.moduli[y])}


def uncertainty(design: Design, kinds: Mapping[str, str], factor: float, samples: int, seed: int = 0) -> dict:
    """The histogram of β/α and P(β/α > 1) for the page's distributions (docs/uq.md).

    Parameters
    ----------
    kinds : modulus → one of :data:`UQ_KINDS`: log-uniform over the calibrated domain,
        lognormal about the design's value with spread ``factor`` (σ = ln factor), or fixed
    factor : the lognormal's factor, > 1
    samples : draws, in [1000, :data:`MAX_UQ_SAMPLES`]
    """
    from isj.studies.uq import evaluate_outputs, lumped_evaluator, probability_interval, sample_moduli
    from isj.studies.uq_inputs import Distribution, UQConfig

    if not (isinstance(samples, int) and 1000 <= samples <= MAX_UQ_SAMPLES):
        # cut to 40 characters: a typed 400-digit number stays a one-line message
        raise InvalidParameter(
            f"samples = {str(samples)[:40]}: must be an integer in [1000, {MAX_UQ_SAMPLES}]"
        )
    if not (isinstance(factor, int | float) and math.isfinite(factor) and 1 < factor <= math.exp(3)):
        raise InvalidParameter(f"factor = {factor!r}: must be a number in (1, {math.exp(3):.4g}]")
    dom = calibrated_domain()
    base = Materials().replace(**dict(design.moduli))
    dists = {"incus_e_pa": Distribution.fixed(base.incus_e_pa, name="incus_e_pa")}
    for k in MODULI:
        kind = kinds.get(k, "fixed")
        if kind == "loguniform":
            dists[k] = Distribution.loguniform(*dom[k], name=k)
        elif kind == "lognormal":
            dists[k] = Distribution.lognormal(design.moduli[k], factor=factor, name=k)
        elif kind == "fixed":
            dists[k] = Distribution.fixed(design.moduli[k], name=k)
        else:
            raise InvalidParameter(f"{k} distribution = {kind!r}: must be one of {', '.join(UQ_KINDS)}")
    cfg = UQConfig(dists, samples=samples, seed=seed)
    out = evaluate_outputs(lumped_evaluator(design.model(), design.pressure_pa), sample_moduli(cfg))
    ratio = out["beta_over_alpha"]
    k = int(np.count_nonzero(ratio > 1))
    counts, edges = np.histogram(np.log10(ratio), bins=50)
    return {
        "log10_edges": edges,
        "counts": counts,
        "p_gt_1": k / samples,
        "p_interval": probability_interval(k, samples),
        "samples": samples,
    }


def case_toml(design: Design, resolution: float = 1.0) -> str:
    """The design as a case file for ``isj report --config`` (docs/user-guide.md §6.5)."""
    lines = ["# isj case file written by isj app", "[design]"]
    lines += [f"{k} = {v!r}" for k, v in design.moduli.items()]
    lines.append(f"pressure_pa = {float(design.pressure_pa)!r}")
    g = design.geometry()
    changed = {
        f.name: getattr(g, f.name)
        for f in dataclasses.fields(g)
        if getattr(g, f.name) != getattr(Geometry(), f.name)
    }
    if changed:
        lines += ["", "[geometry]"] + [f"{k} = {v!r}" for k, v in changed.items()]
    lines += ["", "[mesh]", f"resolution = {float(resolution)!r}"]
    if design.joint == "sliding":
        lines += [
            "",
            "# the sliding joint: the report computes every case bonded and sliding",
            "[sliding]",
            'joints = ["bonded", "sliding"]',
        ]
    return "\n".join(lines) + "\n"


def report_command(filename: str = "isj-case.toml") -> str:
    """The command line that makes the report of an exported case file."""
    return f"isj report --config {filename} --out report-{filename.removesuffix('.toml')}"
