"""Soak test of the main job: ``isj report`` again and again from empty caches, counting failures.

Run:  .venv/bin/python benchmarks/soak.py [--coarse 20] [--default 3] [--killed 0] [--after-solve 0] [--keep]

Three kinds of run, each in fresh processes with its own empty mesh and FE
caches (``ISJ_CACHE_DIR``, ``ISJ_FE_CACHE_DIR``) and its own output folder:

- ``coarse``: ``isj report --config CASE --out DIR`` on the coarse mesh of the
  tests (P2 at resolution 0.35, few points per section; the case of
  ``tests/conftest.py``), ``--coarse`` times;
- ``default``: ``isj report --out DIR``, the README's main job on the default
  mesh, ``--default`` times;
- ``after-solve``: ``isj fem solve``, then ``isj report --out DIR`` (default
  mesh), ``--after-solve`` times. The joint mesh is then already cached when
  the report starts, and later steps still mesh (the cantilever): the sequence
  that crashed PARDISO with a SIGSEGV (exit 139) in 2 runs out of 2 before the
  solver's threads were pinned (``isj.fem.solvers``);
- ``killed``: ``isj report --out DIR`` on the default mesh, killed (SIGKILL)
  ``--kill-after-s`` seconds after the step cache holds ``--kill-at-step``
  finished steps (by default 10: during the guard step, which keeps partial
  work), then run again, ``--killed`` times. It fails unless the rerun leaves
  every step entry stored before the kill untouched (same inode and mtime) and
  its report equals the first ``default`` run's, bit for bit (every file but
  ``run.json``, which holds timings; the PDF too when both runs are on one day).
  It needs ``--default 1`` or more, which run first.

A run fails when a command exits non-zero, the report folder lacks
``report.pdf``, or a staging folder (``.report.*``) is left beside it. Each
failure is printed with its exit code (a negative code, or 128 + n, is signal
n) and the last lines of its output; the summary is one JSON line with the
runs and failures per kind. The exit code is 1 if any run failed.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# the coarse case of tests/conftest.py (COARSE_REPORT): every step runs, on a small mesh
COARSE_CASE = """\
[mesh]
order = 2
resolution = 0.35
[trends]
moduli = ["gap_e_pa", "pedicle_e_pa"]
n_lumped = 9
fe_points = 2
[convergence]
orders = [2]
directions = ["y"]
[calibration]
check_samples = 2
seed = 7
[sweep]
n_freq = 20
fe_checks = 1
n_modes = 3
[transmission]
n_freq = 40
cases = ["p12"]
fe_checks = 1
sliding_cases = ["p12"]
[uq]
samples = 20000
sobol_samples = 512
bootstrap = 20
[sliding]
joints = ["bonded", "sliding"]
[guard]
dense_samples = 512
fe_checks = 1
"""

KINDS = ("default", "killed", "coarse", "after-solve")


def _isj() -> list[str]:
    """The ``isj`` command of this interpreter's environment (``python -m isj`` if none)."""
    exe = Path(sys.executable).with_name("isj")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "isj"]


def _env(root: Path) -> dict:
    """The environment of a run whose mesh and FE caches are in ``root``, empty at first."""
    return dict(os.environ, ISJ_CACHE_DIR=str(root / "meshes"), ISJ_FE_CACHE_DIR=str(root / "fe"))


def _failed(kind: str, command: str, returncode: int, tail: list[str], t0: float) -> dict:
    return {
        "kind": kind,
        "ok": False,
        "command": command,
        "returncode": returncode,
        "tail": tail,
        "seconds": time.perf_counter() - t0,
    }


def _report_checks(root: Path) -> list[str]:
    """What is wrong with the report folder ``root/report``: no PDF, or a staging folder left."""
    left = sorted(p.name for p in root.glob(".report.*"))
    if not (root / "report" / "report.pdf").is_file():
        return ["exit 0 but no report.pdf"]
    return [f"left {left[0]} beside it"] if left else []


def _files_state(folder: Path) -> dict[str, tuple[int, int]]:
    """(inode, mtime) of every file below ``folder``: a file rewritten gets a new pair."""
    return {
        str(p.relative_to(folder)): (p.stat().st_ino, p.stat().st_mtime_ns)
        for p in folder.rglob("*")
        if p.is_file()
    }


def _digests(folder: Path, with_pdf: bool) -> dict[str, str]:
    """SHA-256 of every file of a report folder but ``run.json`` (timings) and, unless asked, the PDF."""
    skip = {"run.json"} | (set() if with_pdf else {"report.pdf"})
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and str(p.relative_to(folder)) not in skip
    }


def _same_day(a: Path, b: Path) -> bool:
    """Whether two reports' provenance gives one date and revision (their PDFs then compare)."""
    pa, pb = (json.loads((f / "run.json").read_text())["provenance"] for f in (a, b))
    return (pa["date"], pa["git_revision"]) == (pb["date"], pb["git_revision"])


