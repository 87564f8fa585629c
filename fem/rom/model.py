"""The certified surrogate: build once per mesh, cache, then α, β and their bounds for any design.

>>> rom = reduced_model(order=2, resolution=1.0)          # doctest: +SKIP
>>> out = rom.evaluate(gap_e_pa=[5e6, 2e7])               # doctest: +SKIP
>>> out["alpha_rad"], out["alpha_bound_rad"]              # doctest: +SKIP

A built surrogate is stored in ``$ISJ_FE_CACHE_DIR/rom`` (default
``~/.cache/isj/fe/rom``) as one checksummed NPZ entry (:mod:`isj.cachefile`), keyed
by the mesh's content hash, the element order, the geometry, the design space, the
greedy's settings and the results versions of the surrogate and of the FE model it reduces
(:func:`isj.results_version.versions`, docs/developer/cache-keys.md). A damaged entry is
reported, deleted and rebuilt. A build in progress keeps its finished greedy steps beside
the entry and resumes from them if killed; two builds of one entry take turns (:func:`reduced_model`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from isj.atomic import file_lock
from isj.cachefile import DamagedEntry, canonical_json, discard, read_npz_entry, write_npz_entry
from isj.design import DEFAULT_PRESSURE_PA, Geometry, check_pressure
from isj.design_space import RANGED, DesignSpace
from isj.errors import CacheWarning, InvalidParameter
from isj.results_version import versions

from .local import evaluate_local, unpack
from .online import derived_bounds, evaluate_unit

#: Bump when the stored arrays change meaning.
ROM_FORMAT_VERSION = 2

#: Default greedy settings: target relative bound, training and validation sample sizes.
DEFAULT_TOL = 1e-3
N_TRAIN = 1024
N_VALIDATE = 8192
MAX_SNAPSHOTS = 120

#: Surrogates shipped with isj (the default mesh's, ``scripts/ship_surrogate.py``): each as its
#: greedy's global arrays, named by its cache key; the local stage is redone when it is read.
SHIPPED_DIR = Path(__file__).with_name("data")

#: Designs above which :meth:`ReducedModel.evaluate` splits the work over two threads
#: (NumPy's batched solves release the GIL; measured 1.7× on 2 cores).
THREAD_MIN = 20000


def rom_cache_dir() -> Path:
    """``$ISJ_FE_CACHE_DIR/rom``, else ``~/.cache/isj/fe/rom``: beside the FE result cache."""
    from isj.caches import fe_cache_dir

    return fe_cache_dir() / "rom"


@dataclasses.dataclass(frozen=True)
class SurrogateStaticResult:
    """One design's α and β from the surrogate, with their certified bounds (SI units).

    ``*_bound*``: |FE − surrogate| ≤ bound, FE on the same mesh (:meth:`ReducedModel.evaluate`).
    """

    alpha_rad: float
    alpha_bound_rad: float
    beta_rad: float
    beta_bound_rad: float
    alpha_plus_beta_rad: float
    alpha_plus_beta_bound_rad: float
    beta_over_alpha: float
    beta_over_alpha_bound: float
    coercivity_lb: float
    pressure_pa: float
    moduli: dict
    nu: float
    sizes: dict

    def to_dict(self) -> dict:
        """The keys of ``isj rom solve --json``: the values, the moduli (Pa), ν and the sizes."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "sizes"}
        return out | {"moduli": dict(self.moduli)} | dict(self.sizes)


