"""The report's configuration: TOML case files loaded into frozen dataclasses.

Every key carries its unit in its name (``pedicle_e_pa``, ``fmax_hz``). A case
file holds any subset of the sections below; what it leaves out takes the
built-in default. Command-line ``--set SECTION.KEY=VALUE`` overrides the file.
An unknown section or key, or a bad value, raises :class:`ConfigError` (a
``ValueError``) with one line naming it, before anything is computed or written.

Example::

    [design]
    pedicle_e_pa = 12e9

    [sweep]
    fmax_hz = 40e3
    fe_checks = 3

    [ear]
    drum_e_pa = 30e6
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import ClassVar

from isj.cases import THESIS_CASES
from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials
from isj.ear import DEFAULT_DRUM_MESH_SIZE_M, EarMaterials
from isj.errors import (
    ConfigError,
    InvalidParameter,
)
from isj.validate import (
    DRUM_MESH_SIZE_RANGE_M,
    EAR_FMAX_HZ,
    TRANSMISSION_SAMPLES_RANGE,
    TRANSMISSION_SOBOL_SAMPLES_RANGE,
    check_band,
    check_damping,
    check_modulus,
    check_pressure,
    loads_toml,
    read_toml,
)


@dataclass(frozen=True)
class DesignConfig(Materials):
    """The [design] section: the base design's :class:`~isj.design.Materials` and the pressure on the incus.

    The moduli (Pa) and ν are Materials' own fields, with its defaults and its
    validation; ``pressure_pa`` (Pa) is the load. The section's keys are
    :attr:`CONFIG_KEYS`: the densities are not among them and keep Materials' defaults.
    """

    pressure_pa: float = DEFAULT_PRESSURE_PA

    #: The [design] keys, in the order the resolved configuration writes them.
    CONFIG_KEYS: ClassVar[tuple[str, ...]] = (
        "pedicle_e_pa",
        "gap_e_pa",
        "capsule_e_pa",
        "plate_e_pa",
        "stapes_e_pa",
        "incus_e_pa",
        "nu",
        "pressure_pa",
    )

    def materials(self) -> Materials:
        """The base design without the load, as a plain :class:`~isj.design.Materials`."""
        return Materials(**{f.name: getattr(self, f.name) for f in fields(Materials)})

    def moduli(self) -> dict[str, float]:
        """The Young's moduli as a design dict for the lumped model and the FE runner (Pa)."""
        return {k: getattr(self, k) for k in self.CONFIG_KEYS if k.endswith("_e_pa")}


@dataclass(frozen=True)
class MeshConfig:
    """FE discretisation of every FE step but the convergence study.

    ``order`` and ``resolution``: the joint model's elements. ``drum_mesh_size_m``: the FE
    ear's eardrum element size, read by the steps with the FE ear (ear, transmission, uq); the
    default is the coarsest converged drum (docs/ear.md §5.15).
    """

    order: int = 2
    resolution: float = 1.0
    drum_mesh_size_m: float = DEFAULT_DRUM_MESH_SIZE_M


@dataclass(frozen=True)
class TrendsConfig:
    """Lumped curves of α, β, β/α against one modulus at a time, over the calibrated domain."""

    moduli: tuple[str, ...] = ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa")
    n_lumped: int = 61
    fe_points: int = 3


@dataclass(frozen=True)
class GeometryTrendsConfig:
    """β against the pedicle's thickness, α against the gap's, over the geometry calibration's range.

    ``n_lumped`` points per lumped curve; FE at the report's geometry and ``fe_points`` values
    spread log-evenly over the range, its ends included (0: only the report's geometry).
    """

    n_lumped: int = 41
    fe_points: int = 2


@dataclass(frozen=True)
class ConvergenceConfig:
    """The pedicle cantilever against Timoshenko (docs/model.md §2.6): orders and load directions."""

    orders: tuple[int, ...] = (1, 2)
    directions: tuple[str, ...] = ("x", "y")


