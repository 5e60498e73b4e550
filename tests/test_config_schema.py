"""Configuration files checked like input: the schema, key-by-key overrides of a loader's defaults, the
stream's config line, and the command line's messages (no traceback for a user's mistake)."""
from __future__ import annotations

import dataclasses
import io
import json
import warnings

import numpy as np
import pytest

from graphnav.cli import main
from graphnav.core.config import (
    IMU_GRADES,
    SCHEMA,
    ConfigOverrides,
    DvlSpec,
    ImuSpec,
    SensorConfig,
    describe,
    read_config,
)
from graphnav.core.errors import ConfigError
from graphnav.io.loaders import akit_default_config
from graphnav.io.paths import akit_dir
from graphnav.io.streamio import StreamReader
from graphnav.missions import load_mission
from graphnav.sim.simulate import default_config


def _write(tmp_path, data, name="config.json"):
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


# --- the schema -------------------------------------------------------------------------------------------
def test_schema_has_every_field_and_only_those():
    fields = {f.name for f in dataclasses.fields(SensorConfig)} - {"imu", "dvl"}
    fields |= {f"imu.{f.name}" for f in dataclasses.fields(ImuSpec)}
    fields |= {f"dvl.{f.name}" for f in dataclasses.fields(DvlSpec)}
    assert set(SCHEMA) == fields


def test_every_key_is_described_with_its_unit():
    suffix_units = {"_mps": "m/s", "_mps2": "m/s^2", "_hz": "Hz", "_s": "s", "_rad": "rad", "_pa": "Pa",
                    "_kgpm3": "kg/m^3"}
    for key, expected, meaning in describe():
        assert meaning, f"{key} has no docstring entry"
        unit = SCHEMA[key].unit
        if unit:
            by_name = any(key.endswith(s) and u == unit for s, u in suffix_units.items())
            assert unit in meaning or by_name, f"{key}: unit {unit} not in its docstring: {meaning}"
            assert f"({unit})" in expected


@pytest.mark.parametrize("config", [SensorConfig(), default_config(), akit_default_config(),
                                    *[SensorConfig(imu=dataclasses.replace(s)) for s in IMU_GRADES.values()]],
                         ids=["defaults", "simulator", "akit", *IMU_GRADES])
def test_shipped_configurations_pass_and_round_trip(config, tmp_path):
    path = tmp_path / "c.json"
    config.save(path)
    back = SensorConfig.load(path)
    assert json.dumps(back.to_dict()) == json.dumps(config.to_dict())


@pytest.mark.parametrize("data, message", [
    ([], "a configuration is a JSON object of keys"),
    ("\"x\"", "a configuration is a JSON object of keys"),
    ({"imu_rate_hz": -100}, "key 'imu_rate_hz': expected a number in (0, 100000] (Hz), got -100"),
    ({"imu": {"gyro_noise_density": -1e-5}},
     "key 'imu.gyro_noise_density': expected a number in (0, 1] (rad/s/sqrt(Hz)), got -1e-05"),
    ({"dvl": {"beam_noise_std": -0.04}}, "key 'dvl.beam_noise_std': expected a number in (0, 10] (m/s)"),
    ({"dvl": {"lever_arm_b": [0.1, 0.2]}}, "key 'dvl.lever_arm_b': expected a list of 3 numbers"),
    ({"imu_rate_hz": "100"}, "key 'imu_rate_hz': expected a number in (0, 100000] (Hz), got \"100\""),
    ({"earth_rotation": 1}, "key 'earth_rotation': expected true or false, got 1"),
    ({"imu_rate_hz": True}, "key 'imu_rate_hz': expected a number"),
    ({"imu_axis_signs": [1, -1, 0]}, "key 'imu_axis_signs': expected a list of 3 signs"),
    ({"dvl": {"C_d_b": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}}, "rows not orthonormal with determinant +1"),
    ({"dvl": "default"}, "key 'dvl': expected a JSON object of dvl keys"),
    ({"gravity_mps2": 98.1}, "key 'gravity_mps2': expected a number in [9.7, 9.9] (m/s^2), got 98.1"),
])
def test_bad_values_are_refused_in_the_users_terms(data, message, tmp_path):
    path = _write(tmp_path, data)
    with pytest.raises(ConfigError) as exc:
        read_config(path)
    assert str(exc.value).startswith(str(path) + ": ")
    assert message in str(exc.value)


