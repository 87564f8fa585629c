"""A lumped cat ossicular chain (docs/ear.md §5.10): umbo and stapes per Pa.

Second-order model M q̈ + E q̇ + K(1 + iη) q = B p, y = C q (``SecondOrderModel``
of :mod:`lumped.dynamics`), input p the ear-canal pressure (Pa), SI units.

Coordinates q (the ear's frame, :mod:`isj.ear`):

- ``u_x, u_y, u_z, th_x, th_y, th_z``: the malleus–incus body as one rigid body,
  its translation (m) and rotation (rad) at :attr:`isj.ear.EarGeometry.body_reference_m`,
  on the ligament springs (as the FE ear: the anterior mallear ligament as three
  springs of k/3 along x, y, z; each incudal bundle isotropic, k I). With
  ``body="rotation"`` the body only turns about its nominal axis (the ligament line,
  ``th_axis``, the textbook one-dof ossicle); the FE body's axis, free to move, then
  lies elsewhere, and the umbo comes out ≈ 17 % low (``tests/test_lumped_ear.py`` checks it).
- ``alpha``, ``beta`` (rad): the joint's and the pedicle's relative rotations about
  the joint model's y axis, as in :func:`lumped.dynamics.chain_model` (α the joint's
  rotation about its mid-plane z_j = (z_gap + z_plate)/2, β = the pedicle's root and top
  rotations plus its tip's rotation as a Timoshenko cantilever). The chain's joint and
  pedicle springs, massless here, are condensed exactly onto (α, β)
  (:func:`lumped.dynamics.joint_coupling`): a 2 × 2 stiffness and the incus's rigid motion
  relative to the stapes per unit α and β (an x translation at z_j and a rotation), so
  that the pedicle's effective pivot follows the load the ear puts on it; under the
  isolated model's load they give the calibrated static α_P, β_P
  (:func:`lumped.model.equations`). The chain's joint shear (calibrated on the isolated
  model's second mode only) and the stapes head's bending are left out of the ear.
  **Mapping into the ear**: the stapes (head, crura, footplate: one rigid body) moves
  relative to the incus by minus that relative motion, about and along the joint
  model's axes placed at the stapes head (``EarGeometry.stapes_head_m``, z along
  ``joint_z_direction``, x along ``joint_x_direction``). Everything else in the coupling is rigid:
  no axial (piston-direction) compliance, no bending about the joint's x axis, no
  torsion, because the calibrated model gives none of them. Dropped with
  ``rigid_joint=True`` (the FE ear's ``joint=None``).
- ``w`` (m): the eardrum's uncoupled part, the mean displacement over the ring's
  outline area A_r = π a b of the drum's shape under pressure with the manubrium held
  (volume A_r w, compliance C_d, acoustic mass M_a).

The drum: its part that moves with the manubrium is condensed exactly (statics)
onto the body's six dofs: a 6-vector of load per Pa (the effective area), a
6 × 6 stiffness and mass (:class:`EardrumParameters`, measured on the FE drum by
:func:`fem.ear.lumped_params.eardrum_parameters`). The stapes's footplate is rigid,
on the annular ligament + cochlear load: ``annular_springs`` point springs on its
elliptical outline (11 N/m out of plane, 9.9 N/m in plane, docs/ear.md §5.5), as the FE ear.

Masses (estimates unless stated): eardrum from the FE shell's consistent mass
(density 1200 kg/m³, an estimate; 2.07 mg over the drum's surface);
malleus + incus 6 mg, an estimate (no cat value found here), centroid at the body's
reference point, radius of gyration 1.0 mm (estimate); stapes 0.5 mg (estimate),
centroid 0.3 of the crura's height above the footplate, radius of gyration 0.4 mm
(estimate); the pedicle-and-joint regions (micrograms) are neglected.

Damping per part (:class:`isj.damping.Damping`, docs/dynamics.md §4.3; defaults: the published
loss factors): the drum's condensed stiffness and its uncoupled shape take the eardrum's loss
factor and Rayleigh b, the ligament springs their sets', the annular springs the annular
ligament's, the condensed joint the joint regions' in proportion to their share of it
(:mod:`isj.lumped.damping`); the cochlear resistance R = Z_C A² is a dashpot along the piston
direction, R/n at each of the n annular springs, as in the FE ear. Rayleigh a: the drum's mass
takes the eardrum's, the malleus–incus body the incus's, the whole stapes (footplate
included) the stapes's.

Outputs per Pa (:data:`OUTPUTS`): the umbo's displacement along its static
direction of motion (m; its static value is the magnitude of the umbo's
displacement vector, the FE ear's ``umbo_m_per_pa``), the stapes's piston
(footplate centre along the piston direction, m), α and β (rad; zero for the rigid
joint).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from isj.cavities import DEFAULT_CAVITIES, cavity_factor, check_cavities
from isj.damping import Damping, resolve
from isj.design import REGIONS, Geometry, Materials, check_pressure
from isj.ear import EarGeometry, EarMasses, EarMaterials
from isj.errors import InvalidParameter
from isj.kinematics import grounded_springs, point_map, rigid_mass
from isj.responses import FrequencyResponse
from isj.validate import check_frequencies

from .damping import damping_terms, region_stiffness
from .dynamics import _coupling, joint_coupling
from .ear_drum import DrumModes, mode_blocks, mode_scale, resolve_modes
from .ear_drum import freq_resp as condensed_freq_resp
from .model import moduli_arrays
from .second_order import SecondOrderModel

OUTPUTS = ("umbo_m", "stapes_m", "alpha_rad", "beta_rad")
UNITS = {"umbo_m": "m/Pa", "stapes_m": "m/Pa", "alpha_rad": "rad/Pa", "beta_rad": "rad/Pa"}
BODY_COORDINATES = ("u_x", "u_y", "u_z", "th_x", "th_y", "th_z")


@dataclass(frozen=True)
class EardrumParameters:
    """The eardrum condensed onto the malleus–incus body (SI).

    Parameters
    ----------
    load_per_pa : (6,) generalized force on the body's (u, θ) at ``reference_m`` per Pa
        (N/Pa, N·m/Pa), manubrium held; by reciprocity the drum's volume displacement
        per unit body motion (m², m³/rad): the effective area
    stiffness : (6, 6) the drum's stiffness against the body's motion (N/m, N, N·m/rad)
    mass : (6, 6) kinetic-energy mass of the drum's shapes that follow the body (kg, kg·m, kg·m²)
    cross_mass : (6,) mass coupling of those shapes with the uncoupled unit-volume shape
        (kg/m², kg/m)
    compliance_m3_per_pa : volume displacement per Pa with the manubrium held (m³/Pa)
    uncoupled_mass_kg_m4 : acoustic mass of that shape (kg/m⁴)
    reference_m : (3,) the body's reference point the 6-vectors refer to (m)
    drum_e_pa : eardrum modulus they were measured with (Pa)
    drum_mass_kg : ρ t × surface area (kg), for information
    """

    load_per_pa: tuple
    stiffness: tuple
    mass: tuple
    cross_mass: tuple
    compliance_m3_per_pa: float
    uncoupled_mass_kg_m4: float
    reference_m: tuple
    drum_e_pa: float
    drum_mass_kg: float = float("nan")

    def __post_init__(self) -> None:
        shapes = {"load_per_pa": (6,), "stiffness": (6, 6), "mass": (6, 6), "cross_mass": (6,)}
        for name, shape in {**shapes, "reference_m": (3,)}.items():
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise InvalidParameter(f"{name}: must be finite numbers of shape {shape}")
            object.__setattr__(self, name, tuple(map(tuple, a)) if a.ndim == 2 else tuple(a))
        for name in ("compliance_m3_per_pa", "uncoupled_mass_kg_m4", "drum_e_pa"):
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0:
                raise InvalidParameter(f"{name} = {v!r}: must be a finite number > 0")

    @classmethod
    def from_dict(cls, d: dict) -> EardrumParameters:
        """From :func:`fem.ear.lumped_params.eardrum_parameters`' dict (extra keys ignored)."""
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in names})

    def with_modulus(self, drum_e_pa: float) -> EardrumParameters:
        """The same drum with modulus ``drum_e_pa`` (Pa): exact, stiffness ∝ E and compliance ∝ 1/E."""
        if not np.isfinite(drum_e_pa) or drum_e_pa <= 0:
            raise InvalidParameter(f"drum_e_pa = {drum_e_pa!r} Pa: must be a finite number > 0")
        s = drum_e_pa / self.drum_e_pa
        return dataclasses.replace(
            self,
            stiffness=s * np.asarray(self.stiffness),
            compliance_m3_per_pa=self.compliance_m3_per_pa / s,
            drum_e_pa=float(drum_e_pa),
        )


