"""The geometry calibration's FE designs on a real Dask cluster: a scheduler and two workers,
each a separate process started with Dask's own command line (``dask scheduler``,
``dask worker``) on loopback, free ports, torn down at the end.

One run of nine P1 designs (three geometries × three moduli sets, coarse mesh) shows that

- the cluster's records equal, bit for bit, those of the local process pool;
- a worker killed (SIGKILL) mid-run costs only the design it was solving: the designs it had
  finished are in the cache and are not solved again when the scheduler gives its group to
  another worker. Solves are counted by an evaluator that logs each start and end with its pid.
"""

from __future__ import annotations

import functools
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

import pytest

pytest.importorskip("distributed")

from isj.calibration.runner import design_key, run_geometry_designs  # noqa: E402
from isj.fem.batch import evaluate_design, fe_settings  # noqa: E402

pytestmark = pytest.mark.slow  # a Dask cluster of subprocesses

#: Seconds allowed for the cluster to start, and for the whole Dask run.
START_TIMEOUT_S = 90
RUN_TIMEOUT_S = 300
#: Pause after each logged start, before the solve: the kill's window (a P1 solve takes ~0.1 s).
DELAY_S = 1.0

GEOMETRIES = [
    {"pedicle_x_m": 45e-6},
    {"pedicle_x_m": 65e-6, "gap_thickness_m": 30e-6},
    {"plate_thickness_m": 70e-6},
]
MODULI = [{"gap_e_pa": 5e7}, {"gap_e_pa": 2e8, "pedicle_e_pa": 4e9}, {"capsule_e_pa": 3e6}]
ITEMS = [(m, g) for g in GEOMETRIES for m in MODULI]


def counted_evaluate(log_path: str, delay_s: float, design: dict, settings: dict) -> dict:
    """:func:`evaluate_design`, logging ``start``/``end`` with this process's pid and the design's key."""
    tag = f"{os.getpid()} {design_key(design, settings)}"
    with open(log_path, "a") as f:  # one short O_APPEND write per line: whole lines
        f.write(f"start {tag}\n")
    time.sleep(delay_s)
    result = evaluate_design(design, settings)
    with open(log_path, "a") as f:
        f.write(f"end {tag}\n")
    return result


def _log(path: Path) -> list[tuple[str, int, str]]:
    if not path.exists():
        return []
    return [(e, int(p), k) for e, p, k in (line.split() for line in path.read_text().splitlines())]


def _dask(*args) -> list[str]:
    exe = Path(sys.executable).with_name("dask")
    return [str(exe), *args] if exe.exists() else [sys.executable, "-m", "dask", *args]


@pytest.fixture
def cluster(tmp_path):
    """``(address, procs)``: ``dask scheduler`` and two ``dask worker`` (one thread each, default nanny)."""
    env = dict(os.environ)
    # workers import this module to unpickle counted_evaluate
    env["PYTHONPATH"] = os.pathsep.join([str(Path(__file__).parent), env.get("PYTHONPATH", "")])
    sched_file = tmp_path / "scheduler.json"
    logs = tmp_path / "cluster-logs"
    logs.mkdir()
    procs: list[subprocess.Popen] = []

    def start(name, args):
        out = open(logs / f"{name}.log", "w")  # noqa: SIM115 - closed with the process
        p = subprocess.Popen(
            args, env=env, cwd=tmp_path, stdout=out, stderr=subprocess.STDOUT, start_new_session=True
        )
        procs.append(p)
        return p

    try:
        start(
            "scheduler",
            _dask(
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(sched_file),
            ),
        )
        deadline = time.monotonic() + START_TIMEOUT_S
        while not sched_file.exists() or not sched_file.read_text().strip():
            assert time.monotonic() < deadline, "dask scheduler did not start"
            assert procs[0].poll() is None, (logs / "scheduler.log").read_text()
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        for i in range(2):
            start(
                f"worker{i}",
                _dask(
                    "worker",
                    address,
                    "--nthreads",
                    "1",
                    "--no-dashboard",
                    "--host",
                    "127.0.0.1",
                    "--name",
                    f"w{i}",
                ),
            )
        from distributed import Client

        with Client(address, timeout=START_TIMEOUT_S) as client:
            client.wait_for_workers(2, timeout=START_TIMEOUT_S)
        yield address, procs
    finally:
        for p in reversed(procs):  # workers first, then the scheduler; each its own process group
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(timeout=10)


