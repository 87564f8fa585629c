"""The results versions are honest: a result that changes while its family's version does not fails here.

Cache keys hold :func:`isj.results_version.versions` instead of the code's text, so a change of
code that alters a result without a version bump would leave stale entries behind. This test
recomputes, from scratch, a few numbers of every result family on coarse models (the joint
model of tests/conftest.py: P2 at resolution 0.35; P1 for the surrogate; a 0.4 mm drum mesh) and
compares them with ``tests/data/results_reference.json``, which stores them with the versions
they were made with:

- same versions, a value differs → the code changed results without a bump: bump the family
  whose code changed in ``isj/results_version.py``, then regenerate;
- a version differs from the stored one → regenerate (the reference is of other results).

Regenerate (every family, or the ones named)::

    .venv/bin/python tests/test_results_version.py --write [FAMILY ...]

Tolerance: relative :data:`RTOL` (1e-10) with the stored library versions: two runs agree bit
for bit, and one and two PARDISO threads within 9e-12 (docs/developer/cache-keys.md §3; looser
for the surrogate's bounds, :data:`RTOL_OF`); :data:`RTOL_OTHER_LIBS` (1e-6) when
numpy's or scipy's major.minor differs from the stored one (their solvers change the last bits;
a changed formula moves results far more). A reference made with another gmsh cannot be
compared (another gmsh may mesh differently): those families are skipped, saying so.

The report steps' own code (``STEP_VERSIONS``) is kept honest the same way on the coarse report
of tests/conftest.py: a few numbers of each step's result (``steps`` in the reference, spread over
its sorted numeric entries, timings left out), compared at :data:`RTOL_STEPS` under the step's
versions (:func:`isj.results_version.step_versions`). Regenerate them with ``--write-steps``
(runs the coarse report, minutes; ``--write-steps DIR`` keeps its caches in DIR).

``--check FAMILY ...`` runs the same comparison as a script (exit 1 and the messages when a value
differs): tests/test_cache_invalidation.py runs it on a copy of isj.
"""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

import pytest

REFERENCE = Path(__file__).parent / "data" / "results_reference.json"
REGENERATE = ".venv/bin/python tests/test_results_version.py --write"
REGENERATE_STEPS = ".venv/bin/python tests/test_results_version.py --write-steps"

#: Relative tolerance of a stored value made with the same library versions.
#: (FE results agree within 2e-10 between the machine the reference was made on and an AMD EPYC
#: one, MKL taking other code paths there; a real change of results is far larger.)
RTOL = 1e-8
#: Relative tolerance when numpy's or scipy's major.minor differs from the stored one.
RTOL_OTHER_LIBS = 1e-6
#: Values with a looser tolerance of their own: the surrogate's certified bounds are square roots
#: of residual norms in which large terms nearly cancel (measured: 6e-9 relative between one and
#: two PARDISO threads, where α and β agree within 2e-12).
#: Between two machines (other MKL code paths) the bounds moved by 2.3e-6.
RTOL_OF = {("surrogate", "alpha_bound_rad"): 1e-4, ("surrogate", "beta_bound_rad"): 1e-4}

#: Relative tolerance of a report step's numbers: they pass through eigensolvers, sampling
#: estimates and the surrogate's bounds (6e-9 between thread counts, :data:`RTOL_OF`).
RTOL_STEPS = 1e-6
#: Step numbers that are the surrogate's certified bounds or errors: between two machines the
#: guard's moved by up to 1.5e-4 (the same cancellation as :data:`RTOL_OF`).
RTOL_STEPS_BOUNDS = 1e-3
BOUNDS = re.compile(r"bound|certified")
#: Numbers kept per step.
N_STEP_VALUES = 8
#: Result entries that are not results (wall times, dates, versions, paths).
NOT_RESULTS = re.compile(r"time|second|elapsed|wall|_s$|date|created|version|path|file|cached")
#: Paths of numbers a step echoes from its inputs (moduli, settings, domains, data): kept only
#: for a step with fewer than :data:`N_STEP_VALUES` other numbers.
INPUTS = re.compile(
    r"_e_pa|_shear_pa|pressure_pa|order|resolution|domain|provenance|settings|seed|bootstrap|"
    r"tolerance|samples|n_freq|n_tets|materials|damping|design|cat\[|spl_|edges|bands|quality"
)