@dataclass(frozen=True)
class CalibrationConfig:
    """Which calibration the report uses and how many fresh FE designs check it.

    ``file = ""`` means the calibration shipped with isj. The check designs are
    a scrambled Sobol sample of the calibrated domain drawn with ``seed``; the
    shipped calibration was trained and validated on seed 0.
    """

    file: str = ""
    check_samples: int = 8
    seed: int = 2026


def _damping_tables(name: str = "published") -> dict:
    from isj.damping import Damping

    return Damping.preset(name).to_dict()


@dataclass(frozen=True)
class SweepConfig:
    """Frequency response (docs/dynamics.md §4): band, damping, FE spot checks, modes.

    The damping (docs/dynamics.md §4.3, :class:`isj.damping.Damping`): ``damping`` names a
    preset (``published``, ``uniform-rayleigh``, ``undamped``); ``loss_factor``,
    ``rayleigh_a_per_s`` and ``rayleigh_b_s`` change it, each a number (every region, ear part and
    spring set) or a table by name (``loss_factor = {gap = 0.2}``), and
    ``cochlear_impedance_pa_s_m3`` sets the cochlear resistance. The resolved configuration
    lists every value.
    """

    fmin_hz: float = 100.0
    fmax_hz: float = 40e3
    n_freq: int = 300
    fe_checks: int = 2
    damping: str = "published"
    rayleigh_a_per_s: dict = field(default_factory=lambda: _damping_tables()["rayleigh_a_per_s"])
    rayleigh_b_s: dict = field(default_factory=lambda: _damping_tables()["rayleigh_b_s"])
    loss_factor: dict = field(default_factory=lambda: _damping_tables()["loss_factor"])
    cochlear_impedance_pa_s_m3: float = field(
        default_factory=lambda: _damping_tables()["cochlear_impedance_pa_s_m3"]
    )
    n_modes: int = 6

    #: The damping's keys, resolved by :meth:`resolve_values` before the section is built.
    DAMPING_KEYS: ClassVar[tuple[str, ...]] = (
        "rayleigh_a_per_s",
        "rayleigh_b_s",
        "loss_factor",
        "cochlear_impedance_pa_s_m3",
    )

    @classmethod
    def resolve_values(cls, values: dict) -> dict:
        """The file's keys with the damping resolved: the preset's tables, then the keys given."""
        from isj.damping import Damping

        values = dict(values)
        preset = values.get("damping", "published")
        if not isinstance(preset, str):
            raise ConfigError(f"sweep.damping = {preset!r}: must be a preset name (a string)")
        try:
            d = Damping.preset(preset)
            for k in cls.DAMPING_KEYS:
                if k in values:
                    v = values[k]
                    if isinstance(v, bool) or not isinstance(v, int | float | dict):
                        raise ConfigError(
                            f"sweep.{k} = {v!r}: must be a number or a table of numbers by name"
                        )
                    d = d.replace(**{k: v})
        except InvalidParameter as exc:
            raise ConfigError(f"sweep.{exc}") from None
        return values | {k: v for k, v in d.to_dict().items()}

    def damping_model(self):
        """The resolved :class:`isj.damping.Damping`."""
        from isj.damping import Damping

        return Damping.from_dict({k: getattr(self, k) for k in self.DAMPING_KEYS})


