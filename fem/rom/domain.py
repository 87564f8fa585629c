"""The surrogate's design space: five ranged moduli, log-scaled, and the fixed rest (docs/rom.md §10.2).

The ranged moduli and their bounds are the shipped calibration's domain
(``lumped/data/default_calibration.json``): pedicle, gap, capsule, plate and
stapes. The incus modulus and ν are fixed per surrogate, like the mesh: the
calibration never ranged the incus (the lumped model treats it as a rigid
block), so five ranged moduli give the issue's 32 corners.

Coordinates: each ranged modulus maps to t = log(E / E_lo) / log(E_hi / E_lo)
in [0, 1]; training and validation samples are drawn in that unit cube.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from isj.design import REGIONS, Materials
from isj.errors import InvalidParameter
from isj.validate import check_poisson

#: Ranged moduli, in the order of the design coordinates.
RANGED: tuple[str, ...] = ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa", "plate_e_pa", "stapes_e_pa")

#: Relative slack at the domain's faces: a corner written in decimal (5e9) must not be refused
#: for a last-bit difference after a round trip through log and exp.
EDGE_SLACK = 1e-12


#: The shipped calibration's domain (Pa), ``lumped/data/default_calibration.json``: copied here
#: because isj.fem may not import isj.lumped; ``tests/test_rom.py`` checks that the two agree.
CALIBRATION_DOMAIN_PA: dict[str, tuple[float, float]] = {
    "pedicle_e_pa": (1e9, 27e9),
    "gap_e_pa": (1e6, 50e6),
    "capsule_e_pa": (10e6, 300e6),
    "plate_e_pa": (300e6, 5e9),
    "stapes_e_pa": (300e6, 5e9),
}


def calibration_domain() -> dict[str, tuple[float, float]]:
    """The shipped calibration's domain: ranged modulus name → (low, high) in Pa."""
    return dict(CALIBRATION_DOMAIN_PA)


@dataclass(frozen=True)
class DesignSpace:
    """Box of log-scaled moduli with the incus modulus and ν fixed.

    Parameters
    ----------
    bounds : ranged modulus name → (low, high), Pa; every name of :data:`RANGED`
    incus_e_pa : the fixed incus modulus (Pa)
    nu : Poisson's ratio of every region, in (-1, 0.5)
    """

    bounds: dict[str, tuple[float, float]] = field(default_factory=calibration_domain)
    incus_e_pa: float = Materials().incus_e_pa
    nu: float = Materials().nu

    def __post_init__(self) -> None:
        if set(self.bounds) != set(RANGED):
            raise InvalidParameter(f"bounds: must give exactly {', '.join(RANGED)}")
        for k in RANGED:
            lo, hi = self.bounds[k]
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
                raise InvalidParameter(f"bounds[{k}] = ({lo!r}, {hi!r}) Pa: must satisfy 0 < low < high")
        if not (math.isfinite(self.incus_e_pa) and self.incus_e_pa > 0):
            raise InvalidParameter(f"incus_e_pa = {self.incus_e_pa!r} Pa: must be a finite number > 0")
        check_poisson(self.nu, "nu")
        object.__setattr__(
            self, "bounds", {k: (float(self.bounds[k][0]), float(self.bounds[k][1])) for k in RANGED}
        )

    # ---- coordinates -------------------------------------------------------------------

    @property
    def log_lo(self) -> np.ndarray:
        return np.log([self.bounds[k][0] for k in RANGED])

    @property
    def log_span(self) -> np.ndarray:
        return np.log([self.bounds[k][1] / self.bounds[k][0] for k in RANGED])

    def from_unit(self, t) -> np.ndarray:
        """(n, 5) moduli (Pa) of unit-cube points ``t`` (n, 5)."""
        return np.exp(self.log_lo + np.asarray(t, dtype=float) * self.log_span)

    def to_unit(self, E) -> np.ndarray:
        """(n, 5) unit-cube coordinates of moduli ``E`` (n, 5), Pa."""
        return (np.log(np.asarray(E, dtype=float)) - self.log_lo) / self.log_span

    def center(self) -> np.ndarray:
        """(5,) the log-centre of the box (Pa): the reference design μ̄ of the energy norm."""
        return self.from_unit(np.full((1, len(RANGED)), 0.5))[0]

    def corners(self) -> np.ndarray:
        """(32, 5) moduli (Pa) of the box's corners, exactly the bounds."""
        bits = (np.arange(2 ** len(RANGED))[:, None] >> np.arange(len(RANGED))) & 1
        lo = np.array([self.bounds[k][0] for k in RANGED])
        hi = np.array([self.bounds[k][1] for k in RANGED])
        return np.where(bits == 1, hi, lo)

    def sample(self, n: int, seed: int = 0) -> np.ndarray:
        """(n, 5) moduli (Pa) of a scrambled Sobol sample (space-filling, reproducible)."""
        from scipy.stats import qmc

        m = max(1, math.ceil(math.log2(max(n, 1))))
        t = qmc.Sobol(len(RANGED), scramble=True, seed=seed).random_base2(m)[:n]
        return self.from_unit(t)

    # ---- designs -----------------------------------------------------------------------

    def check(self, E) -> np.ndarray:
        """``E`` (n, 5) as floats (Pa), refused unless every design lies in the box.

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
            col = E[:, j]
            bad = ~(np.isfinite(col) & (col >= lo * (1 - EDGE_SLACK)) & (col <= hi * (1 + EDGE_SLACK)))
            if bad.any():
                v = col[np.flatnonzero(bad)[0]]
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
        """(n, 5) moduli from a Materials, a mapping of floats or arrays, or keywords.

        A modulus that is not ranged must equal the surrogate's (incus) or is refused; missing
        ranged moduli take :class:`Materials`' defaults.
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

    def to_dict(self) -> dict:
        return {
            "bounds": {k: list(v) for k, v in self.bounds.items()},
            "incus_e_pa": self.incus_e_pa,
            "nu": self.nu,
        }
