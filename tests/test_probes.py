"""Bad input, probed from the command line: one line naming the parameter, exit 2, nothing written.

Each row is a command, the exit code it must give, a fragment the one-line
message must hold (the parameter's name), and optionally environment variables
set for it. The probes run in an empty working folder with empty private caches
and an empty home folder, so "nothing written" covers the output paths, the
working folder, the caches and the home alike. Every probe must be refused
before any computation: an alarm turns a probe that starts computing (a mesh at
--resolution 50, say) into a failure instead of a hang. A row with exit code 0
is a warning: its one stderr line is the warning, and it may print its result.
"""

import json
import os
import signal
import subprocess
import sys

import meshio
import numpy as np
import pytest

from isj.cli import main

BINARY = bytes(range(256)) * 4
#: TOML nested far deeper than Python's parser recurses, and deeper than the limit (32) only.
DEEP = "[" * 5000 + "]" * 5000
DEEP_100 = "[" * 100 + "]" * 100


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


def _tiny_mesh(path, nan: bool = False):
    """Six separate tetrahedra, one per region, with the loaded and clamped faces: a .msh that
    passes the group checks (only), with one NaN coordinate when ``nan``."""
    from isj.design import REGIONS

    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * 1e-4
    points = np.concatenate([tet + [3e-4 * i, 0, 0] for i in range(len(REGIONS))])
    if nan:
        points[5, 1] = np.nan
    tets = np.arange(4 * len(REGIONS)).reshape(-1, 4)
    tris = np.array([[0, 1, 2], [4, 5, 6]])
    names = [*REGIONS, "loaded", "clamped"]
    tags = [np.arange(1, len(REGIONS) + 1), np.array([len(REGIONS) + 1, len(REGIONS) + 2])]
    field_data = {n: np.array([i + 1, 3 if i < len(REGIONS) else 2]) for i, n in enumerate(names)}
    m = meshio.Mesh(
        points,
        [("tetra", tets), ("triangle", tris)],
        cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
        field_data=field_data,
    )
    meshio.write(path, m, file_format="gmsh22", binary=False)
    return str(path)


@pytest.fixture(scope="module")
def micrometre_mesh(tmp_path_factory):
    """The coarse built-in mesh written with its coordinates in µm (read as metres: 1000 m wide)."""
    from isj.fem.mesh import mesh_pedicle_joint
    from isj.fem.user_mesh import write_mesh

    d = tmp_path_factory.mktemp("um")
    m = meshio.read(write_mesh(mesh_pedicle_joint(resolution=0.35), d / "m.msh"))
    m.points = m.points * 1e6
    meshio.write(d / "um.msh", m, file_format="gmsh22", binary=False)
    return str(d / "um.msh")


