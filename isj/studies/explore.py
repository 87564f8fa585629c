"""The lumped model over a grid or a sample of many designs, guarded by the surrogate and FE.

An exploration space is a :class:`~isj.design_space.DesignSpace` with the
incus modulus added (``isj explore`` lets every region's modulus range); a
pinned modulus has low == high. Designs come from the unit cube through
:meth:`DesignSpace.columns_from_unit`, the same log-uniform map as every
calibration sample, as one array per modulus so that millions of designs stay
cheap. The spot checks go through :func:`isj.calibration.checks.compare_static`
with the FE evaluator the caller passes in. Given the certified surrogate of the FE model
(:func:`isj.fem.rom.reduced_model`), :func:`explore` guards every design with it
(:mod:`isj.calibration.guard`) and spends the FE spot checks on the designs with the largest
certified lumped error, where FE also confirms the surrogate's bound.
:func:`run_explore` is ``isj explore`` as one call: the designs, the surrogate the caller
loads, the FE settings, :func:`explore` and the summary the command prints and writes.
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
    pairs, fe_designs = _spot_checks(guard, designs, spot_checks, seed)
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


def _spot_checks(guard, designs: Mapping[str, np.ndarray], spot_checks: int, seed: int):
    """(set name, index) of each spot check and its design: the guard's worst certified lumped
    errors with a guard, else :func:`spot_check_picks` of ``designs``."""
    if guard is not None:
        pairs = worst_picks(guard, spot_checks)
        return pairs, [guard.sets[name].design(i) for name, i in pairs]
    pairs = [("explored", i) for i in spot_check_picks(designs, spot_checks, seed)]
    return pairs, [{k: float(v[i]) for k, v in designs.items()} for _, i in pairs]


@dataclass(frozen=True)
class ExploreRun:
    """What :func:`run_explore` computed.

    Attributes
    ----------
    exploration : Exploration
        The lumped model over the designs, the guard and the FE spot checks.
    checks : list of dict
        Per FE spot check: its set, design, FE and lumped α, β (rad), their relative errors
        (lumped / FE − 1) and whether both lie within the tolerance.
    guard : dict
        The guard's summary (:meth:`isj.calibration.guard.Guard.summary`, with
        ``surrogate_load_time_s``), or ``{"available": False, "reason": ...}`` without a surrogate.
    summary : dict
        The JSON summary of ``isj explore`` (SI units; timings in s).
    failures : list of str
        What fails the run, one phrase each: explored designs whose spot check exceeds the
        tolerance, explored designs that fail the guard, FE outside the surrogate's bound.
    """

    exploration: Exploration
    checks: list[dict]
    guard: dict
    summary: dict
    failures: list[str]

    @property
    def passed(self) -> bool:
        """No failure."""
        return not self.failures


def run_explore(
    calibration,
    space: DesignSpace,
    load_surrogate: Callable[[], tuple[object | None, str | None]],
    cache_dir: str | os.PathLike,
    *,
    n: int = 5,
    sample: int | None = None,
    seed: int = 0,
    spot_checks: int = 4,
    tolerance: float = DEFAULT_TOLERANCE,
    n_dense: int = DEFAULT_DENSE,
    geometry: Geometry | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    order: int = 2,
    resolution: float = 1.0,
    evaluate: Callable[[dict, dict], Mapping] | None = None,
    progress: bool = True,
) -> ExploreRun:
    """``isj explore`` as one library call: the designs of ``space``, guarded, spot-checked, summarised.

    The caller checks the inputs first (the command line in :mod:`isj._cli.explore`); nothing
    is written here.

    Parameters
    ----------
    calibration : isj.lumped.artifact.Calibration
    space : DesignSpace
        Usually an :class:`ExploreSpace`: :func:`explore_designs` with ``n``, ``sample``, ``seed``.
    load_surrogate : callable
        Called once, after the designs are made: ``(surrogate, None)``, or ``(None, why)`` to
        explore unguarded (``why`` is recorded as the guard's reason). Its time is recorded.
    cache_dir : path
        FE result cache.
    spot_checks, tolerance, n_dense, progress
        As in :func:`explore` (``tolerance`` is relative; it also decides the spot checks).
    geometry : Geometry, optional
        Dimensions (m) of the lumped model and the FE checks; default geometry when None.
    pressure_pa : float
        Pressure on the incus (Pa).
    order, resolution : int, float
        The FE model's element order and mesh refinement (:func:`isj.fem.batch.fe_settings`).
    evaluate : callable, optional
        FE evaluator; default :func:`isj.fem.batch.evaluate_design`.
    """
    from isj.fem.batch import evaluate_design, fe_settings

    designs = explore_designs(space, n, sample, seed)
    t0 = time.perf_counter()
    surrogate, why = load_surrogate()
    t_load = time.perf_counter() - t0
    # after the surrogate: its first build takes minutes, and the settings carry the FE results versions
    settings = fe_settings(order=order, resolution=resolution, geometry=geometry, pressure_pa=pressure_pa)
    ex = explore(
        calibration,
        designs,
        spot_checks,
        evaluate or evaluate_design,
        settings,
        cache_dir,
        seed=seed,
        progress=progress,
        surrogate=surrogate,
        tolerance=tolerance,
        n_dense=n_dense,
    )
    checks = _check_rows(ex, tolerance)
    guard = _guard_summary(ex, why, t_load)
    failures = _failures(checks, ex, guard, tolerance)
    summary = _summary(calibration, ex, checks, guard, tolerance, passed=not failures)
    return ExploreRun(exploration=ex, checks=checks, guard=guard, summary=summary, failures=failures)


def _summary(calibration, ex: Exploration, checks, guard: dict, tolerance: float, passed: bool) -> dict:
    """The JSON summary of ``isj explore``: ranges of α, β (rad) over the designs, checks, guard, region."""
    lum = ex.lumped
    return {
        "n_designs": ex.n_designs,
        "lumped_time_s": ex.lumped_time_s,
        "outside_domain": ex.outside_domain,
        "alpha_rad_range": [float(lum.alpha_rad.min()), float(lum.alpha_rad.max())],
        "beta_rad_range": [float(lum.beta_rad.min()), float(lum.beta_rad.max())],
        "tolerance": tolerance,
        "spot_checks": checks,
        "max_spot_error": ex.checks.max_abs_error(),
        "guard": guard,
        "region": _region_summary(calibration, ex),
        "passed": passed,
    }


def _check_rows(ex: Exploration, tolerance: float) -> list[dict]:
    """One JSON-able row per FE spot check of ``ex``."""
    comp = ex.checks
    passed = comp.passed(tolerance)
    ea, eb = comp.rel_error("alpha_rad"), comp.rel_error("beta_rad")
    return [
        {
            "set": ex.pick_sets[i],
            "design": comp.designs[i],
            "fe_alpha_rad": comp.fe_results[i]["alpha_rad"],
            "fe_beta_rad": comp.fe_results[i]["beta_rad"],
            "lumped_alpha_rad": float(comp.lumped_alpha_rad[i]),
            "lumped_beta_rad": float(comp.lumped_beta_rad[i]),
            "alpha_rel_error": float(ea[i]),
            "beta_rel_error": float(eb[i]),
            "passed": bool(passed[i]),
        }
        for i in range(comp.n)
    ]


def _guard_summary(ex: Exploration, why: str | None, load_time_s: float) -> dict:
    """The guard's summary with the surrogate's load time, or why there is no guard."""
    if ex.guard is None:
        return {"available": False, "reason": why}
    g = ex.guard.summary(ex.confirmations)
    g["surrogate_load_time_s"] = load_time_s  # from the cache, or the first build for this mesh
    return g


def _failures(checks: list[dict], ex: Exploration, guard: dict, tolerance: float) -> list[str]:
    """What fails the run: an explored design's spot check or guard, or FE outside the surrogate's bound.

    The spot checks of the corners and the dense sample are reported but fail nothing.
    """
    n_failed = sum(not ck["passed"] for ck in checks if ck["set"] == "explored")
    n_guard_failed = guard["explored"]["n_fail"] if ex.guard is not None else 0
    n_unconfirmed = sum(not r["confirmed"] for r in ex.confirmations)
    out = []
    if n_failed:
        out.append(f"{n_failed} FE spot check(s) of explored designs exceed the tolerance {tolerance:g}")
    if n_guard_failed:
        out.append(f"{n_guard_failed} explored design(s) fail the guard")
    if n_unconfirmed:
        out.append(f"FE lies outside the surrogate's bound at {n_unconfirmed} design(s)")
    return out


def _region_summary(calibration, ex: Exploration) -> dict | None:
    """How many explored designs lie outside the calibration's map of its tolerance (None: no map)."""
    if ex.in_region is None:
        return None
    n_out = int(ex.in_region.size - ex.in_region.sum())
    return {
        "tolerance": float(region_of(calibration)["tolerance"]),
        "n_outside": n_out,
        "n": int(ex.in_region.size),
    }