def test_a_time_offset_of_days_or_a_unix_clock_is_a_configuration(tmp_path):
    """The prepare step puts a DVL or GT days away, or on a Unix clock beside a 0-based IMU, on the IMU clock, and
    calibrate writes the offset it found: the configuration takes it back (an hour was the limit, and calibrate
    refused to write a GT three days away); a non-finite offset is still refused."""
    path = _write(tmp_path, {"gt_time_offset_s": -259200.41, "dvl_time_offset_s": -1.7e9})
    config = read_config(path).over(SensorConfig())
    assert (config.gt_time_offset_s, config.dvl_time_offset_s) == (-259200.41, -1.7e9)
    config.save(tmp_path / "back.json")
    assert SensorConfig.load(tmp_path / "back.json").gt_time_offset_s == -259200.41
    with pytest.raises(ConfigError, match="key 'gt_time_offset_s'"):
        read_config(_write(tmp_path, '{"gt_time_offset_s": Infinity}', "inf.json"))


@pytest.mark.parametrize("data, suggestion", [
    ({"imu_rat_hz": 100}, "unknown key 'imu_rat_hz'; did you mean 'imu_rate_hz'?"),
    ({"imu": {"gyro_noise": 1e-5}}, "unknown key 'imu.gyro_noise'; did you mean 'imu.gyro_noise_density'?"),
    ({"lever_arm_b": [0, 0, 0]}, "unknown key 'lever_arm_b'; did you mean 'dvl.lever_arm_b'?"),
    ({"colour": "red"}, "unknown key 'colour'"),
])
def test_unknown_keys_get_a_did_you_mean(data, suggestion, tmp_path):
    with pytest.raises(ConfigError, match="did you mean" if "did" in suggestion else "unknown key") as exc:
        read_config(_write(tmp_path, data))
    assert suggestion in str(exc.value)


def test_unreadable_files_are_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="configuration file not found"):
        read_config(tmp_path / "missing.json")
    with pytest.raises(ConfigError, match=r"not JSON: .* line 1"):
        read_config(_write(tmp_path, "{imu_rate_hz: 100"))


# --- key by key over a loader's defaults ---------------------------------------------------------------------
def test_empty_config_is_no_config_on_the_simulated_mission(tmp_path):
    plain = load_mission(None, None, duration_s=20.0, seed=3)
    empty = load_mission(None, _write(tmp_path, {}), duration_s=20.0, seed=3)
    assert json.dumps(empty.config.to_dict()) == json.dumps(plain.config.to_dict())
    np.testing.assert_array_equal(empty.dvl.beams, plain.dvl.beams)


def test_partial_config_overrides_one_key_and_keeps_the_others(tmp_path):
    base = default_config()
    over = ConfigOverrides.parse({"dvl": {"beam_noise_std": 0.08}, "depth_noise_std": 0.2}).over(base)
    a, b = base.to_dict(), over.to_dict()
    assert b["dvl"].pop("beam_noise_std") == 0.08 and a["dvl"].pop("beam_noise_std") == 0.042
    assert b.pop("depth_noise_std") == 0.2
    a.pop("depth_noise_std")
    assert a == b
    # the base is not modified through the copy
    assert base.dvl.beam_noise_std == 0.042


def test_a_key_the_data_replaces_is_warned_about(tmp_path):
    # the simulator draws the IMU from its grade: a config's IMU noise is replaced, and the user is told
    path = _write(tmp_path, {"imu": {"gyro_noise_density": 1e-4}})
    with pytest.warns(RuntimeWarning, match=r"key 'imu.gyro_noise_density' = 0.0001 replaced by .* from the data"):
        m = load_mission(None, path, duration_s=10.0)
    assert any("imu.gyro_noise_density" in n for n in m.meta["streams"]["config"]["notes"])


@pytest.fixture(scope="module")
def akit1():
    root = akit_dir()
    folder = None if root is None else root / "Trajectory1"
    if folder is None or not folder.is_dir():
        pytest.skip("A-KIT Trajectory1 not found (graphnav.io.paths; set GRAPHNAV_DATA)")
    return folder


