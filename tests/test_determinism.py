"""The same input gives the same bits: cold or warm caches, resumed or not, repeated modes.

Each run is a fresh process (as a user's runs are), so that nothing memoised in
one run (models, solver threads) can make another agree by accident. Numbers
are compared as their exact binary values (``float.hex``) or as the bytes of
the report's data files.
"""

import json
import os
import shutil
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.slow  # runs in fresh processes, reports included

_SOLVE = textwrap.dedent(
    """
    from isj.fem.mesh import mesh_cantilever
    from isj.fem.model import PedicleJointModel
    model = PedicleJointModel(order=2, resolution=0.35)
    res = model.static()
    mesh_cantilever(resolution=0.5, cache_dir=False)  # gmsh after the first factorization
    again = model.static(res.materials.replace(gap_e_pa=2e7))
    print(res.alpha_rad.hex(), res.beta_rad.hex(), again.alpha_rad.hex(), again.beta_rad.hex())
    """
)

_MODES = textwrap.dedent(
    """
    from isj.fem.dynamics import modes
    from isj.fem.model import PedicleJointModel
    freq, shapes = modes(PedicleJointModel(order=1, resolution=0.35), n=3)
    print(" ".join(f.hex() for f in freq), shapes[:, 0].sum().hex(), abs(shapes).sum().hex())
    """
)

# interrupted at the ear (the seventh step), as a user's Ctrl-C would be
_INTERRUPTED_REPORT = textwrap.dedent(
    """
    import sys
    import isj.reports.run as run
    from isj.reports.config import load_config

    def interrupted(ctx):
        raise KeyboardInterrupt
    run.STEPS = tuple((n, interrupted if n == "ear" else f, s) for n, f, s in run.STEPS)
    try:
        run.run_report(load_config(sys.argv[1]), sys.argv[2], verbosity=0)
    except KeyboardInterrupt:
        sys.exit(0)
    sys.exit("the report was not interrupted")
    """
)


def _env(tmp_path, name: str) -> dict:
    """The environment of a run with its own mesh and FE caches ``tmp_path/name-*``."""
    env = dict(os.environ)
    env["ISJ_CACHE_DIR"] = str(tmp_path / f"{name}-meshes")
    env["ISJ_FE_CACHE_DIR"] = str(tmp_path / f"{name}-fe")
    return env


def _python(code: str, env: dict, *args: str, script=None) -> str:
    command = [sys.executable, str(script)] if script else [sys.executable, "-c", code]
    run = subprocess.run([*command, *args], env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, f"exit {run.returncode}: {run.stderr[-3000:]}"
    return run.stdout


def _report(case, out, env) -> None:
    cli = "import sys; from isj.cli import main; sys.exit(main(sys.argv[1:]))"
    _python(cli, env, "report", "--config", str(case), "--out", str(out), "-q")


def _data(out) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "data").iterdir())}


def test_alpha_and_beta_do_not_depend_on_the_mesh_cache(tmp_path):
    env = _env(tmp_path, "a")
    cold = _python(_SOLVE, env)  # meshes with gmsh first
    warm = _python(_SOLVE, env)  # the mesh from the cache: PARDISO runs before gmsh
    assert cold.split() == warm.split()
    assert len(set(cold.split())) == 4


def test_repeated_modes_are_identical(tmp_path):
    env = _env(tmp_path, "m")
    first, second = _python(_MODES, env), _python(_MODES, env)
    assert first == second
    assert len(first.split()) == 5


@pytest.mark.slow
def test_cold_and_warm_resumed_reports_give_the_same_data(tmp_path, cold_cli_report):
    # cold: empty caches (tests/conftest.py's small report, shared with tests/test_reliability.py)
    cold_dir, case, caches = cold_cli_report["dir"], cold_cli_report["case"], cold_cli_report["caches"]
    # warm: the cold run's meshes, FE results and surrogate, but none of its report steps, so
    # every step is recomputed from what the caches give; interrupted, then resumed in a new
    # process at the first unfinished step (tests/test_reliability.py resumes a cold run)
    shutil.copytree(caches / "meshes", tmp_path / "c-meshes")
    shutil.copytree(caches / "fe", tmp_path / "c-fe")
    shutil.rmtree(tmp_path / "c-fe" / "report")  # the step cache
    resumed_env = _env(tmp_path, "c")
    script = tmp_path / "interrupted.py"  # a file: the step cache reads the steps' source
    script.write_text(_INTERRUPTED_REPORT)
    _python(script.read_text(), resumed_env, str(case), str(tmp_path / "resumed"), script=script)
    assert not (tmp_path / "resumed").exists()  # nothing half-written is left under --out
    _report(case, tmp_path / "resumed", resumed_env)
    run = json.loads((tmp_path / "resumed" / "run.json").read_text())
    assert run["cached_steps"] == ["model", "sweep", "cases", "trends", "convergence", "calibration"]

    cold = _data(cold_dir)
    assert len(cold) >= 7
    resumed = _data(tmp_path / "resumed")
    assert resumed.keys() == cold.keys()
    differ = [f for f in cold if cold[f] != resumed[f]]
    assert not differ, f"the warm, resumed run differs from the cold one in {differ}"
    # the PDF too, unless the pages' date or git revision changed between the runs
    cold_run = json.loads((cold_dir / "run.json").read_text())
    if cold_run["provenance"] == run["provenance"]:
        pdf = [(d / "report.pdf").read_bytes() for d in (cold_dir, tmp_path / "resumed")]
        assert pdf[0] == pdf[1]
