"""The command line, one module per command group; :func:`main` wires them up (``isj._cli._main``)."""

from ._main import build_parser, main

__all__ = ["build_parser", "main"]
