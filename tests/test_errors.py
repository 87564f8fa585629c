"""One error hierarchy: every class is an IsjError (or IsjWarning) and the builtin it is;
the old homes still export the same class objects; the CLI turns them into one line and exit 2."""

import importlib
import warnings

import pytest

import isj.errors as errors

ERRORS = {
    "InvalidParameter": ValueError,
    "UsageError": ValueError,
    "ConfigError": ValueError,
    "PointOutsideBody": ValueError,
    "CorruptCalibration": ValueError,
    "InvalidMesh": ValueError,
    "MeshError": RuntimeError,
    "SolverUnavailable": RuntimeError,
    "SolverFailed": RuntimeError,
    "FitFailed": RuntimeError,
    "EvaluationError": RuntimeError,
}
WARNINGS = [
    "CacheWarning",
    "CorruptCacheEntry",
    "OutOfDomainWarning",
    "CalibrationWarning",
    "VolumetricLockingWarning",
    "DampingWarning",
]

# where each class lived before isj.errors; code that imports it from there must keep working


@pytest.mark.parametrize("name, builtin", ERRORS.items())
def test_error_is_isj_error_and_its_builtin(name, builtin):
    cls = getattr(errors, name)
    assert issubclass(cls, errors.IsjError) and issubclass(cls, builtin)
    assert not issubclass(cls, Warning)


@pytest.mark.parametrize("name", WARNINGS)
def test_warning_is_isj_warning(name):
    cls = getattr(errors, name)
    assert issubclass(cls, errors.IsjWarning) and issubclass(cls, UserWarning)
    assert not issubclass(cls, errors.IsjError)


def test_all_lists_exactly_the_classes():
    assert set(errors.__all__) == {*ERRORS, *WARNINGS, "IsjError", "IsjWarning"}
    assert issubclass(errors.IsjError, Exception) and not issubclass(errors.IsjError, ValueError)


@pytest.mark.parametrize("name", [*ERRORS, *WARNINGS])
def test_every_error_and_warning_has_one_home(name):
    """Defined in isj.errors, and listed by no subpackage's ``__all__`` (no old homes; the flat
    ``isj`` namespace lists them as the public API's)."""
    assert getattr(errors, name).__module__ == "isj.errors"
    for module in ("isj.fem", "isj.lumped", "isj.calibration", "isj.reports"):
        assert name not in getattr(importlib.import_module(module), "__all__", ()), module


def test_extra_fields_survive():
    e = errors.FitFailed("no convergence", {"return_status": "Maximum_Iterations_Exceeded"})
    assert e.stats["return_status"].startswith("Maximum") and str(e) == "no convergence"
    f = errors.EvaluationError("1 failed", [({"gap_e_pa": 1.0}, ValueError("x"))])
    assert f.failures[0][0] == {"gap_e_pa": 1.0}


def test_one_filter_turns_every_isj_warning_into_an_error():
    with warnings.catch_warnings():
        warnings.simplefilter("error", errors.IsjWarning)
        for name in WARNINGS:
            with pytest.raises(getattr(errors, name)):
                warnings.warn("x", getattr(errors, name), stacklevel=1)


def test_design_error_is_invalid_parameter():
    from isj.design import Materials

    with pytest.raises(errors.IsjError, match="gap_e_pa"):
        Materials(gap_e_pa=-1.0)


def test_damaged_report_step_warns_with_a_category(tmp_path):
    from isj.reports.store import StepStore

    store = StepStore(tmp_path)
    store.put("s", "k" * 24, {"x": 1})
    (path,) = tmp_path.glob("s-*.json")
    path.write_text("{not json")
    with pytest.warns(errors.CorruptCacheEntry):
        assert store.get("s", "k" * 24) is None


@pytest.mark.parametrize(
    "argv, word",
    [
        (["lumped", "solve", "--gap-e", "-1"], "--gap-e"),
        (["fem", "solve", "--order", "7"], "--order"),
        (["sweep", "--fmin", "5000", "--fmax", "100"], "--fmin"),
    ],
)
def test_cli_bad_input_is_one_line_exit_2(capsys, argv, word):
    from isj.cli import main

    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and word in err and len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


def test_cli_bad_files_are_one_line_exit_2(capsys, tmp_path, monkeypatch):
    from isj.cli import main

    monkeypatch.chdir(tmp_path)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    for argv, word in [
        (["lumped", "solve", "--calibration", str(bad)], "bad.json"),  # CorruptCalibration
        (["report", "--set", "design.shoe_size_m=1", "--out", "r"], "shoe_size_m"),  # ConfigError
    ]:
        assert main(argv) == 2
        out, err = capsys.readouterr()
        assert out == "" and word in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.json"]


def test_cli_non_isj_value_error_is_not_hidden(monkeypatch):
    """A ValueError that is no IsjError is a bug, not bad input: main lets its traceback through."""
    from isj._cli import lumped
    from isj.cli import main

    def broken(args):
        raise ValueError("a bug")

    monkeypatch.setattr(lumped, "solve", broken)
    with pytest.raises(ValueError, match="a bug"):
        main(["lumped", "solve"])
