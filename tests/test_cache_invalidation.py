"""Cache keys hold results versions, not code: tested both ways on copies of isj.

Each run is a subprocess with a copy of the isj package first on ``sys.path`` and private
mesh and FE result caches. It puts three static designs and one modal design of a coarse P1
model through :func:`isj.calibration.runner.run_designs` and counts what it computes: the
evaluator's calls and gmsh's runs (spies in the run script), and the cache entries on disk.

(a) a pure refactor of FE modules (comments, renamed local variables in ``fem/elements.py``
    and in the element stiffness of ``fem/assembly.py``, two independent statements swapped)
    recomputes nothing: no evaluation, no mesh, no new entry, and the same numbers;
(b) a changed element formula (every element stiffness × 1.01) with the ``fe_static`` version
    bumped, as the honesty rule asks, recomputes every FE result, static and modal (the
    ``fe_dynamic`` results depend on ``fe_static``), keeps the mesh (its family is another),
    and the results differ: α and β × 1/1.01, the frequencies × √1.01;
(c) the same change without the bump: the honesty test (tests/test_results_version.py) fails
    on that copy, naming the family to bump; on the unchanged copy it passes.
"""

import importlib
import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

TESTS = Path(__file__).parent


def packages() -> list[str]:
    """isj's packages, as pyproject.toml lists them for the wheel (``[tool.setuptools] packages``)."""
    with open(TESTS.parent / "pyproject.toml", "rb") as fh:
        return list(tomllib.load(fh)["tool"]["setuptools"]["packages"])


def copy_of_isj(dest: Path) -> Path:
    """isj as a wheel lays it out under ``dest`` (sources and data files), from the installed packages."""
    for pkg in packages():
        src = Path(importlib.import_module(pkg).__path__[0])
        out = dest.joinpath(*pkg.split("."))
        out.mkdir(parents=True, exist_ok=True)
        for f in src.glob("*.py"):
            shutil.copyfile(f, out / f.name)
        if (src / "data").is_dir():
            shutil.copytree(src / "data", out / "data", dirs_exist_ok=True)
    # the honesty test and its reference, to run on the copy
    (dest / "tests" / "data").mkdir(parents=True, exist_ok=True)
    for name in ("test_results_version.py", "data/results_reference.json"):
        shutil.copyfile(TESTS / name, dest / "tests" / name)
    return dest


def edit(path: Path, old: str, new: str) -> None:
    """Replace the one occurrence of ``old`` in ``path`` by ``new``."""
    text = path.read_text()
    assert text.count(old) == 1, (path, old)
    path.write_text(text.replace(old, new))


RUN = """
import json, sys
import isj.fem.elements, isj.fem.mesh as mesh_mod
from isj.calibration.runner import run_designs
from isj.fem.batch import evaluate_design, evaluate_modes, fe_settings

calls = {"static": 0, "modes": 0, "gmsh": 0}
real_gmsh = mesh_mod._gmsh_mesh
def gmsh_spy(*a):
    calls["gmsh"] += 1
    return real_gmsh(*a)
mesh_mod._gmsh_mesh = gmsh_spy

def counted(fn, name):
    def run(design, settings):
        calls[name] += 1
        return fn(design, settings)
    run.result_families = fn.result_families
    return run

s = fe_settings(order=1, resolution=0.35)
designs = [{}, {"gap_e_pa": 5e6}, {"pedicle_e_pa": 3e9}]
st = run_designs(designs, counted(evaluate_design, "static"), s, sys.argv[1], max_workers=0, progress=False)
mo = run_designs([{}], counted(evaluate_modes, "modes"), s | {"kind": "modes", "n_modes": 2}, sys.argv[1],
                 max_workers=0, progress=False)
print(json.dumps({"elements": isj.fem.elements.__file__, "calls": calls,
                  "alpha": [r["result"]["alpha_rad"] for r in st],
                  "beta": [r["result"]["beta_rad"] for r in st],
                  "freq": mo[0]["result"]["freq_hz"]}))
"""


def _env(site: Path, caches: Path) -> dict:
    return dict(
        os.environ,
        PYTHONPATH=str(site),
        ISJ_CACHE_DIR=str(caches / "meshes"),
        ISJ_FE_CACHE_DIR=str(caches / "fe"),
        HOME=str(caches / "home"),
    )


