"""The second process of :func:`reports.pdf.write_report`: draws some of the report's pages.

``python -m isj.reports.pdf_worker JOB PART`` reads the pickled pages, results, arrays,
configuration, provenance and matplotlib settings from ``JOB`` (written by the report's process
for this run), and draws those pages into ``PART`` with :func:`reports.pdf.draw_part`, as the
report's process would have drawn them.
"""

from __future__ import annotations

import pickle
import sys


def main(argv=None) -> int:
    job, part = (sys.argv[1:] if argv is None else argv)[:2]
    with open(job, "rb") as fh:
        spec = pickle.load(fh)
    import matplotlib

    from .pdf import draw_part

    with matplotlib.rc_context(spec["rc"]):
        draw_part(part, spec["config"], spec["results"], spec["arrays"], spec["provenance"], spec["pages"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
