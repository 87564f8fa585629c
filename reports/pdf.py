"""Lay the report out as an A4 PDF, one section per page (matplotlib, no creation date).

The pages are drawn by :mod:`reports.pages_static` (title, model, cases,
trends, energy) and :mod:`reports.pages_dynamic` (convergence, calibration,
sweep, ear) on the layout of :mod:`reports.layout` (page size, fonts and the number formats
``urad``, ``ratio``, ``pct`` with which the tests check the PDF's text against the JSON).
"""

from __future__ import annotations

import dataclasses

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


def build_pages(config, results: dict, arrays: dict, provenance: dict):
    """Yield ``(title, figure)`` for each page (:class:`matplotlib.figure.Figure`, Agg canvas)."""
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
        fig = new_page(title, i, total, footer)
        build(fig)
        yield title, fig


#: Resolution (dots per inch) of the artists drawn as images (the guard page's dense scatter); the
#: rest of every page stays vector.
RASTER_DPI = 200

#: zlib level of the PDF's streams: level 1 wrote the fifteen pages in 8.9 s against 11.4–11.8 s
#: at matplotlib's default 6, for a file 2.5 % larger (1.75 MB against 1.71 MB).
PDF_COMPRESSION = 1


def write_report(path, config, results: dict, arrays: dict, provenance: dict) -> list[str]:
    """Write the PDF atomically; returns the page titles."""
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    from isj.atomic import atomic_write

    titles = []

    def write(tmp):
        # no creation date: the same inputs give the same bytes
        with (
            matplotlib.rc_context({"pdf.compression": PDF_COMPRESSION}),
            PdfPages(tmp, metadata={"CreationDate": None, "Title": "isj report"}) as pdf,
        ):
            for title, fig in build_pages(config, results, arrays, provenance):
                pdf.savefig(fig, dpi=RASTER_DPI)
                titles.append(title)

    atomic_write(path, write)
    return titles
