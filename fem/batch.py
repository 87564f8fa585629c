"""One FE evaluation per design, for batch runners (``calibration.runner``).

:func:`evaluate_design` is a picklable top-level function taking and returning
plain JSON-able data. Building a model (meshing and assembly) costs seconds
and a solve with new moduli about as much again, so each process keeps its
models in a module-level dict keyed by (geometry, order, resolution) and only
solves for the next design.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Iterator, Mapping
from contextlib import contextmanager

from isj.design import DEFAULT_PRESSURE_PA, REGIONS, Geometry, Materials, check_pressure
from isj.errors import InvalidParameter
from isj.results_version import versions

from .model import PedicleJointModel

#: Keys a settings dict may hold (see :func:`fe_settings`).
SETTINGS_KEYS = frozenset({"order", "resolution", "geometry", "pressure_pa", "versions", "joint"})

#: Keys a design may hold: the Young's moduli (Pa) and Poisson's ratio.
DESIGN_KEYS = frozenset({f"{r}_e_pa" for r in REGIONS} | {"nu"})

#: Models built in this process, by (geometry fields, order, resolution); few, since each holds
#: its matrices and factorization (tens to hundreds of MB).
_MODELS: dict[tuple, tuple[PedicleJointModel, str]] = {}
_MAX_MODELS = 4
# gmsh is process-global state and a model's solver is refactored in place, so
# threads of one process (Dask threaded workers) must take turns
_LOCK = threading.RLock()


def results_versions(kind: str = "static") -> dict:
    """The results versions (:func:`isj.results_version.versions`) of one kind of FE result.

    ``kind``: "static" (:func:`evaluate_design`: the ``fe_static`` family and the meshes),
    "modes" or "harmonic" (:func:`evaluate_modes`, :func:`evaluate_harmonic`: ``fe_dynamic``
    too). Part of every cached result's key in place of the FE code's text: a change to
    ``fem/`` that changes results bumps a version, one that does not keeps every entry.
    """
    if kind not in _FAMILY:
        raise InvalidParameter(f"kind = {kind!r}: must be one of {sorted(_FAMILY)}")
    return versions(_FAMILY[kind])


#: The result family of each kind of evaluation.
_FAMILY = {"static": "fe_static", "modes": "fe_dynamic", "harmonic": "fe_dynamic"}


def _check_versions(settings: Mapping, kind: str) -> None:
    """InvalidParameter when ``settings`` carry the results versions of other FE code.

    ``settings["versions"]`` must hold only versions that this code's results of ``kind``
    depend on, each at its present value: those of :func:`fe_settings` (static) or of ``kind``.
    A result computed now would be cached under a key that claims other results (a Dask
    worker with another isj refuses the designs).
    """
    have, mine = settings.get("versions"), results_versions(kind)
    if have is not None and not (isinstance(have, Mapping) and have.items() <= mine.items()):
        raise InvalidParameter(
            f"settings['versions'] = {settings['versions']!r}: this FE code's {kind} results are "
            f"version {results_versions(kind)!r}; rebuild the settings with fe_settings()"
        )


def fe_settings(
    order: int = 2,
    resolution: float = 1.0,
    geometry: Geometry | Mapping | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    joint: str = "bonded",
) -> dict:
    """Canonical settings for :func:`evaluate_design`, every value explicit.

    Parameters
    ----------
    order : 1 or 2 (P1 or P2 tetrahedra)
    resolution : refinement factor of every element size (> 0)
    geometry : Geometry or dict of its fields (m); None = defaults
    pressure_pa : load on the incus's −x face (Pa)
    joint : "bonded" or "sliding" (:data:`isj.fem.sliding.JOINTS`; the layer's shear modulus
        is not a setting, so "layer" is refused)

    Returns
    -------
    dict
        ``{"order", "resolution", "geometry" (all fields, m), "pressure_pa", "versions"}``
        (``versions``: :func:`results_versions` of the static results; the result runner
        puts those of the evaluator's kind there, :data:`evaluate_modes.result_families`), and
        ``"joint"`` for a joint other than bonded (so bonded settings and their cache keys are
        those of before the joint existed): JSON-able, so it can key a result cache.
    """
    geom = _geometry(geometry)
    _check_mesh(order, resolution)
    joint = _joint(joint)
    return {
        "order": int(order),
        "resolution": float(resolution),
        "geometry": dataclasses.asdict(geom),
        "pressure_pa": check_pressure(pressure_pa),
        "versions": results_versions("static"),
    } | ({"joint": joint} if joint != "bonded" else {})


def _joint(joint) -> str:
    if joint not in ("bonded", "sliding"):
        raise InvalidParameter(f"joint = {joint!r}: must be bonded or sliding")
    return joint


def _geometry(geometry: Geometry | Mapping | None) -> Geometry:
    if geometry is None or isinstance(geometry, Geometry):
        return geometry or Geometry()
    unknown = set(geometry) - {f.name for f in dataclasses.fields(Geometry)}
    if unknown:
        raise InvalidParameter(f"unknown geometry fields {sorted(unknown)}")
    return Geometry(**{k: float(v) for k, v in geometry.items()})


def _check_mesh(order, resolution) -> None:
    if order not in (1, 2) or isinstance(order, bool):
        raise InvalidParameter(f"order = {order!r}: must be 1 or 2")
    if not isinstance(resolution, int | float) or not 0 < resolution < float("inf"):
        raise InvalidParameter(f"resolution = {resolution!r}: must be a finite number > 0")


def _model(
    geometry: Geometry, order: int, resolution: float, joint: str = "bonded"
) -> tuple[PedicleJointModel, str]:
    """The memoised (model, mesh content hash) for this process."""
    key = (tuple(dataclasses.asdict(geometry).items()), order, resolution, joint)
    if key not in _MODELS:
        scope = _TRANSIENT[-1] if _TRANSIENT else None
        if scope is not None and len(scope["new"]) >= scope["max_new"]:
            _MODELS.pop(scope["new"].pop(0), None)  # the block's oldest model: it is done with it
        if len(_MODELS) >= _MAX_MODELS:
            _MODELS.pop(next(iter(_MODELS)))  # oldest first
        # no analysis ahead (ElasticModel.analyse_ahead) here: its 145 MB, held while the model is
        # assembled, raised a report's peak memory by about 0.2 GB (docs/performance.md §8.10)
        model = PedicleJointModel(geometry, order=order, resolution=resolution, joint=joint)
        _MODELS[key] = (model, model.mesh.content_hash())
        if scope is not None:
            scope["new"].append(key)
    return _MODELS[key]


#: The open :func:`transient_models` blocks, innermost last.
_TRANSIENT: list[dict] = []

#: What :func:`transient_models` drops on entering, besides the models: the clear methods of
#: other memos that hold models (:mod:`fem.ear.shared` adds its ears when it is imported).
TRANSIENT_CLEARS: list = []


@contextmanager
def transient_models(max_new: int = 1) -> Iterator[None]:
    """A block whose new models are not kept: at most ``max_new`` of them are memoised at a
    time (the oldest is dropped for the next), and on leaving the block this process's
    memoised models are again those it had before it.

    For work over many geometries that are not needed again (each model holds its matrices
    and factorization: the report's geometry trends held 2.5 GB more without it,
    docs/performance.md §8.6). Results are the same: only what is kept in memory changes. The
    memos of :data:`TRANSIENT_CLEARS` (the shared ears, :func:`fem.ear.shared.shared_ear`) are
    emptied on entering: such work does not need them, and each ear holds hundreds of MB (a
    later caller builds them again). The models kept from before the block release their
    factorizations (each a few hundred MB on the default mesh; a later solve factors again, and
    their kept static results stay).
    """
    if isinstance(max_new, bool) or not isinstance(max_new, int) or max_new < 1:
        raise InvalidParameter(f"max_new = {max_new!r}: must be an integer >= 1")
    with _LOCK:
        for clear in TRANSIENT_CLEARS:
            clear()
        free_solvers()
        before = dict(_MODELS)
        _TRANSIENT.append({"max_new": max_new, "new": []})
    try:
        yield
    finally:
        with _LOCK:
            _TRANSIENT.pop()
            _MODELS.clear()
            _MODELS.update(before)


def free_solvers() -> None:
    """Release the factorizations this process's memoised models keep (a few hundred MB each on
    the default mesh). The models, their orderings and their kept static results stay; a later
    solve analyses and factors again."""
    with _LOCK:
        for model, _ in _MODELS.values():
            model.free_solver()


def shared_model(settings: Mapping) -> tuple[PedicleJointModel, str]:
    """The (model, mesh hash) this process memoises for ``settings`` (see :func:`fe_settings`).

    For callers that need the model itself (pictures, exports) and want the
    meshing and assembly :func:`evaluate_design` has done, or will do, only once.
    """
    order, resolution = settings.get("order", 2), settings.get("resolution", 1.0)
    _check_mesh(order, resolution)
    with _LOCK:
        joint = _joint(settings.get("joint", "bonded"))
        return _model(_geometry(settings.get("geometry")), int(order), float(resolution), joint)


def evaluate_design(design: Mapping, settings: Mapping) -> dict:
    """Static FE response of one design (SI units, plain Python types).

    Parameters
    ----------
    design : dict
        Moduli over ``Materials()`` defaults: ``"pedicle_e_pa"``, ``"gap_e_pa"``,
        ... (Pa), optionally ``"nu"``.
    settings : dict
        ``order`` (default 2), ``resolution`` (default 1.0), ``geometry``
        (dict of :class:`~isj.design.Geometry` fields, m), ``pressure_pa``
        (default ``DEFAULT_PRESSURE_PA``), ``joint`` (default ``"bonded"``); best made by
        :func:`fe_settings`.

    Returns
    -------
    dict
        ``alpha_rad``, ``beta_rad``, ``alpha_ls_rad``, ``beta_ls_rad`` (rad),
        ``max_disp_m`` (m), ``strain_energy_j`` (J per region), ``n_dofs``,
        ``mesh_hash`` (sha256 of the mesh).

    Raises
    ------
    InvalidParameter
        Unknown keys or invalid values; settings whose ``versions`` are those of other FE
        results (:func:`results_versions`).
    """
    unknown = set(settings) - SETTINGS_KEYS
    if unknown:
        raise InvalidParameter(f"unknown settings {sorted(unknown)}; valid: {sorted(SETTINGS_KEYS)}")
    unknown = set(design) - DESIGN_KEYS
    if unknown:
        raise InvalidParameter(f"unknown design keys {sorted(unknown)}; valid: {sorted(DESIGN_KEYS)}")
    _check_versions(settings, "static")
    order = settings.get("order", 2)
    resolution = settings.get("resolution", 1.0)
    _check_mesh(order, resolution)
    geometry = _geometry(settings.get("geometry"))
    pressure = check_pressure(settings.get("pressure_pa", DEFAULT_PRESSURE_PA))
    joint = _joint(settings.get("joint", "bonded"))
    materials = Materials(**{k: float(v) for k, v in design.items()})
    with _LOCK:
        model, mesh_hash = _model(geometry, int(order), float(resolution), joint)
        res = model.static(materials, pressure)
        n_dofs = int(model.n_dofs)
    return {
        "alpha_rad": float(res.alpha_rad),
        "beta_rad": float(res.beta_rad),
        "alpha_ls_rad": float(res.alpha_ls_rad),
        "beta_ls_rad": float(res.beta_ls_rad),
        "max_disp_m": float(res.max_disp_m),
        "strain_energy_j": {str(k): float(v) for k, v in res.strain_energy_j.items()},
        "n_dofs": n_dofs,
        "mesh_hash": mesh_hash,
    }


def evaluate_modes(design: Mapping, settings: Mapping) -> dict:
    """Lowest in-plane natural frequencies (Hz) of one design: the modes the x load excites.

    ``settings`` as for :func:`evaluate_design` plus ``n_modes`` (modes computed,
    default 6). A mode counts as in-plane (x–z, the plane the load acts in) when
    Σ u_y² < 0.05 Σ u_x² over its nodes: the y-bending and torsion modes, which
    the x load does not excite by symmetry, fail that test.

    Returns
    -------
    dict
        ``freq_hz`` (all computed), ``in_plane_freq_hz``, ``mesh_hash``.
    """
    from .dynamics import modes

    s = dict(settings)
    n = int(s.pop("n_modes", 6))
    s.pop("kind", None)
    unknown = set(s) - SETTINGS_KEYS
    if unknown:
        raise InvalidParameter(f"unknown settings {sorted(unknown)}; valid: {sorted(SETTINGS_KEYS)}")
    _check_versions(s, "modes")
    geometry = _geometry(s.get("geometry"))
    order, resolution = s.get("order", 2), s.get("resolution", 1.0)
    _check_mesh(order, resolution)
    joint = _joint(s.get("joint", "bonded"))
    materials = Materials(**{k: float(v) for k, v in design.items()})
    with _LOCK:
        model, mesh_hash = _model(geometry, int(order), float(resolution), joint)
        freq, shapes = modes(model, materials, n)
    u = shapes.reshape(-1, 3, shapes.shape[1])
    y_fraction = (u[:, 1, :] ** 2).sum(axis=0) / (u[:, 0, :] ** 2).sum(axis=0)
    in_plane = freq[y_fraction < 0.05]
    return {
        "freq_hz": [float(f) for f in freq],
        "in_plane_freq_hz": [float(f) for f in in_plane],
        "y_to_x_fraction": [float(v) for v in y_fraction],
        "mesh_hash": mesh_hash,
    }


#: Extra settings of :func:`evaluate_harmonic`: frequencies (Hz) and damping (docs/dynamics.md §4.3):
#: ``damping`` (:meth:`isj.damping.Damping.to_dict`) and/or changes to it by field.
HARMONIC_KEYS = frozenset(
    {
        "kind",
        "freq_hz",
        "damping",
        "rayleigh_a_per_s",
        "rayleigh_b_s",
        "loss_factor",
        "cochlear_impedance_pa_s_m3",
    }
)


def evaluate_harmonic(design: Mapping, settings: Mapping) -> dict:
    """Damped harmonic response of one design at a few frequencies (FE, docs/dynamics.md §4.5).

    ``settings`` as for :func:`evaluate_design` plus ``freq_hz`` (list, Hz) and
    the damping: ``damping``, a :meth:`isj.damping.Damping.to_dict` (default: the published
    loss factors), changed by ``rayleigh_a_per_s``, ``rayleigh_b_s``, ``loss_factor`` (numbers
    for every region or mappings region → value).

    Returns
    -------
    dict
        ``freq_hz`` and, per output (``alpha_rad``, ``beta_rad``, ``incus_ux_m``),
        ``{output}_re`` and ``{output}_im``: lists over the frequencies (rad, m).
    """
    from isj.damping import Damping, resolve

    from .dynamics import harmonic_outputs

    s = dict(settings)
    extra = {k: s.pop(k) for k in HARMONIC_KEYS if k in s}
    unknown = set(s) - SETTINGS_KEYS
    if unknown:
        raise InvalidParameter(
            f"unknown settings {sorted(unknown)}; valid: {sorted(SETTINGS_KEYS | HARMONIC_KEYS)}"
        )
    _check_versions(s, "harmonic")
    freq = [float(f) for f in extra.get("freq_hz", ())]
    if not freq:
        raise InvalidParameter("settings['freq_hz']: must list at least one frequency (Hz)")
    base = extra.get("damping")
    damping = resolve(
        Damping.from_dict(base) if isinstance(base, Mapping) else base,
        **{
            k: extra[k]
            for k in ("rayleigh_a_per_s", "rayleigh_b_s", "loss_factor", "cochlear_impedance_pa_s_m3")
            if k in extra
        },
    )
    pressure = check_pressure(s.get("pressure_pa", DEFAULT_PRESSURE_PA))
    materials = Materials(**{k: float(v) for k, v in design.items()})
    model, mesh_hash = shared_model(s)
    with _LOCK:
        out = harmonic_outputs(model, freq, materials, damping, pressure)
    result = {"freq_hz": freq, "mesh_hash": mesh_hash}
    for k, v in out.items():
        result[f"{k}_re"] = [float(x) for x in v.real]
        result[f"{k}_im"] = [float(x) for x in v.imag]
    return result


# The result families of each evaluator: calibration.runner keys its results with their
# versions (calibration may not import fem, so it reads them off the function it is given).
evaluate_design.result_families = ("fe_static",)
evaluate_modes.result_families = ("fe_dynamic",)
evaluate_harmonic.result_families = ("fe_dynamic",)
