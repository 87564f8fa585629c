"""Soak test of the main job: ``isj report`` again and again from empty caches, counting failures.

Run:  .venv/bin/python benchmarks/soak.py [--n 20] [--after-solve 2] [--coarse] [--keep]

Two kinds of run, each in fresh processes with its own empty mesh and FE
caches (``ISJ_CACHE_DIR``, ``ISJ_FE_CACHE_DIR``) and its own output folder:

- ``cold``: ``isj report --out DIR``, the README's main job, ``--n`` times;
- ``after-solve``: ``isj fem solve``, then ``isj report --out DIR``,
  ``--after-solve`` times. The joint mesh is then already cached when the
  report starts, and later steps still mesh (the cantilever): the sequence that
  crashed PARDISO with a SIGSEGV (exit 139) in 2 runs out of 2 before the
  solver's threads were pinned (``isj.fem.solvers``).

A run fails when a command exits non-zero or the report folder lacks
``report.pdf``. Each failure is printed with its exit code (a negative code,
or 128 + n, is signal n) and the last lines of its output; the summary is one
JSON line. The exit code is 1 if any run failed.

A cold report takes about 70 s on 2 shared cores, so ``--n 20`` takes about
half an hour; ``--coarse`` runs a small case (P2 at resolution 0.35, few
points, about 30 s) to check the soak itself.
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

# as tests/test_report.py's coarse case: every step runs, on a small mesh
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
"""


def _isj() -> list[str]:
    """The ``isj`` command of this interpreter's environment (``python -m isj`` if none)."""
    exe = Path(sys.executable).with_name("isj")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "isj"]


def run_once(kind: str, root: Path, coarse: bool) -> dict:
    """One soak run in ``root`` (its caches and report folder); returns its record."""
    env = dict(os.environ)
    env["ISJ_CACHE_DIR"] = str(root / "meshes")
    env["ISJ_FE_CACHE_DIR"] = str(root / "fe")
    report = [*_isj(), "report", "--out", str(root / "report"), "-q"]
    solve = [*_isj(), "fem", "solve"]
    if coarse:
        case = root / "case.toml"
        case.write_text(COARSE_CASE)
        report += ["--config", str(case)]
        solve += ["--order", "2", "--resolution", "0.35"]  # the report's joint mesh, cached by the solve
    commands = ([("fem solve", solve)] if kind == "after-solve" else []) + [("report", report)]
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
    ok = (root / "report" / "report.pdf").is_file()
    record = {"kind": kind, "ok": ok, "seconds": time.perf_counter() - t0}
    if not ok:
        record |= {"command": "report", "returncode": 0, "tail": ["exit 0 but no report.pdf"]}
    return record


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=20, help="cold reports (default 20)")
    p.add_argument("--after-solve", type=int, default=2, help="reports after isj fem solve (default 2)")
    p.add_argument("--coarse", action="store_true", help="a small case (30 s a report), not the defaults")
    p.add_argument("--keep", action="store_true", help="keep the runs' folders (printed), do not delete them")
    args = p.parse_args(argv)
    for name in ("n", "after_solve"):
        if not 0 <= getattr(args, name) <= 1000:
            p.error(f"--{name.replace('_', '-')} {getattr(args, name)}: must be an integer in [0, 1000]")
    kinds = ["cold"] * args.n + ["after-solve"] * args.after_solve
    if not kinds:
        p.error("--n and --after-solve are both 0: nothing to run")
    records = []
    top = tempfile.mkdtemp(prefix="isj-soak-")
    try:
        for i, kind in enumerate(kinds, 1):
            root = Path(top) / f"{i:03d}-{kind}"
            root.mkdir()
            rec = run_once(kind, root, args.coarse)
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
        "runs": len(records),
        "failures": len(failures),
        "by_kind": {k: sum(1 for r in failures if r["kind"] == k) for k in ("cold", "after-solve")},
        "exit_codes": sorted({r["returncode"] for r in failures}),
        "coarse": args.coarse,
        "mean_seconds": sum(r["seconds"] for r in records) / len(records),
    }
    print(json.dumps(summary))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
