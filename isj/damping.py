"""Damping per material (docs/dynamics.md §4.3): loss factors, Rayleigh terms, dashpots, the cochlea.

One :class:`Damping` describes the losses of every model in isj, the isolated
pedicle-and-joint model and the whole ear, FE and lumped alike:

- each FE region of the joint model (:data:`isj.design.REGIONS`: stapes head,
  gap, plate, pedicle, incus, capsule) and each shell of the ear (``eardrum``,
  ``footplate``) has a loss factor η (complex modulus E (1 + iη)) and Rayleigh
  coefficients a (1/s, on its mass) and b (s, on its stiffness);
- each spring set of the ear (``mallear_ligament``, ``incudal_ligaments``,
  ``annular_ligament``) has a loss factor and a dashpot in parallel with each of
  its springs, c = b k (b in s);
- the cochlea loads the footplate with a resistance in parallel with the annular
  springs: its acoustic input impedance Z_C (Pa·s/m³), converted with the footplate
  area A into R = Z_C A² (N·s/m) along the piston direction.

The dynamic stiffness of a model with stiffness K = Σ_r K_r and mass M = Σ_r M_r
(per region or part r) is then

    Z(ω) = Σ_r (1 + iη_r + iω b_r) K_r + iω Σ_r a_r M_r + iω R n nᵀ − ω² M.

Defaults (:meth:`Damping.preset` ``"published"``) are constant loss factors of
published middle-ear models; docs/dynamics.md §4.3 cites each one. The preset
``"uniform-rayleigh"`` is the old convention (b = 1e-4 s on everything, no cochlear
resistance), kept for comparison; ``"undamped"`` has no losses at all.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from isj.design import BONE_REGIONS, REGIONS
from isj.errors import DampingWarning, InvalidParameter

#: The ear's shells (the drum and the footplate), besides the joint model's regions.
EAR_PARTS: tuple[str, ...] = ("eardrum", "footplate")
#: The ear's spring sets: a loss factor and a dashpot c = b k in parallel with each spring.
SPRING_SETS: tuple[str, ...] = ("mallear_ligament", "incudal_ligaments", "annular_ligament")
#: Everything with a mass: Rayleigh a applies to these (in the ear the malleus–incus body takes
#: the incus's a, the stapes superstructure the stapes's).
MASS_PARTS: tuple[str, ...] = REGIONS + EAR_PARTS
#: Everything with a stiffness: loss factor and Rayleigh b apply to these.
STIFFNESS_PARTS: tuple[str, ...] = MASS_PARTS + SPRING_SETS

#: Loss factor of bone (incus, pedicle, plate, stapes head, footplate): 0.01, the ossicles' constant
#: loss factor of a published middle-ear FE model (docs/dynamics.md §4.3).
BONE_LOSS_FACTOR = 0.01
#: Loss factor of the incudostapedial joint's gap and capsule: 0.15 (docs/dynamics.md §4.3).
JOINT_LOSS_FACTOR = 0.15
#: Loss factor of the eardrum: 0.1, inside the range 0.01–0.13 of De Greef et al. 2014 (a choice).
EARDRUM_LOSS_FACTOR = 0.1
#: Loss factors of the ligaments (docs/dynamics.md §4.3).
LIGAMENT_LOSS_FACTORS = {"mallear_ligament": 0.3, "incudal_ligaments": 0.15, "annular_ligament": 0.3}
#: Cat cochlear input impedance, resistive between 0.5 and 5 kHz: |Z_C| ≈ 1.2e6 dyn·s/cm⁵
#: = 1.2e11 Pa·s/m³ (Lynch, Nedzelnitsky & Peake 1982, JASA 72:108).
CAT_COCHLEAR_IMPEDANCE_PA_S_M3 = 1.2e11

#: Names of :meth:`Damping.preset`.
PRESETS: tuple[str, ...] = ("published", "uniform-rayleigh", "undamped")

#: ωb or a/ω above this inside a band draws a :class:`isj.errors.DampingWarning`.
RAYLEIGH_WARN_LEVEL = 0.5

_KINDS = {  # field -> (names it applies to, unit)
    "loss_factor": (STIFFNESS_PARTS, ""),
    "rayleigh_a_per_s": (MASS_PARTS, " 1/s"),
    "rayleigh_b_s": (STIFFNESS_PARTS, " s"),
}


def _published_loss_factor(name: str) -> float:
    if name in BONE_REGIONS or name == "footplate":
        return BONE_LOSS_FACTOR
    if name in ("gap", "capsule"):
        return JOINT_LOSS_FACTOR
    if name == "eardrum":
        return EARDRUM_LOSS_FACTOR
    return LIGAMENT_LOSS_FACTORS[name]


def _check_value(field: str, name: str | None, value) -> float:
    where = field if name is None else f"{field}[{name!r}]"
    unit = _KINDS[field][1] if field in _KINDS else " Pa·s/m^3"
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value < 0:
        raise InvalidParameter(f"{where} = {value!r}{unit}: must be a finite number >= 0")
    return float(value)


def _resolve(field: str, value, base: Mapping[str, float]) -> MappingProxyType:
    """A full read-only mapping name → value: ``value`` a number (every name), a mapping, or None."""
    names = _KINDS[field][0]
    if value is None:
        return MappingProxyType(dict(base))
    if isinstance(value, Mapping):
        unknown = sorted(set(value) - set(names))
        if unknown:
            raise InvalidParameter(
                f"{field}[{unknown[0]!r}]: unknown name; must be one of {', '.join(names)}"
            )
        out = dict(base)
        out.update({k: _check_value(field, k, v) for k, v in value.items()})
        return MappingProxyType(out)
    v = _check_value(field, None, value)
    return MappingProxyType(dict.fromkeys(names, v))


_PUBLISHED = {
    "loss_factor": {n: _published_loss_factor(n) for n in STIFFNESS_PARTS},
    "rayleigh_a_per_s": dict.fromkeys(MASS_PARTS, 0.0),
    "rayleigh_b_s": dict.fromkeys(STIFFNESS_PARTS, 0.0),
}


@dataclass(frozen=True)
class Damping:
    """Damping of every region, ear part and spring set (SI; module docstring for the law).

    Parameters
    ----------
    rayleigh_a_per_s : Rayleigh mass coefficient a (1/s) per region/part (:data:`MASS_PARTS`)
    rayleigh_b_s : Rayleigh stiffness coefficient b (s) per region, part or spring set
        (:data:`STIFFNESS_PARTS`); on a spring set, a dashpot c = b k in parallel with each spring
    loss_factor : loss factor η (dimensionless) per region, part or spring set
    cochlear_impedance_pa_s_m3 : the cochlea's acoustic input resistance Z_C (Pa·s/m³), in
        parallel with the annular springs as R = Z_C A² along the piston direction

    Notes
    -----
    Each of the first three is None (the published defaults), a number (that value for every
    name it applies to) or a mapping name → value (those names changed, the others at their
    published defaults). ``Damping()`` is the published default, :meth:`preset` gives the named
    ones, :meth:`uniform` the old one-value-everywhere convention, :meth:`replace` changes some
    values of an existing damping. After construction each field is a read-only mapping holding
    every name.
    """

    rayleigh_a_per_s: Mapping[str, float] | float | None = None
    rayleigh_b_s: Mapping[str, float] | float | None = None
    loss_factor: Mapping[str, float] | float | None = None
    cochlear_impedance_pa_s_m3: float | None = None

    def __post_init__(self) -> None:
        for field in _KINDS:
            object.__setattr__(self, field, _resolve(field, getattr(self, field), _PUBLISHED[field]))
        z = self.cochlear_impedance_pa_s_m3
        z = (
            CAT_COCHLEAR_IMPEDANCE_PA_S_M3
            if z is None
            else _check_value("cochlear_impedance_pa_s_m3", None, z)
        )
        object.__setattr__(self, "cochlear_impedance_pa_s_m3", z)

    def __reduce__(self):  # the read-only mappings do not pickle; the tables do
        return (Damping.from_dict, (self.to_dict(),))

    def check_names(self, names) -> None:
        """InvalidParameter unless every one of ``names`` (a model's regions or parts) has a damping."""
        unknown = sorted(set(names) - set(STIFFNESS_PARTS))
        if unknown:
            raise InvalidParameter(
                f"region {unknown[0]!r} has no damping: regions must be among {', '.join(STIFFNESS_PARTS)}"
            )

    def __hash__(self) -> int:
        return hash(
            tuple(tuple(getattr(self, f).items()) for f in _KINDS) + (self.cochlear_impedance_pa_s_m3,)
        )

    # ---- construction ---------------------------------------------------------------------

    @classmethod
    def preset(cls, name: str) -> Damping:
        """A named damping: ``"published"`` (the default), ``"uniform-rayleigh"`` (b = 1e-4 s on
        every region, part and spring set, no loss factor, no cochlear resistance: the old
        default) or ``"undamped"``."""
        if name == "published":
            return cls()
        if name == "uniform-rayleigh":
            return cls.uniform(rayleigh_b_s=1e-4)
        if name == "undamped":
            return cls.uniform()
        raise InvalidParameter(f"damping preset = {name!r}: must be one of {', '.join(PRESETS)}")

    @classmethod
    def uniform(
        cls,
        rayleigh_a_per_s: float = 0.0,
        rayleigh_b_s: float = 0.0,
        loss_factor: float = 0.0,
        cochlear_impedance_pa_s_m3: float = 0.0,
    ) -> Damping:
        """One a (1/s), b (s) and η for everything, and no cochlear resistance unless given."""
        return cls(rayleigh_a_per_s, rayleigh_b_s, loss_factor, cochlear_impedance_pa_s_m3)

    def replace(self, **changes) -> Damping:
        """A copy with some values changed: a number sets every name of its field, a mapping some names."""
        unknown = sorted(set(changes) - {*_KINDS, "cochlear_impedance_pa_s_m3"})
        if unknown:
            raise InvalidParameter(f"damping: unknown field {unknown[0]!r}")
        kw = {f: _resolve(f, changes.get(f), getattr(self, f)) for f in _KINDS}
        z = changes.get("cochlear_impedance_pa_s_m3", self.cochlear_impedance_pa_s_m3)
        return Damping(**kw, cochlear_impedance_pa_s_m3=z)

    # ---- queries --------------------------------------------------------------------------

    def uniform_values(self, names=REGIONS) -> tuple[float, float, float] | None:
        """(a, b, η) when all of ``names`` share the three values (proportional damping), else None."""
        a = {self.rayleigh_a_per_s[n] for n in names if n in self.rayleigh_a_per_s}
        b = {self.rayleigh_b_s[n] for n in names}
        eta = {self.loss_factor[n] for n in names}
        if len(a) > 1 or len(b) > 1 or len(eta) > 1:
            return None
        return (a.pop() if a else 0.0), b.pop(), eta.pop()

    def damped(self, names=STIFFNESS_PARTS, cochlea: bool = True) -> bool:
        """Whether any of ``names`` (or the cochlea) dissipates energy."""
        return (cochlea and self.cochlear_impedance_pa_s_m3 > 0) or any(
            self.loss_factor[n] > 0 or self.rayleigh_b_s[n] > 0 or self.rayleigh_a_per_s.get(n, 0.0) > 0
            for n in names
        )

    def cochlear_resistance_n_s_m(self, footplate_area_m2: float) -> float:
        """R = Z_C A² (N·s/m): the cochlea's resistance on the footplate's piston motion."""
        return self.cochlear_impedance_pa_s_m3 * footplate_area_m2**2

    def effective_loss_factor(self, name: str, freq_hz: float) -> float:
        """η + ωb + a/ω of one region, part or spring set at ``freq_hz`` (> 0) Hz."""
        w = 2 * math.pi * freq_hz
        return self.loss_factor[name] + w * self.rayleigh_b_s[name] + self.rayleigh_a_per_s.get(name, 0.0) / w

    def rayleigh_excesses(self, fmin_hz: float, fmax_hz: float, names=STIFFNESS_PARTS) -> list[str]:
        """A line per Rayleigh term whose ωb or a/ω exceeds :data:`RAYLEIGH_WARN_LEVEL` in [fmin, fmax] Hz."""
        lvl = RAYLEIGH_WARN_LEVEL
        by_b: dict[float, list[str]] = {}
        by_a: dict[float, list[str]] = {}
        for n in names:
            b, a = self.rayleigh_b_s[n], self.rayleigh_a_per_s.get(n, 0.0)
            if b > 0 and 2 * math.pi * fmax_hz * b > lvl:
                by_b.setdefault(b, []).append(n)
            if a > 0 and (fmin_hz <= 0 or a / (2 * math.pi * fmin_hz) > lvl):
                by_a.setdefault(a, []).append(n)
        out = [
            f"rayleigh_b_s = {b:g} s ({', '.join(ns)}): omega*b > {lvl:g} "
            f"above {lvl / (2 * math.pi * b):.4g} Hz"
            for b, ns in by_b.items()
        ]
        out += [
            f"rayleigh_a_per_s = {a:g} 1/s ({', '.join(ns)}): a/omega > {lvl:g} "
            f"below {a / (2 * math.pi * lvl):.4g} Hz"
            for a, ns in by_a.items()
        ]
        return out

    def to_dict(self) -> dict:
        """Every value, JSON-ready: the three per-name tables and the cochlear impedance."""
        return {f: dict(getattr(self, f)) for f in _KINDS} | {
            "cochlear_impedance_pa_s_m3": self.cochlear_impedance_pa_s_m3
        }

    @classmethod
    def from_dict(cls, d: Mapping) -> Damping:
        """Inverse of :meth:`to_dict` (missing names at their published defaults)."""
        unknown = sorted(set(d) - {*_KINDS, "cochlear_impedance_pa_s_m3"})
        if unknown:
            raise InvalidParameter(f"damping: unknown field {unknown[0]!r}")
        return cls(**dict(d))


def resolve(damping: Damping | str | None = None, **overrides) -> Damping:
    """A :class:`Damping` from a damping, its :meth:`Damping.to_dict`, a preset name or None
    (published), then ``overrides``.

    ``overrides``: ``rayleigh_a_per_s``, ``rayleigh_b_s``, ``loss_factor`` (numbers for every
    name, or mappings), ``cochlear_impedance_pa_s_m3``; None values are ignored. The legacy
    keyword arguments of the models (``rayleigh_b_s=...``) come through here.
    """
    if isinstance(damping, Mapping):
        damping = Damping.from_dict(damping)
    d = Damping.preset(damping) if isinstance(damping, str) else (damping or Damping())
    if not isinstance(d, Damping):
        raise InvalidParameter(
            f"damping: must be an isj.damping.Damping or a preset name, not {type(d).__name__}"
        )
    changes = {k: v for k, v in overrides.items() if v is not None}
    return d.replace(**changes) if changes else d


def warn_rayleigh_band(damping: Damping, fmin_hz: float, fmax_hz: float, names=STIFFNESS_PARTS) -> list[str]:
    """Warn (:class:`isj.errors.DampingWarning`) when a Rayleigh term is large in the band; the lines."""
    lines = damping.rayleigh_excesses(fmin_hz, fmax_hz, names)
    if lines:
        warnings.warn(
            f"Rayleigh damping dominates inside {fmin_hz:g}-{fmax_hz:g} Hz (the damping law, not the "
            "structure, shapes the response there): " + "; ".join(lines),
            DampingWarning,
            stacklevel=3,
        )
    return lines
