"""Design of experiments over the calibration space of docs/lumped.md §3.5 (moduli in Pa).

The moduli span one to two decades each, so every design is drawn uniformly in
log E over a :class:`isj.design_space.DesignSpace`: the unit cube of
``scipy.stats.qmc`` maps onto it by u ↦ exp(log lo + u (log hi − log lo))
(:meth:`~isj.design_space.DesignSpace.columns_from_unit`). The incus modulus is not
a design variable (it stays at ``isj.design.Materials()``'s default, 12 GPa): it is
far stiffer than everything it is loaded through.

>>> space = DesignSpace()
>>> designs = sample(space, 64, seed=1)              # list of {"pedicle_e_pa": ..., ...}
>>> bool(space.contains(designs).all())
True
"""

from __future__ import annotations

import inspect
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np
from isj.lumped.artifact import GEOMETRY_CLEARANCE_M as _CLEARANCE_M

from isj.design_space import Bounds, DesignSpace, inside
from isj.errors import InvalidParameter

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
    return space.designs_from_unit(_engine(method, len(space.names), seed).random(int(n)))


def corners(space: DesignSpace) -> list[dict[str, float]]:
    """The 2^d corners of the box (Pa), lowest first (last modulus varies fastest)."""
    return [dict(zip(space.names, c, strict=True)) for c in itertools.product(*space.bounds.values())]


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


#: Geometric part of the calibration's design space (m): (low, high) per dimension of
#: :class:`isj.design.Geometry`, with the reasoning in docs/lumped.md §3.13. The pedicle's size,
#: the gap's and the capsule's thicknesses come from one cat's histology (thesis) and vary by
#: ±25 % here; the other dimensions are estimates and vary by ±40 %. Every other dimension of the
#: geometry stays at its default.
GEOMETRY_DOMAIN_M: dict[str, Bounds] = {
    "pedicle_x_m": (41.25e-6, 68.75e-6),
    "pedicle_y_m": (120e-6, 200e-6),
    "pedicle_length_m": (180e-6, 300e-6),
    "gap_thickness_m": (26.25e-6, 43.75e-6),
    "capsule_thickness_m": (22.5e-6, 37.5e-6),
    "capsule_reach_m": (24e-6, 56e-6),
    "capsule_bond_m": (12e-6, 28e-6),
    "plate_thickness_m": (36e-6, 84e-6),
}

#: Smallest clearance (m) the sampler keeps between the capsule's levels (defined beside the
#: calibration artifact, whose outside_geometry checks it too).
GEOMETRY_CLEARANCE_M = _CLEARANCE_M


