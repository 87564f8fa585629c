"""The report's three timings: cold, warm, and after a one-modulus design change.

Runs ``isj report`` three times in a fresh, empty home and cache folder, as a new
user would, and prints each run's wall time, peak memory and each step's share:

1. cold: empty caches;
2. warm: the same command again;
3. changed: after the warm run, ``--set design.gap_e_pa=7e6`` (one modulus).

Usage::

    python benchmarks/report_speed.py [--config CASE.toml] [--site DIR] [--json OUT.json] [--keep DIR]

``--site`` puts another isj tree first on ``PYTHONPATH`` (an ``isj`` package folder
with ``fem``, ``lumped``, ... inside, as ``scripts/report_diff.py``'s notes describe),
to time the previous code the same way. Targets (issue 25, 2 quiet cores, default
mesh): cold ≤ 120 s, warm ≤ 5 s, changed ≤ 60 s, peak memory ≤ 3 GB.
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

CHANGE = "design.gap_e_pa=7e6"

#: Runs its arguments and prints, as the last line of stderr, the peak of the summed resident
#: set (kB) of the process and all of its descendants (gmsh or any other helper process too),
#: sampled every 50 ms from /proc, and the largest single process's peak (ru_maxrss), which
#: catches a peak shorter than a sample.
_PEAK = (
    "import os, resource, subprocess, sys, threading\n"
    "def tree_kb(root):\n"
    "    kids, rss = {}, {}\n"
    "    for pid in filter(str.isdigit, os.listdir('/proc')):\n"
    "        try:\n"
    "            text = open(f'/proc/{pid}/status').read()\n"
    "        except OSError:\n"
    "            continue\n"
    "        f = dict(l.split(':', 1) for l in text.splitlines() if ':' in l)\n"
    "        kids.setdefault(int(f['PPid']), []).append(int(pid))\n"
    "        rss[int(pid)] = int(f.get('VmRSS', '0 kB').split()[0])\n"
    "    todo, total = [root], 0\n"
    "    while todo:\n"
    "        pid = todo.pop()\n"
    "        total += rss.get(pid, 0)\n"
    "        todo += kids.get(pid, [])\n"
    "    return total\n"
    "proc = subprocess.Popen(sys.argv[1:])\n"
    "peak, done = [0], threading.Event()\n"
    "def sample():\n"
    "    while not done.wait(0.05):\n"
    "        peak[0] = max(peak[0], tree_kb(proc.pid))\n"
    "threading.Thread(target=sample, daemon=True).start()\n"
    "code = proc.wait()\n"
    "done.set()\n"
    "single = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss\n"
    "print(max(peak[0], single), single, file=sys.stderr)\n"
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
    peak_kb, single_kb = (int(v) for v in proc.stderr.strip().splitlines()[-1].split())
    run = json.loads((out / "run.json").read_text())
    return {
        "label": label,
        "wall_s": wall_s,
        "peak_rss_gb": peak_kb / 1024**2,  # all of the report's processes together
        "peak_rss_one_process_gb": single_kb / 1024**2,
        "steps_s": run["timings_s"],
        "peak_gb_after_step": run.get("peak_memory_gb_after_step", {}),
        "held_gb_after_step": run.get("memory_gb_after_step", {}),
        "cached_steps": run.get("cached_steps", []),
    }


def _print(result: dict) -> None:
    steps = result["steps_s"]
    # run.json's timings hold the steps and their "total": shares are of the total
    total = steps.get("total") or sum(steps.values()) or 1.0
    print(
        f"{result['label']}: {result['wall_s']:.1f} s wall, peak {result['peak_rss_gb']:.2f} GB "
        f"(all processes; the largest one {result['peak_rss_one_process_gb']:.2f} GB)"
    )
    peak = result.get("peak_gb_after_step", {})
    for name, seconds in sorted(steps.items(), key=lambda kv: -kv[1]):
        mark = " (cached)" if name in result["cached_steps"] else ""
        held = result.get("held_gb_after_step", {}).get(name)
        after = f"  peak {peak[name]:.2f} GB after it" if name in peak else ""
        after += f", {held:.2f} GB held" if held is not None else ""
        print(f"  {name:18s} {seconds:7.1f} s  {100 * seconds / total:5.1f} %{mark}{after}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, help="a case file (default: built-in defaults)")
    parser.add_argument("--site", type=Path, help="an isj tree to put first on PYTHONPATH")
    parser.add_argument("--json", type=Path, help="write the three results here")
    parser.add_argument("--keep", type=Path, help="copy the cold report's folder here (to compare outputs)")
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
        if args.keep:
            shutil.copytree(tmp / "cold", args.keep, dirs_exist_ok=True)
    for result in results:
        _print(result)
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
