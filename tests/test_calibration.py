"""graphnav calibrate on simulated missions with known errors, and on the shared real data.

Simulated missions are made "as recorded" by a miscalibrated system: the DVL reports its velocity in its
own (yawed) frame with a scale error, the DVL and GT stamps carry offsets, and the configuration claims a
zero lever arm. Tolerances are stated per test; they are ~3 sigma of the estimates for these settings.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graphnav.calibration.axes import (
    check_imu_axes_with_gt,
    check_imu_axes_without_gt,
    signed_permutations,
)
from graphnav.calibration.calibrate import calibrate
from graphnav.core.config import SensorConfig
from graphnav.core.dvl import DvlGeometry
from graphnav.sim.simulate import simulate_mission

TRUE_LEVER = np.array([-1.2, 0.3, 0.5])
TRUE_DVL_OFFSET = 0.40       # s, to add to the recorded DVL stamps
TRUE_GT_OFFSET = -0.30       # s, to add to the recorded GT stamps
TRUE_YAW = np.deg2rad(1.5)   # DVL mounting yaw, C_d_b = Rz(yaw)
TRUE_SCALE = 0.01


def miscalibrated_mission(seed=3, duration=600.0, beam_noise=0.01, yaw=TRUE_YAW):
    truth = SensorConfig()
    truth.dvl.lever_arm_b = TRUE_LEVER
    truth.dvl.C_d_b = Rotation.from_euler("z", yaw).as_matrix()
    truth.dvl.scale_factor = np.full(3, TRUE_SCALE)
    truth.dvl.beam_noise_std = beam_noise
    m = simulate_mission(duration, seed=seed, config=truth)
    believed = SensorConfig.from_dict(m.config.to_dict())
    believed.dvl.lever_arm_b = np.zeros(3)
    believed.dvl.C_d_b = np.eye(3)
    # what the DVL reports: least squares with its own (unrotated) geometry
    v_reported = DvlGeometry.from_spec(believed.dvl).velocity_from_beams(m.dvl.beams, m.dvl.valid,
                                                                         allow_missing=True)
    dvl = dataclasses.replace(m.dvl, t=m.dvl.t - TRUE_DVL_OFFSET, v_b=v_reported)
    gt = dataclasses.replace(m.gt, t=m.gt.t - TRUE_GT_OFFSET)
    return dataclasses.replace(m, dvl=dvl, gt=gt, config=believed)


@pytest.fixture(scope="module")
def mission():
    return miscalibrated_mission()


def test_gt_mode_recovers_known_errors(mission):
    r = calibrate(mission, "gt")
    assert r.axis_check.ok, r.axis_check.suspects
    np.testing.assert_allclose(r.lever_arm_b.value, TRUE_LEVER, atol=0.06)
    assert abs(r.dvl_time_offset_s.value - TRUE_DVL_OFFSET) < 0.1      # sigma ~0.03 s here
    assert abs(r.gt_time_offset_s.value - TRUE_GT_OFFSET) < 0.005
    assert abs(r.dvl_yaw_rad.value - TRUE_YAW) < np.deg2rad(0.1)
    assert abs(r.dvl_scale.value - TRUE_SCALE) < 0.002
    # the simulated IMU sits at the GT point
    np.testing.assert_allclose(r.imu_position_b.value, 0.0, atol=max(0.05, 4 * np.max(r.imu_position_b.sigma)))
    # the sigmas are honest: every estimate within 4 sigma of the truth
    for est, true in ((r.lever_arm_b, TRUE_LEVER), (r.dvl_time_offset_s, TRUE_DVL_OFFSET),
                      (r.dvl_yaw_rad, TRUE_YAW), (r.dvl_scale, TRUE_SCALE)):
        assert np.all(np.abs(np.asarray(est.value) - true) < 4 * np.asarray(est.sigma) + 1e-9), est
    # the calibrated configuration carries the values
    cfg = r.config
    np.testing.assert_allclose(cfg.dvl.lever_arm_b, r.lever_arm_b.value)
    assert cfg.dvl_time_offset_s == pytest.approx(r.dvl_time_offset_s.value)
    assert Rotation.from_matrix(cfg.dvl.C_d_b).as_euler("ZYX")[0] == pytest.approx(r.dvl_yaw_rad.value)
    assert cfg.dvl.velocity_scale_correction == pytest.approx(r.dvl_scale.value)


def test_calibrated_config_round_trips(mission, tmp_path):
    r = calibrate(mission, "gt")
    path = tmp_path / "cal.json"
    r.config.save(path)
    back = SensorConfig.load(path)
    np.testing.assert_allclose(back.dvl.lever_arm_b, r.config.dvl.lever_arm_b)
    np.testing.assert_allclose(back.dvl.C_d_b, r.config.dvl.C_d_b)
    assert back.dvl.velocity_scale_correction == r.config.dvl.velocity_scale_correction
    assert back.gt_time_offset_s == r.config.gt_time_offset_s


def flipped(mission, axis):
    flip = np.ones(3)
    flip[axis] = -1
    imu = dataclasses.replace(mission.imu, f_b=mission.imu.f_b * flip, omega_b=mission.imu.omega_b * flip)
    return dataclasses.replace(mission, imu=imu), flip


def test_flipped_y_axis_is_named_and_calibration_still_works(mission):
    """The A-KIT case: y of both sensors flipped."""
    bad, flip = flipped(mission, 1)
    r = calibrate(bad, "gt")
    assert sorted(r.axis_check.suspects) == ["accelerometer y: sign flipped", "gyro y: sign flipped"]
    np.testing.assert_allclose(r.config.imu_axis_signs, flip)
    np.testing.assert_allclose(r.lever_arm_b.value, TRUE_LEVER, atol=0.06)


@pytest.mark.parametrize("axis", [0, 2])
def test_flipped_axis_is_named(mission, axis):
    check, _ = check_imu_axes_with_gt(flipped(mission, axis)[0])
    name = "xyz"[axis]
    assert sorted(check.suspects) == [f"accelerometer {name}: sign flipped", f"gyro {name}: sign flipped"]


def test_swapped_gyro_axes_are_named(mission):
    omega = mission.imu.omega_b[:, [1, 0, 2]]
    bad = dataclasses.replace(mission, imu=dataclasses.replace(mission.imu, omega_b=omega))
    check, _ = check_imu_axes_with_gt(bad)
    assert "gyro x: reads the raw y axis (swapped axes)" in check.suspects
    assert "gyro y: reads the raw x axis (swapped axes)" in check.suspects
    assert not any(s.startswith("accelerometer") for s in check.suspects)


def test_correct_axes_pass_both_checks(mission):
    check, _ = check_imu_axes_with_gt(mission)
    assert check.ok and check.gyro_rms[0] == check.gyro_rms[1]
    assert check_imu_axes_without_gt(mission).ok


@pytest.mark.parametrize("sensor, axis, expect", [
    ("f_b", 2, "accelerometer z: sign flipped"),
    ("f_b", 1, "accelerometer y: sign flipped"),
    ("omega_b", 0, "gyro x: sign flipped"),
])
def test_axis_check_without_gt(mission, sensor, axis, expect):
    arr = getattr(mission.imu, sensor).copy()
    arr[:, axis] *= -1
    bad = dataclasses.replace(mission, imu=dataclasses.replace(mission.imu, **{sensor: arr}))
    check = check_imu_axes_without_gt(bad)
    assert any(s.startswith(expect) for s in check.suspects), check.suspects


def test_signed_permutations_are_the_48_orthogonal_axis_maps():
    maps = signed_permutations()
    assert len(maps) == 48 and np.array_equal(maps[0], np.eye(3))
    assert len({m.tobytes() for m in maps}) == 48
    for P in maps:
        np.testing.assert_allclose(P @ P.T, np.eye(3))


@pytest.mark.realdata
def test_real_data_estimates_near_readme_values(akit_dir):
    """Data README: lever arm close to [-1.86, -0.04, 0.2] m (relative to the published GT point),
    IMU-to-GT offset -0.5..0.5 s, the DVL leading the GT by 0.5..1.5 s. With the GT moved to the IMU point
    (the loader's default) the DVL lever arm comes out near zero."""
    from graphnav.io.loaders import list_akit
    from graphnav.missions import load_akit
    for folder in list_akit(akit_dir)[:4]:
        at_imu = calibrate(load_akit(folder), "gt")
        np.testing.assert_allclose(at_imu.lever_arm_b.value, 0.0, atol=0.2, err_msg=folder.name)
        r = calibrate(load_akit(folder, imu_position_b=(0, 0, 0)), "gt")
        assert r.axis_check.ok, (folder.name, r.axis_check.suspects)
        np.testing.assert_allclose(r.lever_arm_b.value, [-1.86, -0.04, 0.2], atol=0.2, err_msg=folder.name)
        gt_off, dvl_off = r.gt_time_offset_s.value, r.dvl_time_offset_s.value
        assert -0.6 < gt_off < 0.6 and 0.4 < dvl_off - gt_off < 1.6, (folder.name, gt_off, dvl_off)
        assert r.residual_rms < 0.02


def test_graph_mode_without_gt_recovers_lever_arm_and_dvl_offset():
    """No ground truth: the lever arm is a Point3 graph variable, the DVL offset the minimum of the
    graph's profile likelihood. 300 s, beams with 0.01 m/s noise; sigma ~0.02-0.07 m and ~0.03 s."""
    truth = SensorConfig()
    truth.dvl.lever_arm_b = TRUE_LEVER
    truth.dvl.beam_noise_std = 0.01
    m = simulate_mission(300.0, seed=5, config=truth)
    believed = SensorConfig.from_dict(m.config.to_dict())
    believed.dvl.lever_arm_b = np.zeros(3)
    m = dataclasses.replace(m, dvl=dataclasses.replace(m.dvl, t=m.dvl.t - TRUE_DVL_OFFSET), gt=None,
                            config=believed)
    r = calibrate(m, "graph", search_s=(-1.0, 1.0), step_s=0.5)
    assert r.mode == "graph" and r.gt_time_offset_s is None and r.axis_check.ok
    sigma = np.asarray(r.lever_arm_b.sigma)
    assert np.all(sigma < 0.1), sigma
    assert np.all(np.abs(r.lever_arm_b.value - TRUE_LEVER) < np.maximum(4 * sigma, 0.05)), r.lever_arm_b
    assert abs(r.dvl_time_offset_s.value - TRUE_DVL_OFFSET) < max(4 * r.dvl_time_offset_s.sigma, 0.05), \
        r.dvl_time_offset_s
    np.testing.assert_allclose(r.config.dvl.lever_arm_b, r.lever_arm_b.value)


def test_cli_writes_a_config_later_runs_accept(tmp_path, capsys):
    from graphnav.cli import main
    from graphnav.missions import load_mission
    out, report = tmp_path / "cal.json", tmp_path / "report.json"
    assert main(["calibrate", "--duration", "150", "--seed", "2", "--out", str(out), "--report", str(report)]) == 0
    text = capsys.readouterr().out
    assert "DVL lever arm" in text and "IMU axes" in text and "consistent" in text
    cfg = SensorConfig.load(out)
    # the simulated default has the Snapir lever arm; 150 s with the paper's beam noise: sigma ~0.15 m
    np.testing.assert_allclose(cfg.dvl.lever_arm_b, [-1.86, -0.04, 0.2], atol=0.6)
    m = load_mission(None, str(out), duration_s=30.0, seed=2)
    np.testing.assert_allclose(m.config.dvl.lever_arm_b, cfg.dvl.lever_arm_b)


def test_ground_truth_at_another_point_is_its_kinematics():
    """v of the moved GT equals the time derivative of its moved position (simulated, noiseless IMU)."""
    from graphnav.calibration.reference import ground_truth_at
    m = simulate_mission(60.0, seed=1, noiseless=True)
    r = np.array([-1.9, 0.1, -0.3])
    moved = ground_truth_at(m, r)
    dt = np.diff(moved.t)[:, None]
    v_num = np.diff(moved.p_n, axis=0) / dt
    v_mid = 0.5 * (moved.v_n[1:] + moved.v_n[:-1])
    assert np.max(np.abs(v_num - v_mid)) < 2e-3
    # moving the point changes the velocity where the vehicle rotates
    assert np.max(np.linalg.norm(moved.v_n - m.gt.v_n, axis=1)) > 0.01


@pytest.mark.realdata
def test_real_data_raw_y_axis_is_named_with_and_without_gt(akit_dir):
    """The published IMU files have y flipped: both checks name it (offsets fixed to skip "auto")."""
    from graphnav.io.loaders import list_akit
    from graphnav.missions import load_akit
    for folder in list_akit(akit_dir)[:3]:
        raw = load_akit(folder, imu_axis_signs=(1, 1, 1), gt_time_offset_s=0.0, dvl_time_offset_s=1.0)
        with_gt, _ = check_imu_axes_with_gt(raw)
        assert sorted(with_gt.suspects) == ["accelerometer y: sign flipped", "gyro y: sign flipped"], folder
        assert sorted(check_imu_axes_without_gt(raw).suspects) == ["accelerometer y: sign flipped",
                                                                   "gyro y: sign flipped"], folder
        fixed = load_akit(folder, gt_time_offset_s=0.0, dvl_time_offset_s=1.0)
        assert check_imu_axes_without_gt(fixed).ok and check_imu_axes_with_gt(fixed)[0].ok


def test_a_reference_too_sparse_for_the_accelerometer_is_named():
    from graphnav.calibration.dvl_fit import estimate_imu_position
    from graphnav.core.errors import DataError
    with pytest.raises(DataError, match=r"field 'gt.t': the GT has 0 sample interval"):
        estimate_imu_position(simulate_mission(20.0, seed=1, gt_rate_hz=0.1))


@pytest.mark.parametrize("gt_rate_hz", [10.0, 1.0])
def test_the_accelerometer_position_holds_with_a_sparse_reference(gt_rate_hz):
    """The simulated accelerometer sits at the GT point: found there within 4 sigma and 3 cm with a 10 Hz and with a
    1 Hz reference (A-KIT's rate). Taking the attitude at an interval's middle instead of averaging the gravity
    term over the interval put it 0.86 m too high with the 1 Hz reference of a rolling vehicle."""
    from graphnav.calibration.dvl_fit import estimate_imu_position
    r, cov, before, after = estimate_imu_position(simulate_mission(400.0, seed=3, gt_rate_hz=gt_rate_hz))
    sigma = np.sqrt(np.diag(cov))
    assert np.all(np.abs(r) < np.maximum(4 * sigma, 1e-3)) and np.all(np.abs(r) < 0.03), (r, sigma)
    assert after <= before


@pytest.mark.parametrize("gt_rate_hz", [10.0, 1.0])
def test_the_accelerometer_position_does_not_hang_on_where_the_gt_stamps_fall(gt_rate_hz):
    """The simulated GT stamps fall on IMU samples; half a microsecond later each boundary falls just after one. The
    GT's acceleration steps there: integrated sample by sample, the sample held across the boundary took one side's
    acceleration or the other's, and the position moved by up to 20 mm (10 Hz GT) for that half microsecond. The
    interval means of the rotation times each interval's constant acceleration do not see where the samples fall."""
    from graphnav.calibration.dvl_fit import estimate_imu_position
    mission = simulate_mission(300.0, seed=21, gt_rate_hz=gt_rate_hz)
    late = dataclasses.replace(mission, gt=dataclasses.replace(mission.gt, t=mission.gt.t + 5e-7))
    r, cov, _, _ = estimate_imu_position(mission)
    r_late = estimate_imu_position(late)[0]
    assert np.max(np.abs(r_late - r)) < 0.1 * np.min(np.sqrt(np.diag(cov))), (r, r_late)


def test_the_positions_are_labelled_with_the_point_they_are_measured_from(mission):
    """GT mode measures the lever arm and the accelerometer from the point the mission's GT stands for. ``prepare``
    moves an A-KIT GT to the IMU point (``meta["gt_point_b"]``, [-1.86, -0.04, 0.2] m from the published GT point):
    the report says "vs IMU point" and gives both positions from the GT as recorded too. It said "vs GT point" for
    numbers measured from the IMU point, 1.9 m away."""
    from graphnav.calibration.combine import combine, incompatibility
    moved = np.array([-1.86, -0.04, 0.2])
    r = calibrate(dataclasses.replace(mission, meta={**mission.meta, "gt_point_b": moved.tolist()}), "gt")
    np.testing.assert_array_equal(r.gt_point_b, moved)
    np.testing.assert_allclose(r.lever_arm_b.value, TRUE_LEVER, atol=0.06)    # the GT is the truth at the IMU
    text = r.report()
    assert "DVL lever arm vs IMU point: [" in text and "accelerometer vs IMU point: [" in text
    assert "GT point" not in text.split("(lever arm")[0]
    dvl = ", ".join(f"{x:+.3f}" for x in np.asarray(r.lever_arm_b.value) + moved)
    accel = ", ".join(f"{x:+.3f}" for x in np.asarray(r.imu_position_b.value) + moved)
    assert (f"(the IMU point is [-1.860, -0.040, +0.200] m from the GT point as recorded; from there the DVL is at "
            f"[{dvl}] m, the accelerometer at [{accel}] m)") in text
    assert r.to_dict()["reference_point"] == {"point": "IMU point", "frame": "body", "gt_point_b": moved.tolist()}
    np.testing.assert_array_equal(r.config.dvl.lever_arm_b, r.lever_arm_b.value)    # written from the IMU point
    as_recorded = dataclasses.replace(r, gt_point_b=None)           # a GT the loader did not move (a bag's)
    text = as_recorded.report()
    assert "DVL lever arm vs GT point : [" in text and "accelerometer vs GT point : [" in text
    assert "from the GT point as the log holds it" in text and "IMU point is" not in text
    assert "DVL lever arm vs IMU point: [" in combine([r, r], ["a", "b"]).report()
    assert incompatibility(r, as_recorded).startswith("gt_point_b: lever arm measured from the point GT point, not "
                                                      "IMU point [-1.86, -0.04, 0.2] m from the GT")


def test_a_dvl_too_short_for_the_gt_fit_is_refused_naming_its_file():
    """A simulated 60 s mission whose DVL file holds its first 15 pings only: the GT calibration refused it as 'dvl:
    fewer than 20 DVL pings overlap the ground truth', naming no file. It names the DVL's file and its stamp field,
    how many pings overlap of those usable and the span they must lie in."""
    import warnings

    from graphnav.calibration.calibrate import calibrate_with_gt
    from graphnav.core.errors import DataError
    m = simulate_mission(duration_s=60.0, seed=3)
    m = dataclasses.replace(m, dvl=dataclasses.replace(m.dvl.take(np.arange(15)), source="logs/dvl.csv"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=r"^logs/dvl\.csv, field 't': \d+ of the \d+ usable DVL pings overlap the "
                                            r"ground truth and the IMU \(\[0\.000, 60\.000\] s\) at every time offset "
                                            r"searched \(-3 to \+3 s\): the DVL fit needs 20$"):
            calibrate_with_gt(m)