#: The coarse joint model: P2 at resolution 0.35 (tests/conftest.py's ``coarse_model``).
ORDER, RESOLUTION = 2, 0.35
#: A second design: soft gap, stiff pedicle (Pa).
OTHER_DESIGN = {"gap_e_pa": 5e6, "pedicle_e_pa": 3e9}


def _settings() -> dict:
    from isj.fem.batch import fe_settings

    return fe_settings(order=ORDER, resolution=RESOLUTION)


def _mesh() -> dict:
    from isj.fem.mesh import mesh_pedicle_joint

    m = mesh_pedicle_joint(resolution=RESOLUTION, cache_dir=False)  # gmsh itself, no cache
    return {"content_hash": m.content_hash(), "n_nodes": m.n_nodes, "n_tets": m.n_tets}


def _fe_static() -> dict:
    from isj.fem.batch import evaluate_design

    out = {}
    for tag, design in (("default", {}), ("other", OTHER_DESIGN)):
        r = evaluate_design(design, _settings())
        for k in ("alpha_rad", "beta_rad", "alpha_ls_rad", "beta_ls_rad", "max_disp_m"):
            out[f"{tag}.{k}"] = r[k]
        out[f"{tag}.strain_energy_j"] = math.fsum(r["strain_energy_j"].values())
    return out


def _fe_dynamic() -> dict:
    from isj.fem.batch import evaluate_harmonic, evaluate_modes

    m = evaluate_modes({}, _settings() | {"n_modes": 3})
    h = evaluate_harmonic({}, _settings() | {"freq_hz": [1000.0]})
    out = {f"mode{i}.freq_hz": f for i, f in enumerate(m["freq_hz"])}
    for k in ("alpha_rad", "beta_rad"):
        out[f"harmonic_1khz.{k}_re"], out[f"harmonic_1khz.{k}_im"] = h[f"{k}_re"][0], h[f"{k}_im"][0]
    return out


def _ear() -> dict:
    from isj.fem.batch import shared_model
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.ear.reduced_ear import OUTPUTS, reduced_ear

    model, _ = shared_model(_settings())
    ear = MiddleEarModel(joint=model, drum_mesh_size_m=0.4e-3)
    static = ear.static()
    H = reduced_ear(ear, fmax_hz=2e3).frequency_response([500.0]).response[0, :, 0]
    h_v = complex(H[OUTPUTS.index("stapes_velocity_m_s")])
    return {
        "static.umbo_m_per_pa": float(static.umbo_m_per_pa),
        "h_v_500hz.re": h_v.real,
        "h_v_500hz.im": h_v.imag,
    }


def _drum_modes() -> dict:
    from isj.fem.ear.drum_modes import drum_modes

    d = drum_modes(n_modes=4, mesh_size_m=0.4e-3)
    out = {f"mode{i}.freq_hz": f for i, f in enumerate(d["freq_hz"])}
    out["residual_compliance_m3_per_pa"] = d["residual_compliance_m3_per_pa"]
    return out


def _surrogate() -> dict:
    from isj.fem.model import PedicleJointModel
    from isj.fem.rom import build_reduced_model

    rom = build_reduced_model(
        PedicleJointModel(order=1, resolution=RESOLUTION, cache_dir=False),
        n_train=16,
        n_validate=16,
        max_snapshots=6,
        tol=1e-2,
    )
    ev = rom.evaluate(gap_e_pa=[1e7], pedicle_e_pa=[5e9])
    return {k: float(ev[k][0]) for k in ("alpha_rad", "beta_rad", "alpha_bound_rad", "beta_bound_rad")}


