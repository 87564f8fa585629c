"""Parametric pars tensa of the cat eardrum (docs/ear.md §5.2) and its triangle mesh.

Shape (Funnell & Laszlo 1978, as summarised in docs/ear.md §5.2): a cone with its apex
at the umbo, pointing medially, whose generators are circular arcs running
from the manubrium to the tympanic ring, with a normalised radius of curvature
of 1.19. Here "normalised" means the arc's radius divided by its chord (the
straight distance from the manubrium to the ring along that generator), so
every generator has the same shape whatever its length; ≥ 0.5 is needed for a
circle through both ends, and ∞ gives straight generators (a plain cone).

Coordinates (m): origin at the centre of the ring's elliptical outline, which
lies in the plane z = 0; x along the projection of the manubrium, pointing to
its superior end; z lateral (towards the ear canal), so the umbo sits at
(umbo_x, 0, −cone_depth). The manubrium is a straight line in the plane
y = 0 whose extension would meet the ring at (a, 0, 0); it stops short of the
ring by ``manubrium_gap_m`` (where the small pars flaccida of the cat would
be), so no node is both clamped to the ring and tied to the malleus.

Generators: a point whose projection lies beside the manubrium (umbo_x ≤ x ≤
top) belongs to the generator at right angles to the manubrium's projection
(the line x = const); beyond either end of the manubrium the generators fan
out from that end (the umbo below, the manubrium's tip above). The arcs bulge
laterally. Meshing happens on the flat projection (gmsh, with the manubrium
embedded as a line so its nodes are shared by both sides), and each node is
then lifted onto its generator.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from isj.design import check_positive
from isj.ear import DEFAULT_DRUM_MESH_SIZE_M, EarGeometry
from isj.errors import InvalidParameter

from .shell import ShellMaterial, pressure_load

#: Pars tensa of the cat (docs/ear.md §5.2: E = 20 MPa, ν = 0.3, thickness 40 µm). The density
#: is not in the thesis: 1200 kg/m³ is an estimate (soft collagenous tissue).
PARS_TENSA = ShellMaterial(e_pa=20e6, nu=0.3, thickness_m=40e-6, density_kg_m3=1200.0)


_EAR = EarGeometry()


@dataclass(frozen=True)
class EardrumGeometry:
    """Dimensions of the pars tensa (m) and its mesh size; the cat defaults with their sources.

    Parameters
    ----------
    semi_axis_manubrium_m : half-axis a of the elliptical ring along the manubrium (x).
        Estimate: 4.0 mm, chosen with the next so that π a b = 40.2 mm², docs/ear.md §5.2's
        "area about 0.4 cm²" (itself an estimate).
    semi_axis_transverse_m : half-axis b across the manubrium (y). Estimate: 3.2 mm (a/b = 1.25).
    cone_depth_m : depth of the umbo below the plane of the ring. Estimate: 1.5 mm,
        ≈ 0.2 × the mean ring diameter, the depth-to-diameter ratio of gerbil
        (0.77 mm / 4.1 mm) and human (≈ 2 mm / 9 mm) eardrums.
    normalized_radius : radius of curvature of each generator divided by its chord:
        1.19 (docs/ear.md §5.2). Must be > 0.5; ``math.inf`` gives straight generators.
    umbo_x_m : x of the umbo's projection. Estimate: 0, the centre of the outline.
    manubrium_gap_m : distance in x from the manubrium's superior tip to the ring.
        Estimate: 0.4 mm.
    mesh_size_m : target edge length of the triangles (measured in the projection).
        Not a physical dimension: the default, :data:`isj.ear.DEFAULT_DRUM_MESH_SIZE_M`
        (0.125 mm, ≈ 6,200 triangles), is the coarsest converged drum (docs/ear.md §5.15).
    """

    # defaults from the whole ear's anatomy (isj.ear), so the two cannot drift apart
    semi_axis_manubrium_m: float = _EAR.drum_semi_axis_manubrium_m
    semi_axis_transverse_m: float = _EAR.drum_semi_axis_transverse_m
    cone_depth_m: float = _EAR.drum_cone_depth_m
    normalized_radius: float = _EAR.drum_normalized_radius
    umbo_x_m: float = _EAR.umbo_x_m
    manubrium_gap_m: float = _EAR.manubrium_gap_m
    mesh_size_m: float = DEFAULT_DRUM_MESH_SIZE_M

    def __post_init__(self) -> None:
        for name in ("semi_axis_manubrium_m", "semi_axis_transverse_m", "cone_depth_m", "manubrium_gap_m"):
            check_positive(name, getattr(self, name), "m")
        rho = self.normalized_radius
        if not isinstance(rho, int | float) or math.isnan(rho) or not rho > 0.5:
            raise InvalidParameter(
                f"normalized_radius = {rho!r}: must be > 0.5 (inf for straight generators)"
            )
        a, x_u = self.semi_axis_manubrium_m, self.umbo_x_m
        if not isinstance(x_u, int | float) or not math.isfinite(x_u) or not -a < x_u < a:
            raise InvalidParameter(f"umbo_x_m = {x_u!r} m: must lie inside the ring, in (-{a}, {a})")
        if not self.manubrium_gap_m < a - x_u:
            raise InvalidParameter(
                f"manubrium_gap_m = {self.manubrium_gap_m!r} m: must be < {a - x_u} m (ring to umbo, in x)"
            )
        check_positive("mesh_size_m", self.mesh_size_m, "m")
        limit = min(self.manubrium_gap_m, self.semi_axis_transverse_m / 4)
        if self.mesh_size_m > limit:
            raise InvalidParameter(
                f"mesh_size_m = {self.mesh_size_m!r} m: must be <= {limit} m "
                "(the manubrium gap, and a quarter of the transverse half-axis)"
            )

    @property
    def manubrium_top_x_m(self) -> float:
        """x of the manubrium's superior tip (m)."""
        return self.semi_axis_manubrium_m - self.manubrium_gap_m

    @property
    def outline_area_m2(self) -> float:
        """Area enclosed by the elliptical ring, π a b (m²)."""
        return math.pi * self.semi_axis_manubrium_m * self.semi_axis_transverse_m

    def manubrium_z(self, x_m):
        """Depth z (m) of the manubrium at x: linear from −cone_depth at the umbo to 0 at the ring."""
        a = self.semi_axis_manubrium_m
        return -self.cone_depth_m * (a - np.asarray(x_m, dtype=float)) / (a - self.umbo_x_m)

    def replace(self, **changes) -> EardrumGeometry:
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True, eq=False)
class EardrumMesh:
    """Triangle mesh of the pars tensa.

    Attributes
    ----------
    nodes_m : (N, 3) coordinates (m), frame of :class:`EardrumGeometry`
    triangles : (M, 3) node indices; normals point laterally (+z side, towards the ear canal)
    node_sets : "ring" (tympanic ring, to clamp), "manubrium" (nodes along the manubrium,
        umbo and tip included, to tie to the malleus), "umbo" (the one apex node)
    geometry : the parameters it was built from
    """

    nodes_m: np.ndarray
    triangles: np.ndarray
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    geometry: EardrumGeometry = field(default_factory=EardrumGeometry)