class ReducedModel:
    """A built surrogate: the online arrays, its design space and what it was built from.

    The surrogate is static only: :meth:`static` (one design) and :meth:`evaluate` (many). It has
    no mass, so no ``frequency_response`` and no ``natural_frequencies_hz``; the FE model's
    are :meth:`isj.fem.model.PedicleJointModel.frequency_response` and
    :meth:`isj.fem.model.PedicleJointModel.natural_frequencies_hz`.

    Parameters
    ----------
    arrays : the online arrays (:mod:`isj.fem.rom.online`)
    space : the design space
    meta : mesh hash, order, resolution, sizes, build statistics (JSON-able)
    """

    def __init__(self, arrays: dict, space: DesignSpace, meta: dict):
        self.arrays = {k: np.asarray(v) for k, v in arrays.items()}
        self.space = space
        self.meta = dict(meta)
        self.boxes = unpack(self.arrays)  # the sub-boxes' local arrays (fem/rom/local.py)

    # ---- sizes -------------------------------------------------------------------------

    @property
    def n_basis(self) -> dict[str, int]:
        """Basis sizes of the primal space and the duals of α and β."""
        return {
            "primal": self.arrays["u_g"].size,
            "dual_alpha": self.arrays["a_g"].size,
            "dual_beta": self.arrays["b_g"].size,
        }

    def __repr__(self) -> str:
        return (
            f"ReducedModel(P{self.meta.get('order')}, {self.meta.get('n_dofs')} dofs, "
            f"bases {self.n_basis}, max relative bound {self.meta.get('validate_max_rel_bound', 0):.2e})"
        )

    # ---- online ------------------------------------------------------------------------

    def evaluate(self, designs=None, pressure_pa: float = DEFAULT_PRESSURE_PA, **moduli) -> dict:
        """α, β, α + β and β/α with their bounds for many designs at once.

        Parameters
        ----------
        designs : a :class:`isj.design.Materials`, a mapping of moduli (floats or arrays, Pa), or
            an (n, 5) array of the ranged moduli in :data:`isj.design_space.RANGED` order
        pressure_pa : load (Pa); the outputs and bounds scale with it
        moduli : keyword moduli, overriding ``designs``; missing ones take the defaults

        Returns
        -------
        dict of (n,) arrays
            ``alpha_rad``, ``beta_rad``, ``alpha_plus_beta_rad``, ``beta_over_alpha``, each with
            its ``*_bound`` (``alpha_bound_rad``, ``beta_bound_rad``, ``alpha_plus_beta_bound_rad``,
            ``beta_over_alpha_bound``): |FE − surrogate| ≤ bound, FE on the same mesh.

        Raises
        ------
        InvalidParameter
            A design outside the surrogate's domain (one line naming the modulus and its range).
        """
        p = check_pressure(pressure_pa)
        if isinstance(designs, np.ndarray) and designs.ndim == 2 and not moduli:
            E = self.space.check(designs)
        else:
            E = self.space.designs_from(designs, **moduli)
        from ..ear.joint_condensation import one_blas_thread

        theta = self.space.theta(E)
        # one OpenBLAS thread per evaluating thread: the products are small, and OpenBLAS's own
        # threads on top of these made them several times slower on two shared cores
        with one_blas_thread():
            if theta.shape[0] >= THREAD_MIN:
                halves = zip(np.array_split(E, 2), np.array_split(theta, 2), strict=True)
                with ThreadPoolExecutor(2) as pool:
                    parts = list(pool.map(lambda et: self._evaluate_unit(*et), halves))
                ev = {k: np.concatenate([q[k] for q in parts]) for k in parts[0]}
            else:
                ev = self._evaluate_unit(E, theta)
        a, da = ev["alpha"] * p, ev["alpha_bound"] * abs(p)
        b, db = ev["beta"] * p, ev["beta_bound"] * abs(p)
        der = derived_bounds(a, da, b, db)
        return {
            "alpha_rad": a,
            "alpha_bound_rad": da,
            "beta_rad": b,
            "beta_bound_rad": db,
            "alpha_plus_beta_rad": der["sum"],
            "alpha_plus_beta_bound_rad": der["sum_bound"],
            "beta_over_alpha": der["ratio"],
            "beta_over_alpha_bound": der["ratio_bound"],
            "coercivity_lb": ev["alpha_lb"],
        }

    def _evaluate_unit(self, E: np.ndarray, theta: np.ndarray) -> dict:
        """Per unit pressure: each design in its sub-box's local spaces, else the global ones."""
        if self.boxes:
            return evaluate_local(self.boxes, self.space.to_unit(E), theta)
        return evaluate_unit(self.arrays, theta)

    def static(
        self, materials=None, pressure_pa: float = DEFAULT_PRESSURE_PA, **moduli
    ) -> SurrogateStaticResult:
        """One design: the values of :meth:`evaluate` as floats, with the moduli and the model's sizes."""
        E = self.space.designs_from(materials, **moduli)
        if E.shape[0] != 1:
            raise InvalidParameter(f"designs: static takes one design, not {E.shape[0]}; use evaluate")
        out = {k: float(v[0]) for k, v in self.evaluate(E, pressure_pa).items()}
        return SurrogateStaticResult(
            **out,
            pressure_pa=float(pressure_pa),
            moduli=dict(zip(RANGED, map(float, E[0]), strict=True)) | {"incus_e_pa": self.space.incus_e_pa},
            nu=self.space.nu,
            sizes=self.sizes(),
        )

    def sizes(self) -> dict:
        """The FE model's and the surrogate's sizes, for JSON output."""
        keys = ("n_dofs", "n_tets", "order", "resolution", "mesh_hash")
        return {k: self.meta[k] for k in keys if k in self.meta} | {"n_basis": self.n_basis}

    def cases(self, pressure_pa: float = DEFAULT_PRESSURE_PA) -> list[dict]:
        """The seven thesis cases (:data:`isj.cases.THESIS_CASES`) in one vectorised evaluation.

        The cases' plate and stapes moduli are the defaults; the surrogate's ν and incus
        modulus are used (the thesis's are the defaults).
        """
        from isj.cases import THESIS_CASES
        from isj.design import Materials

        base = Materials(incus_e_pa=self.space.incus_e_pa, nu=self.space.nu)
        rows = [c.materials(base) for c in THESIS_CASES]
        E = np.array([[m.youngs(k.removesuffix("_e_pa")) for k in RANGED] for m in rows])
        ev = self.evaluate(E, pressure_pa)
        return [
            {"case": c.name}
            | {k: float(E[i, j]) for j, k in enumerate(RANGED)}
            | {k: float(v[i]) for k, v in ev.items()}
            for i, c in enumerate(THESIS_CASES)
        ]

    # ---- storage -----------------------------------------------------------------------

    def save(self, path: str | Path) -> None:
        """Write to ``path`` (.npz, checksummed, atomic)."""
        meta = self.meta | {"space": self.space.to_record(), "format": ROM_FORMAT_VERSION}
        write_npz_entry(path, dict(self.arrays) | {"meta_json": np.array(canonical_json(meta))})

    @classmethod
    def load(cls, path: str | Path) -> ReducedModel:
        """Read an entry written by :meth:`save`; :class:`DamagedEntry` if it cannot be trusted."""
        arrays, _ = read_npz_entry(path)
        try:
            meta = json.loads(str(arrays.pop("meta_json")))
            if meta.get("format") != ROM_FORMAT_VERSION:
                raise DamagedEntry(f"format {meta.get('format')} != {ROM_FORMAT_VERSION}")
            sp = meta.pop("space")
            space = DesignSpace.from_record(sp)
        except (KeyError, TypeError, ValueError) as exc:
            raise DamagedEntry(f"{type(exc).__name__}: {exc}") from exc
        return cls(arrays, space, meta)


