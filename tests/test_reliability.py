"""Reliability: gmsh between two PARDISO factorizations, solver threads, OpenMP state.

The crash this guards against was a SIGSEGV (exit 139): a PARDISO analysis made
with two threads, then gmsh (which sets OpenMP to one thread), then a new
numeric factorization. It is run in a subprocess, so that a crash fails the
test instead of killing the test run.
"""

import os
import subprocess
import sys
import textwrap

import pytest
from isj.fem import solvers

from isj.errors import InvalidParameter

# Build from a cached mesh and solve; mesh the cantilever uncached (gmsh runs); solve again.
_MINIMAL_SEQUENCE = textwrap.dedent(
    """
    import sys
    from pathlib import Path

    from isj.design import Materials
    from isj.fem.cache import load_mesh
    from isj.fem.mesh import mesh_cantilever
    from isj.fem.model import PedicleJointModel

    # the mesh from disk, as from the mesh cache: gmsh has not run in this process
    model = PedicleJointModel(order=2, mesh=load_mesh(Path(sys.argv[1])))
    first = model.solve()
    mesh_cantilever(cache_dir=False)
    again = model.solve()
    other = model.solve(Materials(pedicle_e_pa=4e9))
    print(first.alpha_rad.hex(), again.alpha_rad.hex(), other.alpha_rad.hex())
    """
)


