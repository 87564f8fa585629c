"""The computations behind the report, one function per section.

Each step takes a :class:`Context` and returns ``(result, arrays)``: a JSON-able
dict of numbers (SI units) and a dict of numpy arrays (may be empty). Steps do
not plot and do not write into the output folder; :mod:`reports.run` caches
their results (:mod:`reports.store`) and writes the data files. Static FE
designs also go through the FE result cache of :mod:`calibration.runner`, which
``isj calibrate`` and ``isj explore`` share.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

# STATIC_KEYS: the outputs compared between FE and lumped models, in table order
from isj.calibration.checks import STATIC_KEYS, static_row

from isj.cases import THESIS_BASE_ALPHA_RAD, THESIS_BASE_BETA_RAD, THESIS_CASES

from .config import DesignConfig, ReportConfig
from .geometry import geometry_calibration_summary, geometry_trends_step
from .guard import guard_step
from .sliding import lumped_calibration, sliding_step
from .transmission_step import load_path_step, transmission_step
from .uq import uq_step


@dataclass
class Context:
    """What every step needs: the configuration, the calibration, where FE results are cached."""

    config: ReportConfig
    calibration: object  # lumped.artifact.Calibration
    fe_cache_dir: Path
    progress: bool = True

    @property
    def settings(self) -> dict:
        from isj.fem.batch import fe_settings

        c = self.config
        return fe_settings(c.mesh.order, c.mesh.resolution, c.geometry, c.design.pressure_pa)

    def base_design(self) -> dict[str, float]:
        return self.config.design.moduli() | {"nu": self.config.design.nu}

    def lumped(self, designs: list[dict]):
        """Lumped static response (arrays over ``designs``)."""
        from isj.calibration.checks import lumped_static

        return lumped_static(self.calibration, designs, self.config.geometry, self.config.design.pressure_pa)

    def compare(self, designs: list[dict]):
        """FE and lumped on ``designs``: an ``isj.calibration.checks.StaticComparison``.

        FE results are cached and evaluated in this process, so the model is built once.
        """
        from isj.calibration.checks import compare_static
        from isj.fem.batch import evaluate_design

        return compare_static(
            self.calibration,
            designs,
            evaluate_design,
            self.settings,
            self.fe_cache_dir,
            max_workers=0,
            progress=self.progress,
        )


def _surface(tets: np.ndarray, region: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangles bounding each region of ``tets`` (outer faces and interfaces), with their region."""
    local = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
    tri = tets[:, local].reshape(-1, 3)
    reg = np.repeat(region, 4)
    key = np.sort(tri, axis=1)
    # a face belongs to a region's boundary when that region holds it once
    both = np.column_stack([key, reg])
    _, inv, counts = np.unique(both, axis=0, return_inverse=True, return_counts=True)
    keep = counts[inv.ravel()] == 1
    return tri[keep], reg[keep]


def model_step(ctx: Context) -> tuple[dict, dict]:
    """Mesh statistics and quality, and the base design's static solution with its fields for pictures."""
    from isj.fem.batch import shared_model
    from isj.fem.quality import mesh_quality

    cfg = ctx.config
    model, mesh_hash = shared_model(ctx.settings)
    res = model.static(cfg.design.materials(), cfg.design.pressure_pa)
    mesh = model.mesh
    q = mesh_quality(mesh)
    # the half y < 0 (y = 0 is the plane of symmetry): its cut face shows the joint inside
    centroid_y = mesh.points[mesh.tets, 1].mean(axis=1)
    half = centroid_y < 0
    tri, reg = _surface(mesh.tets[half], mesh.region[half])
    nv = mesh.n_nodes
    u = res.displacement_m[:nv]
    result = {
        "mesh_hash": mesh_hash,
        "order": cfg.mesh.order,
        "resolution": cfg.mesh.resolution,
        "n_tets": int(model.n_tets),
        "n_dofs": int(model.n_dofs),
        "quality": q,
        "region_names": list(mesh.region_names),
        "base": res.to_dict(),
    }
    arrays = {
        "points_m": mesh.points,
        "triangles": tri.astype(np.int32),
        "triangle_region": reg.astype(np.int8),
        "displacement_m": u,
    }
    return result, arrays


