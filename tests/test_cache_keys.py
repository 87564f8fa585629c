"""Cache keys hold a result's inputs and the results versions it depends on (isj.results_version), not code.

Each key changes with the version of each family the result depends on and with no other
(:data:`isj.results_version.DEPENDS`); each report step's families cover the code it reaches
(found through the import system, :mod:`isj.digest`). The end-to-end check runs the coarse
report (tests/conftest.py) again in a subprocess on a copy of isj whose lumped equations differ
and whose ``lumped`` version is bumped, as the honesty rule asks: the steps that use the lumped
model are recomputed with the new equation, the FE-only steps come from the cache (so a copy of
the same code elsewhere gives the same keys). tests/test_cache_invalidation.py tests the FE
results both ways on copies.
"""

import ast
import importlib.metadata
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_cache_invalidation import copy_of_isj, edit

from isj import digest
from isj import results_version as rv


def test_imports_in_resolves_relative_submodule_and_attribute_imports():
    text = (
        "from typing import TYPE_CHECKING\n"
        "import numpy\n"
        "from . import design\n"  # a submodule
        "from isj import __version__\n"  # an attribute of the package
        "if TYPE_CHECKING:\n"
        "    from isj.fem import mesh\n"  # never runs: not a dependency
        "def f():\n"
        "    from .ear import EarGeometry\n"  # lazy: still a dependency
    )
    assert digest.imports_in(ast.parse(text), "isj") == {"isj.design", "isj", "isj.ear"}


def test_no_key_reads_the_code():
    """The FE, the mesh cache, the surrogate and the runner never load isj.digest."""
    for module in ("isj.fem.batch", "isj.fem.rom.model", "isj.calibration.runner", "isj.reports.store"):
        assert "isj.digest" not in digest.closure([module]), module


def test_versions_close_over_their_families_and_name_the_libraries():
    v = rv.versions("fe_dynamic")
    assert {k for k in v if k in rv.VERSIONS} == {"mesh", "fe_static", "fe_dynamic"}
    assert v["gmsh"] == importlib.metadata.version("gmsh")  # full: another gmsh may mesh differently
    assert v["numpy"] == ".".join(importlib.metadata.version("numpy").split(".")[:2])
    assert v["scipy"] == ".".join(importlib.metadata.version("scipy").split(".")[:2])
    assert rv.versions("lumped") == {"lumped": rv.VERSIONS["lumped"]}
    assert set(rv.VERSIONS) == set(rv.DEPENDS) and set(rv.STEP_VERSIONS) == set(rv.STEP_FAMILIES)
    from isj.errors import InvalidParameter

    with pytest.raises(InvalidParameter, match="fe_statc"):
        rv.versions("fe_statc")


def _keys(ctx) -> dict[str, str]:
    """Every kind of key for one input each, under the versions in force now."""
    from isj.calibration.runner import design_key, keyed_settings
    from isj.fem import cache as mesh_cache
    from isj.fem.batch import evaluate_design, evaluate_modes, fe_settings
    from isj.fem.geometry import MeshSizes
    from isj.fem.rom.model import cache_key as rom_key
    from isj.reports.steps import STEPS, step_inputs
    from isj.reports.store import step_key

    from isj.design import Geometry
    from isj.design_space import DesignSpace

    s = fe_settings(order=1, resolution=0.35)
    out = {
        "mesh": mesh_cache.cache_key("pedicle_joint", Geometry(), MeshSizes()),
        "static": design_key({}, keyed_settings(evaluate_design, s)),
        "modes": design_key({}, keyed_settings(evaluate_modes, s | {"kind": "modes"})),
        "surrogate": rom_key("0" * 64, 1, Geometry(), DesignSpace(), {"tol": 1e-3}),
    }
    for name, fn, sections in STEPS:
        if name in ("model", "cases", "ear", "uq"):
            out[f"step:{name}"] = step_key(name, step_inputs(ctx, sections, fn))
    return out


@pytest.mark.parametrize(
    "family, changed",
    [
        # step:uq: its ΔH_V comes from the fast ear (an FE ear result)
        ("mesh", {"mesh", "static", "modes", "surrogate", "step:model", "step:cases", "step:ear", "step:uq"}),
        ("fe_static", {"static", "modes", "surrogate", "step:model", "step:cases", "step:ear", "step:uq"}),
        ("fe_dynamic", {"modes", "step:model", "step:cases", "step:ear", "step:uq"}),
        ("ear", {"step:ear", "step:uq"}),
        ("surrogate", {"surrogate"}),
        ("lumped", {"step:cases", "step:uq"}),
        ("drum_modes", {"step:uq"}),
    ],
)
def test_a_bumped_version_changes_exactly_the_keys_of_what_depends_on_it(family, changed, monkeypatch):
    from isj.reports.config import ReportConfig
    from isj.reports.run import load_calibration
    from isj.reports.steps import Context

    cfg = ReportConfig()
    ctx = Context(cfg, load_calibration(cfg), Path("unused"))
    before = _keys(ctx)
    monkeypatch.setitem(rv.VERSIONS, family, rv.VERSIONS[family] + 1)
    after = _keys(ctx)
    assert {k for k in before if before[k] != after[k]} == changed


