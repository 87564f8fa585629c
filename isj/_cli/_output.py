"""Files the sweep commands write: the response as CSV and NPZ, each written atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from isj.atomic import atomic_write, atomic_write_text


def write_response_csv(path: Path, freq_hz, H, outputs, units: str, extra=None) -> None:
    """Frequency response as CSV: re, im, |.|, unwrapped phase (deg) per output; units in a # line.

    Parameters
    ----------
    path : Path
    freq_hz : (n,) frequencies (Hz)
    H : (n, len(outputs)) complex responses
    outputs : output names, the column order of ``H``
    units : the ``# units:`` line's text
    extra : optional mapping name → (n,) real column, written after the complex ones
    """
    extra = dict(extra or {})
    header = "freq_hz," + ",".join(f"{k}_re,{k}_im,{k}_abs,{k}_phase_deg" for k in outputs)
    header += "".join(f",{k}" for k in extra)
    cols = [freq_hz]
    for j in range(len(outputs)):
        h = H[:, j]
        cols += [h.real, h.imag, np.abs(h), np.degrees(np.unwrap(np.angle(h)))]
    cols += [np.asarray(v, dtype=float) for v in extra.values()]
    rows = "\n".join(",".join(f"{v:.9g}" for v in row) for row in np.column_stack(cols))
    atomic_write_text(path, f"# units: {units}\n{header}\n{rows}\n")


def write_npz(path: Path, **arrays) -> None:
    """``arrays`` as an uncompressed NPZ file, written atomically."""

    def write(tmp):
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    atomic_write(path, write)
