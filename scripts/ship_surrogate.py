"""Build the default mesh's surrogate and store it in ``fem/rom/data`` for every isj install.

    python scripts/ship_surrogate.py

Run it when the surrogate's key changes (a results version of the surrogate or of the FE
model, the default mesh, geometry or design space): ``tests/test_rom_shipped.py`` fails until
then. It builds from scratch (no cache; minutes on 2 cores), writes the greedy's global arrays
under the new key, removes the file of any other key, and reads the file back to check that
:func:`isj.fem.rom.model.load_shipped` gives the built surrogate bit for bit.
"""

from __future__ import annotations

import sys
import time

import numpy as np
from isj.fem.mesh import mesh_pedicle_joint
from isj.fem.rom.model import (
    DEFAULT_TOL,
    N_VALIDATE,
    SHIPPED_DIR,
    load_shipped,
    reduced_model,
    ship,
    surrogate_key,
)

from isj.design import Geometry
from isj.design_space import DesignSpace


def main() -> int:
    geometry, space, order, resolution = Geometry(), DesignSpace(), 2, 1.0
    key = surrogate_key(
        mesh_pedicle_joint(geometry, resolution=resolution),
        order,
        geometry,
        space,
        DEFAULT_TOL,
        resolution,
        {},
    )
    t0 = time.perf_counter()
    rom = reduced_model(geometry, order, resolution, space, cache=False)
    print(f"built in {time.perf_counter() - t0:.1f} s: {rom!r}")
    SHIPPED_DIR.mkdir(exist_ok=True)
    for old in SHIPPED_DIR.glob("rom-*.npz"):
        old.unlink()
    path = ship(rom, key)
    back = load_shipped(key, space, tol=DEFAULT_TOL, n_validate=N_VALIDATE, seed=0)
    same = back is not None and back.arrays.keys() == rom.arrays.keys()
    same = same and all(np.array_equal(back.arrays[k], rom.arrays[k]) for k in rom.arrays)
    print(f"{path} ({path.stat().st_size / 1e6:.2f} MB); read back bit for bit: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
