"""Marks of designs outside the region where the lumped model holds its tolerance (docs/lumped.md §3.15).

``isj lumped solve`` looks its design up in the calibration's stored map (``region``) and, outside
it, shows the certified surrogate's values beside the lumped ones when the surrogate of the
calibration's mesh is in the cache; it never builds one (minutes), it says how.
"""

from __future__ import annotations

from isj.design import Geometry, Materials

from . import _common as c


def cached_surrogate(
    order: int, resolution: float, geometry=None, incus_e_pa: float | None = None, **settings
):
    """The surrogate of a mesh if it is in the cache, never built here: ``(rom, None)`` or ``(None, why)``.

    The cache entry is found as :func:`isj.fem.rom.reduced_model` names it (``settings`` as its
    greedy settings; default: the defaults ``isj rom build`` and ``isj explore`` use), so a
    command that must stay fast (``isj lumped solve``) can show the surrogate's values when a
    build exists and say how to make one when not.
    """
    from isj.cachefile import DamagedEntry
    from isj.errors import MeshError

    try:
        from isj.design_space import DesignSpace
        from isj.fem.mesh import mesh_pedicle_joint
        from isj.fem.rom import ReducedModel, rom_cache_dir
        from isj.fem.rom.model import DEFAULT_TOL, cache_key

        geometry = geometry or Geometry()
        space = DesignSpace(incus_e_pa=Materials().incus_e_pa if incus_e_pa is None else float(incus_e_pa))
        mesh = mesh_pedicle_joint(geometry, resolution=resolution)
        keyed = {"tol": settings.pop("tol", DEFAULT_TOL), "resolution": resolution} | settings
        key = cache_key(mesh.content_hash(), order, geometry, space, keyed)
        path = rom_cache_dir() / f"rom-{key[:32]}.npz"
        if not path.exists():
            return None, (
                f"the surrogate of the P{order} mesh at resolution {resolution:g} is not built yet "
                f"(isj rom build --order {order} --resolution {resolution:g}: minutes, once)"
            )
        return ReducedModel.load(path), None
    except (ImportError, MeshError, DamagedEntry, OSError, ValueError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return None, f"no surrogate of the P{order} mesh at resolution {resolution:g}: {first}"


def region_marks(cal, designs, geometry, pressure_pa) -> dict:
    """``region`` (is the design inside the map of where the lumped model holds its tolerance?) and,
    outside it, ``surrogate`` (the certified surrogate's values, when its build is cached) or
    ``surrogate_note`` (why not). docs/lumped.md section 3.15."""
    from isj.calibration.region import in_region, region_of

    region = region_of(cal)
    inside = in_region(region, cal.domain, designs)
    if inside is None:
        return {"region": None}
    out = {"region": {"tolerance": float(region["tolerance"]), "inside": bool(inside[0])}}
    if inside[0]:
        return out
    fe = cal.fe_settings
    rom, why = cached_surrogate(int(fe.get("order", 2)), float(fe.get("resolution", 1.0)), geometry)
    if rom is None:
        return out | {"surrogate": None, "surrogate_note": why}
    import numpy as np

    from isj.calibration.guard import GUARDED, _inside

    full = {k: float(v) for k, v in designs.items() if k.endswith("_e_pa")}
    E = {k: np.atleast_1d(v) for k, v in full.items()}
    if not _inside(rom, E)[0]:
        return out | {"surrogate": None, "surrogate_note": "the design lies outside the surrogate's domain"}
    ev = rom.evaluate(np.array([[full[k] for k in rom.space.bounds]]), pressure_pa)
    keys = [*GUARDED, *GUARDED.values()]
    return out | {"surrogate": {k: float(np.asarray(ev[k])[0]) for k in keys}}


def print_region(out: dict) -> None:
    """The text line of :func:`region_marks`: only for a design outside the region."""
    r = out.get("region")
    if not r or r["inside"]:
        return
    print(f"OUTSIDE the region where the lumped model holds {100 * r['tolerance']:g} % of FE (certified)")
    s = out.get("surrogate")
    if s is None:
        print(f"  surrogate: {out['surrogate_note']}")
        return
    print(
        f"  surrogate (FE within its bound): alpha = {c.urad(s['alpha_rad'])} "
        f"+- {c.urad(s['alpha_bound_rad'])} urad, beta = {c.urad(s['beta_rad'])} "
        f"+- {c.urad(s['beta_bound_rad'])} urad, "
        f"beta/alpha = {s['beta_over_alpha']:.3f}"
    )
