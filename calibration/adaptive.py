"""Adaptive calibration: training designs added where the lumped model is worst (docs/lumped.md §3.15).

Starting from a calibration and its FE training records, each round

1. guards the lumped model with the certified surrogate of the FE model over the 2^d corners of
   the calibrated domain and a dense Sobol sample of it (:func:`isj.calibration.guard.run_guard`);
2. stops when the largest certified error is within the tolerance, or when over ``patience``
   rounds it has not fallen by ``min_gain`` (relative) and no fewer designs fail, or after
   ``max_rounds``;
3. else takes the ``per_round`` designs of largest certified error, runs FE there
   (``confirm``: true FE values, cached by the runner), checks that FE lies within the
   surrogate's bound, adds them to the training records and refits the factors
   (:func:`isj.calibration.fit.fit_factors`, started from the current ones).

The round with the fewest designs over the tolerance wins, ties by the smallest worst certified
error (a refit may move the worst design elsewhere; once the tolerance is out of reach, the
region where it holds, :mod:`isj.calibration.region`, is what a user gets). The surrogate and
the FE runs come from the caller (``isj calibrate --adaptive`` passes
:func:`isj.fem.rom.reduced_model`'s surrogate and :func:`isj.fem.batch.evaluate_design` through
the runner): this package never imports isj.fem, so it runs without gmsh. Any object
with the surrogate's ``space.bounds``, ``space.incus_e_pa``, ``evaluate(E, pressure_pa)`` and
``sizes()`` serves as the oracle (the tests use the lumped model itself with known factors).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from isj.lumped.model import FACTOR_NAMES

from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials
from isj.errors import InvalidParameter

from .fit import LOG_BOUND, fit_factors
from .guard import DEFAULT_DENSE, DEFAULT_TOLERANCE, GUARDED, Guard, run_guard, worst_picks

#: Designs added per round (the worst ones over the corners and the dense sample).
DEFAULT_PER_ROUND = 8

#: Most rounds.
DEFAULT_MAX_ROUNDS = 12

#: A round counts as progress when the worst certified error falls by at least this (relative).
DEFAULT_MIN_GAIN = 0.01

#: L^p norm of the refits: close to the largest error, still smooth for IPOPT.
DEFAULT_NORM = 8

#: Rounds without progress before the loop stops.
DEFAULT_PATIENCE = 3


@dataclass(frozen=True)
class AdaptiveResult:
    """The adaptive loop's outcome.

    Attributes
    ----------
    factors : the best round's factors, in :data:`isj.lumped.model.FACTOR_NAMES` order
    records : the best round's training records (the initial ones, then the added ones in order)
    added : per design added up to the best round ``{"round", "design", "confirmed", "certified_error"}``
    history : per round ``{"round", "n_train", "max_certified_error", "corners", "dense",
        "n_fail", "worst"}`` (errors relative; ``worst`` the design of largest certified error)
    best_round : index of the best round in ``history``: the fewest failing designs, then the
        smallest worst certified error
    reached : whether the best round's worst certified error is within the tolerance
    stop : why the loop ended: ``reached``, ``no progress`` or ``max rounds``
    iterations : IPOPT's iterations of the best round's fit (the starting calibration's for round 0)
    guard : the best round's guard
    """

    factors: np.ndarray
    records: list[dict]
    added: list[dict]
    history: list[dict]
    best_round: int
    reached: bool
    stop: str
    iterations: int | None = None
    guard: Guard = field(repr=False, default=None)

    @property
    def best(self) -> dict:
        return self.history[self.best_round]


def _check(name: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not lo <= value <= hi:
        raise InvalidParameter(f"{name} = {value!r}: must be an integer in [{lo}, {hi}]")
    return int(value)


def _round_summary(k: int, n_train: int, guard: Guard) -> dict:
    c, d = guard.sets["corners"].summary(), guard.sets["dense"].summary()
    worst = max((c, d), key=lambda s: -1.0 if s["max_certified_error"] is None else s["max_certified_error"])
    errs = [s["max_certified_error"] for s in (c, d)]
    return {
        "round": k,
        "n_train": n_train,
        "max_certified_error": math.inf if None in errs else max(errs),
        "corners": {"max_certified_error": c["max_certified_error"], "n_fail": c["n_fail"]},
        "dense": {"max_certified_error": d["max_certified_error"], "n_fail": d["n_fail"]},
        "n_fail": c["n_fail"] + d["n_fail"],
        "worst": {k2: v for k2, v in (worst["worst"] or {}).items() if k2.endswith("_e_pa")},
    }


def _round_line(row: dict) -> str:
    """The log line of a round's summary (:func:`_round_summary`)."""
    return (
        f"round {row['round']}: {row['n_train']} training designs; worst certified error "
        f"{100 * row['max_certified_error']:.2f} %, {row['n_fail']} fail"
    )


def _refit(records, geometry, factors, norm):
    """Refit from ``factors`` (a factor at 0, a term switched off, starts at the fit's floor)."""
    return fit_factors(records, geometry, x0=np.maximum(factors, np.exp(-LOG_BOUND)), norm=norm)


def _design(design: dict, domain) -> dict[str, float]:
    """The moduli of the domain, and any other one away from its default (the fit's records)."""
    base = Materials()
    return {k: v for k, v in design.items() if k in domain or v != getattr(base, k)}


def _confirmed(guard: Guard, picks, records: Sequence[dict], pressure_pa: float) -> list[bool]:
    """|FE − surrogate| ≤ bound for α and β at each pick (FE records per pascal)."""
    out = []
    for (name, i), rec in zip(picks, records, strict=True):
        s = guard.sets[name]
        ok = True
        for key, per_pa in (("alpha_rad", "alpha_per_pa"), ("beta_rad", "beta_per_pa")):
            fe = rec[per_pa] * pressure_pa
            ok &= abs(fe - float(s.surrogate[key][i])) <= float(s.surrogate[GUARDED[key]][i])
        out.append(bool(ok))
    return out


def _stalled(history: list[dict], k: int, patience: int, min_gain: float) -> bool:
    """No progress in the ``patience`` rounds up to ``k``: the worst certified error did not fall by
    ``min_gain`` and no fewer designs fail."""
    before, recent = history[k - patience], history[k - patience + 1 :]
    gain = min(h["max_certified_error"] for h in recent) <= before["max_certified_error"] * (1 - min_gain)
    fewer = min(h["n_fail"] for h in recent) < before["n_fail"]
    return not (gain or fewer)


def _new_picks(guard, seen: set, per_round: int, domain) -> tuple[list, list[dict]]:
    """The ``per_round`` worst guarded designs not trained on yet: (set, index) pairs and their moduli."""
    picks = [
        p
        for p in worst_picks(guard, per_round + len(seen))
        if tuple(sorted(_design(guard.sets[p[0]].design(p[1]), domain).items())) not in seen
    ][:per_round]
    return picks, [_design(guard.sets[name].design(i), domain) for name, i in picks]


def _added_rows(round_: int, guard, picks, designs: list[dict], confirmed: list[bool]) -> list[dict]:
    """One row per design added in round ``round_``: its set, moduli, FE confirmation and error."""
    return [
        {
            "round": round_,
            "set": name,
            "design": d,
            "confirmed": c,
            "certified_error": float(guard.sets[name].max_certified[i]),
        }
        for (name, i), d, c in zip(picks, designs, confirmed, strict=True)
    ]


def _best_round(history: list[dict]) -> int:
    """The best round: the fewest designs over the tolerance, then the smallest worst error (once the
    tolerance is out of reach, the region where it holds is what a user gets), then the earliest."""
    return min(
        range(len(history)), key=lambda j: (history[j]["n_fail"], history[j]["max_certified_error"], j)
    )


def _stopping_rules(per_round, max_rounds, patience, min_gain) -> tuple[int, int, int]:
    """``per_round``, ``max_rounds`` and ``patience`` as checked ints; ``min_gain`` checked in [0, 1)."""
    per_round = _check("per_round", per_round, 1, 1000)
    max_rounds = _check("max_rounds", max_rounds, 0, 1000)
    patience = _check("patience", patience, 1, 1000)
    if not (isinstance(min_gain, float | int) and 0 <= min_gain < 1):
        raise InvalidParameter(f"min_gain = {min_gain!r}: must lie in [0, 1)")
    return per_round, max_rounds, patience


def _starting_fit(calibration, records, geometry, refit_first: bool, norm) -> tuple[np.ndarray, int | None]:
    """Round 0's factors and IPOPT iterations: the calibration's, or a refit on ``records``."""
    factors = np.asarray(calibration.factor_array(), dtype=float)
    iterations = calibration.training.get("ipopt_iterations")
    if refit_first:
        fit = _refit(records, geometry, factors, norm)
        factors, iterations = fit.factors, fit.iterations
    return factors, iterations


def _guard_factors(calibration, factors: np.ndarray, oracle, **guard_options) -> Guard:
    """:func:`~isj.calibration.guard.run_guard` of the calibration with ``factors`` in place of its own."""
    cal = dataclasses.replace(calibration, factors=dict(zip(FACTOR_NAMES, map(float, factors), strict=True)))
    return run_guard(cal, oracle, {}, **guard_options)


def _stop_reason(
    history: list[dict], tolerance: float, max_rounds: int, patience: int, min_gain: float
) -> str | None:
    """Why the loop ends after the last round in ``history`` (:attr:`AdaptiveResult.stop`); None: go on."""
    k = len(history) - 1
    if history[k]["max_certified_error"] <= tolerance:
        return "reached"
    if k >= patience and _stalled(history, k, patience, min_gain):
        return "no progress"
    if k == max_rounds:
        return "max rounds"
    return None


def _confirm_worst(
    guard: Guard, seen: set, per_round: int, domain, confirm, pressure_pa: float, round_: int
) -> tuple[list[dict], list[dict]]:
    """FE at the worst designs not trained on yet: their records and their rows of ``added``.

    ``seen`` (sorted design items of every training design) gains the new designs.
    """
    picks, designs = _new_picks(guard, seen, per_round, domain)
    new = confirm(designs)
    if len(new) != len(designs):
        raise ValueError(f"confirm returned {len(new)} records for {len(designs)} designs")
    ok = _confirmed(guard, picks, new, pressure_pa)
    seen.update(tuple(sorted(d.items())) for d in designs)
    return list(new), _added_rows(round_, guard, picks, designs, ok)


def _best_result(history, fits, guards, records, added, tolerance: float, stop: str) -> AdaptiveResult:
    """The :class:`AdaptiveResult` of the best round (:func:`_best_round`) of the rounds run."""
    b = _best_round(history)
    n_train = history[b]["n_train"]
    return AdaptiveResult(
        factors=fits[b][0],
        iterations=fits[b][1],
        records=records[:n_train],  # the best round's training set
        added=[a for a in added if a["round"] <= b],
        history=history,
        best_round=b,
        reached=history[b]["max_certified_error"] <= tolerance,
        stop=stop,
        guard=guards[b],
    )


def adaptive_fit(
    calibration,
    records: Sequence[dict],
    oracle,
    confirm: Callable[[list[dict]], list[dict]],
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    n_dense: int = DEFAULT_DENSE,
    seed: int = 0,
    per_round: int = DEFAULT_PER_ROUND,
    max_rounds: int = DEFAULT_MAX_ROUNDS,
    min_gain: float = DEFAULT_MIN_GAIN,
    patience: int = DEFAULT_PATIENCE,
    geometry: Geometry | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    refit_first: bool = False,
    norm: float = DEFAULT_NORM,
    log: Callable[[str], None] | None = None,
) -> AdaptiveResult:
    """Add training designs where the lumped model is worst until it holds ``tolerance`` everywhere.

    Parameters
    ----------
    calibration : isj.lumped.artifact.Calibration
        The starting factors and the domain whose corners and dense sample are guarded.
    records : list of dict
        The FE training records ``{"design", "alpha_per_pa", "beta_per_pa"}`` (rad/Pa).
    oracle : isj.fem.rom.ReducedModel or alike
        The certified surrogate of the FE model on the calibration's mesh.
    confirm : callable
        ``confirm(designs) -> records``: FE at ``designs`` (moduli in Pa), one record each.
    tolerance : float
        Largest certified relative error aimed at (α, β and β/α).
    n_dense : int
        Dense Sobol designs guarded per round (seed ``seed``).
    per_round : int
        Designs added per round.
    max_rounds, min_gain, patience : stopping rules (module constants).
    refit_first : bool
        Refit on ``records`` before the first round (the starting factors otherwise).
    norm : float
        The refits' L^p norm of the relative errors (:func:`isj.calibration.fit.fit_factors`):
        the loop aims at the largest error, so p = 8 by default rather than least squares.
    log : callable, optional
        Called with one line per round.
    """
    per_round, max_rounds, patience = _stopping_rules(per_round, max_rounds, patience, min_gain)
    records = list(records)
    factors, iterations = _starting_fit(calibration, records, geometry, refit_first, norm)
    guard_options = {
        "tolerance": tolerance,
        "n_dense": n_dense,
        "seed": seed,
        "pressure_pa": pressure_pa,
        "geometry": geometry,
    }
    history, added, guards, fits = [], [], [], []
    seen = {tuple(sorted(r["design"].items())) for r in records}
    for k in range(max_rounds + 1):
        guard = _guard_factors(calibration, factors, oracle, **guard_options)
        row = _round_summary(k, len(records), guard)
        history.append(row)
        guards.append(guard)
        fits.append((factors, iterations))
        if log:
            log(_round_line(row))
        stop = _stop_reason(history, tolerance, max_rounds, patience, min_gain)
        if stop is not None:
            break
        new, rows = _confirm_worst(guard, seen, per_round, calibration.domain, confirm, pressure_pa, k + 1)
        added += rows
        records += new
        fit = _refit(records, geometry, factors, norm)
        factors, iterations = fit.factors, fit.iterations
    return _best_result(history, fits, guards, records, added, tolerance, stop)


def fe_confirm(
    evaluate, settings: dict, cache_dir, progress: bool = False, scheduler=None
) -> Callable[[list[dict]], list[dict]]:
    """``confirm`` for :func:`adaptive_fit`: FE through the runner (cached), as fit records.

    Without a scheduler the few designs of a round run in this process (``max_workers=0``): no
    worker start-up, and the FE model memoised by ``evaluate`` serves every round.
    """
    from .pipeline import records_for_fit
    from .runner import run_designs

    def confirm(designs: list[dict]) -> list[dict]:
        workers = None if scheduler is not None else 0
        recs = run_designs(
            designs,
            evaluate,
            settings,
            cache_dir,
            scheduler=scheduler,
            max_workers=workers,
            progress=progress,
        )
        return records_for_fit(recs)

    return confirm


def adaptive_calibration(
    calibration, result: AdaptiveResult, held_records: Sequence[dict], settings: dict, **options
) -> object:
    """The artifact of an adaptive fit: ``calibration`` with the best round's factors and errors.

    ``training`` holds the errors over every training record (initial and added), ``validation``
    those over ``held_records`` (designs no round added), and ``provenance["adaptive"]`` the loop:
    its settings (``options``), each round's worst certified error and the added designs.
    """
    from .pipeline import error_stats

    geometry = Geometry(**settings["geometry"]) if settings.get("geometry") else None
    f = result.factors
    fitted = {n: float(v) for n, v in zip(FACTOR_NAMES, f, strict=True)}
    training = error_stats(f, result.records, geometry) | {"ipopt_iterations": result.iterations}
    adaptive = {
        **options,
        "rounds": len(result.history) - 1,
        "best_round": result.best_round,
        "stop": result.stop,
        "reached": result.reached,
        "n_added": len(result.added),
        "n_unconfirmed": sum(not a["confirmed"] for a in result.added),
        "history": result.history,
        "added": result.added,
    }
    return dataclasses.replace(
        calibration,
        factors=fitted,
        training=training,
        validation=error_stats(f, list(held_records), geometry) if held_records else {},
        provenance=dict(calibration.provenance) | {"adaptive": adaptive},
    )


def calibrate_adaptive(
    evaluate,
    settings: dict,
    cache_dir,
    oracle,
    *,
    samples: int = 128,
    validation: int = 64,
    seed: int = 0,
    scheduler=None,
    progress: bool = True,
    region_sample: int | None = None,
    log: Callable[[str], None] | None = None,
    **loop,
):
    """:func:`calibration.pipeline.calibrate`, then :func:`adaptive_fit` on its training records.

    ``loop`` goes to :func:`adaptive_fit` (``tolerance``, ``n_dense``, ``per_round``,
    ``max_rounds``, ...); the dense sample takes ``seed``. The artifact carries the loop under
    ``provenance["adaptive"]`` and the map of the region where the tolerance holds under
    ``region`` (:func:`calibration.region.build_region`, ``region_sample`` designs).
    """
    from isj.design_space import DesignSpace

    from .doe import sample
    from .pipeline import calibrate, records_for_fit
    from .region import DEFAULT_MAP_SAMPLE, build_region
    from .runner import run_designs

    start = calibrate(
        evaluate, settings, cache_dir, samples, validation, seed, scheduler=scheduler, progress=progress
    )
    space = DesignSpace.from_dict(start.domain)
    train = sample(space, samples, seed, method="sobol")
    held = sample(space, validation, seed + 1, method="lhs") if validation else []
    recs = records_for_fit(run_designs(train + held, evaluate, settings, cache_dir, progress=False))
    geometry = Geometry(**settings["geometry"]) if settings.get("geometry") else None
    pressure = float(settings.get("pressure_pa", DEFAULT_PRESSURE_PA))
    confirm = fe_confirm(evaluate, settings, cache_dir, progress, scheduler)
    res = adaptive_fit(
        start,
        recs[: len(train)],
        oracle,
        confirm,
        seed=seed,
        geometry=geometry,
        pressure_pa=pressure,
        refit_first=True,
        log=log,
        **loop,
    )
    options = {"norm": DEFAULT_NORM, "n_dense": DEFAULT_DENSE, "tolerance": DEFAULT_TOLERANCE}
    options |= {"per_round": DEFAULT_PER_ROUND, "max_rounds": DEFAULT_MAX_ROUNDS} | loop | {"seed": seed}
    cal = adaptive_calibration(start, res, recs[len(train) :], settings, **options)
    n_map = DEFAULT_MAP_SAMPLE if region_sample is None else int(region_sample)
    tolerance = loop.get("tolerance", DEFAULT_TOLERANCE)
    region = build_region(
        cal, oracle, tolerance=tolerance, n_sample=n_map, seed=seed, pressure_pa=pressure, geometry=geometry
    )
    return dataclasses.replace(cal, region=region)