@dataclass(frozen=True)
class TransmissionConfig:
    """The whole ear over a band, per thesis case and rigid (docs/transmission.md).

    Each case in ``cases`` comes from the fast ear (:mod:`isj.fem.ear.fast_ear`, built once per mesh and
    ear and cached) where it covers the case's materials, else from its own reduced FE ear
    (:func:`isj.fem.ear.reduced_ear.reduced_ear`), beside the rigid incus–stapes connection (an FE
    reduction). The fast ear is compared with the rigid connection's FE reduction over the band, and
    ``fe_checks`` direct harmonic solves, the highest at ``fmax_hz``, check the first case as the step
    computed it (the fast ear's or its FE reduction's). ``fast_ear_check``: "direct" (as above) or "band"
    (the first case also reduced with FE, the fast ear compared with it over the band, and the direct
    solves checking that reduction: one more reduction, about 10 s on 2 cores). ``cases_from``: "fast"
    (as above) or "fe" (every case its own FE reduction, no fast ear: for one or two cases, where
    building the fast ear costs more than it saves). ``sliding_cases`` are computed again with the
    sliding joint (docs/model.md §2.12), as ``<case>_sliding``, from the sliding joint's own fast ear in
    the same way. The damping is the ``[sweep]`` section's. ``cavities``:
    the middle-ear cavity states computed beside the open ear and compared with the published cat circuit,
    "open", "intact" or "both" (docs/circuit.md §13.3: the ear's own default state is open,
    :data:`isj.cavities.DEFAULT_CAVITIES`, and every other number of the step is the open ear's; the
    report shows both states by default, §13.4). The intact state is a post-processing of the same reduced
    ears, no new reduction.
    """

    fmin_hz: float = 100.0
    fmax_hz: float = 20e3
    n_freq: int = 200
    cases: tuple[str, ...] = ("base", "j5", "c20", "c100", "j5c20", "p12", "p3")
    fe_checks: int = 2
    sliding_cases: tuple[str, ...] = ("base",)
    cavities: str = "both"
    cases_from: str = "fast"
    fast_ear_check: str = "direct"


@dataclass(frozen=True)
class SlidingConfig:
    """The seven thesis cases with the joint bonded and sliding (docs/model.md §2.12).

    ``joints`` among ``bonded``, ``sliding`` (a frictionless gap–plate face) and ``layer`` (a
    gap of low through-thickness shear modulus ``layer_shear_pa``, Pa, an estimate). On the
    report's mesh, geometry and design.
    """

    joints: tuple[str, ...] = ("bonded", "sliding")
    layer_shear_pa: float = 1e3


@dataclass(frozen=True)
class GuardConfig:
    """The lumped model checked against the certified surrogate over the calibrated domain.

    The surrogate of the report's mesh is built once (minutes) and cached (docs/rom.md §10.6);
    the corners and ``dense_samples`` Sobol designs (``seed``) go through it, and FE runs at the
    ``fe_checks`` worst (docs/rom.md §10.10). ``tolerance``: the lumped model's largest
    certified relative error of a design called ``ok``.
    """

    dense_samples: int = 4096
    seed: int = 0
    fe_checks: int = 2
    tolerance: float = 0.03


#: ``isj uq``'s ranges (isj.studies.uq_inputs; a test checks they are the same), here so
#: that the configuration does not import the lumped model (step cache keys follow imports).
UQ_RANGES = {
    "samples": (1_000, 10_000_000),
    "sobol_samples": (2**6, 2**18),
    "bootstrap": (10, 10_000),
    "seed": (0, 2**32 - 1),
}


@dataclass(frozen=True)
class UQReportConfig:
    """The moduli's uncertainty on the lumped model (docs/uq.md §11.7): counts and seed.

    The distributions are ``isj uq``'s defaults: log-uniform over the calibration's domain,
    the incus fixed (docs/uq.md §11.2); ``isj uq --config`` takes others. ``transmission_samples``
    draws (the first of the α/β draws; 0: none) and ``transmission_sobol_samples`` Saltelli base
    samples carry the same distributions to ΔH_V through the fast ear of the transmission step
    (docs/uq.md §11.10), on the report's mesh, ear and damping.
    """

    samples: int = 1_000_000
    sobol_samples: int = 2**14
    bootstrap: int = 100
    seed: int = 0
    transmission_samples: int = 4096
    transmission_sobol_samples: int = 2**8


