"""The design space: a box of Young's moduli (Pa), log-scaled, with the incus modulus and ν fixed.

One class for the calibration (:mod:`isj.calibration.doe` samples it, the lumped model is
fitted on it) and the certified surrogate (:mod:`isj.fem.rom`, built on it). Its default
bounds are the plausible ranges of docs/lumped.md §3.5 (thesis §6.2.3–6.2.5), which are also
the shipped calibration's domain (``lumped/data/default_calibration.json``).

The moduli span one to two decades each, so a design space is a box of log-moduli: the unit
cube maps onto it by t ↦ exp(log lo + t log(hi / lo)). The incus modulus is not ranged (it is
far stiffer than everything it is loaded through, and the lumped model treats it as a rigid
block); it and ν are fixed per space, as they are per surrogate.

Whether a value lies inside a box is :func:`inside`, with one relative slack
(:data:`BOX_SLACK`) at the faces.

>>> space = DesignSpace()
>>> bool(inside(27e9, *space.pedicle_e_pa)), bool(inside(27.1e9, *space.pedicle_e_pa))
(True, False)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .design import REGIONS, Materials
from .errors import InvalidParameter
from .validate import check_poisson

Bounds = tuple[float, float]

#: Ranged moduli, in the column order of every array method.
RANGED: tuple[str, ...] = ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa", "plate_e_pa", "stapes_e_pa")

#: Relative slack at a box's faces: a value v lies inside [low, high] when
#: low (1 − BOX_SLACK) ≤ v ≤ high (1 + BOX_SLACK). It absorbs the last bits lost in the
#: log–exp map and in decimal round trips (a corner written as 5e9), and nothing a design
#: could mean: 1e-9 of a modulus is far below any physical resolution.
BOX_SLACK = 1e-9


def inside(value, low: float, high: float, slack: float = BOX_SLACK) -> np.ndarray:
    """Whether ``value`` (a number or an array) lies in [``low``, ``high``] up to the relative ``slack``.

    NaN is never inside. Returns a boolean array shaped as ``value`` (0-d for a number).
    """
    v = np.asarray(value, dtype=float)
    with np.errstate(invalid="ignore"):
        return (v >= low * (1 - slack)) & (v <= high * (1 + slack))


@dataclass(frozen=True)
class DesignSpace:
    """Box of Young's moduli (Pa), log-scaled, with the incus modulus and ν fixed.

    Each ranged field is ``(low, high)`` in Pa, with 0 < low ≤ high; ``low == high`` pins a
    modulus (the surrogate needs low < high). Defaults: docs/lumped.md §3.5.

    Parameters
    ----------
    pedicle_e_pa : bone, 1–27 GPa
    gap_e_pa : joint cartilage, 1–50 MPa
    capsule_e_pa : ligament, 10–300 MPa
    plate_e_pa : lenticular plate, 0.3–5 GPa
    stapes_e_pa : head of the stapes, 0.3–5 GPa
    incus_e_pa : the fixed incus modulus (Pa; default :class:`isj.design.Materials`')
    nu : Poisson's ratio of every region, in (-1, 0.5) (default :class:`isj.design.Materials`')

    Notes
    -----
    Two views of the same box. As mappings (the calibration): :meth:`designs_from_unit`,
    :meth:`columns_from_unit`, :meth:`contains`, :meth:`mid`. As (n, 5) arrays in
    :data:`RANGED` order (the surrogate): :meth:`from_unit`, :meth:`to_unit`, :meth:`check`,
    :meth:`theta`, :meth:`designs_from`, :meth:`corners`, :meth:`sample`.
    """

    pedicle_e_pa: Bounds = (1e9, 27e9)
    gap_e_pa: Bounds = (1e6, 50e6)
    capsule_e_pa: Bounds = (10e6, 300e6)
    plate_e_pa: Bounds = (0.3e9, 5e9)
    stapes_e_pa: Bounds = (0.3e9, 5e9)
    incus_e_pa: float = Materials().incus_e_pa
    nu: float = Materials().nu

    def __post_init__(self) -> None:
        for name in self.names:
            value = getattr(self, name)
            try:
                lo, hi = (float(v) for v in value)
            except (TypeError, ValueError):
                raise InvalidParameter(f"{name} = {value!r}: must be a pair (low, high) in Pa") from None
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise InvalidParameter(f"{name} = {value!r} Pa: must satisfy 0 < low <= high, both finite")
            # lists (from JSON) become tuples so that the space stays hashable
            object.__setattr__(self, name, (lo, hi))
        if "incus_e_pa" not in self.names:  # fixed, not ranged (a subclass may range it)
            incus = self.incus_e_pa
            number = isinstance(incus, int | float) and not isinstance(incus, bool)
            if not (number and math.isfinite(incus) and incus > 0):
                raise InvalidParameter(f"incus_e_pa = {incus!r} Pa: must be a finite number > 0")
            object.__setattr__(self, "incus_e_pa", float(incus))
        object.__setattr__(self, "nu", check_poisson(self.nu, "nu"))

    # ---- the box ----------------------------------------------------------------------

    @property
    def names(self) -> tuple[str, ...]:
        """The ranged moduli's names (:data:`RANGED`), in the column order of every method."""
        return RANGED

    @property
    def bounds(self) -> dict[str, Bounds]:
        """Ranged modulus name → (low, high), Pa."""
        return {n: getattr(self, n) for n in self.names}

    @property
    def lower(self) -> np.ndarray:
        """Lower bounds (Pa), one per :attr:`names`."""
        return np.array([getattr(self, n)[0] for n in self.names])

    @property
    def upper(self) -> np.ndarray:
        """Upper bounds (Pa), one per :attr:`names`."""
        return np.array([getattr(self, n)[1] for n in self.names])

    def mid(self) -> dict[str, float]:
        """Geometric mid-point √(low · high) of every modulus of :attr:`names` (Pa)."""
        return {n: float(math.sqrt(lo * hi)) for n, (lo, hi) in self.bounds.items()}

    def replace(self, **changes) -> DesignSpace:
        """A copy with some fields changed (bounds in Pa, ``incus_e_pa``, ``nu``)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, list[float]]:
        """The bounds, JSON-able: ``{name: [low_pa, high_pa]}`` (without the fixed incus and ν)."""
        return {n: list(getattr(self, n)) for n in self.names}

    @classmethod
    def from_dict(cls, data: Mapping, **fixed) -> DesignSpace:
        """Inverse of :meth:`to_dict`; a missing modulus takes its default bounds.

        ``fixed``: ``incus_e_pa`` and ``nu``, if not the defaults.
        """
        valid = cls().names
        unknown = set(data) - set(valid)
        if unknown:
            raise InvalidParameter(f"unknown design-space moduli {sorted(unknown)}; valid: {list(valid)}")
        return cls(**{k: tuple(v) for k, v in data.items()}, **fixed)

    def to_record(self) -> dict:
        """The box and its fixed moduli, JSON-able: ``{"bounds": ..., "incus_e_pa": ..., "nu": ...}``."""
        return {"bounds": self.to_dict(), "incus_e_pa": self.incus_e_pa, "nu": self.nu}

    @classmethod
    def from_record(cls, record: Mapping) -> DesignSpace:
        """Inverse of :meth:`to_record`."""
        return cls.from_dict(record["bounds"], incus_e_pa=record["incus_e_pa"], nu=record["nu"])

    # ---- designs as mappings (the calibration) ----------------------------------------

    def designs_from_unit(self, u: np.ndarray) -> list[dict[str, float]]:
        """Designs (Pa) from points of the unit cube, log-uniform map (:meth:`columns_from_unit`)."""
        cols = self.columns_from_unit(u)
        e = np.column_stack([cols[n] for n in self.names])
        return [dict(zip(self.names, map(float, row), strict=True)) for row in e]

    def columns_from_unit(self, u: np.ndarray) -> dict[str, np.ndarray]:
        """One array (Pa) per modulus, shape (n,) each, from unit-cube points ``u`` (n, d).

        exp(log lo + u (log hi − log lo)), clipped to the bounds (exp(log lo) may miss lo by an
        ulp, and a design drawn from the box must lie in it).
        """
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if u.shape[1] != len(self.names):
            raise ValueError(f"u has {u.shape[1]} columns, the space has {len(self.names)} moduli")
        log_lo, log_hi = np.log(self.lower), np.log(self.upper)
        out = {}
        for j, name in enumerate(self.names):  # column by column: a few arrays of n at a time
            e = np.exp(log_lo[j] + u[:, j] * (log_hi[j] - log_lo[j]))
            out[name] = np.clip(e, self.lower[j], self.upper[j])
        return out

    def _matrix(self, designs: Mapping | Sequence[Mapping]) -> np.ndarray:
        if isinstance(designs, Mapping):
            designs = [designs]
        rows = [[float(d.get(n, np.nan)) for n in self.names] for d in designs]
        return np.array(rows, dtype=float).reshape(len(rows), len(self.names))

    def contains(self, designs: Mapping | Sequence[Mapping]) -> np.ndarray:
        """Which designs (mappings of moduli, Pa) lie inside the box (:func:`inside`), shape (n,).

        A design must give every ranged modulus (extra keys are ignored).
        """
        e = self._matrix(designs)
        return np.all(inside(e, self.lower, self.upper), axis=1)

    # ---- designs as (n, 5) arrays (the surrogate) -------------------------------------

    @property
    def log_lo(self) -> np.ndarray:
        """log of the lower bounds (log Pa), (5,)."""
        return np.log([self.bounds[k][0] for k in RANGED])

    @property
    def log_span(self) -> np.ndarray:
        """log(high / low) per ranged modulus, (5,)."""
        return np.log([self.bounds[k][1] / self.bounds[k][0] for k in RANGED])

    def from_unit(self, t) -> np.ndarray:
        """(n, 5) moduli (Pa) of unit-cube points ``t`` (n, 5): exp(log lo + t log(hi / lo))."""
        return np.exp(self.log_lo + np.asarray(t, dtype=float) * self.log_span)

    def to_unit(self, E) -> np.ndarray:
        """(n, 5) unit-cube coordinates of moduli ``E`` (n, 5), Pa; the inverse of :meth:`from_unit`."""
        return (np.log(np.asarray(E, dtype=float)) - self.log_lo) / self.log_span

    def center(self) -> np.ndarray:
        """(5,) the log-centre of the box (Pa): the surrogate's reference design μ̄."""
        return self.from_unit(np.full((1, len(RANGED)), 0.5))[0]

    def corners(self) -> np.ndarray:
        """(32, 5) moduli (Pa) of the box's corners, exactly the bounds (first modulus fastest)."""
        bits = (np.arange(2 ** len(RANGED))[:, None] >> np.arange(len(RANGED))) & 1
        return np.where(bits == 1, self.upper, self.lower)

    def sample(self, n: int, seed: int = 0) -> np.ndarray:
        """(n, 5) moduli (Pa) of a scrambled Sobol' sample (space-filling, reproducible)."""
        from scipy.stats import qmc  # scipy.stats takes a second to import: only when sampling

        m = max(1, math.ceil(math.log2(max(n, 1))))
        t = qmc.Sobol(len(RANGED), scramble=True, seed=seed).random_base2(m)[:n]
        return self.from_unit(t)

    def check(self, E) -> np.ndarray:
        """``E`` (n, 5) as floats (Pa), refused unless every design lies in the box (:func:`inside`).

        Raises
        ------
        InvalidParameter
            One line naming the first modulus outside its range, the value and the range.
        """
        E = np.atleast_2d(np.asarray(E, dtype=float))
        if E.ndim != 2 or E.shape[1] != len(RANGED):
            raise InvalidParameter(f"designs: must be an array of shape (n, {len(RANGED)}), not {E.shape}")
        for j, k in enumerate(RANGED):
            lo, hi = self.bounds[k]
            bad = ~inside(E[:, j], lo, hi)
            if bad.any():
                v = E[np.flatnonzero(bad)[0], j]
                raise InvalidParameter(
                    f"{k} = {v:g} Pa: outside the surrogate's domain; must lie in [{lo:g}, {hi:g}] Pa"
                )
        return E

    def theta(self, E) -> np.ndarray:
        """(n, 6) Young's moduli per region, in :data:`isj.design.REGIONS` order (Pa)."""
        E = np.atleast_2d(np.asarray(E, dtype=float))
        out = np.empty((E.shape[0], len(REGIONS)))
        for i, r in enumerate(REGIONS):
            name = f"{r}_e_pa"
            out[:, i] = self.incus_e_pa if name not in RANGED else E[:, RANGED.index(name)]
        return out

    def materials(self, e) -> Materials:
        """The :class:`Materials` of one design ``e`` (5,), Pa."""
        return Materials(
            **dict(zip(RANGED, map(float, e), strict=True)), incus_e_pa=self.incus_e_pa, nu=self.nu
        )

    def designs_from(self, materials=None, **moduli) -> np.ndarray:
        """(n, 5) moduli from a Materials, a mapping of floats or arrays, or keywords (Pa).

        A modulus that is not ranged must equal the space's (incus) or is refused; missing
        ranged moduli take :class:`Materials`' defaults; every design must lie in the box.
        """
        src: dict = {}
        if isinstance(materials, Materials):
            src = {f"{r}_e_pa": materials.youngs(r) for r in REGIONS}
            if materials.nu != self.nu:
                raise InvalidParameter(f"nu = {materials.nu!r}: this surrogate is built for nu = {self.nu!r}")
        elif materials is not None:
            src = dict(materials)
        src.update(moduli)
        unknown = set(src) - {f"{r}_e_pa" for r in REGIONS}
        if unknown:
            raise InvalidParameter(f"{sorted(unknown)[0]}: not a modulus; must be one of {', '.join(RANGED)}")
        incus = np.asarray(src.pop("incus_e_pa", self.incus_e_pa), dtype=float)
        if np.any(incus != self.incus_e_pa):
            raise InvalidParameter(
                f"incus_e_pa = {float(np.ravel(incus)[0]):g} Pa: this surrogate is built for "
                f"incus_e_pa = {self.incus_e_pa:g} Pa"
            )
        d = Materials()
        cols = [np.asarray(src.get(k, getattr(d, k)), dtype=float) for k in RANGED]
        cols = np.broadcast_arrays(*cols)
        return self.check(np.stack([c.ravel() for c in cols], axis=1))
