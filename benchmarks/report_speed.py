"""The report's three timings: cold, warm, and after a one-modulus design change.

Runs ``isj report`` three times in a fresh, empty home and cache folder, as a new
user would, and prints each run's wall time, peak memory and each step's share:

1. cold: empty caches;
2. warm: the same command again;
3. changed: after the warm run, ``--set design.gap_e_pa=7e6`` (one modulus).

Usage::

    python benchmarks/report_speed.py [--config CASE.toml] [--site DIR] [--json OUT.json]

``--site`` puts another isj tree first on ``PYTHONPATH`` (an ``isj`` package folder
with ``fem``, ``lumped``, ... inside, as ``scripts/report_diff.py``'s notes describe),
to time the previous code the same way. Targets (issue 25, 2 quiet cores, default
mesh): cold ≤ 120 s, warm ≤ 5 s, changed ≤ 60 s, peak memory ≤ 3 GB.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHANGE = "design.gap_e_pa=7e6"

#: Runs its arguments and prints their peak resident set (kB) as the last line of stderr:
#: a fresh process per run, so each run's peak is its own.
_PEAK = (
    "import resource, subprocess, sys\n"
    "code = subprocess.run(sys.argv[1:]).returncode\n"
    "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr)\n"
    "sys.exit(code)\n"
)


def _run(label: str, args: list[str], env: dict[str, str], out: Path) -> dict:
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", _PEAK, sys.executable, "-m", "isj", "report", "--out", str(out), "-q", *args],
        env=env,
        capture_output=True,
        text=True,
    )
    wall_s = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{label} run failed (exit {proc.returncode}):\n{proc.stderr[-2000:]}")
    peak_kb = int(proc.stderr.strip().splitlines()[-1])
    run = json.loads((out / "run.json").read_text())
    return {
        "label": label,
        "wall_s": wall_s,
        "peak_rss_gb": peak_kb / 1024**2,
        "steps_s": run["timings_s"],
        "peak_gb_after_step": run.get("peak_memory_gb_after_step", {}),
        "cached_steps": run.get("cached_steps", []),
    }


def _print(result: dict) -> None:
    steps = result["steps_s"]
    # run.json's timings hold the steps and their "total": shares are of the total
    total = steps.get("total") or sum(steps.values()) or 1.0
    print(f"{result['label']}: {result['wall_s']:.1f} s wall, peak {result['peak_rss_gb']:.2f} GB")
    peak = result.get("peak_gb_after_step", {})
    for name, seconds in sorted(steps.items(), key=lambda kv: -kv[1]):
        mark = " (cached)" if name in result["cached_steps"] else ""
        after = f"  peak {peak[name]:.2f} GB after it" if name in peak else ""
        print(f"  {name:18s} {seconds:7.1f} s  {100 * seconds / total:5.1f} %{mark}{after}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, help="a case file (default: built-in defaults)")
    parser.add_argument("--site", type=Path, help="an isj tree to put first on PYTHONPATH")
    parser.add_argument("--json", type=Path, help="write the three results here")
    args = parser.parse_args(argv)

    with tempfile.TemporaryDirectory(prefix="isj-report-speed-") as tmp:
        tmp = Path(tmp)
        (tmp / "home").mkdir()
        env = dict(os.environ, HOME=str(tmp / "home"), MPLBACKEND="agg")
        for var in ("ISJ_CACHE_DIR", "ISJ_FE_CACHE_DIR", "ISJ_ROM_CACHE_DIR", "XDG_CACHE_HOME"):
            env.pop(var, None)
        if args.site:
            env["PYTHONPATH"] = str(args.site.resolve())
        base = ["--config", str(args.config.resolve())] if args.config else []
        results = [
            _run("cold", base, env, tmp / "cold"),
            _run("warm", base, env, tmp / "cold"),
            _run(f"changed ({CHANGE})", [*base, "--set", CHANGE], env, tmp / "changed"),
        ]
    for result in results:
        _print(result)
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
