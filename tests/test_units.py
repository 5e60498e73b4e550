"""Units from the data (graphnav.io.units): stamps in ms/us/ns, gyro in deg/s, accelerometer in g, swapped IMU
blocks, DVL in mm/s -- converted with a warning and a note, or refused naming the field; never a false detection
on the ten shared A-KIT trajectories."""
from __future__ import annotations

import dataclasses
import shutil
import warnings

import numpy as np
import pytest

from graphnav.core.errors import DataError
from graphnav.io.loaders import AKIT_COLUMNS, akit_files, list_akit, read_csv
from graphnav.io.units import (
    check_units,
    dvl_speed_scale,
    gyro_tilt_scale,
    imu_units,
    stamps_in_seconds,
    time_scale,
)
from graphnav.missions import load_akit
from graphnav.sim.simulate import simulate_mission


@pytest.fixture(scope="module")
def sim():
    return simulate_mission(duration_s=60.0, seed=3)


def _raw(folder):
    files = akit_files(folder)
    imu = read_csv(files["IMU"], AKIT_COLUMNS["IMU"])
    dvl = read_csv(files["DVL"], AKIT_COLUMNS["DVL"], nan_ok=AKIT_COLUMNS["DVL"][1:])
    return imu, dvl


def test_no_false_detection_on_the_shared_trajectories(akit_dir):
    folders = list_akit(akit_dir)
    assert len(folders) >= 1
    for folder in folders:
        imu, dvl = _raw(folder)
        with warnings.catch_warnings():
            warnings.simplefilter("error")        # any conversion warns: none may happen
            f_b, omega_b = imu_units(imu[:, 0], imu[:, 1:4], imu[:, 4:7], folder.name)
            assert time_scale(imu[:, 0], "imu", folder.name, 100.0) == (1.0, "s")
            assert time_scale(dvl[:, 0], "dvl", folder.name, 1.0) == (1.0, "s")
            assert dvl_speed_scale(None, dvl[:, 1:4], folder.name)[0] == 1.0
        assert f_b is not None and np.array_equal(omega_b, imu[:, 4:7])
        # the tilt kinematics tell the units apart on every trajectory, with a wide margin either side of the deg/s
        # threshold
        k_rad, _ = gyro_tilt_scale(imu[:, 0], imu[:, 1:4], imu[:, 4:7])
        k_deg, _ = gyro_tilt_scale(imu[:, 0], imu[:, 1:4], np.degrees(imu[:, 4:7]))
        assert k_rad > 0.3 and k_deg < 0.03, (folder.name, k_rad, k_deg)


def _copy(src, dst_root, imu_transform=None, dvl_transform=None):
    dst = dst_root / src.name
    dst.mkdir()
    files = akit_files(src)
    imu, dvl = _raw(src)
    for arr, kind, transform in ((imu, "IMU", imu_transform), (dvl, "DVL", dvl_transform)):
        if transform is not None:
            arr = transform(arr.copy())
        np.savetxt(dst / files[kind].name, arr, delimiter=",", fmt="%.12g", comments="",
                   header=",".join(AKIT_COLUMNS[kind]))
    shutil.copy(files["GT"], dst / files["GT"].name)
    return dst


def _load(folder):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_akit(folder, imu_axis_signs=(1, -1, 1))
    return m, [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]


def _gyro_deg(a):
    a[:, 4:7] = np.degrees(a[:, 4:7])
    return a


def _accel_g(a):
    a[:, 1:4] /= 9.80665
    return a


def _swap(a):
    a[:, 1:7] = a[:, [4, 5, 6, 1, 2, 3]]
    return a


def _stamps_ms(a):
    a[:, 0] *= 1e3
    return a


def _dvl_mm(a):
    a[:, 1:4] *= 1e3
    return a


