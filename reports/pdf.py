"""Lay the report out as an A4 PDF, one section per page (matplotlib, no creation date).

The pages are drawn by :mod:`reports.pages_static` (title, model, cases,
trends, energy) and :mod:`reports.pages_dynamic` (convergence, calibration,
sweep, ear) on the layout of :mod:`reports.layout` (page size, fonts and the number formats
``urad``, ``ratio``, ``pct`` with which the tests check the PDF's text against the JSON).

Drawing takes about 9 s of one core, so :func:`write_report` draws the last pages
(:data:`WORKER_PAGES`) in a second process (:mod:`reports.pdf_worker`) while this one draws
the others, and joins the two parts with pypdf. The parts are drawn the same way in either
process, and joined the same way when the second process fails and this one draws its pages
too, so the file's bytes do not depend on who drew which page (tests/test_report.py).
"""

from __future__ import annotations

import dataclasses
import os
import pickle
import subprocess
import sys
from pathlib import Path

from .guard import guard_page
from .layout import new_page
from .pages_circuit import circuit_page
from .pages_dynamic import calibration_page, convergence_page, ear_page, sweep_page
from .pages_static import cases_page, energy_page, model_page, title_page, trends_page
from .pages_transmission import delta_page, hv_page
from .sliding import sliding_page
from .uq import uq_page

#: Page titles, in order; the tests look for them in the PDF's text.
PAGE_TITLES = (
    "isj report",
    "1. The model",
    "2. The seven thesis cases",
    "3. Trends across the design space",
    "4. Strain energy per region",
    "5. Mesh convergence",
    "6. Calibration of the lumped model",
    "7. Frequency response",
    "8. The whole middle ear",
    "9. Sound transmission through the whole ear",
    "10. What the pedicle and the joint cost transmission",
    "11. A sliding joint",
    "12. Uncertainty of the moduli",
    "13. The lumped model's error over the domain",
    "14. The ear beside the published cat circuit",
)


def build_pages(config, results: dict, arrays: dict, provenance: dict, pages=None):
    """Yield ``(title, figure)`` for each page (:class:`matplotlib.figure.Figure`, Agg canvas),
    or for the pages whose 0-based indices are in ``pages``."""
    total = len(PAGE_TITLES)
    footer = (
        f"isj {provenance['versions'].get('isj', '?')} ({provenance.get('git_revision') or 'no git'}), "
        f"{provenance['date']}; data behind every figure: data/*.json, data/*.csv"
    )
    geo = (results["geometry_trends"], arrays["geometry_trends"])  # the trends page's last row
    builders = (
        lambda f: title_page(f, config, provenance, results["model"]),
        lambda f: model_page(f, results["model"], arrays["model"]),
        lambda f: cases_page(f, results["cases"], results["model"]),
        lambda f: trends_page(
            f, results["trends"], arrays["trends"], config.design.moduli(), config.trends.moduli, geometry=geo
        ),
        lambda f: energy_page(f, results["cases"]),
        lambda f: convergence_page(f, results["convergence"]),
        lambda f: calibration_page(f, results["calibration"], dataclasses.asdict(config.geometry)),
        lambda f: sweep_page(f, results["sweep"], arrays["sweep"]),
        lambda f: ear_page(f, results["ear"], arrays["ear"], results["cases"]),
        lambda f: hv_page(f, results["transmission"], arrays["transmission"]),
        lambda f: delta_page(
            f, results["transmission"], arrays["transmission"], results["load_path"], arrays["load_path"]
        ),
        lambda f: sliding_page(f, results["sliding"]),
        lambda f: uq_page(f, results["uq"], results["uq"]["histograms"]),
        lambda f: guard_page(f, results["guard"], arrays["guard"]),
        lambda f: circuit_page(f, results["transmission"]),
    )
    for i, (title, build) in enumerate(zip(PAGE_TITLES, builders, strict=True), 1):
        if pages is not None and i - 1 not in pages:
            continue
        fig = new_page(title, i, total, footer)
        build(fig)
        yield title, fig


#: Resolution (dots per inch) of the artists drawn as images (the guard page's dense scatter); the
#: rest of every page stays vector.
RASTER_DPI = 200

#: zlib level of the PDF's streams: level 1 wrote the fifteen pages in 8.9 s against 11.4–11.8 s
#: at matplotlib's default 6, for a file 2.5 % larger (1.75 MB against 1.71 MB).
PDF_COMPRESSION = 1


#: Pages (0-based) the second process draws: the last four (the sliding joint, the uncertainty,
#: the guard's twelve scatter panels, the circuit), about 4.2 s of drawing on the default report
#: against 5.2 s for the eleven before them; the second process also starts Python (0.7-0.9 s).
WORKER_PAGES = tuple(range(11, len(PAGE_TITLES)))

