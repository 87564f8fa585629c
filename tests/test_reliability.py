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
