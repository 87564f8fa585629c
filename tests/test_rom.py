"""The certified reduced-basis surrogate (isj.fem.rom): bound ≥ true error against FE on the same mesh.

One surrogate of a coarse P1 model (resolution 0.35, about 2.6k dofs) is built once for the module,
through the cache, and checked against FE on that mesh at all 32 corners and at random designs.
The effectivities (bound ÷ error) are printed (``pytest -s``) and must be ≥ 1 everywhere.
"""

import json
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from test_cache_entries import flip_a_stored_byte

from isj.cachefile import read_npz_entry
from isj.errors import CorruptCacheEntry, InvalidParameter

pytestmark = pytest.mark.slow  # builds a surrogate (module fixture)

ORDER, RESOLUTION = 1, 0.35


@pytest.fixture(scope="module")
def rom_cache(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    path = tmp_path_factory.mktemp("fe-cache")
    mp.setenv("ISJ_FE_CACHE_DIR", str(path))
    yield path
    mp.undo()


@pytest.fixture(scope="module")
def fe():
    from isj.fem.model import PedicleJointModel

    return PedicleJointModel(order=ORDER, resolution=RESOLUTION)


@pytest.fixture(scope="module")
def rom(rom_cache, fe):
    from isj.fem.rom import reduced_model

    return reduced_model(order=ORDER, resolution=RESOLUTION)


def _fe_outputs(fe, rom, E, pressure=1.0):
    rows = []
    for e in E:
        r = fe.static(rom.space.materials(e), pressure)
        rows.append([r.alpha_rad, r.beta_rad, r.sum_rad, r.ratio])
    return np.array(rows)


def _check_bounds(fe, rom, E, label):
    truth = _fe_outputs(fe, rom, E)
    ev = rom.evaluate(E, 1.0)
    keys = [
        ("alpha_rad", "alpha_bound_rad"),
        ("beta_rad", "beta_bound_rad"),
        ("alpha_plus_beta_rad", "alpha_plus_beta_bound_rad"),
        ("beta_over_alpha", "beta_over_alpha_bound"),
    ]
    for j, (k, kb) in enumerate(keys):
        err = np.abs(truth[:, j] - ev[k])
        bound = ev[kb]
        assert np.all(err <= bound), f"{label} {k}: error above bound at {np.flatnonzero(err > bound)}"
        eff = bound / np.maximum(err, 1e-300)
        rel = bound / np.abs(truth[:, j])
        print(
            f"{label} {k}: relative bound max {rel.max():.2e} median {np.median(rel):.2e}; "
            f"effectivity min {eff.min():.3g} max {eff.max():.3g}"
        )
        assert rel.max() <= 2e-3  # the target is 1e-3 for α, β, β/α; α + β sums two bounds


def test_bound_holds_at_all_corners(fe, rom):
    _check_bounds(fe, rom, rom.space.corners(), "corners")


def test_bound_holds_at_random_designs(fe, rom):
    rng = np.random.default_rng(2024)
    _check_bounds(fe, rom, rom.space.from_unit(rng.random((12, 5))), "random")


def test_bound_target_met_on_a_fresh_dense_sample(rom):
    E = rom.space.sample(16384, seed=99)
    ev = rom.evaluate(E, 1.0)
    for k, kb in (
        ("alpha_rad", "alpha_bound_rad"),
        ("beta_rad", "beta_bound_rad"),
        ("beta_over_alpha", "beta_over_alpha_bound"),
    ):
        rel = ev[kb] / np.abs(ev[k])
        assert rel.max() <= rom.meta["tol"], k
    assert rom.meta["converged"] and rom.meta["validate_max_rel_bound"] <= rom.meta["tol"]
    assert rom.meta["local_validate_max_rel_bound"] <= rom.meta["tol"]


def test_local_arrays_of_the_whole_basis_reproduce_the_global_ones(rom):
    """Φ = I: the same outputs to round-off, and bounds no smaller than the global ones."""
    from isj.fem.rom.local import compress
    from isj.fem.rom.online import SPACES, evaluate_unit

    arr = {k: v for k, v in rom.arrays.items() if not k.startswith("box")}
    loc = compress(arr, {s: np.eye(arr[f"{s}_g"].size) for s in SPACES})
    theta = rom.space.theta(np.concatenate([rom.space.corners(), rom.space.sample(256, seed=4)]))
    glob, ours = evaluate_unit(arr, theta), evaluate_unit(loc, theta)
    for key in ("alpha", "beta"):
        assert np.allclose(ours[key], glob[key], rtol=1e-11, atol=0)
        assert np.all(ours[f"{key}_bound"] >= glob[f"{key}_bound"] * (1 - 1e-9))
        # the guards added for forming R Φ and for the QR factor are small against the bound
        assert np.median(ours[f"{key}_bound"] / glob[f"{key}_bound"]) < 1.01


def test_designs_go_to_their_sub_box(rom):
    from isj.fem.rom.local import SPLIT, box_index
    from isj.fem.rom.online import evaluate_unit

    bits = (np.arange(32)[:, None] >> np.arange(5)) & 1
    assert np.array_equal(box_index(bits.astype(float)), np.arange(32))  # the face t = 1 is inside
    assert np.array_equal(box_index(np.full((1, 5), 1 / SPLIT)), [31])
    assert len(rom.boxes) == 32 and len(rom.meta["local_sizes"]) == 32
    assert all(1 <= k <= rom.n_basis["primal"] for k in rom.meta["local_sizes"])
    E = rom.space.sample(64, seed=8)
    got = rom.evaluate(E, 1.0)
    idx = box_index(rom.space.to_unit(E))
    for b in np.unique(idx)[:4]:
        sel = idx == b
        ref = evaluate_unit(rom.boxes[b], rom.space.theta(E[sel]))
        assert np.array_equal(got["alpha_rad"][sel], ref["alpha"])
        assert np.array_equal(got["beta_bound_rad"][sel], ref["beta_bound"])


def test_min_theta_is_the_coercivity_constant(fe, rom):
    """min-θ is rigorous (every A_r is PSD) and, here, not loose: it equals λ_min(K(μ), K(μ̄))."""
    from isj.fem.rom.offline import affine_parts

    pattern, data, _, _, _ = affine_parts(fe, rom.space.nu)
    theta_bar = rom.arrays["theta_bar"]

    def K(t):
        return type(pattern)((t @ data, pattern.indices, pattern.indptr), shape=pattern.shape).tocsc()

    X = K(theta_bar)
    for e in rom.space.corners()[[0, 7, 21, 31]]:
        t = rom.space.theta(e[None])[0]
        lu = spla.splu(K(t))
        inv = spla.LinearOperator(X.shape, matvec=lu.solve)
        lam_max = spla.eigsh(X, k=1, M=K(t), Minv=inv, which="LA", tol=1e-10)[0][0]
        true_lb = 1 / lam_max
        lb = rom.evaluate(e[None], 1.0)["coercivity_lb"][0]
        assert lb <= true_lb * (1 + 1e-6)
        assert lb >= 0.9 * true_lb


def test_residual_norm_is_accurate_at_small_residuals(fe, rom):
    """‖R c‖ (representers orthonormalised) tracks the true dual norm where cᵀGc loses every digit."""
    from isj.fem.rom.offline import Greedy
    from isj.fem.rom.online import _solve, residual_coefficients, residual_norm

    from isj.design_space import DesignSpace

    space = DesignSpace()
    g = Greedy(fe, space)
    g.add_snapshot(space.center())
    corner = space.corners()[9]
    g.add_snapshot(corner)
    arr = g.arrays(orthogonality=True)
    lu = spla.splu(g.X.tocsc())
    for e, small in ((corner, True), (space.from_unit(np.full((1, 5), 0.3))[0], False)):
        theta = space.theta(e[None])
        x = _solve(arr, "u", theta)
        c = residual_coefficients(theta, x)
        ours = residual_norm(c, arr["u_R"], arr["u_eta"], float(arr["u_scale"]))[0]
        r = g.f - g._stiffness(theta[0]) @ (g.spaces["u"].V.matrix @ x[0])
        true = np.sqrt(r @ lu.solve(r))
        scale = arr["u_R"][0, 0]  # ‖f‖_X'
        assert ours >= true * (1 - 1e-6)
        R = arr["u_R"]
        gram = float(c[0] @ (R.T @ R) @ c[0])  # the textbook expansion cᵀ G c
        if small:
            assert true < 1e-8 * scale  # a snapshot: the residual is round-off
            assert ours < 1e-7 * scale
            assert abs(np.sqrt(abs(gram)) - true) > 10 * abs(ours - true)  # Gram: digits lost
        else:
            assert abs(ours - true) <= 1e-6 * true


def test_representers_within_their_error_radius(fe):
    """Every stored representer Q R_j (five solved, one derived from Σ θ̄_r X⁻¹A_r v = v) is X⁻¹ of its
    term within its radius η_j, against an independent solver (SuperLU)."""
    from isj.fem.rom.offline import REFINE_EVERY, Greedy

    from isj.design_space import DesignSpace

    space = DesignSpace()
    g = Greedy(fe, space)
    for e in (space.center(), *space.corners()[[9, 22]]):
        g.add_snapshot(e)
    assert g._rep_calls < REFINE_EVERY + 1 and g.derive_rel > 0  # step 1 on: one of six derived
    lu = spla.splu(g.X.tocsc())
    for s in ("u", "a", "b"):
        sp_ = g.spaces[s]
        R, eta = sp_.rep.arrays()
        Z = sp_.rep.Q.matrix @ R
        terms = [sp_.rhs] + [A @ v for v in sp_.V for A in g.mats]  # the load, then six per basis vector
        assert len(terms) == Z.shape[1]
        for j, t in enumerate(terms):
            d = Z[:, j] - lu.solve(t)
            miss = np.sqrt(max(d @ (g.X @ d), 0.0))
            assert miss <= eta[j] * (1 + 1e-6) + 1e-15 * np.sqrt(t @ lu.solve(t)), (s, j, miss, eta[j])


def test_domain_is_the_shipped_calibrations():
    from isj.lumped.artifact import default_calibration

    from isj.design_space import RANGED, DesignSpace

    dom = default_calibration().domain
    assert set(dom) == set(RANGED)
    assert {k: tuple(v) for k, v in dom.items()} == DesignSpace().bounds


def test_outputs_scale_with_pressure(rom):
    a = rom.evaluate(gap_e_pa=2e7, pressure_pa=1.0)
    b = rom.evaluate(gap_e_pa=2e7, pressure_pa=-30.0)
    assert b["alpha_rad"][0] == pytest.approx(-30 * a["alpha_rad"][0], rel=1e-12)
    assert b["beta_bound_rad"][0] == pytest.approx(30 * a["beta_bound_rad"][0], rel=1e-12)
    assert b["beta_over_alpha"][0] == pytest.approx(a["beta_over_alpha"][0], rel=1e-12)


def test_designs_outside_the_domain_are_refused(rom):
    with pytest.raises(InvalidParameter, match=r"gap_e_pa = 100000 Pa: outside .* \[1e\+06, 5e\+07\] Pa"):
        rom.evaluate(gap_e_pa=1e5)
    with pytest.raises(InvalidParameter, match="incus_e_pa"):
        rom.evaluate(incus_e_pa=1e9)
    corners = rom.space.corners()
    assert np.all(np.isfinite(rom.evaluate(corners)["alpha_rad"]))  # the faces themselves are inside


def test_thesis_cases_with_bounds(fe, rom):
    rows = rom.cases()
    assert [r["case"] for r in rows] == ["base", "j5", "c20", "c100", "j5c20", "p12", "p3"]
    base = fe.static(
        rom.space.materials(
            [rows[0][k] for k in ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa", "plate_e_pa", "stapes_e_pa")]
        )
    )
    assert abs(base.alpha_rad - rows[0]["alpha_rad"]) <= rows[0]["alpha_bound_rad"]
    assert abs(base.beta_rad - rows[0]["beta_rad"]) <= rows[0]["beta_bound_rad"]


def test_cache_round_trip_and_damaged_entry(rom_cache, rom):
    from isj.fem.rom import reduced_model, rom_cache_dir

    def stamps():
        return {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in rom_cache_dir().rglob("*") if p.is_file()}

    stored = stamps()
    again = reduced_model(order=ORDER, resolution=RESOLUTION)
    assert stamps() == stored  # loaded: no entry written or replaced, so nothing was rebuilt
    E = rom.space.sample(64, seed=3)
    assert np.array_equal(again.evaluate(E)["beta_rad"], rom.evaluate(E)["beta_rad"])
    # a small surrogate of its own, damaged on disk: reported, deleted, rebuilt to the same numbers
    small = {"n_train": 16, "n_validate": 16, "max_snapshots": 4}
    before = set(rom_cache_dir().glob("rom-*.npz"))
    first = reduced_model(order=ORDER, resolution=RESOLUTION, **small)
    (entry,) = set(rom_cache_dir().glob("rom-*.npz")) - before
    read_npz_entry(entry)  # sound before the damage
    flip_a_stored_byte(entry)
    with pytest.warns(CorruptCacheEntry):
        second = reduced_model(order=ORDER, resolution=RESOLUTION, **small)
    assert np.array_equal(second.evaluate(E)["alpha_rad"], first.evaluate(E)["alpha_rad"])


def _isj(*args, env_dir):
    import os

    env = dict(os.environ, ISJ_FE_CACHE_DIR=str(env_dir))
    return subprocess.run([sys.executable, "-m", "isj", *args], capture_output=True, text=True, env=env)


def test_cli_solve_json_keys(rom_cache, rom):
    out = _isj(
        "rom",
        "solve",
        "--order",
        str(ORDER),
        "--resolution",
        str(RESOLUTION),
        "--gap-e",
        "2e7",
        "--json",
        env_dir=rom_cache,
    )
    assert out.returncode == 0, out.stderr
    d = json.loads(out.stdout)
    for k in (
        "alpha_rad",
        "beta_rad",
        "alpha_bound_rad",
        "beta_bound_rad",
        "alpha_plus_beta_rad",
        "beta_over_alpha",
        "n_dofs",
        "mesh_hash",
        "pressure_pa",
    ):
        assert k in d
    ref = rom.static(gap_e_pa=2e7).to_dict()
    assert d["alpha_rad"] == ref["alpha_rad"] and d["n_dofs"] == ref["n_dofs"]
    cases = _isj(
        "rom", "cases", "--order", str(ORDER), "--resolution", str(RESOLUTION), "--json", env_dir=rom_cache
    )
    assert cases.returncode == 0 and len(json.loads(cases.stdout)) == 7


def test_cli_refuses_outside_domain_in_one_line(tmp_path):
    out = _isj("rom", "solve", "--capsule-e", "5e8", "--json", env_dir=tmp_path / "cache")
    assert out.returncode == 2
    assert out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "--capsule-e" in lines[0] and "[1e+07, 3e+08] Pa" in lines[0]
    assert not (tmp_path / "cache").exists()
