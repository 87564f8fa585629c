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
from pathlib import Path

import pytest
from conftest import SMALL_REPORT
from isj.fem import solvers
from test_cache_entries import flip_a_stored_byte

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
    first = model.static()
    mesh_cantilever(cache_dir=False)
    again = model.static()
    other = model.static(Materials(pedicle_e_pa=4e9))
    print(first.alpha_rad.hex(), again.alpha_rad.hex(), other.alpha_rad.hex())
    """
)


def _clean_env(tmp_path, **extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    env.pop(solvers.SOLVER_THREADS_ENV, None)
    env["ISJ_CACHE_DIR"] = str(tmp_path / "meshes")
    env.update(extra)
    return env


@pytest.mark.slow
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
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
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


@pytest.mark.slow
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
    res = ear.static()
    assert res.alpha_rad_per_pa > 0 and res.beta_rad_per_pa > 0
    assert np.isfinite(res.footplate_piston_m_per_pa) and res.footplate_piston_m_per_pa > 0
    # the rigid-joint variant of the same ear
    rigid = MiddleEarModel(joint=None, geometry=g).static()
    assert rigid.footplate_piston_m_per_pa > res.footplate_piston_m_per_pa  # a compliant joint loses motion
    assert EarGeometry().for_joint(Geometry()) == EarGeometry()
    # the lumped ear too
    from isj.lumped.ear import ear_model

    lumped = ear_model(joint_geometry=geometry)._freq_resp([100.0])
    assert lumped.shape == (1, 4) and np.isfinite(lumped).all()


# the small report of tests/conftest.py with another stack height
_COARSE_REPORT = {"geometry": {"gap_thickness_m": 40e-6}} | SMALL_REPORT


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


@pytest.mark.slow
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
    # every step that does not read the [ear] section comes from the cache (uq reads it: its
    # ΔH_V comes from the fast ear of the report's ear)
    assert summary["cached"] == [
        "model",
        "sweep",
        "cases",
        "trends",
        "convergence",
        "calibration",
        "sliding",
        "guard",
        "geometry_trends",
    ]
    after = _snapshot(out)
    assert after["data/model.json"] == before["data/model.json"]
    assert after["data/ear.json"] != before["data/ear.json"]
    assert after["base.vtu"] == before["base.vtu"]  # reused: the same model step
    assert "drum_e_pa = 30000000.0" in (out / "resolved_config.toml").read_text()


@pytest.mark.parametrize(
    "kind", ["foreign file", "a file", "current folder", "empty name", "unwritable", "link"]
)
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
    elif kind == "unwritable":
        target = "/proc/isj/report"
    elif kind == "link":
        (tmp_path / "real").mkdir()
        target.symlink_to(tmp_path / "real")
    else:
        target = ""
    with pytest.raises(InvalidParameter, match=r"^--out = .*: (holds|exists|must|nothing can|is a symbolic)"):
        run.check_out_dir(target, "--out")
    before = sorted(p.name for p in tmp_path.iterdir())
    calls = []
    monkeypatch.setattr(run, "_run", lambda *a, **k: calls.append(a))
    with pytest.raises(InvalidParameter):
        run.run_report(None, target, verbosity=0, calibration=object())
    assert calls == []  # refused before anything is computed
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # and nothing written
    if kind == "foreign file":
        assert (target / "notes.txt").read_text() == "mine"


# ---------------------------------------------------------------- bad geometry, locking, mesh size


@pytest.mark.parametrize("name", sorted(__import__("isj.design", fromlist=["x"]).GEOMETRY_BOUNDS_M))
def test_geometry_outside_its_physical_bounds_is_refused_naming_the_field(name):
    from isj.design import GEOMETRY_BOUNDS_M, Geometry

    lo, hi = GEOMETRY_BOUNDS_M[name]
    for bad in (lo * 0.99, hi * 1.01, 1.0):  # 1.0: metre-sized
        with pytest.raises(InvalidParameter, match=rf"^{name} = .* m: must lie in \[{lo:g}, {hi:g}\] m$"):
            Geometry(**{name: bad})
    assert lo <= getattr(Geometry(), name) <= hi  # the default is inside


@pytest.mark.slow
def test_degenerate_gap_is_refused_and_the_thinnest_allowed_gap_meshes_well():
    from isj.fem.mesh import mesh_pedicle_joint
    from isj.fem.quality import mesh_quality

    from isj.design import GEOMETRY_BOUNDS_M, Geometry

    with pytest.raises(InvalidParameter, match="gap_thickness_m = 1e-09 m"):
        Geometry(gap_thickness_m=1e-9)  # gave a minimum dihedral angle of 0.0014°
    thinnest = GEOMETRY_BOUNDS_M["gap_thickness_m"][0]
    q = mesh_quality(mesh_pedicle_joint(Geometry(gap_thickness_m=thinnest), resolution=0.5, cache_dir=False))
    assert q["min_dihedral_deg"] > 1.5  # 2.1° measured (the default geometry: 2.0°)


def test_nearly_incompressible_materials_warn_of_locking(coarse_model):
    import warnings

    from isj.fem.model import LOCKING_NU, check_locking

    from isj.design import Materials
    from isj.errors import IsjWarning, VolumetricLockingWarning

    assert issubclass(VolumetricLockingWarning, IsjWarning)
    with pytest.warns(VolumetricLockingWarning, match=r"nu = 0.4999999: above 0.49 P2"):
        locked = coarse_model.static(Materials(nu=0.4999999))
    with warnings.catch_warnings():
        warnings.simplefilter("error", VolumetricLockingWarning)
        fine = coarse_model.static(Materials(nu=LOCKING_NU[2]))  # the threshold itself: no warning
    assert locked.alpha_rad < fine.alpha_rad
    assert not check_locking(0.45, 1) and not check_locking(0.3, 2)
    with pytest.warns(VolumetricLockingWarning, match="P1"):
        assert check_locking(0.46, 1)  # P1 elements lock earlier


@pytest.mark.slow
def test_mesh_size_estimate_matches_meshes_it_was_not_fitted_to():
    from isj.fem.mesh import mesh_pedicle_joint
    from isj.fem.model import ElasticModel
    from isj.fem.sizing import MEASURED_TET_ERROR, estimate_mesh_size

    from isj.design import Geometry

    for geometry, resolution in (
        (Geometry(), 0.6),
        (Geometry(joint_x_m=450e-6, pedicle_length_m=400e-6), 0.5),
    ):
        mesh = mesh_pedicle_joint(geometry, resolution=resolution, cache_dir=False)
        n_tets, n_dofs, n_bytes = estimate_mesh_size(geometry, 1, resolution)
        assert abs(n_tets / mesh.n_tets - 1) < MEASURED_TET_ERROR + 0.05
        assert abs(n_dofs / ElasticModel(mesh, order=1).n_dofs - 1) < 0.25
        assert 4e3 * n_dofs < n_bytes < 2e4 * n_dofs  # P1 models measured 6.5–7.8 kB per dof
        t2, d2, b2 = estimate_mesh_size(geometry, 2, resolution)
        assert t2 == n_tets and 5 < d2 / n_dofs < 8 and b2 > n_bytes  # P2: ~6.5x the dofs


def test_an_over_large_mesh_is_refused_up_front_with_the_largest_resolution_that_fits():
    import re

    from isj.fem.sizing import check_mesh_size, estimate_mesh_size

    from isj.design import Geometry

    sizes = [estimate_mesh_size(order=2, resolution=r) for r in (0.5, 1.0, 2.0, 4.0)]
    assert all(a[k] < b[k] for a, b in zip(sizes, sizes[1:], strict=False) for k in range(3))
    big = Geometry(joint_x_m=2e-3, joint_y_m=2e-3, incus_x_m=2e-3, incus_y_m=2e-3)
    with pytest.raises(InvalidParameter) as err:
        check_mesh_size(big, 2, 50, max_bytes=4 * 2**30, name="--resolution")
    message = str(err.value)
    assert "\n" not in message and message.startswith("--resolution = 50: the P2 model would need about")
    largest = float(re.search(r"must be <= ([0-9.e+-]+) for this geometry", message).group(1))
    assert check_mesh_size(big, 2, largest * 0.999, max_bytes=4 * 2**30)[2] <= 4 * 2**30
    with pytest.raises(InvalidParameter):
        check_mesh_size(big, 2, largest * 1.02, max_bytes=4 * 2**30)
    assert check_mesh_size(order=2, resolution=1.0)[1] > 1e5  # the default mesh is accepted


def test_report_refuses_a_mesh_too_large_for_memory_before_computing(tmp_path, monkeypatch, capsys):
    from isj.cli import main

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "fe"))
    out = tmp_path / "out"
    # P2 at resolution 4: about 3 million dofs, tens of GB by the estimate
    assert main(["report", "--set", "mesh.resolution=4", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "mesh.resolution = 4" in err[0] and "must be <=" in err[0]
    assert not out.exists() and not (tmp_path / "fe").exists()


# ---------------------------------------------------------------- killed, concurrent and damaged runs
#
# Each long command is killed with SIGKILL (no handler runs), then run again: it must finish,
# redo nothing that was finished (the files of finished work keep their inode and mtime), and
# give what an uninterrupted run gives, bit for bit.

_SMALL_ROM = {"n_train": 64, "n_validate": 64, "max_snapshots": 12}  # a P1 coarse surrogate: seconds

_BUILD = textwrap.dedent(
    """
    import json, sys, time
    import isj.fem.rom.model as m
    from isj.fem.rom import reduced_model

    built = []
    build = m.build_reduced_model

    def announced(*a, **k):
        built.append(1)
        open(sys.argv[1], "w").close()  # 'building now'
        time.sleep(float(sys.argv[2]))  # long enough for a second process to arrive
        return build(*a, **k)

    m.build_reduced_model = announced
    rom = reduced_model(order=1, resolution=0.35, **json.loads(sys.argv[3]))
    print(json.dumps({"built": len(built), "u_g": rom.arrays["u_g"].tolist()}))
    """
)


def _files_state(folder) -> dict:
    """(inode, mtime) of every file below ``folder``: a file rewritten gets a new one."""
    return {
        str(p.relative_to(folder)): (p.stat().st_ino, p.stat().st_mtime_ns)
        for p in folder.rglob("*")
        if p.is_file()
    }


def _wait_for(predicate, proc, timeout_s: float = 600.0) -> None:
    import time

    t0 = time.monotonic()
    while not predicate():
        assert proc.poll() is None, f"finished (exit {proc.returncode}) before the point to kill it"
        assert time.monotonic() - t0 < timeout_s, "the point to kill it never came"
        time.sleep(0.05)


def _same_arrays(a: dict, b: dict) -> bool:
    import numpy as np

    return set(a) == set(b) and all(
        a[k].dtype == b[k].dtype and a[k].shape == b[k].shape and np.array_equal(a[k], b[k]) for k in a
    )


def _build_meta(rom) -> dict:
    return {
        k: v
        for k, v in rom.meta.items()
        if k not in ("build_time_s", "timings_s", "local_time_s", "resumed_snapshots")
    }


@pytest.mark.slow
def test_a_killed_rom_build_resumes_at_its_last_step_to_the_same_bits(tmp_path, monkeypatch):
    import json
    import signal

    import isj.fem.rom.offline as offline
    from isj.fem.rom import reduced_model, rom_cache_dir

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "clean"))
    clean = reduced_model(order=1, resolution=0.35, **_SMALL_ROM)
    assert not list(rom_cache_dir().glob("*.steps"))  # the steps go once the entry is stored
    n = clean.meta["n_snapshots"]
    assert n >= 8

    killed = tmp_path / "killed"
    script = _BUILD.replace("time.sleep(float(sys.argv[2]))", "pass")
    proc = subprocess.Popen(
        [sys.executable, "-c", script, str(tmp_path / "started"), "0", json.dumps(_SMALL_ROM)],
        env=dict(os.environ, ISJ_FE_CACHE_DIR=str(killed)),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    steps = killed / "rom"
    _wait_for(lambda: len(list(steps.glob("*.steps/step-*.npz"))) >= 5, proc)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    kept = len(list(steps.glob("*.steps/step-*.npz")))
    assert 5 <= kept < n and not list(steps.glob("rom-*.npz"))  # killed mid-greedy

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(killed))
    solved = []
    add = offline.Greedy.add_snapshot
    monkeypatch.setattr(offline.Greedy, "add_snapshot", lambda self, e: (solved.append(1), add(self, e))[1])
    again = reduced_model(order=1, resolution=0.35, **_SMALL_ROM)
    assert again.meta["resumed_snapshots"] == kept
    assert len(solved) == n - kept  # only the unfinished snapshots were solved
    assert _same_arrays(again.arrays, clean.arrays)
    assert _build_meta(again) == _build_meta(clean)
    assert not list(rom_cache_dir().glob("*.steps"))


@pytest.mark.slow
def test_damaged_or_stale_rom_build_steps_are_never_used(tmp_path, monkeypatch):
    import isj.fem.rom.offline as offline
    import numpy as np
    from isj.fem.rom import reduced_model, rom_cache_dir

    from isj.errors import CorruptCacheEntry

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "clean"))
    clean = reduced_model(order=1, resolution=0.35, **_SMALL_ROM)

    class Killed(BaseException):
        pass

    save = offline.GreedySteps.save

    def save_then_die(self, greedy, train, history):
        save(self, greedy, train, history)
        if len(greedy.snapshots) == 6:
            raise Killed

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "damaged"))
    monkeypatch.setattr(offline.GreedySteps, "save", save_then_die)
    with pytest.raises(Killed):
        reduced_model(order=1, resolution=0.35, **_SMALL_ROM)
    monkeypatch.setattr(offline.GreedySteps, "save", save)
    (folder,) = rom_cache_dir().glob("*.steps")
    files = sorted(folder.glob("step-*.npz"))
    assert len(files) == 6
    # step 4 damaged: steps 1-3 are taken, 4 reported and deleted, 5 and 6 (chained to it) dropped
    flip_a_stored_byte(files[3])
    with pytest.warns(CorruptCacheEntry, match=r"surrogate greedy step cache entry .*step-0004\.npz"):
        again = reduced_model(order=1, resolution=0.35, **_SMALL_ROM)
    assert again.meta["resumed_snapshots"] == 3
    assert _same_arrays(again.arrays, clean.arrays)

    # a step of another build in place of step 2: refused, and the build starts after step 1
    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "stale"))
    monkeypatch.setattr(offline.GreedySteps, "save", save_then_die)
    with pytest.raises(Killed):
        reduced_model(order=1, resolution=0.35, **(_SMALL_ROM | {"n_train": 32}))
    with pytest.raises(Killed):
        reduced_model(order=1, resolution=0.35, **_SMALL_ROM)
    monkeypatch.setattr(offline.GreedySteps, "save", save)
    (entry,) = (tmp_path / "clean" / "rom").glob("rom-*.npz")  # the same key names our steps
    ours = rom_cache_dir() / f"{entry.stem}.steps"
    (other,) = set(rom_cache_dir().glob("*.steps")) - {ours}
    (ours / "step-0002.npz").write_bytes((other / "step-0002.npz").read_bytes())
    with pytest.warns(CorruptCacheEntry, match="written by another build"):
        third = reduced_model(order=1, resolution=0.35, **_SMALL_ROM)
    assert third.meta["resumed_snapshots"] == 1
    assert np.array_equal(third.arrays["u_R"], clean.arrays["u_R"])


@pytest.mark.slow
def test_two_rom_builds_at_once_one_waits_and_loads_what_the_other_built(tmp_path):
    import json
    import time

    env = dict(os.environ, ISJ_FE_CACHE_DIR=str(tmp_path / "fe"))
    started = tmp_path / "started"
    settings = json.dumps(_SMALL_ROM)
    first = subprocess.Popen(
        [sys.executable, "-c", _BUILD, str(started), "3", settings],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    _wait_for(started.exists, first, timeout_s=300)
    # the second asks for the same surrogate while the first is building it (3 s of sleep, then the build)
    t0 = time.monotonic()
    second = subprocess.run(
        [sys.executable, "-c", _BUILD, str(tmp_path / "second"), "0", settings],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    waited = time.monotonic() - t0
    out_first, _ = first.communicate(timeout=600)
    assert first.returncode == 0 and second.returncode == 0, second.stderr[-2000:]
    a, b = json.loads(out_first), json.loads(second.stdout)
    assert (a["built"], b["built"]) == (1, 0)  # one build: the second waited and loaded it
    assert a["u_g"] == b["u_g"]
    assert not (tmp_path / "second").exists()
    assert waited > 1.0  # it did wait for the first (which slept 3 s before building)


_STAGE = textwrap.dedent(
    """
    import sys, time
    from isj.atomic import replace_dir

    with replace_dir(sys.argv[1]) as staging:
        (staging / "report.pdf").write_text("half")
        print(staging, flush=True)
        time.sleep(600)
    """
)


def test_a_killed_run_leaves_a_staging_folder_the_next_report_removes_and_a_live_one_it_keeps(
    tmp_path, monkeypatch
):
    import signal

    import isj.reports.run as run

    out = tmp_path / "R"
    procs = [
        subprocess.Popen([sys.executable, "-c", _STAGE, str(out)], stdout=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    try:
        dead, live = (Path(p.stdout.readline().strip()) for p in procs)
        procs[0].send_signal(signal.SIGKILL)
        procs[0].wait()
        assert dead.name.startswith(".R.") and dead.name.endswith(".partial") and dead.is_dir()
        assert live.is_dir()

        def fake_run(config, out_, staging, *a):
            (staging / "report.pdf").write_text("whole")
            return {"ok": True}

        monkeypatch.setattr(run, "_run", fake_run)
        assert run.run_report(_config(tmp_path), out, verbosity=0, calibration=object()) == {"ok": True}
        assert (out / "report.pdf").read_text() == "whole"
        assert not dead.exists()  # the killed run's folder is gone
        assert live.is_dir() and (live / "report.pdf").read_text() == "half"  # a live run's is not
        # an interrupted run (an exception) removes its own folder, and leaves R as it was
        monkeypatch.setattr(run, "_run", lambda *a: (_ for _ in ()).throw(KeyboardInterrupt))
        with pytest.raises(KeyboardInterrupt):
            run.run_report(_config(tmp_path), out, verbosity=0, calibration=object())
        assert (out / "report.pdf").read_text() == "whole"
        assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".R.")) == [live.name]
    finally:
        for p in procs:
            p.kill()
            p.wait()


@pytest.mark.parametrize("damage", ["directory", "truncated", "garbage", "directory for the arrays"])
def test_a_damaged_report_step_entry_is_reported_removed_and_recomputed(tmp_path, damage):
    import numpy as np
    from isj.reports.store import StepStore

    from isj.errors import CorruptCacheEntry

    store = StepStore(tmp_path)
    store.put("ear", "k1", {"x": 1.5}, {"a": np.arange(3.0)})
    jpath, npath = tmp_path / "ear-k1.json", tmp_path / "ear-k1.npz"
    if damage == "directory":
        jpath.unlink()
        (jpath / "inside").mkdir(parents=True)  # a folder, not empty, where the record belongs
    elif damage == "truncated":
        jpath.write_bytes(jpath.read_bytes()[:20])
    elif damage == "garbage":
        npath.write_bytes(b"\x00garbage" * 10)
    else:
        npath.unlink()
        npath.mkdir()
    with pytest.warns(CorruptCacheEntry, match="deleted, recomputing"):
        assert store.get("ear", "k1") is None
    assert not jpath.exists() and not npath.exists()  # files and folders alike
    store.put("ear", "k1", {"x": 2.5}, {"a": np.arange(4.0)})  # the recomputed step is stored
    result, arrays = store.get("ear", "k1")
    assert result == {"x": 2.5} and np.array_equal(arrays["a"], np.arange(4.0))


def _isj_run(args, env, **kw):
    return subprocess.run([sys.executable, "-m", "isj", *args], env=env, capture_output=True, text=True, **kw)


def _report_differences(a, b) -> list[str]:
    """The files in which the reports in folders ``a`` and ``b`` differ, run.json aside (timings).

    The PDF is compared when both were made at the same date and git revision (its pages say
    both): a commit between the runs changes its bytes, not its numbers.
    """
    import json

    fa, fb = (_snapshot(f) for f in (a, b))
    pa, pb = (json.loads((f / "run.json").read_text())["provenance"] for f in (a, b))
    skip = {"run.json"} | (
        {"report.pdf"} if (pa["date"], pa["git_revision"]) != (pb["date"], pb["git_revision"]) else set()
    )
    return sorted(k for k in set(fa) | set(fb) if k not in skip and fa.get(k) != fb.get(k))


@pytest.mark.slow
def test_a_killed_report_resumes_redoes_nothing_and_damaged_ear_entries_are_recomputed(
    tmp_path, cold_cli_report
):
    import json
    import shutil
    import signal

    # the uninterrupted run: tests/conftest.py's small report, cold, in a fresh process
    ref, case = cold_cli_report["dir"], cold_cli_report["case"]

    def env(name):
        return dict(
            os.environ, ISJ_FE_CACHE_DIR=str(tmp_path / name / "fe"), ISJ_CACHE_DIR=str(tmp_path / name / "m")
        )

    # killed (SIGKILL) once four steps are stored; meshes and FE results cold, the surrogate
    # taken from the cold run (tests/test_determinism.py's warm run checks it is read back whole)
    out, fe = tmp_path / "R", tmp_path / "b" / "fe"
    steps = fe / "report"
    shutil.copytree(cold_cli_report["caches"] / "fe" / "rom", fe / "rom")
    cmd = ["report", "--config", str(case), "--out", str(out), "-q"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "isj", *cmd],
        env=env("b"),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    _wait_for(lambda: len(list(steps.glob("[!.]*.json"))) >= 4, proc, timeout_s=3600)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not out.exists() and len(list(tmp_path.glob(".R.*.partial"))) == 1  # what the kill left
    finished = {p.name.split("-")[0] for p in steps.glob("[!.]*.json")}  # not a write cut short
    before = {k: v for k, v in _files_state(fe).items() if ".steps/" not in k}  # greedy steps are used up

    again = _isj_run(cmd, env("b"), timeout=3600)
    assert again.returncode == 0 and "Traceback" not in again.stderr, again.stderr[-3000:]
    after = _files_state(fe)
    assert {k: after.get(k) for k in before} == before  # nothing finished was redone
    assert finished <= set(json.loads((out / "run.json").read_text())["cached_steps"])
    assert not list(tmp_path.glob(".R.*"))  # the killed run's staging folder is gone
    assert _report_differences(ref, out) == []  # bit for bit

    # damage: the FE-ear entries (reductions, drum modes) and every mesh entry, three ways
    damaged = sorted(
        p for p in steps.iterdir() if p.name.split("-")[0] in ("ear", "transmission", "load_path")
    )
    meshes = sorted((tmp_path / "b" / "m").rglob("*.npz"))
    assert damaged and meshes
    for i, p in enumerate(damaged + meshes):
        if i % 3 == 0:
            p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])  # truncated
        elif i % 3 == 1:
            p.write_bytes(os.urandom(max(p.stat().st_size, 64)))  # random bytes
        else:
            p.unlink()
            (p / "x").mkdir(parents=True)  # a folder where the entry belongs
    third = _isj_run([c for c in cmd if c != "-q"], env("b"), timeout=3600)  # warnings shown
    assert third.returncode == 0 and "Traceback" not in third.stderr, third.stderr[-3000:]
    assert "deleted, recomputing" in third.stderr
    cached = set(json.loads((out / "run.json").read_text())["cached_steps"])
    assert not cached & {p.name.split("-")[0] for p in damaged} and "model" in cached
    assert _report_differences(ref, out) == []
    # every damaged step entry was read, so a folder standing where one belongs is gone; a mesh
    # entry is read only by a step that is recomputed, so a damaged one may wait for its next use
    assert not any(p.is_dir() for p in damaged)


#: The adaptive calibration that is killed, damaged and run twice at once below: P1 at resolution
#: 0.35, 16 designs, one round of 2.
_ADAPTIVE = ["calibrate", "--adaptive", "--samples", "16", "--validation", "0", "--modal-samples", "0"]
_ADAPTIVE += ["--order", "1", "--resolution", "0.35", "--rounds", "1", "--per-round", "2"]
_ADAPTIVE += ["--guard-sample", "64", "-q"]

# isj calibrate with ResultCache.put counted: each stored FE design's key, one line in argv[1]
# (the guard: the pool's spawned workers import this script too)
_COUNTED_CALIBRATE = textwrap.dedent(
    """
    import sys

    if __name__ == "__main__":
        import isj.calibration.runner as runner
        from isj.cli import main

        put = runner.ResultCache.put

        def counted(self, key, *a, **k):
            with open(sys.argv[1], "a") as f:
                f.write(key + "\\n")
            return put(self, key, *a, **k)

        runner.ResultCache.put = counted
        sys.exit(main(sys.argv[2:]))
    """
)


def _caches_env(folder) -> dict:
    return dict(os.environ, ISJ_FE_CACHE_DIR=str(folder / "fe"), ISJ_CACHE_DIR=str(folder / "m"))


def _leftovers(*folders) -> list[str]:
    """Temporary or partial entries below ``folders``: atomic writes' ``.name.*``, staging folders."""
    return sorted(
        str(p)
        for f in folders
        for p in Path(f).rglob("*")
        if p.name.startswith(".") or p.name.endswith((".partial", ".tmp", ".new", ".old", ".steps"))
    )


