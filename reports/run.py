"""``isj report``: run every step (cached), write the data files, then the PDF.

The output folder gets, each written atomically:

- ``report.pdf``;
- ``data/<step>.json`` (every number of a section) and ``data/*.csv`` (tables);
- ``resolved_config.toml``, ``run.json`` (versions, git revision, timings);
- ``base.vtu``, the base design for ParaView.

Bad configuration is rejected by :func:`reports.config.load_config` before
this module creates anything.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from isj.atomic import atomic_write_json, atomic_write_text
from isj.caches import fe_cache_dir

from .config import ReportConfig
from .steps import STEPS, Context, step_inputs
from .store import StepStore, default_cache_dir, step_key

_fe_cache_dir = fe_cache_dir  # the default FE result cache, shared with the CLI and the benchmarks


def load_calibration(config: ReportConfig):
    from isj.lumped.artifact import Calibration, default_calibration

    return Calibration.load(config.calibration.file) if config.calibration.file else default_calibration()


def run_report(
    config: ReportConfig, out_dir: str | Path, verbosity: int = 1, cache_dir=None, calibration=None
) -> dict:
    """Compute (or reuse) every step and write the report into ``out_dir``.

    Parameters
    ----------
    config : the resolved configuration
    out_dir : folder to write (created; existing files of a previous report are replaced)
    verbosity : 0 quiet, 1 one line per step and progress bars, 2 also timings and cache keys
    cache_dir : step cache (default ``$ISJ_FE_CACHE_DIR/report``)
    calibration : a loaded ``lumped.artifact.Calibration`` (default: as ``config.calibration.file`` says)

    Returns
    -------
    dict
        ``steps`` (name → result), ``arrays``, ``timings_s``, ``cached`` (step names), ``pages``,
        ``provenance``.
    """
    from . import csvdata, pdf

    out = Path(out_dir)
    t_start = time.perf_counter()

    def say(msg: str, level: int = 1) -> None:
        if verbosity >= level:
            print(msg, file=sys.stderr, flush=True)

    cal = calibration if calibration is not None else load_calibration(config)
    ctx = Context(config, cal, _fe_cache_dir(), progress=verbosity >= 1)
    store = StepStore(cache_dir or default_cache_dir())
    results, arrays, timings, cached = {}, {}, {}, []
    for i, (name, fn, sections) in enumerate(STEPS, 1):
        key = step_key(name, step_inputs(ctx, sections, fn))
        t0 = time.perf_counter()
        hit = store.get(name, key)
        if hit is None:
            say(f"[{i}/{len(STEPS)}] {name} ...")
            res, arr = fn(ctx)
            store.put(name, key, res, arr)
            # as the cache gives it back (sorted keys, JSON floats): a fresh run and a cached
            # one then lay out the same PDF, byte for byte
            res = json.loads(json.dumps(res, sort_keys=True))
        else:
            res, arr = hit
            cached.append(name)
        timings[name] = time.perf_counter() - t0
        say(
            f"[{i}/{len(STEPS)}] {name}: {'cached' if hit else 'done'} ({timings[name]:.1f} s)",
            1 if hit else 2,
        )
        say(f"        key {key}", 2)
        results[name], arrays[name] = res, arr
        atomic_write_json(out / "data" / f"{name}.json", res)
        for fname, text in csvdata.tables(name, res, arr).items():
            atomic_write_text(out / "data" / fname, text)

    t0 = time.perf_counter()
    vtu = out / "base.vtu"
    if not vtu.exists() or "model" not in cached:
        from .steps import write_base_vtu

        write_base_vtu(ctx, vtu)
    timings["vtu"] = time.perf_counter() - t0
    atomic_write_text(out / "resolved_config.toml", config.to_toml())
    from isj.provenance import git_revision, package_versions

    provenance = {
        "versions": package_versions(),
        "git_revision": git_revision(),
        "date": time.strftime("%Y-%m-%d"),
        "calibration": results["calibration"]["source"],
    }
    say("writing report.pdf ...")
    t0 = time.perf_counter()
    pages = pdf.write_report(out / "report.pdf", config, results, arrays, provenance)
    timings["pdf"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    atomic_write_json(
        out / "run.json",
        {"provenance": provenance, "timings_s": timings, "cached_steps": cached, "pages": pages},
    )
    say(f"wrote {out / 'report.pdf'} ({len(pages)} pages) in {timings['total']:.1f} s", 1)
    return {
        "steps": results,
        "arrays": arrays,
        "timings_s": timings,
        "cached": cached,
        "pages": pages,
        "provenance": provenance,
    }