@dataclass(frozen=True)
class ReportConfig:
    """Everything ``isj report`` computes from; ``geometry`` in metres (docs/model.md §2.2).

    ``ear`` holds the whole ear's eardrum, footplate and spring constants (docs/ear.md §5.8,
    :class:`isj.ear.EarMaterials`); its anatomy is :class:`isj.ear.EarGeometry`'s default.
    """

    design: DesignConfig = field(default_factory=DesignConfig)
    geometry: Geometry = field(default_factory=Geometry)
    mesh: MeshConfig = field(default_factory=MeshConfig)
    trends: TrendsConfig = field(default_factory=TrendsConfig)
    geometry_trends: GeometryTrendsConfig = field(default_factory=GeometryTrendsConfig)
    convergence: ConvergenceConfig = field(default_factory=ConvergenceConfig)
    calibration: CalibrationConfig = field(default_factory=CalibrationConfig)
    sweep: SweepConfig = field(default_factory=SweepConfig)
    ear: EarMaterials = field(default_factory=EarMaterials)
    transmission: TransmissionConfig = field(default_factory=TransmissionConfig)
    sliding: SlidingConfig = field(default_factory=SlidingConfig)
    guard: GuardConfig = field(default_factory=GuardConfig)
    uq: UQReportConfig = field(default_factory=UQReportConfig)

    def to_dict(self) -> dict[str, dict]:
        return {f.name: _section_dict(getattr(self, f.name)) for f in fields(self)}

    def to_toml(self) -> str:
        """The resolved configuration as TOML (every key, defaults included)."""
        lines = ["# isj report: resolved configuration (SI units; the unit is in each key)"]
        for section, values in self.to_dict().items():
            lines += ["", f"[{section}]"]
            lines += [f"{k} = {_toml_value(v)}" for k, v in values.items()]
        return "\n".join(lines) + "\n"


_SECTIONS = {f.name: f for f in fields(ReportConfig)}


def _section_keys(obj) -> tuple[str, ...]:
    """A section's configuration keys: its fields, unless it names them (:attr:`DesignConfig.CONFIG_KEYS`)."""
    return getattr(obj, "CONFIG_KEYS", None) or tuple(f.name for f in fields(obj))


def _section_dict(obj) -> dict:
    return {k: getattr(obj, k) for k in _section_keys(obj)}


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, tuple | list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):  # an inline table (the damping's values by name)
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _coerce(where: str, value, default):
    """``value`` as the type of ``default``, or ConfigError naming ``where``."""
    if isinstance(default, bool) or isinstance(value, bool):
        raise ConfigError(f"{where} = {value!r}: booleans are not accepted here")
    if isinstance(default, float):
        if not isinstance(value, int | float) or not math.isfinite(value):
            raise ConfigError(f"{where} = {value!r}: must be a finite number")
        return float(value)
    if isinstance(default, int):
        if not isinstance(value, int):
            raise ConfigError(f"{where} = {value!r}: must be an integer")
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(f"{where} = {value!r}: must be a string")
        return value
    if isinstance(default, tuple):
        if not isinstance(value, list | tuple) or not value:
            raise ConfigError(f"{where} = {value!r}: must be a non-empty list")
        return tuple(_coerce(where, v, default[0]) for v in value)
    if isinstance(default, dict):  # a table by name (resolved in full by the section first)
        if not isinstance(value, dict):
            raise ConfigError(f"{where} = {value!r}: must be a table")
        return {k: _coerce(f"{where}.{k}", v, 0.0) for k, v in value.items()}
    raise TypeError(default)


def _build_section(name: str, values: dict):
    cls_field = _SECTIONS[name]
    default = cls_field.default_factory()
    allowed = _section_dict(default)
    for key in values:
        if key not in allowed:
            raise ConfigError(f"unknown key {name}.{key}; valid keys of [{name}]: {', '.join(allowed)}")
    if hasattr(default, "resolve_values"):  # keys that depend on each other (the sweep's damping)
        values = default.resolve_values(values)
    coerced = {k: _coerce(f"{name}.{k}", v, allowed[k]) for k, v in values.items()}
    try:
        return dataclasses.replace(default, **coerced)
    except InvalidParameter as exc:  # Geometry and the design's Materials validate themselves
        where = "design." if name == "design" else f"[{name}] "
        raise ConfigError(f"{where}{exc}") from None