def run_killed(root: Path, reference: Path, at_step: int, after_s: float) -> dict:
    """A default-mesh report killed during its work, then run again to the end; its record."""
    t0 = time.perf_counter()
    env, steps = _env(root), root / "fe" / "report"
    command = [*_isj(), "report", "--out", str(root / "report"), "-q"]
    proc = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    while len(list(steps.glob("[!.]*.json"))) < at_step:
        if proc.poll() is not None:
            return _failed(
                "killed", "report (to kill)", proc.returncode, ["ended before the point to kill it"], t0
            )
        time.sleep(0.2)
    time.sleep(after_s)
    if proc.poll() is not None:
        return _failed("killed", "report (to kill)", proc.returncode, ["ended before it was killed"], t0)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    finished = sorted(p.name.split("-")[0] for p in steps.glob("[!.]*.json"))
    # a greedy step's partial work (``.steps/``) is used up by the rerun, so it is not compared
    before = {k: v for k, v in _files_state(root / "fe").items() if ".steps/" not in k}
    done = subprocess.run(command, env=env, capture_output=True, text=True)
    if done.returncode != 0 or "Traceback" in done.stderr:
        tail = (done.stdout + done.stderr).strip().splitlines()[-8:]
        return _failed("killed", "report (rerun)", done.returncode, tail, t0)
    after = _files_state(root / "fe")
    problems = _report_checks(root)
    redone = sorted(k for k, v in before.items() if after.get(k) != v)
    if redone:
        problems.append(f"{len(redone)} finished entries rewritten, e.g. {redone[0]}")
    with_pdf = _same_day(reference, root / "report")
    ref, got = _digests(reference, with_pdf), _digests(root / "report", with_pdf)
    differ = sorted(k for k in set(ref) | set(got) if ref.get(k) != got.get(k))
    if differ:
        problems.append(f"differs from the uninterrupted report in {len(differ)} files, e.g. {differ[0]}")
    record = {"kind": "killed", "ok": not problems, "seconds": time.perf_counter() - t0}
    record |= {"finished_before_kill": finished, "compared_files": len(ref), "pdf_compared": with_pdf}
    if problems:
        record |= {"command": "report (rerun)", "returncode": 0, "tail": problems}
    return record


def run_once(kind: str, root: Path) -> dict:
    """One soak run in ``root`` (its caches and report folder); returns its record."""
    env = _env(root)
    report = [*_isj(), "report", "--out", str(root / "report"), "-q"]
    if kind == "coarse":
        case = root / "case.toml"
        case.write_text(COARSE_CASE)
        report += ["--config", str(case)]
    commands = ([("fem solve", [*_isj(), "fem", "solve"])] if kind == "after-solve" else []) + [
        ("report", report)
    ]
    t0 = time.perf_counter()
    for name, command in commands:
        done = subprocess.run(command, env=env, capture_output=True, text=True)
        if done.returncode != 0:
            tail = (done.stdout + done.stderr).strip().splitlines()[-8:]
            return _failed(kind, name, done.returncode, tail, t0)
    record = {"kind": kind, "ok": True, "seconds": time.perf_counter() - t0}
    problems = _report_checks(root)
    if problems:
        record |= {"ok": False, "command": "report", "returncode": 0, "tail": problems}
    return record


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--coarse", type=int, default=20, help="cold reports on the coarse mesh (default 20)")
    p.add_argument("--default", type=int, default=3, help="cold reports on the default mesh (default 3)")
    p.add_argument("--killed", type=int, default=0, help="default-mesh reports killed and rerun (default 0)")
    p.add_argument("--kill-at-step", type=int, default=10, help="finished steps before the kill (default 10)")
    p.add_argument("--kill-after-s", type=float, default=30.0, help="seconds after those steps (default 30)")
    p.add_argument("--after-solve", type=int, default=0, help="reports after isj fem solve (default 0)")
    p.add_argument("--keep", action="store_true", help="keep the runs' folders (printed), do not delete them")
    args = p.parse_args(argv)
    counts = {
        "default": args.default,
        "killed": args.killed,
        "coarse": args.coarse,
        "after-solve": args.after_solve,
    }
    for name, n in counts.items():
        if not 0 <= n <= 1000:
            p.error(f"--{name} {n}: must be an integer in [0, 1000]")
    if args.killed and not args.default:
        p.error("--killed needs --default 1 or more: its reports are compared with the first default one")
    if not 1 <= args.kill_at_step <= 12:
        p.error(
            f"--kill-at-step {args.kill_at_step}: must be an integer in [1, 12] (the report has 13 steps)"
        )
    if not 0 <= args.kill_after_s <= 3600:
        p.error(f"--kill-after-s {args.kill_after_s}: must be in [0, 3600]")
    kinds = [k for k in KINDS for _ in range(counts[k])]
    if not kinds:
        p.error("--coarse, --default and --after-solve are all 0: nothing to run")
    records, reference = [], None
    top = tempfile.mkdtemp(prefix="isj-soak-")
    try:
        for i, kind in enumerate(kinds, 1):
            root = Path(top) / f"{i:03d}-{kind}"
            root.mkdir()
            if kind == "killed" and reference is None:
                rec = _failed(
                    kind,
                    "report",
                    0,
                    ["the first default run failed: nothing to compare with"],
                    time.perf_counter(),
                )
            elif kind == "killed":
                rec = run_killed(root, reference, args.kill_at_step, args.kill_after_s)
            else:
                rec = run_once(kind, root)
            if kind == "default" and i == 1 and rec["ok"]:
                reference = root / "report"
            records.append(rec)
            status = "ok" if rec["ok"] else f"FAILED ({rec['command']}: exit {rec['returncode']})"
            print(f"[{i}/{len(kinds)}] {kind}: {status} in {rec['seconds']:.0f} s", flush=True)
            if not rec["ok"]:
                for line in rec["tail"]:
                    print(f"    {line}", flush=True)
    finally:
        if args.keep:
            print(f"runs kept in {top}")
        else:
            shutil.rmtree(top, ignore_errors=True)
    failures = [r for r in records if not r["ok"]]
    summary = {
        "runs": {k: sum(1 for r in records if r["kind"] == k) for k in KINDS},
        "failures": {k: sum(1 for r in failures if r["kind"] == k) for k in KINDS},
        "exit_codes": sorted({r["returncode"] for r in failures}),
        "mean_seconds": {
            k: sum(r["seconds"] for r in records if r["kind"] == k) / max(1, counts[k])
            for k in KINDS
            if counts[k]
        },
    }
    print(json.dumps(summary))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
