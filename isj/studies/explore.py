"""The lumped model over a grid or a sample of many designs, guarded by the surrogate and FE.

An exploration space is a :class:`~isj.design_space.DesignSpace` with the
incus modulus added (``isj explore`` lets every region's modulus range); a
pinned modulus has low == high. Designs come from the unit cube through
:meth:`DesignSpace.columns_from_unit`, the same log-uniform map as every
calibration sample, as one array per modulus so that millions of designs stay
cheap. The spot checks go through :func:`isj.calibration.checks.compare_static`
with the FE evaluator the caller passes in. Given the certified surrogate of the FE model
(:func:`isj.calibration.guard.load_surrogate`), :func:`explore` guards every design with it
(:mod:`isj.calibration.guard`) and spends the FE spot checks on the designs with the largest
certified lumped error, where FE also confirms the surrogate's bound.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from isj.calibration.checks import (
    StaticComparison,
    compare_static,
    lumped_static,
    warn_fe_settings,
    warn_outside_domain,
)
from isj.calibration.doe import _engine
from isj.calibration.guard import (
    DEFAULT_DENSE,
    DEFAULT_TOLERANCE,
    Guard,
    confirmations,
    run_guard,
    worst_picks,
)
from isj.calibration.region import in_region, region_of
from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials
from isj.design_space import RANGED, Bounds, DesignSpace
from isj.errors import InvalidParameter
from isj.lumped.model import StaticResponse

#: Most designs one exploration evaluates: about 6 arrays of 8 bytes each per design, ~2.4 GB.
MAX_DESIGNS = 50_000_000


@dataclass(frozen=True)
class ExploreSpace(DesignSpace):
    """A :class:`DesignSpace` whose incus modulus may range too (Pa); pinned at 12 GPa by default."""

    incus_e_pa: Bounds = (Materials().incus_e_pa, Materials().incus_e_pa)

    @property
    def names(self) -> tuple[str, ...]:
        """The ranged moduli, the incus's last."""
        return (*RANGED, "incus_e_pa")

    @classmethod
    def pinned(cls, materials: Materials | None = None, **ranges: Bounds) -> ExploreSpace:
        """Every modulus pinned at ``materials``' value (default :class:`Materials`), except ``ranges``."""
        m = materials or Materials()
        bounds = {n: (m.youngs(n.removesuffix("_e_pa")),) * 2 for n in cls().names}
        return cls(**(bounds | ranges))

    @property
    def ranged(self) -> tuple[str, ...]:
        """The moduli with low < high, in column order."""
        return tuple(self.names[i] for i in _ranged(self))


def _ranged(space: DesignSpace) -> list[int]:
    """Columns of the moduli of ``space`` with low < high."""
    return [i for i, (lo, hi) in enumerate(space.bounds.values()) if hi > lo]


def count_designs(space: DesignSpace, n: int = 5, sample: int | None = None) -> int:
    """How many designs :func:`explore_designs` makes: ``sample``, else ``n`` per ranged modulus.

    Computed without allocating anything, so a caller can refuse a size up front.
    """
    if sample is not None:
        _check_count("sample", sample)
        return int(sample)
    _check_count("n", n)
    return int(n) ** len(_ranged(space))