# --------------------------------------------------------------------------- surface


def lift(geometry: EardrumGeometry, xy_m, on_ring=None, on_manubrium=None) -> np.ndarray:
    """Map points of the flat projection onto the eardrum surface.

    Parameters
    ----------
    geometry : the eardrum
    xy_m : (N, 2) projected positions (m), inside the elliptical outline
    on_ring, on_manubrium : optional (N,) booleans marking points known to lie on the
        ring or the manubrium: they are placed exactly there, whatever round-off says

    Returns
    -------
    (N, 3) points (m). A point at fraction ξ of the way along its projected
    generator goes to the point of the circular arc above the chord's fraction ξ.
    """
    g = geometry
    a, b = g.semi_axis_manubrium_m, g.semi_axis_transverse_m
    x_u, x_top = g.umbo_x_m, g.manubrium_top_x_m
    p = np.asarray(xy_m, dtype=float).reshape(-1, 2)
    x = p[:, 0]
    # Foot of each generator on the manubrium's projection (the segment y = 0, x_u ≤ x ≤ x_top).
    foot_x = np.clip(x, x_u, x_top)
    d = p - np.stack([foot_x, np.zeros_like(x)], axis=1)
    dist = np.linalg.norm(d, axis=1)
    on_m = dist <= 1e-12 * a if on_manubrium is None else np.asarray(on_manubrium, bool) | (dist == 0)
    direction = np.where(on_m[:, None], [0.0, 1.0], d / np.where(on_m, 1.0, dist)[:, None])
    # Distance s from the foot to the ring along the generator: ((fx + s dx)/a)² + (s dy/b)² = 1.
    qa = (direction[:, 0] / a) ** 2 + (direction[:, 1] / b) ** 2
    qb = 2 * foot_x * direction[:, 0] / a**2
    qc = (foot_x / a) ** 2 - 1.0
    s = (-qb + np.sqrt(qb**2 - 4 * qa * qc)) / (2 * qa)
    xi = np.where(on_m, 0.0, np.clip(dist / s, 0.0, 1.0))
    if on_ring is not None:
        xi = np.where(np.asarray(on_ring, bool), 1.0, xi)
    start = np.stack([foot_x, np.zeros_like(x), g.manubrium_z(foot_x)], axis=1)
    ring_xy = np.stack([foot_x, np.zeros_like(x)], axis=1) + s[:, None] * direction
    chord = np.concatenate([ring_xy, np.zeros((len(x), 1))], axis=1) - start
    c = np.linalg.norm(chord, axis=1)
    unit = chord / c[:, None]
    # Unit normal to the chord in its vertical plane, on the lateral (+z) side: the bulge.
    normal = np.array([0.0, 0.0, 1.0]) - unit[:, 2:3] * unit
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    if math.isinf(g.normalized_radius):
        sag = np.zeros_like(xi)
    else:
        r = g.normalized_radius * c
        sag = np.sqrt(r**2 - (c * (xi - 0.5)) ** 2) - np.sqrt(r**2 - c**2 / 4)
    out = start + xi[:, None] * chord + sag[:, None] * normal
    if on_ring is not None:  # exactly on the outline, in the plane of the ring
        ring = np.asarray(on_ring, bool)
        out[ring, :2], out[ring, 2] = p[ring], 0.0
    return out


