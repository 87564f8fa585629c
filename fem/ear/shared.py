"""Whole ears shared within a process.

The report's steps (the ear, the transmission and the uncertainty steps) build the same ear
around the same joint model several times: 2 s each on the default drum, and hundreds of MB
held. :func:`shared_ear` builds each once per process, around the joint model
:func:`fem.batch.shared_model` memoises. A :func:`fem.batch.transient_models` block empties
this memo on entering.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping

from isj.ear import DEFAULT_DRUM_MESH_SIZE_M

from .. import batch
from .middle_ear import MiddleEarModel

#: Whole ears built in this process around a memoised joint model, by (joint, drum element size,
#: rigid): each holds its constraint map and pattern (hundreds of MB on the default drum).
_EARS: dict[tuple, tuple] = {}
_MAX_EARS = 3
_LOCK = threading.RLock()  # a rigid connection is built from the ear, under the same lock

batch.TRANSIENT_CLEARS.append(_EARS.clear)


def shared_ear(
    settings: Mapping, drum_mesh_size_m: float | None = None, rigid: bool = False
) -> MiddleEarModel:
    """The whole ear this process memoises around :func:`fem.batch.shared_model`'s joint for
    ``settings``, or with ``rigid`` that ear's rigid connection.

    Parameters
    ----------
    settings : the FE settings (:func:`fem.batch.fe_settings`)
    drum_mesh_size_m : the drum's element size (m); None: the default
    rigid : the ear's rigid connection instead of the joint

    Notes
    -----
    The ear holds no factorization between callers: a caller that solves with it frees its
    solver (:meth:`~fem.ear.middle_ear.MiddleEarModel.free_solver`) when it is done.
    """
    drum = float(DEFAULT_DRUM_MESH_SIZE_M if drum_mesh_size_m is None else drum_mesh_size_m)
    with _LOCK:
        joint, _ = batch.shared_model(settings)
        key = (id(joint), drum, bool(rigid))  # the entry holds the joint: its id stays its own
        if key not in _EARS:
            if rigid:
                ear = shared_ear(settings, drum).rigid_connection()
            else:
                ear = MiddleEarModel(joint=joint, drum_mesh_size_m=drum)
            if len(_EARS) >= _MAX_EARS:
                _EARS.pop(next(iter(_EARS)))  # oldest first
            _EARS[key] = (joint, ear)
        return _EARS[key][1]
