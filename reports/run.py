"""``isj report``: run every step (cached), write the data files, then the PDF.

The report is written into a temporary sibling folder (``.<name>.<random>.partial``)
and moved into place only when it is complete, so a folder named by ``--out``
holds one whole report or the previous one, never a mix of two configurations
(an interrupted run leaves the previous report untouched; the step cache lets
the next run start again at the first unfinished step, and removes the folder
a killed run left, :func:`isj.atomic.replace_dir`). The output folder gets:

- ``report.pdf``;
- ``data/<step>.json`` (every number of a section) and ``data/*.csv`` (tables);
- ``resolved_config.toml``, ``run.json`` (versions, git revision, timings, what the PDF was
  made from: a rerun with the same inputs into the same folder keeps the PDF, bit for bit);
- ``base.vtu``, the base design for ParaView.

Bad configuration is rejected by :func:`reports.config.load_config` before
this module creates anything; so is an output folder that holds anything but
a previous report (:func:`check_out_dir`), since it is replaced as a whole, and
a geometry and mesh whose model would not fit in memory
(:func:`isj.fem.sizing.check_mesh_size`).
"""

from __future__ import annotations

import hashlib
import json
import os
import resource
import shutil
import sys
import time
from pathlib import Path

from isj.atomic import atomic_write_json, atomic_write_text, check_out_folder, replace_dir
from isj.cachefile import canonical_json
from isj.caches import fe_cache_dir

from .config import ReportConfig
from .steps import STEPS, Context, step_inputs
from .store import StepStore, default_cache_dir, step_key

_fe_cache_dir = fe_cache_dir  # the default FE result cache, shared with the CLI and the benchmarks

#: What a report folder holds; an existing ``--out`` folder with anything else is refused.
REPORT_ENTRIES = frozenset({"report.pdf", "data", "resolved_config.toml", "run.json", "base.vtu"})


def check_out_dir(out_dir: str | os.PathLike, name: str = "out_dir") -> Path:
    """The output folder as an absolute path, if a finished report may replace it.

    It may be new, empty, or a previous report (only :data:`REPORT_ENTRIES`): the
    report replaces the whole folder, so a folder with other files, a file, a
    symbolic link, or the current folder (or one above it) is refused, and so is
    a place where no folder can be created (:func:`isj.atomic.check_out_folder`).

    Parameters
    ----------
    out_dir : the folder
    name : what to call it in the message (``"--out"`` on the command line)

    Raises
    ------
    InvalidParameter
        One line naming ``name`` and what the folder must be.
    """
    return check_out_folder(out_dir, name, REPORT_ENTRIES, written_by="isj report")


def _link_or_copy(source: Path, target: Path) -> None:
    """A previous report's file into the new one: a hard link (the old folder keeps its own name
    for it), or a copy where links cannot be made."""
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)


def _reuse_vtu(out: Path, model_key: str, target: Path) -> bool:
    """Link the previous report's ``base.vtu`` into ``target`` if it came from the same model step."""
    try:
        previous = json.loads((out / "run.json").read_text())
        if previous.get("step_keys", {}).get("model") != model_key or not (out / "base.vtu").is_file():
            return False
        _link_or_copy(out / "base.vtu", target)
        return True
    except (OSError, ValueError, AttributeError):
        return False


def _pdf_key(config: ReportConfig, step_keys: dict, provenance: dict) -> str:
    """What the PDF is made from: every step's key, the resolved configuration (page 1 prints
    it), the provenance (versions, git revision, date: the pages' footers print them) and the
    text of this package's modules, which lay out the pages."""
    h = hashlib.sha256(canonical_json([step_keys, config.to_toml(), provenance]).encode())
    for path in sorted(Path(__file__).resolve().parent.glob("*.py")):
        h.update(path.name.encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:24]


def _file_sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _reuse_pdf(out: Path, pdf_key: str, target: Path) -> list[str] | None:
    """Link the previous report's PDF into ``target`` if it was made from the same inputs and is
    whole (its sha256 as recorded); returns its page titles, or None to lay the PDF out again."""
    try:
        previous = json.loads((out / "run.json").read_text())
        pdf = previous.get("pdf", {})
        if pdf.get("key") != pdf_key or _file_sha256(out / "report.pdf") != pdf.get("sha256"):
            return None
        _link_or_copy(out / "report.pdf", target)
        return list(previous["pages"])
    except (OSError, ValueError, AttributeError, KeyError, TypeError):
        return None


def load_calibration(config: ReportConfig):
    from isj.lumped.artifact import Calibration, default_calibration

    return Calibration.load(config.calibration.file) if config.calibration.file else default_calibration()


def run_report(
    config: ReportConfig,
    out_dir: str | Path,
    verbosity: int = 1,
    cache_dir=None,
    calibration=None,
    out_name: str = "out_dir",
) -> dict:
    """Compute (or reuse) every step and write the report into ``out_dir``.

    Parameters
    ----------
    config : the resolved configuration
    out_dir : folder to write: new, empty, or a previous report, which is replaced as a whole
        once the new one is complete (see :func:`check_out_dir`)
    verbosity : 0 quiet, 1 one line per step and progress bars, 2 also timings and cache keys
    cache_dir : step cache (default ``$ISJ_FE_CACHE_DIR/report``)
    calibration : a loaded ``lumped.artifact.Calibration`` (default: as ``config.calibration.file`` says)
    out_name : what to call ``out_dir`` in messages (``"--out"`` on the command line)

    Returns
    -------
    dict
        ``steps`` (name → result), ``arrays``, ``timings_s``, ``cached`` (step names), ``pages``,
        ``provenance``.
    """
    out = check_out_dir(out_dir, out_name)
    from isj.fem.sizing import check_mesh_size

    # before anything is computed: a geometry and resolution whose model would not fit in memory
    check_mesh_size(config.geometry, config.mesh.order, config.mesh.resolution, name="mesh.resolution")
    t_start = time.perf_counter()
    cal = calibration if calibration is not None else load_calibration(config)
    # staging folders a killed run left beside the output are removed here (isj.atomic.replace_dir)
    with replace_dir(out, out_name) as staging:
        summary = _run(config, out, staging, verbosity, cache_dir, cal, t_start)
    return summary


