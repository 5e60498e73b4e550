"""IMU axis convention detected at load time (``imu_axis_signs="auto"``): the shared A-KIT files as
published (y flipped) and the same files with y already in the body frame, with and without GT."""
from __future__ import annotations

import json
import shutil
import warnings

import numpy as np
import pytest

from graphnav.calibration.preparation import prepare
from graphnav.core.config import SensorConfig
from graphnav.core.errors import DataError
from graphnav.io.loaders import AKIT_COLUMNS, akit_files, read_akit_mission, read_csv
from graphnav.missions import load_akit, load_mission

TRAJ = ("Trajectory2", "Trajectory11")   # Trajectory11: little roll, the accelerometer check is undecided


def _copy(src, dst_root, imu_transform=None, with_gt=True):
    """A copy of an A-KIT folder in ``dst_root`` (never in the repo); the IMU rows pass through
    ``imu_transform`` (raw (N,7) -> (N,7))."""
    dst = dst_root / src.name
    dst.mkdir()
    files = akit_files(src)
    imu = read_csv(files["IMU"], AKIT_COLUMNS["IMU"])
    if imu_transform is not None:
        imu = imu_transform(imu)
    np.savetxt(dst / files["IMU"].name, imu, delimiter=",", fmt="%.10g", comments="",
               header=",".join(AKIT_COLUMNS["IMU"]))
    shutil.copy(files["DVL"], dst / files["DVL"].name)
    if with_gt:
        shutil.copy(files["GT"], dst / files["GT"].name)
    return dst


def _negate_y(imu):
    imu = imu.copy()
    imu[:, [2, 5]] *= -1          # ACC Y, GYRO Y: the authors' corrected files (y in the body frame)
    return imu


def read_and_prepare(folder):
    """The folder read and prepared (the axis check runs in ``prepare``)."""
    return prepare(read_akit_mission(folder))


def _auto(load, *args, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = load(*args, **kwargs)
    msgs = [str(w.message) for w in caught if "IMU axis convention" in str(w.message)]
    assert len(msgs) == 1, msgs
    return out, msgs[0]


@pytest.mark.parametrize("name", TRAJ)
def test_published_files_detected_as_y_flipped(akit_dir, name):
    m, msg = _auto(load_akit, akit_dir / name)
    np.testing.assert_array_equal(m.config.imu_axis_signs, [1, -1, 1])
    assert "against the GT attitude" in msg and "(1, -1, 1)" in msg
    explicit = load_akit(akit_dir / name, imu_axis_signs=(1, -1, 1))
    np.testing.assert_array_equal(m.imu.omega_b, explicit.imu.omega_b)
    assert m.config.gt_time_offset_s == explicit.config.gt_time_offset_s   # reused, not re-estimated


@pytest.mark.parametrize("name", TRAJ)
def test_y_in_body_frame_detected(akit_dir, tmp_path, name):
    folder = _copy(akit_dir / name, tmp_path, _negate_y)
    m, msg = _auto(load_akit, folder)
    np.testing.assert_array_equal(m.config.imu_axis_signs, [1, 1, 1])
    assert "(1, 1, 1)" in msg
    published = load_akit(akit_dir / name, imu_axis_signs=(1, -1, 1))
    np.testing.assert_allclose(m.imu.omega_b, published.imu.omega_b, atol=1e-9)
    np.testing.assert_allclose(m.imu.f_b, published.imu.f_b, atol=1e-8)


@pytest.mark.parametrize("transform, signs", [(None, [1, -1, 1]), (_negate_y, [1, 1, 1])])
def test_without_gt_gravity_and_gyro_decide(akit_dir, tmp_path, transform, signs):
    folder = _copy(akit_dir / TRAJ[0], tmp_path, transform, with_gt=False)
    raw, msg = _auto(read_and_prepare, folder)
    assert raw.gt is None and "no GT" in msg
    np.testing.assert_array_equal(raw.config.imu_axis_signs, signs)
    with pytest.warns(RuntimeWarning, match="no GT file"):        # a vehicle's folder: IMU and DVL only
        m = load_akit(folder)
    assert m.gt is None and m.depth is None
    np.testing.assert_array_equal(m.config.imu_axis_signs, signs)


def _turn_90(imu):
    """The IMU mounted turned 90 deg about z (x to starboard), in the published files' y-flipped convention."""
    imu = imu.copy()
    for x, y in ((1, 2), (4, 5)):
        imu[:, [x, y]] = np.column_stack([-imu[:, y], imu[:, x]])
    return imu


def _turn_180(imu):
    imu = imu.copy()
    imu[:, [1, 2, 4, 5]] *= -1
    return imu


@pytest.mark.parametrize("turn, yaw, fix", [(_turn_90, 90, "turn the accelerometer and gyro columns of the file"),
                                            (_turn_180, 180, r"set imu_axis_signs \(-1, 1, 1\)")])
def test_without_gt_an_imu_turned_about_z_is_refused_by_the_dvl(akit_dir, tmp_path, turn, yaw, fix):
    folder = _copy(akit_dir / TRAJ[0], tmp_path, turn, with_gt=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=rf"IMU_trajectory2\.csv, field 'ACC X \[m/s\^2\]/.*/GYRO Z \[rad/s\]': the "
                                            rf"IMU's axes are turned {yaw} deg about z against the file's axes with "
                                            rf"imu_axis_signs \(1, -1, 1\).*{fix}"):
            load_akit(folder)
        if yaw == 180:                                           # the advice loads it as the published file
            got = load_akit(folder, imu_axis_signs=(-1, 1, 1))
            (tmp_path / "clean").mkdir()
            clean = load_akit(_copy(akit_dir / TRAJ[0], tmp_path / "clean", with_gt=False))
    if yaw == 180:
        np.testing.assert_allclose(got.imu.f_b, clean.imu.f_b, atol=1e-9)


def test_explicit_signs_win_and_config_without_field_is_auto(akit_dir, tmp_path):
    folder = akit_dir / TRAJ[0]
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=".*IMU axis convention")
        m = load_akit(folder, imu_axis_signs=(1, 1, 1))           # wrong on purpose: used as given
        np.testing.assert_array_equal(m.config.imu_axis_signs, [1, 1, 1])
        cfg = SensorConfig(imu_axis_signs=(1, 1, 1))
        cfg.save(tmp_path / "with.json")
        m = load_mission(folder, tmp_path / "with.json")
        np.testing.assert_array_equal(m.config.imu_axis_signs, [1, 1, 1])
    d = cfg.to_dict()
    del d["imu_axis_signs"]
    (tmp_path / "without.json").write_text(json.dumps(d))
    m, _ = _auto(load_mission, folder, tmp_path / "without.json")
    np.testing.assert_array_equal(m.config.imu_axis_signs, [1, -1, 1])


