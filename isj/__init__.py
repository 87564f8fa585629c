"""isj: mechanics of the coupling between the incus and the stapes.

This small package holds the shared vocabulary (design parameters, the thesis
cases) and the command line; the models live in the top-level packages
``fem``, ``lumped``, ``calibration`` and ``reports``.
"""

__version__ = "0.1.0"