def _check_count(name: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise InvalidParameter(f"{name} = {value!r}: must be an integer >= 1")


def explore_designs(
    space: DesignSpace, n: int = 5, sample: int | None = None, seed: int = 0
) -> dict[str, np.ndarray]:
    """A full grid (``n`` points per ranged modulus) or a Latin-hypercube sample of ``space``.

    Parameters
    ----------
    space : DesignSpace
        Usually an :class:`ExploreSpace`; pinned moduli keep their value.
    n : int
        Grid points per ranged modulus, log-uniform from low to high (ignored with ``sample``).
    sample : int, optional
        Instead of a grid: this many Latin-hypercube designs (scrambled, ``seed``).
    seed : int
        Seed of the sample.

    Returns
    -------
    dict of numpy.ndarray
        One array (Pa) per modulus of ``space``, all of the same length (:func:`count_designs`).

    Raises
    ------
    InvalidParameter
        More than :data:`MAX_DESIGNS` designs, refused before anything is allocated.
    """
    total = count_designs(space, n, sample)
    if total > MAX_DESIGNS:
        what = f"sample = {sample}" if sample is not None else f"n = {n} per ranged modulus"
        raise InvalidParameter(f"{what}: {total:.3g} designs is too many (at most {MAX_DESIGNS:.0e})")
    names = space.names
    ranged = _ranged(space)
    u = np.zeros((total, len(names)))
    if sample is not None:
        # one column per ranged modulus (at least one: scipy needs d >= 1)
        pts = _engine("lhs", max(len(ranged), 1), seed).random(total)
        u[:, ranged] = pts[:, : len(ranged)]
    elif ranged:
        axes = np.meshgrid(*[np.linspace(0.0, 1.0, n) for _ in ranged], indexing="ij")
        for i, a in zip(ranged, axes, strict=True):
            u[:, i] = a.ravel()
    return space.columns_from_unit(u)


def spot_check_picks(designs: Mapping[str, np.ndarray], k: int, seed: int = 0) -> list[int]:
    """Indices of ``k`` designs to check with FE: the two extreme corners first, then random ones.

    The corners are the designs with the lowest and the highest sum of log-moduli (every
    modulus at a bound at once, where the lumped model errs most); the others are drawn
    without repetition from the rest with ``seed``.
    """
    if k <= 0:
        return []
    log_sum = sum(np.log(v) for v in designs.values())
    n = log_sum.size
    rng = np.random.default_rng(seed)
    picks = [int(np.argmin(log_sum)), int(np.argmax(log_sum)), *map(int, rng.permutation(n)[:k])]
    return list(dict.fromkeys(picks))[:k]


@dataclass(frozen=True)
class Exploration:
    """The lumped model over many designs, and FE spot checks of a few.

    Attributes
    ----------
    designs : dict of numpy.ndarray
        Moduli (Pa) per design.
    lumped : isj.lumped.model.StaticResponse
        α, β (rad) per design.
    lumped_time_s : float
        Seconds the lumped model took for all designs.
    outside_domain : int
        Designs outside the calibrated domain (the largest count over the moduli).
    picks : list of int
        Indices of the spot-checked designs, in their set (:attr:`pick_sets`).
    checks : StaticComparison
        FE and lumped at the picks.
    guard : isj.calibration.guard.Guard or None
        The surrogate's guard (None: explored without a surrogate).
    pick_sets : list of str
        The set of each pick: ``explored``, or with a guard also ``corners`` or ``dense``.
    confirmations : list of dict
        FE against the surrogate at the picks (:func:`isj.calibration.guard.confirmations`).
    in_region : numpy.ndarray or None
        (n,) bool: the designs inside the calibration's map of where the lumped model holds its
        tolerance (:func:`isj.calibration.region.in_region`); None for a calibration without one.
    """

    designs: dict[str, np.ndarray]
    lumped: StaticResponse
    lumped_time_s: float
    outside_domain: int
    picks: list[int]
    checks: StaticComparison
    guard: Guard | None = None
    pick_sets: list[str] = field(default_factory=list)
    confirmations: list[dict] = field(default_factory=list)
    in_region: np.ndarray | None = None

    @property
    def n_designs(self) -> int:
        return int(np.size(self.lumped.alpha_rad))


def explore(
    calibration,
    designs: Mapping[str, np.ndarray],
    spot_checks: int,
    evaluate: Callable[[dict, dict], Mapping] | None,
    settings: Mapping,
    cache_dir: str | os.PathLike,
    *,
    seed: int = 0,
    progress: bool = True,
    surrogate=None,
    tolerance: float = DEFAULT_TOLERANCE,
    n_dense: int = DEFAULT_DENSE,
) -> Exploration:
    """The lumped model over ``designs`` and FE spot checks of ``spot_checks`` of them.

    Warns (:class:`~isj.errors.OutOfDomainWarning`) for designs outside the calibrated domain
    and (:class:`~isj.errors.CalibrationWarning`) for spot checks on another mesh than the
    calibration's.

    Parameters
    ----------
    calibration : isj.lumped.artifact.Calibration
    designs : dict of numpy.ndarray
        Moduli (Pa), e.g. from :func:`explore_designs`.
    spot_checks : int
        FE checks K (>= 0): see :func:`spot_check_picks`.
    evaluate : callable
        FE evaluator (``isj.fem.batch.evaluate_design``); unused when ``spot_checks`` is 0.
    settings : dict
        Its settings (``isj.fem.batch.fe_settings``); ``pressure_pa`` and ``geometry`` are the
        lumped model's too.
    cache_dir : path
        FE result cache.
    seed : int
        Seed of the random picks.
    progress : bool
        Progress bar of the FE runs.
    surrogate : isj.fem.rom.ReducedModel, optional
        The certified surrogate of the FE model on the spot checks' mesh: with it, every design,
        the corners of the calibrated domain and ``n_dense`` Sobol designs of it are guarded
        (:func:`isj.calibration.guard.run_guard`, ``tolerance``), and the spot checks go to the
        designs of largest certified lumped error instead of :func:`spot_check_picks`.
    """
    geometry = Geometry(**settings["geometry"]) if settings.get("geometry") else None
    n_out = warn_outside_domain(calibration, designs, geometry)
    pressure = settings.get("pressure_pa", DEFAULT_PRESSURE_PA)
    t0 = time.perf_counter()
    lum = lumped_static(calibration, designs, geometry, pressure)
    t_lumped = time.perf_counter() - t0
    guard = None
    if surrogate is not None:
        guard = run_guard(
            calibration,
            surrogate,
            designs,
            tolerance=tolerance,
            n_dense=n_dense,
            seed=seed,
            pressure_pa=pressure,
            geometry=geometry,
        )
        pairs = worst_picks(guard, spot_checks)
        fe_designs = [guard.sets[name].design(i) for name, i in pairs]
    else:
        pairs = [("explored", i) for i in spot_check_picks(designs, spot_checks, seed)]
        fe_designs = [{k: float(v[i]) for k, v in designs.items()} for _, i in pairs]
    if pairs:
        warn_fe_settings(calibration, settings.get("order"), settings.get("resolution"))
    checks = compare_static(calibration, fe_designs, evaluate, settings, cache_dir, progress=progress)
    confirmed = confirmations(guard, pairs, checks, tolerance) if guard is not None else []
    return Exploration(
        designs=dict(designs),
        lumped=lum,
        lumped_time_s=t_lumped,
        outside_domain=n_out,
        picks=[i for _, i in pairs],
        checks=checks,
        guard=guard,
        pick_sets=[name for name, _ in pairs],
        confirmations=confirmed,
        in_region=in_region(region_of(calibration), calibration.domain, designs),
    )