def write_base_vtu(ctx: Context, path: Path) -> Path:
    """The base design as VTU (displacement, region id, strain-energy density)."""
    from isj.fem.batch import shared_model
    from isj.fem.export import write_model_vtu

    model, _ = shared_model(ctx.settings)
    res = model.static(ctx.config.design.materials(), ctx.config.design.pressure_pa)
    return write_model_vtu(path, model, res)


def cases_step(ctx: Context) -> tuple[dict, dict]:
    """The seven thesis cases (docs/model.md §2.5) from FE and lumped models, with the thesis's base case."""
    base = ctx.base_design()
    designs = [
        base | {"pedicle_e_pa": c.pedicle_e_pa, "gap_e_pa": c.gap_e_pa, "capsule_e_pa": c.capsule_e_pa}
        for c in THESIS_CASES
    ]
    comp = ctx.compare(designs)
    rel = {k: comp.rel_error(k) for k in STATIC_KEYS}
    rows = []
    for i, case in enumerate(THESIS_CASES):
        f, lu = comp.fe_row(i), comp.lumped_row(i)
        rows.append(
            {
                "case": case.name,
                "pedicle_e_pa": case.pedicle_e_pa,
                "gap_e_pa": case.gap_e_pa,
                "capsule_e_pa": case.capsule_e_pa,
                "fe": f,
                "lumped": lu,
                "rel_diff": {k: float(rel[k][i]) for k in STATIC_KEYS},
                "strain_energy_j": comp.fe_results[i]["strain_energy_j"],
            }
        )
    base_fe = rows[0]["fe"]

    # a trend agrees when FE and lumped move the same way from the base case (FE changes
    # under 1 % count as no trend: within the lumped model's accuracy)
    trends = {}
    for row in rows[1:]:
        same = {}
        for k in STATIC_KEYS:
            dfe = row["fe"][k] / base_fe[k] - 1
            dlu = row["lumped"][k] / rows[0]["lumped"][k] - 1
            same[k] = bool(abs(dfe) < 0.01 or np.sign(dfe) == np.sign(dlu))
        trends[row["case"]] = same
    thesis = static_row(THESIS_BASE_ALPHA_RAD, THESIS_BASE_BETA_RAD)
    return {"rows": rows, "thesis_base": thesis, "trend_agrees": trends}, {}


def _domain(ctx: Context) -> dict[str, tuple[float, float]]:
    return {k: (float(lo), float(hi)) for k, (lo, hi) in ctx.calibration.domain.items()}


def trends_step(ctx: Context) -> tuple[dict, dict]:
    """α, β, β/α against each modulus over the calibrated domain: lumped curves, FE points."""
    t = ctx.config.trends
    base = ctx.base_design()
    domain = _domain(ctx)
    out, arrays = {}, {}
    for name in t.moduli:
        lo, hi = domain[name]
        x = np.geomspace(lo, hi, t.n_lumped)
        lum = ctx.lumped([base | {name: float(v)} for v in x])
        arrays[f"{name}_x"] = x
        arrays[f"{name}_alpha_rad"] = lum.alpha_rad
        arrays[f"{name}_beta_rad"] = lum.beta_rad
        xf = [float(v) for v in np.geomspace(lo, hi, t.fe_points)] if t.fe_points else []
        comp = ctx.compare([base | {name: v} for v in xf])
        out[name] = {
            "domain_pa": [lo, hi],
            "fe_points": [
                {"value_pa": v, "fe": comp.fe_row(i), "lumped": comp.lumped_row(i)} for i, v in enumerate(xf)
            ],
        }
    return out, arrays


