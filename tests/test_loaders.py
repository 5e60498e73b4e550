"""CSV reading and A-KIT/BeamsNet loading on small synthetic files (no real data needed)."""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from graphnav.core.earth import WGS84_A
from graphnav.core.errors import DataError
from graphnav.io.loaders import (
    AKIT_COLUMNS,
    AKIT_IMU_POSITION_B,
    AKIT_LEVER_ARM_B,
    beamsnet_split,
    list_akit,
    load_beamsnet,
    read_csv,
)
from graphnav.missions import load_akit


def write_csv(path, columns, rows):
    lines = [",".join(columns)] + [",".join(str(v) for v in row) if not isinstance(row, str) else row
                                   for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def make_akit_folder(root, n=3, seconds=120, yaw_rate=0.05):
    """A small A-KIT folder: level vehicle, 1.5 m/s forward, constant yaw rate, stamps as published
    (``linspace(0, seconds, N)``; over 100 rows, as the loader's rescale asks), IMU y axis stored flipped like
    the published files."""
    folder = root / f"Trajectory{n}"
    folder.mkdir(parents=True)
    lat, lon, g = 0.5733, 0.6089, 9.7949
    n_imu, n_1hz = seconds * 100, seconds
    t_imu = np.linspace(0, seconds, n_imu)
    imu = np.zeros((n_imu, 7))
    imu[:, 0] = t_imu
    imu[:, 2] = -(yaw_rate * 1.5)       # centripetal specific force is +y (right turn), stored flipped
    imu[:, 3] = -g
    imu[:, 6] = yaw_rate
    t1 = np.linspace(0, seconds, n_1hz)
    k = np.arange(n_1hz)                # true stamps are k * 1 s
    yaw = yaw_rate * k
    gt = np.zeros((n_1hz, 10))
    gt[:, 0] = t1
    gt[:, 1], gt[:, 2], gt[:, 3] = lon, lat, -15.0
    gt[:, 4], gt[:, 5] = 1.5 * np.cos(yaw), 1.5 * np.sin(yaw)
    gt[:, 9] = yaw
    # positions that follow the velocity, as a navigation solution's do (the loader checks that they do)
    north, east = (np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2)]) for v in (gt[:, 4], gt[:, 5]))
    gt[:, 2], gt[:, 1] = lat + north / WGS84_A, lon + east / (WGS84_A * np.cos(lat))
    dvl = np.zeros((n_1hz, 4))
    dvl[:, 0] = t1
    dvl[:, 1] = 1.5
    dvl[:, 2] = yaw_rate * -1.86        # omega x l with l = (-1.86, 0, 0)
    write_csv(folder / f"IMU_trajectory{n}.csv", AKIT_COLUMNS["IMU"], imu.tolist())
    write_csv(folder / f"GT_trajectory{n}.csv", AKIT_COLUMNS["GT"], gt.tolist())
    write_csv(folder / f"DVL_trajectory{n}.csv", AKIT_COLUMNS["DVL"], dvl.tolist())
    return folder


COLS = AKIT_COLUMNS["DVL"]


def good_rows(n=5):
    return [[float(i), 1.0, 0.1, 0.0] for i in range(n)]


def test_read_csv_good(tmp_path):
    p = write_csv(tmp_path / "DVL_x.csv", COLS, good_rows())
    data = read_csv(p, COLS)
    assert data.shape == (5, 4)
    np.testing.assert_allclose(data[:, 0], np.arange(5))


def test_missing_column_named(tmp_path):
    p = write_csv(tmp_path / "DVL_x.csv", COLS[:2] + ("DVL Q [m/s]",) + COLS[3:], good_rows())
    with pytest.raises(DataError) as err:
        read_csv(p, COLS)
    assert err.value.source == str(p) and err.value.line == 1 and err.value.field == "DVL Y [m/s]"
    assert "DVL Y [m/s]" in str(err.value) and str(p) in str(err.value)


@pytest.mark.parametrize("bad_line, field, words", [
    ("2.0,1.0,0.1", "DVL Y [m/s]", "truncated"),
    ("2.0,1.0,abc,0.0", "DVL Y [m/s]", "not a number"),
    ("2.0,1.0,,0.0", "DVL Y [m/s]", "not a number"),
    ("2.0,1.0,0.1,0.0,7", "DVL Z [m/s]", "too many"),
])
def test_bad_line_reported_with_line_and_field(tmp_path, bad_line, field, words):
    rows = good_rows()
    rows[2] = bad_line                  # data row 2 is file line 4 (header is line 1)
    p = write_csv(tmp_path / "DVL_x.csv", COLS, rows)
    with pytest.raises(DataError) as err:
        read_csv(p, COLS)
    e = err.value
    assert (e.source, e.line, e.field) == (str(p), 4, field)
    assert words in str(e) and "line 4" in str(e)


def test_every_bad_line_listed(tmp_path):
    rows = good_rows(8)
    rows[1] = "1.0,x,0.1,0.0"
    rows[5] = "5.0,1.0"
    p = write_csv(tmp_path / "DVL_x.csv", COLS, rows)
    with pytest.raises(DataError) as err:
        read_csv(p, COLS)
    assert err.value.line == 3
    assert [prob[0] for prob in err.value.problems] == [3, 7]
    assert "2 bad line(s)" in str(err.value)


def test_nan_rejected_unless_allowed(tmp_path):
    rows = good_rows()
    rows[3][2] = float("nan")
    p = write_csv(tmp_path / "DVL_x.csv", COLS, rows)
    with pytest.raises(DataError) as err:
        read_csv(p, COLS)
    assert (err.value.line, err.value.field) == (5, "DVL Y [m/s]")
    data = read_csv(p, COLS, nan_ok=COLS[1:])
    assert np.isnan(data[3, 2])


def test_nan_time_rejected_even_if_values_may_be_nan(tmp_path):
    rows = good_rows()
    rows[4][0] = float("nan")
    p = write_csv(tmp_path / "DVL_x.csv", COLS, rows)
    with pytest.raises(DataError) as err:
        read_csv(p, COLS, nan_ok=COLS[1:])
    assert (err.value.line, err.value.field) == (6, "Time [s]")


@pytest.mark.parametrize("stamps, kind, line", [([0, 1, 1, 2, 3], "duplicated", 4),
                                                ([0, 1, 3, 2, 4], "out of order", 5)])
def test_bad_stamps(tmp_path, stamps, kind, line):
    rows = [[float(s), 1.0, 0.1 * i, 0.0] for i, s in enumerate(stamps)]      # a repeated stamp, other values
    p = write_csv(tmp_path / "DVL_x.csv", COLS, rows)
    with pytest.raises(DataError) as err:
        read_csv(p, COLS)
    assert kind in str(err.value) and (err.value.line, err.value.field) == (line, "Time [s]")
    with pytest.warns(UserWarning, match="repaired"):
        data = read_csv(p, COLS, repair=True)
    assert np.all(np.diff(data[:, 0]) > 0) and len(data) == len(set(stamps))


def test_blank_lines_do_not_shift_line_numbers(tmp_path):
    rows = good_rows()
    rows.insert(1, "")
    rows[4] = "3.0,oops,0.1,0.0"
    p = write_csv(tmp_path / "DVL_x.csv", COLS, rows)
    with pytest.raises(DataError) as err:
        read_csv(p, COLS)
    assert err.value.line == 6


def test_list_and_load_akit(tmp_path):
    folder = make_akit_folder(tmp_path, n=3)
    make_akit_folder(tmp_path, n=12)
    (tmp_path / "Trajectory7").mkdir()                       # incomplete folders are not listed
    assert [p.name for p in list_akit(tmp_path)] == ["Trajectory3", "Trajectory12"]
    m = load_akit(folder, dvl_time_offset_s=0.5, gt_time_offset_s=-0.25)
    cfg = m.config
    assert cfg.dvl_time_offset_s == 0.5 and cfg.gt_time_offset_s == -0.25
    np.testing.assert_allclose(cfg.imu_axis_signs, [1, -1, 1])
    # stamps rescaled from linspace(0, 120, N) to k / rate, then shifted
    np.testing.assert_allclose(m.imu.t[:3], [0.0, 0.01, 0.02], atol=1e-12)
    np.testing.assert_allclose(m.gt.t[:3], [-0.25, 0.75, 1.75], atol=1e-12)
    np.testing.assert_allclose(m.dvl.t[:2], [0.5, 1.5], atol=1e-12)
    assert m.imu.f_b[0, 1] > 0                              # flipped y specific force is right again
    # the GT is moved to the IMU point, 0.2 m below the published GT point (level vehicle)
    np.testing.assert_allclose(m.depth.depth, 15.0 + 0.2, atol=1e-3)     # + the NED frame's curvature drop
    assert m.meta["depth_source"] == "gt"
    # NED origin at the surface above the first fix: down is the absolute depth (one position convention)
    assert m.gt.origin_lla[2] == 0.0
    np.testing.assert_allclose(m.gt.p_n[0], np.asarray(AKIT_IMU_POSITION_B) + [0.0, 0.0, 15.0], atol=1e-9)
    np.testing.assert_allclose(m.gt.p_n[:, 2], m.depth.depth)
    np.testing.assert_allclose(m.config.dvl.lever_arm_b, 0.0, atol=1e-12)
    at_gt_point = load_akit(folder, dvl_time_offset_s=0.5, gt_time_offset_s=-0.25, imu_position_b=(0, 0, 0))
    np.testing.assert_allclose(at_gt_point.depth.depth, 15.0, atol=1e-3)
    np.testing.assert_allclose(at_gt_point.gt.p_n[0], [0.0, 0.0, 15.0], atol=1e-9)
    np.testing.assert_allclose(at_gt_point.config.dvl.lever_arm_b, AKIT_LEVER_ARM_B)
    assert m.dvl.valid.all() and m.dvl.beams.shape == (120, 4)
    np.testing.assert_allclose(m.dvl.v_b[:, 0], 1.5)
    assert abs(cfg.lat_rad - 0.5733) < 1e-12 and 9.78 < cfg.gravity_mps2 < 9.81


def test_load_akit_auto_offsets_on_synthetic_turn(tmp_path):
    """With the IMU and GT consistent and no offsets, "auto" finds ~0 for both."""
    folder = make_akit_folder(tmp_path, n=1, yaw_rate=0.0)
    # add a yaw-rate step so that the attitude and velocity carry timing information
    imu_path = folder / "IMU_trajectory1.csv"
    imu = read_csv(imu_path, AKIT_COLUMNS["IMU"])
    t_true = np.arange(len(imu)) * 0.01
    rate = 0.08 * np.sin(2 * np.pi * t_true / 10.0)
    imu[:, 6] = rate
    imu[:, 2] = -rate * 1.5
    write_csv(imu_path, AKIT_COLUMNS["IMU"], imu.tolist())
    gt = read_csv(folder / "GT_trajectory1.csv", AKIT_COLUMNS["GT"])
    k = np.arange(len(gt))
    yaw = 0.08 * 10.0 / (2 * np.pi) * (1 - np.cos(2 * np.pi * k / 10.0))
    gt[:, 9] = yaw
    gt[:, 4], gt[:, 5] = 1.5 * np.cos(yaw), 1.5 * np.sin(yaw)
    write_csv(folder / "GT_trajectory1.csv", AKIT_COLUMNS["GT"], gt.tolist())
    dvl = read_csv(folder / "DVL_trajectory1.csv", AKIT_COLUMNS["DVL"])
    dvl[:, 2] = 0.08 * np.sin(2 * np.pi * k / 10.0) * -1.86
    write_csv(folder / "DVL_trajectory1.csv", AKIT_COLUMNS["DVL"], dvl.tolist())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_akit(folder, lever_arm_b=(-1.86, 0.0, 0.0), imu_position_b=(0, 0, 0), imu_axis_signs=(1, -1, 1))
    assert abs(m.config.gt_time_offset_s) < 0.03
    assert abs(m.config.dvl_time_offset_s) < 0.05


def test_dvl_nan_rows_are_invalid_pings(tmp_path):
    folder = make_akit_folder(tmp_path, n=2)
    p = folder / "DVL_trajectory2.csv"
    lines = p.read_text().splitlines()
    lines[5] = f"{4 * 120 / 119!r},nan,nan,nan"
    p.write_text("\n".join(lines) + "\n")
    m = load_akit(folder, dvl_time_offset_s=0.0, gt_time_offset_s=0.0)
    assert not m.dvl.valid[4].any() and m.dvl.valid[np.arange(120) != 4].all()
    assert np.isnan(m.dvl.beams[4]).all()


