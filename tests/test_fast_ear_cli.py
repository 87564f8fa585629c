"""``isj ear sweep --fast``: the fast ear's H_V and ΔH_V in the sweep's files (issue 24 item 4).

The default mesh's fast ear ships with isj (docs/fast_ear.md §14.7), so the command reads it; its
accuracy against the FE ear is tested in tests/test_fast_ear_shipped.py. Here: the files, that
ΔH_V is H_V over the fast ear's own rigid connection, and the refusals before anything is built.
"""

import json

import numpy as np
import pytest

from isj.cli import main

pytestmark = pytest.mark.slow  # the default ear model is built for the fast ear's key

ARGV = ["ear", "sweep", "--fast", "--n", "12", "--gap-e", "5e6"]


def test_fast_sweep_writes_h_v_and_delta_h_v(capsys, tmp_path, monkeypatch):
    from isj.fem.ear.fast_ear import fast_ear
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.model import PedicleJointModel

    from isj.design import Materials

    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path / "fe"))
    out = tmp_path / "fast"
    assert main([*ARGV, "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["fast"] and summary["shipped"] and summary["band_hz"] == [100.0, 20000.0]
    assert sorted(p.name for p in out.iterdir()) == [
        "ear_bode.png",
        "ear_sweep.csv",
        "ear_sweep.json",
        "ear_sweep.npz",
    ]
    header = (out / "ear_sweep.csv").read_text().splitlines()[1].split(",")
    assert {"h_v_db", "h_v_deg", "delta_h_v_db", "delta_h_v_deg"} <= set(header)
    data = np.load(out / "ear_sweep.npz")
    f = data["freq_hz"]
    assert f.size == 12 and data["check_freq_hz"].size == 0  # no direct checks
    # H_V in the file is the fast ear's for this design; H_V − ΔH_V is its rigid connection's
    ear = fast_ear(MiddleEarModel(joint=PedicleJointModel(order=2, resolution=1.0)))
    ref = ear.batch(f, Materials(gap_e_pa=5e6))
    np.testing.assert_allclose(data["h_v_db"], 20 * np.log10(np.abs(ref["h_v"][0])), rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        data["h_v_db"] - data["delta_h_v_db"], 20 * np.log10(np.abs(ref["h_v_rigid"])), rtol=0, atol=1e-9
    )
    low = f <= 10e3
    assert summary["delta_h_v"]["max_abs_delta_h_v_db_to_10khz"] == np.max(np.abs(data["delta_h_v_db"][low]))
    assert json.loads((out / "ear_sweep.json").read_text())["results"]["fast"] is True


@pytest.mark.parametrize(
    "extra, names",
    [
        (["--gap-e", "1e4"], "gap_e_pa"),  # outside the calibrated domain
        (["--fe"], "--fe and --fast"),
        (["--fmax-hz", "24000"], "--fmax-hz"),
        (["--rigid-joint"], "--rigid-joint"),
    ],
)
def test_fast_sweep_refuses_in_one_line_and_writes_nothing(capsys, tmp_path, extra, names):
    out = tmp_path / "fast"
    assert main([*ARGV, *extra, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and names in err[0], err
    assert not out.exists()
