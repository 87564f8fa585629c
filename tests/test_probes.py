"""Bad input, probed from the command line: one line naming the parameter, exit 2, nothing written.

Each row is a command, the exit code it must give, a fragment the one-line
message must hold (the parameter's name), and whether it may leave files. The
probes run in an empty working folder with empty private caches, so "nothing
written" covers the output paths, the working folder and the caches alike.
Every probe must be refused before any computation: an alarm turns a probe
that starts computing (a mesh at --resolution 50, say) into a failure instead
of a hang.
"""

import json
import os
import signal

import pytest

from isj.cli import main

BINARY = bytes(range(256)) * 4


def _calibration_with(path, **changes):
    """The shipped calibration with some fields replaced, written to ``path``."""
    from importlib import resources

    from isj.lumped.artifact import DEFAULT_CALIBRATION

    data = json.loads((resources.files("isj.lumped") / "data" / DEFAULT_CALIBRATION).read_text())
    for k, v in changes.items():
        if k == "shear_factor":
            data["dynamics"]["shear_factor"] = v
        else:
            data[k] = v
    path.write_text(json.dumps(data))
    return str(path)


# (id, argv, exit code, message fragment); {tmp} is an input folder outside the
# working folder, for files the probe reads
PROBES = [
    ("report-binary-config", ["report", "--config", "{tmp}/binary.toml", "--out", "r"], 2, "--config"),
    ("lumped-training-not-object", ["lumped", "solve", "--calibration", "{cal_training}"], 2, "training"),
    (
        "lumped-validation-not-object",
        ["lumped", "solve", "--calibration", "{cal_validation}"],
        2,
        "validation",
    ),
    ("lumped-shear-factor-bool", ["lumped", "solve", "--calibration", "{cal_shear}"], 2, "shear_factor"),
    ("explore-seed-negative", ["explore", "--pedicle-e", "1e9:2e10", "--seed", "-1"], 2, "--seed"),
    ("calibrate-seed-negative", ["calibrate", "--seed", "-1", "--out", "c.json"], 2, "--seed"),
    (
        "explore-huge-n",
        ["explore", "--pedicle-e", "1e9:2e10", "--gap-e", "1e6:5e7", "--n", "100000000"],
        2,
        "--n",
    ),
    ("explore-huge-sample", ["explore", "--pedicle-e", "1e9:2e10", "--sample", "10000000000"], 2, "--sample"),
    ("calibrate-huge-samples", ["calibrate", "--samples", "10000000000", "--out", "c.json"], 2, "--samples"),
    ("calibrate-few-samples", ["calibrate", "--samples", "4", "--out", "c.json"], 2, "--samples"),
    # --samples 16: the smallest valid count, so that only the option under test is wrong
    ("calibrate-unwritable-out", ["calibrate", "--samples", "16", "--out", "/proc/isj/c.json"], 2, "--out"),
    ("solve-unwritable-vtu", ["fem", "solve", "--vtu", "/proc/isj/x.vtu"], 2, "--vtu"),
    (
        "convergence-unwritable-plot",
        ["fem", "convergence", "--direction", "x", "--plot", "/proc/isj/c.png"],
        2,
        "--plot",
    ),
    ("sweep-unwritable-out", ["sweep", "--out", "/proc/isj/sweep"], 2, "--out"),
    ("report-unwritable-out", ["report", "--out", "/proc/isj/report"], 2, "--out"),
    ("sweep-empty-out", ["sweep", "--out", ""], 2, "--out"),
    ("report-empty-out", ["report", "--out", ""], 2, "--out"),
    (
        "calibrate-unreachable-scheduler",
        ["calibrate", "--samples", "16", "--scheduler", "tcp://127.0.0.1:9", "--out", "c.json"],
        2,
        "--scheduler",
    ),
    ("solve-pressure-tiny", ["fem", "solve", "--pressure", "1e-300"], 2, "--pressure"),
    ("solve-pressure-huge", ["fem", "solve", "--pressure", "1e300", "--json"], 2, "--pressure"),
    ("solve-incus-e-tiny", ["fem", "solve", "--incus-e", "1e-300", "--json"], 2, "--incus-e"),
    ("solve-pressure-zero", ["fem", "solve", "--pressure", "0"], 2, "pressure"),
    ("lumped-pressure-zero", ["lumped", "solve", "--pressure", "0"], 2, "pressure"),
    ("ear-drum-e-huge", ["ear", "solve", "--rigid-joint", "--drum-e", "1e300"], 2, "--drum-e"),
    (
        "report-pedicle-e-huge",
        ["report", "--set", "design.pedicle_e_pa=1e300", "--out", "r"],
        2,
        "pedicle_e_pa",
    ),
    ("mesh-resolution-50", ["fem", "mesh", "--resolution", "50"], 2, "--resolution"),
    ("solve-resolution-50", ["fem", "solve", "--resolution", "50"], 2, "--resolution"),
    ("ear-resolution-50", ["ear", "solve", "--resolution", "50"], 2, "--resolution"),
    ("solve-metre-geometry", ["fem", "solve", "--geometry", "incus_length_m=1.0"], 2, "incus_length_m"),
    ("solve-degenerate-gap", ["fem", "solve", "--geometry", "gap_thickness_m=1e-9"], 2, "gap_thickness_m"),
    ("sweep-rayleigh-b-huge", ["sweep", "--rayleigh-b", "1e300", "--out", "s"], 2, "--rayleigh-b"),
    ("sweep-loss-factor-negative", ["sweep", "--loss-factor", "-0.1", "--out", "s"], 2, "--loss-factor"),
    ("lumped-nu-ignored", ["lumped", "solve", "--nu", "0.45"], 2, "--nu"),
    # more of the same kinds, on the other commands
    ("cases-resolution-50", ["fem", "cases", "--resolution", "50"], 2, "--resolution"),
    ("modes-resolution-50", ["fem", "modes", "--resolution", "50"], 2, "--resolution"),
    ("ear-cases-resolution-50", ["ear", "cases", "--resolution", "50"], 2, "--resolution"),
    ("ear-sweep-resolution-50", ["ear", "sweep", "--resolution", "50", "--out", "s"], 2, "--resolution"),
    (
        "convergence-resolutions-50",
        ["fem", "convergence", "--direction", "x", "--resolutions", "50"],
        2,
        "--resolutions",
    ),
    # inside the option's range, but over the memory the mesh-size estimate allows
    ("solve-resolution-memory", ["fem", "solve", "--resolution", "6"], 2, "--resolution"),
    ("mesh-resolution-memory", ["fem", "mesh", "--resolution", "6"], 2, "--resolution"),
    ("ear-resolution-memory", ["ear", "solve", "--resolution", "6"], 2, "--resolution"),
    ("calibrate-resolution-memory", ["calibrate", "--resolution", "6", "--out", "c.json"], 2, "--resolution"),
    ("explore-resolution-memory", ["explore", "--resolution", "6"], 2, "--resolution"),
    (
        "convergence-joint-memory",
        ["fem", "convergence", "--model", "joint", "--resolutions", "6"],
        2,
        "--resolutions",
    ),
    ("solve-geometry-nan", ["fem", "solve", "--geometry", "gap_thickness_m=nan"], 2, "gap_thickness_m"),
    ("mesh-metre-geometry", ["fem", "mesh", "--geometry", "joint_x_m=1.0"], 2, "joint_x_m"),
    (
        "sweep-metre-geometry",
        ["sweep", "--geometry", "pedicle_length_m=1.0", "--out", "s"],
        2,
        "pedicle_length_m",
    ),
    (
        "report-degenerate-gap",
        ["report", "--set", "geometry.gap_thickness_m=1e-9", "--out", "r"],
        2,
        "gap_thickness_m",
    ),
    ("report-pressure-huge", ["report", "--set", "design.pressure_pa=1e300", "--out", "r"], 2, "pressure_pa"),
    ("explore-modulus-huge", ["explore", "--pedicle-e", "1e9:1e300"], 2, "--pedicle-e"),
    ("explore-pressure-zero", ["explore", "--pressure", "0"], 2, "--pressure"),
    ("modes-capsule-e-huge", ["fem", "modes", "--capsule-e", "1e300"], 2, "--capsule-e"),
    ("ear-solve-gap-e-tiny", ["ear", "solve", "--gap-e", "1e-300"], 2, "--gap-e"),
    ("sweep-pressure-huge", ["sweep", "--pressure", "1e300", "--out", "s"], 2, "--pressure"),
    ("sweep-rayleigh-a-huge", ["sweep", "--rayleigh-a", "1e300", "--out", "s"], 2, "--rayleigh-a"),
    ("sweep-loss-factor-huge", ["sweep", "--loss-factor", "1e300", "--out", "s"], 2, "--loss-factor"),
    ("ear-sweep-rayleigh-b-huge", ["ear", "sweep", "--rayleigh-b", "1e300", "--out", "s"], 2, "--rayleigh-b"),
    ("sweep-huge-n", ["sweep", "--n", "10000000000", "--out", "s"], 2, "--n"),
    ("modes-huge-n", ["fem", "modes", "--n", "10000000000"], 2, "--n"),
    (
        "calibrate-huge-validation",
        ["calibrate", "--validation", "10000000000", "--out", "c.json"],
        2,
        "--validation",
    ),
    (
        "calibrate-huge-modal",
        ["calibrate", "--modal-samples", "10000000000", "--out", "c.json"],
        2,
        "--modal-samples",
    ),
    ("explore-huge-seed", ["explore", "--seed", "99999999999999999999999"], 2, "--seed"),
    ("cases-unwritable-vtu", ["fem", "cases", "--vtu", "/proc/isj/x.vtu"], 2, "--vtu"),
    ("modes-unwritable-vtu-dir", ["fem", "modes", "--vtu-dir", "/proc/isj/m"], 2, "--vtu-dir"),
    ("ear-sweep-unwritable-out", ["ear", "sweep", "--out", "/proc/isj/e"], 2, "--out"),
    ("ear-sweep-empty-out", ["ear", "sweep", "--out", ""], 2, "--out"),
    ("calibrate-empty-out", ["calibrate", "--out", ""], 2, "--out"),
    ("solve-empty-vtu", ["fem", "solve", "--vtu", ""], 2, "--vtu"),
    ("convergence-empty-plot", ["fem", "convergence", "--direction", "x", "--plot", ""], 2, "--plot"),
    ("sweep-out-is-cwd", ["sweep", "--out", "."], 2, "--out"),
    ("sweep-out-holds-other-files", ["sweep", "--out", "{tmp}"], 2, "--out"),
    (
        "calibrate-scheduler-scheme",
        ["calibrate", "--scheduler", "inproc://x", "--out", "c.json"],
        2,
        "--scheduler",
    ),
    (
        "calibrate-scheduler-no-port",
        ["calibrate", "--scheduler", "tcp://127.0.0.1", "--out", "c.json"],
        2,
        "--scheduler",
    ),
    ("lumped-mesh-options-gone", ["lumped", "solve", "--resolution", "2"], 2, "--resolution"),
    ("uq-binary-config", ["uq", "--config", "{tmp}/binary.toml", "--out", "u"], 2, "--config"),
    ("uq-unwritable-out", ["uq", "--out", "/proc/isj/u"], 2, "--out"),
    ("uq-out-holds-other-files", ["uq", "--out", "{tmp}"], 2, "--out"),
    ("uq-huge-samples", ["uq", "--samples", "10000000000"], 2, "--samples"),
    ("uq-sobol-not-power-of-2", ["uq", "--sobol-samples", "1000", "--out", "u"], 2, "--sobol-samples"),
]