def test_a_nan_dvl_row_is_warned_about_at_its_file_line(tmp_path):
    """The no-valid-beam warning names the DVL file's line (header = line 1), as the loader's other messages do,
    not the ping's index."""
    from graphnav.io.loaders import read_mission
    folder = make_akit_folder(tmp_path, n=2)
    p = folder / "DVL_trajectory2.csv"
    lines = p.read_text().splitlines()
    lines[5] = f"{4 * 120 / 119!r},nan,nan,nan"          # line 6 of the file
    p.write_text("\n".join(lines) + "\n")
    with pytest.warns(RuntimeWarning, match=r"DVL_trajectory2.csv: 1 of 120 DVL ping\(s\) have no valid beam \(first "
                                            r"at line 6, t = .*\): nothing is measured there; only the hybrid "
                                            r"methods use them, with the beams their completer regresses"):
        read_mission(folder)


def test_an_akit_dvl_file_without_one_usable_ping_is_refused_naming_the_file_and_column(tmp_path):
    """A DVL that never had bottom lock (every row NaN or empty) is refused naming the file, the column and the
    count, as a column-map log's is (before: ZeroDivisionError in the DVL time-offset fit against the GT)."""
    from graphnav.missions import load_mission
    folder = make_akit_folder(tmp_path, n=2)
    p = folder / "DVL_trajectory2.csv"
    lines = p.read_text().splitlines()
    p.write_text("\n".join([lines[0]] + [line.split(",")[0] + (",nan,nan,nan" if k % 2 else ",,,")
                                          for k, line in enumerate(lines[1:])]) + "\n")
    with pytest.warns(RuntimeWarning), pytest.raises(DataError, match=r"no usable DVL ping: all 120 refused "
                                                                      r"\(120 no valid beam") as err:
        load_mission(folder)
    assert err.value.source.endswith("DVL_trajectory2.csv") and err.value.field == "DVL X [m/s]"


def test_missing_file_named(tmp_path):
    folder = make_akit_folder(tmp_path, n=4)
    (folder / "DVL_trajectory4.csv").unlink()
    with pytest.raises(DataError, match="DVL_trajectory4.csv"):
        load_akit(folder)


def test_folder_without_gt_loads_as_a_vehicle_has_it(tmp_path):
    """IMU and DVL only: no ground truth, no depth (A-KIT's is the GT's), the DVL offset from the vehicle's
    measured constant with a warning (it cannot be estimated against a missing GT)."""
    from graphnav.io.loaders import AKIT_DVL_TIME_OFFSET_S
    folder = make_akit_folder(tmp_path, n=4)
    (folder / "GT_trajectory4.csv").unlink()
    with pytest.warns(RuntimeWarning, match="no GT file"):
        m = load_akit(folder, imu_axis_signs=(1, -1, 1))
    assert m.gt is None and m.depth is None and m.meta["ground_truth"] is False
    assert m.config.dvl_time_offset_s == AKIT_DVL_TIME_OFFSET_S
    m = load_akit(folder, imu_axis_signs=(1, -1, 1), dvl_time_offset_s=0.5)
    assert m.config.dvl_time_offset_s == 0.5


@pytest.mark.parametrize("resolution", [0.0, 0.001])
def test_a_dvl_velocity_held_within_its_noise_judges_nothing(tmp_path, resolution):
    """A steady turn at a constant speed, noiseless or at a 1 mm/s resolution: the DVL's velocity changes by nothing
    its fits could judge by. Before, the gyro was converted as deg/s (residuals of a zero variance compared) and the
    DVL then refused as 0.02x; now neither is judged, with notes saying so."""
    folder = make_akit_folder(tmp_path, n=4)
    (folder / "GT_trajectory4.csv").unlink()
    if resolution:
        path = folder / "DVL_trajectory4.csv"
        dvl = np.loadtxt(path, delimiter=",", skiprows=1)
        noise = np.random.default_rng(3).normal(0.0, resolution, (len(dvl), 3))
        dvl[:, 1:4] = np.round((dvl[:, 1:4] + noise) / resolution) * resolution
        write_csv(path, AKIT_COLUMNS["DVL"], dvl.tolist())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_akit(folder, imu_axis_signs=(1, -1, 1))
    assert not [w for w in caught if "deg/s" in str(w.message) or "DVL velocity is" in str(w.message)]
    notes = m.meta["streams"]
    assert any("gyro's scale is not judged" in n and "within its noise" in n for n in notes["imu"]["notes"])
    assert any("not judged against the IMU" in n and "within its noise" in n for n in notes["dvl"]["notes"])
    assert np.allclose(m.imu.omega_b[:, 2], 0.05)


@pytest.mark.parametrize("turn", [90.0, 180.0, 0.0, 45.0])
def test_a_dvl_pointing_sideways_on_a_straight_leg_is_warned_about_and_counted(tmp_path, turn):
    """A straight leg at constant speed with 2 mm/s of DVL noise: no fit judges the DVL's turn. A velocity turned 90
    or 180 deg (a turned DVL read as body) used to load with notes only; its mean direction from body x now gives a
    warning naming the file, columns and direction, and the pings are counted as doubted. Forward, or 45 deg (within
    the bound a crabbing hull is allowed), nothing is said."""
    from graphnav.calibration.dvl_scale import SIDEWAYS_DOUBT
    folder = make_akit_folder(tmp_path, n=4, yaw_rate=0.0, seconds=200)
    (folder / "GT_trajectory4.csv").unlink()
    path = folder / "DVL_trajectory4.csv"
    dvl = np.loadtxt(path, delimiter=",", skiprows=1)
    c, s = np.cos(np.radians(turn)), np.sin(np.radians(turn))
    dvl[:, 1], dvl[:, 2] = c * dvl[:, 1] - s * dvl[:, 2], s * dvl[:, 1] + c * dvl[:, 2]
    dvl[:, 1:4] += np.random.default_rng(1).normal(0.0, 0.002, (len(dvl), 3))
    write_csv(path, AKIT_COLUMNS["DVL"], dvl.tolist())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_akit(folder, imu_axis_signs=(1, -1, 1))
    said = [str(w.message) for w in caught if "on average over the log" in str(w.message)]
    if turn in (0.0, 45.0):
        assert not said and "doubted" not in m.meta["streams"]["dvl"]
        return
    assert len(said) == 1 and said[0].startswith(f"{path}: field 'DVL X [m/s]/DVL Y [m/s]/DVL Z [m/s]': the DVL "
                                                 f"velocity points +{turn:.0f} deg about z from body x"), said
    assert m.meta["streams"]["dvl"]["doubted"] == {SIDEWAYS_DOUBT: len(dvl)}


@pytest.mark.parametrize("seed", [1, 3])
def test_a_dvl_error_drifting_on_a_steady_turn_does_not_judge_a_good_gyro(tmp_path, seed):
    """A steady turn whose DVL error drifts slowly (3 mm/s, a 50-ping memory): its second differences are small, so
    the floor takes the velocity's changes for signal, but no gyro scale explains them (each leaves more than a
    straight line per window). Before, the rates x0.01745 left 'less' unexplained (1.1 against 9.9) and a good gyro
    was converted as deg/s; now it is not judged, with the note saying why."""
    folder = make_akit_folder(tmp_path, n=4)
    (folder / "GT_trajectory4.csv").unlink()
    path = folder / "DVL_trajectory4.csv"
    dvl = np.loadtxt(path, delimiter=",", skiprows=1)
    e = np.random.default_rng(seed).normal(0.0, 0.003, (len(dvl), 3))
    for i in range(1, len(e)):
        e[i] = 0.98 * e[i - 1] + np.sqrt(1 - 0.98 ** 2) * e[i]
    dvl[:, 1:4] += e
    write_csv(path, AKIT_COLUMNS["DVL"], dvl.tolist())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_akit(folder, imu_axis_signs=(1, -1, 1))
    assert not [w for w in caught if "deg/s" in str(w.message)]
    assert any("no scale explains its velocity's changes" in n for n in m.meta["streams"]["imu"]["notes"])
    assert np.allclose(m.imu.omega_b[:, 2], 0.05)


def test_beamsnet(tmp_path):
    rng = np.random.default_rng(0)
    np.save(tmp_path / "V.npy", rng.normal(size=(3, 100)))
    np.save(tmp_path / "V_test.npy", rng.normal(size=(3, 20)))
    d = load_beamsnet(tmp_path)
    train, val = beamsnet_split(d["V"])
    assert train.shape == (3, 75) and val.shape == (3, 25)
    np.testing.assert_array_equal(np.concatenate([train, val], axis=1), d["V"])
    bad = rng.normal(size=(3, 10))
    bad[1, 7] = np.nan
    np.save(tmp_path / "V_test.npy", bad)
    with pytest.raises(DataError) as err:
        load_beamsnet(tmp_path)
    assert err.value.line == 7 and err.value.field == "y"
    np.save(tmp_path / "V.npy", rng.normal(size=(4, 10)))
    with pytest.raises(DataError, match=r"\(3, N\)"):
        load_beamsnet(tmp_path)


