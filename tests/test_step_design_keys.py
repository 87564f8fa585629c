"""The report steps that compute only the thesis cases hold no case modulus of [design] in their keys
(reports/steps.py ``DESIGN_OF_CASES``): a new pedicle, gap and capsule modulus leaves each result as
it was, bit for bit, and a modulus the cases do not set changes it."""

from __future__ import annotations

import json

import pytest
from isj.reports.steps import CASE_MODULI, DESIGN_OF_CASES, STEPS

pytestmark = pytest.mark.slow  # FE on the coarse mesh and a coarse drum

#: A small configuration: the coarse joint mesh, a 0.25 mm drum, one case and its sliding twin.
CASE = """
[mesh]
order = 2
resolution = 0.35
drum_mesh_size_m = 0.00025
[transmission]
n_freq = 24
cases = ["p12"]
fe_checks = 1
sliding_cases = ["p12"]
cavities = "open"
[sliding]
joints = ["bonded", "sliding"]
"""

CASE_STEPS = ("cases", "ear", "transmission", "sliding")


def test_the_case_steps_keys_hold_no_case_modulus():
    keys = {name: sections for name, _, sections in STEPS}
    for name in CASE_STEPS:
        assert "design" not in keys[name] and set(DESIGN_OF_CASES) <= set(keys[name]), name
    assert not any(f"design.{k}" in keys[n] for n in CASE_STEPS for k in CASE_MODULI)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Each case step's JSON: the base, the three case moduli changed, and the incus modulus changed."""
    from isj.lumped.artifact import default_calibration
    from isj.reports.config import load_config
    from isj.reports.steps import Context

    tmp = tmp_path_factory.mktemp("design-keys")
    case = tmp / "case.toml"
    case.write_text(CASE)
    mp = pytest.MonkeyPatch()
    mp.setenv("ISJ_FE_CACHE_DIR", str(tmp / "fe"))
    base = load_config(case)
    moved = [f"design.{k}={getattr(base.design, k) * 1.7!r}" for k in CASE_MODULI]
    configs = {
        "base": base,
        "case_moduli": load_config(case, moved),
        "incus": load_config(case, [f"design.incus_e_pa={base.design.incus_e_pa * 1.7!r}"]),
    }
    fns = {name: fn for name, fn, _ in STEPS}
    out = {}
    try:
        for label, config in configs.items():
            ctx = Context(config, default_calibration(), tmp / "fe", progress=False)
            out[label] = {n: json.dumps(fns[n](ctx)[0], sort_keys=True) for n in CASE_STEPS}
    finally:
        mp.undo()
    return out


@pytest.mark.parametrize("step", CASE_STEPS)
def test_a_new_case_modulus_leaves_the_step_as_it_was(results, step):
    assert results["case_moduli"][step] == results["base"][step]


@pytest.mark.parametrize("step", CASE_STEPS)
def test_a_modulus_the_cases_do_not_set_changes_the_step(results, step):
    assert results["incus"][step] != results["base"][step]
