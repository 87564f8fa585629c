"""Design of experiments over the calibration space of docs/lumped.md §3.5 (moduli in Pa).

The moduli span one to two decades each, so every design is drawn uniformly in
log E: a design space is the box of log-moduli, and the unit cube of
``scipy.stats.qmc`` maps onto it by u ↦ exp(log lo + u (log hi − log lo)).
The incus modulus is not a design variable (it stays at
``isj.design.Materials()``'s default, 12 GPa): it is far stiffer than
everything it is loaded through.

>>> space = DesignSpace()
>>> designs = sample(space, 64, seed=1)              # list of {"pedicle_e_pa": ..., ...}
>>> bool(space.contains(designs).all())
True
"""

from __future__ import annotations

import dataclasses
import inspect
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields

import numpy as np

from isj.design import InvalidParameter

Bounds = tuple[float, float]


@dataclass(frozen=True)
class DesignSpace:
    """Box of Young's moduli (Pa), sampled log-uniformly (docs/lumped.md §3.5–3.6).

    Each field is ``(low, high)`` in Pa, with 0 < low ≤ high; ``low == high``
    pins a modulus. Defaults: the plausible ranges of docs/lumped.md §3.5 (thesis
    §6.2.3–6.2.5).

    Parameters
    ----------
    pedicle_e_pa : bone, 1–27 GPa
    gap_e_pa : joint cartilage, 1–50 MPa
    capsule_e_pa : ligament, 10–300 MPa
    plate_e_pa : lenticular plate, 0.3–5 GPa
    stapes_e_pa : head of the stapes, 0.3–5 GPa
    """

    pedicle_e_pa: Bounds = (1e9, 27e9)
    gap_e_pa: Bounds = (1e6, 50e6)
    capsule_e_pa: Bounds = (10e6, 300e6)
    plate_e_pa: Bounds = (0.3e9, 5e9)
    stapes_e_pa: Bounds = (0.3e9, 5e9)

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

    @property
    def names(self) -> tuple[str, ...]:
        """Modulus names, in the column order used by every array method."""
        return tuple(f.name for f in fields(self))

    @property
    def lower(self) -> np.ndarray:
        """Lower bounds (Pa), shape (d,)."""
        return np.array([getattr(self, n)[0] for n in self.names])

    @property
    def upper(self) -> np.ndarray:
        """Upper bounds (Pa), shape (d,)."""
        return np.array([getattr(self, n)[1] for n in self.names])

    def mid(self) -> dict[str, float]:
        """Geometric mid-point √(low · high) of every modulus (Pa)."""
        return {n: float(math.sqrt(lo * hi)) for n, (lo, hi) in zip(self.names, self._pairs(), strict=True)}

    def _pairs(self) -> list[Bounds]:
        return [getattr(self, n) for n in self.names]

    def from_unit(self, u: np.ndarray) -> list[dict[str, float]]:
        """Designs (Pa) from points of the unit cube, log-uniform map; ``u`` shape (n, d)."""
        cols = self.columns_from_unit(u)
        e = np.column_stack([cols[n] for n in self.names])
        return [dict(zip(self.names, map(float, row), strict=True)) for row in e]

    def columns_from_unit(self, u: np.ndarray) -> dict[str, np.ndarray]:
        """:meth:`from_unit` as one array (Pa) per modulus, shape (n,) each: for millions of designs."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if u.shape[1] != len(self.names):
            raise ValueError(f"u has {u.shape[1]} columns, the space has {len(self.names)} moduli")
        log_lo, log_hi = np.log(self.lower), np.log(self.upper)
        out = {}
        for j, name in enumerate(self.names):
            # column by column: a few arrays of n at a time, not of (n, d); clip, since
            # exp(log(lo)) may miss lo by an ulp and designs must lie inside the box
            e = np.exp(log_lo[j] + u[:, j] * (log_hi[j] - log_lo[j]))
            out[name] = np.clip(e, self.lower[j], self.upper[j])
        return out

    def to_unit(self, designs: Mapping | Sequence[Mapping]) -> np.ndarray:
        """Log-scaled coordinates in [0, 1] (0 for a pinned modulus), shape (n, d)."""
        e = self._matrix(designs)
        log_lo, log_hi = np.log(self.lower), np.log(self.upper)
        span = np.where(log_hi > log_lo, log_hi - log_lo, 1.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            return (np.log(e) - log_lo) / span

    def _matrix(self, designs: Mapping | Sequence[Mapping]) -> np.ndarray:
        if isinstance(designs, Mapping):
            designs = [designs]
        rows = [[float(d.get(n, np.nan)) for n in self.names] for d in designs]
        return np.array(rows, dtype=float).reshape(len(rows), len(self.names))

    def contains(self, designs: Mapping | Sequence[Mapping], rtol: float = 1e-9) -> np.ndarray:
        """Which designs lie inside the box, shape (n,) of bool.

        A design must give every modulus of the space (extra keys are ignored);
        each must be finite and within ``[low (1 − rtol), high (1 + rtol)]``, the
        tolerance absorbing rounding in the log-uniform map and in JSON round trips.
        """
        e = self._matrix(designs)
        with np.errstate(invalid="ignore"):
            inside = (e >= self.lower * (1 - rtol)) & (e <= self.upper * (1 + rtol))
        return np.all(inside & np.isfinite(e), axis=1)

    def to_dict(self) -> dict[str, list[float]]:
        """JSON-able form ``{name: [low_pa, high_pa]}``."""
        return {n: list(getattr(self, n)) for n in self.names}

    @classmethod
    def from_dict(cls, data: Mapping) -> DesignSpace:
        """Inverse of :meth:`to_dict`; a missing modulus takes its default bounds."""
        unknown = set(data) - {f.name for f in fields(cls)}
        if unknown:
            valid = list(cls().names)
            raise InvalidParameter(f"unknown design-space moduli {sorted(unknown)}; valid: {valid}")
        return cls(**{k: tuple(v) for k, v in data.items()})

    def replace(self, **changes: Bounds) -> DesignSpace:
        return dataclasses.replace(self, **changes)


#: Sampling methods understood by :func:`sample`.
METHODS = ("sobol", "lhs")


def _engine(method: str, d: int, seed: int):
    from scipy.stats import qmc  # lazy: scipy.stats takes a second to import

    kind = {"sobol": qmc.Sobol, "lhs": qmc.LatinHypercube}[method]
    # scipy ≥ 1.15 takes ``rng``; older releases only ``seed`` (same meaning for an int)
    key = "rng" if "rng" in inspect.signature(kind).parameters else "seed"
    return kind(d, scramble=True, **{key: seed})


def sample(space: DesignSpace, n: int, seed: int, method: str = "sobol") -> list[dict[str, float]]:
    """``n`` designs drawn log-uniformly from ``space`` (moduli in Pa).

    Parameters
    ----------
    space : DesignSpace
    n : int
        Number of designs, ≥ 1. Sobol' points keep their balance properties
        when ``n`` is a power of 2 (scipy warns otherwise).
    seed : int
        Seeds the scrambling: the same seed gives the same designs every time.
    method : {"sobol", "lhs"}
        Scrambled Sobol' sequence or Latin hypercube (``scipy.stats.qmc``).

    Returns
    -------
    list of dict
        One ``{modulus name: value (Pa)}`` per design, floats.
    """
    if not isinstance(n, int | np.integer) or isinstance(n, bool) or n < 1:
        raise ValueError(f"n = {n!r}: must be an integer >= 1")
    if method not in METHODS:
        raise ValueError(f"method = {method!r}: must be one of {METHODS}")
    return space.from_unit(_engine(method, len(space.names), seed).random(int(n)))


def corners(space: DesignSpace) -> list[dict[str, float]]:
    """The 2^d corners of the box (Pa), lowest first (last modulus varies fastest)."""
    return [dict(zip(space.names, c, strict=True)) for c in itertools.product(*space._pairs())]


def grid(space: DesignSpace, name: str, n: int) -> list[dict[str, float]]:
    """``n`` designs sweeping ``name`` log-uniformly from low to high (Pa).

    The other moduli sit at their geometric mid-points (:meth:`DesignSpace.mid`).
    """
    if name not in space.names:
        raise ValueError(f"name = {name!r}: must be one of {list(space.names)}")
    if not isinstance(n, int | np.integer) or isinstance(n, bool) or n < 2:
        raise ValueError(f"n = {n!r}: must be an integer >= 2")
    lo, hi = getattr(space, name)
    values = np.geomspace(lo, hi, int(n))
    values[0], values[-1] = lo, hi  # exact ends, not exp(log(lo))
    base = space.mid()
    return [{**base, name: float(v)} for v in values]