def convergence_step(ctx: Context) -> tuple[dict, dict]:
    """The pedicle cantilever (docs/model.md §2.6): maximum displacement against tets, P1 and P2, x and y."""
    from isj.fem.convergence import cantilever_study

    c = ctx.config.convergence
    studies = []
    for order in c.orders:
        for direction in c.directions:
            rows = cantilever_study(direction, order, geometry=ctx.config.geometry)
            studies.append({"order": order, "direction": direction, "rows": rows})
    return {"studies": studies}, {}


def calibration_step(ctx: Context) -> tuple[dict, dict]:
    """The calibration's recorded quality, and a fresh check on designs it never saw."""
    from isj.calibration.doe import sample

    from isj.design_space import DesignSpace

    cal = ctx.calibration
    c = ctx.config.calibration
    space = DesignSpace.from_dict(cal.domain)
    designs = sample(space, c.check_samples, c.seed, method="sobol") if c.check_samples else []
    base = {"nu": ctx.config.design.nu}
    designs = [base | d for d in designs]
    comp = ctx.compare(designs)
    points = [
        {"design": d, "fe": comp.fe_row(i), "lumped": comp.lumped_row(i)} for i, d in enumerate(designs)
    ]
    # max and RMS of the relative errors of α, β and β/α (None without designs)
    check = {"n": comp.n, "seed": c.seed, **comp.error_summary()}
    return {
        "source": c.file or "shipped default",
        "factors": dict(cal.factors),
        "domain": {k: list(v) for k, v in cal.domain.items()},
        "training": cal.training,
        "validation": cal.validation,
        "fe_settings": {k: v for k, v in cal.fe_settings.items() if k != "geometry"},
        "report_mesh": {"order": ctx.config.mesh.order, "resolution": ctx.config.mesh.resolution},
        "provenance": cal.provenance,
        "check": check,
        "points": points,
        "geometry": geometry_calibration_summary(),
    }, {}


def sweep_step(ctx: Context) -> tuple[dict, dict]:
    """Damped frequency response of the base design: lumped chain, FE harmonic checks, modes."""
    from isj.calibration.runner import run_designs
    from isj.fem.batch import evaluate_harmonic, evaluate_modes

    from isj.studies.sweeps import chain_sweep, fe_check_frequencies, harmonic_record_response

    cfg = ctx.config
    s = cfg.sweep
    cal = ctx.calibration
    damping = s.damping_model()  # per region (docs/dynamics.md §4.3), every value resolved
    freq = np.geomspace(s.fmin_hz, s.fmax_hz, s.n_freq)
    sw = chain_sweep(
        cal, freq, cfg.design.materials(), cfg.geometry, pressure_pa=cfg.design.pressure_pa, damping=damping
    )
    OUTPUTS, H = sw.outputs, sw.response  # the chain's output names and response
    design = ctx.base_design()

    def fe_response(f):
        """The FE harmonic outputs at ``f`` through the FE result cache."""
        hs = ctx.settings | {
            "kind": "harmonic",
            "freq_hz": [float(v) for v in f],
            "damping": damping.to_dict(),
        }
        rec = run_designs(
            [design], evaluate_harmonic, hs, ctx.fe_cache_dir, max_workers=0, progress=ctx.progress
        )
        return harmonic_record_response(rec[0]["result"], OUTPUTS)

    checks = []
    if s.fe_checks:
        comp = sw.fe_checks(fe_check_frequencies(s.fmin_hz, s.fmax_hz, s.fe_checks), fe_response)
        for i, f in enumerate(comp.freq_hz):
            row = {"freq_hz": float(f)}
            for j, k in enumerate(OUTPUTS):
                h_fe, h_lu = comp.fe[i, j], comp.lumped[i, j]
                row[k] = {
                    "fe_abs": float(abs(h_fe)),
                    "fe_phase_deg": float(np.degrees(np.angle(h_fe))),
                    "lumped_abs": float(abs(h_lu)),
                    "lumped_phase_deg": float(np.degrees(np.angle(h_lu))),
                    "rel_error": float(comp.rel_error[i, j]),
                }
            checks.append(row)
    ms = ctx.settings | {"kind": "modes", "n_modes": s.n_modes}
    rec = run_designs([design], evaluate_modes, ms, ctx.fe_cache_dir, max_workers=0, progress=ctx.progress)
    fe_modes = rec[0]["result"]
    arrays = {"freq_hz": freq} | {f"{k}_re": H[:, j].real for j, k in enumerate(OUTPUTS)}
    arrays |= {f"{k}_im": H[:, j].imag for j, k in enumerate(OUTPUTS)}
    return {
        "outputs": list(OUTPUTS),
        "fmin_hz": s.fmin_hz,
        "fmax_hz": s.fmax_hz,
        "damping": damping.to_dict(),
        "damping_preset": s.damping,
        # the chain's poles: undamped natural frequencies (damping leaves them) and damping ratios
        "lumped_natural_freq_hz": [float(v) for v in sw.natural_freq_hz],
        "lumped_damped_pole_freq_hz": [float(v) for v in sw.natural_freq_hz],
        "lumped_damping_ratio": [float(v) for v in sw.damping_ratio],
        "fe_modes_hz": fe_modes["freq_hz"],
        "fe_in_plane_modes_hz": fe_modes["in_plane_freq_hz"],
        "fe_mode_y_to_x": fe_modes["y_to_x_fraction"],
        "fe_checks": checks,
        "shear_factor": cal.shear_factor,
    }, arrays


