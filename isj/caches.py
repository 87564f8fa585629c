"""Where isj keeps what it can recompute: the default cache folders, in one place.

Three caches, each safe to delete at any time:

- meshes (:mod:`isj.fem.cache`): ``$ISJ_CACHE_DIR``, else ``~/.cache/isj/meshes``;
- FE results of single designs (:mod:`isj.calibration.runner`), shared by
  ``isj calibrate``, ``isj explore``, the report and the benchmarks:
  ``$ISJ_FE_CACHE_DIR``, else ``~/.cache/isj/fe``;
- finished report steps (:mod:`isj.reports.store`): the ``report`` folder of the FE
  result cache.

The environment is read at each call, not at import, so a test or a script
can point the caches elsewhere at any time.
"""

from __future__ import annotations

import os
from pathlib import Path

#: Environment variable that moves the mesh cache.
MESH_CACHE_ENV = "ISJ_CACHE_DIR"
#: Environment variable that moves the FE result cache (and the report step cache inside it).
FE_CACHE_ENV = "ISJ_FE_CACHE_DIR"


def _home_cache() -> Path:
    return Path.home() / ".cache" / "isj"


def mesh_cache_dir() -> Path:
    """``$ISJ_CACHE_DIR`` if set, else ``~/.cache/isj/meshes``."""
    env = os.environ.get(MESH_CACHE_ENV)
    return Path(env).expanduser() if env else _home_cache() / "meshes"


def fe_cache_dir(path: str | os.PathLike | None = None) -> Path:
    """``path`` if given (a ``--cache`` option), else ``$ISJ_FE_CACHE_DIR``, else ``~/.cache/isj/fe``."""
    if path:
        return Path(path).expanduser()
    env = os.environ.get(FE_CACHE_ENV)
    return Path(env).expanduser() if env else _home_cache() / "fe"


def report_cache_dir() -> Path:
    """``$ISJ_FE_CACHE_DIR/report``, else ``~/.cache/isj/fe/report``: inside :func:`fe_cache_dir`."""
    return fe_cache_dir() / "report"
