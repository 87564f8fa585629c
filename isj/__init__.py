"""isj: mechanics of the coupling between the incus and the stapes.

The package holds the shared vocabulary (design parameters, the thesis cases)
and the command line; the models live in its subpackages ``isj.fem``,
``isj.lumped``, ``isj.calibration`` and ``isj.reports``.
"""

__version__ = "0.1.0"