@pytest.fixture()
def probe_env(tmp_path, monkeypatch):
    inputs = tmp_path / "inputs"
    work = tmp_path / "work"
    caches = tmp_path / "caches"
    for d in (inputs, work, caches / "mesh", caches / "fe"):
        d.mkdir(parents=True)
    (inputs / "binary.toml").write_bytes(BINARY)
    subs = {
        "tmp": str(inputs),
        "cal_training": _calibration_with(inputs / "training.json", training=[1, 2]),
        "cal_validation": _calibration_with(inputs / "validation.json", validation="x"),
        "cal_shear": _calibration_with(inputs / "shear.json", shear_factor=True),
    }
    monkeypatch.setenv("ISJ_CACHE_DIR", str(caches / "mesh"))
    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(caches / "fe"))
    monkeypatch.chdir(work)
    return work, caches, subs


class _Computing(Exception):
    pass


def _alarm(signum, frame):
    raise _Computing("the probe started computing instead of refusing its input")


def _files_under(d):
    return sorted(str(p.relative_to(d)) for p in d.rglob("*") if p.is_file())


@pytest.mark.parametrize("argv, code, fragment", [p[1:] for p in PROBES], ids=[p[0] for p in PROBES])
def test_probe(probe_env, capsys, argv, code, fragment):
    work, caches, subs = probe_env
    argv = [a.format(**subs) for a in argv]
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(15)
    try:
        try:
            got = main(argv)
        except SystemExit as e:  # argparse's own refusals
            got = e.code
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    out, err = capsys.readouterr()
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert got == code, (got, err[-2000:])
    assert len(lines) == 1, err[-2000:]
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in err
    assert not out.strip(), out[:500]
    assert _files_under(work) == []
    assert _files_under(caches) == []
    assert not os.path.exists("/proc/isj")
