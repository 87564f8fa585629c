"""Design parameters of the pedicle-and-joint model (docs/model.md §2.1–2.3), in SI units.

Two frozen dataclasses carry everything a model needs: :class:`Geometry` (what
the mesh depends on) and :class:`Materials` (what only the assembled matrices
depend on). Both validate themselves on construction and raise
:class:`InvalidParameter` with a one-line message naming the parameter and its
valid range.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields

from isj.errors import InvalidParameter
from isj.validate import check_poisson

#: Region names in region-id order. The id is the index in this tuple.
REGIONS: tuple[str, ...] = ("stapes", "gap", "plate", "pedicle", "incus", "capsule")

#: Regions made of bone (docs/model.md §2.1), for the default density.
BONE_REGIONS: frozenset[str] = frozenset({"stapes", "plate", "pedicle", "incus"})


def check_positive(name: str, value: float, unit: str) -> None:
    """InvalidParameter naming ``name`` unless ``value`` is a finite number > 0 (booleans refused)."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or value <= 0
    ):
        raise InvalidParameter(f"{name} = {value!r} {unit}: must be a finite number > 0")


#: Physical bounds (m) of each :class:`Geometry` field, (lowest, highest); see its docstring.
GEOMETRY_BOUNDS_M: dict[str, tuple[float, float]] = {
    "joint_x_m": (10e-6, 2e-3),
    "joint_y_m": (10e-6, 2e-3),
    "stapes_height_m": (10e-6, 2e-3),
    "gap_thickness_m": (5e-6, 0.5e-3),
    "plate_thickness_m": (10e-6, 2e-3),
    "pedicle_x_m": (10e-6, 2e-3),
    "pedicle_y_m": (10e-6, 2e-3),
    "pedicle_length_m": (10e-6, 2e-3),
    "incus_x_m": (10e-6, 2e-3),
    "incus_y_m": (10e-6, 2e-3),
    "incus_length_m": (10e-6, 2e-3),
    "capsule_thickness_m": (5e-6, 0.5e-3),
    "capsule_reach_m": (5e-6, 2e-3),
    "capsule_bond_m": (5e-6, 2e-3),
}