def _peak_memory_gb() -> float:
    """This process's peak resident memory so far (GB; ``ru_maxrss`` is in KiB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2


def _memory_gb() -> float | None:
    """This process's resident memory now (GB), from ``/proc/self/statm``; None without it."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except (OSError, IndexError, ValueError):
        return None
    return pages * os.sysconf("SC_PAGE_SIZE") / 1024**3


def _compute_steps(ctx: Context, store: StepStore, out: Path, say) -> dict:
    """Each step from the step cache or computed and stored, its data files written into ``out``:
    results, arrays, keys, timings, the cached steps and the memory after each step."""
    from isj.fem.mesh_ahead import meshes_ahead

    from .geometry import geometry_trend_geometries

    run = {"results": {}, "arrays": {}, "timings": {}, "cached": [], "keys": {}, "peak": {}, "held": {}}
    # the geometry trends' new meshes (gmsh, one thread) are made by a second process while the
    # steps before them solve; none is started when the mesh cache holds them all
    with meshes_ahead(geometry_trend_geometries(ctx), ctx.config.mesh.resolution):
        for i, step in enumerate(STEPS, 1):
            _compute_step(ctx, store, out, say, run, i, step)
    return run


def _compute_step(ctx: Context, store: StepStore, out: Path, say, run: dict, i: int, step: tuple) -> None:
    """Step ``i`` of :data:`STEPS`, ``step`` = (name, function, sections), from the step cache or
    computed and stored, into ``run`` and its data files into ``out``."""
    from . import csvdata

    name, fn, sections = step
    key = run["keys"][name] = step_key(name, step_inputs(ctx, sections, fn))
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
        run["cached"].append(name)
    seconds = run["timings"][name] = time.perf_counter() - t0
    run["peak"][name] = _peak_memory_gb()
    run["held"][name] = _memory_gb()
    say(f"[{i}/{len(STEPS)}] {name}: {'cached' if hit else 'done'} ({seconds:.1f} s)", 1 if hit else 2)
    say(f"        key {key}", 2)
    run["results"][name], run["arrays"][name] = res, arr
    atomic_write_json(out / "data" / f"{name}.json", res)
    for fname, text in csvdata.tables(name, res, arr).items():
        atomic_write_text(out / "data" / fname, text)


def _write_pdf(config: ReportConfig, run: dict, provenance: dict, final: Path, out: Path, say) -> dict:
    """``out/report.pdf``: the previous report's when made from the same inputs, else laid out;
    what run.json records of it, and its pages."""
    from . import pdf

    pdf_key = _pdf_key(config, run["keys"], provenance)
    pages = _reuse_pdf(final, pdf_key, out / "report.pdf")  # a warm rerun: the same bytes
    reused = pages is not None
    if not reused:
        say("writing report.pdf ...")
        pages = pdf.write_report(
            out / "report.pdf", config, run["results"], run["arrays"], provenance, say=say
        )
    return {"key": pdf_key, "sha256": _file_sha256(out / "report.pdf"), "reused": reused, "pages": pages}


def _run(config: ReportConfig, out: Path, staging: Path, verbosity: int, cache_dir, cal, t_start) -> dict:
    """Every step, the data files and the PDF, written into ``staging`` (``out`` is only read)."""
    from isj.provenance import git_revision, package_versions

    final, out = out, staging

    def say(msg: str, level: int = 1) -> None:
        if verbosity >= level:
            print(msg, file=sys.stderr, flush=True)

    ctx = Context(config, cal, _fe_cache_dir(), progress=verbosity >= 1)
    run = _compute_steps(ctx, StepStore(cache_dir or default_cache_dir()), out, say)
    timings = run["timings"]
    t0 = time.perf_counter()
    vtu = out / "base.vtu"
    if "model" not in run["cached"] or not _reuse_vtu(final, run["keys"]["model"], vtu):
        from .steps import write_base_vtu

        write_base_vtu(ctx, vtu)
    timings["vtu"] = time.perf_counter() - t0
    atomic_write_text(out / "resolved_config.toml", config.to_toml())
    provenance = {
        "versions": package_versions(),
        "git_revision": git_revision(),
        "date": time.strftime("%Y-%m-%d"),
        "calibration": run["results"]["calibration"]["source"],
    }
    t0 = time.perf_counter()
    made = _write_pdf(config, run, provenance, final, out, say)
    pages = made.pop("pages")
    timings["pdf"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    atomic_write_json(
        out / "run.json",
        {
            "provenance": provenance,
            "timings_s": timings,
            # the process's peak resident memory so far, after each step: the step that raises
            # it is the one that sets the run's peak (not part of any key or compared output)
            "peak_memory_gb_after_step": run["peak"],
            "memory_gb_after_step": run["held"],  # resident now: what the steps before still hold
            "cached_steps": run["cached"],
            "pages": pages,
            "step_keys": run["keys"],
            "pdf": made,
        },
    )
    say(f"wrote {final / 'report.pdf'} ({len(pages)} pages) in {timings['total']:.1f} s", 1)
    return {
        "steps": run["results"],
        "arrays": run["arrays"],
        "timings_s": timings,
        "cached": run["cached"],
        "pages": pages,
        "provenance": provenance,
    }