def _run(site: Path, caches: Path) -> dict:
    caches.mkdir(exist_ok=True)
    proc = subprocess.run(
        [sys.executable, "-c", RUN, str(caches / "fe")],
        env=_env(site, caches),
        cwd=caches,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    assert Path(got["elements"]).is_relative_to(site)  # the copy is what ran
    got["entries"] = sorted(
        str(p.relative_to(caches)) for d in ("meshes", "fe") for p in (caches / d).rglob("*") if p.is_file()
    )
    return got


def _honesty(site: Path, caches: Path, family: str) -> subprocess.CompletedProcess:
    caches.mkdir(exist_ok=True)
    return subprocess.run(
        [sys.executable, str(site / "tests" / "test_results_version.py"), "--check", family],
        env=_env(site, caches),
        cwd=caches,
        capture_output=True,
        text=True,
        timeout=600,
    )


def _refactor(site: Path) -> None:
    """A change of text that leaves every result bit for bit."""
    elements = site / "isj" / "fem" / "elements.py"
    edit(  # two independent statements swapped
        elements,
        "#: Vertex pairs of the P2 mid-edge nodes, in VTK tetra10 order.\n"
        "TET10_EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]], dtype=np.int64)\n\n"
        "#: Gradient of the barycentric coordinates with respect to (ξ, η, ζ).\n"
        "_DL = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])\n",
        "#: Gradient of the barycentric coordinates with respect to (ξ, η, ζ).\n"
        "_DL = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])\n\n"
        "#: Vertex pairs of the P2 mid-edge nodes, in VTK tetra10 order.\n"
        "TET10_EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]], dtype=np.int64)\n",
    )
    edit(  # a local variable renamed, a comment added
        elements,
        "    g = shape_gradients(order, barycentric(pts))\n"
        '    return np.einsum("q,qia,qjb->ijab", w, g, g)\n',
        "    # the gradients at the quadrature points (a refactor made by tests/test_cache_invalidation.py)\n"
        "    grads = shape_gradients(order, barycentric(pts))\n"
        '    return np.einsum("q,qia,qjb->ijab", w, grads, grads)\n',
    )
    assembly = site / "isj" / "fem" / "assembly.py"  # the element stiffness the model assembles
    edit(
        assembly,
        "    g = g.reshape(e.size, q, n * 3) * np.sqrt(space.det[e] / (6 * q))[:, None, None]\n"
        "    return np.matmul(g.transpose(0, 2, 1), g)\n",
        "    # weighted by the square root of each quadrature weight (a refactor made by the test)\n"
        "    grads = g.reshape(e.size, q, n * 3) * np.sqrt(space.det[e] / (6 * q))[:, None, None]\n"
        "    return np.matmul(grads.transpose(0, 2, 1), grads)\n",
    )


def _scale_stiffness(site: Path) -> None:
    """A changed element formula: every element's gradient products, hence its stiffness, × 1.01."""
    edit(
        site / "isj" / "fem" / "assembly.py",
        "    return np.matmul(grads.transpose(0, 2, 1), grads)\n",
        "    return 1.01 * np.matmul(grads.transpose(0, 2, 1), grads)  # changed by the test\n",
    )


def _bump(site: Path, family: str) -> None:
    edit(site / "isj" / "results_version.py", f'    "{family}": 1,\n', f'    "{family}": 2,\n')


@pytest.mark.slow
def test_refactor_keeps_every_entry_and_a_changed_formula_recomputes_every_fe_result(tmp_path):
    site = copy_of_isj(tmp_path / "site")
    caches = tmp_path / "caches"
    first = _run(site, caches)
    assert first["calls"] == {"static": 3, "modes": 1, "gmsh": 1}
    assert len(first["entries"]) >= 5  # the mesh, three static and one modal result (and orderings)

    # (a) a pure refactor: nothing recomputed, nothing new on disk, the same numbers
    _refactor(site)
    again = _run(site, caches)
    assert again["calls"] == {"static": 0, "modes": 0, "gmsh": 0}
    assert again["entries"] == first["entries"]
    assert (again["alpha"], again["beta"], again["freq"]) == (first["alpha"], first["beta"], first["freq"])

    # (b) a changed formula with the bump: every FE result recomputed and different, the mesh kept
    bumped = copy_of_isj(tmp_path / "bumped")
    _refactor(bumped)
    _scale_stiffness(bumped)
    _bump(bumped, "fe_static")
    changed = _run(bumped, caches)
    assert changed["calls"] == {"static": 3, "modes": 1, "gmsh": 0}
    new = set(changed["entries"]) - set(first["entries"])
    assert len(new) == 4 and all(e.startswith("fe/") and e.endswith(".json") for e in new)
    for a, b in zip(changed["alpha"] + changed["beta"], first["alpha"] + first["beta"], strict=True):
        assert a == pytest.approx(b / 1.01, rel=1e-9)
    for a, b in zip(changed["freq"], first["freq"], strict=True):
        assert a == pytest.approx(b * 1.01**0.5, rel=1e-7)


@pytest.mark.slow
def test_a_changed_formula_without_a_bump_fails_the_honesty_test(tmp_path):
    site = copy_of_isj(tmp_path / "site")
    caches = tmp_path / "caches"
    _refactor(site)
    ok = _honesty(site, caches, "fe_static")
    assert ok.returncode == 0, ok.stdout + ok.stderr[-2000:]

    # (c) the formula changed, the version not: the honesty test fails and says what to do
    _scale_stiffness(site)
    bad = _honesty(site, caches, "fe_static")
    assert bad.returncode == 1, bad.stdout + bad.stderr[-2000:]
    assert "fe_static: default.alpha_rad" in bad.stdout and "bump the version" in bad.stdout
    assert "tests/test_results_version.py --write" in bad.stdout