def _need(ok: bool, where: str, value, rule: str) -> None:
    if not ok:
        raise ConfigError(f"{where} = {value!r}: {rule}")


def _check(cfg: ReportConfig) -> None:
    """Ranges the dataclasses do not check themselves; one line per problem."""
    _check_design(cfg)
    _check_studies(cfg)
    _check_bands(cfg)
    _check_sliding(cfg)
    _check_guard_and_uq(cfg)


def _check_design(cfg: ReportConfig) -> None:
    """The design's moduli and pressure, and the mesh."""

    d = cfg.design  # its moduli and ν were checked by Materials on construction; here their ranges
    try:
        for k in d.moduli():
            check_modulus(getattr(d, k), f"design.{k}")
        check_pressure(d.pressure_pa, "design.pressure_pa")
    except InvalidParameter as exc:
        raise ConfigError(str(exc)) from None
    _need(cfg.mesh.order in (1, 2), "mesh.order", cfg.mesh.order, "must be 1 or 2")
    _need(0.2 <= cfg.mesh.resolution <= 4, "mesh.resolution", cfg.mesh.resolution, "must be in [0.2, 4]")
    lo, hi = DRUM_MESH_SIZE_RANGE_M
    size = cfg.mesh.drum_mesh_size_m
    _need(lo <= size <= hi, "mesh.drum_mesh_size_m", size, f"must be in [{lo}, {hi}] m")


def _check_studies(cfg: ReportConfig) -> None:
    """[trends], [geometry_trends], [convergence], [calibration]."""
    t = cfg.trends
    valid = ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa", "plate_e_pa", "stapes_e_pa")
    for m in t.moduli:
        _need(m in valid, "trends.moduli", m, f"each must be one of {', '.join(valid)}")
    _need(len(set(t.moduli)) == len(t.moduli), "trends.moduli", list(t.moduli), "must not repeat")
    _need(5 <= t.n_lumped <= 10_000, "trends.n_lumped", t.n_lumped, "must be in [5, 10000]")
    _need(0 <= t.fe_points <= 20, "trends.fe_points", t.fe_points, "must be in [0, 20]")
    gt = cfg.geometry_trends
    _need(5 <= gt.n_lumped <= 10_000, "geometry_trends.n_lumped", gt.n_lumped, "must be in [5, 10000]")
    _need(
        gt.fe_points in (0, *range(2, 9)), "geometry_trends.fe_points", gt.fe_points, "must be 0 or in [2, 8]"
    )
    for o in cfg.convergence.orders:
        _need(o in (1, 2), "convergence.orders", o, "each must be 1 or 2")
    for s in cfg.convergence.directions:
        _need(s in ("x", "y"), "convergence.directions", s, 'each must be "x" or "y"')
    c = cfg.calibration
    if c.file:
        _need(Path(c.file).is_file(), "calibration.file", c.file, "no such file")
    _need(0 <= c.check_samples <= 512, "calibration.check_samples", c.check_samples, "must be in [0, 512]")
    _need(c.seed >= 0, "calibration.seed", c.seed, "must be >= 0")


