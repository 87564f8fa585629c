"""Every error and warning class of isj, in one place.

Each error derives from :class:`IsjError` and also from the builtin exception
it is, so ``except ValueError`` keeps catching a bad parameter and
``except IsjError`` catches anything the project raises on purpose. Warnings
derive from :class:`IsjWarning` (a :class:`UserWarning`), so one
``warnings.simplefilter("error", IsjWarning)`` turns all of them into errors.

The modules that used to define these classes (``isj.design``,
``isj.fem.mesh``, ``isj.calibration.runner``, ...) import them from here, so
the old names keep working.
"""

from __future__ import annotations

__all__ = [
    "IsjError",
    "InvalidParameter",
    "UsageError",
    "ConfigError",
    "MeshError",
    "InvalidMesh",
    "SolverUnavailable",
    "SolverFailed",
    "PointOutsideBody",
    "CorruptCalibration",
    "FitFailed",
    "EvaluationError",
    "IsjWarning",
    "CacheWarning",
    "CorruptCacheEntry",
    "OutOfDomainWarning",
    "CalibrationWarning",
    "VolumetricLockingWarning",
    "DampingWarning",
]


class IsjError(Exception):
    """Common base of every error isj raises on purpose."""


# -- bad input ---------------------------------------------------------------


class InvalidParameter(IsjError, ValueError):
    """A design or model parameter is non-physical or inconsistent with the others."""


class UsageError(IsjError, ValueError):
    """A command-line value is outside its valid range."""


class ConfigError(IsjError, ValueError):
    """A report configuration names an unknown key or holds a bad value."""


class PointOutsideBody(IsjError, ValueError):
    """A probe point lies outside the body it is meant to sample."""


class CorruptCalibration(IsjError, ValueError):
    """A calibration file is missing, unreadable or inconsistent."""


class InvalidMesh(IsjError, ValueError):
    """A user's mesh file is unreadable, lacks a named group, or is no valid model mesh
    (an inverted element, a region touching nothing, a non-conforming interface, too large)."""


# -- failures while computing -------------------------------------------------


class MeshError(IsjError, RuntimeError):
    """Gmsh failed to build or mesh the model."""


class SolverUnavailable(IsjError, RuntimeError):
    """The requested solver backend is not installed here."""


class SolverFailed(IsjError, RuntimeError):
    """The sparse solver could not factor or solve a system.

    Raised for a matrix that is not positive definite where a Cholesky factor is
    asked for (a body with a rigid-body mode left free), a pattern without its
    diagonal, or the solver's own failure (memory). The message names the
    solver's error code.
    """


class FitFailed(IsjError, RuntimeError):
    """IPOPT did not converge; ``stats`` holds the solver's statistics.

    Parameters
    ----------
    message : str
        What failed.
    stats : dict
        IPOPT's statistics (``return_status``, iteration count, ...).
    """

    def __init__(self, message: str, stats: dict):
        super().__init__(message)
        self.stats = stats


class EvaluationError(IsjError, RuntimeError):
    """One or more designs failed to evaluate.

    Parameters
    ----------
    message : str
        What failed.
    failures : list of (dict, BaseException)
        Each failed design with the exception it raised.
    """

    def __init__(self, message: str, failures: list[tuple[dict, BaseException]]):
        super().__init__(message)
        self.failures = failures


# -- warnings -------------------------------------------------------------------


class IsjWarning(UserWarning):
    """Common base of every warning isj emits."""


class CacheWarning(IsjWarning):
    """A cache entry was unreadable, or could not be written; the result was recomputed."""


class CorruptCacheEntry(CacheWarning):
    """A cached record was unreadable or inconsistent; it was deleted and will be recomputed."""


class OutOfDomainWarning(IsjWarning):
    """A design lies outside the domain the lumped model was calibrated on (an extrapolation)."""


class CalibrationWarning(IsjWarning):
    """Settings differ from those the calibration was made with (e.g. FE checks at another mesh)."""


class VolumetricLockingWarning(IsjWarning):
    """Poisson's ratio so close to 0.5 that displacement elements lock (see ``isj.fem.model``)."""


class DampingWarning(IsjWarning):
    """A Rayleigh damping term is large inside the requested band (ωb or a/ω > 0.5): there the
    damping law, not the structure, shapes the response (docs/dynamics.md §4.3)."""
