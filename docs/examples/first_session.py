"""The tutorial's first Python session (docs/tutorial.md, "A first Python session").

Run from the repository root: ``.venv/bin/python docs/examples/first_session.py``.
tests/test_docs.py runs it and checks the numbers it prints against the physics.
"""

import numpy as np

import isj

# The calibrated lumped model: microseconds per design.
lm = isj.LumpedModel.default()
base = lm.static()  # the default design, 28.5 Pa on the incus
soft = lm.static(gap_e_pa=5e6)  # a softer joint gap
print(f"default:   alpha {base.alpha_rad * 1e6:.3f} urad, beta {base.beta_rad * 1e6:.3f} urad")
print(f"gap 5 MPa: alpha {soft.alpha_rad * 1e6:.3f} urad, beta {soft.beta_rad * 1e6:.3f} urad")

# Vectorised: a thousand designs in one call.
gaps_pa = np.geomspace(2e6, 5e7, 1000)
many = lm.static(gap_e_pa=gaps_pa)
print(f"beta over the gap range: {many.beta_rad.min() * 1e6:.2f} to {many.beta_rad.max() * 1e6:.2f} urad")

# The FE verifier of the same design, on a coarse mesh (seconds; the mesh is cached).
fe = isj.PedicleJointModel(order=2, resolution=0.5)
res = fe.static(isj.Materials(gap_e_pa=5e6))
print(f"FE (P2, coarse): alpha {res.alpha_rad * 1e6:.3f} urad, beta {res.beta_rad * 1e6:.3f} urad")
print(sorted(res.to_dict())[:6])
