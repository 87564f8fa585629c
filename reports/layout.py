"""Page layout shared by the report's pages: an A4 figure with title and footer, text blocks, numbers.

Numbers in the text are formatted by :func:`urad`, :func:`ratio` and
:func:`pct`, which the tests use too, so the PDF's text can be checked against
the JSON. Pages are plain :class:`matplotlib.figure.Figure` objects with an Agg
canvas: no pyplot state, no backend chosen for the caller.
"""

from __future__ import annotations

A4 = (8.27, 11.69)  # inches
MONO = {"family": "monospace", "fontsize": 7.5}


def urad(x: float) -> str:
    """rad → µrad, 4 decimals (the tables' format)."""
    return f"{x * 1e6:.4f}"


def ratio(x: float) -> str:
    """A dimensionless ratio, 3 decimals."""
    return f"{x:.3f}"


def pct(x: float) -> str:
    """A relative difference as a signed percentage, 2 decimals."""
    return f"{100 * x:+.2f}"


def new_page(title: str, number: int, total: int, footer: str):
    """An A4 figure with its title, footer and page number."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=A4)
    FigureCanvasAgg(fig)  # drawable on its own (fig.canvas.draw()), without pyplot
    fig.text(0.07, 0.965, title, fontsize=15, weight="bold", va="top")
    fig.text(0.07, 0.02, footer, fontsize=6.5, color="0.4")
    fig.text(0.93, 0.02, f"{number} / {total}", fontsize=7, color="0.4", ha="right")
    return fig


def text_block(fig, x: float, y: float, text: str, **kw):
    """Monospace block of text with its top-left corner at (x, y) in figure coordinates."""
    return fig.text(x, y, text, va="top", **(MONO | kw))


def wrap(text: str, width: int = 100) -> str:
    """Each paragraph of ``text`` filled to ``width`` characters; blank lines kept."""
    import textwrap

    return "\n".join(textwrap.fill(p, width) if p else "" for p in text.split("\n"))
