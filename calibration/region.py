"""Where the lumped model holds its tolerance: a map of the calibrated domain stored in the artifact.

The calibrated domain's log-moduli box (its ranged moduli, in :data:`isj.lumped.model.MODULI`
order) is cut into ``cells`` equal slices per modulus (12: 12^5 = 248,832 cells for the shipped
domain). The certified surrogate guards the lumped model on a dense scrambled Sobol sample of
the box and on its corners (:func:`isj.calibration.guard.guard_set`); a cell is *outside* the
region when a design in it, or in a cell that shares a face or corner with it, has a certified
error above the threshold (the tolerance less a margin). The neighbours and the margin cover
what the sample misses between its designs: the error varies smoothly in log E, and the region
is checked on an independent sample (docs/lumped.md §3.15).

The map is stored as a bit mask (hex, one bit per cell, C order over the cell indices) in the
artifact's ``region`` block, so ``isj lumped solve`` and ``isj explore`` mark designs outside it
without the surrogate: :func:`in_region` is a table look-up.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np
from isj.lumped.model import MODULI

from isj.design import DEFAULT_PRESSURE_PA, Geometry
from isj.design_space import inside

from .guard import DEFAULT_TOLERANCE, _base, corner_designs, dense_designs, guard_set

#: Slices per ranged modulus.
DEFAULT_CELLS = 12

#: Dense designs the map is built from (2^18: about one per cell; the neighbours cover the rest).
DEFAULT_MAP_SAMPLE = 2**18

#: Margin below the tolerance (absolute, relative error) at which a sampled design marks its cell.
DEFAULT_MARGIN = 0.002


def _ranged(domain: Mapping) -> list[str]:
    return [k for k in MODULI if k in domain and domain[k][0] < domain[k][1]]


def cell_index(domain: Mapping, designs: Mapping[str, np.ndarray], cells: int) -> np.ndarray:
    """(n, d) integer cell indices of ``designs`` (moduli in Pa) in ``domain``'s ranged moduli.

    A design on the box's upper face falls in the last cell; designs outside the box get -1.
    """
    names = _ranged(domain)
    n = max((np.size(designs[k]) for k in names), default=0)
    out = np.empty((n, len(names)), dtype=np.int64)
    for j, k in enumerate(names):
        lo, hi = (float(v) for v in domain[k])
        v = np.broadcast_to(np.asarray(designs[k], dtype=float), (n,))
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.log(v / lo) / np.log(hi / lo)
        inside = (u >= -1e-9) & (u <= 1 + 1e-9)
        out[:, j] = np.where(inside, np.clip(np.floor(u * cells), 0, cells - 1), -1)
    return out


def _flat(idx: np.ndarray, cells: int) -> np.ndarray:
    return np.ravel_multi_index(tuple(idx.T), (cells,) * idx.shape[1]) if idx.size else np.zeros(0, int)


def _dilate(mask: np.ndarray) -> np.ndarray:
    """``mask`` (d-dimensional, bool) grown by one cell in every direction, diagonals included."""
    out = mask.copy()
    d = mask.ndim
    for shift in itertools.product((-1, 0, 1), repeat=d):
        if any(shift):
            src = tuple(slice(max(0, -s), mask.shape[i] - max(0, s)) for i, s in enumerate(shift))
            dst = tuple(slice(max(0, s), mask.shape[i] - max(0, -s)) for i, s in enumerate(shift))
            out[dst] |= mask[src]
    return out


def build_region(
    calibration,
    oracle,
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    cells: int = DEFAULT_CELLS,
    n_sample: int = DEFAULT_MAP_SAMPLE,
    seed: int = 0,
    margin: float = DEFAULT_MARGIN,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    geometry: Geometry | None = None,
) -> dict:
    """The ``region`` block of ``calibration``'s artifact, from the surrogate ``oracle``.

    Returns
    -------
    dict
        ``factors`` and ``domain`` (what the map holds for), ``tolerance``, ``margin``, ``cells``,
        ``moduli`` (the ranged ones, in cell order),
        ``outside`` (hex bit mask), ``n_sample``, ``seed``, ``n_cells_outside``,
        ``fraction_outside`` (of the cells), ``max_certified_error`` (over the sample and corners).
    """
    domain = {k: tuple(map(float, v)) for k, v in calibration.domain.items()}
    names = _ranged(domain)
    base = _base(oracle)
    threshold = tolerance - margin
    bad = np.zeros((cells,) * len(names), dtype=bool)
    worst = 0.0
    dense = dense_designs(domain, n_sample, seed, base)
    chunk = 2**16  # the guard holds a dozen arrays per design: chunks keep memory small
    sets = [corner_designs(domain, base)] + [
        {k: v[i : i + chunk] for k, v in dense.items()} for i in range(0, n_sample, chunk)
    ]
    for designs in sets:
        g = guard_set("region", calibration, oracle, designs, tolerance, pressure_pa, geometry)
        err = np.where(g.inside, g.max_certified, np.inf)
        worst = max(worst, float(np.max(err)) if err.size else 0.0)
        idx = cell_index(domain, g.designs, cells)[err > threshold]
        bad.flat[_flat(idx, cells)] = True
    outside = _dilate(bad)
    return {
        # the factors and domain the map holds for: any other factors (a refit, a user's file made
        # from this one) have no map (:func:`region_of`)
        "factors": {k: float(v) for k, v in calibration.factors.items()},
        "domain": {k: [float(lo), float(hi)] for k, (lo, hi) in domain.items()},
        "tolerance": float(tolerance),
        "margin": float(margin),
        "cells": int(cells),
        "moduli": names,
        "outside": np.packbits(outside.ravel()).tobytes().hex(),
        "n_sample": int(n_sample),
        "seed": int(seed),
        "n_cells_outside": int(outside.sum()),
        "fraction_outside": float(outside.mean()),
        "max_certified_error": worst,
    }


def region_of(calibration) -> dict:
    """``calibration``'s map if it was built for its factors and domain, else ``{}`` (no map).

    A calibration made from another by changing its factors or domain (``dataclasses.replace``)
    keeps the other's ``region`` block; the map does not hold for it, and is not used.
    """
    r = calibration.region
    if not r:
        return {}
    domain = {k: [float(lo), float(hi)] for k, (lo, hi) in calibration.domain.items()}
    if r.get("factors") != dict(calibration.factors) or r.get("domain") != domain:
        return {}
    return dict(r)


def in_region(region: Mapping, domain: Mapping, designs: Mapping[str, np.ndarray]) -> np.ndarray | None:
    """(n,) bool: the designs (moduli in Pa) inside the region where the tolerance holds.

    None when ``region`` is empty (a calibration without a map). Designs outside the calibrated
    domain are outside the region.
    """
    if not region:
        return None
    cells, names = int(region["cells"]), list(region["moduli"])
    bits = np.unpackbits(np.frombuffer(bytes.fromhex(region["outside"]), dtype=np.uint8))
    bits = bits[: cells ** len(names)].astype(bool)
    sub = {k: domain[k] for k in names}
    n = max((np.size(designs[k]) for k in designs), default=1)
    full = {k: np.broadcast_to(np.asarray(designs[k], dtype=float), (n,)) for k in names}
    idx = cell_index(sub, full, cells)
    known = np.all(idx >= 0, axis=1)
    out = np.zeros(n, dtype=bool)
    out[known] = ~bits[_flat(idx[known], cells)]
    # a modulus the map does not range must sit at its (pinned) calibrated value
    for k, (lo, hi) in domain.items():
        if k not in names and k in designs:
            v = np.broadcast_to(np.asarray(designs[k], dtype=float), (n,))
            out &= inside(v, lo, hi)
    return out


def region_summary(region: Mapping) -> str:
    """One line: the share of the domain outside the region and its tolerance."""
    if not region:
        return "no map of the region where the lumped model holds its tolerance"
    return (
        f"{100 * region['fraction_outside']:.2f} % of the calibrated domain lies outside the region "
        f"where the lumped model holds {100 * region['tolerance']:g} % (certified, "
        f"{region['cells']}^{len(region['moduli'])} cells)"
    )
