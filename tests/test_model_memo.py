"""fem/batch.py's memo of models: what transient_models keeps, with a stand-in model (no meshing)."""

import dataclasses

import pytest
from isj.fem import batch

from isj.design import Geometry
from isj.errors import InvalidParameter


class _Mesh:
    def content_hash(self) -> str:
        return "stand-in"


class _StandIn:
    built = 0

    def __init__(self, geometry, order, resolution, joint, analyse_ahead=False):
        type(self).built += 1
        self.geometry, self.mesh = geometry, _Mesh()
        self.freed = 0

    def free_solver(self):
        self.freed += 1


@pytest.fixture
def stand_in(monkeypatch):
    monkeypatch.setattr(batch, "PedicleJointModel", _StandIn)
    monkeypatch.setattr(batch, "_MODELS", {})
    _StandIn.built = 0
    return _StandIn


def _geometry(k: int) -> Geometry:
    return dataclasses.replace(Geometry(), gap_thickness_m=Geometry().gap_thickness_m * (1 + 0.05 * k))


def test_a_transient_block_keeps_one_new_model_at_a_time_and_restores_the_memo(stand_in):
    report_model = batch._model(Geometry(), 2, 1.0)
    with batch.transient_models():
        assert report_model[0].freed == 1  # its factorization released on entering
        for k in range(1, 4):
            batch._model(_geometry(k), 2, 1.0)
            new = [m for m, _ in batch._MODELS.values() if m.geometry != Geometry()]
            assert len(new) == 1 and new[0].geometry == _geometry(k)  # the older ones dropped
        assert batch._model(Geometry(), 2, 1.0) is report_model  # kept through the block
    assert list(batch._MODELS.values()) == [report_model]
    assert stand_in.built == 4


def test_outside_a_block_the_memo_keeps_its_four_newest(stand_in):
    for k in range(6):
        batch._model(_geometry(k), 2, 1.0)
    assert [m.geometry for m, _ in batch._MODELS.values()] == [_geometry(k) for k in range(2, 6)]


@pytest.mark.parametrize("bad", [0, -1, 1.5, True])
def test_transient_models_refuses_a_bad_count(bad):
    with pytest.raises(InvalidParameter, match="max_new"), batch.transient_models(bad):
        pass


def test_shared_ears_are_built_once_and_dropped_by_a_transient_block(stand_in, monkeypatch):
    from isj.fem.ear import shared

    class _Ear:
        built = 0

        def __init__(self, joint=None, drum_mesh_size_m=None):
            type(self).built += 1
            self.joint, self.drum_mesh_size_m = joint, drum_mesh_size_m

        def rigid_connection(self):
            return _Ear(None, self.drum_mesh_size_m)

    monkeypatch.setattr(shared, "MiddleEarModel", _Ear)
    shared._EARS.clear()  # the dict itself: transient_models empties this one
    settings = {"order": 2, "resolution": 1.0}
    try:
        ear = shared.shared_ear(settings, 1e-4)
        assert shared.shared_ear(settings, 1e-4) is ear and ear.joint is batch.shared_model(settings)[0]
        rigid = shared.shared_ear(settings, 1e-4, rigid=True)
        assert rigid.joint is None and shared.shared_ear(settings, 1e-4, rigid=True) is rigid
        assert shared.shared_ear(settings, 2e-4) is not ear  # another drum, another ear
        assert _Ear.built == 3
        with batch.transient_models():
            assert not shared._EARS
        assert shared.shared_ear(settings, 1e-4) is not ear  # built again after the block
    finally:
        shared._EARS.clear()  # no stand-in ears left for later tests


@pytest.mark.slow
def test_a_freed_model_solves_again_to_the_same_bits():
    """free_solver drops the factorization, not the model: the next new design is analysed and
    factored again and gives what a model that never freed gives."""
    import numpy as np
    from isj.fem.model import PedicleJointModel

    from isj.design import Materials

    kept, freed = (PedicleJointModel(order=1, resolution=0.35) for _ in range(2))
    for model in (kept, freed):
        model.static(Materials())
    freed.free_solver()
    assert freed._solver is None
    assert freed.static(Materials()) is freed.static(Materials())  # the kept result stays
    soft = Materials(gap_e_pa=3e6)
    a, b = kept.static(soft), freed.static(soft)
    assert freed._solver is not None
    assert (a.alpha_rad, a.beta_rad) == (b.alpha_rad, b.beta_rad)
    assert np.array_equal(a.displacement_m, b.displacement_m)
