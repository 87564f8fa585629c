"""The published cat circuit (lumped/circuit.py), its nodal solve and the cavity load (isj/cavities.py).

The check values are those an independent nodal solve of the published table gave (the source
table's ``values_computed_from_this_table_as_a_check``, kept in the data file's ``check_values``);
the solver is checked on its own against closed forms.
"""

import json

import numpy as np
import pytest
from isj.lumped.circuit import CatCircuit, Element, nodal_solve

from isj.cavities import (
    cavity_factor,
    cavity_impedance_pa_s_m3,
    cavity_stiffness_pa_m3,
    cavity_values,
    check_cavities,
    load_circuit_data,
)
from isj.errors import InvalidParameter

FINE_HZ = np.geomspace(100.0, 20e3, 4001)  # 0.13 % steps: the extremes' frequencies to ±0.07 %


@pytest.fixture(scope="module")
def circuit():
    return CatCircuit.load()


@pytest.fixture(scope="module")
def fine(circuit):
    return circuit.frequency_response(FINE_HZ)


def db(x):
    return 20 * np.log10(np.abs(x))


# ---- the published check values (cavities intact)


@pytest.mark.parametrize("freq_hz, gain_db", [(100.0, 3.9), (1e3, 29.1), (10e3, 20.8)])
def test_vestibule_gain_check_values(circuit, freq_hz, gain_db):
    """Stated to 0.1 dB: within half of that rounding plus 0.01 dB."""
    g = circuit.frequency_response([freq_hz]).vestibule_gain_db()[0]
    assert abs(g - gain_db) <= 0.06


def test_vestibule_gain_maximum_near_1600_hz(fine):
    """'A maximum of about 32 dB near 1.6 kHz': within 0.5 dB (the stated rounding) and 10 %."""
    g = fine.vestibule_gain_db()
    i = np.argmax(g)
    assert abs(g[i] - 32.0) <= 0.5
    assert abs(FINE_HZ[i] / 1600 - 1) <= 0.1


def test_vestibule_gain_notch_near_4360_hz(fine):
    """'A notch of about 12 dB at 4.36 kHz': the local minimum between 3 and 6 kHz, within 0.5 dB
    and 1 % of 4.36 kHz, and the gain at 4.36 kHz itself within 0.5 dB of 12 dB."""
    g = fine.vestibule_gain_db()
    band = (FINE_HZ > 3e3) & (FINE_HZ < 6e3)
    i = np.flatnonzero(band)[np.argmin(g[band])]
    assert abs(g[i] - 12.0) <= 0.5
    assert abs(FINE_HZ[i] / 4360 - 1) <= 0.01
    assert g[i] < g[band][0] - 10 and g[i] < g[band][-1] - 3  # a notch, not a slope


def test_stapes_volume_velocity_check_value(circuit):
    """2.05e-11 m³/s/Pa at 100 Hz, stated to three digits: within 1 %."""
    u = circuit.frequency_response([100.0]).stapes_volume_velocity_m3_s[0]
    assert abs(abs(u) / 2.05e-11 - 1) <= 0.01


def test_data_file_check_values_are_the_tests(circuit):
    """The data file's recorded check values are what the solve gives (so docs and file agree)."""
    cv = load_circuit_data()["check_values"]
    for f, g in cv["vestibule_pressure_gain_db"].items():
        assert abs(circuit.frequency_response([float(f)]).vestibule_gain_db()[0] - g) <= 0.06
    for f, u in cv["stapes_volume_velocity_m3_s_pa"].items():
        assert abs(abs(circuit.frequency_response([float(f)]).stapes_volume_velocity_m3_s[0]) / u - 1) <= 0.01


def test_cochlear_load_is_lynch_resistance(circuit):
    """Between 0.5 and 5 kHz the load seen from the vestibule, P_V / U_S less the vestibule's own
    mass, is primarily resistive near 1.2e11 Pa·s/m³ (Lynch et al. 1982): within 35 % and 45°."""
    f = np.geomspace(500, 5e3, 9)
    r = circuit.frequency_response(f)
    Zc = r.vestibule_gain / r.stapes_volume_velocity_m3_s
    assert np.all(np.abs(np.abs(Zc) / 1.2e11 - 1) < 0.35)
    assert np.all(np.abs(np.angle(Zc, deg=True)) < 45)


def test_data_file_is_si_with_its_published_values():
    """Every value is its published CGS value times the stated factor, and the sources are there."""
    d = load_circuit_data()
    scale = {"R": 1e5, "L": 1e5, "C": 1e-5}
    keys = {"R": "resistance_pa_s_m3", "L": "inertance_kg_m4", "C": "compliance_m3_pa"}
    for e in d["elements"]:
        if e["kind"] == "T":
            assert e["ratio"] == 55
            continue
        assert e[keys[e["kind"]]] == pytest.approx(e["published_cgs"]["value"] * scale[e["kind"]], rel=1e-6)
    text = json.dumps(d)
    for name in ("Bruce", "Peake", "Lynch", "Matthews"):
        assert name in text
    assert "not a measurement" in d["what"]
    outside = "/".join(("..", "shared"))  # the workspace folder the values were first read from
    assert outside not in text  # the repository's own file stands on its own