def ear_step(ctx: Context) -> tuple[dict, dict]:
    """The whole cat middle ear (docs/ear.md §5) with the joint model inside: static response per Pa."""
    from isj.fem.batch import free_solvers
    from isj.fem.ear.shared import shared_ear

    from isj.ear import EXPERIMENT_STAPES_M_PER_PA, EXPERIMENT_UMBO_M_PER_PA, SPL_100DB_PEAK_PA

    cfg = ctx.config
    base = cfg.design.materials()
    # the whole-ear steps solve the ear, not the joint alone: the joint models' factorizations
    # (0.45 GB on the default mesh) would only raise the memory the ear's solves peak from
    free_solvers()
    ear = shared_ear(ctx.settings, cfg.mesh.drum_mesh_size_m)  # the transmission and uq steps' too
    from tqdm import tqdm

    bar = tqdm(THESIS_CASES, desc="whole ear, 7 cases", unit="case", disable=not ctx.progress, leave=False)
    cases = {c.name: ear.static(c.materials(base), cfg.ear) for c in bar}
    rigid_model = shared_ear(ctx.settings, cfg.mesh.drum_mesh_size_m, rigid=True)
    rigid = rigid_model.static(base, cfg.ear)
    ear.free_solver(), rigid_model.free_solver()  # the shared ears keep no factorization
    res0 = cases[THESIS_CASES[0].name]
    g = ear.geometry
    result = {
        "n_dofs": int(ear.n_dofs),
        "n_dofs_rigid_joint": int(rigid_model.n_dofs),
        "lever_ratio": float(g.lever_ratio),
        "ear_materials": dataclasses.asdict(cfg.ear),
        "cases": [{"case": k} | _ear_summary(r) for k, r in cases.items()],  # a list keeps the order
        "rigid_joint": _ear_summary(rigid),
        "experiment": {
            "umbo_m_per_pa": EXPERIMENT_UMBO_M_PER_PA,
            "stapes_m_per_pa": list(EXPERIMENT_STAPES_M_PER_PA),
            "source": "Guinan & Peake 1967 (umbo, stapes); Decraemer et al. 2000 (stapes about 30 nm/Pa)",
        },
        "spl_100db_peak_pa": SPL_100DB_PEAK_PA,
    }
    drum = ear.drum
    arrays = {
        "drum_nodes_m": drum.nodes_m,
        "drum_triangles": drum.triangles.astype(np.int32),
        "drum_u_m_per_pa": ear.drum_displacement(res0.displacement),
        "footplate_nodes_m": ear.footplate.nodes_m,
        "footplate_triangles": ear.footplate.triangles.astype(np.int32),
        # the ossicular chain as a polyline: umbo, manubrium tip, body, long process, head, footplate
        "chain_m": np.array(
            [
                g.umbo_m,
                g.manubrium_tip_m,
                g.body_reference_m,
                g.long_process_end_m,
                g.stapes_head_m,
                g.footplate_centre_m,
            ]
        ),
        "ligaments_m": np.array([g.malleus_ligament_m, g.incudal_lateral_m, g.incudal_medial_m]),
    }
    return result, arrays


