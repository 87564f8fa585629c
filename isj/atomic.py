"""Atomic file writes: a result file is either complete or absent, never half-written.

Every writer in isj goes through :func:`atomic_write`: the content is written to
a temporary file in the target's own folder (so the final rename never crosses
a file system), then moved into place with :func:`os.replace`, which readers see
as one step. If writing fails or is interrupted, the temporary file is removed
and any previous file at the target is left as it was.

Files that belong together (a sweep's CSV, NPZ, plot and record) go through
:func:`replace_dir`: they are written into a new sibling folder that replaces
the output folder as a whole once every file is there, so the folder holds one
complete set or the previous one, never a mix.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path


def atomic_write(path: str | os.PathLike, write: Callable[[str], object], *, fsync: bool = False) -> Path:
    """Call ``write(tmp_path)``, then move the file it wrote onto ``path``.

    Parameters
    ----------
    path : the file to (re)place; its folder is created if needed
    write : writes the whole content to the path it is given (a file name
        ending in ``path``'s suffix, so writers that read the format from the
        suffix still work)
    fsync : flush the file to disk before the rename (for cache entries that
        must survive a power cut as either the old or the new version)

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        if fsync:
            with open(tmp, "r+b") as f:
                os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_bytes(path: str | os.PathLike, data: bytes, *, fsync: bool = False) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_write`)."""
    return atomic_write(path, lambda tmp: Path(tmp).write_bytes(data), fsync=fsync)


def atomic_write_text(path: str | os.PathLike, text: str, *, fsync: bool = False) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_write`)."""
    return atomic_write_bytes(path, text.encode("utf-8"), fsync=fsync)


def atomic_write_json(path: str | os.PathLike, obj, *, fsync: bool = False) -> Path:
    """Write ``obj`` as indented JSON with sorted keys to ``path`` atomically."""
    return atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=True) + "\n", fsync=fsync)


@contextlib.contextmanager
def replace_dir(path: str | os.PathLike) -> Iterator[Path]:
    """A new empty sibling folder of ``path`` to write into; swapped in for ``path`` on success.

    The folder (``.<name>.<random>.partial`` beside ``path``) replaces ``path`` as a whole when
    the ``with`` block ends without an exception: any previous folder at ``path`` is moved aside
    into a folder of its own, the new one renamed into place, the old one removed last (so
    ``path`` holds the previous set or the new one, never a mix). On an exception or an
    interrupt the new folder is removed and ``path`` is left as it was.

    Yields
    ------
    Path
        The folder to write into.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        staging = path.parent / f".{path.name}.{secrets.token_hex(4)}.partial"
        try:
            staging.mkdir()  # not mkdtemp: its 0700 would become the output folder's mode
            break
        except FileExistsError:  # pragma: no cover - 32 random bits
            continue
    try:
        yield staging
        old = None
        if path.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".old", dir=path.parent))
            os.replace(path, old / path.name)
        try:
            os.replace(staging, path)
        except BaseException:
            if old is not None:  # put the previous folder back
                os.replace(old / path.name, path)
                old.rmdir()
            raise
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
