"""``isj``: the top-level parser, and :func:`main`, which only dispatches to the command modules.

Each command group lives in its own module of :mod:`isj._cli` with a
``register(subparsers)`` that adds its parser and sets its handler as
``func``; a handler takes the parsed arguments and returns the exit code.
"""

from __future__ import annotations

import sys

from isj import __version__
from isj.caches import matplotlib_in_cache
from isj.errors import IsjError, UsageError

from . import _common, app, calibrate, ear, explore, fem, lumped, report, rom, sweep, uq

#: Command modules in ``isj --help`` order.
COMMANDS = (fem, lumped, calibrate, explore, sweep, report, ear, rom, uq, app)


def build_parser() -> _common.Parser:
    """The ``isj`` parser with every command registered."""
    parser = _common.Parser(prog="isj", description="Mechanics of the incus-stapes coupling.")
    parser.add_argument("--version", action="version", version=f"isj {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_common.Parser)
    for command in COMMANDS:
        command.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``); returns the exit code.

    0: done; 1: the input was fine but a check or the run failed; 2: bad input, refused in one
    line before anything was computed or written; 130: interrupted.
    """
    try:
        with _common.isj_warnings_as_lines(), matplotlib_in_cache():
            args = build_parser().parse_args(argv)
            return args.func(args)
    except (UsageError, ValueError) as exc:
        if not isinstance(exc, IsjError):  # a bug, not bad input: keep its traceback
            raise
        print(f"isj: error: {exc}", file=sys.stderr)
        return _common.EXIT_USAGE
    except RuntimeError as exc:  # MeshError, SolverUnavailable, ...: the input was fine, the run failed
        print(f"isj: error: {str(exc).splitlines()[0]}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("isj: interrupted", file=sys.stderr)
        return 130