def _ear_summary(r) -> dict:
    d = r.to_dict()
    keep = (
        "umbo_m_per_pa",
        "umbo_vector_m_per_pa",
        "eardrum_max_m_per_pa",
        "footplate_m_per_pa",
        "footplate_piston_m_per_pa",
        "alpha_rad_per_pa",
        "beta_rad_per_pa",
        "rotation_axis",
    )
    return {k: d[k] for k in keep}


#: The [mesh] keys of the steps without an eardrum: a new drum mesh keeps their results.
MESH_NO_DRUM = ("mesh.order", "mesh.resolution")

#: The moduli every thesis case sets (:class:`isj.cases.ThesisCase`), whatever the base design's.
CASE_MODULI = ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa")

#: The [design] keys of the steps that compute the thesis cases (and the rigid connection, which
#: has no joint moduli) and nothing at the base design: a new pedicle, gap or capsule modulus keeps
#: their results (tests/test_step_design_keys.py).
DESIGN_OF_CASES = tuple(f"design.{k}" for k in DesignConfig.CONFIG_KEYS if k not in CASE_MODULI)

#: Report sections in order: (name, function, the configuration sections it reads, or single
#: keys of one, "section.key").
STEPS = (
    ("model", model_step, ("design", "geometry", *MESH_NO_DRUM)),
    # right after the model step: its harmonic checks and modes are of the base design, whose
    # factorization the model step's static solve leaves in the joint model (one fewer)
    ("sweep", sweep_step, ("design", "geometry", *MESH_NO_DRUM, "sweep")),
    ("cases", cases_step, (*DESIGN_OF_CASES, "geometry", *MESH_NO_DRUM)),
    ("trends", trends_step, ("design", "geometry", *MESH_NO_DRUM, "trends")),
    ("convergence", convergence_step, ("geometry", "convergence")),
    ("calibration", calibration_step, ("design", "geometry", *MESH_NO_DRUM, "calibration")),
    ("ear", ear_step, (*DESIGN_OF_CASES, "geometry", "mesh", "ear")),
    (
        "transmission",
        transmission_step,
        (*DESIGN_OF_CASES, "geometry", "mesh", "ear", "sweep", "transmission"),
    ),
    ("load_path", load_path_step, ("design", "geometry", "ear", "sweep", "transmission")),
    ("sliding", sliding_step, (*DESIGN_OF_CASES, "geometry", *MESH_NO_DRUM, "sliding")),
    ("guard", guard_step, ("design", "geometry", *MESH_NO_DRUM, "guard")),
    # of [design] only the load: the moduli are drawn from their distributions and the rest are
    # isj uq's defaults (tests/test_uq.py checks that no other [design] key changes the result)
    ("uq", uq_step, ("design.pressure_pa", "geometry", "mesh", "ear", "sweep", "transmission", "uq")),
    # last: its FE geometries are many (fem.batch.transient_models drops their models after it)
    ("geometry_trends", geometry_trends_step, ("design", "geometry", *MESH_NO_DRUM, "geometry_trends")),
)


