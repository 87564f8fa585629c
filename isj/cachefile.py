"""Cache entries that carry a checksum of their payload, verified on every read.

Two formats, each written atomically (:mod:`isj.atomic`):

- **JSON**: an object whose ``"sha256"`` field is the sha256 of the canonical
  JSON of all its other fields (sorted keys, no whitespace, floats as Python's
  ``repr``, the shortest text that reads back to the same number). The file
  itself may be indented for people to read; the checksum does not depend on it.
- **NPZ**: a NumPy archive (no pickles) whose array ``__sha256__`` is the sha256
  over every other array's name, dtype, shape and bytes.

A reader raises :class:`DamagedEntry` for anything it cannot trust: a
truncated file, random bytes, a missing checksum, or a number edited so that
the file is still valid JSON or NPZ but no longer matches its checksum. The
cache that owns the entry then calls :func:`discard`: one warning line
(:class:`~isj.errors.CorruptCacheEntry`), the files deleted (a folder standing
where an entry belongs too), the result recomputed by the caller.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import warnings
from pathlib import Path

import numpy as np

from isj.atomic import atomic_write, atomic_write_text
from isj.errors import CorruptCacheEntry

#: Field of a JSON entry, and array of an NPZ entry, that holds the checksum.
CHECKSUM = "sha256"
_NPZ_CHECKSUM = "__sha256__"


class DamagedEntry(Exception):
    """A cache entry failed to read or to verify; the message says why, in one line."""


def canonical_json(obj) -> str:
    """The canonical JSON text of ``obj``: what JSON checksums and cache keys are computed from."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False)


def json_checksum(record: dict) -> str:
    """sha256 (hex) of the canonical JSON of ``record`` without its checksum field."""
    payload = {k: v for k, v in record.items() if k != CHECKSUM}
    return hashlib.sha256(canonical_json(payload).encode("utf-8")).hexdigest()


def write_json_entry(path: str | os.PathLike, record: dict, *, indent: int | None = None) -> dict:
    """Write ``record`` plus its checksum to ``path`` atomically; return the record as it reads back.

    ``record`` must be JSON-able (str keys); the returned copy has plain JSON types
    (lists for tuples, sorted keys) and no checksum field.
    """
    if CHECKSUM in record:
        raise ValueError(f"record field {CHECKSUM!r} is reserved for the checksum")
    plain = json.loads(canonical_json(record))
    sealed = plain | {CHECKSUM: json_checksum(plain)}
    text = json.dumps(sealed, sort_keys=True, indent=indent, ensure_ascii=False) + "\n"
    atomic_write_text(path, text, fsync=True)
    return plain


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"non-finite number {text}")
    return value


def _no_constant(text: str):
    raise ValueError(f"non-finite number {text}")


def read_json_entry(path: str | os.PathLike, *, finite: bool = False) -> dict | None:
    """The record stored at ``path`` (without its checksum), or None if there is no file.

    Parameters
    ----------
    path : the entry
    finite : refuse NaN, Infinity and numbers too large for a float (1e999)

    Raises
    ------
    DamagedEntry
        Unreadable, not a JSON object, no checksum, or a checksum that does not match.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise DamagedEntry(f"cannot read ({exc.strerror})") from exc
    try:
        hooks = {"parse_float": _finite_float, "parse_constant": _no_constant} if finite else {}
        record = json.loads(data.decode("utf-8"), **hooks)
    except ValueError as exc:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        raise DamagedEntry(_one_line(exc)) from exc
    if not isinstance(record, dict) or not isinstance(record.get(CHECKSUM), str):
        raise DamagedEntry("no checksum")
    if record[CHECKSUM] != json_checksum(record):
        raise DamagedEntry("checksum does not match the content")
    del record[CHECKSUM]
    return record


def arrays_checksum(arrays: dict[str, np.ndarray]) -> str:
    """sha256 (hex) over the name, dtype, shape and bytes of each array, in name order."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        if name == _NPZ_CHECKSUM:
            continue
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def write_npz_entry(
    path: str | os.PathLike, arrays: dict[str, np.ndarray], *, compressed: bool = False
) -> str:
    """Write ``arrays`` plus their checksum to ``path`` (.npz) atomically; return the checksum."""
    if _NPZ_CHECKSUM in arrays:
        raise ValueError(f"array name {_NPZ_CHECKSUM!r} is reserved for the checksum")
    arrays = {k: np.asarray(v) for k, v in arrays.items()}
    digest = arrays_checksum(arrays)
    save = np.savez_compressed if compressed else np.savez

    def write(tmp: str) -> None:
        with open(tmp, "wb") as f:
            save(f, **arrays, **{_NPZ_CHECKSUM: np.array(digest)})

    atomic_write(path, write, fsync=True)
    return digest


def read_npz_entry(path: str | os.PathLike) -> tuple[dict[str, np.ndarray], str]:
    """(arrays, checksum) of the entry at ``path``, every array read and verified.

    Raises
    ------
    DamagedEntry
        Missing, unreadable (truncated, not a zip, a bad CRC), no checksum, or a
        checksum that does not match the arrays.
    """
    try:
        # opened here, not by np.load, so that the file is closed whatever np.load raises
        with open(path, "rb") as f:
            if f.read(4) != b"PK\x03\x04":  # an NPZ is a zip archive; anything else np.load reads as a pickle
                raise DamagedEntry("not an NPZ archive")
            f.seek(0)
            with np.load(f, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
    except DamagedEntry:
        raise
    except Exception as exc:  # BadZipFile, zlib.error, EOFError, ValueError, OSError: all mean damaged
        raise DamagedEntry(_one_line(exc)) from exc
    stored = arrays.pop(_NPZ_CHECKSUM, None)
    if stored is None or stored.shape != () or stored.dtype.kind != "U":
        raise DamagedEntry("no checksum")
    if str(stored) != arrays_checksum(arrays):
        raise DamagedEntry("checksum does not match the arrays")
    return arrays, str(stored)


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return f"{type(exc).__name__}: {text}"


def discard(paths, what: str, reason: str | BaseException, stacklevel: int = 2) -> None:
    """Report a damaged cache entry in one warning line and delete its files.

    Parameters
    ----------
    paths : the entry's file or files (the first one is named in the warning)
    what : which cache, e.g. ``"mesh"``, ``"FE result"``, ``"report step"``
    reason : why it is not trusted
    stacklevel : as for :func:`warnings.warn`, counted from the caller of ``discard``
    """
    paths = [Path(paths)] if isinstance(paths, str | os.PathLike) else [Path(p) for p in paths]
    why = reason if isinstance(reason, str) else _one_line(reason)
    why = " ".join(why.split())
    warnings.warn(
        f"{what} cache entry {paths[0]} is damaged or unreadable ({why}); deleted, recomputing",
        CorruptCacheEntry,
        stacklevel=stacklevel + 1,
    )
    for p in paths:
        remove_entry(p)


def remove_entry(path: str | os.PathLike) -> None:
    """Delete the file ``path``, or the folder (with all it holds) standing where a file belongs.

    A read-only cache keeps the entry; it is never used, since it does not verify.
    """
    p = Path(path)
    try:
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p)
        else:
            p.unlink(missing_ok=True)
    except OSError:
        pass
