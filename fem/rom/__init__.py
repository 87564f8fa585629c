"""Certified reduced-basis surrogate of the static FE model (docs/rom.md §10).

:func:`reduced_model` builds (once per mesh, then from the cache) a :class:`ReducedModel`
whose :meth:`~ReducedModel.evaluate` gives α, β, α + β and β/α with rigorous bounds on their
difference from the FE model on the same mesh, at a cost independent of the mesh size.
"""

from .model import ReducedModel, build_reduced_model, reduced_model, rom_cache_dir


def thesis_cases(rom: ReducedModel | None = None, pressure_pa: float | None = None) -> list[dict]:
    """The seven thesis cases through the surrogate (default: the default mesh's), with bounds."""
    from isj.design import DEFAULT_PRESSURE_PA

    rom = rom or reduced_model()
    return rom.cases(DEFAULT_PRESSURE_PA if pressure_pa is None else pressure_pa)


__all__ = [
    "ReducedModel",
    "build_reduced_model",
    "reduced_model",
    "rom_cache_dir",
    "thesis_cases",
]
