"""Where isj keeps what it can recompute: the default cache folders, in one place.

Three caches, each safe to delete at any time:

- meshes (:mod:`isj.fem.cache`): ``$ISJ_CACHE_DIR``, else ``~/.cache/isj/meshes``;
- FE results of single designs (:mod:`isj.calibration.runner`), shared by
  ``isj calibrate``, ``isj explore``, the report and the benchmarks:
  ``$ISJ_FE_CACHE_DIR``, else ``~/.cache/isj/fe``;
- finished report steps (:mod:`isj.reports.store`): the ``report`` folder of the FE
  result cache.

Matplotlib's font cache and configuration folder go into the ``matplotlib`` folder of the FE
result cache while a command runs (:func:`matplotlib_in_cache`), unless ``$MPLCONFIGDIR``
says otherwise, so that a command writes nothing into the home folder beyond the caches.

The environment is read at each call, not at import, so a test or a script
can point the caches elsewhere at any time.

:func:`check_cache_dirs` checks, before any work, that each cache a command
uses can be used: every command of the command line calls it first.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from isj.errors import InvalidParameter

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


#: Matplotlib's own variable for its configuration and font cache folder.
MATPLOTLIB_ENV = "MPLCONFIGDIR"


@contextlib.contextmanager
def matplotlib_in_cache():
    """While it is open, ``$MPLCONFIGDIR`` is the FE result cache's ``matplotlib`` folder, unless
    it was set already; afterwards the environment is as before.

    Matplotlib reads the variable once, when it first needs the folder, and otherwise writes
    ``~/.config/matplotlib`` and ``~/.cache/matplotlib/fontlist-*.json``.
    """
    if MATPLOTLIB_ENV in os.environ:
        yield
        return
    os.environ[MATPLOTLIB_ENV] = str(fe_cache_dir() / "matplotlib")
    try:
        yield
    finally:
        os.environ.pop(MATPLOTLIB_ENV, None)


#: The caches :func:`check_cache_dirs` knows: the mesh cache, the FE result cache, and the
#: surrogate (``rom``) and report step caches inside the FE result cache's default folder.
CACHE_KINDS = ("mesh", "fe", "rom", "report")


def _nearest_existing(p: Path) -> Path:
    return next(q for q in (p, *p.parents) if q.exists() or q.is_symlink())


def cache_dir_problem(path: str | os.PathLike) -> str | None:
    """Why ``path`` cannot serve as a cache folder, or None if it can.

    It can when it is a folder in which a folder can be made and removed, or when it does not
    exist and the nearest folder above it is such a folder (the cache is created at its first
    entry). The test makes an empty folder and removes it at once: nothing is left behind, and
    unlike :func:`os.access` it also says no to root on a read-only file system.
    """
    p = Path(os.path.abspath(Path(path).expanduser()))
    above = _nearest_existing(p)
    if not above.is_dir():
        return f"{str(above)!r} exists and is not a folder"
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".isj-probe-", dir=above))
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        return f"nothing can be written in {str(above)!r} ({why})"
    return None


def _where(kind: str, fe_path, fe_option: str) -> tuple[Path, str]:
    """(folder, how the message names it) of the cache ``kind``."""
    if kind == "mesh":
        env = os.environ.get(MESH_CACHE_ENV)
        return mesh_cache_dir(), (f"${MESH_CACHE_ENV}" if env else "the mesh cache")
    if kind == "fe" and fe_path:
        return fe_cache_dir(fe_path), fe_option
    env = os.environ.get(FE_CACHE_ENV)
    base, name = fe_cache_dir(), (f"${FE_CACHE_ENV}" if env else "the FE result cache")
    if kind == "fe":
        return base, name
    return base / kind, f"{name} (its {kind!r} folder)"


def check_cache_dirs(*kinds: str, fe_path: str | os.PathLike | None = None, fe_option: str = "--cache"):
    """Refuse, before any work, a cache that cannot be used; return the folders checked.

    Parameters
    ----------
    kinds : names in :data:`CACHE_KINDS`: ``"mesh"`` (:func:`mesh_cache_dir`), ``"fe"``
        (:func:`fe_cache_dir` of ``fe_path``), ``"rom"`` and ``"report"`` (their folders inside
        the default FE result cache).
    fe_path : the FE result cache given on the command line (``--cache``), if any.
    fe_option : the option that gave ``fe_path``, for the message.

    Returns
    -------
    dict
        kind → folder (:class:`~pathlib.Path`).

    Raises
    ------
    InvalidParameter
        One line naming the folder, where it came from (the option, the environment variable
        or the default) and why it cannot be used (:func:`cache_dir_problem`).
    """
    out = {}
    for kind in kinds:
        if kind not in CACHE_KINDS:
            raise InvalidParameter(f"kind = {kind!r}: must be one of {', '.join(CACHE_KINDS)}")
        path, name = _where(kind, fe_path, fe_option)
        why = cache_dir_problem(path)
        if why is not None:
            raise InvalidParameter(
                f"{name} = {str(path)!r}: cannot be used as a cache folder: {why}; give a writable folder"
            )
        out[kind] = path
    return out
