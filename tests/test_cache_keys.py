"""Cache keys come from the code a result depends on, found through the import system (isj.digest).

The end-to-end check runs the coarse report (tests/conftest.py) again in a
subprocess on a copy of isj whose lumped equations differ: the steps that use
the lumped model are recomputed with the new equation, the FE-only steps come
from the cache (so a copy of the same code elsewhere gives the same keys).
"""

import ast
import importlib
import importlib.resources
import json
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

from isj import digest


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


def test_fe_code_digest_is_the_import_closure_of_fem_batch():
    from isj.fem import batch

    deps = digest.closure(["isj.fem.batch"])
    assert {"isj.fem.model", "isj.fem.dynamics", "isj.fem.mesh", "isj.design"} <= set(deps)  # dynamics: lazy
    assert not [m for m in deps if m.startswith(("isj.lumped", "isj.reports", "isj.calibration"))]
    assert batch.fem_code_digest() == digest.code_digest("isj.fem.batch")
    assert len(batch.fem_code_digest()) == 64
    assert digest.code_digest("isj.fem.batch") != digest.code_digest("isj.fem.mesh")


def test_each_report_step_depends_on_the_lumped_model_exactly_when_it_uses_it():
    from isj.reports.config import ReportConfig
    from isj.reports.run import load_calibration
    from isj.reports.steps import STEPS, Context, step_modules

    cfg = ReportConfig()
    ctx = Context(cfg, load_calibration(cfg), Path("unused"))
    uses_lumped = {"cases", "trends", "calibration", "sweep", "load_path", "guard", "uq", "geometry_trends"}
    uses_lumped.add("sliding")  # each joint's lumped α, β beside FE (docs/lumped.md §3.14)
    for name, fn, _ in STEPS:
        mods = step_modules(ctx, fn)
        lumped = {m for m in mods if m.startswith("isj.lumped")}
        if name in uses_lumped:
            assert "isj.lumped.model" in lumped, name
        else:
            assert not lumped, (name, lumped)
    by_name = {name: set(step_modules(ctx, fn)) for name, fn, _ in STEPS}
    assert {"isj.fem.batch", "isj.fem.quality"} <= by_name["model"]
    assert "isj.fem.convergence" in by_name["convergence"]
    assert "isj.fem.ear.middle_ear" in by_name["ear"]
    assert "isj.fem.ear.reduced_ear" in by_name["transmission"]
    assert "isj.lumped.dynamics" in by_name["sweep"]
    assert "isj.lumped.artifact" in by_name["calibration"]  # the calibration object's own code


def _all_modules() -> dict[str, bool]:
    """Every isj module → is it a package, through the import system (an editable install maps
    isj.fem to another folder, so isj's own folder does not list it)."""
    found = {m: False for m in digest.closure(["isj.reports.run", "isj.cli"])}
    packages = {"isj"} | {m.rpartition(".")[0] for m in found if "." in m}
    todo = sorted(packages)
    while todo:
        pkg = todo.pop()
        found[pkg] = True
        for info in pkgutil.iter_modules(importlib.import_module(pkg).__path__, pkg + "."):
            if info.ispkg and info.name not in packages:
                packages.add(info.name)
                todo.append(info.name)
            found.setdefault(info.name, info.ispkg)
    return found


def _copy_of_isj(dest: Path) -> Path:
    """isj as a wheel lays it out, rebuilt from the import system (sources and package data)."""
    for name, is_package in _all_modules().items():
        parts = name.split(".")
        stem = dest.joinpath(*parts)
        path = stem / "__init__.py" if is_package else stem.with_name(parts[-1] + ".py")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(digest.module_source(name))
    data = importlib.resources.files("isj.lumped") / "data"
    (dest / "isj" / "lumped" / "data").mkdir(exist_ok=True)
    for f in data.iterdir():
        (dest / "isj" / "lumped" / "data" / f.name).write_bytes(f.read_bytes())
    return dest


RUN_REPORT = """
import json, sys
import isj, isj.lumped.model
from isj.reports.config import load_config
from isj.reports.run import run_report

res = run_report(load_config(sys.argv[1]), sys.argv[2], verbosity=0)
print(json.dumps({"lumped_file": isj.lumped.model.__file__, "cached": res["cached"],
                  "cases": res["steps"]["cases"]}))
"""


def test_changed_lumped_equation_recomputes_the_steps_that_use_it(report, tmp_path):
    site = _copy_of_isj(tmp_path / "site")
    model = site / "isj" / "lumped" / "model.py"
    text = model.read_text()
    anchor = "    return alpha, beta\n"  # the end of lumped.model.equations
    assert text.count(anchor) == 1
    model.write_text(text.replace(anchor, "    return alpha, 1.25 * beta  # changed by the test\n"))

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

    # the FE-only steps: same keys from a copy of the same code elsewhere, so cached
    # (the sliding step shows each joint's lumped α, β: it runs again too)
    assert sorted(got["cached"]) == ["convergence", "ear", "model", "transmission"]
    # the lumped steps ran the changed equation: β × 1.25, α and every FE number unchanged
    before = report["second"]["steps"]["cases"]["rows"]
    after = got["cases"]["rows"]
    assert len(after) == len(before) == 7
    for b, a in zip(before, after, strict=True):
        assert a["fe"] == b["fe"]
        assert a["lumped"]["alpha_rad"] == pytest.approx(b["lumped"]["alpha_rad"], rel=1e-12)
        assert a["lumped"]["beta_rad"] == pytest.approx(1.25 * b["lumped"]["beta_rad"], rel=1e-12)
