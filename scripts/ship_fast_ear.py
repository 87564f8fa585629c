"""Build the default report's fast ears and store them in ``fem/ear/data`` for every isj install.

    python scripts/ship_fast_ear.py [JOINT ...]

The default report's fast ears, one per joint of :data:`JOINTS` (bonded, and the sliding joint of
the transmission step's sliding case): the default joint mesh (P2, resolution 1), the default drum,
the default ear materials and masses, f_max 20 kHz (``isj ear sweep`` uses the same). Run it when
a key changes (the ``ear`` results version, a default mesh, the geometry or the ear's data):
``tests/test_fast_ear_shipped.py`` fails until then. It builds each named joint's (default: all)
from scratch (no cache; one to two minutes each on 2 cores), writes it under its new key, removes
the files of keys that are no joint's current one, and reads each file back to check that
:func:`isj.fem.ear.fast_ear.load_shipped` gives the built arrays bit for bit. A build on another
machine (another MKL thread count, another BLAS) gives another basis of the same accuracy, so
name only the joints whose key changed: the others keep their bits.
"""

from __future__ import annotations

import sys
import time

import numpy as np
from isj.fem.ear.fast_ear import SHIPPED_DIR, build_fast_ear, cache_key_of, load_shipped, ship
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.model import PedicleJointModel

#: The joints whose default fast ear ships.
JOINTS = ("bonded", "sliding")


def _model(joint: str) -> MiddleEarModel:
    return MiddleEarModel(joint=PedicleJointModel(order=2, resolution=1.0, joint=joint))


def ship_one(joint: str) -> bool:
    """Build the default fast ear of ``joint`` and ship it; whether it reads back whole."""
    model = _model(joint)
    key = cache_key_of(model)
    t0 = time.perf_counter()
    ear = build_fast_ear(model)
    print(f"{joint}: built in {time.perf_counter() - t0:.1f} s: {ear!r}")
    path = ship(ear, key)
    back = load_shipped(key)
    same = back is not None and list(back.arrays) == list(ear.arrays)  # the order sums the parts
    same = same and all(
        a.dtype == back.arrays[k].dtype and np.array_equal(back.arrays[k], a) for k, a in ear.arrays.items()
    )
    print(f"{path} ({path.stat().st_size / 1e6:.2f} MB); read back bit for bit: {same}")
    return same


def main(argv: list[str] | None = None) -> int:
    joints = list(sys.argv[1:] if argv is None else argv) or list(JOINTS)
    unknown = sorted(set(joints) - set(JOINTS))
    if unknown:
        print(f"joints {unknown}: each must be one of {', '.join(JOINTS)}", file=sys.stderr)
        return 2
    SHIPPED_DIR.mkdir(exist_ok=True)
    whole = [ship_one(joint) for joint in joints]
    current = {f"fast-ear-{cache_key_of(_model(joint))[:32]}.npz" for joint in JOINTS}
    for old in SHIPPED_DIR.glob("fast-ear-*.npz"):
        if old.name not in current:
            old.unlink()
    return 0 if all(whole) else 1


if __name__ == "__main__":
    sys.exit(main())
