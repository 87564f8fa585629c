"""The pedicle-and-joint model on a user's mesh (docs/model.md §2.11).

:class:`UserMeshModel` is a :class:`~fem.model.PedicleJointModel` on a ready
mesh (:func:`fem.user_mesh.read_mesh`): loaded face pushed in +x by the
pressure, clamped face fixed, α and β from the least-squares rigid rotations
about y of the bodies (α = ω(plate) − ω(stapes), β = ω(incus) − ω(plate)),
and from point pairs when :func:`read_points` gives them.

The points file (TOML, metres)::

    axis = [0.0, 1.0, 0.0]      # rotation axis, optional (default y)

    [faces.incus_at_pedicle]    # four tables, these names
    region = "incus"
    points = [[-4.0e-5, 0.0, 3.1e-4], [4.0e-5, 0.0, 3.1e-4]]
    [faces.plate_at_pedicle]
    ...
    [faces.plate_at_gap]
    ...
    [faces.stapes_at_gap]
    ...

Each face's rotation θ about the unit axis a is that of the segment from its
first point p₁ to its second p₂: θ = (u(p₂) − u(p₁))·(a × d)/|a × d|², d = p₂ − p₁;
α = θ(plate_at_gap) − θ(stapes_at_gap), β = θ(incus_at_pedicle) − θ(plate_at_pedicle).
For the built-in geometry (:func:`default_points`) this is docs/model.md §2.4's
θ = −(u_z(+0.4 w) − u_z(−0.4 w))/(0.8 w).
"""

from __future__ import annotations

import math
import time
import tomllib
from pathlib import Path

import numpy as np

from isj.design import REGIONS, Geometry
from isj.errors import ConfigError, InvalidMesh, PointOutsideBody
from isj.validate import loads_toml

from .angles import face_pairs
from .boundary import pressure_load
from .model import ElasticModel, PedicleJointModel
from .probes import point_operator, rotation_operator

#: Face names of the points file, in the order α and β use them.
POINT_FACES = ("incus_at_pedicle", "plate_at_pedicle", "plate_at_gap", "stapes_at_gap")


def default_points(geometry: Geometry | None = None) -> dict:
    """The built-in point pairs (docs/model.md §2.4) in the points file's layout (m)."""
    g = geometry or Geometry()
    faces = {}
    for name, (body, z, w) in face_pairs(g).items():
        faces[name] = {"region": body, "points": [[-0.4 * w, 0.0, z], [0.4 * w, 0.0, z]]}
    return {"axis": [0.0, 1.0, 0.0], "faces": faces}


def points_toml(spec: dict) -> str:
    """A points file's text (floats to 17 digits, so it reads back exactly)."""

    def vec(v) -> str:
        return "[" + ", ".join(repr(float(x)) for x in v) + "]"

    lines = [f"axis = {vec(spec['axis'])}", ""]
    for name in POINT_FACES:
        f = spec["faces"][name]
        lines += [f"[faces.{name}]", f'region = "{f["region"]}"']
        lines += [f"points = [{', '.join(vec(p) for p in f['points'])}]", ""]
    return "\n".join(lines)