def cache_key(mesh_hash: str, order: int, geometry: Geometry, space: DesignSpace, settings: dict) -> str:
    """sha256 (hex) of everything a surrogate depends on."""
    payload = {
        "mesh": mesh_hash,
        "order": order,
        "geometry": dataclasses.asdict(geometry),
        "space": space.to_record(),
        "settings": settings,
        "versions": versions("surrogate"),
        "format": ROM_FORMAT_VERSION,
    }
    return hashlib.sha256(canonical_json(payload).encode()).hexdigest()


def surrogate_key(
    mesh, order: int, geometry: Geometry, space: DesignSpace, tol: float, resolution: float, settings: dict
) -> str:
    """The key :func:`reduced_model` files a surrogate under; the solver in ``settings`` is not part of it."""
    keyed = {"tol": tol, "resolution": resolution} | {k: v for k, v in settings.items() if k != "solver"}
    return cache_key(mesh.content_hash(), order, geometry, space, keyed)


def build_reduced_model(
    model,
    space: DesignSpace | None = None,
    *,
    tol: float = DEFAULT_TOL,
    n_train: int = N_TRAIN,
    n_validate: int = N_VALIDATE,
    seed: int = 0,
    max_snapshots: int = MAX_SNAPSHOTS,
    solver: str = "auto",
    progress=None,
    steps=None,
) -> ReducedModel:
    """Run the greedy on an assembled :class:`isj.fem.model.PedicleJointModel`.

    Training set: the 32 corners and ``n_train`` scrambled Sobol designs (seed ``seed``);
    validation: the corners, the box's 80 edge midpoints and ``n_validate`` other Sobol
    designs (seed ``seed + 1``). Stops when every validation design's relative bound on α,
    β and β/α is at most ``tol`` (or at ``max_snapshots``; ``meta["converged"]`` says which).
    ``steps`` (:class:`isj.fem.rom.offline.GreedySteps`) keeps each finished greedy step on
    disk and resumes from those a killed build left; without it nothing is written.
    """
    from .offline import Greedy, run_greedy

    space = space or DesignSpace()
    if not (isinstance(tol, float | int) and 0 < tol < 1):
        raise InvalidParameter(f"tol = {tol!r}: must lie in (0, 1)")
    for k, (lo, hi) in space.bounds.items():
        if not lo < hi:
            raise InvalidParameter(f"{k} = {(lo, hi)!r} Pa: the surrogate needs low < high")
    t0 = time.perf_counter()
    greedy = Greedy(model, space, solver)
    train = np.concatenate([space.corners(), space.sample(n_train, seed)])
    validate = _validation_designs(space, n_validate, seed)
    hist = run_greedy(greedy, train, validate, tol, max_steps=max_snapshots, progress=progress, steps=steps)
    meta = {
        "mesh_hash": model.mesh.content_hash(),
        "order": model.order,
        "n_dofs": model.n_dofs,
        "n_tets": model.n_tets,
        "geometry": dataclasses.asdict(model.geometry),
        "n_snapshots": len(greedy.snapshots),
        "snapshots_pa": np.array(greedy.snapshots).tolist(),
        "tol": tol,
        "converged": hist["converged"],
        "validate_max_rel_bound": hist["validate_max_rel_bound"],
        "n_validate": int(validate.shape[0]),
        "history": hist["history"],
        "timings_s": dict(greedy.timings_s),
        "representer_rel_error": greedy.xsolve.rel,
        "resumed_snapshots": steps.restored if steps is not None else 0,
    }
    rom = local_stage(
        greedy.arrays(orthogonality=True), space, meta, tol=tol, n_validate=n_validate, seed=seed
    )
    rom.meta["build_time_s"] = time.perf_counter() - t0
    return rom