@dataclass(frozen=True)
class GeometrySpace:
    """Box of dimensions (m), sampled uniformly, that keeps :class:`isj.design.Geometry` valid.

    ``bounds`` maps a :class:`~isj.design.Geometry` field to ``(low, high)`` (m); fields not
    named stay at ``base``'s value (default: the default geometry). A point of the box is a
    valid design only when the geometry constructs and the capsule's levels keep
    :data:`GEOMETRY_CLEARANCE_M` apart (:meth:`valid`); :func:`sample_with_geometry` draws
    only such points.
    """

    bounds: tuple[tuple[str, Bounds], ...] = tuple(GEOMETRY_DOMAIN_M.items())
    base: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        from isj.design import Geometry

        bounds = dict(self.bounds.items() if isinstance(self.bounds, Mapping) else self.bounds)
        valid_names = {f.name for f in fields(Geometry)}
        out = []
        for name, value in bounds.items():
            if name not in valid_names:
                raise InvalidParameter(f"geometry space: unknown dimension {name!r}")
            try:
                lo, hi = (float(v) for v in value)
            except (TypeError, ValueError):
                raise InvalidParameter(f"{name} = {value!r}: must be a pair (low, high) in m") from None
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise InvalidParameter(f"{name} = {value!r} m: must satisfy 0 < low <= high, both finite")
            out.append((name, (lo, hi)))
        object.__setattr__(self, "bounds", tuple(out))
        base = dict(self.base.items() if isinstance(self.base, Mapping) else self.base)
        object.__setattr__(self, "base", tuple(sorted((k, float(v)) for k, v in base.items())))
        Geometry(**dict(self.base))  # the base must be a geometry

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(n for n, _ in self.bounds)

    def to_dict(self) -> dict[str, list[float]]:
        return {n: [lo, hi] for n, (lo, hi) in self.bounds}

    @classmethod
    def from_dict(cls, data: Mapping) -> GeometrySpace:
        return cls(bounds=tuple((k, tuple(v)) for k, v in data.items()))

    def geometry(self, dims: Mapping[str, float]):
        """The :class:`~isj.design.Geometry` of ``dims`` over the base (InvalidParameter if invalid)."""
        from isj.design import Geometry

        return Geometry(**{**dict(self.base), **{k: float(v) for k, v in dims.items()}})

    def valid(self, dims: Mapping[str, float]) -> bool:
        """Whether ``dims`` make a valid geometry with the capsule's clearances kept."""
        try:
            g = self.geometry(dims)
        except InvalidParameter:
            return False
        c = GEOMETRY_CLEARANCE_M * (1 - 1e-9)
        return g.capsule_reach_m - g.capsule_bond_m >= c and g.plate_thickness_m - g.capsule_reach_m >= c

    def from_unit(self, u: np.ndarray) -> list[dict[str, float]]:
        """Dimensions (m) from points of the unit cube, uniform map; ``u`` shape (n, d)."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        lo = np.array([b[0] for _, b in self.bounds])
        hi = np.array([b[1] for _, b in self.bounds])
        x = np.clip(lo + u * (hi - lo), lo, hi)
        return [dict(zip(self.names, map(float, row), strict=True)) for row in x]

    def contains(self, dims: Mapping[str, float]) -> bool:
        """Whether every named dimension lies in its bounds (:func:`isj.design_space.inside`) and is valid."""
        for n, (lo, hi) in self.bounds:
            v = float(dims.get(n, dict(self.base).get(n, np.nan)))
            if not inside(v, lo, hi):
                return False
        return self.valid(dims)


def sample_with_geometry(
    space: DesignSpace, geometry: GeometrySpace, n: int, seed: int, method: str = "sobol"
) -> list[tuple[dict[str, float], dict[str, float]]]:
    """``n`` designs drawn jointly from moduli (log-uniform) and dimensions (uniform).

    Returns ``(moduli in Pa, dimensions in m)`` pairs. One qmc sequence over the d moduli and
    the dimensions together; points whose geometry is invalid (:meth:`GeometrySpace.valid`)
    are skipped and the sequence continues until ``n`` are kept, so the designs stay
    reproducible from ``seed``.
    """
    if not isinstance(n, int | np.integer) or isinstance(n, bool) or n < 1:
        raise ValueError(f"n = {n!r}: must be an integer >= 1")
    if method not in METHODS:
        raise ValueError(f"method = {method!r}: must be one of {METHODS}")
    dm, dg = len(space.names), len(geometry.names)
    import warnings

    out: list[tuple[dict, dict]] = []
    draw = 1 << max(int(np.ceil(np.log2(n))), 0)
    engine = _engine(method, dm + dg, seed)
    for _ in range(64):
        with warnings.catch_warnings():  # balance is already lost to the rejections
            warnings.simplefilter("ignore")
            u = engine.random(draw)
        moduli = space.designs_from_unit(u[:, :dm])
        dims = geometry.from_unit(u[:, dm:])
        out.extend((m, g) for m, g in zip(moduli, dims, strict=True) if geometry.valid(g))
        if len(out) >= n:
            return out[:n]
    raise ValueError("geometry space: too few valid geometries; widen the bounds")


#: Moduli corners reported with the geometric ones (:func:`mixed_corners`): which moduli sit at
#: their high bound (the others at their low bound).
MODULI_CORNERS: dict[str, tuple[str, ...]] = {
    "all soft": (),
    "all stiff": ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa", "plate_e_pa", "stapes_e_pa"),
    "stiff bone, soft joint": ("pedicle_e_pa", "plate_e_pa", "stapes_e_pa"),
    "soft bone, stiff joint": ("gap_e_pa", "capsule_e_pa"),
}

#: Geometric corners reported (:func:`mixed_corners`): which dimensions sit at their high bound.
GEOMETRY_CORNERS: dict[str, tuple[str, ...]] = {
    "all small": (),
    "all large": tuple(GEOMETRY_DOMAIN_M),
    # slender pedicle on a thin gap, thick capsule with a short reach, thick plate
    "slender pedicle": ("pedicle_length_m", "capsule_thickness_m", "plate_thickness_m"),
}


def mixed_corners(
    space: DesignSpace, geometry: GeometrySpace
) -> list[tuple[str, dict[str, float], dict[str, float]]]:
    """``(label, moduli (Pa), dimensions (m))`` at :data:`MODULI_CORNERS` × :data:`GEOMETRY_CORNERS`."""
    out = []
    bounds = dict(geometry.bounds)
    for glabel, ghigh in GEOMETRY_CORNERS.items():
        dims = {n: b[1] if n in ghigh else b[0] for n, b in bounds.items()}
        if not geometry.valid(dims):
            continue
        for mlabel, mhigh in MODULI_CORNERS.items():
            moduli = {n: getattr(space, n)[1] if n in mhigh else getattr(space, n)[0] for n in space.names}
            out.append((f"{mlabel} / {glabel}", moduli, dims))
    return out