#: Measured by :func:`fem.ear.lumped_params.eardrum_parameters` for the default
#: :class:`isj.ear.EarGeometry` and :class:`isj.ear.EarMaterials` (E = 20 MPa, ν = 0.3,
#: 40 µm), the FE ear's default drum mesh (0.125 mm, ≈ 6,200 triangles,
#: :data:`isj.ear.DEFAULT_DRUM_MESH_SIZE_M`) and density 1200 kg/m³ (an estimate), 8
#: significant digits. ``tests/test_lumped_ear.py`` re-measures them. On the nominal axis
#: they amount to an effective area of 22.1 mm² per umbo displacement, a drum
#: stiffness at the umbo of 371 N/m, a volume compliance with the manubrium
#: held of 1.68e-12 m³/Pa.
DEFAULT_EARDRUM = EardrumParameters(
    load_per_pa=(
        1.3556988e-05,
        -1.1122109e-08,
        -3.1404317e-05,
        2.606866e-11,
        -9.7763031e-08,
        2.6729782e-11,
    ),
    stiffness=(
        (1191.08, -0.22322078, 69.282634, 0.00062099627, 2.7398779, -0.00052642714),
        (-0.22322078, 701.74521, -0.16573299, -1.5879064, -0.00058156168, -0.69514914),
        (69.282634, -0.16573299, 100.87679, 0.00046868616, 0.37253202, 2.645228e-05),
        (0.00062099627, -1.5879064, 0.00046868616, 0.003705205, 1.6334986e-06, 0.0012719978),
        (2.7398779, -0.00058156168, 0.37253202, 1.6334986e-06, 0.0072258764, -1.4718446e-06),
        (-0.00052642714, -0.69514914, 2.645228e-05, 0.0012719978, -1.4718446e-06, 0.0015346396),
    ),
    mass=(
        (1.5454956e-06, -5.4397867e-10, -5.6512124e-07, 1.1106106e-12, -3.215235e-10, 1.7507218e-12),
        (-5.4397867e-10, 2.2730966e-06, 5.6008115e-10, -3.4390835e-09, 1.1145767e-12, -6.855347e-09),
        (-5.6512124e-07, 5.6008115e-10, 1.5716642e-06, -1.3359112e-12, 5.0646087e-09, -1.1965777e-12),
        (1.1106106e-12, -3.4390835e-09, -1.3359112e-12, 5.4636836e-12, -3.1277607e-15, 9.7188353e-12),
        (-3.215235e-10, 1.1145767e-12, 5.0646087e-09, -3.1277607e-15, 1.9875299e-11, -1.6977022e-15),
        (1.7507218e-12, -6.855347e-09, -1.1965777e-12, 9.7188353e-12, -1.6977022e-15, 2.2348305e-11),
    ),
    cross_mass=(0.039493011, -3.9118834e-05, -0.04622476, 8.3718907e-08, -0.00015073545, 9.404211e-08),
    compliance_m3_per_pa=1.6793328e-12,
    uncoupled_mass_kg_m4=2467.5479,
    reference_m=(4.3e-3, 0.0, -2.5e-3),
    drum_e_pa=20e6,
    drum_mass_kg=2.0753823e-06,
)


