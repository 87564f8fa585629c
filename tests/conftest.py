"""Shared fixtures: a private mesh cache, one coarse model and one coarse report reused across tests.

Hard dependencies (gmsh, casadi, numpy, meshio, pypdf, scikit-fem) are imported
directly by the tests: a machine where one of them cannot load fails, it does
not report green with tests skipped. Only optional backends may skip; the run's
header lists which of them this machine has, and the summary which were skipped.
"""

import importlib.util
import json
import os
import subprocess
import sys

import pytest


def _share_the_cores_between_workers() -> None:
    """Under ``pytest -n N``, give each worker's solvers and BLAS its share of the cores.

    N workers each running the machine's full thread count would put N times as many threads
    to work as there are cores. Set before any test imports numpy; a value already set wins,
    and subprocesses inherit it.
    """
    workers = os.environ.get("PYTEST_XDIST_WORKER_COUNT")
    if not workers:
        return
    threads = str(max(1, len(os.sched_getaffinity(0)) // int(workers)))
    for name in ("ISJ_SOLVER_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ.setdefault(name, threads)


_share_the_cores_between_workers()

#: Optional backends: name → (what it is, is it importable here).
OPTIONAL_BACKENDS = {
    "pardiso": "PARDISO sparse solver (pypardiso; x86-64 only)",
    "cholmod": "CHOLMOD sparse solver (scikit-sparse)",
    "mumps": "MUMPS sparse solver (python-mumps)",
    "distributed": "Dask's distributed scheduler",
}


def _available() -> dict[str, bool]:
    from isj.fem.solvers import available_backends

    solvers = available_backends()
    return {
        "pardiso": "pardiso" in solvers,
        "cholmod": "cholmod" in solvers,
        "mumps": importlib.util.find_spec("mumps") is not None,
        "distributed": importlib.util.find_spec("distributed") is not None,
    }


def pytest_report_header(config):
    """One line: which optional backends this machine has (tests that need a missing one skip)."""
    have = _available()
    listed = ", ".join(f"{k} {'yes' if ok else 'NO'}" for k, ok in have.items())
    return [f"optional backends: {listed} (tests needing a missing one skip)"]


def pytest_terminal_summary(terminalreporter):
    """Name the optional backends whose tests were skipped, with how many tests each."""
    counts = dict.fromkeys(OPTIONAL_BACKENDS, 0)
    for rep in terminalreporter.stats.get("skipped", []):
        text = str(rep.longrepr).lower()
        for name in counts:
            if name in text:
                counts[name] += 1
    skipped = [f"{name} ({OPTIONAL_BACKENDS[name]}): {n} test(s)" for name, n in counts.items() if n]
    if skipped:
        terminalreporter.write_line("skipped for lack of an optional backend: " + "; ".join(skipped))


#: Fixtures so expensive that every test using one belongs to the slow tier: the first user
#: pays their cost, and the fast tier must not depend on which test that is.
SLOW_FIXTURES = frozenset({"report", "cold_cli_report", "coarse_fast_ear"})


#: The longest groups (measured with ``--durations``, docs/developer/index.md), sent to the
#: workers first: one started last would leave the other worker idle while it runs.
LONG_GROUPS = ("cold_cli_report", "test_reliability.py", "report", "coarse_fast_ear")


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook, which reads the groups
def pytest_collection_modifyitems(config, items):
    """Tests that use a :data:`SLOW_FIXTURES` fixture are marked slow (``-m "not slow"`` skips them).

    Each test also gets an ``xdist_group`` for ``pytest -n 2 --dist loadgroup`` (the README's
    test command): the :data:`SLOW_FIXTURES` fixture it uses, so that one worker makes that
    fixture and the other never does, or else its file, so that a module's fixtures are made
    once. A module whose fixtures are used both by users of a :data:`SLOW_FIXTURES` fixture
    and by other tests names its group itself (``pytestmark = pytest.mark.xdist_group(...)``).
    The :data:`LONG_GROUPS` come first (``--no-loadscope-reorder`` keeps this order).
    """
    group = {}
    for item in items:
        used = sorted(SLOW_FIXTURES.intersection(getattr(item, "fixturenames", ())))
        if used:
            item.add_marker(pytest.mark.slow)
        own = [m.args[0] for m in item.iter_markers("xdist_group")]  # a module's pytestmark
        group[item] = own[0] if own else used[0] if used else item.path.name
        if not own:
            item.add_marker(pytest.mark.xdist_group(group[item]))
    rank = {name: i for i, name in enumerate(LONG_GROUPS)}
    items.sort(key=lambda item: rank.get(group[item], len(rank)))


@pytest.fixture(scope="session", autouse=True)
def _private_mesh_cache(tmp_path_factory):
    """Keep the tests' meshes out of the user's cache (and start from an empty one)."""
    mp = pytest.MonkeyPatch()
    mp.setenv("ISJ_CACHE_DIR", str(tmp_path_factory.mktemp("mesh-cache")))
    yield
    mp.undo()


@pytest.fixture(scope="session")
def coarse_model():
    """A coarse P2 model (seconds to build): for properties that hold on any mesh."""
    from isj.fem.model import PedicleJointModel

    return PedicleJointModel(order=2, resolution=0.35)


@pytest.fixture(scope="session")
def coarse_ear(coarse_model):
    """The default FE ear with :func:`coarse_model` as its joint."""
    from isj.fem.ear.middle_ear import MiddleEarModel

    return MiddleEarModel(joint=coarse_model)


@pytest.fixture(scope="session")
def coarse_fast_ear(coarse_ear):
    """The fast ear of :func:`coarse_ear` with the default settings, built once for the session
    (tests/test_fast_ear.py checks it against the FE ear, tests/test_uq.py samples it)."""
    from isj.fem.ear.fast_ear import build_fast_ear

    return build_fast_ear(coarse_ear)


# ---- one coarse report, shared by tests/test_report.py and tests/test_cache_keys.py ----------------

#: The coarse report's configuration: P2 at resolution 0.35, few points per section.
COARSE_REPORT = {
    "mesh": {"order": 2, "resolution": 0.35},
    "trends": {"moduli": ["gap_e_pa", "pedicle_e_pa"], "n_lumped": 9, "fe_points": 2},
    "convergence": {"orders": [2], "directions": ["y"]},
    "calibration": {"check_samples": 2, "seed": 7},
    "sweep": {"n_freq": 20, "fe_checks": 1, "n_modes": 3},
    "transmission": {"n_freq": 40, "cases": ["p12"], "fe_checks": 1, "sliding_cases": ["p12"]},
    "uq": {"samples": 20000, "sobol_samples": 512, "bootstrap": 20},
    "sliding": {"joints": ["bonded", "sliding"]},
    "guard": {"dense_samples": 512, "fe_checks": 1},
}


def report_toml(cfg: dict) -> str:
    """A case file (TOML) for a configuration given as {section: {key: value}}."""
    out = []
    for section, values in cfg.items():
        out.append(f"[{section}]")
        for k, v in values.items():
            out.append(f"{k} = {json.dumps(v)}")
    return "\n".join(out) + "\n"


class _Interrupted(Exception):
    pass


@pytest.fixture(scope="session")
def report(tmp_path_factory):
    """Run the coarse report: interrupted at the ear, then again to the end, then once more.

    Returns ``dir`` (the output folder), ``case`` (its TOML), ``config``, ``fe_cache``
    (``$ISJ_FE_CACHE_DIR``: FE results, and the step cache in its ``report`` folder),
    the ``first`` and ``second`` complete runs' results, the PDF's bytes after the
    first, and whether a PDF existed after the interrupted run.
    """
    import isj.reports.run as run_mod
    from isj.reports.config import load_config

    tmp = tmp_path_factory.mktemp("report")
    mp = pytest.MonkeyPatch()
    mp.setenv("ISJ_FE_CACHE_DIR", str(tmp / "fe-cache"))
    case = tmp / "case.toml"
    case.write_text(report_toml(COARSE_REPORT))
    config = load_config(case)
    out = tmp / "out"

    def interrupted(ctx):
        raise _Interrupted

    original = run_mod.STEPS
    try:
        steps = tuple((n, interrupted if n == "ear" else f, s) for n, f, s in original)
        mp.setattr(run_mod, "STEPS", steps)
        with pytest.raises(_Interrupted):
            run_mod.run_report(config, out, verbosity=0)
        pdf_after_interrupt = (out / "report.pdf").exists()
        mp.setattr(run_mod, "STEPS", original)
        first = run_mod.run_report(config, out, verbosity=0)
        first_bytes = (out / "report.pdf").read_bytes()
        second = run_mod.run_report(config, out, verbosity=0)
    finally:
        mp.undo()  # this report's FE cache holds only while it runs: other tests keep their own
    return {
        "dir": out,
        "case": case,
        "config": config,
        "fe_cache": tmp / "fe-cache",
        "first": first,
        "second": second,
        "first_bytes": first_bytes,
        "pdf_after_interrupt": pdf_after_interrupt,
    }


# ---- one small report in a fresh process, shared by tests/test_determinism.py and test_reliability.py

#: As :data:`COARSE_REPORT`, smaller still: every step runs, in about half a minute.
SMALL_REPORT = {
    # a coarse drum too (0.25 mm, docs/ear.md 5.15): the [mesh] key reaches every FE ear
    "mesh": {"order": 2, "resolution": 0.35, "drum_mesh_size_m": 0.25e-3},
    "trends": {"moduli": ["gap_e_pa"], "n_lumped": 5, "fe_points": 1},
    "convergence": {"orders": [2], "directions": ["y"]},
    "calibration": {"check_samples": 1, "seed": 7},
    "sweep": {"n_freq": 10, "fe_checks": 1, "n_modes": 3},
    # one case: its FE reduction costs less than building the fast ear (the coarse report has it)
    "transmission": {
        "n_freq": 10,
        "cases": ["p12"],
        "fe_checks": 1,
        "sliding_cases": ["p12"],
        "cases_from": "fe",
    },
    "sliding": {"joints": ["bonded", "sliding"]},
    "guard": {"dense_samples": 64, "fe_checks": 1},
    "uq": {"samples": 2000, "sobol_samples": 64, "bootstrap": 10, "transmission_samples": 0},
}


def cache_env(folder) -> dict:
    """The environment of a run whose mesh and FE caches are ``folder/meshes`` and ``folder/fe``."""
    return dict(os.environ, ISJ_CACHE_DIR=str(folder / "meshes"), ISJ_FE_CACHE_DIR=str(folder / "fe"))


@pytest.fixture(scope="session")
def cold_cli_report(tmp_path_factory):
    """:data:`SMALL_REPORT` made once by ``isj report`` in a fresh process, with empty caches.

    The uninterrupted, cold reference that the determinism and the kill-and-resume tests
    compare their runs with, bit for bit. Returns ``case`` (its TOML: every run compared with
    it reads the same file), ``dir`` (the output folder) and ``caches`` (the folder that holds
    its ``meshes`` and ``fe`` caches; copy them before use, other tests read them).
    """
    tmp = tmp_path_factory.mktemp("cold-cli-report")
    case = tmp / "case.toml"
    case.write_text(report_toml(SMALL_REPORT))
    out = tmp / "out"
    run = subprocess.run(
        [sys.executable, "-m", "isj", "report", "--config", str(case), "--out", str(out), "-q"],
        env=cache_env(tmp / "caches"),
        capture_output=True,
        text=True,
        timeout=3600,
    )
    assert run.returncode == 0, f"exit {run.returncode}: {run.stderr[-3000:]}"
    return {"case": case, "dir": out, "caches": tmp / "caches"}