def test_no_convention_fits_names_the_axis(akit_dir, tmp_path):
    # swapped x/y (with GT; without GT a swap of the published axes is a turn about z, which the IMU alone
    # cannot see: see detect_imu_axis_signs)
    def swap_xy(imu):
        imu = imu.copy()
        imu[:, [1, 2, 4, 5]] = imu[:, [2, 1, 5, 4]]
        return imu
    folder = _copy(akit_dir / TRAJ[0], tmp_path, swap_xy)
    with pytest.raises(DataError, match="no IMU axis sign convention fits") as err:
        read_and_prepare(folder)
    assert err.value.field.split()[-1] in "xy"
    assert "imu_axis_signs only flips signs" in str(err.value)          # not advice that cannot work


def test_gyro_and_accelerometer_flipped_differently(akit_dir, tmp_path):
    def flip_accel_y_only(imu):
        imu = imu.copy()
        imu[:, 5] *= -1               # gyro y corrected, accelerometer y still flipped
        return imu
    folder = _copy(akit_dir / TRAJ[0], tmp_path, flip_accel_y_only, with_gt=False)
    with pytest.raises(DataError, match="no IMU axis sign convention fits") as err:
        read_and_prepare(folder)
    assert "y" in err.value.field and "negate that axis of one sensor in the file" in str(err.value)
    assert "a bag cannot be edited: set that sensor's axis convention in the driver" in str(err.value)


def _windows(akit_dir, name, length=60.0, step=60.0, transform=None):
    from graphnav.core.mission import ImuData
    imu = read_csv(akit_files(akit_dir / name)["IMU"], AKIT_COLUMNS["IMU"])
    if transform is not None:
        imu = transform(imu)
    t = imu[:, 0]
    for start in np.arange(t[0], t[-1] - length + 1e-9, step):
        sel = (t >= start) & (t < start + length)
        yield start, ImuData(np.ascontiguousarray(t[sel]), imu[sel, 1:4], imu[sel, 4:7], name)


@pytest.mark.parametrize("name", ["Trajectory5", "Trajectory13"])       # many turns; steady at depth
@pytest.mark.parametrize("transform, signs", [(None, [1, -1, 1]), (_negate_y, [1, 1, 1])])
def test_without_gt_every_minute_decides_right(akit_dir, name, transform, signs):
    from graphnav.calibration.axes import detect_imu_axis_signs
    for start, imu in _windows(akit_dir, name, transform=transform):
        det = detect_imu_axis_signs(imu, SensorConfig(), None, name)
        assert det.decided, (name, start, det.notes)
        np.testing.assert_array_equal(det.signs, signs, err_msg=f"{name} window at {start} s")


def _static(imu):
    """An IMU at rest (a vehicle on deck): gravity and noise only, no tilt motion to tell conventions apart."""
    rng = np.random.default_rng(1)
    imu = imu.copy()
    imu[:, 1:4] = [0.0, 0.0, -9.8] + rng.normal(0, 2e-3, (len(imu), 3))
    imu[:, 4:7] = rng.normal(0, 1e-5, (len(imu), 3))
    return imu


def test_without_gt_undecided_falls_back_to_the_configured_convention(akit_dir, tmp_path):
    from graphnav.calibration.axes import detect_imu_axis_signs
    _, imu = next(_windows(akit_dir, TRAJ[0], length=120.0, transform=_static))
    det = detect_imu_axis_signs(imu, SensorConfig(), None, "static", fallback_signs=(1, 1, 1))
    assert not det.decided
    np.testing.assert_array_equal(det.signs, [1, 1, 1])
    # through the loader: a warning, the published A-KIT convention, and a note in meta["streams"]
    folder = _copy(akit_dir / TRAJ[0], tmp_path, _static, with_gt=False)
    raw, msg = _auto(read_and_prepare, folder)
    assert "could not tell the conventions apart" in msg
    np.testing.assert_array_equal(raw.config.imu_axis_signs, [1, -1, 1])
    assert "undecided" in raw.meta["streams"]["imu"]["notes"][0]
