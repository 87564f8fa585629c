"""The joint angle α and the pedicle angle β (docs/model.md §2.4, thesis eq. 7.1–7.2).

Each rotation about y of a face normal to z is measured from the z
displacements of two points of that face, in the plane y = 0, at x = ±0.4 w
(w the face's width in x):

    θ = −(u_z(+0.4 w) − u_z(−0.4 w)) / (0.8 w)

β = θ(incus face at the pedicle) − θ(plate face at the pedicle) and
α = θ(plate face at the gap) − θ(stapes-head face at the gap). The
mesh-independent variant takes θ of each body as its least-squares rigid
rotation about y.
"""

from __future__ import annotations

import numpy as np

from isj.design import Geometry

from .probes import point_operator, rotation_operator
from .space import Space


def face_pairs(g: Geometry) -> dict[str, tuple[str, float, float]]:
    """Faces sampled by the point pairs: name → (body, z of the face (m), width in x (m))."""
    return {
        "incus_at_pedicle": ("incus", g.z_incus, g.incus_x_m),
        "plate_at_pedicle": ("plate", g.z_pedicle, g.joint_x_m),
        "plate_at_gap": ("plate", g.z_plate, g.joint_x_m),
        "stapes_at_gap": ("stapes", g.z_gap, g.joint_x_m),
    }


def angle_operator(space: Space, g: Geometry) -> np.ndarray:
    """(4, n_dofs) dense matrix: rows α, β (point pairs), α, β (least squares), in rad per m."""
    theta = {}
    for name, (body, z, w) in face_pairs(g).items():
        pts = np.array([[0.4 * w, 0.0, z], [-0.4 * w, 0.0, z]])
        P = point_operator(space, pts, body)  # rows: ux,uy,uz of +pt then −pt
        theta[name] = -(P[2].toarray()[0] - P[5].toarray()[0]) / (0.8 * w)
    rot = {body: rotation_operator(space, body)[1] for body in ("incus", "plate", "stapes")}
    return np.vstack(
        [
            theta["plate_at_gap"] - theta["stapes_at_gap"],
            theta["incus_at_pedicle"] - theta["plate_at_pedicle"],
            rot["plate"] - rot["stapes"],
            rot["incus"] - rot["plate"],
        ]
    )
