"""Cat measurements (isj/data/cat_measurements.json) and isj.measurements.compare."""

import copy
import json
import math

import numpy as np
import pytest

from isj.errors import InvalidParameter
from isj.measurements import (
    QUANTITY_UNITS,
    MeasuredSeries,
    compare,
    displacement_to_velocity,
    load_cat_catalogue,
    load_cat_measurements,
    velocity_to_displacement,
)

SERIES = load_cat_measurements()


def _synthetic(**changes) -> MeasuredSeries:
    """A displacement series with phases, made up for the tests only (not data)."""
    base = dict(
        name="test_displacement",
        quantity="stapes_displacement_per_ear_canal_pressure",
        unit="m/Pa",
        freq_hz=np.array([100.0, 300.0, 1000.0, 3000.0, 10000.0]),
        magnitude=np.array([3e-8, 3e-8, 2e-8, 2e-9, 1e-10]),
        phase_deg=np.array([0.0, -10.0, -60.0, -150.0, -250.0]),
        conditions={"animal": "test"},
        source="made up for a test",
        digitised=False,
    )
    base.update(changes)
    return MeasuredSeries(**base)


# -- the data file --------------------------------------------------------------


def test_file_loads_and_has_series():
    assert SERIES, "the data file holds no series"
    names = [s.name for s in SERIES]
    assert len(names) == len(set(names))


@pytest.mark.parametrize("s", SERIES, ids=lambda s: s.name)
def test_series_is_consistent(s):
    assert s.unit == QUANTITY_UNITS[s.quantity]
    n = s.freq_hz.size
    assert n >= 1 and s.magnitude.shape == (n,)
    assert np.all(s.freq_hz > 0) and np.all(np.diff(s.freq_hz) > 0)
    assert np.all(s.magnitude > 0)
    for extra in (s.phase_deg, s.magnitude_min, s.magnitude_max):
        assert extra is None or extra.shape == (n,)
    if s.magnitude_min is not None:
        assert np.all(s.magnitude_min <= s.magnitude)
    if s.magnitude_max is not None:
        assert np.all(s.magnitude_max >= s.magnitude)
    assert s.source.strip(), "every series names its source"
    assert s.conditions, "every series records its conditions"
    assert s.digitised == (s.origin == "digitised")
    if s.origin == "from_text":
        assert s.evidence.strip(), "values from text quote the source"
    assert s.published.get("unit"), "the published unit is recorded"


def test_published_values_convert_to_si():
    """Each series' SI magnitude is its published value times the stated conversion."""
    si_per_published = {"dyn*s/cm^5": 1e5}
    for s in SERIES:
        pub = s.published
        if pub["unit"] in si_per_published:
            assert np.allclose(s.magnitude, np.asarray(pub["magnitude"]) * si_per_published[pub["unit"]])
        elif pub["unit"].startswith("dB"):
            assert np.allclose(s.magnitude, 10 ** (np.asarray(pub["magnitude"]) / 20), rtol=1e-6)
            for key in ("magnitude_min", "magnitude_max"):
                if key in pub:
                    assert np.allclose(getattr(s, key), 10 ** (np.asarray(pub[key]) / 20), rtol=1e-6)


def test_catalogue_states_the_rule_and_sources():
    cat = load_cat_catalogue()
    assert "fitted" in cat["rule"]
    for entry in cat["statements"] + cat["lumped_element_fits"]:
        assert entry["source"]["citation"].strip()
        assert entry["evidence"].strip()


# -- compare --------------------------------------------------------------------


@pytest.mark.parametrize("s", SERIES, ids=lambda s: s.name)
def test_data_against_itself_is_0_db(s):
    phases = s.phase_deg if s.phase_deg is not None else np.zeros_like(s.magnitude)
    values = s.magnitude * np.exp(1j * np.radians(phases))
    if s.freq_hz.size == 1:  # one point: give the model a grid around it
        f = s.freq_hz[0] * np.array([0.5, 1.0, 2.0])
        values = np.full(3, values[0])
    else:
        f = s.freq_hz
    r = compare(s, f, values)
    assert r["max_abs_db"] == pytest.approx(0.0, abs=1e-9)
    assert r["median_abs_db"] == pytest.approx(0.0, abs=1e-9)
    assert r["bands_3db"] == [(float(s.freq_hz[0]), float(s.freq_hz[-1]))]
    assert r["skipped_freq_hz"].size == 0


@pytest.mark.parametrize("offset_db", [6.0, -6.0])
def test_exact_6_db_offset_is_reported_as_6_db(offset_db):
    s = _synthetic()
    f = np.union1d(np.geomspace(50.0, 20000.0, 200), s.freq_hz)  # a model grid that holds the data's points
    model = np.exp(np.interp(np.log(f), np.log(s.freq_hz), np.log(s.magnitude))) * 10 ** (offset_db / 20)
    r = compare(s, f, model)
    assert np.allclose(r["deviation_db"], offset_db)
    assert r["max_abs_db"] == pytest.approx(6.0, abs=1e-9)
    assert r["median_abs_db"] == pytest.approx(6.0, abs=1e-9)
    assert r["bands_6db"] == [(100.0, 10000.0)]  # exactly 6 dB counts as within 6 dB
    assert r["bands_3db"] == []


def test_bands_are_runs_of_measured_points():
    s = _synthetic()
    gains_db = np.array([1.0, 2.0, 5.0, 1.0, 8.0])
    r = compare(s, s.freq_hz, s.magnitude * 10 ** (gains_db / 20))
    assert r["bands_3db"] == [(100.0, 300.0), (3000.0, 3000.0)]
    assert r["bands_6db"] == [(100.0, 3000.0)]
    assert r["max_abs_db"] == pytest.approx(8.0)
    assert r["median_abs_db"] == pytest.approx(2.0)


