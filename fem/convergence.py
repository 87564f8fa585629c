"""Mesh convergence of the pedicle as a cantilever against beam theory (docs/model.md §2.6).

The pedicle alone, one end face (z = 0) clamped, a uniform shear traction on the
other end face (z = L), once in x (bending about the 55 µm side, the hard case)
and once in y. The reference is Timoshenko's tip deflection

    δ = F L³ / (3 E I) + F L / (κ G A),  κ = 5/6,  G = E / (2 (1 + ν)).

What to expect: the 3-D solution is not a beam. With ν = 0 the mean tip
deflection matches Timoshenko within 0.3 % (tests check it); with ν = 0.3 the
clamped face also stops the Poisson contraction, which stiffens the short
pedicle by a few per cent, and the maximum displacement sits at a corner of the
loaded face. The study reports both the maximum (the thesis's measure) and the
mean over the loaded face.
"""

from __future__ import annotations

import numpy as np

from isj.design import Geometry, Materials

from .boundary import face_areas, traction_load

#: Resolution ladders of the default study (P1 needs finer meshes).
DEFAULT_RESOLUTIONS = {1: (1.0, 1.6, 2.5, 4.0, 6.0), 2: (0.7, 1.0, 1.6, 2.5, 4.0)}


def timoshenko_tip_deflection(
    force_n: float, length_m: float, depth_m: float, width_m: float, youngs_pa: float, nu: float
) -> float:
    """Tip deflection (m) of a cantilever of rectangular section (depth along the load)."""
    inertia = width_m * depth_m**3 / 12
    area = width_m * depth_m
    shear = youngs_pa / (2 * (1 + nu))
    return force_n * length_m**3 / (3 * youngs_pa * inertia) + force_n * length_m / (5 / 6 * shear * area)


def solve_cantilever(
    mesh,
    order: int,
    direction: str,
    youngs_pa: float,
    nu: float,
    force_n: float,
    solver: str = "auto",
) -> dict:
    """Solve a cantilever mesh (region "pedicle", faces "clamped", "loaded") under a shear force (N)."""
    import dataclasses

    from .model import ElasticModel

    axis = "xyz".index(direction)
    # one homogeneous body: its material is the pedicle's, whatever the mesh calls it
    mesh = dataclasses.replace(mesh, region_names=("pedicle",), region=np.zeros_like(mesh.region))
    model = ElasticModel(mesh, order, solver)
    space = model.space
    traction = np.zeros(3)
    traction[axis] = force_n / face_areas(space, "loaded").sum()
    f = traction_load(space, "loaded", traction)
    u = model.solve_load(Materials(pedicle_e_pa=youngs_pa, nu=nu), f).reshape(-1, 3)
    tip = space.face_nodes("loaded")
    # mean over the face, area-weighted through the consistent load (∫ N_i dA)
    w = f.reshape(-1, 3)[tip, axis]
    return {
        "n_tets": int(space.n_tets),
        "n_dofs": int(model.n_dofs),
        "max_disp_m": float(np.linalg.norm(u, axis=1).max()),
        "tip_mean_m": float(w @ u[tip, axis] / w.sum()),
    }


def cantilever_study(
    direction: str = "x",
    order: int = 2,
    nu: float | None = None,
    resolutions=None,
    geometry: Geometry | None = None,
    youngs_pa: float | None = None,
    force_n: float = 1e-6,
    cache_dir=None,
) -> list[dict]:
    """Maximum displacement against element count for a ladder of gmsh meshes.

    Returns a list of ``{n_tets, n_dofs, max_disp_m, tip_mean_m, analytic_m,
    rel_error}`` with ``rel_error = max_disp_m / analytic_m − 1``.
    """
    from .mesh import mesh_cantilever

    if direction not in ("x", "y"):
        raise ValueError(f"direction = {direction!r}: must be 'x' or 'y'")
    g = geometry or Geometry()
    m = Materials()
    nu = m.nu if nu is None else nu
    E = m.pedicle_e_pa if youngs_pa is None else youngs_pa
    depth, width = (g.pedicle_x_m, g.pedicle_y_m) if direction == "x" else (g.pedicle_y_m, g.pedicle_x_m)
    analytic = timoshenko_tip_deflection(force_n, g.pedicle_length_m, depth, width, E, nu)
    rows = []
    for r in resolutions or DEFAULT_RESOLUTIONS[order]:
        mesh = mesh_cantilever(g, resolution=r, cache_dir=cache_dir)
        row = solve_cantilever(mesh, order, direction, E, nu, force_n)
        row.update(resolution=float(r), analytic_m=analytic, rel_error=row["max_disp_m"] / analytic - 1)
        rows.append(row)
    return rows