def _lumped() -> dict:
    from isj.lumped.api import LumpedModel

    lm = LumpedModel()
    out = {}
    for tag, design in (("default", {}), ("other", OTHER_DESIGN)):
        r = lm.static(**design)
        out[f"{tag}.alpha_rad"], out[f"{tag}.beta_rad"] = float(r.alpha_rad), float(r.beta_rad)
    for i, f in enumerate(lm.natural_frequencies_hz(2)):
        out[f"chain_mode{i}.freq_hz"] = float(f)
    return out


#: What is computed for each family of :data:`isj.results_version.VERSIONS`.
COMPUTE = {
    "mesh": _mesh,
    "fe_static": _fe_static,
    "fe_dynamic": _fe_dynamic,
    "ear": _ear,
    "drum_modes": _drum_modes,
    "surrogate": _surrogate,
    "lumped": _lumped,
}


def compute(family: str) -> dict:
    """The reference entry of ``family`` as this code makes it: its versions and its values."""
    from isj.results_version import versions

    return {"versions": versions(family), "values": COMPUTE[family]()}


def _split(v: dict) -> tuple[dict, dict]:
    from isj.results_version import VERSIONS

    return {k: x for k, x in v.items() if k in VERSIONS}, {k: x for k, x in v.items() if k not in VERSIONS}


def problems(family: str, stored: dict | None = None) -> tuple[list[str], str | None]:
    """(messages, why skipped) of comparing ``family`` with its stored reference.

    No message: the values agree with the stored ones, or the stored ones are of another
    version (a message to regenerate, then). A skip reason when the reference cannot be
    compared here (made with another gmsh).
    """
    from isj.results_version import versions

    if stored is None:
        stored = json.loads(REFERENCE.read_text())["families"].get(family)
    if stored is None:
        return [f"{family}: no stored reference; regenerate: {REGENERATE} {family}"], None
    own, libs = _split(versions(family))
    s_own, s_libs = _split(stored["versions"])
    if own != s_own:
        return [
            f"{family}: stored with results versions {s_own}, this code has {own}: regenerate the "
            f"reference ({REGENERATE} {family}) after checking that the new results are the intended ones"
        ], None
    if "gmsh" in libs and libs["gmsh"] != s_libs.get("gmsh"):
        return [], f"{family}: reference made with gmsh {s_libs.get('gmsh')}, this is gmsh {libs['gmsh']}"
    base = RTOL if libs == s_libs else RTOL_OTHER_LIBS
    now = COMPUTE[family]()
    out = []
    for name, ref in stored["values"].items():
        got = now.get(name)
        rtol = max(base, RTOL_OF.get((family, name), 0.0))
        if isinstance(ref, str) or isinstance(got, str) or isinstance(ref, int) and isinstance(got, int):
            same = got == ref
            what = f"stored {ref!r}, now {got!r}"
        else:
            same = got is not None and abs(got - ref) <= rtol * abs(ref)
            rel = abs(got - ref) / abs(ref) if got is not None and ref else float("nan")
            what = f"stored {ref!r}, now {got!r} (relative difference {rel:.3g} > {rtol:g})"
        if not same:
            out.append(
                f"{family}: {name}: {what} while the results version {own} is unchanged. A change of "
                f"code altered these results: bump the version of the family whose code changed in "
                f"isj/results_version.py (VERSIONS; {family} or one it depends on), then regenerate "
                f"the reference: {REGENERATE}"
            )
    return out, None


def step_numbers(result) -> dict[str, float]:
    """The finite numbers of a step's result by path (``rows[3].fe.alpha_rad``), results only."""
    out: dict[str, float] = {}

    def walk(x, path: str) -> None:
        if isinstance(x, dict):
            for k, v in x.items():
                if not NOT_RESULTS.search(str(k)):
                    walk(v, f"{path}.{k}" if path else str(k))
        elif isinstance(x, list | tuple):
            for i, v in enumerate(x):
                walk(v, f"{path}[{i}]")
        elif isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) and x != 0:
            out[path] = float(x)

    walk(result, "")
    return out