#: Seconds to wait for the second process before drawing its pages here.
WORKER_TIMEOUT_S = 300

#: rcParams not sent to the second process: its backend is Agg, whatever this one uses.
_RC_NOT_SENT = frozenset({"backend", "backend_fallback", "interactive"})


def draw_part(path, config, results: dict, arrays: dict, provenance: dict, pages) -> list[str]:
    """Draw the pages whose 0-based indices are ``pages`` into the PDF ``path``; their titles."""
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    titles = []
    # no creation date: the same inputs give the same bytes
    with (
        matplotlib.rc_context({"pdf.compression": PDF_COMPRESSION}),
        PdfPages(path, metadata={"CreationDate": None, "Title": "isj report"}) as pdf,
    ):
        for title, fig in build_pages(config, results, arrays, provenance, pages):
            pdf.savefig(fig, dpi=RASTER_DPI)
            titles.append(title)
    return titles


def write_report(path, config, results: dict, arrays: dict, provenance: dict, processes: int = 2, say=None):
    """Write the PDF atomically; returns the page titles.

    ``processes=2`` draws :data:`WORKER_PAGES` in a second process (module docstring); 1 draws
    every page here. The bytes are the same either way. ``say(message, level)``, if given, hears
    why the second process's pages were drawn here after all.
    """
    from isj.atomic import atomic_write

    own = [i for i in range(len(PAGE_TITLES)) if i not in WORKER_PAGES]

    def write(tmp):
        tmp = Path(tmp)
        parts = (tmp.with_name(tmp.name + ".part1"), tmp.with_name(tmp.name + ".part2"))
        worker = None
        try:
            if processes > 1:
                worker = _start_worker(parts[1], config, results, arrays, provenance)
            draw_part(parts[0], config, results, arrays, provenance, own)
            if worker is None:
                failed = "the second process did not start" if processes > 1 else ""
            else:
                failed = _finish_worker(worker, parts[1])
            if worker is None or failed:
                if failed and say is not None:
                    say(f"pages {WORKER_PAGES[0] + 1}-{WORKER_PAGES[-1] + 1} drawn here: {failed}", 2)
                draw_part(parts[1], config, results, arrays, provenance, WORKER_PAGES)
            _join(parts, tmp)
        finally:
            if worker is not None and worker.poll() is None:
                worker.kill()
                worker.wait()
            for f in (*parts, parts[1].with_name(parts[1].name + ".in")):
                f.unlink(missing_ok=True)

    atomic_write(path, write)
    return list(PAGE_TITLES)


def _start_worker(part: Path, config, results, arrays, provenance) -> subprocess.Popen | None:
    """``python -m isj.reports.pdf_worker`` drawing :data:`WORKER_PAGES` into ``part``; None if it
    cannot start. Its input is pickled to a file first: a pipe would hold this process until the
    worker has imported matplotlib and begun to read."""
    import matplotlib

    job = part.with_name(part.name + ".in")
    rc = {k: v for k, v in matplotlib.rcParams.items() if k not in _RC_NOT_SENT}
    spec = {
        "config": config,
        "results": results,
        "arrays": arrays,
        "provenance": provenance,
        "pages": WORKER_PAGES,
        "rc": rc,
    }
    try:
        with open(job, "wb") as fh:
            pickle.dump(spec, fh, protocol=pickle.HIGHEST_PROTOCOL)
        # one thread each for BLAS: the pages need none, and this process is drawing too
        env = dict(
            os.environ, MPLBACKEND="agg", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1"
        )
        return subprocess.Popen(
            [sys.executable, "-m", "isj.reports.pdf_worker", str(job), str(part)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            env=env,
        )
    except (OSError, pickle.PicklingError, TypeError, AttributeError):
        return None


def _finish_worker(worker: subprocess.Popen, part: Path) -> str:
    """Wait for the second process; why its part cannot be used, or "" when it can."""
    try:
        _, err = worker.communicate(timeout=WORKER_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return f"the second process took over {WORKER_TIMEOUT_S} s"
    if worker.returncode != 0:
        last = (err or b"").decode(errors="replace").strip().splitlines()[-1:] or ["no message"]
        return f"the second process failed (exit {worker.returncode}: {last[0]})"
    if not part.exists():
        return "the second process wrote nothing"
    return ""


def _join(parts, target: Path) -> None:
    """The parts' pages, in order, as one PDF (pypdf; no dates, so the same parts give the same bytes)."""
    from pypdf import PdfWriter

    writer = PdfWriter()
    for part in parts:
        writer.append(str(part))
    writer.add_metadata({"/Title": "isj report"})
    with open(target, "wb") as fh:
        writer.write(fh)
