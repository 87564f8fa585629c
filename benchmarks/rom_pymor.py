"""pyMOR against isj's own certified reduced basis (docs/rom.md §10.11), on the test's coarse P1 mesh.

The same affine parts (region matrices A_r, load f, functionals ℓ_α, ℓ_β, X = K(μ̄)) go into a
pyMOR ``StationaryModel`` (``LincombOperator`` of ``NumpyMatrixOperator`` with
``ProjectionParameterFunctional`` coefficients). Two pyMOR greedies run on isj's training set
(32 corners + 1024 Sobol designs):

- ``rb_greedy`` with ``CoerciveRBReductor`` (min-θ coercivity): pyMOR's stock greedy, driven by
  the energy-norm state error estimate, to the relative state tolerance that isj's outputs need;
- a ``weak_greedy`` driven by ``DWRCoerciveRBReductor``'s primal–dual output bound
  (‖r_pr‖‖r_du‖/α_LB) relative to the output, to isj's own target 0.5·tol on α, β and β/α,
  extending primal and both dual bases at each step: the same criterion as isj's greedy.

Then: offline time, basis sizes, online time per design, bound quality, and the true relative
error in α, β against FE (the same matrices, solved directly) at the corners and random designs.
Usage: ``.venv/bin/python benchmarks/rom_pymor.py`` (writes benchmarks/results/rom_pymor.json).
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

try:
    import pymor  # noqa: F401
except ImportError:
    print("rom_pymor: pymor is not installed (pip install pymor); nothing measured")
    sys.exit(0)

from isj.fem.model import PedicleJointModel
from isj.fem.rom.model import build_reduced_model
from isj.fem.rom.offline import affine_parts
from pymor.algorithms.greedy import WeakGreedySurrogate, rb_greedy, weak_greedy
from pymor.core.logger import set_log_levels
from pymor.models.basic import StationaryModel
from pymor.operators.constructions import LincombOperator
from pymor.operators.numpy import NumpyMatrixOperator
from pymor.parameters.functionals import GenericParameterFunctional, ProjectionParameterFunctional
from pymor.reductors.coercive import CoerciveRBReductor
from pymor.reductors.dwr import DWRCoerciveRBReductor

from isj.design_space import DesignSpace

TOL = 1e-3  # isj's default target; both greedies run to 0.5·tol on the training set
OUT = Path(__file__).parent / "results" / "rom_pymor.json"
set_log_levels({"pymor": "WARN"})


def pymor_fom(mats, f, ell, X):
    """The FE model as a pyMOR StationaryModel, parameter 'theta' = the six region moduli (Pa)."""
    n_r = len(mats)
    op = LincombOperator(
        [NumpyMatrixOperator(A) for A in mats],
        [ProjectionParameterFunctional("theta", n_r, i) for i in range(n_r)],
    )
    fom = StationaryModel(
        op,
        NumpyMatrixOperator(f[:, None]),
        output_functional=NumpyMatrixOperator(ell),
        products={"energy": NumpyMatrixOperator(X)},
    )
    # dual problems K ψ = −ℓ (K symmetric), built directly: pyMOR's default builds them through
    # a concatenation with a unit vector for a vector-valued output
    duals = [fom.with_(rhs=NumpyMatrixOperator(-ell[d][:, None]), output_functional=None) for d in range(2)]
    return fom, duals


def rel_output_bound(out, bound):
    """Largest relative bound over α, β and β/α (β/α through its interval, as isj's greedy)."""
    ra, rb = bound[0] / abs(out[0]), bound[1] / abs(out[1])
    rr = (ra + rb) / (1 - ra) if ra < 1 else np.inf
    return max(ra, rb, rr)


class DWRSurrogate(WeakGreedySurrogate):
    """weak_greedy surrogate: the DWR output bound relative to the output, three bases extended."""

    def __init__(self, fom, duals, reductor):
        self.fom, self.duals, self.reductor = fom, duals, reductor
        self.rom = reductor.reduce()

    def evaluate(self, mus, return_all_values=False):
        errs = np.array([self._rel(mu) for mu in mus])
        if return_all_values:
            return errs
        i = int(np.argmax(errs))
        return errs[i], mus[i]

    def _rel(self, mu):
        d = self.rom.compute(output=True, output_error_estimate=True, mu=mu)
        return rel_output_bound(d["output"].ravel(), d["output_error_estimate"].ravel())

    def extend(self, mu):
        U = self.fom.solve(mu)
        P = [m.solve(mu) for m in self.duals]
        self.reductor.extend_basis(U, P)
        self.rom = self.reductor.reduce()


def main() -> None:
    space = DesignSpace()
    load0 = float(os.getloadavg()[0])
    t0 = time.perf_counter()
    model = PedicleJointModel(order=1, resolution=0.35)
    t_assemble = time.perf_counter() - t0
    _, _, mats, f, ell = affine_parts(model, space.nu)
    theta_bar = space.theta(space.center()[None])[0]
    X = sum(t * A for t, A in zip(theta_bar, mats, strict=True)).tocsc()
    fom, duals = pymor_fom(mats, f, ell, X)
    Xop = fom.products["energy"]
    min_theta = GenericParameterFunctional(lambda mu: float(np.min(mu["theta"] / theta_bar)), fom.parameters)
    train_E = np.concatenate([space.corners(), space.sample(1024, 0)])
    train = [fom.parameters.parse(th) for th in space.theta(train_E)]
    print(f"coarse P1 mesh: {model.n_dofs} dofs; training set {len(train)}; load {os.getloadavg()[0]:.2f}")

    # --- isj: the full build (greedy + 8,304-design validation + local bases), no cache
    t0 = time.perf_counter()
    rom = build_reduced_model(model, space, tol=TOL)
    t_isj = time.perf_counter() - t0
    print(f"isj: {t_isj:.2f} s, bases {rom.n_basis}, validation max {rom.meta['validate_max_rel_bound']:.2e}")

    # --- pyMOR stock: rb_greedy on the state estimate; stop at the relative state error that makes
    # the crude output bound ‖e‖_X ‖ℓ‖_X' reach 0.5·tol at the centre
    red_state = CoerciveRBReductor(fom, product=Xop, coercivity_estimator=min_theta)
    u_bar = fom.solve(fom.parameters.parse(theta_bar))
    ell_dual = [np.sqrt(ell[d] @ spla.spsolve(X, ell[d])) for d in range(2)]
    out_bar = fom.output(fom.parameters.parse(theta_bar)).ravel()
    atol_state = 0.5 * TOL * min(abs(out_bar[d]) / ell_dual[d] for d in range(2))
    t0 = time.perf_counter()
    g_state = rb_greedy(fom, red_state, train, atol=atol_state, max_extensions=200)
    t_state = time.perf_counter() - t0
    rom_state = red_state.reduce()
    n_state = len(red_state.bases["RB"])
    print(f"pyMOR rb_greedy (state estimate, atol {atol_state:.3g}): {t_state:.2f} s, basis {n_state}")
    del u_bar

    # --- pyMOR DWR: the primal–dual output bound, isj's criterion
    red_dwr = DWRCoerciveRBReductor(fom, dual_foms=duals, product=Xop, coercivity_estimator=min_theta)
    t0 = time.perf_counter()
    sur = DWRSurrogate(fom, duals, red_dwr)
    g_dwr = weak_greedy(sur, train, atol=0.5 * TOL, max_extensions=120)
    t_dwr = time.perf_counter() - t0
    rom_dwr = sur.rom
    n_dwr = [len(red_dwr.primal_reductor.bases["RB"])] + [len(r.bases["RB"]) for r in red_dwr.dual_reductors]
    print(f"pyMOR DWR weak_greedy: {t_dwr:.2f} s, bases {n_dwr}, final {g_dwr['max_errs'][-1]:.2e}")

    # --- online: isj vectorised vs pyMOR one design at a time, interleaved
    E_on = space.sample(20000, seed=7)
    th_on = space.theta(E_on)
    n_py = 300
    mus_on = [fom.parameters.parse(t) for t in th_on[:n_py]]
    t_isj_on, t_py_on, t_st_on = [], [], []
    for _ in range(3):
        t0 = time.perf_counter()
        ev = rom.evaluate(E_on, 1.0)
        t_isj_on.append((time.perf_counter() - t0) / len(E_on))
        t0 = time.perf_counter()
        py = [rom_dwr.compute(output=True, output_error_estimate=True, mu=mu) for mu in mus_on]
        t_py_on.append((time.perf_counter() - t0) / n_py)
        t0 = time.perf_counter()
        for mu in mus_on:
            rom_state.compute(output=True, output_error_estimate=True, mu=mu)
        t_st_on.append((time.perf_counter() - t0) / n_py)
    py_out = np.array([d["output"].ravel() for d in py])
    py_bnd = np.array([d["output_error_estimate"].ravel() for d in py])
    isj_out = np.column_stack([ev["alpha_rad"], ev["beta_rad"]])[:n_py]
    isj_bnd = np.column_stack([ev["alpha_bound_rad"], ev["beta_bound_rad"]])[:n_py]
    st = [rom_state.compute(output=True, output_error_estimate=True, mu=mu) for mu in mus_on]
    st_bnd = np.array([d["output_error_estimate"].ravel() for d in st])
    rel = {
        "isj": isj_bnd / np.abs(isj_out),
        "pymor_dwr": py_bnd / np.abs(py_out),
        "pymor_state": st_bnd / np.abs(py_out),
    }

    # --- truth: FE on the same matrices at the corners and 16 random designs
    E_chk = np.concatenate([space.corners(), space.sample(16, seed=11)])
    truth, err = [], {"isj": [], "pymor_dwr": [], "pymor_state": []}
    ev_chk = rom.evaluate(E_chk, 1.0)
    eff = {"isj": [], "pymor_dwr": [], "pymor_state": []}
    # (design, output, rel error, rel bound) wherever the error exceeds the bound
    miss = {"isj": [], "pymor_dwr": [], "pymor_state": []}
    for i, th in enumerate(space.theta(E_chk)):
        mu = fom.parameters.parse(th)
        s = fom.output(mu).ravel()
        truth.append(s)
        s_isj = np.array([ev_chk["alpha_rad"][i], ev_chk["beta_rad"][i]])
        b_isj = np.array([ev_chk["alpha_bound_rad"][i], ev_chk["beta_bound_rad"][i]])
        d = rom_dwr.compute(output=True, output_error_estimate=True, mu=mu)
        s_dwr, b_dwr = d["output"].ravel(), d["output_error_estimate"].ravel()
        d = rom_state.compute(output=True, output_error_estimate=True, mu=mu)
        s_st, b_st = d["output"].ravel(), d["output_error_estimate"].ravel()
        for k, v in (("isj", s_isj), ("pymor_dwr", s_dwr), ("pymor_state", s_st)):
            err[k].append(np.abs(v - s) / np.abs(s))
        for k, v, b in (("isj", s_isj, b_isj), ("pymor_dwr", s_dwr, b_dwr), ("pymor_state", s_st, b_st)):
            eff[k].append(b / np.maximum(np.abs(v - s), 1e-300))
            for j in np.flatnonzero(np.abs(v - s) > b):
                miss[k].append([i, int(j), float(abs(v[j] - s[j]) / abs(s[j])), float(b[j] / abs(s[j]))])
    # the pyMOR FOM is isj's FE model: check once against the model's own solve
    r = model.static(space.materials(E_chk[0]), 1.0)
    fe_match = max(abs(r.alpha_rad / truth[0][0] - 1), abs(r.beta_rad / truth[0][1] - 1))

    res = {
        "mesh": {"order": 1, "resolution": 0.35, "n_dofs": int(model.n_dofs)},
        "pymor_version": pymor.__version__,
        "load_average_start_end": [load0, float(os.getloadavg()[0])],
        "tol": TOL,
        "n_train": len(train),
        "assembly_s": t_assemble,
        "fe_model_vs_pymor_fom_max_rel": float(fe_match),
        "offline_s": {
            "isj_build_with_validation_and_local_bases": t_isj,
            "isj_greedy_phases": rom.meta["timings_s"],
            "pymor_rb_greedy_state": t_state,
            "pymor_dwr_weak_greedy": t_dwr,
        },
        "basis": {
            "isj_global": rom.n_basis,
            "isj_local_sizes": rom.meta["local_sizes"],
            "isj_snapshots": rom.meta["n_snapshots"],
            "pymor_rb_greedy_state": n_state,
            "pymor_dwr_primal_dual_a_dual_b": n_dwr,
        },
        "greedy_final_max_rel_bound": {
            "isj_train_then_validation": rom.meta["validate_max_rel_bound"],
            "pymor_dwr_train": float(g_dwr["max_errs"][-1]),
            "pymor_state_abs_energy": float(g_state["max_errs"][-1]),
            "pymor_state_atol": atol_state,
        },
        "online_s_per_design": {
            "isj_vectorised_20000": t_isj_on,
            "pymor_dwr_loop_300": t_py_on,
            "pymor_state_loop_300": t_st_on,
            "ratio_pymor_dwr_over_isj_best": min(t_py_on) / min(t_isj_on),
        },
        "relative_output_bound_300_designs": {
            k: {
                "alpha_max": float(v[:, 0].max()),
                "alpha_median": float(np.median(v[:, 0])),
                "beta_max": float(v[:, 1].max()),
                "beta_median": float(np.median(v[:, 1])),
            }
            for k, v in rel.items()
        },
        "true_rel_error_vs_fe_48_designs": {
            k: {"alpha_max": float(np.max(np.array(v)[:, 0])), "beta_max": float(np.max(np.array(v)[:, 1]))}
            for k, v in err.items()
        },
        "effectivity_min_48_designs": {k: float(np.min(v)) for k, v in eff.items()},
        "bound_below_error_48_designs": miss,
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