def pick(numbers: dict[str, float], n: int = N_STEP_VALUES) -> dict[str, float]:
    """``n`` entries spread evenly over the sorted paths of the results (all when there are fewer).

    Paths matching :data:`INPUTS` (numbers the step echoes from its inputs) are left out unless
    fewer than ``n`` others remain.
    """
    results = sorted(p for p in numbers if not INPUTS.search(p))
    paths = results if len(results) >= n else sorted(numbers)
    if len(paths) > n:
        paths = [paths[round(i * (len(paths) - 1) / (n - 1))] for i in range(n)]
    return {p: numbers[p] for p in paths}


def step_problems(name: str, result: dict, stored: dict | None) -> tuple[list[str], str | None]:
    """As :func:`problems`, for a report step's ``result`` (of the coarse report)."""
    from isj.results_version import step_versions

    if stored is None:
        return [f"step {name}: no stored reference; regenerate: {REGENERATE_STEPS}"], None
    own, libs = _split(step_versions(name))
    s_own, s_libs = _split(stored["versions"])
    if own != s_own:
        return [
            f"step {name}: stored with results versions {s_own}, this code has {own}: regenerate the "
            f"reference ({REGENERATE_STEPS}) after checking that the new results are the intended ones"
        ], None
    if "gmsh" in libs and libs["gmsh"] != s_libs.get("gmsh"):
        return [], f"step {name}: reference made with gmsh {s_libs.get('gmsh')}, this is gmsh {libs['gmsh']}"
    now = step_numbers(result)
    out = []
    for path, ref in stored["values"].items():
        got = now.get(path)
        rtol = RTOL_STEPS_BOUNDS if BOUNDS.search(path) else RTOL_STEPS
        if got is None or abs(got - ref) > rtol * abs(ref):
            out.append(
                f"step {name}: {path}: stored {ref!r}, now {got!r} while its results versions {own} are "
                f"unchanged. A change of code altered this step's results: bump its entry in "
                f"STEP_VERSIONS (or the family whose code changed) in isj/results_version.py, then "
                f"regenerate: {REGENERATE_STEPS}"
            )
    return out, None


def test_a_changed_step_number_is_reported():
    """The step comparison itself, on a made-up result: timings ignored, a moved number caught."""
    from isj.results_version import step_versions

    result = {"rows": [{"alpha_rad": 1.5e-6, "beta_rad": 2e-5, "seconds": 3.0}], "timings_s": {"a": 1.0}}
    assert step_numbers(result) == {"rows[0].alpha_rad": 1.5e-6, "rows[0].beta_rad": 2e-5}
    stored = {"versions": step_versions("uq"), "values": pick(step_numbers(result))}
    assert step_problems("uq", result | {"timings_s": {"a": 2.0}}, stored) == ([], None)
    moved = {"rows": [{"alpha_rad": 1.5e-6 * (1 + 1e-5), "beta_rad": 2e-5}]}
    msgs, _ = step_problems("uq", moved, stored)
    assert len(msgs) == 1 and "rows[0].alpha_rad" in msgs[0] and "STEP_VERSIONS" in msgs[0]
    assert len(pick({f"k{i:02d}": 1.0 for i in range(40)})) == N_STEP_VALUES


def test_report_steps_match_the_reference_of_their_versions(report):
    stored = json.loads(REFERENCE.read_text()).get("steps", {})
    msgs, skipped = [], []
    for name, result in report["second"]["steps"].items():
        m, s = step_problems(name, result, stored.get(name))
        msgs += m
        skipped += [s] if s else []
    assert not msgs, "\n".join(msgs)
    if skipped:
        pytest.skip("; ".join(skipped))


def _slow(family: str):
    return pytest.param(family, marks=pytest.mark.slow) if family in ("ear", "surrogate") else family


@pytest.mark.slow
@pytest.mark.parametrize("family", [_slow(f) for f in COMPUTE])
def test_results_match_the_reference_of_their_version(family):
    msgs, skipped = problems(family)
    if skipped:
        pytest.skip(skipped)
    assert not msgs, "\n".join(msgs)


