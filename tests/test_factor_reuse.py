"""ElasticModel.factored_solver: one factorization per design shared by static, modal and harmonic
solves, never taken for another design."""

import numpy as np
import pytest
from isj.fem.dynamics import harmonic, modes
from isj.fem.model import PedicleJointModel

from isj.design import Materials

pytestmark = pytest.mark.slow


@pytest.fixture
def counted(monkeypatch):
    """A coarse model whose factorizations are counted."""
    model = PedicleJointModel(order=1, resolution=0.35)
    calls = []
    model.static(Materials())  # makes the solver
    solver = model._solver
    original = solver.factor_upper if hasattr(solver, "factor_upper") else solver.factor

    def counting(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(solver, "factor_upper" if hasattr(solver, "factor_upper") else "factor", counting)
    return model, calls


def test_modes_and_harmonic_after_a_static_solve_of_the_design_factor_nothing(counted):
    model, calls = counted
    fresh = PedicleJointModel(order=1, resolution=0.35)
    f_shared, _ = modes(model, Materials(), 4)
    u_shared = harmonic(model, [2000.0], Materials())
    assert calls == []
    f_fresh, _ = modes(fresh, Materials(), 4)  # its own factorization: the same bits
    assert np.array_equal(f_shared, f_fresh)
    assert np.array_equal(u_shared, harmonic(fresh, [2000.0], Materials()))
    soft = Materials(gap_e_pa=2e6)
    modes(model, soft, 2)
    assert len(calls) == 1  # another design: factored once
    model.static(soft)
    assert len(calls) == 1


def test_a_factorization_by_another_caller_is_not_taken_for_the_models(counted):
    model, calls = counted
    soft = Materials(gap_e_pa=2e6)
    model._solver.factor(model.stiffness(soft))  # someone else's factorization in the model's solver
    calls.clear()
    u = model.static(Materials(pedicle_e_pa=2e9))
    assert len(calls) == 1
    fresh = PedicleJointModel(order=1, resolution=0.35)
    assert np.array_equal(u.displacement_m, fresh.static(Materials(pedicle_e_pa=2e9)).displacement_m)
    # a harmonic solve at the design factored by the other caller factors again too
    calls.clear()
    harmonic(model, [500.0], soft)
    assert len(calls) == 1
