"""The lumped model guarded by the certified surrogate of the FE model (docs/rom.md §10.10).

The surrogate (:mod:`isj.fem.rom`) gives α, β and β/α of the FE model on one mesh with a
rigorous bound Δ: the FE value F lies in [S − Δ, S + Δ]. So the lumped model's error
against FE, L / F − 1, lies between its values at the two ends of that interval, and its
largest magnitude there, the *certified* error, is what the guard compares with the
tolerance: a design is ``ok`` when the certified errors of α, β and β/α are all within it,
``fail`` otherwise, and ``outside`` when the surrogate's domain does not hold it.

Three sets are guarded: the explored designs, the 2^d corners of the calibrated domain (d =
its number of moduli: 5, so 32, for the shipped calibration) and a dense scrambled Sobol
sample of that domain. :func:`worst_picks` names the designs with the largest certified
errors, where FE then confirms the surrogate (:func:`confirmations`).

The surrogate comes from the caller (``isj explore`` asks :func:`isj.fem.rom.reduced_model`):
this package never imports isj.fem, so it imports and runs without gmsh.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from isj.lumped.model import MODULI

from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials
from isj.design_space import inside
from isj.errors import InvalidParameter

from .checks import lumped_static

#: Outputs the guard checks, with the surrogate's bound of each.
GUARDED: dict[str, str] = {
    "alpha_rad": "alpha_bound_rad",
    "beta_rad": "beta_bound_rad",
    "beta_over_alpha": "beta_over_alpha_bound",
}

#: Default largest certified relative error of the lumped model.
DEFAULT_TOLERANCE = 0.03

#: Default size of the dense Sobol sample of the calibrated domain (a power of 2: balanced).
DEFAULT_DENSE = 4096

#: Largest dense sample.
MAX_DENSE = 2**22

#: The guarded sets, in report order.
SETS = ("explored", "corners", "dense")

VERDICTS = ("ok", "fail", "outside")


def short(key: str) -> str:
    """``alpha_rad`` → ``alpha``: the stem of an error column (errors are relative, not rad)."""
    return key.removesuffix("_rad")


def _base(rom) -> dict[str, float]:
    """The moduli of a design not given: the defaults, with the surrogate's incus modulus."""
    m = Materials()
    return {k: float(getattr(m, k)) for k in MODULI} | {"incus_e_pa": float(rom.space.incus_e_pa)}


def _full(designs: Mapping[str, np.ndarray], base: Mapping[str, float]) -> dict[str, np.ndarray]:
    n = max((np.size(v) for v in designs.values()), default=1)
    return {k: np.broadcast_to(np.asarray(designs.get(k, base[k]), dtype=float), (n,)).copy() for k in MODULI}


def corner_designs(
    domain: Mapping[str, tuple[float, float]], base: Mapping[str, float]
) -> dict[str, np.ndarray]:
    """The 2^d corners of ``domain`` (modulus → (low, high), Pa), exactly its bounds; others ``base``."""
    names = [k for k in MODULI if k in domain]
    bits = (np.arange(2 ** len(names))[:, None] >> np.arange(len(names))) & 1
    cols = {
        k: np.where(bits[:, j] == 1, domain[k][1], domain[k][0]).astype(float) for j, k in enumerate(names)
    }
    return _full(cols, base)


def dense_designs(
    domain: Mapping[str, tuple[float, float]], n: int, seed: int, base: Mapping[str, float]
) -> dict[str, np.ndarray]:
    """``n`` scrambled Sobol designs (``seed``), log-uniform over ``domain``; others ``base``."""
    from scipy.stats import qmc

    if n == 0:
        return {k: np.zeros(0) for k in MODULI}
    names = [k for k in MODULI if k in domain]
    m = max(1, math.ceil(math.log2(n)))
    t = qmc.Sobol(len(names), scramble=True, seed=seed).random_base2(m)[:n]
    cols = {}
    for j, k in enumerate(names):
        lo, hi = domain[k]
        cols[k] = np.clip(np.exp(np.log(lo) + t[:, j] * np.log(hi / lo)), lo, hi)
    return _full(cols, base)


def certified_error(lumped, value, bound) -> np.ndarray:
    """max |lumped / F − 1| over F in [value − bound, value + bound]; inf where that holds 0."""
    lo, hi = value - bound, value + bound
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.maximum(np.abs(lumped / lo - 1), np.abs(lumped / hi - 1))
    return np.where(lo * hi > 0, e, np.inf)