def _validation_designs(space: DesignSpace, n_validate: int, seed: int) -> np.ndarray:
    """The greedy's validation set: the corners, the box's 80 edge midpoints, ``n_validate`` Sobol designs."""
    return np.concatenate(
        [space.corners(), space.from_unit(_edge_midpoints()), space.sample(n_validate, seed + 1)]
    )


def local_stage(
    arrays: dict, space: DesignSpace, meta: dict, *, tol: float, n_validate: int, seed: int
) -> ReducedModel:
    """The surrogate from the greedy's global arrays: the sub-boxes' local bases added and validated.

    Deterministic in its inputs (one BLAS thread), so a surrogate whose global arrays were
    stored (:func:`ship`) is completed here to the one a build gives.
    """
    from ..ear.joint_condensation import one_blas_thread
    from .local import local_bases, pack, relative_bounds

    t0 = time.perf_counter()
    with one_blas_thread():  # small dense work: OpenBLAS's threads only wait for each other
        boxes, sizes = local_bases(arrays, space, tol, seed=seed)
    validate = _validation_designs(space, n_validate, seed)
    local_max = float(
        np.max(relative_bounds(arrays, space.theta(validate), boxes=boxes, t=space.to_unit(validate))[0])
    )
    meta = dict(meta) | {
        "local_sizes": sizes,
        "local_validate_max_rel_bound": local_max,
        "local_time_s": time.perf_counter() - t0,
    }
    return ReducedModel(dict(arrays) | pack(boxes), space, meta)


def _edge_midpoints() -> np.ndarray:
    """(80, 5) unit-cube points: the middle of every edge of the 5-cube (one coordinate 0.5)."""
    d = len(RANGED)
    out = []
    for j in range(d):
        others = [i for i in range(d) if i != j]
        for bits in range(2 ** (d - 1)):
            t = np.full(d, 0.5)
            t[others] = [(bits >> b) & 1 for b in range(d - 1)]
            out.append(t)
    return np.array(out)


