"""Several missions' calibrations combined (graphnav.calibration.combine, ``graphnav calibrate --data A B ...``).

The random-effects estimator is held to statsmodels' DerSimonian-Laird (someone else's code); its point, that the
next mission's value falls within the next-mission sigma where the per-mission sigmas do not cover it, is checked by
a seeded Monte Carlo and on simulated missions whose DVL mounting differs between missions.
"""
from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graphnav.calibration.calibrate import calibrate
from graphnav.calibration.combine import PER_MISSION_KEYS, combine, random_effects
from graphnav.core.errors import DataError
from tests.test_calibration import TRUE_LEVER, TRUE_YAW, miscalibrated_mission


@pytest.mark.parametrize("seed", [0, 2, 3, 4])
def test_random_effects_is_statsmodels_dersimonian_laird(seed):
    meta = pytest.importorskip("statsmodels.stats.meta_analysis")
    rng = np.random.default_rng(seed)
    k = 4 + 3 * seed
    s = rng.uniform(0.2, 2.0, k)
    y = 3.0 + rng.normal(0.0, 1.0, k) * np.sqrt(s ** 2 + 0.8)
    ours = random_effects(y, s)
    theirs = meta.combine_effects(y, s ** 2, method_re="dl")
    # statsmodels leaves a negative moment estimate of tau^2 as it is (seed 1 here); DerSimonian-Laird, and this
    # module, truncate it at 0 (test_equal_missions_give_the_inverse_variance_mean)
    assert theirs.tau2 > 0
    np.testing.assert_allclose(ours.value, theirs.mean_effect_re, rtol=1e-10)
    np.testing.assert_allclose(ours.sigma, theirs.sd_eff_w_re, rtol=1e-10)
    np.testing.assert_allclose(ours.between_sigma ** 2, theirs.tau2, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(ours.q_per_dof * (k - 1), theirs.q, rtol=1e-10)


def test_equal_missions_give_the_inverse_variance_mean():
    s = np.array([0.1, 0.2, 0.4])
    ours = random_effects(np.array([1.0, 1.0, 1.0]), s)
    assert ours.between_sigma == 0 and ours.value == pytest.approx(1.0)
    assert ours.sigma == pytest.approx(1 / np.sqrt(np.sum(1 / s ** 2)))
    assert ours.next_mission_sigma == pytest.approx(ours.sigma) and ours.p == pytest.approx(1.0)


def test_unusable_missions_are_left_out_column_by_column():
    values = np.array([[1.0, 2.0], [np.nan, 2.2], [1.2, 2.1]])
    sigmas = np.array([[0.1, 0.1], [0.1, 0.0], [0.1, 0.1]])
    ours = random_effects(values, sigmas)
    assert ours.n.tolist() == [2, 2]
    assert ours.value[0] == pytest.approx(1.1) and ours.value[1] == pytest.approx(2.05)
    one = random_effects(np.array([5.0, np.nan]), np.array([0.3, 0.1]))
    assert one.value == 5.0 and one.sigma == 0.3 and np.isnan(one.between_sigma) and np.isnan(one.p)


def test_the_next_mission_sigma_covers_missions_that_differ():
    """Ten missions whose true values scatter twice their sigmas: each held out against the other nine."""
    rng = np.random.default_rng(7)
    z_fixed, z_re = [], []
    for _ in range(300):
        s = rng.uniform(0.5, 1.5, 10)
        y = rng.normal(0.0, 2.0, 10) + rng.normal(0.0, 1.0, 10) * s
        i, rest = 0, np.arange(1, 10)
        w = 1 / s[rest] ** 2
        z_fixed.append((y[i] - np.sum(w * y[rest]) / np.sum(w)) / np.hypot(s[i], 1 / np.sqrt(np.sum(w))))
        re = random_effects(y[rest], s[rest])
        z_re.append((y[i] - re.value) / np.hypot(s[i], re.next_mission_sigma))
    within_fixed, within_re = np.mean(np.abs(z_fixed) < 2), np.mean(np.abs(z_re) < 2)
    assert within_fixed < 0.75            # the per-mission sigmas alone: about 0.6
    assert 0.88 < within_re < 0.99        # 0.95 for a Gaussian; DL's tau from nine missions is a little short


@pytest.mark.parametrize("k", [4, 6])
def test_the_95_percent_interval_holds_with_few_missions(k):
    """k missions whose true values scatter twice their sigmas; a next one drawn from the same spread: the interval
    of t with k - 2 degrees of freedom covers it about 95 % of the time (92-93 % with six missions: DL's tau),
    1.96 next-mission sigmas far less."""
    rng = np.random.default_rng(11 + k)
    gaussian, student = [], []
    for _ in range(4000):
        s = rng.uniform(0.5, 1.5, k)
        truth = rng.normal(0.0, 2.0, k + 1)
        re = random_effects(truth[:k] + rng.normal(0.0, 1.0, k) * s, s)
        miss = abs(truth[k] - re.value)
        gaussian.append(miss < 1.96 * re.next_mission_sigma)
        student.append(miss < re.next_mission_95)
    assert np.mean(gaussian) < 0.88                 # 0.80 and 0.85 here (0.80-0.81, 0.84-0.86 over four seeds)
    assert 0.90 < np.mean(student) < 0.98           # 0.94 and 0.925 here (0.94-0.95, 0.92-0.93); 0.95 if exact
    assert np.isnan(random_effects(np.array([0.0, 1.0]), np.array([0.1, 0.1])).next_mission_95)


@pytest.fixture(scope="module")
def three_mountings():
    """Three missions of one vehicle whose DVL mounting yaw differs by about 0.3 deg (seeded), lever arm the same."""
    yaws = TRUE_YAW + np.deg2rad([-0.3, 0.0, 0.35])
    results = [calibrate(miscalibrated_mission(seed=3 + i, duration=300.0, yaw=y), "gt") for i, y in enumerate(yaws)]
    return yaws, results


def test_combined_calibration_flags_the_mounting_that_differs(three_mountings):
    yaws, results = three_mountings
    combined = combine(results, ["a", "b", "c"])
    assert "dvl_yaw_rad" in combined.differing() and "lever_arm_b" not in combined.differing()
    yaw = combined.quantities["dvl_yaw_rad"]
    per_mission = np.array([float(r.dvl_yaw_rad.sigma) for r in results])
    assert yaw.next_mission_sigma > 5 * np.max(per_mission)        # the scatter, not the per-mission sigma
    assert abs(float(yaw.value) - np.mean(yaws)) < 2 * float(yaw.sigma)
    np.testing.assert_allclose(combined.quantities["lever_arm_b"].value, TRUE_LEVER, atol=0.05)
    cfg = combined.config_dict()
    assert not set(PER_MISSION_KEYS) & set(cfg)
    text = combined.report()
    assert "DVL mounting yaw" in text and "MISSIONS DIFFER" in text and "next mission" in text


def test_missions_of_different_imu_mountings_are_refused(three_mountings):
    _, results = three_mountings
    other = copy.deepcopy(results[1])
    other.config.imu_axis_signs = np.array([1.0, -1.0, 1.0])
    with pytest.raises(DataError, match="imu_axis_signs"):
        combine([results[0], other], ["a", "b"])
    other = copy.deepcopy(results[1])
    other.config.dvl.velocity_scale_correction += 0.01
    with pytest.raises(DataError, match="starting scale correction"):
        combine([results[0], other], ["a", "b"])


def test_the_combined_mounting_and_scale_are_laid_on_the_starting_ones(three_mountings):
    """Missions calibrated from a configuration with a mounting and a scale correction of its own: the written
    C_d_b is Rz(combined yaw) times that start, the scale correction (1 + start)(1 + combined) - 1."""
    _, results = three_mountings
    start_mounting = Rotation.from_euler("xz", [180.0, 45.0], degrees=True).as_matrix()
    start_scale = 0.004
    moved = []
    for r in results:
        r = copy.deepcopy(r)
        r.config.dvl.C_d_b = Rotation.from_euler("z", float(r.dvl_yaw_rad.value)).as_matrix() @ start_mounting
        r.config.dvl.velocity_scale_correction = (1 + start_scale) * (1 + float(r.dvl_scale.value)) - 1
        moved.append(r)
    combined = combine(moved, ["a", "b", "c"])
    yaw, scale = float(combined.quantities["dvl_yaw_rad"].value), float(combined.quantities["dvl_scale"].value)
    assert abs(yaw - float(moved[0].dvl_yaw_rad.value)) > 1e-3         # not the first mission's
    np.testing.assert_allclose(combined.config.dvl.C_d_b,
                               Rotation.from_euler("z", yaw).as_matrix() @ start_mounting, atol=1e-12)
    assert combined.config.dvl.velocity_scale_correction == pytest.approx((1 + start_scale) * (1 + scale) - 1,
                                                                          abs=1e-15)
    np.testing.assert_allclose(combined.config.dvl.lever_arm_b, combined.quantities["lever_arm_b"].value)


def test_cli_combines_folders_and_keeps_the_others_when_one_cannot_be_read(tmp_path, capsys):
    from graphnav.cli import main
    folders = []
    for seed in (1, 2):
        folder = tmp_path / f"sim{seed}"
        assert main(["simulate", "--duration", "150", "--seed", str(seed), "--out", str(folder)]) == 0
        folders.append(str(folder))
    broken = tmp_path / "broken" / "Trajectory9"
    broken.mkdir(parents=True)
    (broken / "IMU_trajectory9.csv").write_text("not a log\n")
    capsys.readouterr()
    out, report = tmp_path / "vehicle.json", tmp_path / "report.json"
    code = main(["calibrate", "--data", *folders, str(broken), "--no-noise", "--out", str(out), "--report",
                 str(report)])
    captured = capsys.readouterr()
    assert code == 1 and "Trajectory9" in captured.err and "not calibrated" in captured.err
    assert "combined over 2 missions" in captured.out
    written = json.loads(out.read_text())
    assert not set(PER_MISSION_KEYS) & set(written)
    np.testing.assert_allclose(written["dvl"]["lever_arm_b"], [-1.86, -0.04, 0.2], atol=0.6)
    data = json.loads(report.read_text())
    assert len(data["missions"]) == 2 and data["not_calibrated"] == [str(broken)]
    assert data["combined"]["lever_arm_b"]["n"] == [2, 2, 2]
    np.testing.assert_allclose(written["dvl"]["lever_arm_b"], data["combined"]["lever_arm_b"]["value"])
    # both simulated missions are Trajectory1: named by their paths
    assert [m["name"] for m in data["missions"]] == [str(Path(f) / "Trajectory1") for f in folders]

    # a mission given twice counts once; with one mission left of several, nothing is combined and the written
    # configuration is still without that mission's own clocks
    capsys.readouterr()
    code = main(["calibrate", "--data", folders[0], str(Path(folders[0]) / "Trajectory1"), str(broken), "--no-noise",
                 "--out", str(out), "--report", str(report), "--force"])
    captured = capsys.readouterr()
    assert code == 1 and "given twice, counted once" in captured.err and "nothing to combine" in captured.out
    written = json.loads(out.read_text())
    assert not set(PER_MISSION_KEYS) & set(written)
    assert len(json.loads(report.read_text())["missions"]) == 1


def test_the_noise_is_written_as_the_missions_rms_and_its_range_named(three_mountings):
    from graphnav.calibration.noise import ESTIMATOR_DENSITY_FACTOR, NoiseEstimate
    _, results = three_mountings
    noisy = []
    for r, (acc, gyro, beam) in zip(results, [(1e-3, 1e-5, 0.04), (2e-3, 2e-5, 0.05), (4e-3, 1e-5, 0.03)]):
        r = copy.deepcopy(r)
        r.noise = NoiseEstimate(acc, gyro, beam_noise_std=beam, density_source="gt")
        noisy.append(r)
    combined = combine(noisy, ["a", "b", "c"])
    f_acc, f_gyro = ESTIMATOR_DENSITY_FACTOR["gt"]
    assert combined.config.imu.accel_noise_density == pytest.approx(f_acc * np.sqrt(np.mean(np.square([1e-3, 2e-3,
                                                                                                        4e-3]))))
    assert combined.config.imu.gyro_noise_density == pytest.approx(f_gyro * np.sqrt(np.mean(np.square([1e-5, 2e-5,
                                                                                                        1e-5]))))
    assert combined.config.dvl.beam_noise_std == pytest.approx(np.sqrt(np.mean(np.square([0.04, 0.05, 0.03]))))
    note = next(n for n in combined.notes if n.startswith("noise densities"))
    assert f"{f_acc * 1e-3:.2e}..{f_acc * 4e-3:.2e}" in note and "0.0300..0.0500 m/s" in note
