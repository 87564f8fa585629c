"""The pedicle-and-joint FE model: mesh and assemble once, solve for any materials.

>>> model = PedicleJointModel(order=2)               # doctest: +SKIP
>>> res = model.static(Materials(pedicle_e_pa=3e9))  # doctest: +SKIP
>>> res.alpha_rad, res.beta_rad                      # doctest: +SKIP

Everything that does not depend on the moduli is built once: the mesh (cached
on disk), the P1/P2 node layout, the per-region unit-modulus matrices, the
clamping reduction, the solver's symbolic analysis, the load vector for unit
pressure and the α/β functionals. A new set of moduli then costs a vector sum
and one numeric factorization.

Near-incompressible materials. Displacement elements lock as ν → 0.5: the
volumetric stiffness λ ∝ ν/(1 − 2ν) swamps the rest and the mesh can no longer
bend without changing volume. Above :data:`LOCKING_NU` (per element order; P1
locks earlier than P2) a :class:`~isj.errors.VolumetricLockingWarning` is issued.
Part of α's fall with ν is physical (a thin bonded layer stiffens as it becomes
incompressible), so each threshold is where α's dependence on the mesh grows,
not where α itself falls (the measurements that set them: docs/history.md).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from isj.cases import THESIS_CASES
from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials, check_pressure
from isj.errors import VolumetricLockingWarning

from .angles import angle_operator
from .assembly import assemble_mass, assemble_regions, build_pattern, combine, lame_unit
from .boundary import Reduction, clamped_dofs, pressure_load
from .dynamics import harmonic_response, modes
from .energy import element_strain_energy_density, region_strain_energy
from .memo import kept_result
from .sliding import (
    DEFAULT_LAYER_SHEAR_PA,
    TiedReduction,
    check_joint,
    check_layer_shear,
    layer_correction,
    layer_gap_energy_change,
    shear_split,
    split_gap_face,
    tied_reduction,
)
from .solvers import PardisoSolver, make_solver, resolve_backend
from .space import build_space

#: Static results a :class:`PedicleJointModel` keeps (:meth:`PedicleJointModel.static`): each is
#: one displacement (0.9 MB on the default mesh). The report solves about 30 designs on its
#: model before the sliding step asks again for the seven thesis cases: 16 were too few.
STATIC_MEMO = 64

#: Largest Poisson's ratio without a :class:`~isj.errors.VolumetricLockingWarning`, per element
#: order (1: P1, 2: P2); see the module docstring for the measurements behind them.
LOCKING_NU: dict[int, float] = {1: 0.45, 2: 0.49}


def check_locking(nu: float, order: int, stacklevel: int = 3) -> bool:
    """Warn (:class:`~isj.errors.VolumetricLockingWarning`) if ``nu`` locks elements of ``order``.

    Returns
    -------
    bool
        True if it warned.
    """
    limit = LOCKING_NU[order]
    if nu <= limit:
        return False
    warnings.warn(
        f"nu = {nu!r}: above {limit} P{order} elements lock (too stiff, mesh-dependent results); "
        f"keep nu <= {limit} or check convergence on finer meshes",
        VolumetricLockingWarning,
        stacklevel=stacklevel,
    )
    return True


@dataclass
class StaticResult:
    """Static response of the pedicle-and-joint model (SI units).

    ``alpha_rad``/``beta_rad`` follow the point-pair definition of docs/model.md §2.4
    (the one compared with the thesis); ``*_ls_rad`` the least-squares rigid
    rotations of the bodies. ``strain_energy_j`` is per region.
    """

    alpha_rad: float
    beta_rad: float
    alpha_ls_rad: float
    beta_ls_rad: float
    max_disp_m: float
    strain_energy_j: dict[str, float]
    pressure_pa: float
    materials: Materials
    displacement_m: np.ndarray = field(repr=False)  # (n_nodes, 3)

    @property
    def sum_rad(self) -> float:
        return self.alpha_rad + self.beta_rad

    @property
    def ratio(self) -> float:
        """β/α, the pedicle's share of the flexibility relative to the joint's."""
        return self.beta_rad / self.alpha_rad

    def energy_fraction(self) -> dict[str, float]:
        total = sum(self.strain_energy_j.values())
        return {k: v / total for k, v in self.strain_energy_j.items()}

    def to_dict(self) -> dict:
        return {
            "alpha_rad": self.alpha_rad,
            "beta_rad": self.beta_rad,
            "alpha_plus_beta_rad": self.sum_rad,
            "beta_over_alpha": self.ratio,
            "alpha_ls_rad": self.alpha_ls_rad,
            "beta_ls_rad": self.beta_ls_rad,
            "max_disp_m": self.max_disp_m,
            "pressure_pa": self.pressure_pa,
            "strain_energy_j": dict(self.strain_energy_j),
            "strain_energy_fraction": self.energy_fraction(),
        }


class ElasticModel:
    """Linear elasticity on a meshed body: assembled once, solved for any moduli.

    Parameters
    ----------
    mesh : fem.mesh.TetMesh with a face named ``clamped``
    order : 1 or 2 (P1 or P2 tetrahedra)
    solver : sparse solver backend, see ``fem.solvers`` ("auto" = fastest here)
    """

    #: Folder of the solver's cached fill-reducing orderings (``fem.solvers.make_solver``); None: none kept.
    ordering_cache = None
    _upper_positions = None  # (solver, positions in the full data of what it factors)

    def __init__(
        self,
        mesh,
        order: int = 2,
        solver: str = "auto",
        clamped: str = "clamped",
        analyse_ahead: bool = False,
    ):
        if order not in (1, 2):
            raise ValueError(f"order = {order!r}: must be 1 or 2")
        self.mesh = mesh
        self.order = order
        self.space = build_space(mesh, order)
        self.pattern = build_pattern(self.space)
        self.reduction = Reduction.build(self.pattern, clamped_dofs(self.space, clamped))
        self.timings_s: dict[str, float] = {}
        self._solver = None
        self._solver_name = solver
        if analyse_ahead:
            self.analyse_ahead()
        self.regions = assemble_regions(self.space, self.pattern)
        self._mass_ready = False

    def analyse_ahead(self) -> None:
        """Start PARDISO's analysis of the clamped pattern on a thread, now.

        The analysis (METIS's ordering and the symbolic factorization, 0.5–1.4 s on the default
        mesh, on one core) reads the pattern only, so it runs while this thread assembles the
        regions and sums the stiffness; the first factorization waits for it. The factorization
        is the same bit for bit (tests/test_solver_ahead.py). Other backends, a model that
        already has its solver, and a reduction whose pattern is not fixed by the mesh (any but
        the plain clamping and the sliding joint's ties): nothing is started.
        """
        if self._solver is not None or type(self.reduction) not in (Reduction, TiedReduction):
            return
        if resolve_backend(self._solver_name) != "pardiso":
            return
        pattern_only = self.reduction.matrix(np.ones(self.pattern.nnz))
        self._solver = make_solver(pattern_only, "pardiso", ordering_cache=self.ordering_cache, ahead=True)

    @property
    def n_dofs(self) -> int:
        """Free dofs (the size of the solved system)."""
        return self.reduction.n_free

    @property
    def n_tets(self) -> int:
        return self.space.n_tets

    def _factor(self, data: np.ndarray) -> None:
        """Factor the reduced stiffness with full-pattern ``data``.

        With PARDISO and a plain clamping the upper triangle PARDISO reads is
        gathered from ``data`` in one step, not through the reduced matrix
        (the same numbers, in the same order; the time it saves: docs/performance.md §8.2).
        """
        solver = self._solver
        if not isinstance(solver, PardisoSolver) or type(self.reduction) is not Reduction:
            solver.factor(self.reduction.matrix(data))
            return
        if self._upper_positions is None or self._upper_positions[0] is not solver:
            self._upper_positions = (solver, self.reduction.keep[solver.upper_mask])
        solver.factor_upper(data[self._upper_positions[1]])

    def stiffness_data(self, materials: Materials) -> np.ndarray:
        """Full-pattern data of K = Σ_r E_r (λ̂ K_λ,r + μ̂ K_μ,r) (N/m).

        Warns (:class:`~isj.errors.VolumetricLockingWarning`) when ``materials.nu``
        exceeds :data:`LOCKING_NU` for this element order.
        """
        check_locking(materials.nu, self.order)
        lam, mu = lame_unit(materials.nu)
        coef = {r: (materials.youngs(r) * lam, materials.youngs(r) * mu) for r in self.regions}
        return combine(self.pattern, self.regions, coef)

    def stiffness(self, materials: Materials, reduced: bool = True):
        data = self.stiffness_data(materials)
        return self.reduction.matrix(data) if reduced else self.pattern.matrix(data)

    def mass_data(self, materials: Materials) -> np.ndarray:
        """Full-pattern data of the consistent mass matrix (kg)."""
        if not self._mass_ready:  # only dynamics need it
            assemble_mass(self.space, self.pattern, self.regions)
            self._mass_ready = True
        coef = {r: (materials.density(r), 0.0) for r in self.regions}
        return combine(self.pattern, self.regions, coef, part="mass")

    def free_solver(self) -> None:
        """Release the factorization the model keeps (the next solve analyses again; the kept
        static results stay)."""
        solver, self._solver = self._solver, None
        self._upper_positions = None
        free = getattr(solver, "free", None)  # CHOLMOD's is released with the object
        if free is not None:
            free()

    def stiffness_key(self, materials: Materials):
        """What K depends on besides the model: ``materials`` (a subclass may add its own settings)."""
        return materials

    def factored_solver(self, materials: Materials):
        """The model's solver holding the factorization of the reduced K(``materials``).

        Factored here unless the solver already holds that factorization (a modal or harmonic
        solve after a static one of the same design, or the reverse): the same factorization,
        so the same bits. A factorization made by any other caller clears the solver's record
        (``factored_for``), so it is never taken for this one.
        """
        key = self.stiffness_key(materials)
        t0 = time.perf_counter()
        if self._solver is None:
            K = self.reduction.matrix(self.stiffness_data(materials))
            self._solver = make_solver(K, self._solver_name, ordering_cache=self.ordering_cache)
            t1 = time.perf_counter()
            self._solver.factor(K)
        elif getattr(self._solver, "factored_for", None) != key:
            ready = getattr(self._solver, "ready", None)
            if ready is not None:
                ready()  # an analysis started ahead (analyse_ahead): the wait counts as analysis
            t1 = time.perf_counter()
            self._factor(self.stiffness_data(materials))
        else:
            t1 = t0
        self._solver.factored_for = key
        self.timings_s.update(analyse=t1 - t0, factor=time.perf_counter() - t1)
        return self._solver

    def solve_load(self, materials: Materials, load: np.ndarray) -> np.ndarray:
        """Full dof vector of the static displacement (m) under nodal forces ``load`` (N)."""
        solver = self.factored_solver(materials)
        t0 = time.perf_counter()
        u = solver.solve(self.reduction.restrict(load))
        self.timings_s["solve"] = time.perf_counter() - t0
        return self.reduction.expand(np.ravel(u))


class PedicleJointModel(ElasticModel):
    """Meshed and assembled pedicle-and-joint model (docs/model.md §2).

    Parameters
    ----------
    geometry : dimensions (m)
    order : 1 or 2 (P1 or P2 tetrahedra)
    resolution : refinement factor of every element size (2 halves them)
    sizes : per-region element sizes, ``fem.geometry.MeshSizes`` (default: graded)
    solver : sparse solver backend, see ``fem.solvers`` ("auto" = fastest here)
    cache_dir : mesh (and solver ordering) cache folder; None = default, False = no cache
    mesh : a ready ``TetMesh`` (skips meshing; for tests)
    joint : "bonded" (default), "sliding" or "layer" (``fem.sliding``, docs/model.md §2.12)
    layer_shear_pa : the ``layer`` joint's through-thickness shear modulus (Pa)
    analyse_ahead : start the solver's analysis while the model is assembled
        (:meth:`ElasticModel.analyse_ahead`): for a model that will be solved
    """

    def __init__(
        self,
        geometry: Geometry | None = None,
        order: int = 2,
        resolution: float = 1.0,
        sizes=None,
        solver: str = "auto",
        cache_dir=None,
        mesh=None,
        joint: str = "bonded",
        layer_shear_pa: float = DEFAULT_LAYER_SHEAR_PA,
        analyse_ahead: bool = False,
    ):
        if order not in (1, 2):
            raise ValueError(f"order = {order!r}: must be 1 or 2")
        self.geometry = geometry or Geometry()
        self.joint = check_joint(joint)
        self.layer_shear_pa = check_layer_shear(layer_shear_pa)
        t0 = time.perf_counter()
        if mesh is None or cache_dir not in (None, False, True):
            # the ordering is kept where the mesh is: with a mesh handed in, only in a folder named
            from .cache import resolve_cache_dir

            self.ordering_cache = resolve_cache_dir(cache_dir)
        if mesh is None:
            from .mesh import mesh_pedicle_joint

            mesh = mesh_pedicle_joint(self.geometry, resolution=resolution, sizes=sizes, cache_dir=cache_dir)
        if joint == "sliding":  # the bonded mesh, cut open at the gap–plate face (fem.sliding)
            mesh = split_gap_face(mesh, self.geometry)
        t1 = time.perf_counter()
        # the sliding joint's reduction (its ties) is made below: its analysis starts after it
        super().__init__(mesh, order, solver, analyse_ahead=analyse_ahead and joint != "sliding")
        if joint == "sliding":
            self.reduction = tied_reduction(self, clamped_dofs(self.space, "clamped"))
            if analyse_ahead:
                self.analyse_ahead()
        # the −x face of the incus, pushed in +x; unit pressure, scaled per case
        self.unit_load = pressure_load(self.space, "loaded", 1.0, (1.0, 0.0, 0.0))
        self.angles = angle_operator(self.space, self.geometry)
        t2 = time.perf_counter()
        self.timings_s.update(mesh=t1 - t0, assembly=t2 - t1)

    def stiffness_data(self, materials: Materials) -> np.ndarray:
        """As :meth:`ElasticModel.stiffness_data`; with ``joint="layer"`` the gap is the layer."""
        data = super().stiffness_data(materials)
        if self.joint == "layer":
            data = data + layer_correction(self, materials)
        return data

    def stiffness_key(self, materials: Materials):
        """``materials``, and with ``joint="layer"`` the layer's shear modulus, which may be set anew."""
        return (materials, self.layer_shear_pa) if self.joint == "layer" else materials

    def displacement(self, materials: Materials, pressure_pa: float) -> np.ndarray:
        """Full dof vector of the static displacement (m)."""
        return self.solve_load(materials, self.unit_load) * pressure_pa

    @property
    def solver_name(self) -> str:
        return self._solver.name if self._solver is not None else self._solver_name

    def static(
        self, materials: Materials | None = None, pressure_pa: float = DEFAULT_PRESSURE_PA
    ) -> StaticResult:
        """Static response to a uniform pressure (Pa) on the incus's −x face.

        The model keeps its last :data:`STATIC_MEMO` results: the same materials and pressure
        again return the same result (its displacement read-only), as a new solve would bit for
        bit, without the factorization. The report's steps ask for the same designs (the base
        case, the thesis cases) more than once.
        """
        materials = materials or Materials()
        pressure_pa = check_pressure(pressure_pa)
        # only the layer joint reads its shear modulus, which may be set anew on the model
        layer_shear_pa = self.layer_shear_pa if self.joint == "layer" else None
        key = (materials, pressure_pa, layer_shear_pa)
        return kept_result(self, key, lambda: self._static(materials, pressure_pa), STATIC_MEMO)

    def _static(self, materials: Materials, pressure_pa: float) -> StaticResult:
        u = self.displacement(materials, pressure_pa)
        t0 = time.perf_counter()
        a, b, a_ls, b_ls = self.angles @ u
        youngs = {r: materials.youngs(r) for r in self.regions}
        energy = region_strain_energy(self.pattern, self.regions, youngs, materials.nu, u)
        if self.joint == "layer":
            energy["gap"] += layer_gap_energy_change(self, materials, u)
        disp = u.reshape(-1, 3)
        disp.flags.writeable = False  # a kept result (static()): nobody may change it
        self.timings_s["post"] = time.perf_counter() - t0
        return StaticResult(
            alpha_rad=float(a),
            beta_rad=float(b),
            alpha_ls_rad=float(a_ls),
            beta_ls_rad=float(b_ls),
            max_disp_m=float(np.linalg.norm(disp, axis=1).max()),
            strain_energy_j=energy,
            pressure_pa=pressure_pa,
            materials=materials,
            displacement_m=disp,
        )

    def frequency_response(
        self,
        freq_hz,
        materials: Materials | None = None,
        damping=None,
        pressure_pa: float = DEFAULT_PRESSURE_PA,
    ):
        """Damped harmonic α, β (rad) and the loaded face's mean u_x (m) at ``freq_hz`` (Hz).

        :func:`fem.dynamics.harmonic_response`: an :class:`isj.responses.FrequencyResponse` at
        the pressure amplitude ``pressure_pa`` (Pa), damping a :class:`fem.dynamics.Damping`
        (default: the published loss factors per region), outputs those of the lumped chain.
        """
        return harmonic_response(self, freq_hz, materials, damping, pressure_pa)

    def natural_frequencies_hz(self, n: int = 6, materials: Materials | None = None) -> np.ndarray:
        """The ``n`` lowest undamped natural frequencies (Hz), ascending (:func:`fem.dynamics.modes`).

        The mode shapes beside them: :func:`isj.fem.dynamics.modes`.
        """
        return modes(self, materials, n)[0]

    def strain_energy_density(self, result: StaticResult) -> np.ndarray:
        """Mean strain-energy density per element (J/m³)."""
        m = result.materials
        e = np.array([m.youngs(r) for r in self.space.region_names])[self.space.region]
        return element_strain_energy_density(self.space, e, m.nu, result.displacement_m.ravel())


def compare_cases(
    order: int = 2,
    resolution: float = 1.0,
    joints=("bonded", "sliding"),
    nu: float = 0.3,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    layer_shear_pa: float = DEFAULT_LAYER_SHEAR_PA,
    cache_dir=None,
    geometry=None,
    base: Materials | None = None,
    models: dict | None = None,
) -> list[dict]:
    """The seven thesis cases for each joint: one row per (case, joint), cases in thesis order.

    ``geometry`` (default :class:`isj.design.Geometry`) and ``base`` (the moduli the cases do not
    set; default :class:`isj.design.Materials` with ``nu``) as the other FE commands take them.
    ``models``: models already built, by joint (those of ``joints`` it lacks are built here),
    for a caller that holds them (the report, :func:`isj.fem.batch.shared_model`).

    Keys: ``case``, ``joint``, ``alpha_rad``, ``beta_rad``, ``alpha_plus_beta_rad``,
    ``beta_over_alpha`` (point pairs, as the thesis), ``alpha_ls_rad``, ``beta_ls_rad``
    (least-squares rotations), ``capsule_shear_share``, ``gap_shear_share``,
    ``capsule_moment_share``, ``gap_moment_share`` (:func:`shear_split`),
    ``strain_energy_j`` (total, = ½ fᵀu, J), ``order``, ``resolution``.
    """
    base = base or Materials(nu=nu)
    given = models or {}
    models = {
        j: given[j]
        if j in given
        else PedicleJointModel(
            geometry,
            order=order,
            resolution=resolution,
            joint=j,
            layer_shear_pa=layer_shear_pa,
            cache_dir=cache_dir,
        )
        for j in joints
    }
    rows = []
    for case in THESIS_CASES:
        for j, model in models.items():
            res = model.static(case.materials(base), pressure_pa)
            split = shear_split(model, res)
            rows.append(
                {
                    "case": case.name,
                    "joint": j,
                    "alpha_rad": res.alpha_rad,
                    "beta_rad": res.beta_rad,
                    "alpha_plus_beta_rad": res.sum_rad,
                    "beta_over_alpha": res.ratio,
                    "alpha_ls_rad": res.alpha_ls_rad,
                    "beta_ls_rad": res.beta_ls_rad,
                    "capsule_shear_share": split["capsule_shear_share"],
                    "gap_shear_share": split["gap_shear_share"],
                    "capsule_moment_share": split["capsule_moment_share"],
                    "gap_moment_share": split["gap_moment_share"],
                    "strain_energy_j": sum(res.strain_energy_j.values()),
                    "order": order,
                    "resolution": resolution,
                }
            )
    return rows