def _design_records(fe) -> list[Path]:
    """The FE design records of an FE cache (the surrogate and the report steps aside)."""
    return sorted(p for p in fe.rglob("*.json") if p.relative_to(fe).parts[0] not in ("rom", "report"))


@pytest.fixture(scope="module")
def adaptive_reference(tmp_path_factory):
    """:data:`_ADAPTIVE` run once, cold: ``artifact`` (its bytes) and ``caches`` (copy before use)."""
    tmp = tmp_path_factory.mktemp("adaptive")
    run = _isj_run([*_ADAPTIVE, "--out", str(tmp / "a.json")], _caches_env(tmp / "caches"), timeout=1800)
    assert run.returncode == 0, run.stderr[-3000:]
    return {"artifact": (tmp / "a.json").read_bytes(), "caches": tmp / "caches"}


@pytest.mark.slow
def test_a_killed_adaptive_calibration_resumes_redoes_nothing_and_writes_the_same_artifact(
    tmp_path, adaptive_reference
):
    import shutil
    import signal

    args = _ADAPTIVE

    def env(name):
        return _caches_env(tmp_path / name)

    # the surrogate is copied: its own kill is tested above; here the FE designs and the fits
    fe = tmp_path / "b" / "fe"
    shutil.copytree(adaptive_reference["caches"] / "fe" / "rom", fe / "rom")

    def records():
        return [p for p in fe.rglob("*.json") if p.relative_to(fe).parts[0] not in ("rom", "report")]

    cmd = [sys.executable, "-m", "isj", *args, "--out", str(tmp_path / "b.json")]
    proc = subprocess.Popen(cmd, env=env("b"), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _wait_for(lambda: len(records()) >= 8, proc, timeout_s=3600)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not (tmp_path / "b.json").exists()
    before = _files_state(fe)
    again = _isj_run([*args, "--out", str(tmp_path / "b.json")], env("b"))
    assert again.returncode == 0 and "Traceback" not in again.stderr, again.stderr[-3000:]
    after = _files_state(fe)
    assert {k: after.get(k) for k in before} == before  # no finished FE design was evaluated again
    assert len(after) > len(before)
    assert (tmp_path / "b.json").read_bytes() == adaptive_reference["artifact"]  # bit for bit


def test_written_files_have_the_mode_open_would_give(tmp_path):
    """Outputs are readable as the umask allows, not owner-only as their temporary files were."""
    import subprocess
    import sys

    code = (
        "import os, sys; os.umask(0o027)\n"
        "from isj.atomic import atomic_write_text\n"
        "p = atomic_write_text(sys.argv[1], 'x')\n"
        "print(oct(os.stat(p).st_mode & 0o777))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "a.txt")], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == oct(0o640)


# ---------------------------------------------------------------- adaptive calibration: damage, two at once


@pytest.mark.slow
def test_damaged_fe_design_records_are_reported_and_recomputed_by_the_adaptive_calibration(
    tmp_path, adaptive_reference
):
    import shutil

    from isj.cachefile import read_json_entry

    here = tmp_path / "b"
    shutil.copytree(adaptive_reference["caches"], here)
    fe = here / "fe"
    records = _design_records(fe)
    assert len(records) == 18  # 16 training designs and the round's 2
    kept = {p: p.read_bytes() for p in records}
    damaged = records[:3]
    damaged[0].write_bytes(kept[damaged[0]][: len(kept[damaged[0]]) // 2])  # truncated
    damaged[1].write_bytes(os.urandom(len(kept[damaged[1]])))  # garbage
    damaged[2].unlink()
    (damaged[2] / "x").mkdir(parents=True)  # a folder, not empty, where the record belongs
    before = {k: v for k, v in _files_state(fe).items() if not k.startswith(tuple(p.name for p in damaged))}

    again = _isj_run([*_ADAPTIVE, "--out", str(tmp_path / "b.json")], _caches_env(here), timeout=1800)
    assert again.returncode == 0 and "Traceback" not in again.stderr, again.stderr[-3000:]
    warned = [line for line in again.stderr.splitlines() if "deleted, recomputing" in line]
    assert sorted(w.split(" cache entry ")[1].split()[0] for w in warned) == sorted(map(str, damaged))
    assert all(w.startswith("isj: warning: FE result cache entry ") for w in warned)  # one line each
    after = _files_state(fe)
    assert {k: after.get(k) for k in before} == before  # the undamaged records were not rewritten
    for p in damaged:  # recomputed and stored again, bit for bit the records of the clean run
        assert p.is_file() and read_json_entry(p) is not None and p.read_bytes() == kept[p]
    assert (tmp_path / "b.json").read_bytes() == adaptive_reference["artifact"]  # bit for bit
    assert _leftovers(here) == []


@pytest.mark.slow
def test_two_adaptive_calibrations_at_once_on_one_fe_cache_write_the_same_artifact(
    tmp_path, adaptive_reference
):
    import shutil

    shared = tmp_path / "shared"
    # the surrogate is copied: two builds at once are tested above; here the FE designs
    shutil.copytree(adaptive_reference["caches"] / "fe" / "rom", shared / "fe" / "rom")
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _COUNTED_CALIBRATE, str(tmp_path / f"put-{i}")]
            + [*_ADAPTIVE, "--out", str(tmp_path / f"{i}.json")],
            env=_caches_env(shared),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for i in (1, 2)
    ]
    runs = [(p, *p.communicate(timeout=1800)) for p in procs]
    for p, _, err in runs:
        assert p.returncode == 0 and "Traceback" not in err, err[-3000:]
    first, second = ((tmp_path / f"{i}.json").read_bytes() for i in (1, 2))
    assert first == second == adaptive_reference["artifact"]  # bit for bit, and as a lone run's
    records = {p.stem for p in _design_records(shared / "fe")}
    assert records == {p.stem for p in _design_records(adaptive_reference["caches"] / "fe")}
    # a run that found every design already stored by the other stores none: it has no file
    put_files = [tmp_path / f"put-{i}" for i in (1, 2)]
    puts = [f.read_text().split() if f.exists() else [] for f in put_files]
    assert all(len(set(k)) == len(k) for k in puts)  # neither stored a design twice
    assert set(puts[0]) | set(puts[1]) == records  # every record was stored by one of them
    # Not asserted: the FE design records are not locked, so both runs usually evaluate every
    # design (18 stores each when measured; none, in one fresh-check, when the other run had
    # stored them all first); the stores are atomic and the results the same bits.
    assert _leftovers(shared) == []


# ---------------------------------------------------------------- reports: two at once


_SWAPS = textwrap.dedent(
    """
    import sys
    from isj.atomic import replace_dir

    for i in range(int(sys.argv[3])):
        with replace_dir(sys.argv[1]) as staging:
            (staging / "data").mkdir()
            (staging / "data" / "run.txt").write_text(f"{sys.argv[2]} {i}")
            (staging / "report.pdf").write_text(f"{sys.argv[2]} {i}")
    """
)


def test_runs_replacing_one_output_folder_at_once_all_succeed_and_leave_one_whole_folder(tmp_path):
    # two reports given one --out finish at about the same time; before the swap retried, 10 of
    # 600 swaps measured here ended in FileNotFoundError or "Directory not empty"
    out = tmp_path / "R"
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _SWAPS, str(out), tag, "300"], stderr=subprocess.PIPE, text=True
        )
        for tag in "abc"
    ]
    errors = [p.communicate(timeout=300)[1] for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], "\n".join(errors)[-3000:]
    pdf, data = (out / "report.pdf").read_text(), (out / "data" / "run.txt").read_text()
    assert pdf == data and pdf.split()[1] == "299"  # one run's folder, whole: the last swap of one
    assert sorted(p.name for p in tmp_path.iterdir()) == ["R"]  # no staging or set-aside folder