# --------------------------------------------------------------------------- mesh


def _gmsh_flat_mesh(g: EardrumGeometry):
    """Mesh the projected outline with the manubrium embedded; return (xy m, tris, ring, manubrium, umbo)."""
    from isj.fem.mesh import import_gmsh, initialize_gmsh

    gmsh = import_gmsh()
    if gmsh.isInitialized():
        raise RuntimeError("gmsh is already initialised in this process; finalize it first")
    scale = 1e3  # build in millimetres: gmsh's tolerances are meant for sizes ~1
    a, b = g.semi_axis_manubrium_m * scale, g.semi_axis_transverse_m * scale
    h = g.mesh_size_m * scale
    initialize_gmsh(gmsh)
    try:
        # Determinism: one thread, fixed seed (as fem.mesh does for the 3-D model).
        for name, value in (
            ("General.Terminal", 0),
            ("General.NumThreads", 1),
            ("Mesh.MaxNumThreads2D", 1),
            ("Mesh.Algorithm", 6),
            ("Mesh.RandomSeed", 1),
            ("Mesh.MeshSizeMax", h),
        ):
            gmsh.option.setNumber(name, value)
        gmsh.model.add("eardrum")
        geo = gmsh.model.geo
        centre = geo.addPoint(0, 0, 0, h)
        ring_pts = [geo.addPoint(px, py, 0, h) for px, py in ((a, 0), (0, b), (-a, 0), (0, -b))]
        major = ring_pts[0] if a >= b else ring_pts[1]
        arcs = [geo.addEllipseArc(ring_pts[k], centre, major, ring_pts[(k + 1) % 4]) for k in range(4)]
        surface = geo.addPlaneSurface([geo.addCurveLoop(arcs)])
        umbo = geo.addPoint(g.umbo_x_m * scale, 0, 0, h)
        tip = geo.addPoint(g.manubrium_top_x_m * scale, 0, 0, h)
        manubrium = geo.addLine(umbo, tip)
        geo.synchronize()
        gmsh.model.mesh.embed(1, [manubrium], 2, surface)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, conn = gmsh.model.mesh.getElements(2, surface)
        tris = np.asarray(conn[list(types).index(2)], dtype=np.int64).reshape(-1, 3)
        ring = np.concatenate([gmsh.model.mesh.getNodes(1, c, includeBoundary=True)[0] for c in arcs])
        manu = gmsh.model.mesh.getNodes(1, manubrium, includeBoundary=True)[0]
        umbo_tag = gmsh.model.mesh.getNodes(0, umbo)[0]
    finally:
        gmsh.finalize()
    # Compact numbering over the nodes that triangles use, in gmsh tag order (deterministic).
    used = np.unique(tris)
    index = np.full(int(max(tags.max(), used.max())) + 1, -1, dtype=np.int64)
    index[used] = np.arange(used.size)
    xy = np.zeros((used.size, 2))
    xy[index[np.asarray(tags, dtype=np.int64)[np.isin(tags, used)]]] = (
        np.asarray(coords).reshape(-1, 3)[np.isin(tags, used), :2] / scale
    )
    return xy, index[tris], np.unique(index[ring]), np.unique(index[manu]), index[np.asarray(umbo_tag)]


def eardrum_mesh(geometry: EardrumGeometry | None = None) -> EardrumMesh:
    """Triangle mesh of the pars tensa (deterministic for a given geometry).

    Returns
    -------
    EardrumMesh with nodes (m) on the curved surface, triangles with lateral (+z)
    normals, and node sets "ring", "manubrium" and "umbo".
    """
    g = EardrumGeometry() if geometry is None else geometry
    xy, tris, ring, manubrium, umbo = _gmsh_flat_mesh(g)
    # Counter-clockwise in the projection, so that normals point laterally.
    p = xy[tris]
    cross = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (
        p[:, 2, 0] - p[:, 0, 0]
    )
    tris[cross < 0] = tris[cross < 0][:, [0, 2, 1]]
    n = len(xy)
    nodes = lift(g, xy, on_ring=np.isin(np.arange(n), ring), on_manubrium=np.isin(np.arange(n), manubrium))
    return EardrumMesh(
        nodes_m=nodes,
        triangles=tris,
        node_sets={"ring": ring, "manubrium": manubrium, "umbo": np.atleast_1d(umbo)},
        geometry=g,
    )


def ear_canal_load(mesh: EardrumMesh, pressure_pa: float) -> np.ndarray:
    """Nodal forces (6N,) of a uniform sound pressure in the ear canal (Pa).

    Positive pressure pushes the drum medially (−z), against the lateral normals
    of :attr:`EardrumMesh.triangles`. The total force is −p × the projected area along z.
    """
    return pressure_load(mesh.nodes_m, mesh.triangles, -pressure_pa)