@dataclass(frozen=True)
class GuardSet:
    """One guarded set of designs: lumped and surrogate values, errors and verdicts.

    Attributes
    ----------
    name : ``explored``, ``corners`` or ``dense``
    designs : modulus → (n,) Pa, every modulus of :data:`isj.lumped.model.MODULI`
    lumped : ``alpha_rad``, ``beta_rad`` (rad), ``beta_over_alpha`` per design
    surrogate : the surrogate's values and bounds (keys of :meth:`ReducedModel.evaluate`), NaN
        outside its domain
    inside : (n,) bool, inside the surrogate's domain
    error : output → (n,) lumped / surrogate − 1 (NaN outside)
    certified : output → (n,) certified error (:func:`certified_error`; NaN outside)
    verdict : (n,) ``ok``, ``fail`` or ``outside``
    """

    name: str
    designs: dict[str, np.ndarray]
    lumped: dict[str, np.ndarray]
    surrogate: dict[str, np.ndarray]
    inside: np.ndarray
    error: dict[str, np.ndarray]
    certified: dict[str, np.ndarray]
    verdict: np.ndarray

    @property
    def n(self) -> int:
        return int(self.inside.size)

    @property
    def max_certified(self) -> np.ndarray:
        """(n,) the largest certified error over α, β and β/α (NaN outside)."""
        if not self.n:
            return np.zeros(0)
        return np.max(np.stack([self.certified[k] for k in GUARDED]), axis=0)

    def count(self, verdict: str) -> int:
        return int(np.count_nonzero(self.verdict == verdict))

    def design(self, i: int) -> dict[str, float]:
        return {k: float(v[i]) for k, v in self.designs.items()}

    def row(self, i: int) -> dict:
        """Design ``i`` as plain floats: moduli, lumped, surrogate, errors, verdict."""
        out = self.design(i) | {f"lumped_{k}": float(v[i]) for k, v in self.lumped.items()}
        if self.inside[i]:
            for k, kb in GUARDED.items():
                out |= {
                    f"surrogate_{k}": float(self.surrogate[k][i]),
                    f"surrogate_{kb}": float(self.surrogate[kb][i]),
                }
                out |= {
                    f"{short(k)}_rel_error": float(self.error[k][i]),
                    f"{short(k)}_certified_error": float(self.certified[k][i]),
                }
        return out | {"verdict": str(self.verdict[i])}

    def summary(self) -> dict:
        """Counts, and the worst design with its certified error (None when none is inside)."""
        out = {
            "n": self.n,
            **{f"n_{v}": self.count(v) for v in VERDICTS},
            "max_certified_error": None,
            "worst": None,
        }
        if self.inside.any():
            m = np.where(self.inside, self.max_certified, -np.inf)
            i = int(np.argmax(m))
            if math.isfinite(m[i]):
                out["max_certified_error"] = float(m[i])
                out["worst"] = self.row(i) | {"index": i}
            else:  # a bound interval holding 0: no finite error (not seen on the shipped domain)
                out["max_certified_error"] = None
                out["worst"] = {"index": i, "verdict": "fail", **self.design(i)}
        return out


def _inside(rom, designs: Mapping[str, np.ndarray]) -> np.ndarray:
    n = np.size(designs["incus_e_pa"])
    # the incus is fixed per surrogate: equal up to the slack (a grid's log-midpoint misses it by an ulp)
    ok = inside(designs["incus_e_pa"], rom.space.incus_e_pa, rom.space.incus_e_pa)
    for k, (lo, hi) in rom.space.bounds.items():
        ok &= inside(designs[k], lo, hi)
    return np.broadcast_to(ok, (n,)).copy()


def guard_set(
    name: str,
    calibration,
    rom,
    designs: Mapping[str, np.ndarray],
    tolerance: float = DEFAULT_TOLERANCE,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    geometry: Geometry | None = None,
) -> GuardSet:
    """Lumped model and surrogate over ``designs`` (moduli in Pa; missing ones the defaults).

    ``rom`` is an :class:`isj.fem.rom.ReducedModel` (its ``space.bounds`` name the ranged moduli in
    the order of its design columns).
    """
    d = _full(designs, _base(rom))
    n = d["incus_e_pa"].size
    lum = lumped_static(calibration, d, geometry, pressure_pa)
    la, lb = np.asarray(lum.alpha_rad, dtype=float), np.asarray(lum.beta_rad, dtype=float)
    lumped = {"alpha_rad": la, "beta_rad": lb, "beta_over_alpha": lb / la}
    inside = _inside(rom, d)
    keys = [*GUARDED, *GUARDED.values()]
    sur = {k: np.full(n, np.nan) for k in keys}
    if inside.any():
        E = np.stack([d[k][inside] for k in rom.space.bounds], axis=1)
        ev = rom.evaluate(E, pressure_pa)
        for k in keys:
            sur[k][inside] = ev[k]
    error, cert = {}, {}
    with np.errstate(invalid="ignore"):
        for k, kb in GUARDED.items():
            error[k] = lumped[k] / sur[k] - 1
            cert[k] = np.where(inside, certified_error(lumped[k], sur[k], sur[kb]), np.nan)
        worst = np.max(np.stack([cert[k] for k in GUARDED]), axis=0) if n else np.zeros(0)
    verdict = np.where(~inside, "outside", np.where(worst <= tolerance, "ok", "fail"))
    return GuardSet(name, d, lumped, sur, inside, error, cert, verdict.astype("<U7"))


