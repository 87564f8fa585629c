"""Anatomy and mechanical constants of the cat middle ear (docs/ear.md §5), in SI units.

Shared vocabulary of the whole-ear models: the FE model (``fem.ear.ear``) and
the lumped one (``lumped/``) read the same :class:`EarGeometry` and
:class:`EarMaterials`. This module imports only from :mod:`isj`.

Frame (m), that of ``fem.ear.eardrum.EardrumGeometry``: origin at the centre of
the tympanic ring's elliptical outline, which lies in the plane z = 0; x along
the projection of the manubrium, pointing superiorly (towards its tip and the
malleus head); z lateral (towards the ear canal), so that medial (into the
middle ear, towards the cochlea) is −z; y completes a right-handed frame
(anterior or posterior depending on the side: the model is symmetric enough
that it does not matter, and the defaults put the incus at −y).

Sources: the numbers cited to docs/ear.md come from the thesis's cat model
(thesis §6.4). Everything marked "estimate" is a plausible cat dimension chosen here,
not a measurement; it is a parameter so that its effect can be studied.

Layout of the defaults: the malleus–incus axis runs along y through
``body_reference_m``, 0.3 mm superior to the ring (x = 4.3 mm) and 2.5 mm
medial (estimates). The umbo lies 4.3 mm below it along x, the footplate's
centre 1.8 mm below it (anatomical lever ratio :attr:`EarGeometry.lever_ratio`
= 2.45, an estimate; published cat values are about 2–2.5), so the umbo and the
stapes move in phase. The footplate's centre is put at the axis's depth
(z = −2.5 mm) so that the stapes moves as a piston, as measured at low
frequency; with the footplate 1.86 mm medial to the axis instead (axis at
z = −1.2 mm), the footplate's in-plane motion equals its piston motion.
The 3-D pedicle-and-joint model hangs from the long process medially:
its z axis (stapes head → incus) points laterally (+z), its x axis (the
pedicle's bending direction) points inferiorly (−x), so a rotation of the
malleus–incus body that moves the umbo medially bends the pedicle with the
sign of the isolated model's load. The stapes's crura run medially from the
head to the footplate, whose normal (the piston direction) is −z.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .design import Geometry, check_positive
from .errors import InvalidParameter
from .validate import check_poisson

Vector = tuple[float, float, float]


def _check_vector(name: str, value, nonzero: bool = False) -> tuple[float, float, float]:
    ok = isinstance(value, tuple | list) and len(value) == 3
    ok = ok and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value
    )
    if not ok:
        raise InvalidParameter(f"{name} = {value!r}: must be a tuple of three finite numbers (m)")
    if nonzero and math.hypot(*value) == 0:
        raise InvalidParameter(f"{name} = {value!r}: must be a non-zero direction")
    return tuple(float(v) for v in value)


def _unit(v) -> tuple[float, float, float]:
    n = math.hypot(*v)
    return (v[0] / n, v[1] / n, v[2] / n)


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@dataclass(frozen=True)
class EarGeometry:
    """Positions (m) and dimensions (m, m²) of the cat middle ear; defaults with sources.

    Parameters
    ----------
    drum_semi_axis_manubrium_m, drum_semi_axis_transverse_m : half-axes of the ring's ellipse
        along x and y. Estimates: 4.0 and 3.2 mm (area π a b = 40.2 mm², docs/ear.md §5.2's "about 0.4 cm²").
    drum_cone_depth_m : depth of the umbo below the ring's plane. Estimate: 1.5 mm.
    drum_normalized_radius : radius of curvature of the drum's generators / chord: 1.19 (docs/ear.md §5.2).
    umbo_x_m : x of the umbo (which lies at (umbo_x, 0, −cone_depth)). Estimate: 0.
    manubrium_gap_m : ring-to-manubrium-tip distance along x. Estimate: 0.4 mm.
    body_reference_m : reference point of the malleus–incus rigid body: a point of the
        nominal anatomical axis, in the malleus head / incus body. Estimate: (4.3, 0, −2.5) mm.
    malleus_ligament_m : attachment of the anterior mallear ligament (anterior process,
        on the nominal axis). Estimate: (4.3, 1.5, −2.5) mm.
    incudal_lateral_m, incudal_medial_m : attachments of the lateral and medial bundles of
        the posterior incudal ligament (short process of the incus, posterior, 0.1 mm either
        side of the nominal axis in z). Estimates: (4.3, −1.2, −2.4) and (4.3, −1.2, −2.6) mm.
    long_process_end_m : end of the incus's long process: the centre of the far (+z_joint)
        face of the 3-D joint model's incus block, where the block meets the rest of the incus.
        Estimate: (2.5, −0.8, −0.845) mm (1.8 mm inferior to the axis, 0.8 mm posterior, and
        lateral enough that the footplate's centre, 0.655 + 1.0 mm further medial, lies at the
        axis's depth).
    joint_z_direction : direction of the joint model's z axis (stapes head → incus) in the
        ear: lateral, (0, 0, 1). The piston direction (footplate normal, into the
        cochlea) is its opposite.
    joint_x_direction : direction of the joint model's x axis (the pedicle's bending
        direction): inferior, (−1, 0, 0). Must be perpendicular to ``joint_z_direction``.
    joint_length_m : joint model's length along its z axis, stapes-head face to the incus's
        far face (m): 655 µm, :attr:`isj.design.Geometry.z_top` of the default geometry. With
        a joint model of another stack height, the ear models take it from the joint's
        geometry (:meth:`for_joint`): the long process's end stays where it is, and the stapes
        head and footplate move along the piston direction.
    crura_height_m : distance along the piston direction from the stapes-head face (joint
        model z = 0) to the footplate's mid-plane. Estimate: 1.0 mm (cat stapes ≈ 1.1 mm tall).
    footplate_area_m2 : area of the footplate's elliptical outline: 1.26 mm² (docs/ear.md §5.5).
    footplate_aspect : ratio of the outline's long to short axis. Estimate: 2.2.
    footplate_long_axis : direction of the outline's long axis (perpendicular to the piston
        direction): (0, 1, 0), anteroposterior, across the long process (estimate).
    footplate_centre_thickness_m : 20 µm (docs/ear.md §5.5).
    footplate_rim_thickness_m : 200 µm (docs/ear.md §5.5).
    footplate_rim_fraction : width of the thick rim as a fraction of the outline's radius
        (the outermost annulus of elements, 0.8–1 of the radius). Estimate: 0.2.
    footplate_rings : rings of nodes in the footplate's structured mesh (the last one is the
        outline). Not a physical dimension.
    annular_springs : number of equally spaced outline nodes carrying the annular ligament
        and cochlear load springs: 40 (docs/ear.md §5.5).
    """

    drum_semi_axis_manubrium_m: float = 4.0e-3
    drum_semi_axis_transverse_m: float = 3.2e-3
    drum_cone_depth_m: float = 1.5e-3
    drum_normalized_radius: float = 1.19
    umbo_x_m: float = 0.0
    manubrium_gap_m: float = 0.4e-3
    body_reference_m: Vector = (4.3e-3, 0.0, -2.5e-3)
    malleus_ligament_m: Vector = (4.3e-3, 1.5e-3, -2.5e-3)
    incudal_lateral_m: Vector = (4.3e-3, -1.2e-3, -2.4e-3)
    incudal_medial_m: Vector = (4.3e-3, -1.2e-3, -2.6e-3)
    long_process_end_m: Vector = (2.5e-3, -0.8e-3, -0.845e-3)
    joint_z_direction: Vector = (0.0, 0.0, 1.0)
    joint_x_direction: Vector = (-1.0, 0.0, 0.0)
    joint_length_m: float = Geometry().z_top
    crura_height_m: float = 1.0e-3
    footplate_area_m2: float = 1.26e-6
    footplate_aspect: float = 2.2
    footplate_long_axis: Vector = (0.0, 1.0, 0.0)
    footplate_centre_thickness_m: float = 20e-6
    footplate_rim_thickness_m: float = 200e-6
    footplate_rim_fraction: float = 0.2
    footplate_rings: int = 5
    annular_springs: int = 40

    def __post_init__(self) -> None:
        for name in (
            "drum_semi_axis_manubrium_m",
            "drum_semi_axis_transverse_m",
            "drum_cone_depth_m",
            "manubrium_gap_m",
            "joint_length_m",
            "crura_height_m",
            "footplate_centre_thickness_m",
            "footplate_rim_thickness_m",
        ):
            check_positive(name, getattr(self, name), "m")
        check_positive("footplate_area_m2", self.footplate_area_m2, "m^2")
        rho = self.drum_normalized_radius
        if not isinstance(rho, int | float) or math.isnan(rho) or not rho > 0.5:
            raise InvalidParameter(f"drum_normalized_radius = {rho!r}: must be > 0.5 (inf for a plain cone)")
        a, x_u = self.drum_semi_axis_manubrium_m, self.umbo_x_m
        if not isinstance(x_u, int | float) or not math.isfinite(x_u) or not -a < x_u < a:
            raise InvalidParameter(f"umbo_x_m = {x_u!r} m: must lie inside the ring, in (-{a}, {a})")
        if not self.manubrium_gap_m < a - x_u:
            raise InvalidParameter(f"manubrium_gap_m = {self.manubrium_gap_m!r} m: must be < {a - x_u} m")
        for name in (
            "body_reference_m",
            "malleus_ligament_m",
            "incudal_lateral_m",
            "incudal_medial_m",
            "long_process_end_m",
        ):
            object.__setattr__(self, name, _check_vector(name, getattr(self, name)))
        for name in ("joint_z_direction", "joint_x_direction", "footplate_long_axis"):
            object.__setattr__(self, name, _unit(_check_vector(name, getattr(self, name), nonzero=True)))
        for name in ("joint_x_direction", "footplate_long_axis"):
            if abs(_dot(getattr(self, name), self.joint_z_direction)) > 1e-9:
                raise InvalidParameter(
                    f"{name} = {getattr(self, name)!r}: must be perpendicular to joint_z_direction "
                    f"= {self.joint_z_direction!r}"
                )
        asp = self.footplate_aspect
        if isinstance(asp, bool) or not isinstance(asp, int | float) or not 1.0 <= asp < 100.0:
            raise InvalidParameter(f"footplate_aspect = {asp!r}: must lie in [1, 100)")
        f = self.footplate_rim_fraction
        if isinstance(f, bool) or not isinstance(f, int | float) or not 0.0 < f <= 0.5:
            raise InvalidParameter(f"footplate_rim_fraction = {f!r}: must lie in (0, 0.5]")
        for name, lo in (("footplate_rings", 2), ("annular_springs", 6)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < lo:
                raise InvalidParameter(f"{name} = {v!r}: must be an integer >= {lo}")

    # ------------------------------------------------------------------ derived

    @property
    def umbo_m(self) -> Vector:
        """Position of the umbo (m)."""
        return (self.umbo_x_m, 0.0, -self.drum_cone_depth_m)

    @property
    def manubrium_tip_m(self) -> Vector:
        """Superior end of the manubrium in the drum (m)."""
        a, x_u = self.drum_semi_axis_manubrium_m, self.umbo_x_m
        x = a - self.manubrium_gap_m
        return (x, 0.0, -self.drum_cone_depth_m * (a - x) / (a - x_u))

    @property
    def piston_direction(self) -> Vector:
        """Unit normal of the footplate pointing into the cochlea: −joint_z_direction."""
        return tuple(-c for c in self.joint_z_direction)

    @property
    def joint_y_direction(self) -> Vector:
        """The joint model's y axis in the ear: z × x (the axis of α and β)."""
        return _cross(self.joint_z_direction, self.joint_x_direction)

    @property
    def stapes_head_m(self) -> Vector:
        """Centre of the stapes-head face the isolated joint model clamps (its z = 0), m."""
        return tuple(
            p - self.joint_length_m * d
            for p, d in zip(self.long_process_end_m, self.joint_z_direction, strict=True)
        )

    @property
    def footplate_centre_m(self) -> Vector:
        """Centre of the footplate's mid-plane (m)."""
        n = self.piston_direction
        return tuple(p + self.crura_height_m * d for p, d in zip(self.stapes_head_m, n, strict=True))

    @property
    def footplate_semi_axes_m(self) -> tuple[float, float]:
        """Long and short half-axes of the footplate's outline (m): π a b = area, a / b = aspect."""
        b = math.sqrt(self.footplate_area_m2 / (math.pi * self.footplate_aspect))
        return self.footplate_aspect * b, b

    @property
    def lever_ratio(self) -> float:
        """Anatomical lever ratio: distance of the umbo from the nominal axis over that of the
        footplate's centre. The nominal axis is the line through the mallear ligament's
        attachment and the midpoint of the incudal bundles' attachments."""
        p = self.malleus_ligament_m
        q = tuple(0.5 * (a + b) for a, b in zip(self.incudal_lateral_m, self.incudal_medial_m, strict=True))
        d = _unit(tuple(b - a for a, b in zip(p, q, strict=True)))

        def dist(x):
            r = tuple(a - b for a, b in zip(x, p, strict=True))
            return math.hypot(*_cross(r, d))

        return dist(self.umbo_m) / dist(self.footplate_centre_m)

    def for_joint(self, joint_geometry: Geometry) -> EarGeometry:
        """This anatomy with the joint length of ``joint_geometry`` (its :attr:`~Geometry.z_top`, m).

        Any geometry the joint model accepts then fits the ear: the ear holds the joint by
        its two end faces only, so its length is the one dimension the ear must know.
        Returns ``self`` when the length already agrees (to 1e-9 relative).
        """
        z_top = joint_geometry.z_top
        if abs(z_top - self.joint_length_m) <= 1e-9 * z_top:
            return self
        return dataclasses.replace(self, joint_length_m=z_top)

    def replace(self, **changes) -> EarGeometry:
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class EarMaterials:
    """Moduli (Pa), Poisson's ratios and spring stiffnesses (N/m) of the cat middle ear (docs/ear.md §5).

    Parameters
    ----------
    drum_e_pa, drum_nu, drum_thickness_m : pars tensa, 20 MPa, 0.3, 40 µm (docs/ear.md §5.2).
    footplate_e_pa, footplate_nu : stapes footplate, 20 GPa (docs/ear.md §5.5), 0.3 (estimate).
    malleus_ligament_n_m : anterior mallear ligament, 4 kN/m in total over three springs
        (docs/ear.md §5.3), here three springs of a third each along x, y and z at
        :attr:`EarGeometry.malleus_ligament_m` (the directions are a modelling choice).
    incudal_lateral_n_m, incudal_medial_n_m : posterior incudal ligament, lateral bundle
        10 kN/m, medial bundle 30 kN/m (docs/ear.md §5.3); each bundle is an isotropic point spring
        (that stiffness along x, y and z) at its attachment (a modelling choice).
    annular_out_of_plane_n_m : annular ligament + cochlear load, each of the
        :attr:`EarGeometry.annular_springs` springs along the piston direction: 11 N/m (docs/ear.md §5.5).
    annular_in_plane_n_m : each annular spring's stiffness along each of the two in-plane
        directions: 9.9 N/m (docs/ear.md §5.5; isotropic in the plane is a modelling choice).
    """

    drum_e_pa: float = 20e6
    drum_nu: float = 0.3
    drum_thickness_m: float = 40e-6
    footplate_e_pa: float = 20e9
    footplate_nu: float = 0.3
    malleus_ligament_n_m: float = 4e3
    incudal_lateral_n_m: float = 10e3
    incudal_medial_n_m: float = 30e3
    annular_out_of_plane_n_m: float = 11.0
    annular_in_plane_n_m: float = 9.9

    def __post_init__(self) -> None:
        check_positive("drum_e_pa", self.drum_e_pa, "Pa")
        check_positive("footplate_e_pa", self.footplate_e_pa, "Pa")
        check_positive("drum_thickness_m", self.drum_thickness_m, "m")
        for name in ("drum_nu", "footplate_nu"):
            check_poisson(getattr(self, name), name)
        for name in (
            "malleus_ligament_n_m",
            "incudal_lateral_n_m",
            "incudal_medial_n_m",
            "annular_out_of_plane_n_m",
            "annular_in_plane_n_m",
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
                raise InvalidParameter(f"{name} = {v!r} N/m: must be a finite number >= 0")

    def replace(self, **changes) -> EarMaterials:
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class EarMasses:
    """Mass data of the whole ear (kg, m, kg/m³), read by both the FE and the lumped ear.

    All estimates (no cat values found here) except the bone density, the estimate of docs/model.md §2.1.

    Parameters
    ----------
    drum_density_kg_m3 : pars tensa, 1200 kg/m³ (estimate); the shell's consistent mass.
        :data:`lumped.ear.DEFAULT_EARDRUM` was measured with this value.
    footplate_density_kg_m3 : the FE footplate shell's density, bone, 2000 kg/m³
        (docs/dynamics.md §4.2, :attr:`isj.design.Materials.bone_density_kg_m3`). The footplate is part of
        the stapes: its shell mass is taken out of ``stapes_kg`` (see ``stapes_kg``).
    malleus_incus_kg : 6 mg (estimate)
    malleus_incus_gyration_m : isotropic radius of gyration about its centroid, 1.0 mm (estimate)
    malleus_incus_centroid_m : centroid (m); None: the body's reference point
        :attr:`EarGeometry.body_reference_m` (estimate)
    stapes_kg : the whole stapes (head, crura and footplate), 0.5 mg (estimate). The lumped ear
        has one rigid stapes of this mass; the FE ear's stapes superstructure (a rigid body)
        carries ``stapes_kg`` minus its footplate shell's mass, at the centroid that puts the
        whole stapes's centroid where ``stapes_centroid_fraction`` says.
    stapes_gyration_m : radius of gyration about the centroid, 0.4 mm (estimate); in the FE ear,
        that of the superstructure about its own centroid (the footplate shell adds its own).
    stapes_centroid_fraction : height of the whole stapes's centroid above the footplate's
        mid-plane / :attr:`EarGeometry.crura_height_m`: 0.3 (estimate)
    """

    drum_density_kg_m3: float = 1200.0
    footplate_density_kg_m3: float = 2000.0
    malleus_incus_kg: float = 6e-6
    malleus_incus_gyration_m: float = 1.0e-3
    malleus_incus_centroid_m: Vector | None = None
    stapes_kg: float = 0.5e-6
    stapes_gyration_m: float = 0.4e-3
    stapes_centroid_fraction: float = 0.3

    def __post_init__(self) -> None:
        for name, unit in (
            ("drum_density_kg_m3", "kg/m^3"),
            ("footplate_density_kg_m3", "kg/m^3"),
            ("malleus_incus_kg", "kg"),
            ("malleus_incus_gyration_m", "m"),
            ("stapes_kg", "kg"),
            ("stapes_gyration_m", "m"),
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
                raise InvalidParameter(f"{name} = {v!r} {unit}: must be a finite number >= 0")
        if self.malleus_incus_centroid_m is not None:
            c = _check_vector("malleus_incus_centroid_m", self.malleus_incus_centroid_m)
            object.__setattr__(self, "malleus_incus_centroid_m", c)
        f = self.stapes_centroid_fraction
        if isinstance(f, bool) or not isinstance(f, int | float) or not 0 <= f <= 1:
            raise InvalidParameter(f"stapes_centroid_fraction = {f!r}: must lie in [0, 1]")

    def malleus_incus_centroid(self, geometry: EarGeometry) -> Vector:
        """The malleus–incus body's centroid (m): ``malleus_incus_centroid_m`` or the reference point."""
        c = self.malleus_incus_centroid_m
        return geometry.body_reference_m if c is None else c

    def stapes_centroid(self, geometry: EarGeometry) -> Vector:
        """The whole stapes's centroid (m): ``stapes_centroid_fraction`` of the crura's height
        above the footplate's centre, towards the stapes head."""
        h = self.stapes_centroid_fraction * geometry.crura_height_m
        return tuple(
            p - h * d for p, d in zip(geometry.footplate_centre_m, geometry.piston_direction, strict=True)
        )

    def replace(self, **changes) -> EarMasses:
        return dataclasses.replace(self, **changes)


#: The eardrum's element size (m) in every FE ear, unless given: the coarsest drum whose H_V and
#: ΔH_V agree with the finest drum measured (0.075 mm) within 1 dB, 0.1 dB and 1° up to 10 kHz,
#: about 6,200 triangles (docs/ear.md §5.15, benchmarks/drum_convergence.py). A numerical
#: choice, not anatomy.
DEFAULT_DRUM_MESH_SIZE_M = 0.125e-3

#: Experimental cat references at low frequency, per Pa of ear-canal pressure (docs/ear.md §5.12):
#: umbo ≈ 53 nm/Pa (Guinan & Peake 1967); stapes 25–30 nm/Pa (Guinan & Peake 1967),
#: ≈ 30 nm/Pa (Decraemer et al. 2000).
EXPERIMENT_UMBO_M_PER_PA = 53e-9
EXPERIMENT_STAPES_M_PER_PA = (25e-9, 30e-9)

#: 100 dB SPL as a peak pressure (Pa), the thesis's stimulus (docs/ear.md §5.6): 20 µPa × 10^5 × √2.
SPL_100DB_PEAK_PA = 2.828
