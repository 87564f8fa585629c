"""Versions of isj's results, by family: what every cache key holds in place of the code's text.

A cached result is keyed by its true inputs (a mesh's parameters or content hash, the
materials, the solver settings) and by :func:`versions` of the result families it depends
on. Each family's version is an integer in :data:`VERSIONS`, bumped by hand when, and only
when, a change of code changes that family's results: a refactor, a faster ordering or a
comment keeps every cache entry; a changed formula makes exactly the entries of the bumped
family and of the families that depend on it (:data:`DEPENDS`) unreachable.

Families
--------
``mesh``
    the gmsh meshes of :mod:`isj.fem.mesh` (and their content hashes);
``fe_static``
    assembly, solve and the static outputs (α, β, strain energy) of :mod:`isj.fem.model`
    and :func:`isj.fem.batch.evaluate_design`;
``fe_dynamic``
    the mass matrix, natural frequencies and harmonic responses (:mod:`isj.fem.dynamics`,
    :func:`isj.fem.batch.evaluate_modes`, :func:`isj.fem.batch.evaluate_harmonic`);
``ear``
    the FE whole ear and its reduction (:mod:`isj.fem.ear.middle_ear`,
    :mod:`isj.fem.ear.reduced_ear`);
``drum_modes``
    the eardrum's component modes (:mod:`isj.fem.ear.drum_modes`) and the lumped drum built
    from them;
``surrogate``
    the certified reduced-basis surrogate (:mod:`isj.fem.rom`);
``lumped``
    the lumped model's equations (:mod:`isj.lumped`), static and dynamic.

Report steps add a version each (:data:`STEP_VERSIONS`) for the code of their own, in
:mod:`isj.reports`, and name the families they read (:data:`STEP_FAMILIES`).

Third-party versions that change results are part of the key too (:data:`LIBRARIES`):
gmsh's full version for meshes (a new gmsh may place nodes differently), numpy's and
scipy's major.minor for the FE families and the drum modes (their sparse solvers,
eigensolvers and bundled BLAS change the last bits; a minor release may change more). The
solver backend (PARDISO or SuperLU) and its thread count are not: they change results
below the honesty tolerance (``tests/test_results_version.py``).

The versions are kept honest by ``tests/test_results_version.py``: it recomputes stored
reference values (``tests/data/results_reference.json``) of every family and fails when a
value differs while its family's version is unchanged (docs/developer/cache-keys.md).
"""

from __future__ import annotations

import functools
import importlib.metadata

from isj.errors import InvalidParameter

#: The version of each result family: bump one by 1 when a change alters its results
#: (then regenerate the reference values, docs/developer/cache-keys.md §3).
VERSIONS = {
    "mesh": 1,
    "fe_static": 1,
    "fe_dynamic": 1,
    "ear": 2,
    "drum_modes": 2,
    "surrogate": 2,
    "lumped": 1,
}

#: The families each family's results are computed from (its key holds their versions too).
DEPENDS = {
    "mesh": (),
    "fe_static": ("mesh",),
    "fe_dynamic": ("fe_static",),
    "ear": ("fe_dynamic",),
    "drum_modes": (),
    "surrogate": ("fe_static",),
    "lumped": (),
}

#: Third-party packages whose version is part of a family's key, and how much of it:
#: "full" (every part of the version) or "minor" (major.minor).
LIBRARIES = {
    "mesh": {"gmsh": "full"},
    "fe_static": {"numpy": "minor", "scipy": "minor"},
    "drum_modes": {"numpy": "minor", "scipy": "minor"},
}

#: The version of each report step's own code (:data:`isj.reports.steps.STEPS`).
STEP_VERSIONS = {
    "model": 1,
    "sweep": 1,
    "cases": 1,
    "trends": 1,
    "convergence": 1,
    "calibration": 1,
    "ear": 1,
    "transmission": 4,
    "load_path": 1,
    "sliding": 1,
    "guard": 1,
    "uq": 2,
    "geometry_trends": 1,
}

#: The result families each report step reads (closed over :data:`DEPENDS` by :func:`versions`).
#: ``tests/test_cache_keys.py`` checks them against the modules each step's code reaches.
STEP_FAMILIES = {
    "model": ("fe_static", "fe_dynamic"),
    "cases": ("fe_static", "fe_dynamic", "lumped"),
    "trends": ("fe_static", "fe_dynamic", "lumped"),
    "convergence": ("fe_static", "fe_dynamic"),
    "calibration": ("fe_static", "fe_dynamic", "lumped"),
    "sweep": ("fe_static", "fe_dynamic", "lumped", "drum_modes"),
    "ear": ("fe_static", "fe_dynamic", "ear"),
    "transmission": ("fe_static", "fe_dynamic", "ear"),
    "load_path": ("lumped", "drum_modes"),
    "sliding": ("fe_static", "fe_dynamic", "lumped"),
    "guard": ("fe_static", "fe_dynamic", "surrogate", "ear", "lumped"),
    "uq": ("lumped", "drum_modes", "fe_static", "fe_dynamic", "ear"),
    "geometry_trends": ("fe_static", "fe_dynamic", "lumped"),
}


def families(*names: str) -> tuple[str, ...]:
    """``names`` and every family they depend on (:data:`DEPENDS`), transitively; sorted.

    Raises
    ------
    InvalidParameter
        A name that is not a family of :data:`VERSIONS`.
    """
    seen: set[str] = set()
    todo = list(names)
    while todo:
        name = todo.pop()
        if name not in VERSIONS:
            raise InvalidParameter(f"result family = {name!r}: must be one of {sorted(VERSIONS)}")
        if name not in seen:
            seen.add(name)
            todo.extend(DEPENDS[name])
    return tuple(sorted(seen))


@functools.cache
def library_version(name: str) -> str:
    """The installed version of the package ``name`` (its distribution metadata), or "absent".

    Read without importing the package: the calibration keys FE results without gmsh.
    """
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "absent"


def _trimmed(version: str, part: str) -> str:
    return version if part == "full" else ".".join(version.split(".")[:2])


def versions(*names: str) -> dict[str, int | str]:
    """What a result of the families ``names`` depends on besides its inputs, for a cache key.

    Returns
    -------
    dict
        Family → version for ``names`` and the families they depend on, and package →
        version for the third-party packages of those families (:data:`LIBRARIES`), e.g.
        ``{"fe_static": 1, "gmsh": "4.15.2", "mesh": 1, "numpy": "2.4", "scipy": "1.17"}``.
        JSON-able, sorted by key.

    Examples
    --------
    >>> versions("mesh")["mesh"] == VERSIONS["mesh"]
    True
    """
    out: dict[str, int | str] = {}
    for fam in families(*names):
        out[fam] = VERSIONS[fam]
        for lib, part in LIBRARIES.get(fam, {}).items():
            out[lib] = _trimmed(library_version(lib), part)
    return dict(sorted(out.items()))


def step_versions(step: str) -> dict[str, int | str]:
    """The versions a report step's key holds: its own (``"step"``) and its families' (:func:`versions`).

    Raises
    ------
    InvalidParameter
        A step without a version in :data:`STEP_VERSIONS`.
    """
    if step not in STEP_VERSIONS:
        raise InvalidParameter(f"report step = {step!r}: must be one of {sorted(STEP_VERSIONS)}")
    return {"step": STEP_VERSIONS[step]} | versions(*STEP_FAMILIES[step])