@dataclass(frozen=True)
class Guard:
    """The three guarded sets, the settings and what it cost.

    Attributes
    ----------
    sets : ``explored``, ``corners``, ``dense`` → :class:`GuardSet`
    tolerance : the largest certified error of an ``ok`` design
    domain : the calibrated domain the corners and the sample span (Pa)
    surrogate : the surrogate's sizes (order, resolution, dofs, mesh hash, bases)
    time_s : seconds the three sets took (surrogate and lumped model; loading excluded)
    seed : the dense sample's seed
    """

    sets: dict[str, GuardSet]
    tolerance: float
    domain: dict[str, tuple[float, float]]
    surrogate: dict
    time_s: float
    seed: int = 0

    def summary(self, confirmed: list[dict] | None = None) -> dict:
        """JSON-able: per set its counts and worst design, the corners in full, FE confirmations."""
        corners = self.sets["corners"]
        return {
            "available": True,
            "tolerance": self.tolerance,
            "outputs": list(GUARDED),
            "domain_pa": {k: list(v) for k, v in self.domain.items()},
            "n_corners": corners.n,
            "n_dense": self.sets["dense"].n,
            "dense_seed": self.seed,
            "surrogate": self.surrogate,
            "time_s": self.time_s,
            **{name: s.summary() for name, s in self.sets.items()},
            "corner_rows": [corners.row(i) for i in range(corners.n)],
            "fe_confirmations": confirmed or [],
            "fe_confirmed": all(c["confirmed"] for c in confirmed or []),
        }


def run_guard(
    calibration,
    rom,
    designs: Mapping[str, np.ndarray],
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    n_dense: int = DEFAULT_DENSE,
    seed: int = 0,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    geometry: Geometry | None = None,
) -> Guard:
    """Guard the explored ``designs``, the corners of the calibrated domain and a dense sample of it."""
    if (
        isinstance(n_dense, bool)
        or not isinstance(n_dense, int | np.integer)
        or not 0 <= n_dense <= MAX_DENSE
    ):
        raise InvalidParameter(f"n_dense = {n_dense!r}: must be an integer in [0, {MAX_DENSE}]")
    if not (isinstance(tolerance, float | int) and math.isfinite(tolerance) and tolerance > 0):
        raise InvalidParameter(f"tolerance = {tolerance!r}: must be a finite number > 0")
    t0 = time.perf_counter()
    domain = {k: (float(v[0]), float(v[1])) for k, v in calibration.domain.items()}
    base = _base(rom)
    sets = {
        "explored": designs,
        "corners": corner_designs(domain, base),
        "dense": dense_designs(domain, int(n_dense), seed, base),
    }
    out = {k: guard_set(k, calibration, rom, v, tolerance, pressure_pa, geometry) for k, v in sets.items()}
    return Guard(out, float(tolerance), domain, rom.sizes(), time.perf_counter() - t0, seed)


def worst_picks(guard: Guard, k: int) -> list[tuple[str, int]]:
    """The ``k`` designs of all sets with the largest certified error: (set name, index), worst first."""
    if k <= 0:
        return []
    cand = []
    for name in SETS:
        s = guard.sets[name]
        m = np.where(s.inside, s.max_certified, -np.inf) if s.n else np.zeros(0)
        top = np.argsort(-m, kind="stable")[:k]
        cand += [(float(m[i]), SETS.index(name), int(i)) for i in top if s.inside[i]]
    cand.sort(key=lambda t: (-t[0], t[1], t[2]))
    out, seen = [], set()
    for _, j, i in cand:  # one FE run per design: an explored corner is also in ``corners``
        key = tuple(guard.sets[SETS[j]].design(i).values())
        if key not in seen and len(out) < k:
            seen.add(key)
            out.append((SETS[j], i))
    return out


def confirmations(guard: Guard, picks: list[tuple[str, int]], comparison, tolerance: float) -> list[dict]:
    """FE at the picks against the surrogate's bound, and against the lumped model.

    ``comparison`` is the :class:`~isj.calibration.checks.StaticComparison` of the picks' designs
    in order. ``confirmed``: |FE − surrogate| ≤ bound for α, β and β/α.
    """
    out = []
    for j, (name, i) in enumerate(picks):
        s = guard.sets[name]
        fe = comparison.fe_row(j)
        row = {"set": name, "index": i, "design": s.design(i)}
        ok = True
        for k, kb in GUARDED.items():
            diff = abs(fe[k] - float(s.surrogate[k][i]))
            bound = float(s.surrogate[kb][i])
            ok &= diff <= bound
            row |= {
                f"fe_{k}": fe[k],
                f"surrogate_{k}": float(s.surrogate[k][i]),
                f"surrogate_{kb}": bound,
                f"fe_minus_surrogate_{k}": fe[k] - float(s.surrogate[k][i]),
                f"{short(k)}_rel_error_vs_fe": float(s.lumped[k][i]) / fe[k] - 1,
                f"{short(k)}_certified_error": float(s.certified[k][i]),
            }
        row["confirmed"] = bool(ok)
        row["lumped_within_tolerance"] = bool(
            max(abs(row[f"{short(k)}_rel_error_vs_fe"]) for k in GUARDED) <= tolerance
        )
        out.append(row)
    return out