# (id, argv, exit code, message fragment[, environment]); {tmp} is an input folder outside the
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
    # issue 27, item 1: NaN coordinates in a user mesh
    ("solve-mesh-nan", ["fem", "solve", "--mesh", "{nan_msh}"], 2, "not a finite number"),
    ("solve-mesh-nan-json", ["fem", "solve", "--json", "--mesh", "{nan_msh}"], 2, "not a finite number"),
    ("mesh-mesh-nan", ["fem", "mesh", "--mesh", "{nan_msh}"], 2, "not a finite number"),
    # item 2: a cache that cannot be used, refused before any work
    (
        "calibrate-cache-is-file",
        ["calibrate", "--cache", "{tmp}/binary.toml", "--out", "c.json"],
        2,
        "--cache",
    ),
    ("calibrate-cache-unmakeable", ["calibrate", "--cache", "/proc/isj/fe", "--out", "c.json"], 2, "--cache"),
    (
        "explore-cache-is-file",
        ["explore", "--spot-checks", "1", "--cache", "{tmp}/binary.toml"],
        2,
        "--cache",
    ),
    (
        "report-fe-cache-env-is-file",
        ["report", "--out", "r"],
        2,
        "ISJ_FE_CACHE_DIR",
        {"ISJ_FE_CACHE_DIR": "{tmp}/binary.toml"},
    ),
    (
        "report-fe-cache-env-unmakeable",
        ["report", "--out", "r"],
        2,
        "ISJ_FE_CACHE_DIR",
        {"ISJ_FE_CACHE_DIR": "/proc/isj/fe"},
    ),
    (
        "report-cache-folder-is-file",
        ["report", "--out", "r"],
        2,
        "'report' folder",
        {"ISJ_FE_CACHE_DIR": "{tmp}/fe_report_file"},
    ),
    (
        "rom-solve-cache-env-unmakeable",
        ["rom", "solve"],
        2,
        "ISJ_FE_CACHE_DIR",
        {"ISJ_FE_CACHE_DIR": "/proc/isj/fe"},
    ),
    (
        "rom-build-rom-folder-is-file",
        ["rom", "build"],
        2,
        "'rom' folder",
        {"ISJ_FE_CACHE_DIR": "{tmp}/fe_rom_file"},
    ),
    (
        "explore-env-is-file",
        ["explore", "--spot-checks", "1"],
        2,
        "ISJ_FE_CACHE_DIR",
        {"ISJ_FE_CACHE_DIR": "{tmp}/binary.toml"},
    ),
    (
        "solve-mesh-cache-is-file",
        ["fem", "solve"],
        2,
        "ISJ_CACHE_DIR",
        {"ISJ_CACHE_DIR": "{tmp}/binary.toml"},
    ),
    ("ear-mesh-cache-is-file", ["ear", "solve"], 2, "ISJ_CACHE_DIR", {"ISJ_CACHE_DIR": "{tmp}/binary.toml"}),
    # item 3: every configuration value checked where it is read, whatever overrides it
    (
        "uq-config-samples-zero",
        ["uq", "--config", "{tmp}/uq_zero.toml", "--samples", "5000"],
        2,
        "uq.samples",
    ),
    (
        "uq-config-samples-text",
        ["uq", "--config", "{tmp}/uq_text.toml", "--samples", "5000"],
        2,
        "uq.samples",
    ),
    (
        "uq-config-samples-float",
        ["uq", "--config", "{tmp}/uq_float.toml", "--samples", "5000"],
        2,
        "uq.samples",
    ),
    (
        "uq-config-samples-bool",
        ["uq", "--config", "{tmp}/uq_bool.toml", "--samples", "5000"],
        2,
        "uq.samples",
    ),
    (
        "uq-config-sobol-out-of-range",
        ["uq", "--config", "{tmp}/uq_sobol.toml", "--sobol-samples", "1024"],
        2,
        "uq.sobol_samples",
    ),
    (
        "uq-config-bootstrap-out-of-range",
        ["uq", "--config", "{tmp}/uq_bootstrap.toml", "--bootstrap", "20"],
        2,
        "uq.bootstrap",
    ),
    (
        "report-set-loss-factor-huge",
        ["report", "--set", "sweep.loss_factor=11", "--out", "r"],
        2,
        "sweep.loss_factor",
    ),
    (
        "report-config-loss-factor-overridden",
        ["report", "--config", "{tmp}/case_loss.toml", "--set", "sweep.loss_factor=0.1", "--out", "r"],
        2,
        "sweep.loss_factor",
    ),
    ("sweep-loss-factor-empty-name", ["sweep", "--loss-factor", "=0.1", "--out", "s"], 2, "--loss-factor"),
    ("sweep-rayleigh-a-empty-name", ["sweep", "--rayleigh-a", "=1", "--out", "s"], 2, "--rayleigh-a"),
    # item 4: deeply nested TOML
    ("report-config-deep", ["report", "--config", "{tmp}/deep.toml", "--out", "r"], 2, "nested"),
    ("uq-config-deep", ["uq", "--config", "{tmp}/deep.toml"], 2, "nested"),
    ("uq-config-deep-100", ["uq", "--config", "{tmp}/deep100.toml"], 2, "nested"),
    (
        "solve-points-deep",
        ["fem", "solve", "--mesh", "{nan_msh}", "--points", "{tmp}/deep.toml"],
        2,
        "--points",
    ),
    ("report-set-deep", ["report", "--set", "sweep.fmin_hz={deep}", "--out", "r"], 2, "nested"),
    # item 5: bands beyond what each model represents
    ("ear-sweep-fe-fmax-huge", ["ear", "sweep", "--fe", "--fmax-hz", "1e9", "--out", "s"], 2, "--fmax-hz"),
    (
        "ear-sweep-no-modes-fmax-huge",
        ["ear", "sweep", "--drum-modes", "0", "--fmax-hz", "1e9", "--out", "s"],
        2,
        "--fmax-hz",
    ),
    ("ear-sweep-fmax-above-ear", ["ear", "sweep", "--fmax-hz", "30000", "--out", "s"], 2, "24000"),
    ("sweep-fmax-huge", ["sweep", "--fmax-hz", "1e9", "--out", "s"], 2, "--fmax-hz"),
    ("report-sweep-fmax-huge", ["report", "--set", "sweep.fmax_hz=1e9", "--out", "r"], 2, "sweep.fmax_hz"),
    (
        "report-transmission-fmax-huge",
        ["report", "--set", "transmission.fmax_hz=1e9", "--out", "r"],
        2,
        "transmission.fmax_hz",
    ),
    # item 7: limits that one path checked and another skipped
    ("sweep-nu-extrapolated", ["sweep", "--nu", "0.2", "--out", "s"], 2, "--nu"),
    ("sweep-nu-0.4", ["sweep", "--nu", "0.4", "--out", "s"], 2, "--nu"),
    ("ear-sweep-nu-extrapolated", ["ear", "sweep", "--nu", "0.2", "--out", "s"], 2, "--nu"),
    (
        "report-set-rayleigh-b",
        ["report", "--set", "sweep.rayleigh_b_s=1", "--out", "r"],
        2,
        "sweep.rayleigh_b_s",
    ),
    (
        "lumped-capsule-levels-close",
        ["lumped", "solve", "--geometry", "capsule_reach_m=24e-6"],
        0,
        "capsule_reach_m - capsule_bond_m",
    ),
    ("modes-vtu-dir-holds-other-files", ["fem", "modes", "--vtu-dir", "{tmp}"], 2, "--vtu-dir"),
    # item 9: silent acceptance where a user likely erred
    (
        "solve-geometry-twice",
        ["fem", "solve", "--geometry", "pedicle_x_m=60e-6", "--geometry", "pedicle_x_m=70e-6"],
        2,
        "given twice",
    ),
    (
        "lumped-geometry-twice",
        ["lumped", "solve", "--geometry", "gap_thickness_m=20e-6", "--geometry", "gap_thickness_m=20e-6"],
        2,
        "given twice",
    ),
    ("solve-layer-shear-without-layer", ["fem", "solve", "--layer-shear-pa", "5"], 2, "--layer-shear-pa"),
    (
        "modes-layer-shear-sliding",
        ["fem", "modes", "--joint", "sliding", "--layer-shear-pa", "5"],
        2,
        "--layer-shear-pa",
    ),
    (
        "mesh-micrometres-read-as-metres",
        ["fem", "mesh", "--order", "1", "--mesh", "{um_msh}"],
        0,
        "bounding box",
    ),
]


