"""Results of report steps, cached on disk by a hash of everything they depend on.

A step's key covers its name, the part of the configuration it reads, the
results versions of the step and of the result families it reads
(:func:`isj.reports.steps.step_inputs`, docs/developer/cache-keys.md) and the
calibration it uses. A finished step is stored atomically
(``<dir>/<step>-<key>.json``, plus an ``.npz`` for arrays); an interrupted
report therefore resumes at the first unfinished step, and a second report on
the same inputs, into any folder, recomputes nothing.

Both files carry checksums (:mod:`isj.cachefile`): the JSON record its own and
that of the arrays. A damaged entry (truncated, random bytes, a number edited)
is reported with one :class:`~isj.errors.CorruptCacheEntry` warning line,
deleted and recomputed.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

from isj.cachefile import (
    DamagedEntry,
    canonical_json,
    discard,
    read_json_entry,
    read_npz_entry,
    write_json_entry,
    write_npz_entry,
)
from isj.caches import report_cache_dir

#: ``$ISJ_FE_CACHE_DIR/report``, or ``~/.cache/isj/fe/report`` (one definition, in :mod:`isj.caches`).
default_cache_dir = report_cache_dir


def step_key(name: str, inputs) -> str:
    """sha256 (hex, 24 digits) of the canonical JSON of the step name and its inputs.

    The inputs must be plain JSON (a TypeError otherwise): a ``repr`` fallback could
    abbreviate an array and give two different inputs one key.
    """
    text = canonical_json({"step": name, "inputs": inputs})
    return hashlib.sha256(text.encode()).hexdigest()[:24]


class StepStore:
    """Finished steps in ``directory``: JSON results and optional arrays."""

    def __init__(self, directory: str | os.PathLike):
        self.directory = Path(directory)

    def _paths(self, name: str, key: str) -> tuple[Path, Path]:
        stem = self.directory / f"{name}-{key}"
        return stem.with_suffix(".json"), stem.with_suffix(".npz")

    def get(self, name: str, key: str) -> tuple[dict, dict[str, np.ndarray]] | None:
        """(result, arrays) of a finished step, or None; a damaged entry is reported, deleted, ignored."""
        jpath, npath = self._paths(name, key)
        files = [jpath, npath]  # the first is the one the warning names
        try:
            record = read_json_entry(jpath)
            if record is None:
                return None
            if record.get("key") != key or record.get("step") != name:
                raise DamagedEntry("step or key differs from the file name")
            if not isinstance(record.get("result"), dict):
                raise DamagedEntry("no result")
            arrays = {}
            if record.get("arrays_sha256") is not None:
                files.reverse()
                arrays, digest = read_npz_entry(npath)
                if digest != record["arrays_sha256"]:
                    raise DamagedEntry(f"{npath.name} holds other arrays than the record was written with")
            return record["result"], arrays
        except DamagedEntry as exc:
            discard(files, "report step", str(exc), stacklevel=2)
            return None

    def put(self, name: str, key: str, result: dict, arrays: dict[str, np.ndarray] | None = None) -> None:
        """Store a finished step: its arrays first, then the record that names their checksum."""
        jpath, npath = self._paths(name, key)
        # arrays first: a JSON record only ever points at a complete .npz
        digest = write_npz_entry(npath, arrays, compressed=True) if arrays else None
        record = {"key": key, "step": name, "arrays_sha256": digest, "result": result}
        write_json_entry(jpath, record, indent=2)
