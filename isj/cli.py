"""``isj`` command line entry point (``[project.scripts]``): the commands live in :mod:`isj._cli`.

``main(argv=None) -> int`` so that tests call it directly. Bad input gives one
line on stderr naming the parameter and its valid range, exit code 2, and no
output file.
"""

from ._cli import build_parser, main
from .errors import UsageError

__all__ = ["UsageError", "build_parser", "main"]

if __name__ == "__main__":  # pragma: no cover
    import sys

    sys.exit(main())