# ---- the solver against closed forms


def test_series_rlc_closed_form():
    R, L, C = 2.0e7, 3.0e3, 4.0e-13  # Pa·s/m³, kg/m⁴, m³/Pa
    f = np.geomspace(10, 1e5, 50)
    w = 2 * np.pi * f
    els = [Element("R", "R", (1, 2), R), Element("L", "L", (2, 3), L), Element("C", "C", (3, 0), C)]
    s = nodal_solve(els, (1, 0), f)
    Z = R + 1j * w * L + 1 / (1j * w * C)
    np.testing.assert_allclose(s.source_volume_velocity, 1 / Z, rtol=1e-9)
    np.testing.assert_allclose(s.at(3), (1 / (1j * w * C)) / Z, rtol=1e-9)  # the divider at C
    np.testing.assert_allclose(s.current(els[1]), 1 / Z, rtol=1e-9)
    i = np.argmin(np.abs(s.source_volume_velocity - 1 / R))  # resonance: the current is 1/R
    assert abs(f[i] * 2 * np.pi * np.sqrt(L * C) - 1) < 0.1


def test_transformer_reflects_impedance_and_steps_pressure():
    """An ideal transformer of ratio n loaded by R: input impedance R/n², secondary pressure n p."""
    n, R = 55.0, 1.2e11
    els = [Element("T", "T", (1, 0), n, secondary=(2, 0)), Element("R", "R", (2, 0), R)]
    s = nodal_solve(els, (1, 0), [100.0, 1e4], source_pa=2.0)
    np.testing.assert_allclose(s.source_volume_velocity, 2.0 * n**2 / R, rtol=1e-12)
    np.testing.assert_allclose(s.at(2), 2.0 * n, rtol=1e-12)
    np.testing.assert_allclose(s.current(els[1]) * s.at(2), s.source_volume_velocity * 2.0, rtol=1e-12)


def test_reciprocity_of_the_cat_circuit(circuit):
    """Passive and reciprocal (transformer included): a source behind R₁ at the ear canal drives
    through R₂ at the vestibule the same volume velocity as the source behind R₂ at the vestibule
    drives through R₁ at the ear canal."""
    f = np.geomspace(100, 20e3, 7)
    els = [e for e in circuit.elements if e.name not in ("Ro", "Rc")]  # the cochlea becomes port 2
    r1, r2 = 3e8, 2e10  # Pa·s/m³
    fwd_meter = Element("R2", "R", (16, 0), r2)
    fwd = nodal_solve([*els, Element("R1", "R", (99, 15), r1), fwd_meter], (99, 0), f).current(fwd_meter)
    rev_meter = Element("R1", "R", (15, 0), r1)
    rev = nodal_solve([*els, Element("R2", "R", (99, 16), r2), rev_meter], (99, 0), f).current(rev_meter)
    np.testing.assert_allclose(fwd, rev, rtol=1e-9)
    assert np.all(np.abs(fwd) > 0)


def test_nodal_solve_refuses_bad_input():
    el = [Element("R", "R", (1, 0), 1.0)]
    with pytest.raises(InvalidParameter, match="freq_hz"):
        nodal_solve(el, (1, 0), [0.0])
    with pytest.raises(InvalidParameter, match="value"):
        Element("R", "R", (1, 0), -1.0)
    with pytest.raises(InvalidParameter, match="cavities"):
        check_cavities("closed")


# ---- the cavities


def test_cavity_impedance_nodal_against_closed_form(circuit):
    """Z_cav from the nodal solve of the four elements equals the closed form of isj.cavities."""
    np.testing.assert_allclose(
        circuit.cavity_impedance_pa_s_m3(FINE_HZ), cavity_impedance_pa_s_m3(FINE_HZ), rtol=1e-10
    )
    v = cavity_values()
    assert cavity_stiffness_pa_m3([0.0])[0] == pytest.approx(1 / (v["Ctc"] + v["Cbc"]), rel=1e-14)
    assert np.all(cavity_stiffness_pa_m3(FINE_HZ, "open") == 0)