def _clean_env(tmp_path, **extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    env.pop(solvers.SOLVER_THREADS_ENV, None)
    env["ISJ_CACHE_DIR"] = str(tmp_path / "meshes")
    env.update(extra)
    return env


@pytest.mark.skipif("pardiso" not in solvers.available_backends(), reason="PARDISO not installed")
def test_gmsh_between_two_factorizations_does_not_crash(tmp_path):
    from isj.fem.cache import save_mesh
    from isj.fem.mesh import mesh_pedicle_joint

    # meshed here, read from disk there: gmsh running first in the subprocess would set one
    # thread for the whole process and hide the crash
    path = tmp_path / "joint.npz"
    save_mesh(mesh_pedicle_joint(resolution=0.35, cache_dir=False), path)
    # two solver threads, as on any multi-core machine: the crash needed more than one
    env = _clean_env(tmp_path, **{solvers.SOLVER_THREADS_ENV: "2"})
    run = subprocess.run(
        [sys.executable, "-c", _MINIMAL_SEQUENCE, str(path)],
        env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 0, f"exit {run.returncode}: {run.stderr[-2000:]}"
    first, again, other = run.stdout.split()
    # gmsh in between changes nothing in the solver: the same materials give the same bits
    assert first == again
    assert other != first


@pytest.mark.skipif("pardiso" not in solvers.available_backends(), reason="PARDISO not installed")
def test_solver_threads_stay_pinned_and_openmp_count_is_restored_after_gmsh(tmp_path):
    script = textwrap.dedent(
        """
        import ctypes, os
        import numpy as np, scipy.sparse as sp
        from isj.fem.mesh import mesh_cantilever
        from isj.fem.solvers import make_solver, pin_solver_threads
        import pypardiso

        A = sp.diags([np.full(50, -1.0), np.full(51, 4.0), np.full(50, -1.0)], [-1, 0, 1], format="csr")
        make_solver(A, "pardiso").factor(A)
        gomp = ctypes.CDLL("libgomp.so.1", mode=os.RTLD_NOLOAD | os.RTLD_LAZY)
        before = gomp.omp_get_max_threads()
        mesh_cantilever(cache_dir=False)
        print(pin_solver_threads()["threads"], pypardiso.ps.libmkl.MKL_Get_Max_Threads(),
              before, gomp.omp_get_max_threads())
        """
    )
    env = _clean_env(tmp_path, **{solvers.SOLVER_THREADS_ENV: "3", "OMP_NUM_THREADS": "2"})
    run = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    pinned, mkl_now, omp_before, omp_after = (int(v) for v in run.stdout.split())
    assert pinned == mkl_now == 3  # ISJ_SOLVER_THREADS wins over OMP_NUM_THREADS, and gmsh did not reach it
    assert omp_before == omp_after == 2  # gmsh's one thread did not leak into the process


@pytest.mark.parametrize(
    ("env", "expected"),
    [
        ({solvers.SOLVER_THREADS_ENV: "5", "OMP_NUM_THREADS": "2"}, 5),
        ({"MKL_NUM_THREADS": "3", "OMP_NUM_THREADS": "2"}, 3),
        ({"OMP_NUM_THREADS": "4,2"}, 4),  # OpenMP's nested form: the outer level
        ({"OMP_NUM_THREADS": "lots"}, None),  # not ours to refuse: ignored
    ],
)
def test_solver_threads_follow_the_environment(monkeypatch, env, expected):
    for name in (solvers.SOLVER_THREADS_ENV, "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
        monkeypatch.delenv(name, raising=False)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    n = solvers.solver_threads()
    assert n == (expected if expected is not None else len(os.sched_getaffinity(0)))


@pytest.mark.parametrize("value", ["0", "-1", "two", "1.5", "100000"])
def test_bad_solver_thread_count_is_refused(monkeypatch, value):
    monkeypatch.setenv(solvers.SOLVER_THREADS_ENV, value)
    with pytest.raises(InvalidParameter, match=r"ISJ_SOLVER_THREADS = .*\[1, 1024\]"):
        solvers.solver_threads()


def test_lanczos_start_is_fixed_and_not_degenerate():
    a, b = solvers.lanczos_start(1000), solvers.lanczos_start(1000)
    assert a.tobytes() == b.tobytes()
    assert a.shape == (1000,) and -1 <= a.min() < -0.9 and 0.9 < a.max() < 1


def test_whole_ear_takes_its_joint_length_from_a_joint_of_another_stack_height():
    import numpy as np
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.model import PedicleJointModel

    from isj.design import Geometry
    from isj.ear import EarGeometry

    geometry = Geometry(gap_thickness_m=40e-6)  # 5 µm taller than the ear's default joint
    joint = PedicleJointModel(geometry, order=1, resolution=0.35)
    ear = MiddleEarModel(joint=joint)
    g = ear.geometry
    assert g.joint_length_m == geometry.z_top != EarGeometry().joint_length_m
    assert g.long_process_end_m == EarGeometry().long_process_end_m  # the incus stays put
    # the joint's end faces lie in the planes of the stapes head and of the long process's end
    pts, z = ear.joint_points_m, np.asarray(g.joint_z_direction)
    assert len(ear.stapes_face) > 0 and len(ear.incus_face) > 0
    assert np.abs((pts[ear.stapes_face] - g.stapes_head_m) @ z).max() < 1e-12
    assert np.abs((pts[ear.incus_face] - g.long_process_end_m) @ z).max() < 1e-12
    res = ear.solve()
    assert res.alpha_rad_per_pa > 0 and res.beta_rad_per_pa > 0
    assert np.isfinite(res.footplate_piston_m_per_pa) and res.footplate_piston_m_per_pa > 0
    # the rigid-joint variant of the same ear
    rigid = MiddleEarModel(joint=None, geometry=g).solve()
    assert rigid.footplate_piston_m_per_pa > res.footplate_piston_m_per_pa  # a compliant joint loses motion
    assert EarGeometry().for_joint(Geometry()) is not None
    assert EarGeometry().for_joint(Geometry()) == EarGeometry()


# a coarse report (as tests/test_report.py's) with another stack height
_COARSE_REPORT = {
    "geometry": {"gap_thickness_m": 40e-6},
    "mesh": {"order": 2, "resolution": 0.35},
    "trends": {"moduli": ["gap_e_pa"], "n_lumped": 5, "fe_points": 1},
    "convergence": {"orders": [2], "directions": ["y"]},
    "calibration": {"check_samples": 1, "seed": 7},
    "sweep": {"n_freq": 10, "fe_checks": 1, "n_modes": 3},
}


def _config(tmp_path, extra: dict | None = None):
    import json

    from isj.reports.config import load_config

    sections = {k: dict(v) for k, v in _COARSE_REPORT.items()}
    for k, v in (extra or {}).items():
        sections.setdefault(k, {}).update(v)
    case = tmp_path / f"case-{len(list(tmp_path.glob('case-*')))}.toml"
    case.write_text(
        "".join(
            f"[{s}]\n" + "".join(f"{k} = {json.dumps(v)}\n" for k, v in values.items())
            for s, values in sections.items()
        )
    )
    return load_config(case)


def _snapshot(folder) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_report_with_another_stack_height_completes_and_a_failed_run_leaves_the_old_one(
    tmp_path, monkeypatch
):
    import json

    import isj.reports.run as run

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "fe"))
    out = tmp_path / "out"
    run.run_report(_config(tmp_path), out, verbosity=0)
    ear = json.loads((out / "data" / "ear.json").read_text())
    assert len(ear["cases"]) == 7 and ear["n_dofs"] > ear["n_dofs_rigid_joint"]
    model = json.loads((out / "data" / "model.json").read_text())
    assert model["base"]["alpha_rad"] > 0
    assert "gap_thickness_m = 4e-05" in (out / "resolved_config.toml").read_text()
    before = _snapshot(out)
    assert "report.pdf" in before and "base.vtu" in before

    # another configuration, interrupted at its last step: the old report stays whole
    other = _config(tmp_path, {"ear": {"drum_e_pa": 30e6}})

    def broken(ctx):
        raise KeyboardInterrupt

    steps = run.STEPS
    monkeypatch.setattr(run, "STEPS", tuple((n, broken if n == "ear" else f, s) for n, f, s in steps))
    with pytest.raises(KeyboardInterrupt):
        run.run_report(other, out, verbosity=0)
    assert _snapshot(out) == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []  # no partial folder

    # run again: it starts at the first unfinished step, and the new report replaces the old
    monkeypatch.setattr(run, "STEPS", steps)
    summary = run.run_report(other, out, verbosity=0)
    assert summary["cached"] == ["model", "cases", "trends", "convergence", "calibration", "sweep"]
    after = _snapshot(out)
    assert after["data/model.json"] == before["data/model.json"]
    assert after["data/ear.json"] != before["data/ear.json"]
    assert after["base.vtu"] == before["base.vtu"]  # reused: the same model step
    assert "drum_e_pa = 30000000.0" in (out / "resolved_config.toml").read_text()


@pytest.mark.parametrize("kind", ["foreign file", "a file", "current folder", "empty name"])
def test_report_refuses_an_output_folder_it_may_not_replace(tmp_path, monkeypatch, kind):
    import isj.reports.run as run

    monkeypatch.chdir(tmp_path)
    target = tmp_path / "out"
    if kind == "foreign file":
        target.mkdir()
        (target / "notes.txt").write_text("mine")
    elif kind == "a file":
        target.write_text("mine")
    elif kind == "current folder":
        target = tmp_path
    else:
        target = ""
    with pytest.raises(InvalidParameter, match=r"^out_dir = .*: (holds|exists|must)"):
        run.check_out_dir(target)
    calls = []
    monkeypatch.setattr(run, "_run", lambda *a, **k: calls.append(a))
    with pytest.raises(InvalidParameter):
        run.run_report(None, target, verbosity=0, calibration=object())
    assert calls == []  # refused before anything is computed
    if kind == "foreign file":
        assert (target / "notes.txt").read_text() == "mine"
