"""Studies built on the models: exploration of the design space, frequency sweeps, uncertainty.

These use the lumped model, its calibration and the FE verifier; they are not part of the
calibration itself. ``isj.studies.explore`` maps the lumped model over many designs,
``isj.studies.sweeps`` sweeps the lumped chain and ear against FE harmonic solves, and
``isj.studies.uq`` carries the moduli's uncertainty to the outputs (``isj.studies.uq_inputs``
holds its inputs). The guard and the region map stay in :mod:`isj.calibration`: the adaptive
calibration places its designs with them and the artifact stores the map.
"""