@pytest.fixture()
def probe_env(tmp_path, monkeypatch, request):
    inputs = tmp_path / "inputs"
    work = tmp_path / "work"
    caches = tmp_path / "caches"
    home = tmp_path / "home"
    for d in (
        inputs,
        work,
        caches / "mesh",
        caches / "fe",
        home,
        inputs / "fe_rom_file",
        inputs / "fe_report_file",
    ):
        d.mkdir(parents=True)
    (inputs / "binary.toml").write_bytes(BINARY)
    (inputs / "fe_rom_file" / "rom").write_text("a file where the rom cache's folder belongs\n")
    (inputs / "fe_report_file" / "report").write_text("a file where the report cache's folder belongs\n")
    files = {
        "uq_zero.toml": "[uq]\nsamples = 0\n",
        "uq_text.toml": '[uq]\nsamples = "abc"\n',
        "uq_float.toml": "[uq]\nsamples = 5000.0\n",
        "uq_bool.toml": "[uq]\nsamples = true\n",
        "uq_sobol.toml": "[uq]\nsobol_samples = 1048576\n",
        "uq_bootstrap.toml": "[uq]\nbootstrap = 5\n",
        "case_loss.toml": "[sweep]\nloss_factor = 11\n",
        "deep.toml": f"[uq]\nsamples = {DEEP}\n",
        "deep100.toml": f"[uq]\nsamples = {DEEP_100}\n",
    }
    for name, text in files.items():
        (inputs / name).write_text(text)
    subs = {
        "tmp": str(inputs),
        "deep": DEEP,
        "cal_training": _calibration_with(inputs / "training.json", training=[1, 2]),
        "cal_validation": _calibration_with(inputs / "validation.json", validation="x"),
        "cal_shear": _calibration_with(inputs / "shear.json", shear_factor=True),
        "nan_msh": _tiny_mesh(inputs / "nan.msh", nan=True),
    }
    if "um_msh" in " ".join(request.node.callspec.params.get("argv", [])):
        subs["um_msh"] = request.getfixturevalue("micrometre_mesh")
    monkeypatch.setenv("ISJ_CACHE_DIR", str(caches / "mesh"))
    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(caches / "fe"))
    monkeypatch.setenv("HOME", str(home))
    for var in ("XDG_CONFIG_HOME", "XDG_CACHE_HOME", "XDG_DATA_HOME", "MPLCONFIGDIR"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.chdir(work)
    return work, caches, home, inputs, subs


class _Computing(Exception):
    pass


def _alarm(signum, frame):
    raise _Computing("the probe started computing instead of refusing its input")


def _files_under(d):
    return sorted(str(p.relative_to(d)) for p in d.rglob("*") if p.is_file())


def test_probe_rows_are_well_formed():
    ids = [p[0] for p in PROBES]
    assert len(set(ids)) == len(ids), "probe ids repeat"
    for p in PROBES:
        assert len(p) in (4, 5) and isinstance(p[1], list) and p[2] in (0, 1, 2) and p[3], p


@pytest.mark.parametrize(
    "argv, code, fragment, env",
    [(*p[1:4], p[4] if len(p) > 4 else {}) for p in PROBES],
    ids=[p[0] for p in PROBES],
)
def test_probe(probe_env, capsys, monkeypatch, argv, code, fragment, env):
    work, caches, home, inputs, subs = probe_env
    argv = [a.format(**subs) for a in argv]
    for k, v in env.items():
        monkeypatch.setenv(k, v.format(**subs))
    before = _files_under(inputs)
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
    assert lines[0].startswith("isj: warning: " if code == 0 else "isj: error: "), lines[0]
    assert "Traceback" not in err
    if code != 0:  # a refusal prints nothing; a warning's command goes on and prints its result
        assert not out.strip(), out[:500]
    assert _files_under(work) == []
    assert _files_under(caches) == []
    assert _files_under(home) == [], "written into the home folder"
    assert [p.name for p in home.iterdir()] == []
    assert _files_under(inputs) == before
    assert not os.path.exists("/proc/isj")


def test_gmsh_writes_nothing_into_the_home_folder(tmp_path):
    """A fresh process (FLTK reads its preferences once per process) meshes with gmsh under an
    empty HOME: no ``.fltk/fltk.org/fltk.prefs`` appears there, and HOME is the same after."""
    home = tmp_path / "home"
    home.mkdir()
    code = (
        "import os; from isj.fem.mesh import mesh_cantilever; "
        "m = mesh_cantilever(resolution=0.3, cache_dir=False); "
        "assert len(m.tets) > 0; print(os.environ['HOME'])"
    )
    env = {k: v for k, v in os.environ.items() if not k.startswith("XDG_")}
    env |= {"HOME": str(home), "ISJ_CACHE_DIR": str(tmp_path / "meshes")}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == str(home)  # restored after gmsh's initialisation
    assert sorted(str(p.relative_to(home)) for p in home.rglob("*")) == []
