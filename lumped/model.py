"""Beam-and-spring reduced model of the pedicle and the joint (docs/lumped.md §3), static.

The load path along z: the pressure on the incus's −x face makes a force
P = p · A_face at the face centroid z_load. It bends the pedicle (a beam
clamped into the lenticular plate), and the moment it carries flexes the joint
(gap and capsule) below the plate.

β, the rotation across the pedicle, is three compliances in series:

- beam bending, ∫ M/(E_p I) dz = P L d_mid / (E_p I), with d_mid the distance
  from z_load to the pedicle's mid-length;
- the pedicle's root turning in the plate, like a rigid punch in an elastic
  block, M_root / (E_plate b_x² b_y), reduced as the gap under the plate
  stiffens relative to it: 1 / (1 + f (E_gap/E_plate)^¼), the ¼ power of a
  beam on an elastic foundation's characteristic length;
- the same at its top, in the incus: M_top / (E_incus b_x² b_y).

α, the rotation across the joint under the moment M_j = P (z_load − z_joint),
comes from two paths in parallel plus a series term:

- the gap as a thin bonded layer, k_gap ∝ E_gap j_y j_x³ / (12 t);
- the capsule's ±x walls in tension and compression over their free length,
  k_cap ∝ E_cap A_wall r², in series with their attachments to the plate
  (∝ E_plate^¾ E_cap^¼ j_y j_x²: the strip's load spreads into the plate over a
  length that grows with the capsule's stiffness relative to the plate's; a fit
  with a free exponent gave 0.27) and to the stapes head (∝ E_stapes j_y j_x²);
- the faces of the plate and the stapes head turning under the joint moment,
  ∝ 1/(E j_y j_x²). The plate's term is weighted by e^(−s) cos s with
  s = f_s (10³ E_gap/E_plate)^n: the plate bends under the pedicle's root on
  the gap as on an elastic foundation, and the rotation that the point pair
  at ±0.4 w sees decays, and turns, as the foundation stiffens relative to the
  plate (the e^(−s) cos s of a beam on an elastic foundation). The exponent n
  depends on the joint (:data:`PLATE_SUPPORT_EXPONENT`). Bonded, n = ¾: the gap
  grips the plate's face in shear too, the thick plate (60 µm over a 300 µm
  span) and the layer deform together, and the FE results ask for ¾ (a free
  exponent fitted 0.73). Sliding, n = ¼: the gap only pushes on the plate, which then
  bends on it as a beam on an elastic foundation, whose characteristic length
  (E I / k)^¼ gives s ∝ (E_gap/E_plate)^¼ (Hetényi 1946; docs/lumped.md §3.14).
- load sharing between the two paths, w = k_gap k_cap / (k_gap + k_cap)² times
  f_share / (E_plate j_y j_x²): the plate carries the joint moment from the
  pedicle's root to two reactions in different places, the gap's under its
  face and the capsule's at its edges, and deforms between them. The term
  vanishes when either path carries the whole moment and is largest when they
  share it equally. With it the α residuals of the FE points are flat against
  log(k_cap/k_gap) (docs/lumped.md §3.3).
- the pedicle's root under the joint moment, ∝ f_pf / (E_pedicle j_y j_x²): the joint moment
  enters the plate through the pedicle's footprint, and the plate's face there turns with the
  root, so the face is stiffer when the pedicle is (docs/lumped.md §3.15; what led to it:
  docs/history.md).

Each term carries one dimensionless factor (``FACTOR_NAMES``), calibrated
against FE results (``calibration``). The equations are written once, in plain
arithmetic, so the same function evaluates numpy arrays (thousands of designs
at once) and builds CasADi expressions for the fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isj.design import DEFAULT_PRESSURE_PA, Geometry, Materials
from isj.errors import InvalidParameter

#: Calibrated dimensionless factors, in the order of :func:`equations`' ``factors``.
FACTOR_NAMES: tuple[str, ...] = (
    "pedicle_bending",
    "pedicle_root",
    "pedicle_top",
    "root_foundation",
    "gap",
    "capsule",
    "attachment_plate",
    "attachment_stapes",
    "plate_bulk",
    "stapes_bulk",
    "plate_support",
    "load_sharing",
    "root_plate",
    "pedicle_face",
)

#: Exponent of E_gap/E_plate in the plate face's foundation argument s, per joint (see the module
#: docstring): ¾ fitted on the bonded joint, ¼ the beam on an elastic foundation's for the sliding
#: face, which pushes on the plate without gripping it in shear.
PLATE_SUPPORT_EXPONENT: dict[str, float] = {"bonded": 0.75, "sliding": 0.25}

#: Largest plate-support argument s for which the geometry calibration is fitted and claimed: at
#: π/2 the plate face's weight e^(−s) cos s changes sign. Past it (a thin, soft plate under a
#: stiff gap, 2.4 % of the valid geometry-and-moduli box) the FE point pair and the form part
#: ways: held-out errors there reached 7.6 %, below it 2.7 % (docs/lumped.md §3.16).
PLATE_SUPPORT_LIMIT = math.pi / 2

#: Geometric scaling of the terms (docs/lumped.md §3.13): powers of dimensionless ratios of a
#: geometry's dimensions to the default geometry's (h plate, t gap, t_c capsule wall, b_x, b_y
#: pedicle, bond, L_free the capsule's free length), so every one is 1 at the default geometry
#: and the equations there are those the moduli-only calibration was fitted with. The forms
#: (which term sees which dimension, and the sign) follow the FE slices of
#: benchmarks/geometry_slices.py; the exponents were fitted free, with the factors, on the
#: training designs (geometry and moduli varied together) and the slices, then rounded (the
#: spread of the free values over subsets of the data in the comments). Empirical: the plate
#: (60 µm on a 300 µm span over a soft gap) is neither thin nor thick, so plate theory's
#: exponents do not hold (as for PLATE_SUPPORT_EXPONENT's bonded value).
GEOMETRY_EXPONENTS: dict[str, float] = {
    # the gap's support of the pedicle's root grows as the plate and the gap thin
    "foundation_plate": 3.0,  # (h0/h)^3 in F; free 2.7-3.0
    "foundation_gap": 0.5,  # (t0/t)^½ in F; free 0.5-0.6
    # the plate bending under the root on the gap (the root_plate factor's term): grows fast
    # as the plate thins, and does not see the pedicle's thickness b_x (the punch does)
    "root_plate_bending": 4.5,  # (h0/h)^4.5; free 4.4-4.9
    # the plate's face under the joint moment, which enters through the pedicle's footprint
    "plate_face_width": 1.5,  # (b_y0/b_y)^1.5; free 1.4-1.6
    "plate_face_thickness": 4.0,  # (h0/h)^4; free 4.1-4.5
    # the foundation argument s of the plate's face: the gap supports a thin plate more
    "support_gap": 1.25,  # (t0/t)^1.25 in s; free 1.1-1.3
    "support_plate": 2.0,  # (h0/h)^2 in s; free 1.6-2.2
    # the capsule's walls: FE's α barely sees their thickness (slices: ±1 % over ±25 %), and
    # their free length as L_free^-½ rather than L_free^-1 (their ends are not clamped)
    "capsule_wall": -1.25,  # (t_c/t_c0)^-1.25 on 2 A_wall r² / L_free; free -1.3 (factors fixed)
    "capsule_free": 0.5,  # (L_free/L_free0)^½ on it; free 0.45 (factors fixed)
    # the capsule's anchorage grows with its bonded length
    "attachment_bond": 1.5,  # (bond/bond0)^1.5; free 1.5 (factors fixed)
}

#: Terms of :func:`equations` that a calibration may scale with the geometry (its
#: ``geometry_scaling``, docs/lumped.md §3.16), each with the :class:`Lever` field it multiplies.
#: A term's scale is a product of powers of the dimensions' ratios to the default geometry's,
#: Π (d/d0)^c over :data:`SCALING_DIMENSIONS`, so it is 1 on the default geometry.
SCALED_TERMS: dict[str, str] = {
    # beta
    "pedicle_bending": "beam",
    "pedicle_root": "root",
    "pedicle_top": "top",
    "root_foundation": "foundation",
    "root_plate": "root_plate",
    # alpha
    "gap": "gap",
    "capsule": "capsule",
    "attachment_plate": "attachment_plate_scale",
    "attachment_stapes": "attachment_stapes_scale",
    "plate_bulk": "plate_face",
    "plate_support": "support",
    "stapes_bulk": "stapes_face",
    "pedicle_face": "pedicle_face_scale",
    "load_sharing": "sharing",
}

#: Dimensions a calibration's ``geometry_scaling`` may use (:data:`SCALED_TERMS`): those the
#: geometry calibration varies (calibration.doe.GEOMETRY_DOMAIN_M).
SCALING_DIMENSIONS: tuple[str, ...] = (
    "pedicle_x_m",
    "pedicle_y_m",
    "pedicle_length_m",
    "gap_thickness_m",
    "capsule_thickness_m",
    "capsule_reach_m",
    "capsule_bond_m",
    "plate_thickness_m",
)

#: Moduli the lumped model reads (Pa), as in :class:`isj.design.Materials`.
MODULI: tuple[str, ...] = (
    "pedicle_e_pa",
    "gap_e_pa",
    "capsule_e_pa",
    "plate_e_pa",
    "stapes_e_pa",
    "incus_e_pa",
)


_DEFAULT = Geometry()


@dataclass(frozen=True)
class Lever:
    """Geometric constants of the load path (SI), derived once from a Geometry."""

    force_per_pa: float  # N/Pa: area of the loaded face
    beam: float  # L d_mid / I (1/m²): beam bending per unit force and modulus
    root: float  # M_root per N / (b_x² b_y) (1/m²)
    top: float  # M_top per N / (b_x² b_y) (1/m²)
    joint_arm: float  # z_load − z_joint (m)
    gap: float  # j_y j_x³ / (12 t) (m³): rotational stiffness per unit modulus
    capsule: float  # 2 A_wall r² / L_free (m³)
    attachment: float  # j_y j_x² (m³)
    bulk: float  # 1 / (j_y j_x²) (1/m³)
    # geometric scaling (GEOMETRY_EXPONENTS), dimensionless, 1 at the default geometry
    foundation: float = 1.0  # on (10³ E_gap/E_plate)^¼ in F
    root_plate: float = (
        0.0  # M_root per N / (b_x0² b_y) × (h0/h)^4.5 (1/m²): the plate bending under the root
    )
    plate_face: float = 1.0  # on the plate face's e^(−s) cos s term
    support: float = 1.0  # on s
    # a calibration's geometry_scaling (SCALED_TERMS) of the terms that share a field above
    attachment_plate_scale: float = 1.0
    attachment_stapes_scale: float = 1.0
    stapes_face: float = 1.0
    pedicle_face_scale: float = 1.0
    sharing: float = 1.0

    @classmethod
    def from_geometry(cls, g: Geometry, scaling: dict | None = None) -> Lever:
        """The constants of ``g``; ``scaling`` a calibration's ``geometry_scaling``.

        ``scaling`` maps a term of :data:`SCALED_TERMS` to exponents of :data:`SCALING_DIMENSIONS`:
        the term's field is multiplied by Π (d/d0)^c (none: the forms above alone).
        """
        lever = cls._from_geometry(g)
        if not scaling:
            return lever
        import dataclasses

        changes = {}
        for term, exponents in scaling.items():
            field = SCALED_TERMS[term]
            scale = 1.0
            for dim, c in exponents.items():
                scale *= (getattr(g, dim) / getattr(_DEFAULT, dim)) ** c
            changes[field] = changes.get(field, getattr(lever, field)) * scale
        return dataclasses.replace(lever, **changes)

    @classmethod
    def _from_geometry(cls, g: Geometry) -> Lever:
        z_load = g.z_incus + g.incus_length_m / 2
        bx, by, L = g.pedicle_x_m, g.pedicle_y_m, g.pedicle_length_m
        inertia = by * bx**3 / 12
        d_mid = z_load - (g.z_pedicle + g.z_incus) / 2
        punch = bx**2 * by
        jx, jy, t = g.joint_x_m, g.joint_y_m, g.gap_thickness_m
        tc = g.capsule_thickness_m
        free = g.gap_thickness_m + 2 * (g.capsule_reach_m - g.capsule_bond_m)
        wall = (jy + 2 * tc) * tc
        r = jx / 2 + tc / 2
        x = GEOMETRY_EXPONENTS
        d = _DEFAULT
        h = d.plate_thickness_m / g.plate_thickness_m  # h0/h
        tg = d.gap_thickness_m / t  # t0/t
        root = (z_load - g.z_pedicle) / punch
        free0 = d.gap_thickness_m + 2 * (d.capsule_reach_m - d.capsule_bond_m)
        return cls(
            force_per_pa=g.incus_y_m * g.incus_length_m,
            beam=L * d_mid / inertia,
            root=root,
            top=(z_load - g.z_incus) / punch,
            joint_arm=z_load - (g.z_gap + g.z_plate) / 2,
            gap=jy * jx**3 / (12 * t),
            capsule=2
            * wall
            * r**2
            / free
            * (tc / d.capsule_thickness_m) ** x["capsule_wall"]
            * (free / free0) ** x["capsule_free"],
            attachment=jy * jx**2 * (g.capsule_bond_m / d.capsule_bond_m) ** x["attachment_bond"],
            bulk=1 / (jy * jx**2),
            foundation=h ** x["foundation_plate"] * tg ** x["foundation_gap"],
            # the plate's bending, unlike the punch, does not see the pedicle's thickness b_x
            root_plate=root * (bx / d.pedicle_x_m) ** 2 * h ** x["root_plate_bending"],
            plate_face=(d.pedicle_y_m / by) ** x["plate_face_width"] * h ** x["plate_face_thickness"],
            support=tg ** x["support_gap"] * h ** x["support_plate"],
        )

    @classmethod
    def from_geometries(cls, geometries, scaling: dict | None = None) -> Lever:
        """The constants of many geometries at once: one array (over the geometries) per field."""
        levers = [cls.from_geometry(g, scaling) for g in geometries]
        return cls(**{f: np.array([getattr(lv, f) for lv in levers]) for f in cls.__dataclass_fields__})


def equations(E, factors, lever: Lever, joint: str = "bonded"):
    """α and β per pascal (rad/Pa) from moduli ``E`` (Pa) and the calibrated factors.

    Plain arithmetic only, so that ``E`` and ``factors`` may be floats, numpy
    arrays (broadcast) or CasADi symbols alike.

    Parameters
    ----------
    E : mapping with the keys of :data:`MODULI`
    factors : sequence of the factors in :data:`FACTOR_NAMES` order
    lever : geometric constants
    joint : "bonded" or "sliding", the joint the factors were calibrated on (it sets
        :data:`PLATE_SUPPORT_EXPONENT`)
    """
    if joint not in PLATE_SUPPORT_EXPONENT:
        raise InvalidParameter(f"joint = {joint!r}: must be one of {', '.join(PLATE_SUPPORT_EXPONENT)}")
    (
        f_beam,
        f_root,
        f_top,
        f_fdn,
        f_gap,
        f_cap,
        f_att_p,
        f_att_s,
        f_plate,
        f_stapes,
        f_support,
        f_share,
        f_rp,
        f_pf,
    ) = (factors[i] for i in range(len(FACTOR_NAMES)))
    exp, cos = _exp_cos(E["gap_e_pa"], factors[0])
    P = lever.force_per_pa
    e_gap, e_plate, e_stapes = E["gap_e_pa"], E["plate_e_pa"], E["stapes_e_pa"]
    foundation = 1 + f_fdn * lever.foundation * (1e3 * e_gap / e_plate) ** 0.25
    beta = P * (
        f_beam * lever.beam / E["pedicle_e_pa"]
        + (f_root * lever.root + f_rp * lever.root_plate) / e_plate / foundation
        + f_top * lever.top / E["incus_e_pa"]
    )
    k_gap = f_gap * lever.gap * e_gap
    e_cap = E["capsule_e_pa"]
    k_cap = 1 / (
        1 / (f_cap * lever.capsule * e_cap)
        + 1 / (f_att_p * lever.attachment * lever.attachment_plate_scale * e_plate**0.75 * e_cap**0.25)
        + 1 / (f_att_s * lever.attachment * lever.attachment_stapes_scale * e_stapes)
    )
    s = plate_support_argument(f_support, lever, e_gap, e_plate, joint)
    sharing = k_gap * k_cap / (k_gap + k_cap) ** 2
    # the footprint's scaling is the plate face's under the root only: the load sharing is the
    # plate's deformation between the gap's and the capsule's reactions, over the joint's section
    plate = (lever.plate_face * f_plate * exp(-s) * cos(s) + lever.sharing * f_share * sharing) / e_plate
    # the pedicle's root as part of the plate's face under the joint moment (pedicle_face; 0 in
    # calibrations before format 5, and + 0.0 leaves their α bit for bit)
    bulk = lever.bulk * (
        plate + lever.stapes_face * f_stapes / e_stapes + lever.pedicle_face_scale * f_pf / E["pedicle_e_pa"]
    )
    alpha = P * lever.joint_arm * (1 / (k_gap + k_cap) + bulk)
    return alpha, beta


def plate_support_argument(f_support, lever: Lever, e_gap, e_plate, joint: str = "bonded"):
    """s of the plate face's weight e^(−s) cos s in :func:`equations` (dimensionless).

    The geometry calibration holds only up to :data:`PLATE_SUPPORT_LIMIT` (its
    ``training["plate_support_limit"]``; docs/lumped.md §3.16).
    """
    return f_support * lever.support * (1e3 * e_gap / e_plate) ** PLATE_SUPPORT_EXPONENT[joint]


def _exp_cos(*values):
    """exp and cos for the array backend of ``values``: CasADi's for symbols, numpy's otherwise."""
    if any(type(v).__module__.startswith("casadi") for v in values):
        import casadi as ca

        return ca.exp, ca.cos
    return np.exp, np.cos


@dataclass(frozen=True)
class StaticResponse:
    """Lumped static response (arrays over designs; SI)."""

    alpha_rad: np.ndarray
    beta_rad: np.ndarray

    @property
    def sum_rad(self) -> np.ndarray:
        return self.alpha_rad + self.beta_rad

    @property
    def ratio(self) -> np.ndarray:
        return self.beta_rad / self.alpha_rad


def moduli_arrays(designs=None, **moduli) -> dict[str, np.ndarray]:
    """Moduli (Pa) as broadcastable arrays, defaults from :class:`Materials` for missing ones."""
    base = Materials()
    src = dict(designs or {}, **moduli)
    out = {}
    for k in MODULI:
        v = np.asarray(src.get(k, getattr(base, k)), dtype=float)
        if np.any(~np.isfinite(v)) or np.any(v <= 0):
            from isj.errors import InvalidParameter

            raise InvalidParameter(f"{k}: every value must be a finite number > 0 (Pa)")
        out[k] = v
    return out


def static_response(
    factors,
    geometry: Geometry | None = None,
    pressure_pa: float = DEFAULT_PRESSURE_PA,
    *,
    joint: str = "bonded",
    scaling: dict | None = None,
    **moduli,
) -> StaticResponse:
    """α and β (rad) for arrays of moduli (Pa), vectorised over designs, for the factors' ``joint``.

    ``scaling``: the calibration's ``geometry_scaling`` (:meth:`Lever.from_geometry`).
    """
    lever = Lever.from_geometry(geometry or Geometry(), scaling)
    a, b = equations(moduli_arrays(**moduli), np.asarray(factors, dtype=float), lever, joint)
    return StaticResponse(alpha_rad=a * pressure_pa, beta_rad=b * pressure_pa)