@pytest.mark.parametrize("transform, dvl_transform, stream, words", [
    (_gyro_deg, None, "imu", "deg/s"),
    (_accel_g, None, "imu", "as g"),
    (_swap, None, "imu", "swapped"),
    (_stamps_ms, None, "imu", "stamps read as ms"),
    (None, _stamps_ms, "dvl", "stamps read as ms"),
    (None, _dvl_mm, "dvl", "mm/s"),
])
def test_akit_loader_converts_back_with_a_note(akit_dir, tmp_path, transform, dvl_transform, stream, words):
    src = akit_dir / "Trajectory5"
    ref, _ = _load(src)
    m, caught = _load(_copy(src, tmp_path, transform, dvl_transform))
    assert any(words in w for w in caught), caught
    assert any(words in n for n in m.meta["streams"][stream]["notes"])
    np.testing.assert_allclose(m.imu.t, ref.imu.t, atol=1e-9)
    np.testing.assert_allclose(m.imu.f_b, ref.imu.f_b, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(m.imu.omega_b, ref.imu.omega_b, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(m.dvl.v_b, ref.dvl.v_b, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(m.dvl.t, ref.dvl.t, atol=0.1)    # the DVL offset is re-estimated on the copy


def test_quiet_gyro_in_deg_per_s_found_by_the_tilt_kinematics(akit_dir):
    imu, _ = _raw(akit_dir / "Trajectory13")
    # a vehicle quieter than any of the ten: deg/s rates under both magnitude thresholds
    omega = 0.4 * np.degrees(imu[:, 4:7])
    assert np.median(np.linalg.norm(omega, axis=1)) < 0.3
    with pytest.warns(RuntimeWarning, match="tilt kinematics"):
        _, out = imu_units(imu[:, 0], imu[:, 1:4], omega, "x")
    np.testing.assert_allclose(out, np.radians(omega))


def test_entry_point_on_plain_streams_records_notes(sim):
    imu = sim.imu
    streams = {"imu": type(imu)(imu.t * 1e6, imu.f_b / 9.80665, np.degrees(imu.omega_b), "bag:/imu"),
               "dvl": type(sim.dvl)(sim.dvl.t, sim.dvl.beams * 1e3, sim.dvl.valid, None, "bag:/dvl"),
               "depth": sim.depth}
    meta: dict = {}
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        out = check_units(streams, sim.config, meta)
    np.testing.assert_allclose(out["imu"].t, imu.t, atol=1e-9)
    np.testing.assert_allclose(out["imu"].omega_b, imu.omega_b, atol=1e-12)
    np.testing.assert_allclose(out["imu"].f_b, imu.f_b * sim.config.gravity_mps2 / 9.80665, rtol=1e-9)
    np.testing.assert_allclose(out["dvl"].beams[sim.dvl.valid], sim.dvl.beams[sim.dvl.valid], atol=1e-12)
    assert out["depth"] is sim.depth
    assert len(meta["streams"]["imu"]["notes"]) == 3 and len(meta["streams"]["dvl"]["notes"]) == 1
    # a mission in SI passes untouched
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        same = check_units(sim)
    assert same.imu is sim.imu and same.dvl is sim.dvl


def test_refusals_name_the_field():
    t = np.arange(0.0, 100.0, 0.01)
    bad = t.copy()
    bad[500] = 1e300
    bad[501:] += 1e300
    with pytest.raises(DataError, match=r"index 500.*more than a year|more than a year.*index 500"):
        stamps_in_seconds(bad, "imu", "imu.csv")
    centuries = t * 3e8          # 100 s of samples spread over ~950 years, declared in seconds
    with pytest.raises(DataError, match="field 't'.*more than a year"):
        stamps_in_seconds(centuries, "imu", "imu.csv", declared="s")
    with pytest.warns(RuntimeWarning, match="stamps read as ns"):    # undeclared: a 3 ms step in ns
        np.testing.assert_allclose(stamps_in_seconds(centuries, "imu", "imu.csv"), centuries * 1e-9)
    rng = np.random.default_rng(0)
    f = rng.normal(0, 0.1, (len(t), 3)) + [0, 0, -9.8]
    w = rng.normal(0, 0.01, (len(t), 3))
    with pytest.raises(DataError, match="f_b.*not gravity"):
        imu_units(t, f * 30, w, "imu.csv")
    with pytest.raises(DataError, match="omega_b"):
        imu_units(t, f, np.degrees(w * 100), "imu.csv", declared={"gyro": "rad/s"})
    with pytest.raises(DataError, match="declare the velocity unit"):
        dvl_speed_scale(None, np.full((10, 3), 30.0), "dvl.csv")
    # the advice ends the message once, with no example bolted on after an A-KIT fix's own brackets
    with pytest.raises(DataError, match=r"moving vehicle \(500-10000\): declare the velocity unit$"):
        dvl_speed_scale(None, np.full((10, 3), 3e4), "dvl.csv")


def test_stream_reader_refuses_a_loggers_all_zero_imu_row_as_filler_not_as_a_unit_mix_up():
    """A live stream (``graphnav online --stream``) with IMU records of six zeros, a logger's filler, stamp kept or
    zeroed too: each was refused as '|f_b| 0 m/s^2 is not gravity plus vehicle accelerations (g? declare accel in a
    units record; ~0 with |omega_b| ~9.8: accelerometer and gyro swapped)', advice no unit or swap follows. They are
    refused as the filler they are, as the loaders refuse them; a sample in g is still told to declare it."""
    import json

    from graphnav.io.streamio import StreamReader
    lines = [json.dumps(r) for r in (
        {"type": "imu", "t": 1.0, "f_b": [0.0, 0.0, -9.8], "omega_b": [0.0, 0.0, 0.01]},
        {"type": "imu", "t": 1.01, "f_b": [0.0, 0.0, 0.0], "omega_b": [0.0, 0.0, 0.0]},
        {"type": "imu", "t": 0.0, "f_b": [0.0, -0.0, 0.0], "omega_b": [0.0, 0.0, 0.0]},
        {"type": "imu", "t": 1.03, "f_b": [0.0, 0.0, -1.0], "omega_b": [0.0, 0.0, 0.6]},
    )]
    reader = StreamReader(lines, "test")
    with pytest.warns(RuntimeWarning) as caught:
        recs = list(reader)
    said = [str(w.message) for w in caught]
    for line in (2, 3):
        assert any(f"line {line}: imu sample refused: all-zero IMU row (a logger's filler: zero specific force is "
                   "impossible under gravity); the gap it leaves is bridged" in w and "declare" not in w for w in said)
    assert any("line 4: imu sample refused" in w and "declare accel" in w for w in said)
    assert reader.refused == {"imu": 3} and [r["_line"] for r in recs] == [1]


def test_stream_reader_converts_declared_units_and_refuses_implausible_samples():
    import json

    from graphnav.core.errors import ConfigError
    from graphnav.io.streamio import StreamReader
    lines = [json.dumps(r) for r in (
        {"type": "imu", "t": 1.0, "f_b": [0.0, 0.0, -9.8], "omega_b": [0.0, 0.0, 0.01]},
        {"type": "imu", "t": 1.01, "f_b": [0.0, 0.0, -1.0], "omega_b": [0.0, 0.0, 0.6]},     # g: refused
        {"type": "units", "time": "ms", "accel": "g", "gyro": "deg/s", "velocity": "mm/s"},
        {"type": "imu", "t": 1020.0, "f_b": [0.0, 0.0, -1.0], "omega_b": [0.0, 0.0, 0.6]},
        {"type": "dvl", "t": 1030.0, "beams": [700.0, None, -650.0, 120.0]},
        {"type": "imu", "t": 1.7e15, "f_b": [0.0, 0.0, -1.0], "omega_b": [0.0, 0.0, 0.6]},    # us in ms: refused
        {"type": "units", "gyro": "rpm"},                                                   # unknown: bad line
    )]
    reader = StreamReader(lines, "test")
    with pytest.warns(RuntimeWarning) as caught:
        recs = list(reader)
    text = " ".join(str(w.message) for w in caught)
    assert "line 2: imu sample refused" in text and "declare accel" in text
    assert "line 6: imu sample refused" in text and "not seconds" in text
    assert "line 7: unknown unit gyro='rpm'" in text
    assert reader.refused == {"imu": 2} and reader.n_bad == 3
    assert [r["_line"] for r in recs] == [1, 4, 5]
    assert recs[1]["t"] == pytest.approx(1.02)
    np.testing.assert_allclose(recs[1]["f_b"], [0, 0, -9.80665])
    np.testing.assert_allclose(recs[1]["omega_b"], [0, 0, np.radians(0.6)])
    assert recs[2]["beams"][0] == pytest.approx(0.7) and recs[2]["beams"][1] is None
    with pytest.raises(ConfigError, match="unknown unit"):
        StreamReader([], "x", units={"time": "minutes"})


def test_imu_in_milliseconds_is_refused_before_bridging(sim):
    from graphnav.core.mission import ImuData
    imu = ImuData(sim.imu.t * 1e3, sim.imu.f_b, sim.imu.omega_b, "imu")     # a 10 ms step read as 10 s
    with pytest.raises(DataError, match="are the stamps in seconds"):
        imu.bridge_gaps(sim.config.imu_rate_hz)


def test_a_corrupt_stamp_in_the_middle_is_named():
    t = np.arange(0.0, 100.0, 0.01)
    t[4000] = 1e300
    with pytest.raises(DataError, match="index 4000"):
        stamps_in_seconds(t, "imu", "imu.csv")


# --- the reference (ground truth) --------------------------------------------------------------------------------
GT_COLUMNS = ("Latitude [rad]", "Longitude [rad]", "V North [m/s]", "V East [m/s]")
ATTITUDE_COLUMNS = ("Roll [rad]", "Pitch [rad]", "Yaw [rad]")


def _reference(seconds=120.0):
    """A vehicle near 0 N 0 E heading north at 1.5 m/s, yawing +-2.9 deg and rising and sinking +-1 m around 20 m:
    in degrees its angles stay inside the radian range, so only the rates can tell. Returns the 1 Hz reference
    (t, lat, lon, depth, v_n, euler) and the 100 Hz gyro (t_imu, omega_b), radians and SI."""
    t_imu = np.arange(0.0, seconds, 0.01)
    yaw = 0.05 * np.sin(0.3 * t_imu)
    omega_b = np.zeros((t_imu.size, 3))
    omega_b[:, 2] = 0.015 * np.cos(0.3 * t_imu)
    v_n = np.column_stack([1.5 * np.cos(yaw), 1.5 * np.sin(yaw), 0.1 * np.cos(0.1 * t_imu)])
    p_n = np.concatenate([np.zeros((1, 3)), np.cumsum((v_n[1:] + v_n[:-1]) / 2 * 0.01, axis=0)])
    every = slice(0, None, 100)
    t = t_imu[every]
    lat, lon = 0.005 + p_n[every, 0] / 6378137.0, 0.004 + p_n[every, 1] / 6378137.0
    euler = np.column_stack([np.zeros(t.size), np.zeros(t.size), yaw[every]])
    return t, lat, lon, 20.0 + p_n[every, 2], v_n[every], euler, t_imu, omega_b


def test_a_reference_in_radians_and_si_is_untouched():
    from graphnav.io.units import reference_attitude_units, reference_depth, reference_latlon_units
    t, lat, lon, depth, v_n, euler, t_imu, omega_b = _reference()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert reference_attitude_units(t, euler, t_imu, omega_b, "GT.csv", ATTITUDE_COLUMNS) is euler
        out = reference_latlon_units(t, lat, lon, v_n, "GT.csv", GT_COLUMNS)
        assert out[0] is lat and out[1] is lon
        assert reference_depth(t, depth, v_n[:, 2], "GT.csv", ("Altitude [m]", "V Down [m/s]"), None,
                               (-10.0, 6000.0)) is depth
        # an unwrapped yaw (beyond 2 pi) that turns with the gyro is radians too
        unwrapped = euler + [0.0, 0.0, 4 * np.pi]
        assert reference_attitude_units(t, unwrapped, t_imu, omega_b, "GT.csv", ATTITUDE_COLUMNS) is unwrapped


def test_reference_angles_in_degrees_inside_the_radian_range_are_told_by_their_rates():
    """Latitude 0.29 deg, longitude 0.23 deg, yaw +-2.9 deg: radians by their range; the positions move 57x as far
    as the reference's velocity says and the attitude turns 57x as fast as the gyro."""
    from graphnav.io.units import reference_attitude_units, reference_latlon_units
    t, lat, lon, _, v_n, euler, t_imu, omega_b = _reference()
    assert np.max(np.abs(np.degrees(euler))) < np.pi and np.degrees(lat).max() < np.pi / 2
    meta: dict = {}
    with pytest.warns(RuntimeWarning, match=r"GT.csv: 'Latitude \[rad\]', 'Longitude \[rad\]' read as degrees .* "
                                            r"move 5\d.\dx as far as the velocity"):
        lat_r, lon_r = reference_latlon_units(t, np.degrees(lat), np.degrees(lon), v_n, "GT.csv", GT_COLUMNS, meta)
    np.testing.assert_allclose([lat_r, lon_r], [lat, lon], rtol=1e-12)
    with pytest.warns(RuntimeWarning, match=r"GT.csv: attitude columns 'Roll \[rad\]', 'Pitch \[rad\]', 'Yaw \[rad\]' "
                                            r"read as degrees .* turns 5\d.\dx as fast as the gyro"):
        out = reference_attitude_units(t, np.degrees(euler), t_imu, omega_b, "GT.csv", ATTITUDE_COLUMNS, meta)
    np.testing.assert_allclose(out, euler, atol=1e-15)
    assert len(meta["streams"]["gt"]["notes"]) == 2
    # a declared unit is never converted: rates the other unit fits are an error naming the columns (it was a
    # warning, and the wrong angles were used: a radian attitude declared 'deg' smoothed to 17x the clean VRMSE)
    degrees = np.degrees(euler)
    with pytest.raises(DataError, match=r"GT.csv, field 'Roll \[rad\]/Pitch \[rad\]/Yaw \[rad\]': attitude columns "
                                        r".* declared 'rad' turn 5\d.\dx as fast as the gyro, and (0.9\d*|1.0\d*)x read in the "
                                        r"other unit: the declared angle_unit \(or the gyro's unit\) is wrong"):
        reference_attitude_units(t, degrees, t_imu, omega_b, "GT.csv", ATTITUDE_COLUMNS, {}, declared="rad")
    with pytest.raises(DataError, match=r"declared 'deg' turn 0.017\dx as fast as the gyro"):
        reference_attitude_units(t, np.radians(euler), t_imu, omega_b, "GT.csv", ATTITUDE_COLUMNS, {},
                                 declared="deg")
    # positions that move with the velocity in neither unit are refused, naming the columns
    with pytest.raises(DataError, match=r"field 'Latitude \[rad\]/Longitude \[rad\]': the positions move 5x"):
        reference_latlon_units(t, lat * 5, lon * 5, v_n, "GT.csv", GT_COLUMNS)
    with pytest.raises(DataError, match=r"the positions \(read as degrees\) move 0.26\dx"):
        reference_latlon_units(t, lat * 15, lon * 15, v_n, "GT.csv", GT_COLUMNS)


def test_reference_angles_beyond_radians_without_a_gyro_are_degrees():
    from graphnav.io.units import reference_attitude_units
    t, _, _, _, _, euler, _, _ = _reference()
    tilted = np.degrees(euler + [0.05, 0.1, 1.0])            # pitch 5.7 "rad": beyond radians
    with pytest.warns(RuntimeWarning, match=r"\|pitch\| up to 5.73.*beyond radians"):
        np.testing.assert_allclose(reference_attitude_units(t, tilted, None, None, "GT.csv", ATTITUDE_COLUMNS),
                                   np.radians(tilted))
    with pytest.raises(DataError, match="neither radians nor degrees"):
        reference_attitude_units(t, tilted * 100, None, None, "GT.csv", ATTITUDE_COLUMNS)


def test_a_noisy_reference_attitude_in_radians_is_kept_and_an_unwrapped_yaw_too():
    """Attitude noise of 0.01-0.02 rad over a gyro turning 2 mrad/s: the attitude turns 11-22x as fast as the gyro
    (above the 7.6 split), but read as degrees it would turn 0.19-0.38x as fast: radians kept, with a warning (it
    used to be converted to degrees, yaw 1.0 -> 0.0175, and a declared 'rad' was refused). A yaw of 7 rad (unwrapped)
    with a gyro too quiet to tell and roll/pitch in the radian range: kept, with a warning (it used to be converted)."""
    from graphnav.io.units import attitude_rate_ratio, reference_attitude_units
    from graphnav.core.rotations import euler_to_C_b_n
    rng = np.random.default_rng(0)
    t_imu, t = np.arange(0.0, 600.0, 0.01), np.arange(0.0, 600.0, 1.0)
    omega_b = rng.normal(0.0, 5e-4, (t_imu.size, 3))
    omega_b[:, 2] += 2e-3
    for noise in (0.01, 0.02):
        euler = rng.normal(0.0, noise, (t.size, 3)) + np.column_stack([0 * t, 0 * t, 1.0 + 2e-3 * t])
        assert attitude_rate_ratio(t, euler_to_C_b_n(*euler.T), t_imu, omega_b)[0] > 10.0
        with pytest.warns(RuntimeWarning, match=r"gt.csv: attitude columns 'r', 'p', 'y' kept as radians, but the "
                                                r"attitude turns .*read as degrees it would turn 0.\d+x"):
            assert reference_attitude_units(t, euler, t_imu, omega_b, "gt.csv", ("r", "p", "y")) is euler
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert reference_attitude_units(t, euler, t_imu, omega_b, "gt.csv", ("r", "p", "y"), declared="rad"
                                            ) is euler
        assert any("kept in the declared unit 'rad'" in str(w.message) for w in caught)
    quiet = rng.normal(0.0, 2e-5, (t_imu.size, 3))
    unwrapped = np.column_stack([0 * t, 0 * t, 7.0 + rng.normal(0.0, 1e-4, t.size)])
    with pytest.warns(RuntimeWarning, match=r"kept as radians: .*\|yaw\| up to 7 \(an unwrapped yaw"):
        assert reference_attitude_units(t, unwrapped, t_imu, quiet, "gt.csv", ("r", "p", "y")) is unwrapped


def test_a_reference_in_radians_whose_noise_matches_the_gyro_read_as_degrees_stays_radians():
    """Attitude noise of 0.03-0.1 rad over a gyro turning 2 mrad/s: read as degrees the noise turns 0.6-1.9x as fast
    as the gyro, as a reference in degrees would (it was converted: yaw 1.0 -> 0.0175, a silent wrong reference); its
    turn does not follow the gyro's interval by interval, so radians are kept, with a warning and a count. A clean
    reference in degrees on the same steady turn (no correlation to tell by) follows it and is still converted."""
    from graphnav.io.units import NOISY_TURN_DOUBT, reference_attitude_units
    rng = np.random.default_rng(0)
    t_imu, t = np.arange(0.0, 600.0, 0.01), np.arange(0.0, 600.0, 1.0)
    omega_b = rng.normal(0.0, 5e-4, (t_imu.size, 3))
    omega_b[:, 2] += 2e-3
    steady = np.column_stack([0 * t, 0 * t, 1.0 + 2e-3 * t])
    for noise in (0.03, 0.05, 0.1):
        euler = rng.normal(0.0, noise, (t.size, 3)) + steady
        meta: dict = {}
        with pytest.warns(RuntimeWarning, match=r"gt.csv: attitude columns 'r', 'p', 'y' kept as radians \(the range "
                                                r"allows them\).*does not follow the gyro's interval by interval"):
            assert reference_attitude_units(t, euler, t_imu, omega_b, "gt.csv", ("r", "p", "y"), meta) is euler
        assert meta["streams"]["gt"]["doubted"] == {NOISY_TURN_DOUBT: t.size}
    with pytest.warns(RuntimeWarning, match="read as degrees and converted"):
        out = reference_attitude_units(t, np.degrees(steady), t_imu, omega_b, "gt.csv", ("r", "p", "y"))
    np.testing.assert_allclose(out, steady, atol=1e-12)
    # the same at 0.01 deg resolution, its gyro biased 103 deg/h (a bias offsets every interval alike: not a misfit)
    with pytest.warns(RuntimeWarning, match="read as degrees and converted"):
        out = reference_attitude_units(t, np.round(np.degrees(steady), 2), t_imu, omega_b + 5e-4, "gt.csv",
                                       ("r", "p", "y"))
    np.testing.assert_allclose(out, steady, atol=1e-3)


def test_a_flipped_reference_depth_is_turned_back_or_refused_naming_the_column():
    from graphnav.io.units import reference_depth
    t, _, _, depth, v_n, _, _, _ = _reference()
    fields = ("Altitude [m]", "V Down [m/s]")
    # the vehicle 19-21 m above the sea, rising when its velocity says it sinks: the sign is flipped
    with pytest.warns(RuntimeWarning, match=r"GT.csv: column 'Altitude \[m\]' read with its sign flipped and turned "
                                            r"back: depth -21 to -19 m is outside \[-10, 6000\] m"):
        np.testing.assert_allclose(reference_depth(t, -depth, v_n[:, 2], "GT.csv", fields, None, (-10.0, 6000.0)),
                                   depth)
    # level: nothing tells a flipped sign from a height above the ellipsoid; refused, naming line and column
    level = np.full(t.size, -20.0)
    with pytest.raises(DataError, match=r"GT.csv, line 2, field 'Altitude \[m\]': 120 of 120 depths outside "
                                        r"\[-10, 6000\] m.*sign flipped"):
        reference_depth(t, level, np.zeros(t.size), "GT.csv", fields, None, (-10.0, 6000.0))
    # inside the range (or a reference in a relative frame) the rates cannot say which column is wrong
    with pytest.raises(DataError, match=r"field 'Altitude \[m\]'.*changes against 'V Down \[m/s\]'"):
        reference_depth(t, -(depth - 18.0), v_n[:, 2], "GT.csv", fields, None, (-10.0, 6000.0))


def test_no_reference_conversion_on_the_shared_trajectories(akit_dir):
    """The GT checks of the A-KIT loader leave the ten trajectories as read, with wide margins: the attitude turns
    0.95-1.03x as fast as the gyro (23-56x in degrees), the positions move 0.97-1.01x as far as the velocity says
    (28-57x in degrees), the depth follows V Down (correlation 0.95-1.00 over 10 s windows), and the GT agrees with
    itself."""
    from graphnav.core.rotations import euler_to_C_b_n
    from graphnav.io.loaders import read_akit, read_akit_mission
    from graphnav.io.units import (
        _closest_to_one,
        _latlon_ratios,
        attitude_rate_ratio,
        reference_inconsistencies,
        vertical_sign,
    )
    for folder in list_akit(akit_dir):
        with warnings.catch_warnings():
            warnings.simplefilter("error")       # any conversion warns: none may happen
            raw = read_akit(folder)
        g, imu = raw.gt, raw.imu
        for angles, low, high in ((g[:, 7:10], 0.9, 1.1), (np.degrees(g[:, 7:10]), 20.0, 60.0)):
            ratio, _ = attitude_rate_ratio(g[:, 0], euler_to_C_b_n(*angles.T), imu[:, 0], imu[:, 4:7])
            assert low < ratio < high, (folder.name, ratio)
        assert 0.95 < _closest_to_one(_latlon_ratios(g[:, 0], g[:, 2], g[:, 1], g[:, 4:7])) < 1.05
        assert 25.0 < _latlon_ratios(g[:, 0], np.degrees(g[:, 2]), np.degrees(g[:, 1]), g[:, 4:7])[0] < 60.0
        sign, slope, correlation = vertical_sign(g[:, 0], -g[:, 3], g[:, 6])
        assert sign == 1 and correlation > 0.9, (folder.name, slope, correlation)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = read_akit_mission(folder)
        assert reference_inconsistencies(m.gt.t, m.gt.C_b_n, m.gt.p_n, m.gt.v_n, m.imu.t, m.imu.omega_b) == []


def test_noisy_fixes_of_a_slow_vehicle_are_metres_and_feet_are_not():
    """A reference whose positions are USBL-like fixes (4 m sigma) on a vehicle at 0.2 m/s moves 3.3x as far as its
    velocity over 10 s windows, the ratio of feet to metres; over longer windows the noise shrinks against the
    distance and the same units show (it was refused as "other units"). Positions in feet stay 3.28x at every
    window and are refused."""
    from graphnav.io.units import check_reference_displacement, displacement_ratio
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 600.0, 1.0)
    v = np.column_stack([np.full(t.size, 0.2), np.zeros(t.size)])
    p = np.column_stack([0.2 * t, np.zeros(t.size)]) + rng.normal(0.0, 4.0, (t.size, 2))
    from graphnav.io.units import _window_increments
    dp, dv = _window_increments(t, p, v, 10.0)                          # 10 s windows alone: "other units"
    assert np.median(np.linalg.norm(dp, axis=1)) / np.median(np.linalg.norm(dv, axis=1)) > 3.0
    ratio = displacement_ratio(t, p, v)[0]
    assert 0.9 < ratio < 1.3
    check_reference_displacement(ratio, "ref.csv", ["n", "e", "vn", "ve"])
    feet = np.column_stack([1.5 * t, np.zeros(t.size)]) / 0.3048 + rng.normal(0.0, 0.1, (t.size, 2))
    ratio_feet = displacement_ratio(t, feet, np.column_stack([np.full(t.size, 1.5), np.zeros(t.size)]))[0]
    assert ratio_feet == pytest.approx(3.2808, rel=0.01)
    with pytest.raises(DataError, match="3.28x as far as the velocity says"):
        check_reference_displacement(ratio_feet, "ref.csv", ["n", "e", "vn", "ve"])


def test_gyro_rates_57_times_too_small_are_refused_declared_or_not(sim):
    # rad/s data declared deg/s (or converted twice): the tilt kinematics see the gravity turn ~57x faster
    small = sim.imu.omega_b * np.pi / 180
    with pytest.raises(DataError, match=r"field 'gx/gy/gz'.*declared gyro unit 'deg/s' looks wrong"):
        imu_units(sim.imu.t, sim.imu.f_b, small, "imu.csv", declared={"gyro": "deg/s"},
                  fields=("ax", "ay", "az", "gx", "gy", "gz"))
    with pytest.raises(DataError, match=r"field 'omega_b'.*too small for rad/s.*converted from deg/s to rad/s twice"):
        imu_units(sim.imu.t, sim.imu.f_b, small, "bag:/imu")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert imu_units(sim.imu.t, sim.imu.f_b, sim.imu.omega_b, "imu.csv")[1] is not None


def test_akit_gyro_57_times_too_small_names_the_file_and_gyro_columns(akit_dir, tmp_path):
    src = akit_dir / "Trajectory5"

    def shrink(a):
        a[:, 4:7] = np.radians(a[:, 4:7])
        return a
    folder = _copy(src, tmp_path, shrink)
    with pytest.raises(DataError, match="too small for rad/s") as err:
        _load(folder)
    assert err.value.source == str(akit_files(folder)["IMU"])
    assert err.value.field == "/".join(AKIT_COLUMNS["IMU"][4:7])


def test_tilt_scale_far_from_both_thresholds_on_the_shared_trajectories(akit_dir):
    from graphnav.io.units import GYRO_TILT_SCALE_DEG, GYRO_TILT_SCALE_SMALL
    for folder in list_akit(akit_dir):
        imu, _ = _raw(folder)
        k, _ = gyro_tilt_scale(imu[:, 0], imu[:, 1:4], imu[:, 4:7])
        k_small, _ = gyro_tilt_scale(imu[:, 0], imu[:, 1:4], np.radians(imu[:, 4:7]))
        # rad/s 3.5x above the deg/s threshold and 4.5x under the too-small one; 57.3x too small 6.8x above it
        assert 3.5 * GYRO_TILT_SCALE_DEG < k < GYRO_TILT_SCALE_SMALL / 4.5, (folder.name, k)
        assert k_small > 6.8 * GYRO_TILT_SCALE_SMALL, (folder.name, k_small)


def _hovering(acc_mps2=0.05, tilt_rad=0.001, seed=1, rate=100.0, duration_s=600.0):
    """A station-keeping AUV: FRD, gyro rad/s; a slow roll/pitch wobble of ``tilt_rad`` and thruster accelerations
    of ``acc_mps2`` (random, smoothed over 2 s) that turn the accelerometer's direction more than the wobble does."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 1.0 / rate)
    roll, pitch = tilt_rad * np.sin(2 * np.pi * t / 7.0), tilt_rad * np.sin(2 * np.pi * t / 11.0 + 1)
    omega = np.column_stack([np.gradient(roll, t), np.gradient(pitch, t), np.zeros_like(t)])
    omega += rng.normal(0.0, np.radians(0.003) * np.sqrt(rate), omega.shape)
    n, w = t.size, int(2 * rate)
    a = np.cumsum(rng.normal(0.0, 1.0, (n + w, 3)), axis=0)
    a = a[w:] - a[:-w]
    return t, _tilted_gravity(roll, pitch) + a * acc_mps2 / a.std(axis=0) + rng.normal(0.0, 0.01, (n, 3)), omega


def _wave_rider(follow=0.9, seed=2, rate=100.0, duration_s=600.0):
    """A surface vehicle in waves: its specific force normal to the water surface, its hull rolling and pitching
    with ``follow`` of the surface's slope (so the accelerometer sees only the rest); gyro rad/s, FRD."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 1.0 / rate)
    slope_r = sum(0.04 * np.sin(2 * np.pi * t / P + ph) for P, ph in ((3.1, 0), (4.3, 1), (5.7, 2)))
    slope_p = sum(0.03 * np.sin(2 * np.pi * t / P + ph) for P, ph in ((3.7, 0.5), (4.9, 1.5)))
    roll, pitch = follow * slope_r, follow * slope_p
    omega = np.column_stack([np.gradient(roll, t), np.gradient(pitch, t), 0.01 * np.sin(2 * np.pi * t / 60)])
    omega += rng.normal(0.0, 1e-3, omega.shape)
    f = _tilted_gravity(slope_r - roll, slope_p - pitch) + rng.normal(0.0, 0.01, omega.shape)
    return t, f, omega


def _tilted_gravity(roll, pitch, g=9.81):
    return np.column_stack([g * np.sin(pitch), -g * np.sin(roll) * np.cos(pitch), -g * np.cos(roll) * np.cos(pitch)])


@pytest.mark.parametrize("acc, tilt, seed", [(0.05, 0.001, 1), (0.2, 0.0003, 2), (0.1, 0.001, 3)])
def test_a_hovering_auv_gyro_in_rad_s_is_kept(acc, tilt, seed):
    # its thrusters turn the accelerometer's direction 4-50x faster than the gyro says, unrelated to the gyro:
    # the tilt kinematics cannot judge the gyro's scale (it was refused as too small for rad/s, even declared rad/s)
    t, f, omega = _hovering(acc, tilt, seed)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for declared in (None, {"gyro": "rad/s"}):
            assert np.array_equal(imu_units(t, f, omega, "hover.csv", {}, declared)[1], omega)


def test_a_wave_riding_surface_vehicle_gyro_in_rad_s_is_kept():
    # its accelerometer follows the water surface, so the gravity direction turns 15x slower than the gyro says
    # (it was converted as deg/s); declared rad/s, a hull that follows the slope even closer is kept with a warning
    t, f, omega = _wave_rider(0.9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for declared in (None, {"gyro": "rad/s"}):
            assert np.array_equal(imu_units(t, f, omega, "asv.csv", {}, declared)[1], omega)
    t, f, omega = _wave_rider(0.95)
    meta = {}
    with pytest.warns(RuntimeWarning, match="asv.csv: the gravity direction .* kept in the declared unit 'rad/s'"):
        assert np.array_equal(imu_units(t, f, omega, "asv.csv", meta, {"gyro": "rad/s"})[1], omega)
    assert "kept in the declared unit" in meta["streams"]["imu"]["notes"][0]
    with pytest.warns(RuntimeWarning, match="read as deg/s.*declare the gyro unit"):
        imu_units(t, f, omega, "asv.csv")              # undeclared it cannot be told from deg/s: the note says so


def test_rates_57_times_too_small_declared_rad_s_are_kept_with_a_warning(sim):
    # a declared unit that is the unit checked is the user's call: a warning, never an error from this test
    small = sim.imu.omega_b * np.pi / 180
    with pytest.warns(RuntimeWarning, match=r"imu.csv: the gravity direction .* turns 5\d\.\dx as fast .* 'rad/s'"):
        assert np.array_equal(imu_units(sim.imu.t, sim.imu.f_b, small, "imu.csv", {}, {"gyro": "rad/s"})[1], small)


def test_a_reference_down_sign_and_a_depth_sensor_use_one_fit():
    """The reference's down sign (``vertical_sign``) and a depth sensor's convention (``depth_rate_fit``) fitted the
    depth against a vertical velocity over the same windows with two rules (residual ratios, then a slope with a
    correlation); the sign is now the fit's, over the same windows, with its correlation gate."""
    from graphnav.io.units import DEPTH_FIT_MIN_CORRELATION, depth_rate_fit, vertical_sign
    t = np.arange(0.0, 120.0, 1.0)
    v_down = 0.3 * np.cos(0.3 * t)
    down = 15.0 + np.sin(0.3 * t) + 0.01 * np.random.default_rng(1).standard_normal(t.size)
    for sign in (1, -1):
        k, r = depth_rate_fit(t, sign * down, t, v_down, min_windows=3)
        assert vertical_sign(t, sign * down, v_down) == (sign, k, r) and abs(r) >= DEPTH_FIT_MIN_CORRELATION
    assert vertical_sign(t, np.full(t.size, 15.0), v_down)[0] == 0


# ------------------------------------------------------------------------------------------------
# the gyro's scale against the DVL, where the tilt kinematics cannot judge it
# ------------------------------------------------------------------------------------------------
def _with_dvl(t, f, omega, v_b, seed, noise=0.005):
    """ImuData and a 1 Hz velocity-only DvlData (body velocity ``v_b`` at the IMU stamps, m/s) of one vehicle."""
    from graphnav.core.mission import DvlData, ImuData
    i = np.arange(0, t.size, int(round(1.0 / (t[1] - t[0]))))
    v = v_b[i] + np.random.default_rng(seed).normal(0.0, noise, (i.size, 3))
    return (ImuData(t, f, omega, source="imu.csv"),
            DvlData(t[i], np.full((i.size, 4), np.nan), np.zeros((i.size, 4), bool), v, source="dvl.csv"))


def _hovering_with_dvl(acc_mps2=0.2, tilt_rad=0.0003, seed=1):
    """A station-keeping AUV (:func:`_hovering`'s wobble) whose velocity stays near zero, its accelerometer seeing
    the thrusters' accelerations and its DVL the velocity they make."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 300.0, 0.01)
    roll, pitch = tilt_rad * np.sin(2 * np.pi * t / 7.0), tilt_rad * np.sin(2 * np.pi * t / 11.0 + 1)
    omega = np.column_stack([np.gradient(roll, t), np.gradient(pitch, t), np.zeros_like(t)])
    a = np.cumsum(rng.normal(0.0, 1.0, (t.size + 200, 3)), axis=0)
    a = (a[200:] - a[:-200]) * acc_mps2 / np.std(a[200:] - a[:-200], axis=0)
    v = np.cumsum(a, axis=0) * 0.01
    v -= np.column_stack([np.convolve(v[:, i], np.ones(3000) / 3000, "same") for i in range(3)])
    f = _tilted_gravity(roll, pitch) + np.gradient(v, t, axis=0) + np.cross(omega, v) + rng.normal(0, 0.01, v.shape)
    return _with_dvl(t, f, omega + rng.normal(0.0, 5e-4, omega.shape), v, seed)


def _gyro_check(imu, dvl, config=None, declared=None):
    from graphnav.calibration.dvl_scale import check_gyro_against_dvl
    from graphnav.io.units import GYRO_UNJUDGED
    meta = {GYRO_UNJUDGED: {"declared": declared, "field": "gx/gy/gz", "correlation": 0.2}}
    return check_gyro_against_dvl(imu, dvl, config or sim_config(), meta), meta


def sim_config():
    from graphnav.core.config import SensorConfig
    cfg = SensorConfig()
    cfg.dvl.lever_arm_b = np.zeros(3)
    return cfg


def test_the_tilt_kinematics_leave_a_hovering_gyro_to_the_dvl():
    t, f, omega = _hovering(0.2, 0.0003, 1)
    meta = {}
    imu_units(t, f, omega, "hover.csv", meta)
    from graphnav.io.units import GYRO_UNJUDGED
    assert meta[GYRO_UNJUDGED]["field"] == "omega_b" and meta[GYRO_UNJUDGED]["declared"] is None


def test_gyro_scale_against_the_dvl_refuses_rates_57_times_too_small_and_converts_deg_s(sim):
    imu, dvl = sim.imu, sim.dvl
    small = dataclasses.replace(imu, omega_b=imu.omega_b * np.pi / 180)
    with pytest.raises(DataError, match=r"too small for rad/s: the DVL velocity's changes \(.*\) fit these rates x57"):
        _gyro_check(small, dvl, sim.config)
    with pytest.raises(DataError, match="declared gyro unit 'deg/s' looks wrong"):
        _gyro_check(small, dvl, sim.config, "deg/s")
    deg = dataclasses.replace(imu, omega_b=np.degrees(imu.omega_b))
    with pytest.warns(RuntimeWarning, match="gyro read as deg/s and converted to rad/s: the DVL"):
        out, meta = _gyro_check(deg, dvl, sim.config)
    assert np.allclose(out.omega_b, imu.omega_b) and "deg/s" in meta["streams"]["imu"]["notes"][0]
    with pytest.raises(DataError, match="declared gyro unit 'rad/s' looks wrong.*deg/s\\?"):
        _gyro_check(deg, dvl, sim.config, "rad/s")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _gyro_check(imu, dvl, sim.config)[0] is imu


@pytest.mark.parametrize("seed", [1, 2])
def test_a_hovering_auv_with_a_dvl_keeps_its_rad_s_gyro(seed):
    # the gyro barely matters to a vehicle that does not move: the DVL cannot tell the scales apart (the rates as read
    # leave at most 0.93x as much unexplained as deg/s would), and nothing is changed or refused
    imu, dvl = _hovering_with_dvl(seed=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out, meta = _gyro_check(imu, dvl)
    assert out is imu
    # nothing judged it: said in a note, not left in an unread meta entry
    assert "gyro_scale_unjudged" not in meta
    assert [n for n in meta["streams"]["imu"]["notes"] if "gyro's scale is not judged (field gx/gy/gz): the tilt "
            "kinematics could not (correlation 0.20), nor can the DVL: the rates x0.01745 leave" in n]


def _akit_crop(src, dst_root, t0, t1, gyro_scale=1.0, dvl_shift=0.0):
    """An A-KIT folder of ``src`` rows ``t0 <= Time <= t1`` s, the gyro multiplied by ``gyro_scale``, the DVL stamps
    ``dvl_shift`` s later."""
    dst = dst_root / src.name
    dst.mkdir()
    files = akit_files(src)
    for kind in ("IMU", "DVL", "GT"):
        arr = read_csv(files[kind], AKIT_COLUMNS[kind], nan_ok=AKIT_COLUMNS[kind][1:])
        arr = arr[(arr[:, 0] >= t0) & (arr[:, 0] <= t1)]
        if kind == "IMU":
            arr[:, 4:7] *= gyro_scale
        if kind == "DVL":
            arr[:, 0] += dvl_shift
        np.savetxt(dst / files[kind].name, arr, delimiter=",", fmt="%.12g", comments="",
                   header=",".join(AKIT_COLUMNS[kind]))
    return dst


def test_a_calm_akit_stretch_with_gyro_rates_57_times_too_small_is_refused(akit_dir, tmp_path):
    # 120 s of Trajectory6 where the tilt kinematics cannot judge the gyro (correlation 0.20): divided by 57.3 it ran
    # silently at VRMSE 0.27 m/s (0.024 clean); the DVL's velocity changes fit the rates 57.3x larger ~46x better
    src = akit_dir / "Trajectory6"
    folder = _akit_crop(src, tmp_path, 120.0, 240.0, np.pi / 180)
    with pytest.raises(DataError, match="too small for rad/s: the DVL velocity's changes") as err:
        _load(folder)
    assert err.value.source == str(akit_files(folder)["IMU"])
    assert err.value.field == "/".join(AKIT_COLUMNS["IMU"][4:7])
    (tmp_path / "clean").mkdir()
    m, caught = _load(_akit_crop(src, tmp_path / "clean", 120.0, 240.0))
    assert not any("gyro" in w for w in caught) and "gyro_scale_unjudged" not in m.meta


def _column_map_log(m, folder, gyro_scale=1.0, dvl_shift=0.0):
    """Mission ``m`` as a column-map log in ``folder`` (IMU FRD, DVL velocity columns ``dvl_shift`` s later on a clock
    to be found, ``"clock": "auto"``; gyro multiplied by ``gyro_scale``); returns the configuration path."""
    import json
    from graphnav.core.dvl_kinematics import dvl_velocity_b
    folder.mkdir()
    t, v = dvl_velocity_b(m.dvl, m.config)
    for name, header, columns in (("imu.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"],
                                   [m.imu.t, m.imu.f_b, m.imu.omega_b * gyro_scale]),
                                  ("dvl.csv", ["t", "vx", "vy", "vz"], [t + dvl_shift, v])):
        np.savetxt(folder / name, np.column_stack(columns), delimiter=",", fmt="%.12g", comments="",
                   header=",".join(header))
    cfg = m.config.to_dict()
    cfg["dvl_time_offset_s"] = 0.0
    cfg["imu_axis_signs"] = None            # the files hold the mission's body-frame data, its signs already applied
    cfg["csv_columns"] = {"time_unit": "s", "imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"],
                                                    "omega_b": ["gx", "gy", "gz"], "frame": "frd"},
                          "dvl": {"file": "dvl.csv", "t": "t", "v_b": ["vx", "vy", "vz"], "clock": "auto"}}
    (folder / "config.json").write_text(json.dumps(cfg))
    return folder / "config.json"


def test_a_calm_stretch_with_gyro_rates_57_times_too_small_and_the_dvl_on_its_own_clock_names_the_gyro(akit_dir,
                                                                                                         tmp_path):
    # the same crop with its DVL 600 s away: the clock search failed with the rates as read and the clock was blamed
    # ("the DVL noise hides the vehicle's accelerations"); with them x57.3 it finds the clock, where the DVL judges
    # the gyro. Clean, the offset is found as read and the gyro judged after it (it was left unjudged, unsaid)
    from graphnav.missions import load_mission
    src = akit_dir / "Trajectory6"
    named = (r"too small for rad/s: the DVL velocity's changes \(.*, on the IMU clock at the offset -\d+\.\d+ s the "
             r"DVL clock search finds with the rates x57.3, none with them as read\) fit these rates x57.3")
    (tmp_path / "small").mkdir()
    with pytest.raises(DataError, match=named) as err:          # an A-KIT folder: its coarse DVL clock
        _load(_akit_crop(src, tmp_path / "small", 120.0, 240.0, np.pi / 180, dvl_shift=600.0))
    assert err.value.field == "/".join(AKIT_COLUMNS["IMU"][4:7])
    (tmp_path / "clean").mkdir()
    clean, caught = _load(_akit_crop(src, tmp_path / "clean", 120.0, 240.0))
    for k, shift in ((np.pi / 180, 600.0), (1.0, 600.0)):        # the crop as a column-map log
        folder = tmp_path / f"csv_{k:.3f}"
        config = _column_map_log(clean, folder, k, shift)
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            if k != 1.0:
                with pytest.raises(DataError, match=named) as err:
                    load_mission(folder, config)
                assert err.value.source == str(folder / "imu.csv") and err.value.field == "gx/gy/gz"
                continue
            m = load_mission(folder, config)
        assert m.config.dvl_time_offset_s == pytest.approx(-shift, abs=0.1)
        assert "gyro_scale_unjudged" not in m.meta
        assert not [n for n in m.meta["streams"]["imu"]["notes"] if "gyro" in n]


def test_a_dvl_clock_the_gyro_scales_cannot_find_either_says_so(sim):
    from graphnav.calibration.preparation import _gyro_finds_the_clock
    from graphnav.io.units import GYRO_UNJUDGED
    err = DataError("the clock offset cannot be found", "dvl.csv", field="t")

    def search(imu, meta):
        raise err
    meta = {GYRO_UNJUDGED: {"declared": None, "field": "gx/gy/gz", "correlation": 0.2}}
    with pytest.raises(DataError, match=r"^dvl.csv, field 't': the clock offset cannot be found \(nor with the gyro "
                                        r"rates x57.3 or /57.3"):
        _gyro_finds_the_clock(err, search, sim.imu, sim.dvl, sim.config, meta)
    with pytest.raises(DataError, match=r"cannot be found$"):       # a gyro judged already: the clock's error
        _gyro_finds_the_clock(err, search, sim.imu, sim.dvl, sim.config, {})


def _turning_reference(seconds=200.0):
    """A vehicle at 1.5 m/s through a full circle in ``seconds``, at 1 Hz: t (s), north/east positions (m), north/east
    velocity (m/s), heading (rad) along it."""
    t = np.arange(0.0, seconds, 1.0)
    yaw = 2 * np.pi * t / seconds
    v = 1.5 * np.column_stack([np.cos(yaw), np.sin(yaw)])
    p = np.concatenate([np.zeros((1, 2)), np.cumsum((v[1:] + v[:-1]) / 2, axis=0)])
    return t, p, v, yaw


def test_a_reference_with_north_and_east_exchanged_or_negated_is_refused_naming_the_pair():
    """North and east velocities (or positions) exchanged or negated moved as far as each other, so the
    displacement check passed, and the load went on with a warning of many position steps. The signed permutation
    of the velocity that fits the positions is named, the heading saying which pair is wrong."""
    from graphnav.io.units import check_reference_axes
    t, p, v, yaw = _turning_reference()
    akit = ("Latitude [rad]", "Longitude [rad]", "Altitude [m]", "V North [m/s]", "V East [m/s]", "V Down [m/s]")
    check_reference_axes(t, p, v, yaw, "GT.csv", akit)                   # as read: nothing
    with pytest.raises(DataError, match=r"GT.csv, field 'V North \[m/s\]/V East \[m/s\]': the velocity fits the "
                                        r"positions as north = 'V East \[m/s\]', east = 'V North \[m/s\]'.*"
                                        r"the velocity columns are wrong; correct the file: exchange 'V North \[m/s\]' "
                                        r"and 'V East"):
        check_reference_axes(t, p, v[:, ::-1], yaw, "GT.csv", akit)
    with pytest.raises(DataError, match=r"field 'Latitude \[rad\]/Longitude \[rad\]'.*the position columns are wrong"):
        check_reference_axes(t, p[:, ::-1], v, yaw, "GT.csv", akit)
    mapped = ("n", "e", "d", "vn", "ve", "vd")
    with pytest.raises(DataError, match=r"field 'vn/ve'.*map csv_columns.gt.v_n as \['ve', 'vn', 'vd'\]"):
        check_reference_axes(t, p, v[:, ::-1], yaw, "nav.csv", mapped, ("p_n", "v_n"))
    with pytest.raises(DataError, match=r"north = 'vn', east = -'ve'.*negate 've' \(a column map cannot negate"):
        check_reference_axes(t, p, v * [1, -1], yaw, "nav.csv", mapped, ("p_n", "v_n"))
    # a heading along neither: both pairs named
    with pytest.raises(DataError, match=r"field 'n/e/vn/ve'.*cannot tell which pair.*either the velocity columns"):
        check_reference_axes(t, p, v[:, ::-1], yaw + np.pi, "nav.csv", mapped, ("p_n", "v_n"))
    # USBL-like fixes (4 m sigma) of a slow vehicle on a straight leg: as read nothing; exchanged, named
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 600.0, 1.0)
    v = np.column_stack([np.full(t.size, 0.2), np.zeros(t.size)])
    p = np.column_stack([0.2 * t, np.zeros(t.size)]) + rng.normal(0.0, 4.0, (t.size, 2))
    check_reference_axes(t, p, v, np.zeros(t.size), "nav.csv", mapped)
    with pytest.raises(DataError, match=r"as north = 've', east = 'vn' .*; as north = 've', east = -'vn' too\)"):
        check_reference_axes(t, p, v[:, ::-1], np.zeros(t.size), "nav.csv", mapped)


def test_a_reference_down_velocity_with_its_sign_flipped_is_named_by_the_pitch():
    """A depth changing against its down velocity inside the depth range was refused as 'one of the two columns has
    its sign flipped'; the attitude's pitch (the down velocity it gives the speed) names the column."""
    from graphnav.io.units import reference_depth
    t = np.arange(0.0, 120.0, 1.0)
    pitch = -0.2 * np.sin(2 * np.pi * t / 60.0)                        # nose down: sinking
    v_down = -1.5 * np.sin(pitch)
    depth = 20.0 + np.concatenate([[0.0], np.cumsum((v_down[1:] + v_down[:-1]) / 2)])
    fields = ("d", "vd")
    with pytest.raises(DataError, match=r"field 'vd'.*'vd' has its sign flipped.*correlates -1.00 with 'vd'"):
        reference_depth(t, depth, -v_down, "nav.csv", fields, v_pitch=v_down)
    with pytest.raises(DataError, match=r"field 'd'.*'d' has its sign flipped.*negate 'd' in the file"):
        reference_depth(t, 40.0 - depth, v_down, "nav.csv", fields, v_pitch=v_down)
    # a level pitch (a vehicle changing depth by buoyancy or thrusters) cannot tell: both named, as before
    with pytest.raises(DataError, match=r"field 'd'.*one of the two columns has its sign flipped \(the attitude's "
                                        r"pitch cannot tell"):
        reference_depth(t, depth, -v_down, "nav.csv", fields, v_pitch=np.random.default_rng(0).normal(0, 0.01, t.size))


def _akit_copy(akit_dir, tmp_path, change):
    """Trajectory1 in ``tmp_path`` with its GT rows' cells (a list of strings) changed by ``change``."""
    src = akit_dir / "Trajectory1"
    dst = tmp_path / "Trajectory1"
    dst.mkdir(parents=True)
    for f in src.iterdir():
        if not f.name.startswith("GT"):
            (dst / f.name).symlink_to(f)
    lines = (src / "GT_trajectory1.csv").read_text().splitlines()
    (dst / "GT_trajectory1.csv").write_text("\n".join(lines[:1] + [",".join(change(line.split(","))) for line in
                                                                   lines[1:]]) + "\n")
    return dst


def test_an_akit_reference_with_exchanged_columns_is_refused_naming_them(akit_dir, tmp_path):
    """Trajectory1 with V North and V East exchanged was refused only by the prepare step ('the DVL velocity does not
    follow the ground truth's body velocity ... not along its body's forward axis'); with latitude and longitude
    exchanged it loaded with a warning of 187 position steps and was scored against. Both are named at reading;
    V Down negated is named by the pitch. (On all ten: docs/decisions/units-clocks-axes.md.)"""
    from graphnav.io.loaders import read_akit
    cases = ((lambda c: c[:4] + [c[5], c[4]] + c[6:], r"field 'V North \[m/s\]/V East \[m/s\]'.*exchange 'V North"),
             (lambda c: c[:1] + [c[2], c[1]] + c[3:], r"field 'Latitude \[rad\]/Longitude \[rad\]'.*the position "
                                                      r"columns are wrong.*exchange 'Latitude \[rad\]' and 'Longitude"),
             (lambda c: c[:6] + [f"{-float(c[6])!r}"] + c[7:], r"field 'V Down \[m/s\]'.*'V Down \[m/s\]' has its "
                                                               r"sign flipped"))
    for i, (change, message) in enumerate(cases):
        with pytest.raises(DataError, match=message):
            read_akit(_akit_copy(akit_dir, tmp_path / str(i), change))
