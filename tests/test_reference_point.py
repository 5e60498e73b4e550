"""A log's or bag's reference (ground truth) put on the IMU clock and at the IMU point by the prepare step, as an
A-KIT folder's GT is: its time offset estimated (or the configuration's), its point given by
``reference_position_b`` and written by ``graphnav calibrate``."""
from __future__ import annotations

import dataclasses
import json
import re
import warnings

import numpy as np
import pytest

from graphnav.calibration.calibrate import calibrate
from graphnav.calibration.reference import move_ground_truth
from graphnav.core.rotations import C_b_n_to_euler
from graphnav.missions import load_mission
from graphnav.sim.simulate import simulate_mission

#: The reference's point from the IMU, body frame, m: the Snapir's published GT point is 1.8 m ahead of its IMU.
R_B = np.array([1.8, 0.05, -0.2])


@pytest.fixture(scope="module")
def sim():
    return simulate_mission(duration_s=120.0, seed=4)


def _write(path, header, columns):
    rows = [",".join(header)] + [",".join(f"{x:.12g}" for x in row) for row in np.column_stack(columns)]
    path.write_text("\n".join(rows) + "\n")


def _log(tmp_path, m, gt, **keys):
    """``m`` as a column-map log with ``gt`` as its reference; the configuration gets ``keys``."""
    _write(tmp_path / "imu.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"], [m.imu.t, m.imu.f_b, m.imu.omega_b])
    _write(tmp_path / "dvl.csv", ["t", "vx", "vy", "vz"], [m.dvl.t, m.gt.v_b[np.searchsorted(m.gt.t, m.dvl.t)]])
    _write(tmp_path / "gt.csv", ["t", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [gt.t, gt.p_n, gt.v_n, C_b_n_to_euler(gt.C_b_n)])
    cfg = {"imu": m.config.to_dict()["imu"], "lat_rad": m.config.lat_rad, "gravity_mps2": m.config.gravity_mps2,
           "csv_columns": {"imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"],
                                   "omega_b": ["gx", "gy", "gz"], "frame": "frd"},
                           "dvl": {"file": "dvl.csv", "t": "t", "v_b": ["vx", "vy", "vz"], "clock": "imu"},
                           "gt": {"file": "gt.csv", "t": "t", "p_n": ["n", "e", "d"], "v_n": ["vn", "ve", "vd"],
                                  "euler": ["roll", "pitch", "yaw"], "angle_unit": "rad"}}, **keys}
    (tmp_path / "config.json").write_text(json.dumps(cfg))
    return tmp_path, tmp_path / "config.json"


def _load(data, cfg):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(data, cfg)
    return m, [str(w.message) for w in caught]


def test_a_late_reference_is_put_on_the_imu_clock_and_a_given_offset_wins(sim, tmp_path):
    late = dataclasses.replace(sim.gt, t=sim.gt.t + 0.4)         # the reference logged 0.4 s late
    m, said = _load(*_log(tmp_path, sim, late))
    np.testing.assert_allclose(m.gt.t, sim.gt.t, atol=2e-3)
    assert m.config.gt_time_offset_s == pytest.approx(-0.4, abs=2e-3)
    assert any("gt.csv: time offset -0.400 s added to the reference stamps (estimated" in s for s in said)
    assert any("time offset -0.400 s added" in n for n in m.meta["streams"]["gt"]["notes"])
    # the configuration's offset is used as given, not estimated
    m, said = _load(*_log(tmp_path, sim, late, gt_time_offset_s=-0.3))
    np.testing.assert_allclose(m.gt.t, late.t - 0.3, atol=1e-9)
    assert not any("time offset" in s for s in said)
    # a reference on time stays as read
    m, said = _load(*_log(tmp_path, sim, sim.gt))
    np.testing.assert_allclose(m.gt.t, sim.gt.t, atol=1e-9)
    assert m.config.gt_time_offset_s == 0.0 and not any("time offset" in s for s in said)