def step_versions(step=None) -> dict:
    """The results versions a step's key holds (:func:`isj.results_version.step_versions`).

    ``step``: the step's function or name; None, or a function that is not one of
    :data:`STEPS`, gives every step's version and every family's (a safe superset).
    Versions, not the code's text: a refactor keeps every finished step, a change of what a
    step computes bumps its version or a family's (docs/developer/cache-keys.md).
    """
    from isj import results_version as rv

    name = step if isinstance(step, str) else next((n for n, fn, _ in STEPS if fn is step), None)
    if name is None:
        return {"steps": dict(rv.STEP_VERSIONS)} | rv.versions(*rv.VERSIONS)
    return rv.step_versions(name)


def step_inputs(ctx: Context, sections: tuple[str, ...], step=None) -> dict:
    """What a step's result depends on: its config sections, its results versions, the calibration.

    ``step`` is the step's function or name (None: every step's, a safe superset); see
    :func:`step_versions`. The FE results a step reads are keyed by the same configuration
    and families' versions, so these are also the keys of its upstream results.
    """
    d = ctx.config.to_dict()

    def numbers(cal) -> dict:
        out = dataclasses.asdict(cal)
        out.pop("provenance", None)  # the date of a calibration does not change its numbers
        return out

    def part(name: str):  # a section, or one key of it ("design.pressure_pa")
        section, _, key = name.partition(".")
        return d[section][key] if key else d[section]

    inputs = {
        "config": {s: part(s) for s in sections},
        "versions": step_versions(step),
        "calibration": numbers(ctx.calibration),
    }
    if "sliding" in sections:  # its lumped columns read each joint's shipped calibration: data, not code
        cals = {j: lumped_calibration(ctx, j) for j in ctx.config.sliding.joints}
        inputs["joint_calibrations"] = {j: numbers(c) for j, c in cals.items() if c is not None}
    if "geometry_trends" in sections or step in (calibration_step, "calibration", None):
        # the shipped geometry calibration (its domain, errors; the trends' lumped curves): data too
        from isj.lumped.artifact import geometry_calibration

        inputs["geometry_calibration"] = numbers(geometry_calibration())
    return inputs


def step_modules(ctx: Context, step=None) -> tuple[str, ...]:
    """The isj modules whose code a step runs, sorted (``step`` None: every step's).

    Every isj module, with all that it imports in turn, that the step function
    imports, or whose names it uses (imported at this module's top level), or that
    the helpers here and the :class:`Context` members it uses import in the same
    way (``ctx.lumped`` brings in :mod:`isj.lumped.model`), plus the modules of the
    objects in the context that it reads (``ctx.calibration``:
    :mod:`isj.lumped.artifact`). Found through the import system (:mod:`isj.digest`).
    Not part of any key: ``tests/test_cache_keys.py`` checks with it that each step's
    families (:data:`isj.results_version.STEP_FAMILIES`) cover the code it reaches.
    """
    import inspect
    import sys

    from isj import digest

    steps = [fn for _, fn, _ in STEPS] if step is None else [step]
    imported, here = {}, {}
    # this module's names and helpers, and those of every module a step lives in
    # (reports.transmission_step's fe_band, which imports the FE ear)
    for mod in {__name__, *(fn.__module__ for fn in steps if fn.__module__.startswith("isj."))}:
        imported |= digest.top_level_names(mod)  # e.g. static_row → isj.calibration.checks
        ns = vars(sys.modules[mod])
        here |= {n: f for n, f in ns.items() if inspect.isfunction(f) and f.__module__ == mod}
    members = {n: m for n, m in vars(Context).items() if inspect.isfunction(m) or isinstance(m, property)}
    held = {f.name: type(getattr(ctx, f.name)).__module__ for f in dataclasses.fields(ctx)}
    return digest.closure(digest.function_imports(*steps, follow=imported | here | members | held))