@dataclass(frozen=True)
class Geometry:
    """Dimensions of the pedicle-and-joint model (docs/model.md §2.2), all in metres.

    z runs along the load path from the clamped face of the stapes head (z = 0)
    to the incus; x is the pedicle's bending direction (its thin side). Stapes
    head, gap and lenticular plate share one cross-section ``joint_x_m`` ×
    ``joint_y_m``, which the capsule sleeve hugs.

    Every field must lie within physical bounds (:data:`GEOMETRY_BOUNDS_M`):

    - the thin soft layers, ``gap_thickness_m`` and ``capsule_thickness_m``, in
      [5 µm, 0.5 mm], and the capsule's ``capsule_reach_m`` and ``capsule_bond_m``
      in [5 µm, 2 mm]. At 5 µm the meshes keep the default geometry's quality;
      thinner layers degrade it, down to a degenerate mesh (the measurements:
      docs/history.md);
    - every other dimension in [10 µm, 2 mm]: the cat's pedicle, the thinnest
      bone here, is about 55 µm thick, and the whole stapes about 1.1 mm tall, so
      no part of the joint model is larger than about 2 mm.

    Further, the pedicle fits within the joint's and the incus's cross-sections,
    ``capsule_reach_m`` <= min(``stapes_height_m``, ``plate_thickness_m``) and
    ``capsule_bond_m`` <= ``capsule_reach_m``. A violation raises
    :class:`InvalidParameter` naming the field and its range.
    """

    joint_x_m: float = 300e-6
    joint_y_m: float = 300e-6
    stapes_height_m: float = 120e-6
    gap_thickness_m: float = 35e-6
    plate_thickness_m: float = 60e-6
    pedicle_x_m: float = 55e-6
    pedicle_y_m: float = 160e-6
    pedicle_length_m: float = 240e-6
    incus_x_m: float = 200e-6
    incus_y_m: float = 250e-6
    incus_length_m: float = 200e-6
    capsule_thickness_m: float = 30e-6
    capsule_reach_m: float = 40e-6
    capsule_bond_m: float = 20e-6

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            check_positive(f.name, value, "m")
            lo, hi = GEOMETRY_BOUNDS_M[f.name]
            if not lo <= value <= hi:
                raise InvalidParameter(f"{f.name} = {value!r} m: must lie in [{lo:g}, {hi:g}] m")
        for side in ("x", "y"):
            ped = getattr(self, f"pedicle_{side}_m")
            for other in ("joint", "incus"):
                lim = getattr(self, f"{other}_{side}_m")
                if ped > lim:
                    raise InvalidParameter(
                        f"pedicle_{side}_m = {ped!r} m: must be <= {other}_{side}_m = {lim!r} m"
                    )
        reach_max = min(self.stapes_height_m, self.plate_thickness_m)
        if self.capsule_reach_m > reach_max:
            raise InvalidParameter(
                f"capsule_reach_m = {self.capsule_reach_m!r} m: must be <= {reach_max!r} m "
                "(stapes height and plate thickness)"
            )
        if self.capsule_bond_m > self.capsule_reach_m:
            raise InvalidParameter(
                f"capsule_bond_m = {self.capsule_bond_m!r} m: must be <= capsule_reach_m "
                f"= {self.capsule_reach_m!r} m"
            )

    # z levels of the stack, derived (m)
    @property
    def z_gap(self) -> float:
        """z of the stapes-head face at the gap (m)."""
        return self.stapes_height_m

    @property
    def z_plate(self) -> float:
        """z of the plate face at the gap (m)."""
        return self.stapes_height_m + self.gap_thickness_m

    @property
    def z_pedicle(self) -> float:
        """z of the plate face at the pedicle (m)."""
        return self.z_plate + self.plate_thickness_m

    @property
    def z_incus(self) -> float:
        """z of the incus face at the pedicle (m)."""
        return self.z_pedicle + self.pedicle_length_m

    @property
    def z_top(self) -> float:
        """z of the far face of the incus block (m)."""
        return self.z_incus + self.incus_length_m

    def replace(self, **changes: float) -> Geometry:
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class Materials:
    """Young's moduli (Pa), ν and densities (kg/m³): docs/model.md §2.1 and docs/dynamics.md §4.2."""

    stapes_e_pa: float = 1e9
    gap_e_pa: float = 10e6
    plate_e_pa: float = 1e9
    pedicle_e_pa: float = 5e9
    incus_e_pa: float = 12e9
    capsule_e_pa: float = 50e6
    nu: float = 0.3
    bone_density_kg_m3: float = 2000.0
    soft_density_kg_m3: float = 1100.0

    def __post_init__(self) -> None:
        for name in REGIONS:
            check_positive(f"{name}_e_pa", getattr(self, f"{name}_e_pa"), "Pa")
        check_poisson(self.nu, "nu")
        check_positive("bone_density_kg_m3", self.bone_density_kg_m3, "kg/m^3")
        check_positive("soft_density_kg_m3", self.soft_density_kg_m3, "kg/m^3")

    def youngs(self, region: str) -> float:
        """Young's modulus of a region (Pa)."""
        return getattr(self, f"{region}_e_pa")

    def density(self, region: str) -> float:
        """Density of a region (kg/m³)."""
        return self.bone_density_kg_m3 if region in BONE_REGIONS else self.soft_density_kg_m3

    def replace(self, **changes: float) -> Materials:
        return dataclasses.replace(self, **changes)


def check_pressure(pressure_pa: float) -> float:
    """Validate a load pressure (Pa): finite and non-zero (the model is linear)."""
    if not isinstance(pressure_pa, int | float) or not math.isfinite(pressure_pa) or pressure_pa == 0:
        raise InvalidParameter(f"pressure_pa = {pressure_pa!r} Pa: must be finite and non-zero")
    return float(pressure_pa)


#: Default pressure on the incus's −x face (Pa): the pressure that makes the base
#: case α + β = 13.433 µrad (thesis Table 7.2) with the default geometry on a
#: converged P2 mesh. The model is linear, so p = 13.433 µrad / (α + β per Pa).
#: Mesh-converged at 29.6 Pa (benchmarks/mesh_study.py; graded P2 meshes up to
#: 800k dofs): β = 12.12 µrad (Richardson, observed order 1.9, two mesh families
#: agree within 0.1 %) and α = 1.82 ± 0.02 µrad (α converges slowly at the
#: capsule's bond lines), so α + β = 13.94 ± 0.02 µrad and
#: p = 29.6 × 13.433 / 13.94 = 28.5 Pa (± 0.2 %). An earlier independent estimate,
#: 29.6 Pa, came from meshes that did not resolve the singular edges.
DEFAULT_PRESSURE_PA: float = 28.5
