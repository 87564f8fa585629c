"""Atomic file writes: a result file is either complete or absent, never half-written.

Every writer in isj goes through :func:`atomic_write`: the content is written to
a temporary file in the target's own folder (so the final rename never crosses
a file system), then moved into place with :func:`os.replace`, which readers see
as one step. If writing fails or is interrupted, the temporary file is removed
and any previous file at the target is left as it was.

Files that belong together (a sweep's CSV, NPZ, plot and record) go through
:func:`replace_dir`: they are written into a new sibling folder that replaces
the output folder as a whole once every file is there, so the folder holds one
complete set or the previous one, never a mix. The sibling is locked while its
process lives; a later run removes those a killed process left
(:func:`remove_stale_siblings`). :func:`check_out_folder` is the check every
command makes of such a folder before it starts.

:func:`file_lock` makes two processes that would compute the same cache entry
take turns, so that the second finds the first's entry instead of redoing it.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import glob
import itertools
import json
import os
import secrets
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from isj.errors import InvalidParameter


def _process_umask() -> int:
    """The process's umask (read by setting it and setting it back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: Mode of every file written here: what ``open`` would give (0o666 less the umask), not the
#: owner-only 0o600 of the temporary file it was written as.
FILE_MODE = 0o666 & ~_process_umask()


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
        os.chmod(tmp, FILE_MODE)
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
def file_lock(path: str | os.PathLike) -> Iterator[bool]:
    """Hold an exclusive lock (:func:`fcntl.flock`) on the file ``path`` for the ``with`` block.

    Another process asking for the same lock waits until this one is released (or its process
    ends: the kernel drops the lock of a killed process). The lock file is created if needed
    and left in place (it is empty). Where it cannot be created (a read-only folder) the block
    runs unlocked.

    Yields
    ------
    bool
        Whether the lock is held.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:
        yield False
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield True
    finally:
        os.close(fd)  # closing releases the lock


def _locked_sibling(path: Path, suffix: str) -> tuple[Path, int]:
    """A new empty folder ``.<name>.<random><suffix>`` beside ``path``, locked by the returned fd.

    It is made under another name and renamed once locked, so that :func:`remove_stale_siblings`
    of another process never sees it unlocked.
    """
    while True:
        tag = secrets.token_hex(4)
        making = path.parent / f".{path.name}.{tag}.new"
        try:
            making.mkdir()  # not mkdtemp: its 0700 would become the output folder's mode
            break
        except FileExistsError:  # pragma: no cover - 32 random bits
            continue
    fd = os.open(making, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        final = path.parent / f".{path.name}.{tag}{suffix}"
        os.replace(making, final)
    except BaseException:
        os.close(fd)
        making.rmdir()
        raise
    return final, fd


def remove_stale_siblings(path: str | os.PathLike) -> list[Path]:
    """Remove the staging folders of ``path`` that no live process uses; return those removed.

    They are the ``.<name>.<hex>.partial`` and ``.<name>.<hex>.old`` folders beside ``path``
    that a killed run of :func:`replace_dir` left. A folder in use is locked by its process
    (:func:`fcntl.flock` on the folder): it is left alone.
    """
    path = Path(path)
    removed = []
    try:
        candidates = sorted(path.parent.glob(f".{glob.escape(path.name)}.*"))
    except OSError:
        return removed
    for p in candidates:
        tag, _, suffix = p.name[len(path.name) + 2 :].partition(".")
        if suffix not in ("partial", "old") or len(tag) != 8 or p.is_symlink() or not p.is_dir():
            continue
        try:
            fd = os.open(p, os.O_RDONLY | os.O_DIRECTORY)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # held: a live run's folder
            os.close(fd)
            continue
        try:
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
        finally:
            os.close(fd)
    return removed


def swap_dir(staging: Path, path: Path) -> None:
    """Replace the folder ``path`` (if any) by the finished folder ``staging``: two renames.

    Any previous folder is first moved aside into a locked folder of its own, ``staging`` is
    renamed into place, and the previous one removed last; if the second rename fails the
    previous folder is put back.

    Another run swapping its folder into ``path`` at the same moment (two reports given one
    ``--out``) may move ``path`` aside first, or put its own folder there between the two
    renames: the renames are then tried again, so that each run ends with one complete folder
    at ``path`` (the last run's) and no error.
    """
    old, fd = None, None
    try:
        for attempt in itertools.count():
            aside = None
            if path.exists():
                if old is None:
                    old, fd = _locked_sibling(path, ".old")
                aside = old / f"{path.name}.{attempt}"
                try:
                    os.replace(path, aside)  # aside, inside a folder of its own
                except FileNotFoundError:  # another run moved it aside first
                    aside = None
            try:
                os.replace(staging, path)
                return
            except BaseException as exc:
                if isinstance(exc, OSError) and exc.errno in (errno.ENOTEMPTY, errno.EEXIST):
                    continue  # another run's folder came in between: it goes aside too
                if aside is not None:  # put the previous folder back
                    os.replace(aside, path)
                raise
    finally:
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
            os.close(fd)


@contextlib.contextmanager
def replace_dir(path: str | os.PathLike, name: str | None = None) -> Iterator[Path]:
    """A new empty sibling folder of ``path`` to write into; swapped in for ``path`` on success.

    The folder (``.<name>.<random>.partial`` beside ``path``) replaces ``path`` as a whole when
    the ``with`` block ends without an exception (:func:`swap_dir`): ``path`` holds the previous
    set or the new one, never a mix. On an exception or an interrupt the new folder is removed
    and ``path`` is left as it was. The folder is locked while in use, so that the next run
    (:func:`remove_stale_siblings`, called here first) removes it if this process was killed.

    Parameters
    ----------
    path : the output folder
    name : what to call ``path`` in the message if no folder can be created beside it
        (:class:`~isj.errors.InvalidParameter`); without it the ``OSError`` is raised

    Yields
    ------
    Path
        The folder to write into.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_siblings(path)
        staging, fd = _locked_sibling(path, ".partial")
    except OSError as exc:
        if name is None:
            raise
        raise InvalidParameter(
            f"{name} = {str(path)!r}: cannot create a folder beside it ({exc.strerror or exc})"
        ) from None
    try:
        yield staging
        swap_dir(staging, path)
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
        os.close(fd)


def check_writable_place(path: str | os.PathLike, name: str, text: str | None = None, *, error=None) -> None:
    """Refuse ``path`` unless the nearest existing folder above it is one where files can be made.

    :func:`os.access` says yes to root everywhere, so an empty folder is also made there and
    removed at once: nothing is left behind.

    Parameters
    ----------
    path : the file or folder to be written
    name : the option or parameter, named in the message
    text : ``path`` as the user gave it (default ``str(path)``)
    error : the exception class to raise (default :class:`~isj.errors.InvalidParameter`)
    """
    error = error or InvalidParameter
    text = str(path) if text is None else text
    absolute = Path(os.path.abspath(path))
    above = next(q for q in absolute.parents if q.exists())
    if not above.is_dir():
        raise error(f"{name} = {text!r}: {str(above)!r} is not a folder")
    why = None
    if not os.access(above, os.W_OK | os.X_OK):
        why = "permission denied"
    else:
        try:
            os.rmdir(tempfile.mkdtemp(prefix=".isj-probe-", dir=above))
        except OSError as exc:
            why = exc.strerror or str(exc)
    if why is not None:
        raise error(f"{name} = {text!r}: nothing can be written in {str(above)!r} ({why})")


def check_out_folder(
    path: str | os.PathLike,
    name: str,
    entries: frozenset[str] | None = None,
    *,
    written_by: str = "this command",
    error=None,
) -> Path:
    """An output folder as an absolute path, checked before anything runs.

    Refused: an empty name, something that is not a folder, a place where no folder can be
    made (:func:`check_writable_place`); and when ``entries`` is given (the folder is replaced
    as a whole, :func:`replace_dir`) also a root, the current folder or one above it, a symbolic
    link, and a folder holding anything but ``entries``.

    Parameters
    ----------
    path : the folder
    name : the option or parameter, named in the message (``"--out"``)
    entries : what a folder this command wrote holds; None: the folder is written into, not replaced
    written_by : what wrote the ``entries``, for the message
    error : the exception class to raise (default :class:`~isj.errors.InvalidParameter`)

    Raises
    ------
    InvalidParameter
        (or ``error``) One line naming ``name`` and what the folder must be.
    """
    error = error or InvalidParameter
    text = str(path)
    if not text.strip():
        raise error(f"{name} = {text!r}: must name a folder (not empty)")
    out = Path(os.path.abspath(text))
    replaced = entries is not None
    if replaced:
        cwd = Path.cwd().absolute()
        if out.parent == out or out == cwd or out in cwd.parents:
            raise error(f"{name} = {text!r}: must not be the current folder, one above it or a root")
        if out.is_symlink():
            raise error(f"{name} = {text!r}: is a symbolic link; give the folder it points to")
    if out.exists():
        if not out.is_dir():
            raise error(f"{name} = {text!r}: exists and is not a folder")
        other = sorted(q.name for q in out.iterdir() if replaced and q.name not in entries)
        if other:
            raise error(
                f"{name} = {text!r}: holds {other[0]!r}, which {written_by} does not write; "
                f"must be a new or empty folder or one {written_by} wrote"
            )
    check_writable_place(out, name, text, error=error)
    return out