#: The ossicles' masses: :class:`isj.ear.EarMasses` (one place for the FE and the lumped ear).
OssicleMasses = EarMasses


def nominal_axis(g: EarGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Point (m) and unit direction of the nominal axis: mallear ligament → the incudal bundles' midpoint."""
    p = np.asarray(g.malleus_ligament_m, dtype=float)
    d = 0.5 * (np.asarray(g.incudal_lateral_m) + np.asarray(g.incudal_medial_m)) - p
    return p, d / np.linalg.norm(d)


@dataclass(frozen=True)
class LumpedEar:
    """The lumped ear for one design or many (leading design axis), per Pa of ear-canal pressure.

    Attributes
    ----------
    system : the second-order model (input: pressure, Pa; outputs :data:`OUTPUTS`)
    coordinates : names of q
    umbo_direction : (3,) or (n_design, 3) unit direction of the umbo's static motion
    drum_modes : the coordinates of the drum's fixed-interface modes (``drum_1`` …), condensed
        exactly at each frequency by :func:`lumped.ear_drum.freq_resp`; None without modes
    joint : the condensed joint's own terms on (α, β), (K, E, K_loss), each (2, 2) or
        (n_design, 2, 2), the rest of ``system`` being the ear around it (N·m/rad, N·m·s/rad);
        None for the rigid joint (:func:`isj.lumped.transmission.load_path`)
    cavities : "open" (default) or "intact": the middle-ear cavities' load on the drum
        (:mod:`isj.cavities`, docs/circuit.md §13.3), applied to every dynamic output; the static
        outputs are the open ear's
    """

    system: SecondOrderModel
    coordinates: tuple[str, ...]
    umbo_direction: np.ndarray
    drum_modes: slice | None = None
    joint: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    cavities: str = DEFAULT_CAVITIES

    def _open_transfer(self, system, freq_hz) -> np.ndarray:
        if self.drum_modes is None:
            return system.freq_resp(freq_hz)
        return condensed_freq_resp(system, self.drum_modes, freq_hz)

    def _transfer(self, freq_hz) -> np.ndarray:
        H = self._open_transfer(self.system, freq_hz)
        if check_cavities(self.cavities) == "open":
            return H
        return H * cavity_factor(freq_hz, self._open_volume(freq_hz), self.cavities)[..., None, None]

    def _open_volume(self, freq_hz) -> np.ndarray:
        # B is the drum's load per Pa, so by reciprocity Bᵀq is its volume displacement (m³)
        volume = dataclasses.replace(self.system, C=np.swapaxes(self.system.B, -1, -2))
        return self._open_transfer(volume, freq_hz)[..., 0, 0]

    def with_cavities(self, cavities: str) -> LumpedEar:
        """The same ear with the cavities ``cavities`` ("open" or "intact", :mod:`isj.cavities`)."""
        return dataclasses.replace(self, cavities=check_cavities(cavities))

    def drum_volume_m3(self, freq_hz) -> np.ndarray:
        """The drum's net volume displacement per Pa of ear-canal pressure (m³/Pa, medial positive),
        complex, (n_freq,) or (n_design, n_freq), with this ear's cavities."""
        X = self._open_volume(freq_hz)
        return X * cavity_factor(freq_hz, X, check_cavities(self.cavities))

    @property
    def batched(self) -> bool:
        return self.system.M.ndim == 3

    def static(self, pressure_pa: float = 1.0) -> LumpedEarStaticResult:
        """Static outputs (:data:`OUTPUTS`) at ear-canal pressure ``pressure_pa`` (Pa): K q = B p, y = C q.

        Returns
        -------
        LumpedEarStaticResult : ``outputs`` (4,) or (n_design, 4), SI units
        """
        return LumpedEarStaticResult(self._static_outputs(pressure_pa), pressure_pa)

    def _static_outputs(self, pressure_pa: float = 1.0) -> np.ndarray:
        s = self.system
        q = np.linalg.solve(s.K, s.B)
        return (s.C @ q)[..., 0] * pressure_pa

    def _freq_resp(self, freq_hz, pressure_pa: float = 1.0) -> np.ndarray:
        """Complex outputs at ``freq_hz`` (Hz): (n_freq, 4) or (n_design, n_freq, 4) (SI), any designs."""
        return self._transfer(freq_hz)[..., 0] * pressure_pa

    def frequency_response(self, freq_hz, pressure_pa: float = 1.0):
        """Umbo, stapes (m), α and β (rad) at ``freq_hz`` (Hz), an :class:`isj.responses.FrequencyResponse`.

        One design; outputs :data:`OUTPUTS` at the ear-canal pressure amplitude ``pressure_pa``
        (Pa; 1: per Pa).
        """
        if self.batched:
            raise InvalidParameter("LumpedEar.frequency_response: one design only (no design axis)")
        pressure_pa = check_pressure(pressure_pa)
        f = check_frequencies(freq_hz)
        H = self._transfer(f) * pressure_pa
        units = tuple(UNITS[k].removesuffix("/Pa") for k in OUTPUTS)
        return FrequencyResponse(f, H, OUTPUTS, units, input_amplitude=pressure_pa)

    def natural_frequencies_hz(self, n: int | None = None) -> np.ndarray:
        """Undamped natural frequencies (Hz), ascending (the ``n`` lowest; per design when batched).

        The modal damping ratios beside them: ``system.poles()[1]``.
        """
        f = self.system.poles()[0]
        return f if n is None else f[..., :n]


@dataclass(frozen=True, eq=False)  # arrays: no elementwise == pretending to be equality
class LumpedEarStaticResult:
    """Static outputs of the lumped ear (:meth:`LumpedEar.static`), SI units.

    Attributes
    ----------
    outputs : (4,) or (n_design, 4), in :data:`OUTPUTS` order: umbo (m), stapes (m), α, β (rad)
    pressure_pa : the ear-canal pressure (Pa) they are for
    """

    outputs: np.ndarray
    pressure_pa: float = 1.0

    def __getitem__(self, name: str) -> np.ndarray:
        """One output (:data:`OUTPUTS`): a float array, 0-d for one design."""
        return self.outputs[..., OUTPUTS.index(name)]

    def to_dict(self) -> dict:
        """The outputs by name (floats for one design, lists for many) and ``pressure_pa``."""

        def plain(v):
            a = np.asarray(v, dtype=float)
            return float(a) if a.ndim == 0 else a.tolist()

        return {k: plain(self[k]) for k in OUTPUTS} | {"pressure_pa": float(self.pressure_pa)}


def ear_model(
    factors=None,
    *,
    geometry: EarGeometry | None = None,
    joint_geometry: Geometry | None = None,
    ear_materials: EarMaterials | None = None,
    eardrum: EardrumParameters | None = None,
    masses: EarMasses | None = None,
    rigid_joint: bool = False,
    joint: str = "bonded",
    body: str = "rigid",
    rayleigh_a_per_s=None,
    rayleigh_b_s=None,
    loss_factor=None,
    damping: Damping | str | None = None,
    drum_modes: DrumModes | int | None = None,
    **moduli,
) -> LumpedEar:
    """Assemble the lumped ear (see the module docstring) for one design or arrays of moduli.

    Parameters
    ----------
    factors : calibrated static factors (``lumped.model.FACTOR_NAMES`` order); None: the
        shipped calibration's
    geometry, ear_materials : the ear's anatomy (m) and springs (N/m); the drum's modulus in
        ``ear_materials`` rescales ``eardrum`` (exact)
    joint_geometry : the joint model's dimensions (m); the ear's joint length is its z_top
        (:meth:`isj.ear.EarGeometry.for_joint`)
    eardrum : the drum's condensed parameters (default :data:`DEFAULT_EARDRUM`, valid for the
        default anatomy; measure others with :func:`fem.ear.lumped_params.eardrum_parameters`)
    masses : ossicle masses (kg) and radii of gyration (m), estimates (:class:`isj.ear.EarMasses`;
        its densities are not read: the drum's mass is ``eardrum``'s, the footplate is in ``stapes_kg``)
    rigid_joint : no α, β coordinates (a rigid incus–stapes connection)
    joint : "bonded" or "sliding", the joint ``factors`` were calibrated on
        (:func:`lumped.model.equations`)
    body : "rigid" (six dofs) or "rotation" (one rotation about the nominal axis)
    damping : :class:`isj.damping.Damping` or a preset name (default: the published loss factors,
        docs/dynamics.md §4.3)
    drum_modes : the drum's fixed-interface modes (docs/ear.md §5.10): None, the one static shape
        (valid below the first drum mode); an int n, the lowest n of the shipped
        :func:`lumped.ear_drum.default_drum_modes` (default anatomy), with their static residual;
        or :class:`lumped.ear_drum.DrumModes` (measure others with :func:`fem.ear.drum_modes.drum_modes`)
    rayleigh_a_per_s, rayleigh_b_s, loss_factor : changes to ``damping`` (1/s, s, dimensionless): a
        number for every part or a mapping name → value; None leaves it
    **moduli : the joint model's moduli (Pa), floats or broadcastable arrays (``lumped.model.MODULI``)
    """
    g = (geometry or EarGeometry()).for_joint(joint_geometry or Geometry())
    jg = joint_geometry or Geometry()
    mat = ear_materials or EarMaterials()
    drum = (eardrum or DEFAULT_EARDRUM).with_modulus(mat.drum_e_pa)
    modes = resolve_modes(drum_modes, mat.drum_e_pa, eardrum is None or eardrum == DEFAULT_EARDRUM)
    ms = masses or EarMasses()
    if body not in ("rigid", "rotation"):
        raise InvalidParameter(f"body = {body!r}: must be 'rigid' or 'rotation'")
    dmp = resolve(
        damping, rayleigh_a_per_s=rayleigh_a_per_s, rayleigh_b_s=rayleigh_b_s, loss_factor=loss_factor
    )
    _check_reference_points(g, drum, modes)
    coupling = None
    if not rigid_joint:
        if factors is None:
            from .artifact import default_calibration  # the shipped calibration: read when needed

            factors = default_calibration().factor_array()
        coupling = joint_coupling(factors, jg, joint=joint, **moduli)
    frame = _frame(g, jg, body, coupling, 0 if modes is None else modes.n_modes)
    # the modes (none: zeros): stiffness ω² m_s, mass coupling with the body, load
    mode_terms = mode_blocks(modes, frame.body_map, frame.iw + 1, mode_scale(drum.mass))
    parts, dash, K = _stiffness(frame, g, mat, drum, modes, mode_terms[0], dmp, coupling)
    masses_by_part = _masses(frame, g, ms, drum, modes, mode_terms[1])
    if coupling is not None:  # the joint's regions, for the damping per region
        parts |= _joint_region_stiffness(frame, factors, jg, joint, moduli)
    E_visc, K_loss = damping_terms(dmp, parts, masses_by_part, dash)
    joint_terms = _joint_share(frame, dmp, parts, coupling)
    M = sum(masses_by_part.values())  # (nd, n, n)
    Bq, C, d_umbo = _load_and_outputs(frame, g, drum, mode_terms[2], K)
    arrays = [K, M, E_visc, K_loss, np.broadcast_to(Bq, (frame.nd, frame.n, 1)).copy(), C, d_umbo]
    one_design = coupling is None or all(np.ndim(v) == 0 for v in moduli.values())
    return _lumped_ear(frame, arrays, joint_terms, one_design)


def _lumped_ear(frame, arrays: list, joint_terms, one_design: bool) -> LumpedEar:
    """The :class:`LumpedEar` of the stacked (K, M, E, K_loss, B, C, umbo direction); with
    ``one_design`` the design axis dropped."""
    if one_design:
        arrays = [a[0] for a in arrays]
        if joint_terms is not None:
            joint_terms = tuple(np.broadcast_to(t, (frame.nd, 2, 2))[0] for t in joint_terms)
    K, M, E_visc, K_loss, Bb, C, d_umbo = arrays
    system = SecondOrderModel(M=M, E=E_visc, K=K, B=Bb, C=C, K_loss=K_loss)
    modal = slice(frame.iw + 1, frame.n) if frame.n_modes else None
    return LumpedEar(
        system=system, coordinates=frame.names, umbo_direction=d_umbo, drum_modes=modal, joint=joint_terms
    )


def _joint_share(frame, dmp, parts: dict, coupling):
    """The joint's own share of K, E and K_loss on (α, β), for the load-path analysis; None
    without a joint."""
    if coupling is None:
        return None
    E_j, L_j = damping_terms(dmp, {r: parts[r] for r in parts if r in REGIONS})
    blk = (..., slice(frame.ia, frame.ia + 2), slice(frame.ia, frame.ia + 2))
    return coupling.stiffness, E_j[blk], L_j[blk]


def _check_reference_points(g: EarGeometry, drum: EardrumParameters, modes) -> None:
    """The drum's parameters and modes must refer to the body's reference point."""
    x_b = np.asarray(g.body_reference_m, dtype=float)
    if np.linalg.norm(np.asarray(drum.reference_m) - x_b) > 1e-9:
        raise InvalidParameter(
            f"eardrum.reference_m = {drum.reference_m!r}: must be the body's reference point {tuple(x_b)!r} m"
        )
    if modes is not None and np.linalg.norm(np.asarray(modes.reference_m) - x_b) > 1e-9:
        raise InvalidParameter(f"drum_modes.reference_m = {modes.reference_m!r}: must be {tuple(x_b)!r} m")


@dataclasses.dataclass(frozen=True)
class _Frame:
    """The lumped ear's coordinates and the maps from them to the two bodies' motions.

    ``names``: body coordinates, [α, β], the drum's shape w, its modes; ``ia``: α's index
    (β at ia + 1); ``iw``: w's; ``body_map`` (6, n): the body's (u, θ) at its reference point;
    ``stapes_map`` (nd, 6, n): the stapes's (u, θ) at the footplate's centre, per design ``nd``;
    ``outline``: the annular springs' points on the footplate's rim.
    """

    names: tuple[str, ...]
    ia: int
    iw: int
    n_modes: int
    body_map: np.ndarray
    stapes_map: np.ndarray
    outline: np.ndarray
    area_ring_m2: float

    @property
    def n(self) -> int:
        return len(self.names)

    @property
    def nd(self) -> int:
        return self.stapes_map.shape[0]

    @property
    def stapes_t(self) -> np.ndarray:
        return np.swapaxes(self.stapes_map, -1, -2)

    def on_body(self, K6) -> np.ndarray:
        """A 6 × 6 matrix of the body's (u, θ) on the ear's coordinates, per design."""
        return np.broadcast_to(self.body_map.T @ K6 @ self.body_map, (self.nd, self.n, self.n))

    def on_stapes(self, F, k3x3) -> np.ndarray:
        """Grounded springs of 3 × 3 stiffness ``k3x3`` at every outline point of the footplate."""
        springs = grounded_springs(F, self.outline, np.broadcast_to(k3x3, (len(self.outline), 3, 3)))
        return self.stapes_t @ springs @ self.stapes_map


def _frame(g: EarGeometry, jg: Geometry, body: str, coupling, n_modes: int) -> _Frame:
    """Coordinates: body (six, or one rotation about the nominal axis), [α, β], w, drum modes."""
    x_b = np.asarray(g.body_reference_m, dtype=float)
    if body == "rigid":
        Jb = np.eye(6)
        names = list(BODY_COORDINATES)
    else:
        p0, e = nominal_axis(g)
        Jb = np.concatenate([np.cross(e, x_b - p0), e])[:, None]
        names = ["th_axis"]
    nb = Jb.shape[1]
    if coupling is not None:
        names += ["alpha", "beta"]
    names.append("w")
    iw = len(names) - 1
    names += [f"drum_{j + 1}" for j in range(n_modes)]
    n = len(names)
    ia = nb  # alpha, beta at ia, ia + 1
    body_map = np.zeros((6, n))  # body (u, θ) at x_b from q
    body_map[:, :nb] = Jb

    # the stapes as a rigid body: (u, θ) at the footplate's centre F from q
    F = np.asarray(g.footplate_centre_m, dtype=float)
    head = np.asarray(g.stapes_head_m, dtype=float)
    jy, jz = np.asarray(g.joint_y_direction), np.asarray(g.joint_z_direction)
    z_j = (jg.z_gap + jg.z_plate) / 2
    nd = coupling.stiffness.shape[0] if coupling is not None else 1
    stapes_map = np.zeros((nd, 6, n))
    stapes_map[:, :3] = point_map(F, x_b)[0] @ body_map
    stapes_map[:, 3:] = body_map[3:]
    if coupling is not None:  # the stapes moves by −d relative to the incus, d = motion @ (α, β)
        jx = np.asarray(g.joint_x_direction, dtype=float)
        per_d = np.zeros((6, 2))  # stapes (u at F, θ) per unit d = (u_x at head + z_j ẑ, rotation)
        per_d[:3, 0] = -jx
        per_d[:3, 1] = -np.cross(jy, F - (head + z_j * jz))
        per_d[3:, 1] = -jy
        stapes_map[:, :, ia : ia + 2] = per_d @ coupling.motion

    nrm = np.asarray(g.piston_direction)
    long_m, short_m = g.footplate_semi_axes_m
    e_long = np.asarray(g.footplate_long_axis)
    e_short = np.cross(nrm, e_long)
    phi = 2 * np.pi * np.arange(g.annular_springs) / g.annular_springs
    outline = F + np.outer(long_m * np.cos(phi), e_long) + np.outer(short_m * np.sin(phi), e_short)
    area_ring = np.pi * g.drum_semi_axis_manubrium_m * g.drum_semi_axis_transverse_m
    return _Frame(tuple(names), ia, iw, n_modes, body_map, stapes_map, outline, area_ring)


def _drum_shape(drum: EardrumParameters, modes):
    """The drum's uncoupled shape w: the static one, or the residual of the kept modes."""
    if modes is None:
        return drum.compliance_m3_per_pa, drum.uncoupled_mass_kg_m4, drum.cross_mass
    return modes.residual_compliance_m3_per_pa, modes.residual_mass_kg_m4, modes.residual_cross_mass


def _stiffness(
    frame: _Frame, g: EarGeometry, mat: EarMaterials, drum, modes, K_modes, dmp: Damping, coupling
):
    """Stiffness per part (the damping's parts: docs/dynamics.md §4.3), the cochlear dashpot, K."""
    x_b = np.asarray(g.body_reference_m, dtype=float)
    F = np.asarray(g.footplate_centre_m, dtype=float)
    pts = np.array([g.malleus_ligament_m, g.incudal_lateral_m, g.incudal_medial_m])
    eye = np.eye(3)
    k_mallear = np.array([mat.malleus_ligament_n_m / 3 * eye, 0 * eye, 0 * eye])
    k_incudal = np.array([0 * eye, mat.incudal_lateral_n_m * eye, mat.incudal_medial_n_m * eye])
    nrm = np.asarray(g.piston_direction)
    k_ann = mat.annular_out_of_plane_n_m * np.outer(nrm, nrm) + mat.annular_in_plane_n_m * (
        np.eye(3) - np.outer(nrm, nrm)
    )
    C_w = _drum_shape(drum, modes)[0]
    K_drum = frame.on_body(np.asarray(drum.stiffness)).copy()
    K_drum[:, frame.iw, frame.iw] += frame.area_ring_m2**2 / C_w
    K_drum += K_modes
    parts = {
        "eardrum": K_drum,
        "mallear_ligament": frame.on_body(grounded_springs(x_b, pts, k_mallear)),
        "incudal_ligaments": frame.on_body(grounded_springs(x_b, pts, k_incudal)),
        "annular_ligament": frame.on_stapes(F, k_ann),
    }
    K = sum(parts.values())
    if coupling is not None:
        K = K.copy()
        K[:, frame.ia : frame.ia + 2, frame.ia : frame.ia + 2] += coupling.stiffness
    # the cochlea: R = Z_C A² along the piston direction, R/n at each annular spring
    resistance = dmp.cochlear_resistance_n_s_m(g.footplate_area_m2) / len(frame.outline)
    dash = frame.on_stapes(F, resistance * np.outer(nrm, nrm))
    return parts, dash, K


def _masses(frame: _Frame, g: EarGeometry, ms: EarMasses, drum, modes, M_modes) -> dict[str, np.ndarray]:
    """Mass per part: the drum (with its shape w and modes), the malleus–incus body, the stapes."""
    x_b = np.asarray(g.body_reference_m, dtype=float)
    F = np.asarray(g.footplate_centre_m, dtype=float)
    _, m_w, cross_w = _drum_shape(drum, modes)
    centroid = np.asarray(ms.malleus_incus_centroid(g), dtype=float)
    M_ossicle = rigid_mass(ms.malleus_incus_kg, ms.malleus_incus_gyration_m, centroid, x_b)
    c_s = np.asarray(ms.stapes_centroid(g), dtype=float)
    iw, area_ring = frame.iw, frame.area_ring_m2
    M_drum = frame.on_body(np.asarray(drum.mass)).copy()
    cross = frame.body_map.T @ np.asarray(cross_w) * area_ring
    M_drum[:, :, iw] += cross
    M_drum[:, iw, :] += cross
    M_drum[:, iw, iw] += m_w * area_ring**2
    M_drum += M_modes
    return {
        "eardrum": M_drum,
        "incus": frame.on_body(M_ossicle),
        "stapes": frame.stapes_t @ rigid_mass(ms.stapes_kg, ms.stapes_gyration_m, c_s, F) @ frame.stapes_map,
    }


def _joint_region_stiffness(frame: _Frame, factors, jg: Geometry, joint: str, moduli) -> dict:
    """The joint's coupling stiffness split by region, on the ear's coordinates (for the damping)."""
    nu = Materials().nu  # as joint_coupling's

    def coupling_stiffness(Ec):
        return _coupling(factors, jg, nu, Ec, joint).stiffness

    out = {}
    ia = frame.ia
    for r, Kr in region_stiffness(coupling_stiffness, moduli_arrays(**moduli)).items():
        Kf = np.zeros((frame.nd, frame.n, frame.n))
        Kf[:, ia : ia + 2, ia : ia + 2] = Kr
        out[r] = Kf
    return out


def _load_and_outputs(frame: _Frame, g: EarGeometry, drum, B_modes, K):
    """The load per pascal, the outputs' rows (umbo along its static direction, stapes piston,
    α, β) and the umbo's static direction, per design."""
    x_b = np.asarray(g.body_reference_m, dtype=float)
    n, nd, ia = frame.n, frame.nd, frame.ia
    Bq = np.zeros((n, 1))
    Bq[:, 0] = frame.body_map.T @ np.asarray(drum.load_per_pa)
    Bq[frame.iw, 0] += frame.area_ring_m2
    Bq[:, 0] += B_modes
    umbo_map = point_map(g.umbo_m, x_b)[0] @ frame.body_map  # (3, n)
    q_static = np.linalg.solve(K, np.broadcast_to(Bq, (nd, n, 1)))[..., 0]
    u_umbo = q_static @ umbo_map.T  # (nd, 3)
    d_umbo = u_umbo / np.linalg.norm(u_umbo, axis=1, keepdims=True)
    C = np.zeros((nd, 4, n))
    C[:, 0] = d_umbo @ umbo_map
    C[:, 1] = np.asarray(g.piston_direction) @ frame.stapes_map[:, :3]
    if "alpha" in frame.names:
        C[:, 2, ia], C[:, 3, ia + 1] = 1.0, 1.0
    return Bq, C, d_umbo