def _check_bands(cfg: ReportConfig) -> None:
    """[sweep] and [transmission]: their bands, the damping over both, the cases."""
    s = cfg.sweep
    _need(s.fmin_hz > 0, "sweep.fmin_hz", s.fmin_hz, "must be > 0 (Hz)")
    _need(s.fmax_hz > s.fmin_hz, "sweep.fmax_hz", s.fmax_hz, f"must be > sweep.fmin_hz = {s.fmin_hz:g} Hz")
    try:  # the isolated model's chain: its band (isj.validate.CHAIN_FMAX_HZ)
        check_band(s.fmin_hz, s.fmax_hz, ("sweep.fmin_hz", "sweep.fmax_hz"), model="chain")
    except InvalidParameter as exc:
        raise ConfigError(str(exc)) from None
    _need(2 <= s.n_freq <= 100_000, "sweep.n_freq", s.n_freq, "must be in [2, 100000]")
    _need(0 <= s.fe_checks <= 20, "sweep.fe_checks", s.fe_checks, "must be in [0, 20]")
    # the damping's values were checked by isj.damping.Damping when the section was resolved
    _need(1 <= s.n_modes <= 30, "sweep.n_modes", s.n_modes, "must be in [1, 30]")
    t = cfg.transmission
    _need(t.fmin_hz > 0, "transmission.fmin_hz", t.fmin_hz, "must be > 0 (Hz)")
    _need(
        t.fmin_hz < t.fmax_hz <= EAR_FMAX_HZ,
        "transmission.fmax_hz",
        t.fmax_hz,
        f"must be in ({t.fmin_hz:g}, {EAR_FMAX_HZ:g}] Hz (the drum is represented to 24 kHz only, "
        "isj.validate.EAR_FMAX_HZ)",
    )
    # the [sweep] damping serves the sweep and the transmission: its limits over both bands
    lo = "sweep" if s.fmin_hz <= t.fmin_hz else "transmission"
    hi = "sweep" if s.fmax_hz >= t.fmax_hz else "transmission"
    names = {
        "loss_factor": "sweep.loss_factor",
        "rayleigh_a": "sweep.rayleigh_a_per_s",
        "rayleigh_b": "sweep.rayleigh_b_s",
        "fmin": f"{lo}.fmin_hz",
        "fmax": f"{hi}.fmax_hz",
    }
    try:
        check_damping(s.damping_model(), min(s.fmin_hz, t.fmin_hz), max(s.fmax_hz, t.fmax_hz), names)
    except InvalidParameter as exc:
        raise ConfigError(str(exc)) from None
    _need(2 <= t.n_freq <= 2000, "transmission.n_freq", t.n_freq, "must be in [2, 2000]")
    _need(0 <= t.fe_checks <= 5, "transmission.fe_checks", t.fe_checks, "must be in [0, 5]")
    choices = ("open", "intact", "both")
    _need(t.cavities in choices, "transmission.cavities", t.cavities, 'must be "open", "intact" or "both"')
    _need(t.cases_from in ("fast", "fe"), "transmission.cases_from", t.cases_from, 'must be "fast" or "fe"')
    _need(
        t.fast_ear_check in ("direct", "band"),
        "transmission.fast_ear_check",
        t.fast_ear_check,
        'must be "direct" or "band"',
    )
    names = [c.name for c in THESIS_CASES]
    for c in t.cases:
        _need(c in names, "transmission.cases", c, f"each must be one of {', '.join(names)}")
    _need(len(set(t.cases)) == len(t.cases), "transmission.cases", list(t.cases), "must not repeat")
    for c in t.sliding_cases:
        _need(c in names, "transmission.sliding_cases", c, f"each must be one of {', '.join(names)}")
    _need(
        len(set(t.sliding_cases)) == len(t.sliding_cases),
        "transmission.sliding_cases",
        list(t.sliding_cases),
        "must not repeat",
    )


def _check_sliding(cfg: ReportConfig) -> None:
    """[sliding]: the joints and the layer's shear modulus."""
    sl = cfg.sliding
    for j in sl.joints:
        _need(
            j in ("bonded", "sliding", "layer"),
            "sliding.joints",
            j,
            'each must be "bonded", "sliding" or "layer"',
        )
    _need(len(set(sl.joints)) == len(sl.joints), "sliding.joints", list(sl.joints), "must not repeat")
    _need("bonded" in sl.joints, "sliding.joints", list(sl.joints), 'must include "bonded" (the reference)')
    g = sl.layer_shear_pa
    _need(1.0 <= g <= 1e9, "sliding.layer_shear_pa", g, "must be in [1, 1e9] Pa")