def plot_study(rows: list[dict], path, title: str = "", ax=None):
    """Displacement against tetrahedra (log x): FE max |u|, FE mean tip u and Timoshenko's value.

    Parameters
    ----------
    rows : :func:`cantilever_study`'s rows
    path : file to write (format from the suffix) when ``ax`` is None
    title : axes title
    ax : matplotlib Axes to draw on (nothing is written then), or None for a new figure

    Returns
    -------
    the Axes drawn on
    """
    from isj.atomic import atomic_write

    own = ax is None
    if own:  # a bare Figure, no pyplot: the caller's backend is left alone
        from matplotlib.figure import Figure

        fig = Figure(figsize=(5.5, 4))
        ax = fig.subplots()
    n = [r["n_tets"] for r in rows]
    ax.plot(n, [r["max_disp_m"] for r in rows], "o-", label="FE max |u|")
    ax.plot(n, [r["tip_mean_m"] for r in rows], "s--", label="FE mean tip u")
    ax.axhline(rows[0]["analytic_m"], color="k", lw=1, label="Timoshenko")
    ax.set_xscale("log")
    ax.set_xlabel("tetrahedra")
    ax.set_ylabel("displacement (m)")
    ax.set_title(title)
    ax.legend()
    if own:
        fig.tight_layout()
        atomic_write(path, lambda tmp: fig.savefig(tmp, format=str(path).rsplit(".", 1)[-1]))
    return ax


def richardson(values, ratio: float) -> dict:
    """Extrapolate the last three of a sequence on meshes refined by a constant ``ratio``.

    Assumes error ∝ h^p. Returns ``{"limit", "order", "last_rel_change"}``; the
    limit is None when the sequence is not monotone (no asymptotic regime yet).
    """
    f1, f2, f3 = (float(v) for v in values[-3:])
    d1, d2 = f2 - f1, f3 - f2
    out = {"limit": None, "order": None, "last_rel_change": abs(d2 / f3)}
    if d1 * d2 > 0 and abs(d2) < abs(d1):
        p = np.log(d1 / d2) / np.log(ratio)
        out.update(order=float(p), limit=float(f3 + d2 / (ratio**p - 1)))
    return out


def joint_study(
    order: int = 2, resolutions=(0.5, 0.71, 1.0, 1.41), sizes=None, cache_dir=None, progress=None
) -> list[dict]:
    """α and β of the base case on a ladder of meshes (the thesis's model itself)."""
    import time

    from .model import PedicleJointModel

    rows = []
    for r in resolutions:
        t0 = time.perf_counter()
        m = PedicleJointModel(order=order, resolution=r, sizes=sizes, cache_dir=cache_dir)
        res = m.static()
        rows.append(
            {
                "order": order,
                "resolution": float(r),
                "n_tets": m.n_tets,
                "n_dofs": m.n_dofs,
                "alpha_rad": res.alpha_rad,
                "beta_rad": res.beta_rad,
                "alpha_ls_rad": res.alpha_ls_rad,
                "beta_ls_rad": res.beta_ls_rad,
                "time_s": time.perf_counter() - t0,
            }
        )
        if progress:
            progress(rows[-1])
        del m
    return rows