def test_cavity_factor_turns_the_open_circuit_into_the_intact_one(circuit):
    """The circuit's cavities are in series with its drum, as the ear's: the open circuit's outputs
    times 1/(1 + Z_cav Y_U), Y_U its drum's volume velocity per Pa, are the intact circuit's."""
    o, i = (circuit.frequency_response(FINE_HZ, c) for c in ("open", "intact"))
    F = cavity_factor(FINE_HZ, o.drum_volume_velocity_m3_s / (2j * np.pi * FINE_HZ))
    for a, b in (
        (o.vestibule_gain, i.vestibule_gain),
        (o.stapes_volume_velocity_m3_s, i.stapes_volume_velocity_m3_s),
        (o.drum_volume_velocity_m3_s, i.drum_volume_velocity_m3_s),
    ):
        np.testing.assert_allclose(a * F, b, rtol=1e-10)


def test_open_circuit_has_no_cavity_notch(circuit):
    """Joining nodes 14 and 15 removes the notch near 4.4 kHz (it is the cavities'); the values the
    data file states for the open circuit are the solve's."""
    g = circuit.frequency_response(FINE_HZ, "open").vestibule_gain_db()
    band = (FINE_HZ > 3e3) & (FINE_HZ < 6e3)
    assert np.all(np.diff(g[band]) < 0)  # falling through the band: no notch
    i = np.argmax(g)
    assert abs(g[i] - 32.6) <= 0.06 and abs(FINE_HZ[i] / 1460 - 1) <= 0.01
    assert abs(np.interp(100.0, FINE_HZ, g) - 7.3) <= 0.06


# ---- the cavity load on the ear: the factor 1/(1 + Z_cav Y_U) against monolithic solves

CAVITY_CHECK_HZ = np.array([150.0, 1500.0, 4400.0, 12e3])  # below, at and past the cavity notch


def test_lumped_ear_cavities_equal_a_monolithic_solve():
    """The lumped ear (40 drum modes, base joint) with the cavities intact equals the dense solve of
    (Z(ω) + K_cav(ω) B Bᵀ) q = B, B the drum's load per Pa: the back pressure K_cav Bᵀq coupled in."""
    from isj.lumped.ear import ear_model

    ear = ear_model(drum_modes=40)
    s = ear.system
    f, w = CAVITY_CHECK_HZ, 2 * np.pi * CAVITY_CHECK_HZ
    Z = s.stiffness()[0][None] + 1j * w[:, None, None] * s.E[None] - w[:, None, None] ** 2 * s.M[None]
    Z = Z + cavity_stiffness_pa_m3(f)[:, None, None] * (s.B @ s.B.T)[None]
    q = np.linalg.solve(Z, np.broadcast_to(s.B.astype(complex), (f.size, *s.B.shape)))
    direct = np.einsum("ij,fjk->fi", s.C, q)
    intact = ear.with_cavities("intact").frequency_response(f).response[:, :, 0]
    np.testing.assert_allclose(intact, direct, rtol=1e-9, atol=1e-12 * np.abs(direct).max())
    # the default is open and leaves the ear as it was; the cavities lower the stapes at 150 Hz
    assert ear.cavities == "open"
    np.testing.assert_array_equal(ear.frequency_response(f).response, ear._open_transfer(s, f))
    drop_db = db(intact[0, 1] / ear.frequency_response(f).response[0, 1, 0])
    v = cavity_values()
    x0 = abs(ear.drum_volume_m3([150.0])[0])
    assert drop_db == pytest.approx(db(1 / (1 + x0 / (v["Ctc"] + v["Cbc"]))), abs=0.05)


