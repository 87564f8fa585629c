"""Mesh convergence of the base case's α and β (P1 and P2), and the thesis's mesh.

Run:  .venv/bin/python benchmarks/mesh_study.py [--orders 2] [--resolutions 0.5 0.71 1 1.41 2]

For each order, solves the base case on a ladder of geometrically similar graded
meshes (every size divided by R), prints α, β, dofs and time per level, and
Richardson-extrapolates the last three levels to the mesh-converged values
(observed order p). Then answers how far a thesis-like mesh (≈ 13,209 linear
tetrahedra, no grading towards the singular edges) is from them. Writes
``benchmarks/results/mesh_study.json``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from fem.convergence import joint_study, richardson
from fem.export import atomic_write_json
from fem.geometry import DEFAULT_SIZES_M, MeshSizes
from fem.model import PedicleJointModel
from isj.cases import THESIS_N_TETS

OUT = Path(__file__).resolve().parent / "results" / "mesh_study.json"


def thesis_like(target_tets: int = THESIS_N_TETS):
    """P1 on a mesh without edge grading, sized to ≈ the thesis's element count."""
    ungraded = MeshSizes(pedicle_edge_m=1.0, capsule_edge_m=1.0, gap_edge_m=1.0)
    lo, hi = 0.3, 3.0
    best = None
    for _ in range(12):  # bisection on the resolution for the tet count
        r = math.sqrt(lo * hi)
        m = PedicleJointModel(order=1, resolution=r, sizes=ungraded)
        best = (
            (r, m)
            if best is None or abs(m.n_tets - target_tets) < abs(best[1].n_tets - target_tets)
            else best
        )
        if abs(m.n_tets - target_tets) < 0.03 * target_tets:
            break
        lo, hi = (r, hi) if m.n_tets < target_tets else (lo, r)
    r, m = best
    res = m.solve()
    return {
        "resolution": r,
        "n_tets": m.n_tets,
        "n_dofs": m.n_dofs,
        "alpha_rad": res.alpha_rad,
        "beta_rad": res.beta_rad,
        "sizes": ungraded.as_dict(),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--orders", type=int, nargs="+", default=[2, 1])
    ap.add_argument("--resolutions", type=float, nargs="+", default=[0.5, 0.71, 1.0, 1.41, 2.0])
    args = ap.parse_args(argv)
    ratio = args.resolutions[-1] / args.resolutions[-2]
    out = {
        "default_sizes_m": MeshSizes().as_dict(),
        "region_sizes_m": DEFAULT_SIZES_M,
        "orders": {},
    }
    for order in args.orders:
        print(f"P{order}: R, tets, dofs, alpha (urad), beta (urad), time (s)")
        rows = joint_study(
            order,
            args.resolutions,
            progress=lambda r: print(
                f"  {r['resolution']:5.2f} {r['n_tets']:8d} {r['n_dofs']:8d} {r['alpha_rad'] * 1e6:8.4f} "
                f"{r['beta_rad'] * 1e6:8.4f} {r['time_s']:7.1f}",
                flush=True,
            ),
        )
        ext = {k: richardson([r[k] for r in rows], ratio) for k in ("alpha_rad", "beta_rad")}
        for k, e in ext.items():
            lim = e["limit"]
            txt = f"{lim * 1e6:.4f} urad (observed order {e['order']:.2f})" if lim else "no asymptotic regime"
            print(f"  {k}: extrapolated {txt}; last change {100 * e['last_rel_change']:.2f} %")
        out["orders"][str(order)] = {"rows": rows, "richardson": ext}
    ref = out["orders"].get("2", next(iter(out["orders"].values())))["richardson"]
    if all(ref[k]["limit"] for k in ("alpha_rad", "beta_rad")):
        for d in out["orders"].values():
            for r in d["rows"]:
                r["alpha_error"] = r["alpha_rad"] / ref["alpha_rad"]["limit"] - 1
                r["beta_error"] = r["beta_rad"] / ref["beta_rad"]["limit"] - 1
        t = thesis_like()
        t["alpha_error"] = t["alpha_rad"] / ref["alpha_rad"]["limit"] - 1
        t["beta_error"] = t["beta_rad"] / ref["beta_rad"]["limit"] - 1
        out["thesis_like_p1"] = t
        print(
            f"thesis-like P1 mesh ({t['n_tets']} tets, no edge grading): alpha "
            f"{100 * t['alpha_error']:+.1f} %, beta {100 * t['beta_error']:+.1f} % from converged"
        )
    atomic_write_json(OUT, out)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
