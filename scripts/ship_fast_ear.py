"""Build the default report's fast ear and store it in ``fem/ear/data`` for every isj install.

    python scripts/ship_fast_ear.py

The default report's fast ear: the default joint mesh (P2, resolution 1), the default drum, the
default ear materials and masses, f_max 20 kHz (``isj ear sweep`` uses the same). Run it when its
key changes (the ``ear`` results version, a default mesh, the geometry or the ear's data):
``tests/test_fast_ear_shipped.py`` fails until then. It builds from scratch (no cache; about a
minute on 2 cores), writes it under the new key, removes the file of any other key, and reads the
file back to check that :func:`isj.fem.ear.fast_ear.load_shipped` gives the built arrays bit for bit.
"""

from __future__ import annotations

import sys
import time

import numpy as np
from isj.fem.ear.fast_ear import SHIPPED_DIR, build_fast_ear, cache_key_of, load_shipped, ship
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.model import PedicleJointModel


def main() -> int:
    model = MiddleEarModel(joint=PedicleJointModel(order=2, resolution=1.0))
    key = cache_key_of(model)
    t0 = time.perf_counter()
    ear = build_fast_ear(model)
    print(f"built in {time.perf_counter() - t0:.1f} s: {ear!r}")
    SHIPPED_DIR.mkdir(exist_ok=True)
    for old in SHIPPED_DIR.glob("fast-ear-*.npz"):
        old.unlink()
    path = ship(ear, key)
    back = load_shipped(key)
    same = back is not None and list(back.arrays) == list(ear.arrays)  # the order sums the parts
    same = same and all(
        a.dtype == back.arrays[k].dtype and np.array_equal(back.arrays[k], a) for k, a in ear.arrays.items()
    )
    print(f"{path} ({path.stat().st_size / 1e6:.2f} MB); read back bit for bit: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