@pytest.mark.slow
def test_two_reports_at_once_on_shared_caches_agree_bit_for_bit_and_leave_nothing_partial(
    tmp_path, cold_cli_report
):
    import json
    import shutil

    ref, case = cold_cli_report["dir"], cold_cli_report["case"]
    shared = tmp_path / "caches"
    shutil.copytree(cold_cli_report["caches"], shared)
    # the cheaper steps are computed by both runs at once, the costly ones come from the cache
    redo = ("model", "cases", "trends", "convergence", "calibration", "sweep", "guard", "uq")
    steps = shared / "fe" / "report"
    for p in list(steps.iterdir()):
        if p.name.split("-")[0] in redo:
            p.unlink()
    kept = {p.name.split("-")[0] for p in steps.glob("*.json")}
    assert kept and not kept & set(redo)
    env = dict(os.environ, ISJ_FE_CACHE_DIR=str(shared / "fe"), ISJ_CACHE_DIR=str(shared / "meshes"))

    def at_once(*outs):
        procs = [
            subprocess.Popen(
                [sys.executable, "-m", "isj", "report", "--config", str(case), "--out", str(o), "-q"],
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                text=True,
            )
            for o in outs
        ]
        for p, err in [(p, p.communicate(timeout=3600)[1]) for p in procs]:
            assert p.returncode == 0 and "Traceback" not in err, err[-3000:]

    at_once(tmp_path / "A", tmp_path / "B")
    for name in ("A", "B"):
        assert _report_differences(ref, tmp_path / name) == []  # bit for bit the cold run's
        cached = set(json.loads((tmp_path / name / "run.json").read_text())["cached_steps"])
        assert cached >= kept  # what the cache held is taken from it
    # Not asserted: steps are not locked, so each removed step is computed by both runs unless
    # one stores it before the other starts it (measured: one run took 1, then 3, of the 8 from the other)
    assert _leftovers(shared, tmp_path / "A", tmp_path / "B") == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["A", "B", "caches"]

    # one --out for both: each ends without an error, the folder holds one whole report
    at_once(tmp_path / "S", tmp_path / "S")
    assert {"report.pdf", "run.json", "data/model.json"} <= set(_snapshot(tmp_path / "S"))
    assert _report_differences(ref, tmp_path / "S") == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["A", "B", "S", "caches"]  # no .S.* left
    assert _leftovers(shared, tmp_path / "S") == []