def reduced_model(
    geometry: Geometry | None = None,
    order: int = 2,
    resolution: float = 1.0,
    space: DesignSpace | None = None,
    *,
    tol: float = DEFAULT_TOL,
    cache: bool = True,
    shipped: bool = True,
    progress=None,
    **settings,
) -> ReducedModel:
    """The surrogate for a mesh: from the cache if there, else shipped or built (minutes), and stored.

    ``settings`` go to :func:`build_reduced_model` (``n_train``, ``n_validate``, ``seed``,
    ``max_snapshots``, ``solver``).

    On a cache miss the surrogate shipped with isj for the same key (the default mesh's,
    :data:`SHIPPED_DIR`) is taken when there is one and ``shipped`` is true: a few seconds
    instead of minutes, and the same arrays as a build on the machine that made it.

    A build keeps each finished greedy step in ``rom-<key>.steps/`` beside the entry
    (:class:`isj.fem.rom.offline.GreedySteps`), so that a killed build resumes at its last
    step, to the same surrogate bit for bit; the steps are removed once the entry is stored.
    Two processes asking for the same surrogate take turns (a lock file ``rom-<key>.lock``):
    the second waits for the first and loads its entry.
    """
    from ..mesh import mesh_pedicle_joint
    from .offline import GreedySteps

    geometry = geometry or Geometry()
    space = space or DesignSpace()
    mesh = mesh_pedicle_joint(geometry, resolution=resolution)
    key = surrogate_key(mesh, order, geometry, space, tol, resolution, settings)
    path = rom_cache_dir() / f"rom-{key[:32]}.npz"
    if not cache:
        return _build(geometry, order, resolution, mesh, space, tol, progress, None, settings)
    with file_lock(path.with_suffix(".lock")):  # a second build of the same entry waits here
        if path.exists():
            try:
                return ReducedModel.load(path)
            except DamagedEntry as exc:
                discard(path, "surrogate", str(exc), stacklevel=2)
        local = {
            "tol": tol,
            "n_validate": settings.get("n_validate", N_VALIDATE),
            "seed": settings.get("seed", 0),
        }
        rom = load_shipped(key, space, **local) if shipped else None
        steps = None
        if rom is None:
            steps = GreedySteps(path.with_suffix(".steps"), key)
            rom = _build(geometry, order, resolution, mesh, space, tol, progress, steps, settings)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            rom.save(path)
        except OSError as exc:
            warnings.warn(f"could not write surrogate cache entry {path}: {exc}", CacheWarning, stacklevel=2)
        else:
            if steps is not None:
                steps.clear()
    return rom


def ship(rom: ReducedModel, key: str, folder: Path | None = None) -> Path:
    """Store a built surrogate under its cache ``key`` for :func:`load_shipped`; return the file.

    Only the greedy's global arrays and the build's record are kept (compressed, checksummed):
    the sub-boxes' local bases are ten times their size and :func:`local_stage` remakes them.
    """
    arrays = {k: v for k, v in rom.arrays.items() if not k.startswith("box")}
    meta = {k: v for k, v in rom.meta.items() if not k.startswith("local_")}
    meta |= {"key": key, "space": rom.space.to_record(), "format": ROM_FORMAT_VERSION}
    path = Path(folder or SHIPPED_DIR) / f"rom-{key[:32]}.npz"
    write_npz_entry(path, arrays | {"meta_json": np.array(canonical_json(meta))}, compressed=True)
    return path


def load_shipped(
    key: str, space: DesignSpace, *, tol: float, n_validate: int, seed: int, folder: Path | None = None
) -> ReducedModel | None:
    """The shipped surrogate of cache ``key``, completed by :func:`local_stage`; None if none ships.

    A file is taken only when the full key it records is ``key``: the same mesh (content hash),
    order, geometry, design space, greedy settings and results versions. A damaged one is
    reported (:class:`isj.errors.CacheWarning`) and passed over, so the surrogate is built.
    """
    path = Path(folder or SHIPPED_DIR) / f"rom-{key[:32]}.npz"
    if not path.exists():
        return None
    try:
        arrays, _ = read_npz_entry(path)
        meta = json.loads(str(arrays.pop("meta_json")))
        if meta.pop("key") != key or meta.pop("format") != ROM_FORMAT_VERSION:
            return None
    except (DamagedEntry, KeyError, ValueError) as exc:
        warnings.warn(f"shipped surrogate {path} is damaged ({exc}); building it", CacheWarning, stacklevel=3)
        return None
    meta.pop("space", None)  # the key holds the space: it is ``space``
    rom = local_stage(arrays, space, meta, tol=tol, n_validate=n_validate, seed=seed)
    rom.meta["shipped"] = True
    return rom


def _build(geometry, order, resolution, mesh, space, tol, progress, steps, settings) -> ReducedModel:
    """Assemble the FE model of ``mesh`` and build its surrogate (:func:`build_reduced_model`)."""
    from ..model import PedicleJointModel

    t0 = time.perf_counter()
    model = PedicleJointModel(geometry, order, resolution, mesh=mesh)
    rom = build_reduced_model(model, space, tol=tol, progress=progress, steps=steps, **settings)
    rom.meta["resolution"] = resolution
    rom.meta["build_time_s"] = time.perf_counter() - t0  # assembly included
    return rom