def _check_guard_and_uq(cfg: ReportConfig) -> None:
    """[guard] and [uq]."""
    gd = cfg.guard
    _need(0 <= gd.dense_samples <= 2**22, "guard.dense_samples", gd.dense_samples, f"must be in [0, {2**22}]")
    _need(0 <= gd.seed <= 2**32 - 1, "guard.seed", gd.seed, f"must be in [0, {2**32 - 1}]")
    _need(0 <= gd.fe_checks <= 20, "guard.fe_checks", gd.fe_checks, "must be in [0, 20]")
    _need(0 < gd.tolerance < 1, "guard.tolerance", gd.tolerance, "must be in (0, 1)")
    u = cfg.uq
    for key, (lo, hi) in UQ_RANGES.items():
        v = getattr(u, key)
        _need(lo <= v <= hi, f"uq.{key}", v, f"must be in [{lo}, {hi}]")
    n = u.sobol_samples
    _need(n & (n - 1) == 0, "uq.sobol_samples", n, "must be a power of 2 (Sobol' balance), e.g. 16384")
    lo, hi = TRANSMISSION_SAMPLES_RANGE
    n_t = u.transmission_samples
    _need(n_t == 0 or lo <= n_t <= hi, "uq.transmission_samples", n_t, f"must be 0 (none) or in [{lo}, {hi}]")
    lo, hi = TRANSMISSION_SOBOL_SAMPLES_RANGE
    n_t = u.transmission_sobol_samples
    _need(
        lo <= n_t <= hi and n_t & (n_t - 1) == 0,
        "uq.transmission_sobol_samples",
        n_t,
        f"must be a power of 2 in [{lo}, {hi}]",
    )
    _need(
        n_t * u.bootstrap <= 2**24,
        "uq.transmission_sobol_samples x uq.bootstrap",
        n_t * u.bootstrap,
        "must be <= 16777216 (memory of SALib's bootstrap)",
    )
    _need(
        n * u.bootstrap <= 2**24,
        "uq.sobol_samples x uq.bootstrap",
        n * u.bootstrap,
        "must be <= 16777216 (memory of SALib's bootstrap)",
    )


def parse_override(text: str) -> tuple[str, str, object]:
    """``"SECTION.KEY=VALUE"`` → (section, key, value); VALUE is read as TOML, else as a string."""
    lhs, sep, rhs = text.partition("=")
    section, dot, key = lhs.strip().partition(".")
    if not sep or not dot or not key:
        raise ConfigError(f"--set {text!r}: must be SECTION.KEY=VALUE, e.g. design.pedicle_e_pa=12e9")
    try:
        value = loads_toml(f"v = {rhs.strip()}", f"--set {lhs.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = rhs.strip()
    return section, key, value


def load_config(path: str | Path | None = None, overrides: list[str] = ()) -> ReportConfig:
    """Defaults, then the TOML file at ``path``, then ``--set`` overrides; validated.

    The file is validated on its own too, before the overrides: an invalid file is refused
    whatever ``--set`` replaces.

    Raises
    ------
    ConfigError
        Unreadable file, unknown section or key, bad value: one line naming it.
    """
    data: dict[str, dict] = {}
    if path is not None:
        data = read_toml(path)
    for name, values in data.items():
        if name not in _SECTIONS:
            raise ConfigError(f"unknown section [{name}]; valid sections: {', '.join(_SECTIONS)}")
        if not isinstance(values, dict):
            raise ConfigError(f"{name} = {values!r}: must be a [{name}] table")
    if path is not None and overrides:  # the file on its own, whatever --set then replaces
        _check(ReportConfig(**{name: _build_section(name, values) for name, values in data.items()}))
    data = {name: dict(values) for name, values in data.items()}
    for text in overrides:
        section, key, value = parse_override(text)
        if section not in _SECTIONS:
            raise ConfigError(f"--set {text!r}: unknown section {section!r}; valid: {', '.join(_SECTIONS)}")
        data.setdefault(section, {})[key] = value
    cfg = ReportConfig(**{name: _build_section(name, values) for name, values in data.items()})
    _check(cfg)
    return cfg
