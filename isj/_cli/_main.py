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


def _name(command) -> str:
    """The command a module registers: its own name (``isj._cli.fem`` registers ``isj fem``)."""
    return command.__name__.rsplit(".", 1)[-1]


def build_parser(argv: list[str] | None = None) -> _common.Parser:
    """The ``isj`` parser with every command registered.

    Given ``argv`` whose first word names a command, only that command is
    registered: it parses those arguments as the full parser does (its usage,
    help and errors do not list the other commands), without the time the
    other commands' parsers take to build and import (``isj fem solve``:
    about 0.1-0.25 s).
    """
    parser = _common.Parser(prog="isj", description="Mechanics of the incus-stapes coupling.")
    parser.add_argument("--version", action="version", version=f"isj {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_common.Parser)
    named = [m for m in COMMANDS if argv and _name(m) == argv[0]]
    for command in named or COMMANDS:
        command.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``); returns the exit code.

    0: done; 1: the input was fine but a check or the run failed; 2: bad input, refused in one
    line before anything was computed or written; 130: interrupted.
    """
    try:
        with _common.isj_warnings_as_lines(), matplotlib_in_cache():
            if argv is None:
                argv = sys.argv[1:]
            args = build_parser(argv).parse_args(argv)
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