@pytest.mark.slow  # the rigid-joint FE ear: a mesh and four sparse solves
def test_fe_ear_cavities_equal_a_monolithic_solve():
    """The FE ear (rigid joint, published damping): the bordered sparse solve
    [Z f; fᵀ −1/K_cav] [q; p_cav] = [f; 0], the cavity pressure an unknown acting back on the drum
    through its nodal force per Pa f, equals the open solve Z q = f times 1/(1 + K_cav fᵀq) to
    round-off (one solver for both); the direct harmonic solve with ``cavities="intact"`` (PARDISO)
    agrees with it to the two solvers' own difference on the open ear."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla
    from isj.fem.ear.dynamics import damping_data, harmonic, reduced_mass
    from isj.fem.ear.middle_ear import MiddleEarModel

    ear = MiddleEarModel(joint=None)
    f_hz = CAVITY_CHECK_HZ[[0, 2]]
    intact = harmonic(ear, f_hz, cavities="intact", keep_displacement=True).displacement
    opened = harmonic(ear, f_hz, keep_displacement=True).displacement
    K, M = ear.stiffness(), reduced_mass(ear)
    L, C = damping_data(ear)
    f = ear.load_reduced
    kc = cavity_stiffness_pa_m3(f_hz)
    for i, w in enumerate(2 * np.pi * f_hz):
        Z = sp.csr_matrix((K.data + 1j * (L + w * C) - w**2 * M.data, K.indices, K.indptr), shape=K.shape)
        col = sp.csr_matrix(f[:, None])
        A = sp.bmat([[Z, col], [col.T, sp.csr_matrix([[-1 / kc[i]]])]], format="csc")
        x = spla.spsolve(A, np.concatenate([f, [0.0]]).astype(complex))
        q_open = spla.spsolve(Z.tocsc(), f.astype(complex))
        factor = cavity_factor(f_hz[i : i + 1], [f @ q_open])[0]
        # round-off: the factor's solution satisfies the bordered system as well as its own solve does
        # (backward error ‖A x − b‖ / (‖A‖ ‖x‖)); they differ by the system's conditioning (≈ 1e-7)
        y = np.concatenate([factor * q_open, [kc[i] * (f @ (factor * q_open))]])
        rhs = np.concatenate([f, [0.0]])
        back_y, back_x = (np.abs(A @ v - rhs).max() / (spla.norm(A, 1) * np.abs(v).max()) for v in (y, x))
        assert back_y <= 10 * back_x + 1e-15, (back_y, back_x)
        np.testing.assert_allclose(x[:-1], factor * q_open, rtol=0, atol=1e-6 * np.abs(x[:-1]).max())
        assert x[-1] == pytest.approx(kc[i] * (f @ x[:-1]), rel=1e-8)  # p_cav = K_cav fᵀq
        u = ear.T @ x[:-1]
        solvers = np.abs(opened[i] - ear.T @ q_open).max()  # PARDISO against SuperLU, open ear
        assert np.abs(intact[i] - u).max() <= 2 * solvers + 1e-12 * np.abs(u).max()
        assert abs(factor) < 0.8  # the cavities matter: −2.9 dB at 150 Hz, −16 dB at 4.4 kHz


def test_band_deviation_of_a_known_ratio():
    """An ear that is the reference times 10^(1/20) e^(i 10°) deviates by 1 dB and 10° in every band."""
    f = np.geomspace(100, 20e3, 90)
    ref = np.exp(1j * f / 3e3) / f
    rows = __import__("isj.studies.circuit_comparison", fromlist=["x"]).band_deviation(
        f, ref * 10 ** (1 / 20) * np.exp(1j * np.radians(10)), ref
    )
    assert [r["band_hz"] for r in rows][-1] == [12800.0, 20000.0] and len(rows) == 8
    assert sum(r["n_freq"] for r in rows) == f.size
    for r in rows:
        assert r["mean_abs_db"] == pytest.approx(1.0, abs=1e-12) and r["max_abs_db"] == pytest.approx(1.0)
        assert r["mean_abs_deg"] == pytest.approx(10.0, abs=1e-9) and r["mean_db"] == pytest.approx(1.0)


def test_lumped_comparison_pairs_the_same_states():
    """The study compares each cavity state with the circuit in that state; the intact ear over the
    open one is the cavity factor of the ear's own drum volume."""
    from isj.lumped.ear import ear_model

    from isj.studies.circuit_comparison import lumped_ear_comparison

    f = np.geomspace(100, 20e3, 40)
    r = lumped_ear_comparison(f, drum_modes=40)
    assert "not a measurement" in r["what"] and r["default_cavities"] == "open"
    c = CatCircuit.load()
    for state in ("open", "intact"):
        got = np.asarray(r["states"][state]["circuit"]["vestibule_gain"]["db"])
        np.testing.assert_allclose(got, c.frequency_response(f, state).vestibule_gain_db(), rtol=1e-12)
        assert len(r["states"][state]["deviation_per_band"]["stapes_volume_velocity"]) == 8
    e = {
        s: np.asarray(r["states"][s]["ear"]["stapes_volume_velocity"]["magnitude"])
        for s in ("open", "intact")
    }
    F = cavity_factor(f, ear_model(drum_modes=40).drum_volume_m3(f))
    np.testing.assert_allclose(e["intact"] / e["open"], np.abs(F), rtol=1e-9)


def test_circuit_page_is_json_and_refuses_bad_input():
    """The report page's data: JSON-able, the statement, both states; bad input names its parameter."""
    from isj.studies.circuit_comparison import circuit_page, compare_with_circuit

    f = np.geomspace(100, 20e3, 12)
    page = json.loads(json.dumps(circuit_page(f, drum_modes=20)))
    assert "not a measurement" in page["statement"] and page["fe"] is None
    assert set(page["lumped"]["states"]) == {"open", "intact"}
    assert page["check_values"]["computed"]["vestibule_pressure_gain_db"]["1000"] == pytest.approx(
        29.1, abs=0.06
    )
    with pytest.raises(InvalidParameter, match="stapes_velocity_m_s"):
        compare_with_circuit(f, {"closed": f}, 1.26e-6, 1.2e11)
    with pytest.raises(InvalidParameter, match="footplate_area_m2"):
        compare_with_circuit(f, {"open": f}, -1.0, 1.2e11)