def test_a_bag_reference_late_is_put_on_the_imu_clock(sim, tmp_path):
    from graphnav.io.bags import write_mission_bag
    late = dataclasses.replace(sim, gt=dataclasses.replace(sim.gt, t=sim.gt.t + 0.4))
    path = write_mission_bag(late, tmp_path / "late.mcap")
    m, said = _load(path, None)
    assert m.config.gt_time_offset_s == pytest.approx(-0.4, abs=2e-3)
    assert any("time offset -0.400 s added to the reference stamps" in s for s in said)


def test_a_reference_away_from_the_imu_is_moved_there_by_its_configured_point(sim, tmp_path):
    away = move_ground_truth(sim.gt, sim.imu.t, sim.imu.omega_b, R_B, sim.config.lat_rad)
    assert np.abs(away.v_n - sim.gt.v_n).max() > 0.02          # what scoring at the wrong point costs
    m, _ = _load(*_log(tmp_path, sim, away, reference_position_b=R_B.tolist()))
    np.testing.assert_allclose(m.gt.v_n, sim.gt.v_n, atol=2e-3)
    np.testing.assert_allclose(m.gt.p_n, sim.gt.p_n, atol=1e-6)
    assert m.meta["gt_point_b"] == pytest.approx((-R_B).tolist())
    assert any("moved to the IMU point" in n for n in m.meta["streams"]["gt"]["notes"])


def test_calibrate_writes_the_reference_point_of_a_log(sim, tmp_path):
    away = move_ground_truth(sim.gt, sim.imu.t, sim.imu.omega_b, R_B, sim.config.lat_rad)
    m, _ = _load(*_log(tmp_path, sim, away))
    result = calibrate(m, mode="gt")
    np.testing.assert_allclose(result.config.reference_position_b, R_B, atol=0.02)
    np.testing.assert_allclose(result.config.dvl.lever_arm_b, np.zeros(3), atol=0.02)   # the DVL at the IMU
    assert "reference point vs IMU" in result.report()
    # the written configuration reads back and puts the reference at the IMU point
    result.config.save(tmp_path / "calibrated.json")
    m, _ = _load(tmp_path, tmp_path / "calibrated.json")
    np.testing.assert_allclose(m.gt.v_n, sim.gt.v_n, atol=0.01)


def test_an_akit_folder_takes_a_configured_reference_point(akit_dir, tmp_path):
    from graphnav.io.loaders import AKIT_IMU_POSITION_B
    folder = akit_dir / "Trajectory1"
    default, _ = _load(folder, None)
    cfg = tmp_path / "config.json"
    cfg.write_text(json.dumps({"reference_position_b": (-np.asarray(AKIT_IMU_POSITION_B)).tolist()}))
    same, _ = _load(folder, cfg)                 # the vehicle's own point, given: the same mission
    np.testing.assert_array_equal(same.gt.v_n, default.gt.v_n)
    cfg.write_text(json.dumps({"reference_position_b": [0.0, 0.0, 0.0]}))
    published, _ = _load(folder, cfg)            # the GT kept at its published point
    assert published.meta["gt_point_b"] == [0.0, 0.0, 0.0]
    assert np.abs(published.gt.v_n - default.gt.v_n).max() > 0.05


def test_a_given_dvl_time_offset_is_applied_and_a_found_clock_offset_recorded(sim, tmp_path):
    """A log's configured dvl_time_offset_s is added to the DVL stamps (it was ignored); without one the clock
    search's offset is what the configuration records, so calibrate's fine offset adds to the total."""
    data, cfg = _log(tmp_path, sim, sim.gt)
    v_b = sim.gt.v_b[np.searchsorted(sim.gt.t, sim.dvl.t)]
    _write(tmp_path / "dvl.csv", ["t", "vx", "vy", "vz"], [sim.dvl.t - 1.0, v_b])      # the DVL stamped 1 s early
    spec = json.loads(cfg.read_text())
    spec["csv_columns"]["dvl"]["clock"] = "auto"
    cfg.write_text(json.dumps(spec))
    found, _ = _load(data, cfg)
    np.testing.assert_allclose(found.dvl.t, sim.dvl.t, atol=0.05)
    assert found.config.dvl_time_offset_s == pytest.approx(1.0, abs=0.05)
    spec["dvl_time_offset_s"] = 0.7            # given, with the clock search: what it leaves under half a ping stays
    cfg.write_text(json.dumps(spec))
    given, _ = _load(data, cfg)
    np.testing.assert_allclose(given.dvl.t, sim.dvl.t - 1.0 + 0.7)
    assert given.config.dvl_time_offset_s == 0.7
    spec["dvl_time_offset_s"], spec["csv_columns"]["dvl"]["clock"] = 0.0, "auto"    # a full dump's 0: found
    cfg.write_text(json.dumps(spec))
    zero, _ = _load(data, cfg)
    assert zero.config.dvl_time_offset_s == pytest.approx(1.0, abs=0.05)
    spec["dvl_time_offset_s"], spec["csv_columns"]["dvl"]["clock"] = 0.7, "imu"      # no search: as given
    cfg.write_text(json.dumps(spec))
    assert _load(data, cfg)[0].config.dvl_time_offset_s == 0.7
    assert any("given by the configuration's dvl_time_offset_s" in n for n in given.meta["streams"]["dvl"]["notes"])


