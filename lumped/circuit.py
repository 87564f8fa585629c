"""The published cat middle-ear circuit, solved by modified nodal analysis (docs/circuit.md §13).

The circuit of Bruce, Sachs & Young (2003, Appendix A): the middle-ear cavities of Peake, Rosowski
& Lynch (1992), the eardrum and ossicles after Matthews (1983) and the cochlear load of Lynch,
Nedzelnitsky & Peake (1982). It is a published model fitted to cat measurements, not a
measurement; isj compares its ears with it and tunes nothing to it. The element values, in SI,
their conversion from the published CGS acoustic units and their sources are in
``isj/data/cat_middle_ear_circuit.json`` (:func:`isj.cavities.load_circuit_data`).

Impedance analogy: node potentials are acoustic pressures (Pa), branch currents volume
velocities (m³/s), node 0 the reference. At each frequency the modified nodal equations

    [ Y(ω)  B ] [p]   [0]
    [ Bᵀ    0 ] [i] = [s]

have one row per node (Kirchhoff's current law, Y the sum of the elements' admittances 1/R,
1/(iωL), iωC) and one per constraint: the pressure source (p₊ − p₋ = p_EC, its current i) and each
ideal transformer (p_a − p_b − (p_c − p_d)/n = 0; its primary current i enters a and leaves b,
i/n leaves the secondary at c and returns at d, so p_prim i = p_sec i/n: lossless). The matrix is
complex symmetric, so the network is reciprocal. All frequencies are assembled as one stacked
(n_freq, m, m) array and solved with one ``numpy.linalg.solve``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from isj.cavities import CAVITY_ELEMENTS, check_cavities, load_circuit_data
from isj.errors import InvalidParameter
from isj.validate import check_frequencies

#: Element kinds and the SI key of their value in the data file.
VALUE_KEYS = {"R": "resistance_pa_s_m3", "L": "inertance_kg_m4", "C": "compliance_m3_pa"}


@dataclass(frozen=True)
class Element:
    """One two-terminal element (R: Pa·s/m³, L: kg/m⁴, C: m³/Pa) between ``nodes`` (a, b), or an
    ideal transformer (kind "T": ``nodes`` the primary (a, b), ``secondary`` (c, d), ``value`` the
    ratio n, p_c − p_d = n (p_a − p_b)). Current is counted from a to b."""

    name: str
    kind: str
    nodes: tuple[int, int]
    value: float
    secondary: tuple[int, int] | None = None
    part: str = ""

    def __post_init__(self) -> None:
        if self.kind not in ("R", "L", "C", "T"):
            raise InvalidParameter(f"element {self.name}: kind = {self.kind!r}: must be R, L, C or T")
        if not (np.isfinite(self.value) and self.value > 0):
            raise InvalidParameter(
                f"element {self.name}: value = {self.value!r}: must be a finite number > 0"
            )
        if (self.kind == "T") != (self.secondary is not None):
            raise InvalidParameter(f"element {self.name}: a transformer (and only one) has secondary nodes")

    def admittance(self, w: np.ndarray) -> np.ndarray:
        """Complex admittance (m³/(s·Pa)) at angular frequencies ``w`` (rad/s, > 0)."""
        if self.kind == "R":
            return np.full(w.shape, 1.0 / self.value, complex)
        if self.kind == "L":
            return 1.0 / (1j * w * self.value)
        if self.kind == "C":
            return 1j * w * self.value
        raise InvalidParameter(f"element {self.name}: a transformer has no admittance")


@dataclass(frozen=True)
class NodalSolution:
    """Pressures at every node (n_freq, n_nodes; Pa) and the source's volume velocity.

    ``source_volume_velocity`` (m³/s, (n_freq,)) is the volume velocity the source drives into
    the network at its + node."""

    freq_hz: np.ndarray
    nodes: tuple[int, ...]
    pressure: np.ndarray
    source_volume_velocity: np.ndarray

    def at(self, node: int) -> np.ndarray:
        """Pressure (Pa, complex, (n_freq,)) at ``node`` (0: the reference, zeros)."""
        if node == 0:
            return np.zeros(self.freq_hz.size, complex)
        return self.pressure[:, self.nodes.index(node)]

    def current(self, element: Element) -> np.ndarray:
        """Volume velocity (m³/s) through a two-terminal ``element`` from its first node to its second."""
        a, b = element.nodes
        return (self.at(a) - self.at(b)) * element.admittance(2 * np.pi * self.freq_hz)


def nodal_solve(elements, source_nodes: tuple[int, int], freq_hz, source_pa: float = 1.0) -> NodalSolution:
    """Solve a network of :class:`Element` driven by a pressure source (module docstring).

    Parameters
    ----------
    elements : sequence of :class:`Element`; node 0 is the reference
    source_nodes : (+, −): the source holds p₊ − p₋ = ``source_pa``
    freq_hz : frequencies (Hz), each > 0
    source_pa : the source's pressure (Pa)

    Returns
    -------
    :class:`NodalSolution`
    """
    f = check_frequencies(freq_hz)
    if np.any(f <= 0):
        raise InvalidParameter("freq_hz: the nodal solve needs every frequency > 0 Hz")
    if not np.isfinite(source_pa):
        raise InvalidParameter(f"source_pa = {source_pa!r} Pa: must be a finite number")
    elements = tuple(elements)
    all_nodes = set(source_nodes)
    for e in elements:
        all_nodes |= set(e.nodes) | set(e.secondary or ())
    nodes = tuple(sorted(all_nodes - {0}))
    index = {n: i for i, n in enumerate(nodes)}
    transformers = [e for e in elements if e.kind == "T"]
    n_v = len(nodes)
    m = n_v + 1 + len(transformers)
    w = 2 * np.pi * f
    A = np.zeros((f.size, m, m), complex)
    rhs = np.zeros((f.size, m), complex)

    def add(r: int, c: int, v) -> None:
        if r and c:
            A[:, index[r], index[c]] += v

    for e in elements:
        if e.kind == "T":
            continue
        y = e.admittance(w)
        a, b = e.nodes
        add(a, a, y)
        add(b, b, y)
        add(a, b, -y)
        add(b, a, -y)

    def constraint(k: int, coeffs) -> None:  # column and row k: symmetric
        for node, c in coeffs:
            if node:
                A[:, index[node], k] += c
                A[:, k, index[node]] += c

    constraint(n_v, ((source_nodes[0], 1.0), (source_nodes[1], -1.0)))
    rhs[:, n_v] = source_pa
    for j, t in enumerate(transformers):
        (a, b), (c, d), n = t.nodes, t.secondary, t.value
        constraint(n_v + 1 + j, ((a, 1.0), (b, -1.0), (c, -1.0 / n), (d, 1.0 / n)))
    # symmetric diagonal scaling: admittances span twenty decades in SI
    s = 1.0 / np.sqrt(np.maximum(np.abs(A).max(axis=2), 1e-300))  # (n_freq, m)
    x = s * np.linalg.solve(s[:, :, None] * A * s[:, None, :], (s * rhs)[..., None])[..., 0]
    # the source's unknown is the current leaving its + node into the source
    return NodalSolution(f, nodes, x[:, :n_v], -x[:, n_v])


@dataclass(frozen=True)
class CircuitResponse:
    """The circuit per Pa of ear-canal pressure (SI, complex, each (n_freq,)).

    Attributes
    ----------
    freq_hz : frequencies (Hz)
    cavities : "intact" or "open"
    vestibule_gain : P_V / P_EC (Pa/Pa), the pressure at the cochlear load's input
    stapes_volume_velocity_m3_s : U_S / P_EC (m³/(s·Pa)), through the vestibule's mass L_v
    drum_volume_velocity_m3_s : U / P_EC (m³/(s·Pa)), the drum's net volume velocity (the source's)
    """

    freq_hz: np.ndarray
    cavities: str
    vestibule_gain: np.ndarray
    stapes_volume_velocity_m3_s: np.ndarray
    drum_volume_velocity_m3_s: np.ndarray

    def vestibule_gain_db(self) -> np.ndarray:
        """20 log₁₀ |P_V / P_EC| (dB)."""
        return 20 * np.log10(np.abs(self.vestibule_gain))


@dataclass(frozen=True)
class CatCircuit:
    """The published cat middle-ear circuit (module docstring), cavities intact, values in SI.

    Attributes
    ----------
    elements : every element, the cavities' four included
    source_nodes : (15, 0): the ear-canal pressure
    cavity_nodes : (15, 14): the cavity network sits between them, in series with the drum
    vestibule_node : 16, the cochlear load's input
    stapes_element : "Lv", the element whose volume velocity is the stapes's
    """

    elements: tuple[Element, ...]
    source_nodes: tuple[int, int] = (15, 0)
    cavity_nodes: tuple[int, int] = (15, 14)
    vestibule_node: int = 16
    stapes_element: str = "Lv"

    @classmethod
    def load(cls) -> CatCircuit:
        """The circuit of ``isj/data/cat_middle_ear_circuit.json``."""
        data = load_circuit_data()
        els = []
        for e in data["elements"]:
            if e["kind"] == "T":
                els.append(
                    Element(
                        e["name"],
                        "T",
                        tuple(e["primary_nodes"]),
                        float(e["ratio"]),
                        tuple(e["secondary_nodes"]),
                        e["part"],
                    )
                )
            else:
                value = float(e[VALUE_KEYS[e["kind"]]])
                els.append(Element(e["name"], e["kind"], tuple(e["nodes"]), value, part=e["part"]))
        return cls(tuple(els), tuple(data["source"]["nodes"]), tuple(data["cavities"]["nodes"]))

    def element(self, name: str) -> Element:
        """The element called ``name``."""
        for e in self.elements:
            if e.name == name:
                return e
        raise InvalidParameter(f"element = {name!r}: not in the circuit")

    def with_cavities(self, cavities: str) -> CatCircuit:
        """The circuit for ``cavities`` "intact" (itself) or "open": the four cavity elements removed
        and their two nodes joined (the drum then sees the ear-canal pressure directly)."""
        if check_cavities(cavities) == "intact":
            return self
        keep, gone = self.cavity_nodes
        rename = {gone: keep}

        def rn(pair):
            return None if pair is None else tuple(rename.get(n, n) for n in pair)

        els = tuple(
            replace(e, nodes=rn(e.nodes), secondary=rn(e.secondary))
            for e in self.elements
            if e.name not in CAVITY_ELEMENTS
        )
        return replace(self, elements=els)

    def node_pressures(self, freq_hz, cavities: str = "intact") -> NodalSolution:
        """Every node's pressure per Pa of ear-canal pressure (:func:`nodal_solve`)."""
        return nodal_solve(self.with_cavities(cavities).elements, self.source_nodes, freq_hz)

    def frequency_response(self, freq_hz, cavities: str = "intact") -> CircuitResponse:
        """P_V/P_EC, U_S/P_EC and the drum's U/P_EC at ``freq_hz`` (Hz, > 0), cavities "intact" or "open"."""
        sol = self.node_pressures(freq_hz, cavities)
        return CircuitResponse(
            freq_hz=sol.freq_hz,
            cavities=cavities,
            vestibule_gain=sol.at(self.vestibule_node),
            stapes_volume_velocity_m3_s=sol.current(self.element(self.stapes_element)),
            drum_volume_velocity_m3_s=sol.source_volume_velocity,
        )

    def cavity_impedance_pa_s_m3(self, freq_hz) -> np.ndarray:
        """Z_cav (Pa·s/m³, complex, (n_freq,)) of the four cavity elements (C_tc, C_bc, R_f, M_f):
        their network alone between :attr:`cavity_nodes`, driven by 1 Pa, over its volume velocity."""
        hi, lo = self.cavity_nodes
        cav = [
            replace(e, nodes=tuple(0 if n == lo else n for n in e.nodes))
            for e in self.elements
            if e.name in CAVITY_ELEMENTS
        ]  # the drum's side of the cavities as the reference
        return 1.0 / nodal_solve(cav, (hi, 0), freq_hz).source_volume_velocity
