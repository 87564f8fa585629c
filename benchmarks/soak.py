"""Soak test of the main job: ``isj report`` again and again from empty caches, counting failures.

Run:  .venv/bin/python benchmarks/soak.py [--coarse 20] [--default 3] [--after-solve 0] [--keep]

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
  solver's threads were pinned (``isj.fem.solvers``).

A run fails when a command exits non-zero, the report folder lacks
``report.pdf``, or a staging folder (``.report.*``) is left beside it. Each
failure is printed with its exit code (a negative code, or 128 + n, is signal
n) and the last lines of its output; the summary is one JSON line with the
runs and failures per kind. The exit code is 1 if any run failed.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
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

KINDS = ("coarse", "default", "after-solve")


def _isj() -> list[str]:
    """The ``isj`` command of this interpreter's environment (``python -m isj`` if none)."""
    exe = Path(sys.executable).with_name("isj")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "isj"]


def run_once(kind: str, root: Path) -> dict:
    """One soak run in ``root`` (its caches and report folder); returns its record."""
    env = dict(os.environ)
    env["ISJ_CACHE_DIR"] = str(root / "meshes")
    env["ISJ_FE_CACHE_DIR"] = str(root / "fe")
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
            return {
                "kind": kind,
                "ok": False,
                "command": name,
                "returncode": done.returncode,
                "tail": tail,
                "seconds": time.perf_counter() - t0,
            }
    record = {"kind": kind, "ok": True, "seconds": time.perf_counter() - t0}
    left = sorted(p.name for p in root.glob(".report.*"))
    if not (root / "report" / "report.pdf").is_file():
        record |= {"ok": False, "command": "report", "returncode": 0, "tail": ["exit 0 but no report.pdf"]}
    elif left:
        record |= {"ok": False, "command": "report", "returncode": 0, "tail": [f"left {left[0]} beside it"]}
    return record


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--coarse", type=int, default=20, help="cold reports on the coarse mesh (default 20)")
    p.add_argument("--default", type=int, default=3, help="cold reports on the default mesh (default 3)")
    p.add_argument("--after-solve", type=int, default=0, help="reports after isj fem solve (default 0)")
    p.add_argument("--keep", action="store_true", help="keep the runs' folders (printed), do not delete them")
    args = p.parse_args(argv)
    counts = {"coarse": args.coarse, "default": args.default, "after-solve": args.after_solve}
    for name, n in counts.items():
        if not 0 <= n <= 1000:
            p.error(f"--{name} {n}: must be an integer in [0, 1000]")
    kinds = [k for k in KINDS for _ in range(counts[k])]
    if not kinds:
        p.error("--coarse, --default and --after-solve are all 0: nothing to run")
    records = []
    top = tempfile.mkdtemp(prefix="isj-soak-")
    try:
        for i, kind in enumerate(kinds, 1):
            root = Path(top) / f"{i:03d}-{kind}"
            root.mkdir()
            rec = run_once(kind, root)
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
