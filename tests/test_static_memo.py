"""A joint model keeps its last static results (fem/model.py ``STATIC_MEMO``): the same bits, no solve."""

from __future__ import annotations

import numpy as np
import pytest

from isj.design import Materials

pytestmark = pytest.mark.slow  # a coarse P1 model, a few solves


@pytest.fixture(scope="module")
def model():
    from isj.fem.model import PedicleJointModel

    return PedicleJointModel(order=1, resolution=0.35)


def _solves(model, monkeypatch) -> list:
    calls = []
    original = type(model)._static

    def counted(self, materials, pressure_pa):
        if self is model:  # not another model's solves
            calls.append(materials)
        return original(self, materials, pressure_pa)

    monkeypatch.setattr(type(model), "_static", counted)
    return calls


def test_the_same_design_again_is_the_kept_result_and_a_new_solve_gives_its_bits(model, monkeypatch):
    from isj.fem.model import PedicleJointModel

    calls = _solves(model, monkeypatch)
    soft = Materials(gap_e_pa=3e6)
    first = model.static(soft)
    model.static(Materials(capsule_e_pa=80e6))  # another factorization in between
    again = model.static(Materials(gap_e_pa=3e6))  # an equal Materials, not the same object
    assert again is first and calls == [soft, Materials(capsule_e_pa=80e6)]
    with pytest.raises(ValueError):
        again.displacement_m[0, 0] = 1.0  # read-only: no caller can change what others get
    fresh = PedicleJointModel(order=1, resolution=0.35).static(soft)
    assert fresh.displacement_m.tobytes() == first.displacement_m.tobytes()
    assert (fresh.alpha_rad, fresh.beta_rad, fresh.strain_energy_j) == (
        first.alpha_rad,
        first.beta_rad,
        first.strain_energy_j,
    )
    model.static(soft, 2 * first.pressure_pa)  # another pressure is another result
    assert len(calls) == 3


def test_the_oldest_result_goes_first(model, monkeypatch):
    import isj.fem.model as fem_model

    monkeypatch.setattr(fem_model, "STATIC_MEMO", 2)
    model.__dict__.pop("_static_memo", None)
    calls = _solves(model, monkeypatch)
    a, b, c = (Materials(gap_e_pa=e) for e in (4e6, 5e6, 6e6))
    for m in (a, b, a, c, a, b):  # a is used again before c comes, so b goes; then c goes for b
        model.static(m)
    assert calls == [a, b, c, b]
    assert np.isfinite(model.static(a).alpha_rad) and len(calls) == 4


def test_the_ear_keeps_its_static_results_and_harmonic_takes_the_umbo_direction_from_them(coarse_ear):
    """The whole ear keeps its static results as the joint model does, and a harmonic solve's umbo
    direction is the kept static solution's (no complex factorization for it)."""
    from isj.fem.ear.dynamics import harmonic

    from isj.ear import EarMaterials

    soft = Materials(gap_e_pa=3e6)
    first = coarse_ear.static(soft, EarMaterials())
    assert coarse_ear.static(Materials(gap_e_pa=3e6)) is first  # equal inputs (the default ear), kept
    with pytest.raises(ValueError):
        first.displacement[0] = 1.0
    res = harmonic(coarse_ear, [500.0, 2000.0], soft, damping="undamped")
    assert res.static is first
    direction = first.umbo_vector_m_per_pa / np.linalg.norm(first.umbo_vector_m_per_pa)
    assert np.array_equal(res.umbo_direction, direction)
    # below the first resonance the undamped umbo moves in phase with its static direction
    umbo = res.umbo_m_per_pa[0]
    assert umbo.real > 0 and abs(umbo.imag) < 1e-12 * abs(umbo)
    np.testing.assert_allclose(
        np.abs(res.umbo_m_per_pa[0]), np.linalg.norm(res.umbo_vector_m_per_pa[0]), rtol=1e-3
    )