def read_points(path) -> dict:
    """Read and check a points file; one-line :class:`InvalidMesh` on a bad one."""
    path = Path(path)
    try:
        spec = loads_toml(path.read_text(), str(path))
    except FileNotFoundError:
        raise InvalidMesh(f"{path}: no such file") from None
    except ConfigError as exc:  # nested too deep
        raise InvalidMesh(str(exc)) from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InvalidMesh(f"{path}: not a readable TOML file ({exc})") from None
    unknown = set(spec) - {"axis", "faces"}
    if unknown:
        raise InvalidMesh(f"{path}: unknown key {sorted(unknown)[0]!r}; must be axis or faces")
    axis = spec.get("axis", [0.0, 1.0, 0.0])
    if not _vector(axis) or np.linalg.norm(axis) == 0:
        raise InvalidMesh(f"{path}: axis = {axis!r}: must be three finite numbers, not all zero")
    faces = spec.get("faces")
    if not isinstance(faces, dict):
        raise InvalidMesh(f"{path}: no [faces.NAME] tables; need {', '.join(POINT_FACES)}")
    for name in POINT_FACES:
        if name not in faces:
            raise InvalidMesh(f"{path}: no [faces.{name}] table; need {', '.join(POINT_FACES)}")
    extra = set(faces) - set(POINT_FACES)
    if extra:
        raise InvalidMesh(
            f"{path}: unknown face {sorted(extra)[0]!r}; the faces are {', '.join(POINT_FACES)}"
        )
    for name in POINT_FACES:
        f = faces[name]
        if not isinstance(f, dict) or set(f) != {"region", "points"}:
            raise InvalidMesh(f"{path}: [faces.{name}] must hold exactly region and points")
        if f["region"] not in REGIONS:
            raise InvalidMesh(
                f"{path}: faces.{name}.region = {f['region']!r}: must be one of {', '.join(REGIONS)}"
            )
        pts = f["points"]
        if not (isinstance(pts, list) and len(pts) == 2 and all(_vector(p) for p in pts)):
            raise InvalidMesh(f"{path}: faces.{name}.points: must be two points of three numbers (m)")
        d = np.subtract(pts[1], pts[0])
        if np.linalg.norm(np.cross(axis, d)) == 0:
            raise InvalidMesh(f"{path}: faces.{name}.points: the two points lie on a line along the axis")
    return {"axis": [float(a) for a in axis], "faces": faces}


def _vector(v) -> bool:
    return (
        isinstance(v, list)
        and len(v) == 3
        and all(isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) for x in v)
    )


def point_pair_rows(space, spec: dict, where: str = "points") -> np.ndarray:
    """(2, n_dofs): α and β of the point pairs of ``spec`` (:func:`read_points`), rad per m."""
    a = np.asarray(spec["axis"], dtype=float)
    a = a / np.linalg.norm(a)
    theta = {}
    for name in POINT_FACES:
        f = spec["faces"][name]
        p = np.asarray(f["points"], dtype=float)
        try:
            P = point_operator(space, p, f["region"]).toarray()  # rows ux,uy,uz of p1 then p2
        except PointOutsideBody as exc:
            raise InvalidMesh(f"{where}: faces.{name}: {exc} {f['region']}") from None
        n = np.cross(a, p[1] - p[0])
        theta[name] = n @ (P[3:6] - P[0:3]) / (n @ n)
    return np.vstack(
        [
            theta["plate_at_gap"] - theta["stapes_at_gap"],
            theta["incus_at_pedicle"] - theta["plate_at_pedicle"],
        ]
    )


class UserMeshModel(PedicleJointModel):
    """:class:`~fem.model.PedicleJointModel` on a ready mesh, α and β as the module says.

    Parameters
    ----------
    mesh : fem.mesh.TetMesh with the six regions and faces ``loaded`` and ``clamped``
    order : 1 or 2
    solver : sparse solver backend
    points : a points spec (:func:`read_points` or :func:`default_points`), optional
    points_name : how messages name the points (the file)

    Notes
    -----
    ``alpha_rad``/``beta_rad`` of its results are the point-pair angles when ``points``
    is given, else the least-squares ones (equal to ``alpha_ls_rad``/``beta_ls_rad``);
    :attr:`angle_definition` says which.
    """

    def __init__(
        self, mesh, order: int = 2, solver: str = "auto", points: dict | None = None, points_name="points"
    ):
        if order not in (1, 2):
            raise ValueError(f"order = {order!r}: must be 1 or 2")
        t1 = time.perf_counter()
        ElasticModel.__init__(self, mesh, order, solver)
        self.geometry = None  # the user's anatomy: no parametric geometry
        self.joint = "bonded"  # the joint as meshed (the sliding cut needs the parametric faces)
        self.unit_load = pressure_load(self.space, "loaded", 1.0, (1.0, 0.0, 0.0))
        rot = {body: rotation_operator(self.space, body)[1] for body in ("incus", "plate", "stapes")}
        ls = np.vstack([rot["plate"] - rot["stapes"], rot["incus"] - rot["plate"]])
        pairs = ls if points is None else point_pair_rows(self.space, points, points_name)
        self.angles = np.vstack([pairs, ls])
        self.angle_definition = "least squares" if points is None else "point pairs"
        self.timings_s.update(mesh=0.0, assembly=time.perf_counter() - t1)