def test_empty_config_is_no_config_on_akit(akit1, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        plain = load_mission(akit1)
        empty = load_mission(akit1, _write(tmp_path, {}))
        partial = load_mission(akit1, _write(tmp_path, {"dvl": {"beam_noise_std": 0.05}}, "p.json"))
    assert json.dumps(empty.config.to_dict()) == json.dumps(plain.config.to_dict())
    np.testing.assert_array_equal(empty.dvl.t, plain.dvl.t)
    # a partial config keeps the recorded Phins' noise model and the offsets estimated at load time
    assert partial.config.imu.name == "phins-recorded" == plain.config.imu.name
    assert partial.config.dvl_time_offset_s == plain.config.dvl_time_offset_s != 0.0
    assert partial.config.dvl.beam_noise_std == 0.05


# --- the stream's config line --------------------------------------------------------------------------------
IMU_LINE = '{"type": "imu", "t": 0.0, "f_b": [0, 0, -9.8], "omega_b": [0, 0, 0]}'


def test_stream_config_first_line_is_checked_and_partial():
    reader = StreamReader(io.StringIO('{"type": "config", "config": {"imu_rate_hz": 200}}\n' + IMU_LINE + "\n"))
    assert len(list(reader)) == 1
    cfg = reader.config.over(SensorConfig())
    assert cfg.imu_rate_hz == 200 and cfg.dvl.beam_noise_std == SensorConfig().dvl.beam_noise_std


def test_stream_config_after_a_measurement_is_refused_with_its_line():
    text = IMU_LINE + "\n\n" + '{"type": "config", "config": {}}\n'
    with pytest.raises(ConfigError, match=r"<s>, line 3: a config record is accepted only as the first line of "
                                          r"the stream \(measurements start at line 1\)"):
        list(StreamReader(io.StringIO(text), "<s>"))
    twice = '{"type": "config", "config": {}}\n' * 2
    with pytest.raises(ConfigError, match=r"line 2: .* \(a config was already given at line 1\)"):
        list(StreamReader(io.StringIO(twice), "<s>"))


def test_stream_bad_config_stops_the_stream():
    text = '{"type": "config", "config": {"imu": {"gyro_noise_density": -1}}}\n' + IMU_LINE + "\n"
    with pytest.raises(ConfigError, match=r"<s>, line 1: key 'imu.gyro_noise_density'"):
        list(StreamReader(io.StringIO(text), "<s>"))


# --- the command line ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("data, message", [
    ([], "a configuration is a JSON object"),
    ({"imu_rate_hz": -100}, "key 'imu_rate_hz'"),
    ({"dvl": {"lever_arm_b": [0, 1]}}, "key 'dvl.lever_arm_b'"),
    ({"imu": {"gyro_noise_density": "low"}}, "key 'imu.gyro_noise_density'"),
])
def test_cli_refuses_bad_configs_before_any_work(data, message, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["smooth", "--duration", "20", "--config", str(_write(tmp_path, data)), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("graphnav smooth: error: ") and message in err and "Traceback" not in err
    assert not out.exists()


def test_cli_stream_late_config_line(tmp_path, capsys):
    stream = _write(tmp_path, IMU_LINE + "\n" + '{"type": "config", "config": {}}\n', "s.jsonl")
    assert main(["online", "--stream", str(stream), "--out", str(tmp_path / "o"), "--no-progress"]) == 1
    assert "line 2: a config record is accepted only as the first line" in capsys.readouterr().err


def test_cli_stream_warns_once_of_config_keys_a_stream_does_not_apply(tmp_path):
    """imu_axis_signs, the clock offsets and the file layouts are what the loaders and prepare do to a log's files; a
    live stream's records are body FRD on the IMU clock, and the Navigator applied none of them without a word. Now
    each configuration that sets them to something warns once, naming them; a stream's config line that holds the
    values that do nothing (as `graphnav simulate --stream` writes) says nothing."""
    nothing = {"imu_axis_signs": [1, 1, 1], "dvl_time_offset_s": 0.0, "gt_time_offset_s": 0.0, "csv_columns": {}}
    line = json.dumps({"type": "config", "config": nothing})
    stream = _write(tmp_path, line + "\n" + "\n".join([IMU_LINE] * 3) + "\n", "s.jsonl")
    config = _write(tmp_path, {"imu_axis_signs": [1, -1, -1], "dvl_time_offset_s": 0.5, "gt_time_offset_s": 0.0})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        main(["online", "--stream", str(stream), "--config", str(config), "--out", str(tmp_path / "o"),
              "--no-progress"])
    said = [str(w.message) for w in caught if "not applied to a live stream" in str(w.message)]
    assert said == [f"{config}: imu_axis_signs, dvl_time_offset_s not applied to a live stream: its records "
                    "are taken as body FRD on the IMU clock (graphnav online --schema); flip the IMU axes and add the "
                    "offsets where the stream is written (csv_columns and bag_topics describe files)"]


def test_an_all_zero_live_imu_record_is_said_to_be_filler_not_a_unit_to_declare():
    """A live IMU record of six zeros (a logger's filler) or a dead accelerometer beside a live gyro was skipped with
    the advice to declare the accelerometer's unit or to swap accelerometer and gyro: no unit makes gravity read 0."""
    from graphnav.core.screening import ACCEL_ZERO, IMU_FILLER
    filler = '{"type": "imu", "t": 0.01, "f_b": [0, 0, 0], "omega_b": [0, 0, 0]}'
    dead = '{"type": "imu", "t": 0.02, "f_b": [0, 0, 0], "omega_b": [0.01, 0, 0]}'
    with pytest.warns(RuntimeWarning) as said:
        reader = StreamReader(io.StringIO(filler + "\n" + dead + "\n"), "<s>")
        assert list(reader) == []
    text = " ".join(str(w.message) for w in said)
    assert IMU_FILLER in text and ACCEL_ZERO in text and "declare accel" not in text, text
