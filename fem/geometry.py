"""Gmsh (OpenCASCADE) builders for the pedicle-and-joint model and the pedicle cantilever.

docs/model.md §2.2 and §2.6. The builders add geometry, physical groups and a mesh-size
field to the *current* gmsh model; meshing and extraction live in :mod:`fem.mesh`.

Gmsh is imported inside the functions only, so that ``import fem.geometry``
works without gmsh (the packages must import without it).

Units: the public interface is in metres, but the gmsh model is built in
micrometres. OpenCASCADE's default tolerances (1e-7 model units) are meant for
models of size ~1, and metres would put the whole 655 µm stack below them.
:data:`GMSH_UNIT_M` converts back.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from isj.design import REGIONS, Geometry

#: Length of one gmsh model unit (m): the model is built in micrometres.
GMSH_UNIT_M = 1e-6

#: Default target element sizes at resolution 1 (m), one per region of :data:`REGIONS`.
#: Coarse on purpose: away from the singular edges (below) P2 elements of this
#: size already resolve the bending of the pedicle and plate; making every
#: region 0.7× finer changed α and β by < 0.1 % (benchmarks/mesh_study.py), so
#: the dofs go to the edges instead.
DEFAULT_SIZES_M: dict[str, float] = {
    "stapes": 270e-6,
    "gap": 60e-6,
    "plate": 150e-6,
    "pedicle": 60e-6,
    "incus": 270e-6,
    "capsule": 75e-6,
}

#: Default largest size gradient |dh/dx| (dimensionless) in the transition from a
#: fine region into a coarser neighbour: neighbouring elements differ by ≈ 1 + grading.
DEFAULT_GRADING = 0.6

#: Default element sizes at the singular edges at resolution 1 (m). Stresses are
#: singular along the pedicle's re-entrant end edges (bone on bone), along the
#: lines where the capsule's bonded strips start and end (a soft layer bonded to
#: bone next to a free interface: crack-like) and along the gap's rim (soft
#: layer between bones with a free side). Their compliance converges slowly on
#: uniform meshes (α and β were still moving by ~2 % per refinement), so the
#: mesh is graded towards those edges. Tuned with benchmarks/mesh_study.py.
#: The gap's rim is off by default (size = the gap's): it moved α by < 1 %.
DEFAULT_EDGE_SIZES_M: dict[str, float] = {
    "pedicle_edge": 3e-6,
    "capsule_edge": 8e-6,
    "gap_edge": 60e-6,
}

#: Default size gradient away from the singular edges (dimensionless).
DEFAULT_EDGE_GRADING = 0.6


@dataclass(frozen=True)
class MeshSizes:
    """Target element sizes per region and how fast sizes may grow between regions.

    Parameters
    ----------
    stapes_m, gap_m, plate_m, pedicle_m, incus_m, capsule_m : float
        Target edge length of the linear tetrahedra inside each region at
        resolution 1 (m).
    pedicle_edge_m, capsule_edge_m, gap_edge_m : float
        Target size at resolution 1 (m) at the singular edges: the pedicle's
        end edges, the capsule's bond lines, the gap's rim. A size at least
        the region's size switches that refinement off.
    edge_grading : float
        Size gradient |dh/dx| (dimensionless, > 0) away from those edges.
    grading : float
        Largest size gradient |dh/dx| (dimensionless, > 0) where a fine region's
        size spreads into a coarser neighbour; ≈ ratio − 1 between the sizes of
        adjacent elements. The transition zones are fixed in space (computed at
        resolution 1), so refining by ``resolution`` scales the whole size field
        by 1/R and keeps the meshes geometrically similar (what a convergence
        study needs).
    resolution : float
        Refinement factor R (dimensionless, > 0) that divides every size:
        R = 2 halves the element size everywhere (≈ 8× the tetrahedra).
    """

    stapes_m: float = DEFAULT_SIZES_M["stapes"]
    gap_m: float = DEFAULT_SIZES_M["gap"]
    plate_m: float = DEFAULT_SIZES_M["plate"]
    pedicle_m: float = DEFAULT_SIZES_M["pedicle"]
    incus_m: float = DEFAULT_SIZES_M["incus"]
    capsule_m: float = DEFAULT_SIZES_M["capsule"]
    grading: float = DEFAULT_GRADING
    pedicle_edge_m: float = DEFAULT_EDGE_SIZES_M["pedicle_edge"]
    capsule_edge_m: float = DEFAULT_EDGE_SIZES_M["capsule_edge"]
    gap_edge_m: float = DEFAULT_EDGE_SIZES_M["gap_edge"]
    edge_grading: float = DEFAULT_EDGE_GRADING
    resolution: float = 1.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, int | float) or not v > 0 or v == float("inf"):
                raise ValueError(f"MeshSizes.{f.name} = {v!r}: must be a finite number > 0")

    def size(self, region: str) -> float:
        """Target element size of ``region`` at this resolution (m)."""
        return getattr(self, f"{region}_m") / self.resolution

    def base_size(self, region: str) -> float:
        """Target element size of ``region`` at resolution 1 (m)."""
        return getattr(self, f"{region}_m")

    def refined(self, factor: float) -> MeshSizes:
        """These sizes with the resolution multiplied by ``factor``."""
        return dataclasses.replace(self, resolution=self.resolution * factor)

    def as_dict(self) -> dict[str, float]:
        return dataclasses.asdict(self)


# --------------------------------------------------------------------------- helpers


def _um(x_m: float) -> float:
    return x_m / GMSH_UNIT_M


def _centred_box(occ, wx: float, wy: float, z0: float, z1: float) -> int:
    """Box of width wx × wy centred on the z axis, from z0 to z1 (all µm)."""
    return occ.addBox(-wx / 2, -wy / 2, z0, wx, wy, z1 - z0)


def _sleeve(occ, wx: float, wy: float, t: float, z0: float, z1: float) -> int:
    """Rectangular sleeve of wall t around the wx × wy section, z0..z1 (µm)."""
    outer = _centred_box(occ, wx + 2 * t, wy + 2 * t, z0, z1)
    inner = _centred_box(occ, wx, wy, z0, z1)
    out, _ = occ.cut([(3, outer)], [(3, inner)])
    if len(out) != 1:
        raise RuntimeError(f"capsule sleeve piece z {z0}..{z1} µm: cut gave {len(out)} volumes")
    return out[0][1]


def _fragment(occ, pieces: list[tuple[str, int]]) -> dict[str, list[int]]:
    """Fragment all volumes together; return region name → volume tags after fragmenting.

    Fragmenting imprints every shared face on both sides, which makes the mesh
    conforming across all interfaces. The volumes do not overlap, so each input
    volume maps to exactly the output volumes that replace it.
    """
    dimtags = [(3, tag) for _, tag in pieces]
    _, out_map = occ.fragment(dimtags, [])
    occ.synchronize()
    regions: dict[str, list[int]] = {}
    for (name, _), children in zip(pieces, out_map, strict=True):
        regions.setdefault(name, []).extend(t for d, t in children if d == 3)
    return regions


def _boundary_surfaces(model, vols: list[int]) -> set[int]:
    out: set[int] = set()
    for v in vols:
        _, down = model.getAdjacencies(3, v)
        out.update(int(s) for s in down)
    return out


def _surfaces_where(model, surfaces, predicate, tol: float) -> list[int]:
    """Surfaces whose bounding box (µm) satisfies ``predicate(xmin, ymin, ..., tol)``."""
    return sorted(s for s in surfaces if predicate(*model.getBoundingBox(2, s), tol))


def _size_field(
    model,
    boxes: list[tuple[float, tuple[float, ...]]],
    sizes: MeshSizes,
    edges: list[tuple[list[int], float, float]] = (),
) -> None:
    """Per-region Box fields (VIn = region size) combined with Min.

    Each Box ramps linearly from its region's size to the coarsest size over a
    transition layer of thickness (h_coarse − h_region) / grading, computed at
    resolution 1 so the whole field scales as 1/R.

    ``edges``: (curve tags, size at the curves, size far away), all µm at
    resolution 1: a Distance + Threshold field grows the size linearly from the
    curves with slope ``sizes.edge_grading``.
    """
    mesh_field = model.mesh.field
    r = sizes.resolution
    h_max = max(h for h, _ in boxes)
    tags = []
    for h, (x0, y0, z0, x1, y1, z1) in boxes:
        f = mesh_field.add("Box")
        mesh_field.setNumber(f, "VIn", h / r)
        mesh_field.setNumber(f, "VOut", h_max / r)
        for key, val in zip(
            ("XMin", "YMin", "ZMin", "XMax", "YMax", "ZMax"), (x0, y0, z0, x1, y1, z1), strict=True
        ):
            mesh_field.setNumber(f, key, val)
        # Thickness 0 would make a step; any positive value gives a linear ramp.
        mesh_field.setNumber(f, "Thickness", max((h_max - h) / sizes.grading, 1e-3))
        tags.append(f)
    for curves, h_edge, h_far in edges:
        if not curves or h_edge >= h_far:
            continue
        d = mesh_field.add("Distance")
        mesh_field.setNumbers(d, "CurvesList", curves)
        # points per curve at which the distance is sampled: ≥ 2 per edge element
        longest = max(_curve_length(model, c) for c in curves)
        mesh_field.setNumber(d, "Sampling", int(min(2000, max(20, 2 * longest / h_edge))))
        th = mesh_field.add("Threshold")
        mesh_field.setNumber(th, "InField", d)
        mesh_field.setNumber(th, "SizeMin", h_edge / r)
        mesh_field.setNumber(th, "SizeMax", h_far / r)
        mesh_field.setNumber(th, "DistMin", 0.0)
        mesh_field.setNumber(th, "DistMax", (h_far - h_edge) / sizes.edge_grading)
        tags.append(th)
    fmin = mesh_field.add("Min")
    mesh_field.setNumbers(fmin, "FieldsList", tags)
    mesh_field.setAsBackgroundMesh(fmin)

    import gmsh

    # The field alone decides the sizes.
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h_max / r)


def _curve_length(model, c: int) -> float:
    b = model.getBoundingBox(1, c)
    return max(b[3] - b[0], b[4] - b[1], b[5] - b[2])


def _flat_curves(model, z: float, inside, tol: float) -> list[int]:
    """Curves lying in the plane z (µm) whose bounding box satisfies ``inside``."""
    out = []
    for _, c in model.getEntities(1):
        b = model.getBoundingBox(1, c)
        if abs(b[2] - z) < tol and abs(b[5] - z) < tol and inside(b):
            out.append(c)
    return sorted(out)


def _singular_edges(model, g: Geometry, sizes: MeshSizes, tol: float):
    """Edges where stresses are singular, with their sizes (µm at R = 1)."""
    px, py = _um(g.pedicle_x_m), _um(g.pedicle_y_m)
    jx, jy = _um(g.joint_x_m), _um(g.joint_y_m)
    lv = joint_levels_um(g)

    def in_pedicle(b):
        return (
            b[0] >= -px / 2 - tol
            and b[3] <= px / 2 + tol
            and b[1] >= -py / 2 - tol
            and (b[4] <= py / 2 + tol)
        )

    def on_joint_rim(b):  # a straight line along a side face of the joint (inner capsule face)
        return (abs(b[0] - b[3]) < tol and abs(abs(b[0]) - jx / 2) < tol) or (
            abs(b[1] - b[4]) < tol and abs(abs(b[1]) - jy / 2) < tol
        )

    pedicle = [c for z in (_um(g.z_pedicle), _um(g.z_incus)) for c in _flat_curves(model, z, in_pedicle, tol)]
    bond_lines = (lv["free_start"], lv["free_end"])  # where the free interface begins
    capsule = [c for z in bond_lines for c in _flat_curves(model, z, on_joint_rim, tol)]
    gap = [c for z in (_um(g.z_gap), _um(g.z_plate)) for c in _flat_curves(model, z, on_joint_rim, tol)]
    return [
        (pedicle, _um(sizes.pedicle_edge_m), _um(sizes.base_size("pedicle"))),
        (capsule, _um(sizes.capsule_edge_m), _um(sizes.base_size("capsule"))),
        (gap, _um(sizes.gap_edge_m), _um(sizes.base_size("gap"))),
    ]


# --------------------------------------------------------------------------- builders


def joint_levels_um(geometry: Geometry) -> dict[str, float]:
    """z levels of the joint model (µm): capsule ends and bonded/free boundaries."""
    g = geometry
    z_cap0 = _um(g.z_gap - g.capsule_reach_m)
    z_cap1 = _um(g.z_plate + g.capsule_reach_m)
    bond = _um(g.capsule_bond_m)
    return {
        "capsule_start": z_cap0,
        "free_start": z_cap0 + bond,
        "free_end": z_cap1 - bond,
        "capsule_end": z_cap1,
    }


def build_pedicle_joint(geometry: Geometry, sizes: MeshSizes) -> dict[str, list[int]]:
    """Add the pedicle-and-joint model (docs/model.md §2.2) to the current gmsh model.

    Boxes centred on the z axis, stacked along z: stapes head, gap, plate,
    pedicle, incus; the capsule is a sleeve of wall ``capsule_thickness_m``
    around the stapes head, gap and plate from z_gap − reach to z_plate + reach,
    built in three pieces so that the lines between its bonded ends and its
    free middle exist. Everything is fragmented (conforming mesh on shared faces).

    Physical groups: 3-D, one per name in :data:`isj.design.REGIONS`; 2-D
    ``"clamped"`` (stapes face z = 0), ``"loaded"`` (incus −x face) and
    ``"capsule_free"`` (capsule faces touching stapes/gap/plate over the free
    zone). Model units are µm (:data:`GMSH_UNIT_M`).

    Parameters
    ----------
    geometry : Geometry
        Dimensions (m).
    sizes : MeshSizes
        Element sizes (m) per region.

    Returns
    -------
    dict
        Gmsh entity tags: region name → volume tags, plus ``"clamped"``,
        ``"loaded"``, ``"capsule_free"`` and ``"capsule_bonded"`` (the capsule
        faces bonded to bone) → surface tags.
    """
    import gmsh

    g = geometry
    model = gmsh.model
    boxes = _joint_boxes_um(g)
    z_cap = _capsule_levels_um(g)
    regions = _add_joint_volumes(model.occ, boxes, g, z_cap)
    tol = 1e-3 * min(_um(g.capsule_thickness_m), _um(g.pedicle_x_m), _um(g.gap_thickness_m))
    surfaces, bonded = _joint_surfaces(model, regions, g, z_cap, tol)
    for name in REGIONS:
        model.addPhysicalGroup(3, regions[name], name=name)
    for name, tags in surfaces.items():
        model.addPhysicalGroup(2, tags, name=name)
    _size_field(
        model, _joint_field_boxes(boxes, g, sizes, z_cap), sizes, _singular_edges(model, g, sizes, tol)
    )
    return {**regions, **surfaces, "capsule_bonded": bonded}


def _joint_boxes_um(g: Geometry) -> dict[str, tuple[float, float, float, float]]:
    """The stacked boxes of the joint model (µm): region → (x width, y width, z0, z1)."""
    jx, jy = _um(g.joint_x_m), _um(g.joint_y_m)
    z_gap, z_plate = _um(g.z_gap), _um(g.z_plate)
    z_ped, z_inc = _um(g.z_pedicle), _um(g.z_incus)
    return {
        "stapes": (jx, jy, 0.0, z_gap),
        "gap": (jx, jy, z_gap, z_plate),
        "plate": (jx, jy, z_plate, z_ped),
        "pedicle": (_um(g.pedicle_x_m), _um(g.pedicle_y_m), z_ped, z_inc),
        "incus": (_um(g.incus_x_m), _um(g.incus_y_m), z_inc, _um(g.z_top)),
    }


def _capsule_levels_um(g: Geometry) -> list[float]:
    """z (µm) where the capsule starts, its free middle starts and ends, and the capsule ends."""
    lv = joint_levels_um(g)
    return [lv["capsule_start"], lv["free_start"], lv["free_end"], lv["capsule_end"]]


def _add_joint_volumes(occ, boxes: dict, g: Geometry, z_cap: list[float]) -> dict[str, list[int]]:
    """Add the boxes and the capsule's sleeve pieces, fragmented: region → volume tags.

    The capsule is built in up to three pieces (bonded end, free middle, bonded end) so that
    the lines between them exist; a piece of zero length is left out.
    """
    jx, jy = _um(g.joint_x_m), _um(g.joint_y_m)
    t = _um(g.capsule_thickness_m)
    pieces = [(name, _centred_box(occ, wx, wy, z0, z1)) for name, (wx, wy, z0, z1) in boxes.items()]
    pieces += [
        ("capsule", _sleeve(occ, jx, jy, t, z0, z1))
        for z0, z1 in zip(z_cap[:-1], z_cap[1:], strict=True)
        if z1 > z0
    ]
    regions = _fragment(occ, pieces)
    if set(regions) != set(REGIONS) or any(not v for v in regions.values()):
        raise RuntimeError(f"fragment lost a region: got {sorted(regions)}")
    return regions


def _joint_surfaces(
    model, regions: dict[str, list[int]], g: Geometry, z_cap: list[float], tol: float
) -> tuple[dict[str, list[int]], list[int]]:
    """The named faces ``clamped``, ``loaded``, ``capsule_free`` → surface tags, and the bonded capsule faces.

    The capsule faces touching the stapes, gap or plate are free between ``z_cap[1]`` and
    ``z_cap[2]`` and bonded elsewhere; ``tol`` (µm) is the slack of each bounding-box test.
    """
    ix = _um(g.incus_x_m)
    bone_side = set().union(*(_boundary_surfaces(model, regions[n]) for n in ("stapes", "gap", "plate")))
    capsule_inner = _boundary_surfaces(model, regions["capsule"]) & bone_side
    free = _surfaces_where(
        model, capsule_inner, lambda *b: b[2] >= z_cap[1] - b[6] and b[5] <= z_cap[2] + b[6], tol
    )
    bonded = sorted(capsule_inner - set(free))
    clamped = _surfaces_where(
        model,
        _boundary_surfaces(model, regions["stapes"]),
        lambda *b: abs(b[2]) < b[6] and abs(b[5]) < b[6],
        tol,
    )
    loaded = _surfaces_where(
        model,
        _boundary_surfaces(model, regions["incus"]),
        lambda *b: abs(b[0] + ix / 2) < b[6] and abs(b[3] + ix / 2) < b[6],
        tol,
    )
    surfaces = {"clamped": clamped, "loaded": loaded, "capsule_free": free}
    for name, tags in surfaces.items():
        if not tags:
            raise RuntimeError(f"no gmsh surface found for {name!r}")
    return surfaces, bonded


def _joint_field_boxes(boxes: dict, g: Geometry, sizes: MeshSizes, z_cap: list[float]) -> list:
    """Size-field boxes (µm at R = 1): one per stacked box, then one per capsule wall.

    Each is ``(size, (x0, y0, z0, x1, y1, z1))``, as :func:`_size_field` takes them.
    """
    field_boxes = [
        (_um(sizes.base_size(n)), (-wx / 2, -wy / 2, z0, wx / 2, wy / 2, z1))
        for n, (wx, wy, z0, z1) in boxes.items()
    ]
    # A Box field cannot describe a sleeve: use one box per wall so that the
    # capsule's fine size does not fill the joint it surrounds.
    jx, jy, t = _um(g.joint_x_m), _um(g.joint_y_m), _um(g.capsule_thickness_m)
    ax, ay, bx, by = jx / 2, jy / 2, jx / 2 + t, jy / 2 + t
    h_cap = _um(sizes.base_size("capsule"))
    for x0, y0, x1, y1 in (
        (-bx, -by, -ax, by),
        (ax, -by, bx, by),
        (-ax, -by, ax, -ay),
        (-ax, ay, ax, by),
    ):
        field_boxes.append((h_cap, (x0, y0, z_cap[0], x1, y1, z_cap[-1])))
    return field_boxes


def build_cantilever(geometry: Geometry, sizes: MeshSizes) -> dict[str, list[int]]:
    """Add the pedicle alone as a cantilever box (docs/model.md §2.6) to the current gmsh model.

    Box ``pedicle_x_m`` × ``pedicle_y_m`` × ``pedicle_length_m`` centred on the
    z axis, z from 0 to L. Physical groups: 3-D ``"pedicle"``; 2-D
    ``"clamped"`` (z = 0) and ``"loaded"`` (z = L). The element size is
    ``sizes.pedicle_m / sizes.resolution``. Model units are µm.

    Returns
    -------
    dict
        Gmsh entity tags: ``"pedicle"`` → volume tags, ``"clamped"``,
        ``"loaded"`` → surface tags.
    """
    import gmsh

    g = geometry
    model = gmsh.model
    occ = model.occ
    px, py, length = _um(g.pedicle_x_m), _um(g.pedicle_y_m), _um(g.pedicle_length_m)
    vol = _centred_box(occ, px, py, 0.0, length)
    occ.synchronize()
    tol = 1e-3 * min(px, py, length)
    bnd = _boundary_surfaces(model, [vol])
    clamped = _surfaces_where(model, bnd, lambda *b: abs(b[2]) < b[6] and abs(b[5]) < b[6], tol)
    loaded = _surfaces_where(
        model, bnd, lambda *b: abs(b[2] - length) < b[6] and abs(b[5] - length) < b[6], tol
    )
    model.addPhysicalGroup(3, [vol], name="pedicle")
    model.addPhysicalGroup(2, clamped, name="clamped")
    model.addPhysicalGroup(2, loaded, name="loaded")
    h = _um(sizes.base_size("pedicle"))
    _size_field(model, [(h, (-px / 2, -py / 2, 0.0, px / 2, py / 2, length))], sizes)
    return {"pedicle": [vol], "clamped": clamped, "loaded": loaded}
