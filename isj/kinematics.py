"""Small motions of rigid bodies with six dofs at a reference point, for the FE and the lumped ear.

A rigid body's dofs are q = (u, θ) at its reference point x₀: translation (m)
and small rotation vector (rad). A point x of the body moves by

    u(x) = u + θ × (x − x₀) = G(x) q,   G(x) = [I, −[x − x₀]×]   (3 × 6),

so a translational spring of 3 × 3 stiffness k (N/m) from x to ground adds
Gᵀ k G to the body's 6 × 6 stiffness: a spring at an offset point contributes
rotational stiffness (N·m/rad) and translation–rotation coupling (N). A mass m
at the centroid c with isotropic rotary inertia m r_g² adds m G(c)ᵀ G(c) plus
m r_g² on the rotations.

One implementation for :mod:`isj.fem.ear` (the FE ear's rigid ossicles) and
:mod:`isj.lumped.ear` (the lumped ear), which must not import each other.
"""

from __future__ import annotations

import numpy as np


def skew(r) -> np.ndarray:
    """(..., 3, 3) cross-product matrices: skew(r) @ v = r × v."""
    r = np.asarray(r, dtype=float)
    out = np.zeros(r.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -r[..., 2], r[..., 1]
    out[..., 1, 0], out[..., 1, 2] = r[..., 2], -r[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -r[..., 1], r[..., 0]
    return out


def point_map(points_m, reference_m) -> np.ndarray:
    """(P, 3, 6) maps G from the body's dofs (u, θ) at ``reference_m`` to the points' displacements.

    Parameters
    ----------
    points_m : (3,) or (P, 3) points of the body (m); a single point gives P = 1
    reference_m : (3,) the body's reference point (m)
    """
    r = np.atleast_2d(np.asarray(points_m, dtype=float)) - np.asarray(reference_m, dtype=float)
    G = np.zeros((len(r), 3, 6))
    G[:, :, :3] = np.eye(3)
    G[:, :, 3:] = -skew(r)
    return G


def grounded_springs(reference_m, points_m, stiffness_n_m) -> np.ndarray:
    """6 × 6 stiffness of the body (SI) from translational springs between its points and ground.

    Parameters
    ----------
    reference_m : (3,) the body's reference point (m)
    points_m : (P, 3) attachment points on the body (m)
    stiffness_n_m : (P, 3, 3) symmetric spring stiffness of each attachment (N/m); for a spring
        of stiffness k along unit d, k d dᵀ

    Returns
    -------
    Σ Gᵀ k G: rows/columns (u_x, u_y, u_z, θ_x, θ_y, θ_z); N/m, N and N·m/rad blocks.
    """
    G = point_map(points_m, reference_m)
    k = np.asarray(stiffness_n_m, dtype=float).reshape(-1, 3, 3)
    return np.einsum("pia,pij,pjb->ab", G, k, G)


def rigid_mass(mass_kg: float, gyration_m: float, centroid_m, reference_m) -> np.ndarray:
    """6 × 6 mass (kg, kg·m, kg·m²) of a rigid body for its dofs (u, θ) at ``reference_m``.

    Mass ``mass_kg`` at ``centroid_m`` (m) with isotropic rotary inertia m r_g² about it
    (``gyration_m`` = r_g, m): m GᵀG + m r_g² diag(0, I), G = [I, −[c − x₀]×].
    """
    G = point_map(centroid_m, reference_m)[0]
    M = mass_kg * G.T @ G
    M[3:, 3:] += mass_kg * gyration_m**2 * np.eye(3)
    return M


def axis_of_rotation(u_m, theta_rad, reference_m) -> dict:
    """Instantaneous screw axis of a small rigid motion (u, θ) at ``reference_m``.

    The point of least motion is p = x₀ + θ × u / |θ|², the foot of the axis nearest
    the reference point: there the motion is θ (θ·u) / |θ|², along the axis.

    Returns
    -------
    {"point_m": p, "direction": θ/|θ|, "rotation_rad": |θ|, "axial_translation_m": θ·u/|θ|}
    (lists, SI units, per unit load if (u, θ) is).
    """
    u = np.asarray(u_m, dtype=float)
    th = np.asarray(theta_rad, dtype=float)
    t2 = float(th @ th)
    if t2 == 0.0:
        raise ValueError("theta_rad = 0: a pure translation has no axis of rotation")
    p = np.asarray(reference_m, dtype=float) + np.cross(th, u) / t2
    return {
        "point_m": p.tolist(),
        "direction": (th / np.sqrt(t2)).tolist(),
        "rotation_rad": float(np.sqrt(t2)),
        "axial_translation_m": float(th @ u / np.sqrt(t2)),
    }
