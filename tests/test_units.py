"""Units from the data (graphnav.io.units): stamps in ms/us/ns, gyro in deg/s, accelerometer in g, swapped IMU
blocks, DVL in mm/s -- converted with a warning and a note, or refused naming the field; never a false detection
on the ten shared A-KIT trajectories."""
from __future__ import annotations

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
        # the tilt kinematics tell the units apart on every trajectory, with a wide margin either side of 0.1
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