def test_a_given_reference_offset_puts_a_reference_on_another_clock_onto_the_imu(sim, tmp_path):
    """A configured gt_time_offset_s was ignored when the reference lay off the IMU clock (the load then failed on
    the reference's span): it is applied first."""
    late = dataclasses.replace(sim.gt, t=sim.gt.t + 1000.0)
    m, _ = _load(*_log(tmp_path, sim, late, gt_time_offset_s=-1000.0))
    np.testing.assert_allclose(m.gt.t, sim.gt.t, atol=1e-9)
    assert m.config.gt_time_offset_s == -1000.0


def test_a_reference_offset_is_estimated_with_the_gyro_the_dvl_converted_from_deg_s(sim, tmp_path):
    """A gyro in deg/s that the loader's tilt kinematics left unjudged is converted once the DVL, on a clock of its
    own, is put on the IMU's; the reference's time offset was estimated before, with the rates as read: a reference
    0.4 s late came out -0.405 s with sigma 0.33 s and stayed late without a word. Now after: -0.400 s, applied."""
    from graphnav.calibration.preparation import prepare
    from graphnav.io.loaders import read_mission
    from graphnav.io.units import GYRO_UNJUDGED
    data, cfg = _log(tmp_path, sim, dataclasses.replace(sim.gt, t=sim.gt.t + 0.4))
    _write(tmp_path / "dvl.csv", ["t", "vx", "vy", "vz"],
           [sim.dvl.t + 600.0, sim.gt.v_b[np.searchsorted(sim.gt.t, sim.dvl.t)]])     # the DVL on a clock of its own
    spec = json.loads(cfg.read_text())
    spec["csv_columns"]["dvl"]["clock"] = "auto"
    cfg.write_text(json.dumps(spec))
    read = read_mission(data, cfg)
    # as the loader leaves a calm log's gyro in deg/s: unjudged, for the DVL to judge
    read.meta[GYRO_UNJUDGED] = {"declared": None, "field": "gx/gy/gz", "correlation": 0.2}
    read = dataclasses.replace(read, imu=dataclasses.replace(read.imu, omega_b=np.degrees(read.imu.omega_b)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = prepare(read)
    assert any("gyro read as deg/s and converted" in str(w.message) for w in caught)
    np.testing.assert_allclose(m.imu.omega_b, sim.imu.omega_b, atol=1e-9)
    assert m.config.gt_time_offset_s == pytest.approx(-0.4, abs=2e-3)
    np.testing.assert_allclose(m.gt.t, sim.gt.t, atol=2e-3)


def test_a_score_against_a_log_reference_whose_point_is_not_given_says_so_with_the_fix(sim, tmp_path, capsys):
    """A column-map log without reference_position_b is scored at the IMU point: the summary (summary.json's
    accuracy, the printed score) and graphnav evaluate's report say so, with what it costs and graphnav calibrate;
    nothing said once the point is given, nor for an A-KIT folder (whose format fixes it). The score is unchanged."""
    from graphnav.calibration.preparation import REFERENCE_POINT_UNKNOWN, reference_point_unknown
    from graphnav.commands.common import accuracy_summary, print_summary
    from graphnav.core.solution import NavSolution
    from graphnav.evaluation.score import format_report
    m, _ = _load(*_log(tmp_path, sim, sim.gt))
    sol = NavSolution("LC", m.gt.t, m.gt.p_n, m.gt.v_n + 0.01, m.gt.C_b_n)
    acc = accuracy_summary(sol, m, [])
    assert acc["reference_point"] == REFERENCE_POINT_UNKNOWN
    assert acc["vrmse_mission_mps"] == pytest.approx(0.01 * 3 ** 0.5)
    print_summary({"method": "LC", "mission": "log", "epochs": len(sol.t), "duration_s": 1.0, "runtime_s": 1.0,
                   "realtime_factor": 1.0, "accuracy": acc})
    printed = capsys.readouterr().out.splitlines()
    at = next(i for i, line in enumerate(printed) if "VRMSE mission" in line)
    assert printed[at + 1].startswith("  note: the reference is scored at the IMU point (reference_position_b unset)")
    assert "graphnav calibrate estimates the point" in printed[at + 1]
    assert printed[at + 1].endswith("set reference_position_b [0, 0, 0] if the reference is at the IMU point")
    report = format_report({"matched_poses": 1, "aligned": False, "vrmse_mps": 0.0173, "nees_velocity_mean": None,
                            "rpe_delta": 10.0, "rpe_note": "-", "ape_note": "-", "nees_note": "-",
                            "reference_point": REFERENCE_POINT_UNKNOWN}, "trajectory.csv", "log")
    assert "  VRMSE: 0.0173 m/s\n  note: the reference is scored at the IMU point" in report
    given, _ = _load(*_log(tmp_path, sim, sim.gt, reference_position_b=[0.0, 0.0, 0.0]))
    assert reference_point_unknown(given) is None and "reference_point" not in accuracy_summary(sol, given, [])


def _doubted(said, cfg, key, given):
    """The warnings that name the configuration file ``cfg`` for its ``key`` = ``given`` (s) the data disagree with."""
    return [s for s in said if s.startswith(f"{cfg}: {key} = {given:+.3f} s is given, but the data say ")]


@pytest.mark.parametrize("clock", ["imu", "auto"])
def test_a_given_dvl_time_offset_of_a_log_the_dvl_clock_fit_disagrees_with_is_warned_naming_the_file(sim, tmp_path,
                                                                                                      clock):
    """A log's configured dvl_time_offset_s was used without a word however wrong (a configuration copied from another
    vehicle). It is judged against the DVL clock fit, as an A-KIT folder's is against its GT: 0.5 s and 2 s off are
    warned about naming the configuration file and counted as doubted; the right one is not. With ``clock: auto`` the
    clock search moves a DVL half a ping period or more off (2 s) on: the data decided, and only the search's own
    warning is given (an old configuration's 0 s with a DVL days away is not doubted), with a note naming the
    configuration file, the key and what the search added to it (none before); 0.5 s it leaves as given."""
    data, cfg = _log(tmp_path, sim, sim.gt)
    spec = json.loads(cfg.read_text())
    spec["csv_columns"]["dvl"]["clock"] = clock
    for given in (0.0, 0.5, 2.0):
        cfg.write_text(json.dumps({**spec, "dvl_time_offset_s": given}))
        m, said = _load(data, cfg)
        doubted = _doubted(said, cfg, "dvl_time_offset_s", given)
        searched = clock == "auto" and given > 1.0
        # a DVL the search moves on has its given offset named by a note (the search's warning names no key)
        moved_on = [n for n in m.meta["streams"]["dvl"]["notes"] if "the clock search added" in n]
        assert bool(moved_on) == searched and (not searched or re.fullmatch(
            rf"{re.escape(str(cfg))}: dvl_time_offset_s = \+{given:.3f} s is given; the clock search added "
            r"-[12]\.\d{3} s to it \([+-]0\.0\d\d s used\)", moved_on[0])), moved_on
        if not given or searched:
            assert not doubted and "doubted" not in m.meta["streams"]["dvl"], doubted
            assert m.config.dvl_time_offset_s == pytest.approx(0.0, abs=0.05)
            continue
        assert len(doubted) == 1 and re.search(r"the data say [+-]0\.0[0-4]\d s \(sigma 0\.0[0-2]\d\d s, the DVL's "
                                               r"velocity changes against the IMU's accelerations\): it is used as "
                                               r"given; set dvl_time_offset_s to null", doubted[0]), doubted
        assert m.config.dvl_time_offset_s == given
        assert sum(m.meta["streams"]["dvl"]["doubted"].values()) == len(m.dvl.t)


def test_a_given_reference_time_offset_of_a_log_the_gyro_disagrees_with_is_warned_naming_the_file(sim, tmp_path):
    """A log's configured gt_time_offset_s was used without a word: judged against the reference's attitude
    against the gyro, as an A-KIT folder's is. 0.4 s off warned and counted; the right one (0 s, or -0.4 s for a
    reference logged 0.4 s late) not."""
    late = dataclasses.replace(sim.gt, t=sim.gt.t + 0.4)
    for gt, given, right in ((sim.gt, 0.4, 0.0), (sim.gt, 0.0, 0.0), (late, -0.4, -0.4), (late, 0.0, -0.4)):
        data, cfg = _log(tmp_path, sim, gt, gt_time_offset_s=given)
        m, said = _load(data, cfg)
        doubted, wrong = _doubted(said, cfg, "gt_time_offset_s", given), given != right
        assert len(doubted) == wrong and ("doubted" in m.meta["streams"]["gt"]) == wrong
        np.testing.assert_allclose(m.gt.t, gt.t + given)                        # used as given either way
        if wrong:
            assert re.search(rf"the data say [+-]{abs(right):.3f} s \(sigma 0\.00\d\d s\): it is used as given",
                             doubted[0])


def test_a_given_dvl_time_offset_of_a_bag_is_judged_where_the_clock_fit_can_and_noted_where_not(sim, tmp_path):
    """A bag's configured dvl_time_offset_s is judged as a log's is; the simulator's 0.042 m/s beam noise hides its
    gentle accelerations from the clock fit in 120 s, so there the offset is not judged, and the DVL's notes say so."""
    from graphnav.core.config import SensorConfig
    from graphnav.io.bags import write_mission_bag
    quiet = SensorConfig()
    quiet.dvl = dataclasses.replace(quiet.dvl, beam_noise_std=0.01)
    cfg = tmp_path / "config.json"
    for mission, judged, offsets in ((simulate_mission(120.0, seed=4, config=quiet), True, (0.0, 0.45, 2.0)),
                                     (sim, False, (2.0,))):
        bag = write_mission_bag(mission, tmp_path / f"{judged}.mcap")
        for given in offsets:
            cfg.write_text(json.dumps({"dvl_time_offset_s": given}))
            m, said = _load(bag, cfg)
            # a bag's DVL clock is searched: 2 s off is moved on (the search's warning), 0.45 s is left as given
            assert len(_doubted(said, cfg, "dvl_time_offset_s", given)) == (judged and 0 < given < 1), said
            unjudged = [n for n in m.meta["streams"]["dvl"]["notes"] if "dvl_time_offset_s is not judged" in n]
            assert bool(unjudged) != judged


def test_a_given_dvl_time_offset_of_200_s_of_trajectory1_as_a_column_map_log(akit_dir, tmp_path):
    """The first 200 s of Trajectory1 as a column-map log, its DVL on the IMU clock at the offset prepare found
    against the GT: its clock fit adds +0.076 s (sigma 0.006 s), so the right offset, 0 s, is not doubted (the fit is
    not the fine offset against a reference: preparation.GIVEN_DVL_CLOCK_FLOOR_S); 0.5 s is."""
    from test_dvl_frame import _akit_log_on_its_own_clock
    folder, cfg = _akit_log_on_its_own_clock(akit_dir, tmp_path / "log", 200.0, earth=False, dvl_shift=0.0)
    spec = json.loads(cfg.read_text())
    for given, wrong in ((0.0, False), (0.5, True)):
        cfg.write_text(json.dumps({**spec, "dvl_time_offset_s": given}))
        m, said = _load(folder, cfg)
        doubted = _doubted(said, cfg, "dvl_time_offset_s", given)
        assert len(doubted) == wrong, said
        if wrong:
            assert re.search(r"the data say \+0\.0[5-9]\d s \(sigma 0\.00\d\d s, the DVL", doubted[0])