def test_a_bumped_step_version_changes_that_step_only(monkeypatch):
    from isj.reports.config import ReportConfig
    from isj.reports.run import load_calibration
    from isj.reports.steps import Context

    cfg = ReportConfig()
    ctx = Context(cfg, load_calibration(cfg), Path("unused"))
    before = _keys(ctx)
    monkeypatch.setitem(rv.STEP_VERSIONS, "cases", rv.STEP_VERSIONS["cases"] + 1)
    after = _keys(ctx)
    assert {k for k in before if before[k] != after[k]} == {"step:cases"}


def test_the_fe_settings_carry_the_versions_and_the_runner_those_of_its_evaluator():
    from isj.calibration.runner import keyed_settings
    from isj.fem import batch

    from isj.errors import InvalidParameter

    s = batch.fe_settings(order=1, resolution=0.35)
    assert s["versions"] == rv.versions("fe_static")
    assert keyed_settings(batch.evaluate_harmonic, s)["versions"] == rv.versions("fe_dynamic")
    assert keyed_settings(lambda d, s: {}, s) == s  # an evaluator without families: unchanged
    other = {**s, "versions": {**s["versions"], "mesh": s["versions"]["mesh"] + 1}}
    with pytest.raises(InvalidParameter, match="versions"):
        batch.evaluate_modes({}, other)


#: Modules whose code makes a family's results: a step that reaches one reads that family.
FAMILY_MODULES = {
    "mesh": ("isj.fem.mesh", "isj.fem.geometry"),
    "fe_static": ("isj.fem.model", "isj.fem.assembly"),
    "fe_dynamic": ("isj.fem.dynamics",),
    "ear": ("isj.fem.ear.middle_ear", "isj.fem.ear.reduced_ear"),
    "drum_modes": ("isj.fem.ear.drum_modes", "isj.lumped.ear_drum"),
    "surrogate": ("isj.fem.rom",),
    "lumped": ("isj.lumped.model", "isj.lumped.dynamics", "isj.lumped.ear"),
}


def test_each_report_step_reads_every_family_whose_code_it_reaches():
    """STEP_FAMILIES, closed over DEPENDS, cover the families of the modules each step's code reaches."""
    from isj.reports.config import ReportConfig
    from isj.reports.run import load_calibration
    from isj.reports.steps import STEPS, Context, step_modules

    cfg = ReportConfig()
    ctx = Context(cfg, load_calibration(cfg), Path("unused"))
    assert [name for name, _, _ in STEPS] == list(rv.STEP_VERSIONS)
    for name, fn, _ in STEPS:
        mods = set(step_modules(ctx, fn))
        reached = {f for f, prefixes in FAMILY_MODULES.items() if any(m.startswith(prefixes) for m in mods)}
        assert reached <= set(rv.families(*rv.STEP_FAMILIES[name])), (name, reached)
    # and the FE-only steps do not read the lumped model (a change of it keeps them)
    lumped = {n for n in rv.STEP_FAMILIES if "lumped" in rv.STEP_FAMILIES[n]}
    assert {"model", "convergence", "ear", "transmission"}.isdisjoint(lumped)


RUN_REPORT = """
import json, sys
import isj, isj.lumped.model
from isj.reports.config import load_config
from isj.reports.run import run_report

res = run_report(load_config(sys.argv[1]), sys.argv[2], verbosity=0)
print(json.dumps({"lumped_file": isj.lumped.model.__file__, "cached": res["cached"],
                  "cases": res["steps"]["cases"]}))
"""


def test_changed_lumped_equation_with_its_version_bumped_recomputes_the_steps_that_use_it(report, tmp_path):
    site = copy_of_isj(tmp_path / "site")
    anchor = "    return alpha, beta\n"  # the end of lumped.model.equations
    changed = "    return alpha, 1.25 * beta  # changed by the test\n"
    edit(site / "isj" / "lumped" / "model.py", anchor, changed)
    edit(site / "isj" / "results_version.py", '    "lumped": 1,\n', '    "lumped": 2,\n')

    env = dict(os.environ, PYTHONPATH=str(site), ISJ_FE_CACHE_DIR=str(report["fe_cache"]))
    proc = subprocess.run(
        [sys.executable, "-c", RUN_REPORT, str(report["case"]), str(tmp_path / "out")],
        env=env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    assert Path(got["lumped_file"]).is_relative_to(site)  # the changed copy is what ran

    # the steps without the lumped family: same keys from a copy of the same code elsewhere, so cached
    assert sorted(got["cached"]) == sorted(n for n in rv.STEP_VERSIONS if "lumped" not in rv.STEP_FAMILIES[n])
    assert sorted(got["cached"]) == ["convergence", "ear", "model", "transmission"]
    # the lumped steps ran the changed equation: β × 1.25, α and every FE number unchanged
    before = report["second"]["steps"]["cases"]["rows"]
    after = got["cases"]["rows"]
    assert len(after) == len(before) == 7
    for b, a in zip(before, after, strict=True):
        assert a["fe"] == b["fe"]
        assert a["lumped"]["alpha_rad"] == pytest.approx(b["lumped"]["alpha_rad"], rel=1e-12)
        assert a["lumped"]["beta_rad"] == pytest.approx(1.25 * b["lumped"]["beta_rad"], rel=1e-12)