def test_a_dvl_in_another_frame_is_refused_against_the_gt(tmp_path):
    """DVL x and y swapped in an A-KIT folder (a DVL logged in another frame): no time offset makes it follow
    the GT's body velocity, and the load stops naming the DVL file, instead of navigating 1.7 m/s off."""
    from graphnav.io.export import write_akit
    from graphnav.sim.simulate import simulate_mission
    mission = simulate_mission(duration_s=120.0, seed=1)
    files = write_akit(mission, tmp_path, 1)
    lines = files["DVL"].read_text().splitlines()
    swapped = [lines[0]] + [",".join([c[0], c[2], c[1], c[3]]) for c in (ln.split(",") for ln in lines[1:])]
    files["DVL"].write_text("\n".join(swapped) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for offset in ("auto", 0.0):          # estimated, or given (a calibrated config)
            with pytest.raises(DataError, match=r"DVL_trajectory1.csv.*another frame"):
                load_akit(tmp_path / "Trajectory1", dvl_time_offset_s=offset)


def test_a_gt_that_disagrees_with_itself_is_named_instead_of_the_dvl(tmp_path):
    """The GT attitude in degrees (as radians) and a DVL that cannot follow the GT: the GT's attitude turns 57x as
    fast as the gyro and its velocity is not along its own body axis, so the message names the GT file and its
    attitude columns as the likelier fault, not the DVL file (the DVL in another frame above still names the
    DVL)."""
    import dataclasses

    from graphnav.calibration.preparation import prepare
    from graphnav.core.rotations import C_b_n_to_euler, euler_to_C_b_n
    from graphnav.io.export import write_akit
    from graphnav.io.loaders import read_mission
    from graphnav.sim.simulate import simulate_mission
    files = write_akit(simulate_mission(duration_s=120.0, seed=1), tmp_path, 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = read_mission(tmp_path / "Trajectory1")
        degrees = euler_to_C_b_n(*np.degrees(C_b_n_to_euler(m.gt.C_b_n)).T)
        with pytest.raises(DataError) as err:
            prepare(dataclasses.replace(m, gt=dataclasses.replace(m.gt, C_b_n=degrees)))
    assert err.value.source == str(files["GT"]) and err.value.field == "Roll [rad]/Pitch [rad]/Yaw [rad]"
    assert "attitude turns" in str(err.value) and "likelier fault" in str(err.value)
    assert str(files["DVL"]) in str(err.value)


def _edit_gt(folder, n, edit):
    path = folder / f"GT_trajectory{n}.csv"
    gt = read_csv(path, AKIT_COLUMNS["GT"])
    edit(gt)
    write_csv(path, AKIT_COLUMNS["GT"], gt.tolist())
    return path


def _load_quiet(folder):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_akit(folder, imu_axis_signs=(1, -1, 1), gt_time_offset_s=0.0, dvl_time_offset_s=0.0)
    return m, [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]


def _heave(gt):
    """The vehicle rising and sinking +-1 m around 15 m (altitude and V Down together; true stamps k s)."""
    k = np.arange(len(gt))
    gt[:, 3] = -15.0 - np.sin(0.1 * k)
    gt[:, 6] = 0.1 * np.cos(0.1 * k)


def test_akit_gt_in_degrees_is_converted_naming_the_file_and_columns(tmp_path):
    """Latitude/longitude and roll/pitch/yaw in degrees under the [rad] header (32.8 "rad" of latitude): converted
    with a warning naming the GT file and columns; the mission is the one the radian file gives (it used to load
    silently, 4.4 km off at the end of 150 s)."""
    clean, _ = _load_quiet(make_akit_folder(tmp_path / "clean", n=1))
    folder = make_akit_folder(tmp_path / "deg", n=1)
    path = _edit_gt(folder, 1, lambda gt: gt.__setitem__((slice(None), [1, 2, 7, 8, 9]),
                                                         np.degrees(gt[:, [1, 2, 7, 8, 9]])))
    m, caught = _load_quiet(folder)
    assert any(w.startswith(f"{path}: 'Latitude [rad]', 'Longitude [rad]' read as degrees") for w in caught), caught
    assert any(w.startswith(f"{path}: attitude columns 'Roll [rad]', 'Pitch [rad]', 'Yaw [rad]' read as degrees")
               for w in caught), caught
    assert len([n for n in m.meta["streams"]["gt"]["notes"] if "read as degrees" in n]) == 2
    np.testing.assert_allclose(m.gt.p_n, clean.gt.p_n, atol=1e-6)
    np.testing.assert_allclose(m.gt.C_b_n, clean.gt.C_b_n, atol=1e-12)
    assert m.config.lat_rad == pytest.approx(clean.config.lat_rad, abs=1e-12)


def test_akit_gt_altitude_with_its_sign_flipped_names_the_file_and_column(tmp_path):
    """The altitude positive down: the depth (-altitude) is 15 m above the sea. Level, nothing tells a flipped sign
    from a height above the ellipsoid: refused at load naming the GT file, its first line and 'Altitude [m]' (it
    used to end in the navigator, naming neither: "depth, field 'depth': 150 of 150 depth samples refused").
    Rising and sinking against V Down: the sign is flipped back with a warning."""
    folder = make_akit_folder(tmp_path / "level", n=1)
    path = _edit_gt(folder, 1, lambda gt: gt.__setitem__((slice(None), 3), -gt[:, 3]))
    with pytest.raises(DataError) as err:
        _load_quiet(folder)
    assert (err.value.source, err.value.line, err.value.field) == (str(path), 2, "Altitude [m]")
    assert "120 of 120 depths outside [-10, 6000] m" in str(err.value)
    heave = make_akit_folder(tmp_path / "heave", n=1)
    _edit_gt(heave, 1, _heave)
    clean, _ = _load_quiet(heave)
    path = _edit_gt(heave, 1, lambda gt: gt.__setitem__((slice(None), 3), -gt[:, 3]))
    m, caught = _load_quiet(heave)
    assert any(w.startswith(f"{path}: column 'Altitude [m]' read with its sign flipped and turned back")
               for w in caught), caught
    np.testing.assert_allclose(m.depth.depth, clean.depth.depth, atol=1e-12)


def test_akit_gt_altitude_sign_is_fixed_past_a_spike_and_refused_naming_the_real_line(tmp_path):
    """A flipped altitude with one V Down spike (3 m/s, then 30 m/s): the spike row, refused by the screening, is
    left out of the sign decision, so the sign is turned back (it used to be a DataError, "150 of 150 depths
    outside"). A level flipped altitude whose line 2 has an empty roll: the depth error names line 3, the first
    depth tested (it used to name line 2, counting the finite rows only)."""
    heave = make_akit_folder(tmp_path / "heave", n=1)
    _edit_gt(heave, 1, _heave)
    clean, _ = _load_quiet(heave)
    for spike in (3.0, 30.0):
        def flip_and_spike(gt, spike=spike):
            gt[:, 3] = -gt[:, 3]
            gt[50, 6] = spike
        folder = make_akit_folder(tmp_path / f"spike{spike:g}", n=1)
        _edit_gt(folder, 1, _heave)
        path = _edit_gt(folder, 1, flip_and_spike)
        m, caught = _load_quiet(folder)
        assert any(w.startswith(f"{path}: column 'Altitude [m]' read with its sign flipped and turned back")
                   for w in caught), caught
        keep = np.arange(len(clean.depth.depth)) != 50
        np.testing.assert_allclose(m.depth.depth, clean.depth.depth[keep], atol=1e-12)
    level = make_akit_folder(tmp_path / "level", n=1)

    def flip_and_empty(gt):
        gt[:, 3] = -gt[:, 3]
        gt[0, 7] = np.nan
    path = _edit_gt(level, 1, flip_and_empty)
    with pytest.raises(DataError) as err:
        _load_quiet(level)
    assert (err.value.source, err.value.line, err.value.field) == (str(path), 3, "Altitude [m]")


def test_refused_dvl_pings_are_counted_once(tmp_path):
    """A ping outside the vehicle's envelope and a ping of an impossible value are each refused once, under one
    reason, in meta["streams"]."""
    from graphnav.io.export import write_akit
    from graphnav.sim.simulate import simulate_mission
    mission = simulate_mission(duration_s=60.0, seed=2)
    files = write_akit(mission, tmp_path, 1)
    lines = files["DVL"].read_text().splitlines()
    for row, value in ((30, "6.0"), (40, "30.0")):       # faster than the vehicle; beyond any DVL's range
        cols = lines[row].split(",")
        lines[row] = ",".join([cols[0], value, *cols[2:]])
    files["DVL"].write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_akit(tmp_path / "Trajectory1")
    refused = m.meta["streams"]["dvl"]["refused"]
    assert sum(refused.values()) == 2 and len(refused) == 2, refused
    assert m.meta["streams"]["dvl"]["used"] == m.meta["streams"]["dvl"]["read"] - 2


def test_published_period_factor_is_the_files_own_and_survives_a_cut():
    """``linspace(0, T, N)`` stamps go back to the sensor's period whatever rows are left of them; stamps already
    on the period, jittered like a logger's or at another rate are not such a grid."""
    from graphnav.io.loaders import published_period_factor
    t = np.linspace(0.0, 400.0, 400)
    assert published_period_factor(t, 1.0) == pytest.approx(399 / 400, rel=1e-12)
    assert published_period_factor(t[:300], 1.0) == pytest.approx(399 / 400, rel=1e-12)       # cut short
    assert published_period_factor(np.delete(t, np.s_[100:160]), 1.0) == pytest.approx(399 / 400, rel=1e-12)
    assert published_period_factor(t[50:], 1.0) == pytest.approx(399 / 400, rel=1e-12)         # head cut
    imu = np.linspace(0.0, 400.0, 40000)
    assert published_period_factor(imu[:1234], 100.0) == pytest.approx(39999 / 40000, rel=1e-12)
    assert published_period_factor(np.arange(400) * 1.0, 1.0) is None                      # already k / rate
    assert published_period_factor(np.arange(4000) * 0.1, 1.0) is None                     # another rate
    jitter = np.arange(400) * 1.0025 + np.random.default_rng(0).normal(0, 0.02, 400)   # a logger: 20 ms
    assert published_period_factor(jitter, 1.0) is None
    assert published_period_factor(np.arange(100) * 0.02, 100.0) is None                   # 50 Hz, not 100
    assert published_period_factor(np.arange(400) / 0.95, 1.0) is None                    # 0.95 Hz, on a grid
    # stamps rounded to the millisecond, or stored as float32: still the grid, and its factor
    assert published_period_factor(np.round(t, 3), 1.0) == pytest.approx(399 / 400, rel=1e-6)
    assert published_period_factor(imu.astype(np.float32), 100.0) == pytest.approx(39999 / 40000, rel=1e-6)
    # a file with one row fewer over the same span (Trajectory13's IMU): still back on the period
    assert published_period_factor(np.linspace(0.0, 400.0, 39999), 100.0) == pytest.approx(39998 / 40000, rel=1e-12)



@pytest.mark.parametrize("removed", [0.5, 0.7])
def test_a_published_grid_with_most_of_its_rows_removed_is_still_the_grid(removed):
    """A grid with 50-70 % of its rows removed at random (the median step spans a hole) was taken for no grid and kept
    as read, 0.25 % slow against the rescaled IMU; it gets the published factor. Stamps with a short interval that is
    not the grid's (a logger's burst) are still not a grid."""
    from graphnav.io.loaders import grid_step, published_period_factor
    t = np.linspace(0.0, 400.0, 400)
    rng = np.random.default_rng(1)
    kept = np.sort(rng.choice(400, int(400 * (1 - removed)), replace=False))
    assert published_period_factor(t[kept], 1.0) == pytest.approx(399 / 400, rel=1e-12)
    assert grid_step(t[kept]) == pytest.approx(400 / 399, rel=1e-12)
    burst = np.sort(np.concatenate([t[kept], [t[kept][10] + 0.3]]))
    assert published_period_factor(burst, 1.0) is None


@pytest.mark.parametrize("rows, clock_s, seed, removed", [(400, 1.7e9, 0, 0.6), (410, 0.0, 0, 0.6), (390, 0.0, 1, 0.5)])
def test_a_published_grid_with_half_its_rows_or_more_removed_is_the_grid_on_any_clock_and_row_count(
        rows, clock_s, seed, removed):
    """The median difference of a grid with half its rows or more removed can be exactly two steps (always so on a
    Unix clock, whose stamps are 2.4e-7 s apart; here 410 rows) or 1.5 steps (an even count of differences of one and
    two steps; 390 rows, half removed): the shortest, one step, is then not under half the median, and the grid was
    kept as read, 0.25 % slow against the rescaled IMU. It gets the published factor."""
    from graphnav.io.loaders import published_period_factor
    t = clock_s + np.linspace(0.0, float(rows), rows)
    kept = np.sort(np.random.default_rng(seed).choice(rows, int(round(rows * (1 - removed))), replace=False))
    assert published_period_factor(t[kept], 1.0) == pytest.approx((rows - 1) / rows, rel=1e-9)

def test_an_akit_folder_cut_short_reads_with_the_full_folders_stamps(tmp_path):
    """The first rows of a published folder (a log cut short) get the full folder's stamps, row for row: the
    rescale comes from the stamp step, not from the last stamp."""
    full = make_akit_folder(tmp_path / "full", n=3)
    cut = tmp_path / "cut" / "Trajectory3"
    cut.mkdir(parents=True)
    for kind in ("IMU", "DVL", "GT"):
        lines = (full / f"{kind}_trajectory3.csv").read_text().splitlines()
        keep = 1 + (len(lines) - 1) * 3 // 4
        (cut / f"{kind}_trajectory3.csv").write_text("\n".join(lines[:keep]) + "\n")
    offsets = dict(imu_axis_signs=(1, -1, 1), dvl_time_offset_s=0.0, gt_time_offset_s=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a, b = load_akit(full, **offsets), load_akit(cut, **offsets)
    for stream in ("imu", "dvl", "gt"):
        ta, tb = getattr(a, stream).t, getattr(b, stream).t
        np.testing.assert_allclose(tb, ta[:len(tb)], rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.gt.t[:3], [0.0, 1.0, 2.0], atol=1e-12)
    assert any("back on the sensor's 1 s period" in n for n in b.meta["streams"]["gt"]["notes"])


def test_a_published_trajectory_cut_short_finds_the_full_trajectorys_offsets(akit_dir, tmp_path):
    """The first 300 s of Trajectory1: the GT and DVL time offsets of the whole file, within their sigmas
    (read with the file's own last stamp as the published span, the cut copy's stamps were 0.25 s off at its
    end, the GT offset 0.1 s off at 35 sigma and the heading 0.4 deg off, NEES 59)."""
    src = akit_dir / "Trajectory1"
    cut = tmp_path / "Trajectory1"
    cut.mkdir()
    for kind in ("IMU", "DVL", "GT"):
        lines = (src / f"{kind}_trajectory1.csv").read_text().splitlines()
        (cut / f"{kind}_trajectory1.csv").write_text("\n".join(lines[:1 + len(lines[1:]) * 3 // 4]) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        full, part = load_akit(src), load_akit(cut)
    for stream in ("gt", "dvl"):
        a, b = full.meta["time_offsets"][stream], part.meta["time_offsets"][stream]
        assert abs(a["offset_s"] - b["offset_s"]) < 3 * np.hypot(a["sigma_s"], b["sigma_s"]), (stream, a, b)


def test_a_folder_whose_files_are_rescaled_and_kept_is_warned_about(tmp_path):
    """The DVL file re-stamped by a logger (jittered) beside published IMU and GT files: the IMU and GT go back on
    their periods, the DVL stays as read, and the user is told the clocks may now disagree."""
    folder = make_akit_folder(tmp_path, n=5)
    p = folder / "DVL_trajectory5.csv"
    dvl = read_csv(p, AKIT_COLUMNS["DVL"])
    dvl[:, 0] = np.arange(len(dvl)) * 1.0 + np.random.default_rng(1).uniform(-0.05, 0.05, len(dvl)) + 0.1
    write_csv(p, AKIT_COLUMNS["DVL"], dvl.tolist())
    with pytest.warns(RuntimeWarning, match=r"stamps of imu, gt rescaled.*those of dvl kept as read"):
        m = load_akit(folder, dvl_time_offset_s=0.0, gt_time_offset_s=0.0, imu_axis_signs=(1, -1, 1))
    np.testing.assert_allclose(m.dvl.t, dvl[:, 0])
    np.testing.assert_allclose(m.gt.t[:3], [0.0, 1.0, 2.0], atol=1e-12)


def _shift_stamps(src, dst, shifts):
    """A copy of the A-KIT folder ``src`` in ``dst`` (same name) with ``shifts[kind]`` s added to the stamps of
    the ``kind`` file (IMU, DVL, GT), written at full precision."""
    dst = dst / src.name
    dst.mkdir(parents=True)
    for kind in ("IMU", "DVL", "GT"):
        name = next(src.glob(f"{kind}_*.csv")).name
        data = read_csv(src / name, AKIT_COLUMNS[kind], nan_ok=AKIT_COLUMNS[kind][1:])
        data[:, 0] += shifts.get(kind, 0.0)
        write_csv(dst / name, AKIT_COLUMNS[kind], data.tolist())
    return dst


UNIX_T0 = 1_700_000_000.0       # Unix seconds (November 2023)


def test_published_stamps_on_a_unix_clock_are_rescaled_about_their_start(tmp_path):
    """The published folder with every stamp moved to a Unix clock (1.7e9 s): each stream's stamps are the 0-based
    folder's plus the clock's start, to float64's resolution there (scaled about zero they moved by 4e6 s, and the
    GT no longer overlapped the IMU: "too little overlap between IMU and reference"). The grid step is fitted on
    the time since the first stamp (through the absolute stamps it was 1.5e-9 of the step off), and a grid on the
    sensor's period is not taken for a published one when the step excess is within what the stamps resolve
    (2 s of 100 Hz Unix stamps, on the period, fitted 2.4e-7 above it through the absolute stamps)."""
    from graphnav.io.loaders import published_period_factor, read_akit
    zero = make_akit_folder(tmp_path / "zero", n=4)
    unix = _shift_stamps(zero, tmp_path / "unix", {k: UNIX_T0 for k in ("IMU", "DVL", "GT")})
    t = np.linspace(0.0, 400.0, 400)
    assert published_period_factor(UNIX_T0 + t, 1.0) == pytest.approx(399 / 400, rel=1e-10)
    assert published_period_factor(UNIX_T0 + np.arange(200.0), 1.0) is None          # on the period already
    assert published_period_factor(UNIX_T0 + np.arange(200) * 0.01, 100.0) is None
    assert published_period_factor(UNIX_T0 + np.linspace(0.0, 400.0, 40000), 100.0) == pytest.approx(
        39999 / 40000, rel=1e-10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a, b = read_akit(zero), read_akit(unix)
    for stream in ("imu", "dvl", "gt"):
        np.testing.assert_allclose(getattr(b, stream)[:, 0] - UNIX_T0, getattr(a, stream)[:, 0], rtol=0, atol=1e-6)
    assert any(f"about t = {UNIX_T0:.3f} s" in n for n in b.meta["streams"]["gt"]["notes"])


def _first_seconds(src, dst, seconds, shifts=None):
    """The first ``seconds`` of the published folder ``src`` (rows as published), copied to ``dst`` with
    ``shifts[kind]`` s added to the stamps of the ``kind`` file."""
    dst = dst / src.name
    dst.mkdir(parents=True)
    for kind in ("IMU", "DVL", "GT"):
        name = next(src.glob(f"{kind}_*.csv")).name
        data = read_csv(src / name, AKIT_COLUMNS[kind], nan_ok=AKIT_COLUMNS[kind][1:])
        data = data[data[:, 0] < seconds]
        data[:, 0] += (shifts or {}).get(kind, 0.0)
        write_csv(dst / name, AKIT_COLUMNS[kind], data.tolist())
    return dst


def test_a_published_trajectory_on_a_unix_clock_loads_as_on_its_own(akit_dir, tmp_path):
    """The first 150 s of Trajectory1 with every stamp on a Unix clock: the same axis signs and time offsets as the
    0-based copy (before, "too little overlap between IMU and reference" and numpy's "Mean of empty slice")."""
    zero = _first_seconds(akit_dir / "Trajectory1", tmp_path / "zero", 150.0)
    unix = _first_seconds(akit_dir / "Trajectory1", tmp_path / "unix", 150.0,
                          {k: UNIX_T0 for k in ("IMU", "DVL", "GT")})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a, b = load_akit(zero), load_akit(unix)
    assert b.meta["imu_axis_signs"]["signs"] == a.meta["imu_axis_signs"]["signs"]
    for stream in ("gt", "dvl"):
        assert b.meta["time_offsets"][stream]["offset_s"] == pytest.approx(
            a.meta["time_offsets"][stream]["offset_s"], abs=1e-3)
    np.testing.assert_allclose(b.gt.t - UNIX_T0, a.gt.t, rtol=0, atol=1e-5)
    from graphnav.io.inspect import describe_mission
    assert describe_mission(a)["clock"] == "seconds from the first IMU stamp"
    assert describe_mission(b)["clock"] == "Unix seconds (the files' own clock)"


def test_a_late_file_shares_the_folders_origin_and_a_far_one_keeps_its_own(tmp_path):
    """The origin of the rescale: a DVL file whose first rows are gone (it started late) keeps the whole folder's
    stamps to the bit, as before; a GT file on a clock three days away is rescaled about its own first stamp, so
    that it stays the 0-based file's plus three days (about zero it moved by 648 s more)."""
    from graphnav.io.loaders import read_akit
    zero = make_akit_folder(tmp_path / "zero", n=4)
    late = _shift_stamps(zero, tmp_path / "late", {})
    lines = (late / "DVL_trajectory4.csv").read_text().splitlines()
    (late / "DVL_trajectory4.csv").write_text("\n".join(lines[:1] + lines[31:]) + "\n")
    days = _shift_stamps(zero, tmp_path / "days", {"GT": 3 * 86400.0})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a, b, c = read_akit(zero), read_akit(late), read_akit(days)
    np.testing.assert_allclose(b.dvl[:, 0], a.dvl[30:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(c.gt[:, 0] - 3 * 86400.0, a.gt[:, 0], rtol=0, atol=1e-8)
    np.testing.assert_array_equal(c.imu[:, 0], a.imu[:, 0])



@pytest.mark.parametrize("start", [330.0, 120.0])
def test_a_given_dvl_offset_for_a_piece_a_day_off_lands_where_it_says(akit_dir, tmp_path, start):
    """Trajectory10's 60 s from 120 or 330 s without GT, its DVL stamps a day late, given the offset the same piece with
    its GT finds less the day: a file on a clock of its own is rescaled about its own first stamp, and the offset added
    after that put the pings 0.0025 x 120 = 0.30 s and 0.83 s later than it said. It is for the stamps as written: they
    land within 0.01 s of the GT piece's (the rescale of the offset itself, 0.0025 s). The offset the clock search
    records is on the same footing: given back, it lands where the search put the DVL."""
    import json

    from graphnav.missions import load_mission
    from test_dvl_frame import _akit_crop_without_gt
    with_gt = _akit_crop_without_gt(akit_dir / "Trajectory10", tmp_path / "gt", np.eye(3), 60.0, start, gt=True)
    moved = _akit_crop_without_gt(akit_dir / "Trajectory10", tmp_path / "moved", np.eye(3), 60.0, start,
                                  dvl_shift=86400.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        truth = load_mission(with_gt)
        given = truth.config.dvl_time_offset_s - 86400.0
        (tmp_path / "config.json").write_text(json.dumps({"dvl_time_offset_s": given}))
        got = load_mission(moved, tmp_path / "config.json")
        searched = load_mission(moved)
        searched_given = load_akit(moved, dvl_time_offset_s=searched.config.dvl_time_offset_s)
    assert got.config.dvl_time_offset_s == given
    np.testing.assert_allclose(got.dvl.t, truth.dvl.t, rtol=0, atol=0.01)
    np.testing.assert_allclose(searched_given.dvl.t, searched.dvl.t, rtol=0, atol=1e-6)
    assert searched.config.dvl_time_offset_s == pytest.approx(given, abs=0.1)


@pytest.mark.parametrize("gt", [False, True])
def test_the_dvl_offset_said_for_a_piece_a_day_off_is_the_one_recorded(akit_dir, tmp_path, gt):
    """Trajectory10's 60 s from 330 s, its DVL stamps a day late, with and without its GT: the clock search's warning
    and note, ``meta["clock_offsets"]`` and ``meta["time_offsets"]`` said the offset on the stamps as rescaled about
    the file's own first stamp (-86399.767 s) while the configuration records it on the stamps as written
    (-86398.937 s): two offsets "added" 0.83 s apart, and the warning's given back put the pings 0.84 s early. Every
    offset said is now the one recorded, and given back lands where the search put the DVL."""
    import re

    from test_dvl_frame import _akit_crop_without_gt
    moved = _akit_crop_without_gt(akit_dir / "Trajectory10", tmp_path / "moved", np.eye(3), 60.0, 330.0,
                                  dvl_shift=86400.0, gt=gt)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        searched = load_akit(moved)
    recorded = searched.config.dvl_time_offset_s
    said = [float(m.group(1)) for w in caught for m in [re.search(r"DVL clock offset ([-+0-9.]+) s", str(w.message))]
            if m]
    noted = [float(m.group(1)) for n in searched.meta["streams"]["dvl"]["notes"]
             for m in [re.search(r"DVL clock offset ([-+0-9.]+) s", n)] if m]
    found = searched.meta["clock_offsets"]["dvl"]["offset_s"]
    # with the GT the fine estimate adds its 0.01 s to the clock search's
    assert said == noted and len(said) == 1 and said[0] == pytest.approx(found, abs=5e-4)
    assert found == pytest.approx(recorded, abs=0.03 if gt else 1e-9)
    if gt:
        assert searched.meta["time_offsets"]["dvl"]["offset_s"] == pytest.approx(recorded, abs=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        given_back = load_akit(moved, dvl_time_offset_s=found)
    # the clock search's pings given back, less the fine estimate's share (0.0025 of it off: 3e-5 s)
    np.testing.assert_allclose(given_back.dvl.t, searched.dvl.t + found - recorded, rtol=0, atol=1e-4)


def test_a_given_gt_offset_for_a_piece_a_day_off_lands_where_it_says(akit_dir, tmp_path):
    """Trajectory10's 60 s from 330 s, its GT stamps a day late, given the offset the same piece finds less the day (and
    that 0.3 s off): rescaled about its own first stamp, the GT landed 0.83 s late (0.0025 x 330 s), and the data were
    said at -86401.277 s, 1.13 s from the given offset rather than 0.3 s. ``gt_time_offset_s`` is for the stamps as
    written, as ``dvl_time_offset_s`` is: the GT lands within 0.005 s of the piece's, the messages quote the given
    number and the data's on its footing, and the offset the clock search records, given back, lands where it put the
    GT."""
    import json
    import re

    from graphnav.missions import load_mission
    from test_dvl_frame import _akit_crop_without_gt
    src = akit_dir / "Trajectory10"
    on_time = _akit_crop_without_gt(src, tmp_path / "gt", np.eye(3), 60.0, 330.0, gt=True)
    late = _shift_stamps(on_time, tmp_path / "late", {"GT": 86400.0})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        truth = load_mission(on_time)
        searched = load_mission(late)
        (tmp_path / "searched.json").write_text(json.dumps({"gt_time_offset_s": searched.config.gt_time_offset_s}))
        searched_given = load_mission(late, tmp_path / "searched.json")
    given = truth.config.gt_time_offset_s - 86400.0
    for off in (0.0, 0.3):
        (tmp_path / "config.json").write_text(json.dumps({"gt_time_offset_s": given + off}))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            got = load_mission(late, tmp_path / "config.json")
        assert got.config.gt_time_offset_s == given + off
        np.testing.assert_allclose(got.gt.t, truth.gt.t + off, rtol=0, atol=0.005)
        said = [re.search(r"gt_time_offset_s = ([-+0-9.]+) s is given, but the data say ([-+0-9.]+) s",
                          str(w.message)) for w in caught]
        said = [(float(m.group(1)), float(m.group(2))) for m in said if m]
        assert len(said) == (1 if off else 0)
        if off:
            assert said[0][0] == pytest.approx(given + off, abs=5e-4)
            assert said[0][1] == pytest.approx(given, abs=0.005)
    np.testing.assert_allclose(searched.gt.t, truth.gt.t, rtol=0, atol=0.005)
    np.testing.assert_allclose(searched_given.gt.t, searched.gt.t, rtol=0, atol=1e-6)
    assert searched.config.gt_time_offset_s == pytest.approx(given, abs=0.005)
    assert searched.meta["time_offsets"]["gt"]["offset_s"] == pytest.approx(searched.config.gt_time_offset_s, abs=1e-9)


def test_a_given_dvl_offset_off_the_imu_span_is_not_judged_as_used(akit_dir, tmp_path):
    """Trajectory10's 60 s from 330 s without GT, its DVL stamps a day late, configured with the offset less the day
    300 s off: the stamps would leave the IMU span, so the clock search places the DVL (warned about). The search's
    offset was then judged as the given one against itself: "dvl_time_offset_s = -86398.937 s is given, but the data
    say -172798.703 s ... it is used as given", naming neither the number given nor the one used, and advising a
    second day. The pings land where the search puts them without a configuration, and no such doubt is said."""
    import json

    from graphnav.missions import load_mission
    from test_dvl_frame import _akit_crop_without_gt
    moved = _akit_crop_without_gt(akit_dir / "Trajectory10", tmp_path / "moved", np.eye(3), 60.0, 330.0,
                                  dvl_shift=86400.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        searched = load_mission(moved)
    (tmp_path / "config.json").write_text(json.dumps({"dvl_time_offset_s": searched.config.dvl_time_offset_s + 300.0}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = load_mission(moved, tmp_path / "config.json")
    text = [str(w.message) for w in caught]
    assert any("on a clock of its own, whose offset is estimated from the data instead" in t for t in text)
    assert not any("is given, but" in t for t in text), text
    np.testing.assert_allclose(got.dvl.t, searched.dvl.t, rtol=0, atol=1e-6)
    assert got.config.dvl_time_offset_s == pytest.approx(searched.config.dvl_time_offset_s, abs=1e-6)


@pytest.mark.parametrize("gt", [False, True])
def test_a_dvl_a_day_early_is_on_a_clock_of_its_own(akit_dir, tmp_path, gt):
    """Trajectory10's 60 s from 330 s, its DVL stamps a day early, with and without its GT. The earliest file (the
    DVL) was taken for the folder's clock and the IMU and GT for clocks of their own: the DVL rescaled about 0 a day
    away moved 216 s, its correct offset given (+86401.07 s) was refused as leaving it off the IMU span, and the
    search's +86185 s recorded. The IMU's clock is the folder's: the DVL a day early is on a clock of its own, as one a
    day late is. Found or given, its offset is the piece's plus the day and its pings land where the piece's do."""
    import json

    from graphnav.missions import load_mission
    from test_dvl_frame import _akit_crop_without_gt
    src = akit_dir / "Trajectory10"
    on_time = _akit_crop_without_gt(src, tmp_path / "gt", np.eye(3), 60.0, 330.0, gt=True)
    early = _akit_crop_without_gt(src, tmp_path / "early", np.eye(3), 60.0, 330.0, gt=gt, dvl_shift=-86400.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        truth = load_mission(on_time)
        given = truth.config.dvl_time_offset_s + 86400.0
        searched = load_mission(early)
        (tmp_path / "config.json").write_text(json.dumps({"dvl_time_offset_s": given}))
        got = load_mission(early, tmp_path / "config.json")
    assert not any("on a clock of its own, whose offset is estimated" in str(w.message) for w in caught)
    assert got.config.dvl_time_offset_s == given
    np.testing.assert_allclose(got.dvl.t, truth.dvl.t, rtol=0, atol=0.01)
    assert searched.config.dvl_time_offset_s == pytest.approx(given, abs=0.05)
    np.testing.assert_allclose(searched.dvl.t, truth.dvl.t, rtol=0, atol=0.05)


@pytest.mark.parametrize("moved", [{"IMU": 86100.0}, {"IMU": -86100.0}, {"IMU": 5000.0},
                                   {"IMU": 86100.0, "GT": 86100.0}, {"IMU": 86700.0, "GT": 86700.0}])
def test_an_imu_on_a_clock_of_its_own_keeps_the_offsets_of_the_files_it_left(akit_dir, tmp_path, moved):
    """Trajectory10's first 60 s, its IMU file (alone or with its GT) moved by hours or a day less 5 min. Anchored on
    the IMU, the folder's clock was the IMU's though the DVL and GT start at 0: the IMU was rescaled about 0, 2.15 s
    moved at 86 100 s, and the offsets recorded (the piece's plus the move) were 2.15 s off, the true ones given back
    said contradicted and used 2.15 s off; a GT moved with the IMU was converted about the folder's origin, its offset
    recorded 216 s off. The files starting nearest zero keep the folder's clock and the IMU is on its own, as a day
    or more away: found or given, each offset is the piece's plus the move and the samples land where the piece's do."""
    import json

    from graphnav.missions import load_mission
    from test_dvl_frame import _akit_crop_without_gt
    on_time = _akit_crop_without_gt(akit_dir / "Trajectory10", tmp_path / "gt", np.eye(3), 60.0, 0.0, gt=True)
    folder = _shift_stamps(on_time, tmp_path / "moved", moved)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        truth = load_mission(on_time)
        true = {f"{k.lower()}_time_offset_s": getattr(truth.config, f"{k.lower()}_time_offset_s") + moved["IMU"]
                - moved.get(k, 0.0) for k in ("DVL", "GT")}
        searched = load_mission(folder)
        (tmp_path / "config.json").write_text(json.dumps(true))
        given = load_mission(folder, tmp_path / "config.json")
    for got, atol in ((searched, 0.03), (given, 0.005)):
        for stream in ("dvl", "gt"):
            np.testing.assert_allclose(getattr(got, stream).t - got.imu.t[0],
                                       getattr(truth, stream).t - truth.imu.t[0], rtol=0, atol=atol)
    for key, value in true.items():
        assert getattr(searched.config, key) == pytest.approx(value, abs=0.03)
        assert getattr(given.config, key) == value
    assert not any("is given, but" in str(w.message) for w in caught)


@pytest.mark.parametrize("shift", [86400.0, -86400.0])
def test_a_gt_offset_passed_to_load_akit_places_a_gt_a_day_off(akit_dir, tmp_path, shift):
    """Trajectory10's 60 s from 330 s, its GT stamps a day late or early, loaded with ``load_akit(gt_time_offset_s=)``
    the piece's offset less the shift: a day late, the axis check refused the GT as sharing no interval with the IMU
    (a configuration file's offset was placed first, an argument's not); a day early, the offset was read 216 s off. It
    is placed before the axis check as a configuration's is, recorded as given, and the GT lands where the piece's
    does."""
    from test_dvl_frame import _akit_crop_without_gt
    on_time = _akit_crop_without_gt(akit_dir / "Trajectory10", tmp_path / "gt", np.eye(3), 60.0, 330.0, gt=True)
    moved = _shift_stamps(on_time, tmp_path / "moved", {"GT": shift})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        truth = load_akit(on_time)
        given = truth.config.gt_time_offset_s - shift
        got = load_akit(moved, gt_time_offset_s=given)
    assert got.config.gt_time_offset_s == given
    np.testing.assert_allclose(got.gt.t, truth.gt.t, rtol=0, atol=0.005)
    np.testing.assert_allclose(got.dvl.t, truth.dvl.t, rtol=0, atol=0.01)


def test_the_y_trial_quotes_offsets_a_user_can_give_back(akit_dir, tmp_path):
    """Trajectory10's 120 s from 330 s without GT, its DVL a day late and its y negated: the refusal said the clock
    search found -86399.842 s where its own warning said -86399.013 s, and the y negated -86399.781 s, which given back
    (the y fixed) put the pings 0.85 s early: offsets on the stamps rescaled about the file's own first stamp
    (0.0025 x 330 s apart). Every number is on the stamps as written: the search's is its warning's, and the y
    trial's, given back, lands within 0.05 s of the piece's pings."""
    import json
    import re

    from graphnav.missions import load_mission
    from test_dvl_frame import _akit_crop_without_gt
    src = akit_dir / "Trajectory10"
    on_time = _akit_crop_without_gt(src, tmp_path / "gt", np.eye(3), 120.0, 330.0, gt=True)
    negated = _akit_crop_without_gt(src, tmp_path / "y", np.diag([1.0, -1.0, 1.0]), 120.0, 330.0, dvl_shift=86400.0)
    fixed = _akit_crop_without_gt(src, tmp_path / "fixed", np.eye(3), 120.0, 330.0, dvl_shift=86400.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        truth = load_mission(on_time)
        with pytest.raises(DataError, match="with its y negated the DVL finds its clock at") as err:
            load_mission(negated)
    warned = [float(m.group(1)) for w in caught
              for m in [re.search(r"DVL clock offset ([-+0-9.]+) s", str(w.message))] if m]
    found = float(re.search(r"the DVL clock search finds the offset ([-+0-9.]+) s", str(err.value)).group(1))
    y = float(re.search(r"with its y negated the DVL finds its clock at ([-+0-9.]+) s", str(err.value)).group(1))
    assert warned == [found]
    (tmp_path / "config.json").write_text(json.dumps({"dvl_time_offset_s": y}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = load_mission(fixed, tmp_path / "config.json")
    np.testing.assert_allclose(back.dvl.t, truth.dvl.t, rtol=0, atol=0.05)


@pytest.mark.parametrize("kind", ["GT", "DVL"])
def test_a_given_offset_off_the_imu_span_is_quoted_and_judged_as_given(akit_dir, tmp_path, kind):
    """Trajectory10's 60 s from 330 s, its GT or DVL a day late, given the piece's offset less the day plus 300 s
    (off the IMU span: the data place the file). The warning quoted the GT's given offset on its rescaled stamps
    (-86102.026 s for -86100.450 s) and judged the DVL's on them (its stamps said 1.58 s late: 0.0025 x 630 s). Both
    are quoted as given, and the stamps said are where the given offset puts them."""
    import re

    from test_dvl_frame import _akit_crop_without_gt
    on_time = _akit_crop_without_gt(akit_dir / "Trajectory10", tmp_path / "gt", np.eye(3), 60.0, 330.0, gt=True)
    moved = _shift_stamps(on_time, tmp_path / "moved", {kind: 86400.0})
    key = f"{kind.lower()}_time_offset_s"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        truth = load_akit(on_time)
        given = getattr(truth.config, key) - 86400.0 + 300.0
        load_akit(moved, **{key: given})
    said = [re.search(rf"the configured {key} ([-+0-9.]+) s puts the stamps at \[([0-9.]+),", str(w.message))
            for w in caught]
    said = [(float(m.group(1)), float(m.group(2))) for m in said if m]
    assert len(said) == 1 and said[0][0] == pytest.approx(given, abs=5e-4)
    # the 300 s are on the stamps as written, rescaled with them (the 1 Hz files' 400/399 grid)
    first = getattr(truth, kind.lower()).t[0] + 300.0 * 0.9975
    assert said[0][1] == pytest.approx(first, abs=0.01)


@pytest.mark.parametrize("shift, added_by", [(86400.0, "found by the DVL clock search"),
                                             (0.0, "(the vehicle's default)")])
def test_the_dvl_offset_note_says_where_it_came_from(akit_dir, tmp_path, shift, added_by):
    """Without GT the DVL's time offset note said "(given or the vehicle's default)" for the clock search's offset of
    a DVL a day late too. It says which it is."""
    from test_dvl_frame import _akit_crop_without_gt
    folder = _akit_crop_without_gt(akit_dir / "Trajectory10", tmp_path, np.eye(3), 60.0, 330.0, dvl_shift=shift)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_akit(folder)
    notes = [n for n in m.meta["streams"]["dvl"]["notes"] if n.startswith("time offset")]
    assert len(notes) == 1 and added_by in notes[0], notes


def test_an_akit_dvl_whose_stamps_jump_by_days_is_refused_naming_its_line(tmp_path):
    """A DVL file whose stamps jump two days after its 50th row (a clock reset): refused naming "sample 50 of the
    stream" and no line, after a warning of 172800 rows missing from its stamp grid. The error names the file's line
    (52: the header and the 51st row) and column, and no grid is warned about."""
    folder = make_akit_folder(tmp_path, n=1)
    dvl = folder / "DVL_trajectory1.csv"
    data = read_csv(dvl, AKIT_COLUMNS["DVL"])
    data[50:, 0] += 2 * 86400.0
    write_csv(dvl, AKIT_COLUMNS["DVL"], data.tolist())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(DataError, match="time stamp jumps by") as err:
            load_akit(folder)
    assert (err.value.source, err.value.line, err.value.field) == (str(dvl), 52, "Time [s]")
    assert not any("missing from the" in str(w.message) for w in caught)


def test_a_folder_trimmed_at_the_start_keeps_the_whole_folders_stamps(tmp_path):
    """All three files cut to t >= 30 s (a published folder trimmed at the start): every stamp is the whole
    folder's, so the DVL keeps its offset to the IMU. The published grids start at 0 whatever is cut from them;
    rescaled about the folder's earliest stamp (30 s) the DVL moved 0.075 s against the IMU (0.15 s in
    Trajectory1 cut at 60 s)."""
    from graphnav.io.loaders import read_akit
    whole = make_akit_folder(tmp_path / "whole", n=4)
    trimmed = _shift_stamps(whole, tmp_path / "trimmed", {})
    for kind in ("IMU", "DVL", "GT"):
        path = trimmed / f"{kind}_trajectory4.csv"
        data = read_csv(path, AKIT_COLUMNS[kind])
        write_csv(path, AKIT_COLUMNS[kind], data[data[:, 0] >= 30.0].tolist())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a, b = read_akit(whole), read_akit(trimmed)
    for stream in ("imu", "dvl", "gt"):
        ta, tb = getattr(a, stream)[:, 0], getattr(b, stream)[:, 0]
        np.testing.assert_allclose(tb, ta[ta >= 30.0 - 1e-6][-len(tb):], rtol=0, atol=1e-9)
    assert not any("about t =" in n for n in b.meta["streams"]["dvl"]["notes"])


def _keep_imu_rows(folder, lo, hi):
    """Keep the rows of the IMU file of A-KIT ``folder`` with ``lo <= t <= hi`` (s, as published)."""
    path = next(folder.glob("IMU_*.csv"))
    data = read_csv(path, AKIT_COLUMNS["IMU"])
    write_csv(path, AKIT_COLUMNS["IMU"], data[(data[:, 0] >= lo) & (data[:, 0] <= hi)].tolist())


def test_dvl_and_gt_logs_longer_than_the_imu_load_with_the_pings_outside_refused(tmp_path):
    """The IMU file cut to 40-80 s of a 120 s folder, the DVL and GT logging longer on both sides: the clocks agree,
    so the mission loads with the configured offsets kept (no "clock of its own" warning) and the DVL pings outside
    the IMU span refused and counted, and info calls it usable. Before, two thirds of the stamps outside the IMU
    span were taken for a clock of its own: the GT's configured offset was thrown away and the DVL refused."""
    from graphnav.io.inspect import describe_mission
    from graphnav.io.stream_counts import OUTSIDE_IMU_SPAN
    folder = make_akit_folder(tmp_path, n=6)
    _keep_imu_rows(folder, 40.0, 80.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_akit(folder, imu_axis_signs=(1, -1, 1), gt_time_offset_s=0.0, dvl_time_offset_s=0.0)
    text = " ".join(str(w.message) for w in caught)
    assert "clock of its own" not in text and "clock offset" not in text, text
    assert m.config.gt_time_offset_s == 0.0 and m.config.dvl_time_offset_s == 0.0
    t = m.dvl.t
    outside = int(np.sum((t < m.imu.t[0]) | (t > m.imu.t[-1])))
    assert outside > len(t) // 2
    assert m.meta["streams"]["dvl"]["refused"] == {OUTSIDE_IMU_SPAN: outside}
    assert describe_mission(m)["usable"]


def test_a_published_trajectory_whose_imu_stops_early_loads_as_before(akit_dir, tmp_path):
    """Trajectory1 with its IMU file cut to t <= 150 s (the DVL and GT log 400 s): loaded with the offsets found
    from the data, as the copy with every file cut to 150 s, and the 251 DVL pings after the IMU's end refused.
    Before, it was refused ("251 of 400 usable DVL pings lie outside the IMU span ... a clock of its own")."""
    from graphnav.io.stream_counts import OUTSIDE_IMU_SPAN
    src = akit_dir / "Trajectory1"
    longer = _shift_stamps(src, tmp_path / "longer", {})
    _keep_imu_rows(longer, 0.0, 150.0)
    cut = _first_seconds(src, tmp_path / "cut", 150.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        a, b = load_akit(cut), load_akit(longer)
    assert not any("GT clock offset" in str(w.message) for w in caught)
    assert b.meta["streams"]["dvl"]["refused"] == {OUTSIDE_IMU_SPAN: 251}
    for stream in ("gt", "dvl"):
        assert b.meta["time_offsets"][stream]["offset_s"] == pytest.approx(
            a.meta["time_offsets"][stream]["offset_s"], abs=0.05)


def test_a_gt_too_short_to_check_the_axes_against_is_refused_naming_it(tmp_path):
    """A GT file of 8 rows beside a 120 s IMU: a DataError naming the GT file, both spans and what to do (before:
    "gt: too little overlap between IMU and reference", no file named)."""
    folder = make_akit_folder(tmp_path, n=2)
    path = folder / "GT_trajectory2.csv"
    path.write_text("\n".join(path.read_text().splitlines()[:9]) + "\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(DataError, match=r"GT stamps \[0.000, 7.000\] s share 5 interval\(s\) with the IMU span "
                                            r"\[0.000, 119.990\] s.*gt_time_offset_s") as err:
            load_akit(folder)
    assert err.value.source == str(path)
    assert not [w for w in caught if "slice" in str(w.message) or "invalid value" in str(w.message)]


def test_a_time_offset_the_data_barely_fix_is_warned_about(tmp_path, akit_dir):
    """A simulated DVL whose offset the noisy velocities fix only to +-0.17 s: estimated, applied, and warned about
    with its sigma; the shared trajectories fix theirs to 0.017 s or better and load without that warning."""
    from graphnav.io.export import write_akit
    from graphnav.sim.simulate import simulate_mission
    sim = simulate_mission(60.0, seed=3)
    write_akit(sim, tmp_path)
    with pytest.warns(RuntimeWarning, match=r"dvl time offset .* estimated with sigma 0\.\d+ s: the data barely fix"):
        # with a config of its own the folder's written offsets are not given: the DVL's is estimated
        m = load_akit(tmp_path / "Trajectory1", config=sim.config, imu_position_b=(0, 0, 0),
                      imu_axis_signs=(1, 1, 1), gt_time_offset_s=0.0)
    assert m.meta["time_offsets"]["dvl"]["sigma_s"] > 0.05
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_akit(akit_dir / "Trajectory13")
    assert not [w for w in caught if "barely fix" in str(w.message)]


def _set_cells(path, cells):
    """Write the text of ``cells`` ({data row: {column index: text}}) into an A-KIT CSV (data row k is file line
    k + 2)."""
    lines = path.read_text().splitlines()
    for row, edits in cells.items():
        fields = lines[row + 1].split(",")
        for j, text in edits.items():
            fields[j] = text
        lines[row + 1] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")


def _load_recording(folder):
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        m = load_akit(folder, imu_axis_signs=(1, -1, 1), gt_time_offset_s=0.0, dvl_time_offset_s=0.0)
    return m, [str(w.message) for w in rec]


def test_akit_imu_spikes_within_full_scale_are_refused_naming_file_line_field_and_count(tmp_path):
    """The probe's spikes, all within the IMU's full scale: a gyro z of 5 rad/s on one row, an accelerometer x of
    100 m/s^2 on one row, 150 m/s^2 on five rows. Each row is refused as an out-of-range row is: dropped, counted
    under its reason in meta["streams"], and named in one warning with the file, its lines and its column."""
    folder = make_akit_folder(tmp_path, n=1)
    imu = folder / "IMU_trajectory1.csv"
    _set_cells(imu, {3000: {6: "5"}, 4000: {1: "100"}, **{r: {1: "150"} for r in range(5000, 5005)}})
    m, messages = _load_recording(folder)
    assert m.meta["streams"]["imu"]["refused"] == {"spike in 'ACC X [m/s^2]'": 6, "spike in 'GYRO Z [rad/s]'": 1}
    assert m.meta["streams"]["imu"]["used"] == 12000 - 7 == len(m.imu.t)
    assert np.abs(m.imu.f_b[:, 0]).max() < 1.0 and np.abs(m.imu.omega_b[:, 2]).max() < 0.1
    assert (f"{imu}: 7 imu sample(s) refused (6 spike in 'ACC X [m/s^2]'; 1 spike in 'GYRO Z [rad/s]') at line(s) "
            "3002, 4002, 5002, 5003, 5004, 5005, 5006; they are not used") in messages


def test_akit_empty_or_nan_cells_refuse_their_row_and_an_empty_dvl_cell_is_nan(tmp_path):
    """What pandas' to_csv writes for NaN is an empty cell: in the DVL file it is an invalid ping, exactly as
    'nan'; in the IMU and GT files a row with an empty or NaN cell (or stamp) is refused, warned about with its
    file, line and column and counted, and the rest of the mission is read. Text stays a DataError."""
    folder = make_akit_folder(tmp_path, n=1)
    paths = {k: folder / f"{k}_trajectory1.csv" for k in ("IMU", "DVL", "GT")}
    _set_cells(paths["IMU"], {6000: {2: ""}, 6500: {4: "nan"}, 7000: {0: ""}})
    _set_cells(paths["GT"], {50: {3: ""}})
    _set_cells(paths["DVL"], {40: {2: ""}})
    m, messages = _load_recording(folder)
    streams = m.meta["streams"]
    assert streams["imu"]["refused"] == {"stamp not a time": 1, "empty or NaN in 'ACC Y [m/s^2]'": 1,
                                         "empty or NaN in 'GYRO X [rad/s]'": 1}
    assert len(m.imu.t) == 12000 - 3 and np.all(np.isfinite(m.imu.f_b)) and np.all(np.isfinite(m.imu.omega_b))
    assert (f"{paths['IMU']}: 2 imu sample(s) refused (1 empty or NaN in 'ACC Y [m/s^2]'; 1 empty or NaN in "
            "'GYRO X [rad/s]') at line(s) 6002, 6502; they are not used") in messages
    assert any(s.startswith(f"{paths['IMU']}: 1 imu sample(s) refused (1 stamp not a time) at line(s) 7002")
               for s in messages)
    assert streams["gt"]["refused"] == {"empty or NaN in 'Altitude [m]'": 1} and len(m.gt.t) == 119
    assert (f"{paths['GT']}: 1 gt sample(s) refused (1 empty or NaN in 'Altitude [m]') at line(s) 52; they are not "
            "used") in messages
    assert not m.dvl.valid[40].any() and m.dvl.valid[np.arange(120) != 40].all()
    assert sum(streams["dvl"]["refused"].values()) == 1
    _set_cells(paths["DVL"], {40: {2: "nan"}})
    as_nan, _ = _load_recording(folder)
    np.testing.assert_array_equal(as_nan.dvl.valid, m.dvl.valid)
    np.testing.assert_array_equal(as_nan.dvl.beams, m.dvl.beams)
    assert as_nan.meta["streams"]["dvl"] == streams["dvl"]
    _set_cells(paths["IMU"], {8000: {5: "abc"}})
    with pytest.raises(DataError) as err:
        load_akit(folder)
    assert (err.value.source, err.value.line, err.value.field) == (str(paths["IMU"]), 8002, "GYRO Y [rad/s]")
    assert "not a number: 'abc'" in str(err.value)


def test_akit_imu_mostly_empty_is_an_error_naming_the_stream_and_the_reason(tmp_path):
    folder = make_akit_folder(tmp_path, n=1)
    _set_cells(folder / "IMU_trajectory1.csv", {r: {1: ""} for r in range(7000)})
    with pytest.raises(DataError, match=r"7000 of 12000 imu samples refused \(7000 empty or NaN in 'ACC X"):
        _load_recording(folder)


def test_akit_infinite_cells_refuse_their_row_or_ping_as_nan_does(tmp_path):
    """inf, -Infinity and 1e999 (past float range) in an IMU or GT cell refuse that row, warned with the file, line
    and column and counted; in the DVL file the ping is invalid (warned with its line, counted). Each used to stop
    the whole load; a huge finite value (1e308) is out of range, as before."""
    folder = make_akit_folder(tmp_path, n=1)
    paths = {k: folder / f"{k}_trajectory1.csv" for k in ("IMU", "DVL", "GT")}
    _set_cells(paths["IMU"], {6000: {2: "inf"}, 6500: {4: "-Infinity"}, 7000: {1: "1e308"}})
    _set_cells(paths["GT"], {50: {5: "1e999"}})
    _set_cells(paths["DVL"], {40: {1: "-inf"}})
    m, messages = _load_recording(folder)
    streams = m.meta["streams"]
    assert streams["imu"]["refused"] == {"infinite in 'ACC Y [m/s^2]'": 1, "infinite in 'GYRO X [rad/s]'": 1,
                                         "f_b beyond 156.906 m/s^2": 1}
    assert (f"{paths['IMU']}: 3 imu sample(s) refused (1 infinite in 'ACC Y [m/s^2]'; 1 infinite in "
            "'GYRO X [rad/s]'; 1 f_b beyond 156.906 m/s^2) at line(s) 6002, 6502, 7002; they are not used") in messages
    assert streams["gt"]["refused"] == {"infinite in 'V East [m/s]'": 1} and len(m.gt.t) == 119
    assert any(s.startswith(f"{paths['GT']}: 1 gt sample(s) refused (1 infinite in 'V East [m/s]') at line(s) 52")
               for s in messages), messages
    assert not m.dvl.valid[40].any() and m.dvl.valid[np.arange(120) != 40].all()
    assert sum(streams["dvl"]["refused"].values()) == 1
    assert any(s.startswith(f"{paths['DVL']}: 1 ping(s) with an invalid velocity") and "line 42" in s
               for s in messages), messages
    assert np.all(np.isfinite(m.imu.f_b)) and np.all(np.isfinite(m.gt.v_n))


def test_akit_row_written_twice_is_dropped_without_repair(tmp_path):
    """An IMU row written twice exactly is the same sample: dropped, warned with its line and counted, and the
    mission reads as the clean folder; the same stamp with other values still needs repair=True."""
    folder = make_akit_folder(tmp_path, n=1)
    clean, _ = _load_recording(folder)
    imu = folder / "IMU_trajectory1.csv"
    lines = imu.read_text().splitlines()
    imu.write_text("\n".join(lines[:801] + [lines[800]] + lines[801:]) + "\n")
    m, messages = _load_recording(folder)
    assert (f"{imu}: 1 row(s) repeating an earlier row exactly (same stamp and values) dropped, at line(s) 802"
            in messages)
    assert m.meta["streams"]["imu"]["refused"] == {"repeats an earlier row exactly": 1}
    np.testing.assert_array_equal(m.imu.t, clean.imu.t)
    np.testing.assert_array_equal(m.imu.f_b, clean.imu.f_b)
    imu.write_text("\n".join(lines[:801] + [lines[800][:-1] + "7"] + lines[801:]) + "\n")
    with pytest.raises(DataError, match=r"line 802.*--repair-stamps"):
        load_akit(folder)


def _write_twice(path, line, later_s, add=0.0):
    """Write file ``line`` (1-based) of a CSV again after itself, its stamp ``later_s`` s later and ``add`` added to
    its values (a logger writing a row twice with its stamp nudged)."""
    lines = path.read_text().splitlines()
    cells = lines[line - 1].split(",")
    lines.insert(line, ",".join([repr(float(cells[0]) + later_s)] + [repr(float(c) + add) for c in cells[1:]]))
    path.write_text("\n".join(lines) + "\n")


def _read_raw(folder):
    from graphnav.io.loaders import read_akit
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raw = read_akit(folder)
    return raw, [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]


def _noisy(folder, kind="IMU", seed=0):
    """The synthetic folder's ``kind`` file (its DVL holds one velocity) with white noise on every value (the real
    files' rows never repeat)."""
    path = next(folder.glob(f"{kind}_*.csv"))
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    data[:, 1:] += np.random.default_rng(seed).normal(0.0, 1e-3, data[:, 1:].shape)
    write_csv(path, AKIT_COLUMNS[kind], data.tolist())
    return path


@pytest.mark.parametrize("kind, line", [("DVL", 2), ("DVL", 61), ("DVL", 120), ("IMU", 6001)])
def test_akit_row_written_twice_1_ms_later_is_dropped_and_the_published_grid_read(tmp_path, kind, line):
    """A DVL or IMU row written again 1 ms later with the same values (a logger writing a row twice, its stamp
    nudged): the file's stamps were no longer taken for the published linspace(0, T, N) grid and were kept as read,
    the whole file 0.25 % slow (the DVL 0.3 s off at 120 s). The row is the same sample: dropped, warned naming the
    file and line and counted, and the file reads as the clean one, stamps rescaled."""
    from graphnav.core import screening
    folder = make_akit_folder(tmp_path, n=1)
    for noisy in sorted({"IMU", kind}):
        _noisy(folder, noisy)
    clean, _ = _read_raw(folder)
    path = folder / f"{kind}_trajectory1.csv"
    _write_twice(path, line, 0.001)
    raw, caught = _read_raw(folder)
    stream = kind.lower()
    np.testing.assert_array_equal(getattr(raw, stream), getattr(clean, stream))
    assert not any("kept as read" in n for n in raw.meta["streams"][stream]["notes"])
    said = (f"{path}: 1 row(s) repeating the row before them in every value up to 1 ms later (the same sample written "
            f"twice, its stamp nudged) dropped, at line(s) {line + 1}")
    assert any(w.startswith(said) for w in caught), caught
    assert raw.meta["streams"][stream]["refused"] == {screening.NUDGED_COPY: 1}


@pytest.mark.parametrize("kind, line, said", [
    ("DVL", 61, "s) after the row before them (up to 1 ms later): two samples where the stream makes one"),
    ("IMU", 6001, "the IMU clock steps -9.")])
def test_akit_row_written_twice_with_other_values_1_ms_later_is_kept_on_the_published_grid(tmp_path, kind, line, said):
    """A DVL ping (or IMU sample) 1 ms after the one before it with other values: two samples where the grid holds
    one, and nothing tells which is right. Both are kept, warned about with the line and counted as doubted (the
    IMU's as a step of its clock); the file's stamps were kept as read, 0.25 % slow, and are now the published grid
    rescaled: every other row's stamp as in the clean file, the extra one rescaled with them."""
    folder = make_akit_folder(tmp_path, n=1)
    _noisy(folder)
    clean, _ = _read_raw(folder)
    path = folder / f"{kind}_trajectory1.csv"
    stamp = float(path.read_text().splitlines()[line - 1].split(",")[0])
    _write_twice(path, line, 0.001, add=0.01)
    raw, caught = _read_raw(folder)
    stream = kind.lower()
    a, b = getattr(clean, stream), getattr(raw, stream)
    extra = line - 1                                   # the data row after the file line written twice
    np.testing.assert_array_equal(np.delete(b, extra, axis=0), a)
    factor = {"dvl": 119 / 120, "imu": 11999 / 12000}[stream]
    assert b[extra, 0] == pytest.approx((stamp + 0.001) * factor, abs=1e-9)
    assert any(said in w and f"line {line + 1}" in w.replace("line(s)", "line") for w in caught), caught
    assert sum(raw.meta["streams"][stream]["doubted"].values()) == 1
    assert not any("missing from" in w for w in caught), caught


def test_a_published_grid_with_a_stamp_written_twice_is_still_the_grid():
    """A stamp 1 ms after a grid stamp (a 1 Hz or 100 Hz row written twice) is written for that grid point: the grid
    and its factor are read, the stamps leaving it 0.25 % slow before; a stamp 0.3 of a step after one (a logger's
    burst) is still no grid."""
    from graphnav.io import loaders
    for n, rate in ((400, 1.0), (40000, 100.0)):
        t = np.linspace(0.0, 400.0, n)
        twice = np.insert(t, 200, t[199] + 0.001)
        assert loaders.published_period_factor(twice, rate) == pytest.approx((n - 1) / n, rel=1e-12)
        points = loaders.grid_points(twice, loaders.grid_step(twice))
        assert np.flatnonzero(np.diff(points) == 0).tolist() == [199]
        assert loaders.published_period_factor(np.insert(t, 200, t[199] + 0.3 / rate), rate) is None


def test_akit_zero_dvl_velocity_and_an_impossible_latitude_refuse_their_ping_and_row(tmp_path):
    """A DVL row of exactly 0, 0, 0 (how drivers log a ping without bottom lock) is refused, warned with its lines
    and counted, instead of being a measurement of a vehicle standing still; a latitude of 1e308 refuses its GT row
    (it used to stop the whole load with the latitude/longitude unit error)."""
    from graphnav.core.screening import NO_BOTTOM_LOCK
    folder = make_akit_folder(tmp_path, n=1)
    dvl = folder / "DVL_trajectory1.csv"
    lines = dvl.read_text().splitlines()
    for i in range(20, 25):                              # file lines 21-25
        lines[i] = lines[i].split(",")[0] + ",0.0,0,-0.0"
    dvl.write_text("\n".join(lines) + "\n")
    gt = folder / "GT_trajectory1.csv"
    lines = gt.read_text().splitlines()
    cells = lines[40].split(",")                         # file line 41
    lines[40] = ",".join(cells[:2] + ["1e308"] + cells[3:])
    gt.write_text("\n".join(lines) + "\n")
    m, caught = _load_quiet(folder)
    assert m.meta["streams"]["dvl"]["refused"] == {NO_BOTTOM_LOCK: 5}
    assert m.meta["streams"]["gt"]["refused"] == {"latitude beyond 90 deg in 'Latitude [rad]'": 1}
    assert int((~m.dvl.valid.any(axis=1)).sum()) == 5
    assert any(w.startswith(f"{dvl}: 5 DVL ping(s) with a velocity of exactly 0 on every axis (a ping without bottom "
                            "lock: the log's resolution is finer than 1 mm/s or the vehicle is under way) refused at "
                            "line(s) 21, 22, 23, 24, 25") for w in caught), caught
    assert any(w.startswith(f"{gt}: 1 gt sample(s) refused (1 latitude beyond 90 deg in 'Latitude [rad]') at line(s) "
                            "41") for w in caught), caught
    assert len(m.gt.t) == 119 and np.all(np.abs(m.gt.p_n) < 1e4)


def _move_latitude(folder, row, by_rad):
    """Add ``by_rad`` to the latitude cell of GT data ``row`` (file line row + 2) of an A-KIT folder."""
    gt = next(folder.glob("GT_*.csv"))
    lines = gt.read_text().splitlines()
    cells = lines[row + 1].split(",")
    cells[2] = repr(float(cells[2]) + by_rad)
    lines[row + 1] = ",".join(cells)
    gt.write_text("\n".join(lines) + "\n")
    return gt


def _assert_latitude_spike_refused(folder, row, n_rows):
    from graphnav.core.screening import GT_POSITION_SPIKE
    gt = _move_latitude(folder, row, 1e-4)               # 640 m north on one row, its velocity unchanged
    m, caught = _load_quiet(folder)
    reason = GT_POSITION_SPIKE.format("Latitude [rad]")
    assert m.meta["streams"]["gt"]["refused"] == {reason: 1}
    assert any(w.startswith(f"{gt}: 1 gt sample(s) refused (1 {reason}) at line(s) {row + 2};") for w in caught), caught
    assert len(m.gt.t) == n_rows - 1 and np.abs(np.diff(m.gt.p_n[:, 0])).max() < 5.0


def test_akit_latitude_spike_its_velocity_does_not_explain_is_refused(tmp_path):
    """One latitude cell moved by 1e-4 rad (640 m) while the GT's velocity stays: the A-KIT reader refuses the row,
    with the file, line and column, and counts it, as the column-map reader refuses a reference position spike (the
    same rule); it used to be read, the unit checks seeing nothing beyond the radian range."""
    _assert_latitude_spike_refused(make_akit_folder(tmp_path, n=1), 60, 120)


def test_akit_latitude_spike_is_refused_on_a_published_trajectory(akit_dir, tmp_path):
    import shutil
    folder = tmp_path / "Trajectory1"
    shutil.copytree(akit_dir / "Trajectory1", folder)
    _assert_latitude_spike_refused(folder, 200, 400)


def test_akit_dvl_warnings_and_a_stamp_jump_name_the_file_lines_after_a_dropped_row(tmp_path):
    """The A-KIT DVL warnings named ping index + 2 as the line, and the 'more than a year' stamp error the ping
    index: off by one once a row written twice was dropped before them. They name the file lines."""
    folder = make_akit_folder(tmp_path, n=1)
    dvl = folder / "DVL_trajectory1.csv"
    lines = dvl.read_text().splitlines()
    lines.insert(11, lines[10])                          # file line 11 written twice: line 12 is dropped
    edits = {31: "-32.768,0.0,0.0", 41: "0.0,0.0,0.0", 51: "5.0,0.0,0.0", 61: ",,"}
    for line, values in edits.items():
        lines[line - 1] = lines[line - 1].split(",")[0] + "," + values
    dvl.write_text("\n".join(lines) + "\n")
    m, caught = _load_quiet(folder)
    for text in ("first at line 31", "refused at line(s) 41", "at line(s) 51", "first at line 61,"):
        assert any(w.startswith(f"{dvl}:") and text in w for w in caught), (text, caught)
    lines = dvl.read_text().splitlines()
    for i in range(70, len(lines)):                      # from line 71 on the stamps are two years later
        cells = lines[i].split(",")
        lines[i] = ",".join([repr(float(cells[0]) + 2 * 366 * 86400.0)] + cells[1:])
    dvl.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match="more than a year") as err:
        _load_quiet(folder)
    assert (err.value.source, err.value.line, err.value.field) == (str(dvl), 71, "Time [s]")


def test_akit_gt_velocity_in_other_units_is_named_by_the_unit_check(tmp_path):
    """V North/East/Down written in cm/s: the latitude/longitude check against the velocity names the factor and
    the columns, where the speed rule refused every row ('N of N gt samples refused (N GT speed > 4 m/s)')."""
    from graphnav.io.loaders import read_akit
    folder = make_akit_folder(tmp_path, n=1)

    def cms(gt):
        gt[:, 4:7] *= 100.0
    path = _edit_gt(folder, 1, cms)
    with pytest.raises(DataError, match=r"the positions move 0\.00992x as far as the velocity says") as err:
        read_akit(folder)
    assert (err.value.source, err.value.field) == (str(path), "Latitude [rad]/Longitude [rad]")


def _gt_in_degrees(folder, east_shift_deg=0.0, lat=None):
    """The folder's GT latitude/longitude rewritten in degrees, the longitude moved ``east_shift_deg``, the
    latitude set to ``lat`` (deg) when given."""
    path = folder / "GT_trajectory1.csv"
    gt = np.loadtxt(path, delimiter=",", skiprows=1)
    gt[:, 1] = np.degrees(gt[:, 1]) + east_shift_deg
    gt[:, 2] = np.degrees(gt[:, 2]) if lat is None else lat
    write_csv(path, AKIT_COLUMNS["GT"], gt.tolist())


def test_akit_longitude_written_0_to_360_deg_east_is_read(tmp_path):
    """A GT longitude of 215 deg (east of Greenwich written 0..360, as NetCDF and oceanographic tools do) is
    converted like any longitude in degrees: the same track as the file in radians (every row was refused as
    'beyond 180 deg' and the load stopped)."""
    clean, _ = _load_quiet(make_akit_folder(tmp_path / "rad", n=1))
    folder = make_akit_folder(tmp_path / "deg", n=1)
    _gt_in_degrees(folder, 180.0)
    m, _ = _load_quiet(folder)
    assert not m.meta["streams"]["gt"].get("refused")
    np.testing.assert_allclose(m.gt.p_n, clean.gt.p_n, atol=0.01)


def test_akit_latitudes_beyond_90_deg_name_their_column_not_a_column_map(tmp_path):
    """Every GT row refused for a latitude beyond 90 deg: the error names the latitude column (it named the
    stream 'gt') and tells an A-KIT user to check the units, not a column map they do not have."""
    folder = make_akit_folder(tmp_path, n=1)
    _gt_in_degrees(folder, lat=100.0)
    with pytest.raises(DataError) as err:
        _load_quiet(folder)
    assert err.value.field == "Latitude [rad]"
    assert "latitude beyond 90 deg" in str(err.value) and "column map" not in str(err.value)


def test_a_hovering_akit_folder_whose_gyro_is_57_times_too_small_is_warned_about_by_its_gt_attitude(tmp_path):
    """An A-KIT folder of a hovering AUV, its gyro divided by 57.3: the tilt kinematics and the DVL cannot judge the
    gyro's scale; the GT's roll and pitch, as far from level as the accelerometer's tilt, settle the GT's unit and
    its turn (57x the gyro's) is warned about, naming the IMU file's gyro columns and the GT file's attitude columns
    (a GT in degrees on a level vehicle with a tilted IMU gives the same numbers)."""
    from graphnav.io.export import write_akit
    from test_generic_csv import hovering_mission
    write_akit(hovering_mission(tmp_path, np.pi / 180), tmp_path / "small")
    with pytest.warns(RuntimeWarning, match=r"IMU_trajectory1.csv: the gyro rates look 57.3x too small for rad/s: the "
                                            r"reference attitude \(.*GT_trajectory1.csv, columns Roll \[rad\]/Pitch "
                                            r"\[rad\]/Yaw \[rad\]\) turns 5\d\.\dx as fast.*field "
                                            + re.escape("/".join(AKIT_COLUMNS["IMU"][4:7]))):
        load_akit(tmp_path / "small" / "Trajectory1")
    write_akit(hovering_mission(tmp_path), tmp_path / "clean")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_akit(tmp_path / "clean" / "Trajectory1")
    assert [n for n in m.meta["streams"]["imu"]["notes"] if "gyro's scale judged against the reference attitude" in n]


def test_all_zero_imu_rows_of_an_akit_folder_are_refused_before_its_units_and_clocks_are_judged(tmp_path):
    """An A-KIT folder whose IMU file holds a logger's all-zero rows (one alone, 0.5 s of them): they were read as
    measurements, only the run dropped them. Now the reader refuses them as filler under their own reason, in one
    warning naming the file and the lines, and the mission's IMU holds none."""
    from graphnav.io.export import write_akit
    from graphnav.io.loaders import read_mission
    from graphnav.sim.simulate import simulate_mission
    sim = simulate_mission(40.0, seed=5)
    rows = [700, *range(2000, 2050)]
    sim.imu.f_b[rows] = 0.0
    sim.imu.omega_b[rows] = 0.0
    paths = write_akit(sim, tmp_path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = read_mission(tmp_path / "Trajectory1")
    filler = "all-zero IMU row (a logger's filler: zero specific force is impossible under gravity)"
    assert m.meta["streams"]["imu"]["refused"] == {filler: 51}
    assert len(m.imu.t) == len(sim.imu.t) - 51 and np.all(np.any(m.imu.f_b != 0.0, axis=1))
    said = [str(w.message) for w in caught if "all-zero IMU row" in str(w.message)]
    assert len(said) == 1 and said[0].startswith(f"{paths['IMU']}: 51 imu sample(s) refused (51 {filler}) at "
                                                 "line(s) 702, 2002, 2003")


def test_an_akit_file_with_a_decimal_comma_is_told_so_not_too_many_fields(tmp_path):
    """An A-KIT IMU file with one value written "0,5" (quoted, as a spreadsheet exports a decimal comma) was refused as
    'too many fields: 8 fields, expected 7' (its comma split by hand), and so was 0,5 unquoted. The quoted cell is one
    field, refused as a decimal comma with what to write, as a column map's is; the unquoted one is still too many
    fields, said to be likely a decimal comma."""
    from graphnav.io.loaders import AKIT_COLUMNS, read_csv
    header = ",".join(AKIT_COLUMNS["IMU"])
    rows = [f"{0.01 * k:.2f},0.1,0.2,-9.8,0.01,0.02,0.03" for k in range(5)]
    for cell, said in (('"0,5"', r"line 4, field 'ACC Y \[m/s\^2\]': not a number: '0,5', a decimal comma in a quoted "
                                 r"cell of a ','-separated file \(write decimal points: an A-KIT file's separator is "
                                 r"','\)"),
                       ("0,5", r"line 4, field 'GYRO Z \[rad/s\]': too many fields: 8 fields, expected 7; likely a "
                               r"decimal comma \(write decimal points")):
        lines = list(rows)
        lines[2] = lines[2].replace(",0.2,", f",{cell},")
        path = tmp_path / "IMU_trajectory1.csv"
        path.write_text("\n".join([header, *lines]) + "\n")
        with pytest.raises(DataError, match=said):
            read_csv(path, AKIT_COLUMNS["IMU"])
    lines = list(rows)
    lines[2] = lines[2].replace(",0.2,", ',"0.2",')          # quoted without a comma: named as before
    path.write_text("\n".join([header, *lines]) + "\n")
    with pytest.raises(DataError, match=r"line 4, field 'ACC Y \[m/s\^2\]': not a number: '\"0\.2\"'"):
        read_csv(path, AKIT_COLUMNS["IMU"])


def test_an_akit_line_quoting_a_number_beside_a_decimal_comma_names_both_cells(tmp_path):
    """An A-KIT IMU line quoting "0.1" and "0,2": only '0,2' was reported (the quotes were taken off every cell to
    split the line), where "0.1" quoted alone is refused as no number. Both cells are named, each as it is alone."""
    from graphnav.io.loaders import AKIT_COLUMNS, read_csv
    rows = [f"{0.01 * k:.2f},0.1,0.2,-9.8,0.01,0.02,0.03" for k in range(5)]
    rows[2] = rows[2].replace(",0.1,0.2,", ',"0.1","0,2",')
    path = tmp_path / "IMU_trajectory1.csv"
    path.write_text("\n".join([",".join(AKIT_COLUMNS["IMU"]), *rows]) + "\n")
    told = (r"2 bad line\(s\): line 4, column 'ACC X \[m/s\^2\]': not a number: '\"0\.1\"'; line 4, column "
            r"'ACC Y \[m/s\^2\]': not a number: '0,2', a decimal comma in a quoted cell")
    with pytest.raises(DataError, match=told):
        read_csv(path, AKIT_COLUMNS["IMU"])


def test_an_akit_file_separated_by_semicolons_is_told_its_separator(tmp_path):
    """An A-KIT IMU file written by a spreadsheet set to a decimal comma: cells separated by ';' and "0,5" numbers. It
    was refused as 'missing column(s) [all seven]; header is ['Time [s];ACC X [m/s^2];...']', the columns there but
    the separator not named. The refusal says the cells are separated by ';' (or tab) and what an A-KIT file needs."""
    from graphnav.io.loaders import AKIT_COLUMNS, read_csv
    for sep in (";", "\t"):
        rows = [sep.join(["0,01", "0,1", "0,2", "-9,8", "0,01", "0,02", "0,03"])] * 3
        path = tmp_path / "IMU_trajectory1.csv"
        path.write_text("\n".join([sep.join(AKIT_COLUMNS["IMU"]), *rows]) + "\n")
        told = (rf"line 1, field 'Time \[s\]': missing column\(s\) .*; the header's cells are separated by "
                rf"{re.escape(repr(sep))}, an A-KIT file's by ',' \(write ',' between cells and decimal points\)$")
        with pytest.raises(DataError, match=told):
            read_csv(path, AKIT_COLUMNS["IMU"])
    path.write_text("Time [s],ACC X [m/s^2]\n0.1,0.2\n")     # a column missing: named as before
    with pytest.raises(DataError, match=r"missing column\(s\) \['ACC Y .*expected .*'GYRO Z \[rad/s\]'\]$"):
        read_csv(path, AKIT_COLUMNS["IMU"])
