"""``isj calibrate`` as one library call: the static fit of one kind, then the dynamic chain's.

:func:`run_calibration` chooses the static calibration (:func:`calibration.pipeline.calibrate`,
:func:`calibration.pipeline.calibrate_geometry` or, given the certified surrogate,
:func:`calibration.adaptive.calibrate_adaptive`), then fits the chain model's joint shear
factor to FE modal analyses (:func:`calibration.pipeline.calibrate_dynamics`) and returns the
artifact. FE enters through the evaluators passed in, so this module imports without gmsh; the
inputs are checked by the caller before it runs, and nothing is written here.
"""

from __future__ import annotations

from collections.abc import Callable

from .adaptive import DEFAULT_MAX_ROUNDS, DEFAULT_PER_ROUND, calibrate_adaptive
from .guard import DEFAULT_DENSE
from .pipeline import calibrate, calibrate_dynamics, calibrate_geometry


def run_calibration(
    evaluate,
    evaluate_modes,
    settings: dict,
    cache_dir,
    *,
    samples: int,
    validation: int,
    seed: int,
    modal_samples: int = 16,
    geometry_domain: bool = False,
    max_workers: int = 1,
    scheduler=None,
    progress: bool = False,
    surrogate=None,
    tolerance: float = 0.03,
    n_dense: int = DEFAULT_DENSE,
    per_round: int = DEFAULT_PER_ROUND,
    max_rounds: int = DEFAULT_MAX_ROUNDS,
    log: Callable[[str], None] | None = None,
):
    """The calibration of ``isj calibrate``: a :class:`isj.lumped.artifact.Calibration`.

    Parameters
    ----------
    evaluate, evaluate_modes : callable
        The FE static and modal evaluators (``isj.fem.batch.evaluate_design`` and
        ``evaluate_modes``), picklable, ``evaluate(design, settings) -> dict``.
    settings : dict
        The FE settings (``isj.fem.batch.fe_settings``).
    cache_dir : path
        The FE result cache.
    samples, validation, seed : int
        Training and held-out designs, and the seed of their design of experiments.
    modal_samples : int
        FE modal analyses for the chain's joint shear factor (0: none); half as many, at least
        2, hold it out, drawn with ``seed + 100``.
    geometry_domain : bool
        Sample the geometry with the moduli (on ``max_workers`` local processes or ``scheduler``).
    scheduler : str, optional
        A Dask scheduler's address.
    progress : bool
        Progress bars on stderr.
    surrogate : isj.fem.rom.ReducedModel, optional
        Given, the adaptive calibration (docs/lumped.md §3.15) with ``tolerance``, ``n_dense``,
        ``per_round``, ``max_rounds`` and ``log`` (one line per round).
    """
    # the options every kind of static calibration takes
    common = {
        "samples": samples,
        "validation": validation,
        "seed": seed,
        "scheduler": scheduler,
        "progress": progress,
    }
    if surrogate is not None:
        adaptive = {
            "tolerance": tolerance,
            "n_dense": n_dense,
            "per_round": per_round,
            "max_rounds": max_rounds,
        }
        cal = calibrate_adaptive(evaluate, settings, cache_dir, surrogate, log=log, **adaptive, **common)
    elif geometry_domain:
        cal = calibrate_geometry(evaluate, settings, cache_dir, max_workers=max_workers, **common)
    else:
        cal = calibrate(evaluate, settings, cache_dir, **common)
    if modal_samples:
        cal = _chain_calibration(cal, evaluate_modes, settings, cache_dir, modal_samples, seed, progress)
    return cal


def _chain_calibration(
    cal, evaluate_modes, settings: dict, cache_dir, modal_samples: int, seed: int, progress
):
    """``cal`` with the chain's joint shear factor fitted to ``modal_samples`` FE modal analyses.

    Half as many, at least 2, are held out; the designs are drawn with ``seed + 100`` so that
    they differ from the static ones.
    """
    return calibrate_dynamics(
        cal,
        evaluate_modes,
        settings,
        cache_dir,
        samples=modal_samples,
        validation=max(modal_samples // 2, 2),
        seed=seed + 100,
        progress=progress,
    )
