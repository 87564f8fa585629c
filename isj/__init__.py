"""isj: mechanics of the coupling between the incus and the stapes.

The package holds the shared vocabulary (design parameters, the thesis cases,
result types) and the command line; the models live in its subpackages
``isj.fem``, ``isj.lumped``, ``isj.calibration`` and ``isj.reports``.

The entry points are importable from here (``isj.__all__``):

>>> import isj
>>> lm = isj.LumpedModel.default()                       # the calibrated lumped model
>>> model = isj.PedicleJointModel(order=1, resolution=0.5)   # doctest: +SKIP
>>> model.static(isj.Materials(gap_e_pa=5e6)).to_dict()       # doctest: +SKIP

Names are imported on first use (PEP 562), so ``import isj`` stays light (no
gmsh, SciPy or CasADi) and the subpackages, which import ``isj.design``, meet
no import cycle.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

#: Public name → the module that defines it.
_LAZY: dict[str, str] = {
    # the vocabulary
    "Geometry": "isj.design",
    "Materials": "isj.design",
    "REGIONS": "isj.design",
    "DEFAULT_PRESSURE_PA": "isj.design",
    "IsjError": "isj.errors",
    "IsjWarning": "isj.errors",
    "InvalidParameter": "isj.errors",
    "OutOfDomainWarning": "isj.errors",
    "EarGeometry": "isj.ear",
    "EarMaterials": "isj.ear",
    "EarMasses": "isj.ear",
    "ThesisCase": "isj.cases",
    "THESIS_CASES": "isj.cases",
    "case_by_name": "isj.cases",
    "FrequencyResponse": "isj.responses",
    # the FE models
    "PedicleJointModel": "isj.fem.model",
    "StaticResult": "isj.fem.model",
    "Damping": "isj.damping",
    "MiddleEarModel": "isj.fem.ear.middle_ear",
    "EarStaticResult": "isj.fem.ear.middle_ear",
    "EarHarmonicResult": "isj.fem.ear.dynamics",
    # the lumped model and its calibration
    "LumpedModel": "isj.lumped.api",
    "LumpedStaticResult": "isj.lumped.api",
    "Calibration": "isj.lumped.artifact",
    "DesignSpace": "isj.design_space",
    "sample": "isj.calibration.doe",
}

__all__ = ["__version__", *sorted(_LAZY)]


def __getattr__(name: str):
    """Import a public name from its module on first access (PEP 562) and keep it here."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'isj' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
