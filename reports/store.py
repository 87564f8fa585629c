"""Results of report steps, cached on disk by a hash of everything they depend on.

A step's key covers its name, the part of the configuration it reads, the FE
code digest and the calibration it uses. A finished step is stored atomically
(``<dir>/<step>-<key>.json``, plus an ``.npz`` for arrays); an interrupted
report therefore resumes at the first unfinished step, and a second report on
the same inputs, into any folder, recomputes nothing.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from pathlib import Path

import numpy as np

from isj.atomic import atomic_write, atomic_write_json
from isj.caches import report_cache_dir
from isj.errors import CorruptCacheEntry

#: ``$ISJ_FE_CACHE_DIR/report``, or ``~/.cache/isj/fe/report`` (one definition, in :mod:`isj.caches`).
default_cache_dir = report_cache_dir


def step_key(name: str, inputs) -> str:
    """sha256 (hex, 24 digits) of the step name and its JSON-able inputs."""
    text = json.dumps({"step": name, "inputs": inputs}, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


class StepStore:
    """Finished steps in ``directory``: JSON results and optional arrays."""

    def __init__(self, directory: str | os.PathLike):
        self.directory = Path(directory)

    def _paths(self, name: str, key: str) -> tuple[Path, Path]:
        stem = self.directory / f"{name}-{key}"
        return stem.with_suffix(".json"), stem.with_suffix(".npz")

    def get(self, name: str, key: str) -> tuple[dict, dict[str, np.ndarray]] | None:
        """(result, arrays) of a finished step, or None; a damaged entry is reported and ignored."""
        jpath, npath = self._paths(name, key)
        if not jpath.exists():
            return None
        try:
            record = json.loads(jpath.read_text())
            if record.get("key") != key:
                raise ValueError("key mismatch")
            arrays = {}
            if record.get("has_arrays"):
                with np.load(npath, allow_pickle=False) as z:
                    arrays = {k: z[k] for k in z.files}
            return record["result"], arrays
        except (OSError, ValueError, KeyError) as exc:
            warnings.warn(
                f"report cache entry {jpath} is damaged ({exc}); recomputing", CorruptCacheEntry, stacklevel=2
            )
            return None

    def put(self, name: str, key: str, result: dict, arrays: dict[str, np.ndarray] | None = None) -> None:
        jpath, npath = self._paths(name, key)
        if arrays:  # arrays first: a JSON record only ever points at a complete .npz

            def write(tmp):
                with open(tmp, "wb") as f:
                    np.savez_compressed(f, **arrays)

            atomic_write(npath, write)
        atomic_write_json(jpath, {"key": key, "step": name, "has_arrays": bool(arrays), "result": result})
