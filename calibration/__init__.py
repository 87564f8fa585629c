"""Calibration of the lumped model against FE results (docs/lumped.md §3).

``calibration.doe`` draws designs (moduli in Pa) log-uniformly from the
calibration space; ``calibration.runner`` evaluates them through a process pool
or Dask, caching every record on disk. The FE evaluator itself
(``fem.batch.evaluate_design``) is passed in by the caller: this package never
imports ``fem`` or gmsh.
"""

from .doe import corners, grid, sample
from .runner import ResultCache, design_key, run_designs

__all__ = [
    "ResultCache",
    "corners",
    "design_key",
    "grid",
    "run_designs",
    "sample",
]