def test_cluster_matches_local_pool_and_a_killed_worker_costs_only_its_unfinished_design(
    tmp_path, cluster, monkeypatch
):
    address, procs = cluster
    # PARDISO's last bits follow its thread count (fem/solvers.py): the same count on both sides
    monkeypatch.setenv("ISJ_SOLVER_THREADS", "1")
    settings = fe_settings(order=1, resolution=0.25)
    t0 = time.perf_counter()
    local = run_geometry_designs(
        ITEMS, evaluate_design, settings, tmp_path / "pool", max_workers=1, progress=False
    )
    t_pool = time.perf_counter() - t0

    log = tmp_path / "solves.log"
    evaluate = functools.partial(counted_evaluate, str(log), DELAY_S)
    killed: list[tuple[int, str]] = []  # (pid, key of the design it was solving)
    outcome: dict = {}

    def run():
        try:
            outcome["records"] = run_geometry_designs(
                ITEMS, evaluate, settings, tmp_path / "dask", scheduler=address, progress=False
            )
        except BaseException as exc:  # reported by the main thread
            outcome["error"] = exc

    t0 = time.perf_counter()
    runner = threading.Thread(target=run, daemon=True)
    runner.start()
    deadline = time.monotonic() + RUN_TIMEOUT_S
    while runner.is_alive() and time.monotonic() < deadline:
        if not killed:
            # a worker that has finished a design and started another: kill it mid-group
            ended = {p for e, p, _ in _log(log) if e == "end"}
            running = Counter((p, k) for e, p, k in _log(log) if e == "start")
            running.subtract((p, k) for e, p, k in _log(log) if e == "end")
            for (pid, key), n in running.items():
                if n > 0 and pid in ended:
                    os.kill(pid, signal.SIGKILL)
                    killed.append((pid, key))
                    break
        time.sleep(0.02)
    runner.join(timeout=1)
    t_dask = time.perf_counter() - t0
    assert not runner.is_alive(), f"the Dask run took over {RUN_TIMEOUT_S} s"
    assert "error" not in outcome, outcome.get("error")
    assert len(killed) == 1, "no worker was caught between two designs of its group"

    # (a) bit for bit: every record (design, settings, key, result floats) equals the pool's
    assert outcome["records"] == local
    # (b) solves: each design finished exactly once; the killed worker's unfinished design was
    # started twice, every other design once; none its worker had finished was solved again
    events = _log(log)
    starts = Counter(k for e, _, k in events if e == "start")
    ends = Counter(k for e, _, k in events if e == "end")
    keys = {r["key"] for r in local}
    pid, lost = killed[0]
    assert set(ends) == keys and set(ends.values()) == {1}
    assert starts == Counter({k: 1 + (k == lost) for k in keys})
    finished_by_killed = {k for e, p, k in events if e == "end" and p == pid}
    assert finished_by_killed and all(starts[k] == 1 for k in finished_by_killed)
    assert sum(starts.values()) == len(ITEMS) + 1

    # resuming the finished run solves nothing
    again = run_geometry_designs(
        ITEMS, evaluate, settings, tmp_path / "dask", scheduler=address, progress=False
    )
    assert again == local and len(_log(log)) == len(events)
    print(
        f"\n{len(ITEMS)} designs: pool {t_pool:.1f} s, cluster {t_dask:.1f} s with one worker killed, "
        f"{sum(starts.values())} solves"
    )