def test_every_family_has_a_reference_and_a_computation():
    from isj.results_version import VERSIONS

    stored = json.loads(REFERENCE.read_text())
    assert set(COMPUTE) == set(VERSIONS) == set(stored["families"])
    assert stored["rtol"] == RTOL


def test_a_changed_value_or_version_is_reported():
    """The comparison itself: a stored value off by 1e-7 relative, or another version, is caught."""
    stored = json.loads(REFERENCE.read_text())["families"]["lumped"]
    assert problems("lumped", stored) == ([], None)
    name = next(iter(stored["values"]))
    off = {**stored, "values": {**stored["values"], name: stored["values"][name] * (1 + 1e-7)}}
    msgs, _ = problems("lumped", off)
    assert len(msgs) == 1 and name in msgs[0] and "bump the version" in msgs[0] and REGENERATE in msgs[0]
    bumped = {**stored, "versions": {**stored["versions"], "lumped": stored["versions"]["lumped"] + 1}}
    msgs, _ = problems("lumped", bumped)
    assert len(msgs) == 1 and "regenerate" in msgs[0]


def _write(families: list[str]) -> None:
    from isj.atomic import atomic_write_text

    data = json.loads(REFERENCE.read_text()) if REFERENCE.exists() else {}
    data["about"] = (
        "Reference values of each result family (tests/test_results_version.py); regenerate with "
        + REGENERATE
    )
    data["rtol"] = RTOL
    data.setdefault("families", {})
    for fam in families:
        data["families"][fam] = compute(fam)
        print(f"{fam}: {len(data['families'][fam]['values'])} values", file=sys.stderr)
    data["families"] = dict(sorted(data["families"].items()))
    atomic_write_text(REFERENCE, json.dumps(data, indent=1, sort_keys=False) + "\n")


def _write_steps(fe_cache: str | None = None) -> None:
    """Run the coarse report of tests/conftest.py and store its steps' numbers.

    Its caches are private: a temporary folder, or ``fe_cache`` (kept, for a rerun).
    """
    import os
    import tempfile

    from conftest import COARSE_REPORT, report_toml

    from isj.atomic import atomic_write_text
    from isj.results_version import step_versions

    with tempfile.TemporaryDirectory() as tmp:
        os.environ["ISJ_FE_CACHE_DIR"] = f"{fe_cache or tmp}/fe"
        os.environ["ISJ_CACHE_DIR"] = f"{fe_cache or tmp}/meshes"
        from isj.reports.config import load_config
        from isj.reports.run import run_report

        case = Path(tmp) / "case.toml"
        case.write_text(report_toml(COARSE_REPORT))
        res = run_report(load_config(case), Path(tmp) / "out", verbosity=0)
    data = json.loads(REFERENCE.read_text())
    data["steps"] = {
        name: {"versions": step_versions(name), "values": pick(step_numbers(result))}
        for name, result in res["steps"].items()
    }
    data["rtol_steps"] = RTOL_STEPS
    atomic_write_text(REFERENCE, json.dumps(data, indent=1) + "\n")


def main(argv: list[str]) -> int:
    """``--write [FAMILY ...]``, ``--write-steps``: regenerate; ``--check FAMILY ...``: compare (exit 1)."""
    if argv[:1] == ["--write-steps"] and len(argv) <= 2:
        _write_steps(*argv[1:])
        return 0
    if not argv or argv[0] not in ("--write", "--check"):
        print(f"usage: {REGENERATE} [FAMILY ...] | --write-steps | --check FAMILY ...", file=sys.stderr)
        return 2
    families = argv[1:] or list(COMPUTE)
    unknown = sorted(set(families) - set(COMPUTE))
    if unknown:
        print(f"family = {unknown}: must be among {sorted(COMPUTE)}", file=sys.stderr)
        return 2
    if argv[0] == "--write":
        _write(families)
        return 0
    bad = False
    for fam in families:
        msgs, skipped = problems(fam)
        for m in msgs:
            print(m)
        print(f"{fam}: {'skipped: ' + skipped if skipped else 'differs' if msgs else 'ok'}", file=sys.stderr)
        bad |= bool(msgs)
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