def test_log_log_interpolation():
    """A model that is a power law between its two points is met exactly in between."""
    s = _synthetic(freq_hz=np.array([1000.0]), magnitude=np.array([1e-8]), phase_deg=None)
    f = np.array([500.0, 2000.0])
    model = 1e-8 * (f / 1000.0) ** -2  # -12 dB/octave through 1e-8 m/Pa at 1 kHz
    r = compare(s, f, model)
    assert r["deviation_db"][0] == pytest.approx(0.0, abs=1e-9)


def test_points_outside_the_model_band_are_skipped():
    s = _synthetic()
    r = compare(s, [250.0, 4000.0], s.magnitude[[1, 3]] * np.array([1.5, 0.4]))
    assert list(r["freq_hz"]) == [300.0, 1000.0, 3000.0]
    assert list(r["skipped_freq_hz"]) == [100.0, 10000.0]
    with pytest.raises(InvalidParameter):
        compare(s, [20000.0, 30000.0], [1e-9, 1e-9])


def test_stated_range_counts_as_zero():
    s = _synthetic(
        magnitude_min=_synthetic().magnitude / 2, magnitude_max=_synthetic().magnitude * 2, phase_deg=None
    )
    r = compare(s, s.freq_hz, s.magnitude * np.array([1.0, 1.9, 0.6, 4.0, 0.25]))
    expected = [0.0, 0.0, 0.0, 20 * math.log10(2.0), -20 * math.log10(2.0)]
    assert np.allclose(r["range_deviation_db"], expected)


def test_phase_deviation():
    s = _synthetic()
    model = s.magnitude * np.exp(1j * np.radians(s.phase_deg - 20.0))
    r = compare(s, s.freq_hz, model)
    assert np.allclose(r["phase_deviation_deg"], -20.0)
    assert compare(s, s.freq_hz, np.abs(model))["phase_deviation_deg"] is None  # magnitude-only model


# -- displacement and velocity --------------------------------------------------


def test_displacement_to_velocity_at_one_frequency():
    f, x = 1000.0, 2.5e-8  # 25 nm/Pa at 1 kHz
    v = displacement_to_velocity(f, x)
    assert abs(v) == pytest.approx(2 * math.pi * 1000.0 * 2.5e-8)  # 1.571e-4 m/s/Pa
    assert math.degrees(np.angle(v)) == pytest.approx(90.0)
    assert velocity_to_displacement(f, v) == pytest.approx(x)
    with pytest.raises(InvalidParameter):
        velocity_to_displacement(0.0, 1.0)


def test_series_conversion_and_velocity_model_against_displacement_data():
    s = _synthetic()
    sv = s.as_velocity()
    assert sv.unit == "m/s/Pa" and sv.quantity == "stapes_velocity_per_ear_canal_pressure"
    assert np.allclose(sv.magnitude, 2 * np.pi * s.freq_hz * s.magnitude)
    assert np.allclose(sv.phase_deg, s.phase_deg + 90.0)
    back = sv.as_displacement()
    assert np.allclose(back.magnitude, s.magnitude) and back.unit == "m/Pa"
    # a model's H_V (m/s/Pa) that is exactly the data's velocity: 0 dB and 0 degrees
    h_v = sv.magnitude * np.exp(1j * np.radians(sv.phase_deg))
    r = compare(s, s.freq_hz, h_v, model_unit="m/s/Pa")
    assert r["max_abs_db"] == pytest.approx(0.0, abs=1e-9)
    assert np.allclose(r["phase_deviation_deg"], 0.0, atol=1e-9)
    with pytest.raises(InvalidParameter):
        compare(s, s.freq_hz, h_v, model_unit="Pa/Pa")
    with pytest.raises(InvalidParameter):
        SERIES[0].as_velocity()  # an impedance is neither


# -- the loader refuses broken files ---------------------------------------------


def _write(tmp_path, data):
    p = tmp_path / "cat.json"
    p.write_text(json.dumps(data), encoding="utf-8")
    return p


@pytest.mark.parametrize(
    "breakage",
    [
        lambda e: e.update(unit="m/Pa"),  # not the quantity's SI unit
        lambda e: e.update(magnitude=e["magnitude"][:-1] or [1.0, 2.0]),  # length mismatch
        lambda e: e.update(source={"citation": " "}),  # no source
        lambda e: e.update(digitised=True),  # digitised but origin says text
        lambda e: e.update(evidence=""),  # from text without the sentence
        lambda e: e.update(freq_hz=list(reversed(e["freq_hz"])) if len(e["freq_hz"]) > 1 else [-1.0]),
        lambda e: e.update(quantity="umbo_mood"),
    ],
)
def test_loader_refuses_broken_series(tmp_path, breakage):
    data = load_cat_catalogue()
    entry = copy.deepcopy(data["series"][0])
    breakage(entry)
    data["series"] = [entry]
    with pytest.raises(InvalidParameter):
        load_cat_measurements(_write(tmp_path, data))


def test_loader_refuses_duplicate_names_and_bad_json(tmp_path):
    data = load_cat_catalogue()
    data["series"] = [data["series"][0], data["series"][0]]
    with pytest.raises(InvalidParameter):
        load_cat_measurements(_write(tmp_path, data))
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(InvalidParameter):
        load_cat_measurements(bad)
