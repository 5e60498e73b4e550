"""``graphnav info`` (graphnav.io.inspect.describe), the loaders' stream counts, and DVL dead reckoning of a DVL log
without an IMU (graphnav.estimators.dead_reckoning, ``smooth --data FILE.pd0``)."""
from __future__ import annotations

import json
import re
import warnings

import numpy as np
import pytest

from graphnav import cli
from graphnav.calibration.preparation import prepare
from graphnav.core.dvl_log import DvlLog
from graphnav.core.errors import DataError
from graphnav.estimators.dead_reckoning import dvl_dead_reckoning
from graphnav.io.inspect import describe, format_description
from graphnav.io.paths import akit_dir, data_root
from graphnav.io.stream_counts import NO_VALID_BEAM
from graphnav.sim.simulate import simulate_mission

SPEED = 1.5          # m/s
PERIOD = 200.0       # s, one full circle


# --- DVL dead reckoning on a synthetic log -------------------------------------------------------------------
def circle_log(with_v_n: bool = True, drop: slice | None = None, remove: slice | None = None,
               depth: bool = False) -> tuple[DvlLog, float]:
    """A DVL log of a vehicle on a circle at SPEED (clockwise seen from above: heading = 360 t / PERIOD deg),
    1 Hz pings, level; ``drop``: pings without a measurement; ``remove``: pings missing from the log."""
    t = np.arange(0.0, PERIOD + 0.5, 1.0)
    heading = 2 * np.pi * t / PERIOD
    v_n = SPEED * np.column_stack([np.cos(heading), np.sin(heading), np.zeros_like(t)])
    v_d = np.tile([SPEED, 0.0, 0.0], (len(t), 1))
    valid = np.ones(len(t), bool)
    if drop is not None:
        valid[drop] = False
        v_n[drop] = np.nan
        v_d[drop] = np.nan
    keep = np.ones(len(t), bool)
    if remove is not None:
        keep[remove] = False
    attitude = np.column_stack([np.degrees(heading) % 360, np.zeros_like(t), np.zeros_like(t)])
    log = DvlLog(t=t[keep], v_d=v_d[keep], v_d_valid=valid[keep], frame="instrument",
                 attitude_deg=attitude[keep], v_n=v_n[keep] if with_v_n else None,
                 depth_m=(10.0 + 0.01 * t[keep]) if depth else None, source="circle")
    return log, SPEED * PERIOD / (2 * np.pi)


def true_position(t: np.ndarray, radius: float) -> np.ndarray:
    a = 2 * np.pi * t / PERIOD
    return radius * np.column_stack([np.sin(a), 1 - np.cos(a)])


@pytest.mark.parametrize("with_v_n", [True, False], ids=["v_n", "v_d+attitude"])
def test_circle_at_known_speed_closes(with_v_n):
    log, radius = circle_log(with_v_n)
    sol = dvl_dead_reckoning(log)
    assert sol.method == "DVL-DR" and sol.info["velocity"] == ("v_n" if with_v_n else "v_d+attitude")
    # a full circle: back at the start; the trapezoid on 1 Hz pings keeps every point within 1 mm of the circle
    assert np.linalg.norm(sol.p_n[-1] - sol.p_n[0]) < 1e-9
    err = np.linalg.norm(sol.p_n[:, :2] - true_position(sol.t, radius), axis=1)
    # the trapezoid shrinks each 1-s step by cos(dtheta/2): 2 R dtheta^2 / 12 = 7.8 mm across the circle
    assert err.max() < 0.01
    # the path length of the trapezoid: each step is |v_k + v_k+1| / 2 = SPEED cos(dtheta / 2) long
    assert sol.info["distance_m"] == pytest.approx(SPEED * PERIOD * np.cos(np.pi / PERIOD), rel=1e-9)
    # a quarter of the way round: R north and R east of the start, heading 90 deg
    quarter = np.searchsorted(sol.t, PERIOD / 4)
    assert sol.p_n[quarter, 0] == pytest.approx(radius, rel=1e-3) and sol.p_n[quarter, 1] == pytest.approx(
        radius, rel=1e-3)
    assert np.degrees(np.arctan2(sol.C_b_n[quarter, 1, 0], sol.C_b_n[quarter, 0, 0])) == pytest.approx(90.0)


@pytest.mark.parametrize("how", ["drop", "remove"])
def test_a_20_s_gap_is_bridged_without_a_jump(how):
    gap = slice(50, 70)                       # pings 50..69 missing: 21 s between the measured pings 49 and 70
    log, radius = circle_log(**{how: gap})
    with pytest.warns(RuntimeWarning, match=r"1 gap\(s\).*longest 21\.0 s"):
        sol = dvl_dead_reckoning(log)
    assert [g["length_s"] for g in sol.info["gaps"]] == [pytest.approx(21.0)]
    # epochs every second across the gap (filled in where the log has no ping), no step longer than the speed
    assert np.allclose(np.diff(sol.t), 1.0)
    step = np.linalg.norm(np.diff(sol.p_n[:, :2], axis=0), axis=1)
    assert step.max() <= SPEED * 1.0 + 1e-9
    counted = sol.info["pings_interpolated"] if how == "drop" else sol.info["epochs_filled"]
    assert counted == 20
    # the bridge is the chord-like interpolation of the two velocities: off the circle by less than the sagitta
    # of a 21 s arc, and the track is exact again in velocity after the gap
    err = np.linalg.norm(sol.p_n[:, :2] - true_position(sol.t, radius), axis=1)
    assert 0.1 < err[-1] < radius * (1 - np.cos(np.pi * 21 / PERIOD)) * 2


@pytest.mark.parametrize("later_s, words", [(3 * 86400.0, "3 day(s) (259201 s)"), (2 * 3600.0, "2 h (7201 s)"),
                                             (3600.0, "1 h (3601 s)"), (3659.0, "1.02 h (3660 s)")])
def test_a_gap_of_hours_or_days_is_refused_naming_it_not_bridged(later_s, words):
    """The circle log whose pings from the 101st on come 3 days (or 2 h) later, as a log joined to the next one's
    or a clock set on: refused naming the gap by its pings and where to cut the log. It was bridged by interpolating
    the velocity across it (3 days: 389 km "travelled"), warned only as a gap whose track is a guess. A 59 min gap
    is still bridged, warned. A gap just over the hour is said with its seconds (it read "1.0 h", as the limit it is
    over)."""
    log, _ = circle_log()
    t = np.where(np.arange(len(log.t)) >= 100, log.t + later_s, log.t)
    joined = DvlLog(t=t, v_d=log.v_d, v_d_valid=log.v_d_valid, frame="instrument", attitude_deg=log.attitude_deg,
                    v_n=log.v_n, source="joined")
    with pytest.raises(DataError, match=re.escape(
            f"joined, field 't': 1 gap(s) without a velocity over ground longer than 1 h (3600 s): {words} from "
            f"ping 100 at t = 99.000 s to ping 101 at t = {100 + later_s:.3f} s. A dead reckoning cannot bridge that")
            + ".*"
            + re.escape("dead-reckon each side on its own: cut the log before ping 101")):
        dvl_dead_reckoning(joined)
    hour = DvlLog(t=np.where(np.arange(len(log.t)) >= 100, log.t + 3539.0, log.t), v_d=log.v_d,
                  v_d_valid=log.v_d_valid, frame="instrument", attitude_deg=log.attitude_deg, v_n=log.v_n,
                  source="59 min")
    with pytest.warns(RuntimeWarning, match=r"1 gap\(s\).*longest 3540\.0 s"):
        assert [g["length_s"] for g in dvl_dead_reckoning(hour).info["gaps"]] == [pytest.approx(3540.0)]


def test_depth_sensor_sets_the_vertical_and_nothing_to_integrate_is_an_error():
    log, _ = circle_log(depth=True)
    sol = dvl_dead_reckoning(log)
    assert sol.info["vertical"] == "depth" and np.allclose(sol.p_n[:, 2], 10.0 + 0.01 * sol.t)
    bare = DvlLog(t=log.t, v_d=log.v_d, v_d_valid=log.v_d_valid, frame="instrument", source="bare")
    with pytest.raises(DataError, match="no velocity over ground in NED .* no attitude"):
        dvl_dead_reckoning(bare)
    one, _ = circle_log(drop=slice(1, None))
    with pytest.raises(DataError, match="1 ping"):
        dvl_dead_reckoning(one)


def test_dead_reckoning_of_pings_out_of_time_order_says_what_to_do():
    """A log whose stamps mostly run back (a CSV written newest first) is refused saying what to do with it; it
    said only "ping stamps do not increase"."""
    log, _ = circle_log()
    backwards = DvlLog(t=log.t[::-1].copy(), v_d=log.v_d, v_d_valid=log.v_d_valid, frame="instrument",
                       attitude_deg=log.attitude_deg, v_n=log.v_n, source="backwards")
    with pytest.raises(DataError, match=r"field 't': ping stamps do not increase \(median step -1 s between the 201 "
                                        r"pings with a velocity\): put the pings in time order, each with a time of "
                                        "its own"):
        dvl_dead_reckoning(backwards)


# --- describe: simulated missions in the formats graphnav reads ----------------------------------------------
@pytest.fixture(scope="module")
def sim():
    mission = simulate_mission(duration_s=30.0, seed=5, dvl_stamp_offset_s=0.37)
    valid = mission.dvl.valid.copy()
    valid[[3, 4, 5], :] = False               # three pings without any valid beam
    valid[10, 1] = False                      # one 3-beam ping
    return mission.with_dvl_valid(valid)


def speed_median(mission) -> float:
    from graphnav.core.dvl import DvlGeometry
    v = DvlGeometry.from_spec(mission.config.dvl).velocity_from_beams(mission.dvl.beams, mission.dvl.valid,
                                                                     allow_missing=True)
    return float(np.nanmedian(np.linalg.norm(v, axis=1)))


def test_info_on_a_bag(sim, tmp_path):
    pytest.importorskip("rosbags", reason="graphnav[ros] not installed")
    from graphnav.io.bags import write_mission_bag
    import dataclasses
    mission = dataclasses.replace(sim, dvl=dataclasses.replace(sim.dvl, v_b=None))
    bag = write_mission_bag(mission, tmp_path / "sim.mcap")
    d = describe(bag, prepare=prepare)
    assert d["format"] == "rosbag2" and d["usable"] and d["ground_truth"]
    s = d["streams"]
    assert s["imu"]["read"] == len(sim.imu.t) and s["imu"]["rate_hz"] == pytest.approx(100.0, rel=1e-6)
    assert s["dvl"]["read"] == len(sim.dvl.t) and s["dvl"]["rate_hz"] == pytest.approx(1.0, rel=1e-6)
    # the bag reader names its own reason (a bag's DVL may also carry a velocity): one reason, three pings
    (reason, n), = s["dvl"]["refused"].items()
    assert reason.startswith("no valid beam") and n == 3 and s["dvl"]["used"] == len(sim.dvl.t) - 3
    assert d["dvl"]["beams_per_ping"] == {"4": len(sim.dvl.t) - 4, "3": 1, "0": 3}
    assert d["dvl"]["speed_mps"]["median"] == pytest.approx(speed_median(sim), abs=1e-5)   # float32 beams
    # pressure written with the simulation's gravity, read back with the default configuration's
    assert d["depth_m"]["min"] == pytest.approx(sim.depth.depth.min(), abs=1e-3)
    assert any("no valid beam" in w for w in d["warnings"])
    assert s["dvl"]["source"].endswith("/dvl/data (marine_acoustic_msgs/msg/Dvl)")
    assert d["duration_s"] == pytest.approx(sim.t1 - sim.t0, abs=1e-6)


def test_info_on_akit_files_written_from_a_simulation(sim, tmp_path):
    from graphnav.io.export import write_akit
    write_akit(sim, tmp_path, number=7)
    folder = tmp_path / "Trajectory7"
    d = describe(folder, prepare=prepare)
    assert d["format"] == "akit" and d["usable"]
    s = d["streams"]
    assert s["imu"]["read"] == len(sim.imu.t) and s["gt"]["read"] == len(sim.gt.t)
    # the A-KIT DVL file holds the pings with a velocity (the simulation keeps v_b on the pings made invalid)
    assert s["dvl"]["read"] == len(sim.dvl.t) and s["dvl"]["refused"] == {}
    assert any("time offset" in n for n in s["dvl"]["notes"])
    assert d["dvl"]["speed_mps"]["median"] == pytest.approx(speed_median(sim), rel=0.02)
    text = format_description(d)
    assert "A-KIT" in text and "imu" in text and "refused" in text


def test_info_on_a_json_lines_stream(sim, tmp_path):
    from graphnav.estimators.replay import mission_records
    from graphnav.io.streamio import write_records
    path = tmp_path / "stream.jsonl"
    with path.open("w") as fh:
        write_records(mission_records(sim), fh)
        fh.write("not json\n{\"type\": \"imu\", \"t\": 1.0}\n")
    d = describe(path)
    assert d["format"] == "jsonl" and d["usable"]
    s = d["streams"]
    assert s["imu"]["read"] == len(sim.imu.t) and s["dvl"]["read"] == len(sim.dvl.t)
    assert s["dvl"]["refused"] == {"no valid beam": 3}
    assert s["lines"]["refused"] == {"not a valid record (not JSON, unknown type or missing field)": 2}
    assert d["dvl"]["speed_mps"]["median"] == pytest.approx(speed_median(sim), abs=1e-9)


def test_info_on_a_json_lines_stream_shows_the_imu_rate_measured_from_its_stamps(sim, tmp_path):
    """A 70 Hz IMU on a 10 ms clock (steps of 10 and 20 ms) showed 100 Hz, its median step: now 70 Hz, as the
    other readers show it."""
    import dataclasses
    from graphnav.estimators.replay import mission_records
    from graphnav.io.streamio import write_records
    stamps = np.floor(np.arange(sim.imu.t.size) / 70.0 / 0.01 + 1e-9) * 0.01
    path = tmp_path / "stream.jsonl"
    with path.open("w") as fh:
        write_records(mission_records(dataclasses.replace(sim, imu=dataclasses.replace(sim.imu, t=stamps))), fh)
    assert describe(path)["streams"]["imu"]["rate_hz"] == pytest.approx(70.0, rel=1e-3)


def test_cli_json_parses_and_exit_codes(sim, tmp_path, capsys):
    from graphnav.estimators.replay import mission_records
    from graphnav.io.streamio import write_records
    path = tmp_path / "s.jsonl"
    with path.open("w") as fh:
        write_records(mission_records(sim), fh)
    assert cli.main(["info", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["format"] == "jsonl" and d["streams"]["depth"]["read"] == len(sim.depth.t)
    (tmp_path / "notes.txt").write_text("hello\n")
    assert cli.main(["info", str(tmp_path / "notes.txt")]) == 2
    assert "not a format graphnav reads" in capsys.readouterr().out
    assert cli.main(["info", str(tmp_path / "missing")]) == 2


# --- real data (skipped when ../shared/data is absent) ------------------------------------------------------
def test_info_on_a_shared_akit_folder(capsys):
    root = akit_dir()
    if root is None or not (root / "Trajectory1").is_dir():
        pytest.skip("shared A-KIT data not found (GRAPHNAV_DATA or ../shared/data)")
    assert cli.main(["info", str(root / "Trajectory1"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    s = d["streams"]
    assert (s["imu"]["read"], s["dvl"]["read"], s["gt"]["read"]) == (40000, 400, 400)
    assert s["imu"]["rate_hz"] == pytest.approx(100.0, rel=1e-3) and s["dvl"]["rate_hz"] == pytest.approx(1.0, rel=1e-3)
    assert 1.0 < d["dvl"]["speed_mps"]["median"] < 2.5 and d["dvl"]["speed_mps"]["max"] < 4.0
    assert 10.0 < d["depth_m"]["min"] < d["depth_m"]["max"] < 40.0
    assert any("axis signs" in n for n in s["imu"]["notes"])


#: file -> (usable, model, frame or the reason it is refused, ensembles in the file; dolfyn leaves out a
#: file's last ensemble, which is counted as refused)
PD0_FILES = {"RiverPro_test01.PD0": (True, "RiverPro", "beam", 273),
             "RDI_withBT.000": (True, "Workhorse", "earth", 1721),
             "winriver01.PD0": (True, "Workhorse", "ship", 262),
             "sentinelv_b5.pd0": (False, "SentinelV", "no bottom track", 0)}


def shared_pd0(name: str):
    pytest.importorskip("mhkit.dolfyn", reason="graphnav[pd0] not installed")
    root = data_root()
    path = None if root is None else root / "real-formats" / "pd0" / name
    if path is None or not path.is_file():
        pytest.skip(f"shared PD0 file {name} not found (GRAPHNAV_DATA or ../shared/data)")
    return path


@pytest.mark.parametrize("name", sorted(PD0_FILES))
def test_info_on_the_shared_pd0_files(name, capsys):
    path = shared_pd0(name)
    usable, model, what, read = PD0_FILES[name]
    assert cli.main(["info", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["format"] == "pd0" and d["usable"] is usable and d["instrument"]["model"] == model
    assert d["streams"] and d["time_span_s"][0] > 1.4e9           # the instrument's real-time clock
    if usable:
        assert d["dvl_frame"] == what and d["streams"]["dvl"]["read"] == read
        assert 0.01 < d["dvl"]["speed_mps"]["median"] < 3.0 and "DVL dead reckoning" in d["use"]
    else:
        assert what in d["reason"]


def test_smooth_dead_reckons_the_beam_coordinate_pd0_file(tmp_path):
    path = shared_pd0("RiverPro_test01.PD0")
    out = tmp_path / "dr"
    with pytest.warns(RuntimeWarning, match="not graphnav's IMU/DVL estimator.*csv_columns"):
        assert cli.main(["smooth", "--data", str(path), "--out", str(out), "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["method"] == "DVL-DR" and summary["streams"]["dvl"]["read"] == 273   # 272 read by dolfyn, its last ensemble refused
    assert "csv_columns" in summary["warnings"][0]
    assert summary["position_frame"]["set_by"] == "unknown start"      # no frame was written
    from graphnav.io.outputs import read_trajectory_csv, read_tum
    sol = read_trajectory_csv(out / "trajectory.csv")
    t_tum, p_tum, _ = read_tum(out / "trajectory.tum")
    assert len(sol.t) == len(t_tum) == 272 and np.allclose(sol.t, t_tum, atol=1e-6)
    assert np.allclose(sol.p_n, p_tum, atol=1e-6)
    # the boat ran ~200 m by its GPS; the dead reckoning ends 18 m from the GPS's end (the file's compass)
    assert 150.0 < summary["dead_reckoning"]["distance_m"] < 250.0


def test_smooth_dead_reckoning_matches_the_gps_in_the_file():
    """The sign and frame of v_n: the RiverPro file carries the boat's GPS; the dead-reckoned track must follow it
    (a flipped sign or a 90 deg frame error would end hundreds of metres off)."""
    path = shared_pd0("RiverPro_test01.PD0")
    from graphnav.evaluation.metrics import track_against_fixes
    from graphnav.io import pd0
    from graphnav.io.dvl_files import read_dvl
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = dvl_dead_reckoning(read_dvl(path))
        track = track_against_fixes(sol, *pd0.gps_fixes(path))
    assert track["run_m"] > 150.0
    assert track["end_m"] < 0.15 * track["run_m"]


def test_info_on_a_csv_log_with_the_column_map(sim, tmp_path, capsys):
    """The column map: IMU in g and deg/s, DVL beams in mm/s with RDI's -32768 where invalid, ms stamps."""
    def write(path, header, columns):
        rows = [",".join(header)] + [",".join(f"{x:.12g}" for x in row) for row in np.column_stack(columns)]
        path.write_text("\n".join(rows) + "\n")
    t0 = 1_700_000_000.0
    write(tmp_path / "imu.csv", ["ms", "ax", "ay", "az", "gx", "gy", "gz"],
          [(sim.imu.t + t0) * 1e3, sim.imu.f_b / 9.80665, np.degrees(sim.imu.omega_b)])
    write(tmp_path / "dvl.csv", ["ms", "b1", "b2", "b3", "b4"],
          [(sim.dvl.t + t0) * 1e3, np.where(sim.dvl.valid, sim.dvl.beams * 1e3, -32768.0)])
    cfg = sim.config.to_dict()
    cfg["csv_columns"] = {
        "time_unit": "ms",
        "imu": {"file": "imu.csv", "t": "ms", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"],
                "accel_unit": "g", "gyro_unit": "deg/s"},
        "dvl": {"file": "dvl.csv", "t": "ms", "beams": ["b1", "b2", "b3", "b4"], "velocity_unit": "mm/s"}}
    (tmp_path / "config.json").write_text(json.dumps(cfg))
    assert cli.main(["info", str(tmp_path), "--config", str(tmp_path / "config.json"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["format"] == "csv" and d["usable"] and not d["ground_truth"] and d["depth_m"] is None
    s = d["streams"]
    assert s["imu"]["read"] == len(sim.imu.t) and s["dvl"]["refused"] == {NO_VALID_BEAM: 3}
    assert any("g, gyro_unit deg/s" in n for n in s["imu"]["notes"])
    assert any("RDI bad-velocity flag" in w for w in d["warnings"])          # the loader's own warning
    # as every command prints a warning: its message, not Python's category name before it
    assert not any(w.startswith(("RuntimeWarning", "UserWarning")) for w in d["warnings"])
    assert d["dvl"]["speed_mps"]["median"] == pytest.approx(speed_median(sim), abs=1e-9)
    # without the map the same folder is not something graphnav reads
    assert cli.main(["info", str(tmp_path)]) == 2


def test_smooth_summary_carries_the_streams(tmp_path):
    out = tmp_path / "s"
    assert cli.main(["smooth", "--duration", "20", "--method", "Graph-TC", "--no-plots", "--out", str(out)]) == 0
    streams = json.loads((out / "summary.json").read_text())["streams"]
    assert streams["imu"]["read"] == streams["imu"]["used"] == 2001          # 0 .. 20 s at 100 Hz
    assert streams["imu"]["rate_hz"] == pytest.approx(100.0) and streams["dvl"]["read"] == 21


def test_info_on_a_pd0_file_alone_and_with_the_imu_of_the_column_map(tmp_path, capsys):
    """A synthetic beam-coordinate PD0 file (tests/test_pd0.py writes it): alone it is a DVL log for dead
    reckoning, with the IMU of the configuration's column map it is a mission."""
    pytest.importorskip("mhkit.dolfyn", reason="graphnav[pd0] not installed")
    from test_pd0 import START, write_pd0

    from graphnav.core.config import SensorConfig
    config = SensorConfig()
    config.dvl.psi_rad = np.deg2rad([180.0, 0.0, 90.0, 270.0])      # a convex RDI head, 30 deg beams
    config.dvl.theta_rad = np.deg2rad(30.0)
    mission = simulate_mission(duration_s=20.0, seed=2, config=config)
    write_pd0(tmp_path / "dvl.000", mission)
    alone = describe(tmp_path / "dvl.000")
    assert alone["format"] == "pd0" and alone["usable"] and "DVL dead reckoning" in alone["use"]
    n = len(mission.dvl.t) - 1                          # dolfyn does not read a file's last ensemble
    assert alone["streams"]["dvl"]["read"] == n + 1 and alone["dvl_frame"] == "beam"
    assert alone["streams"]["dvl"]["refused"] == {"not read by dolfyn (last ensemble)": 1}
    assert alone["time_span_s"][0] == pytest.approx(START.timestamp() + mission.dvl.t[0], abs=1e-3)
    assert alone["dvl"]["speed_mps"]["median"] == pytest.approx(
        np.median(np.linalg.norm(mission.dvl.v_b[:n], axis=1)), rel=0.02)
    rows = ["t,ax,ay,az,gx,gy,gz"] + [",".join(f"{x:.12g}" for x in (t + START.timestamp(), *f, *w))
                                       for t, f, w in zip(mission.imu.t, mission.imu.f_b, mission.imu.omega_b)]
    (tmp_path / "imu.csv").write_text("\n".join(rows) + "\n")
    cfg = mission.config.to_dict()
    cfg["csv_columns"] = {"imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"],
                                  "omega_b": ["gx", "gy", "gz"]}}
    (tmp_path / "config.json").write_text(json.dumps(cfg))
    with_imu = describe(tmp_path / "dvl.000", tmp_path / "config.json", prepare=prepare)
    assert with_imu["usable"] and "IMU/DVL estimators" in with_imu["use"]
    assert with_imu["streams"]["imu"]["read"] == len(mission.imu.t) and with_imu["streams"]["dvl"]["read"] == n + 1
    # the pressure sensor at the pings, to the decapascal of PD0
    depth_at_pings = np.interp(mission.dvl.t[:n], mission.depth.t, mission.depth.depth)
    assert with_imu["depth_m"]["max"] == pytest.approx(depth_at_pings.max(), abs=2e-3)


@pytest.mark.parametrize("missing", ["IMU", "DVL"])
def test_info_on_an_akit_folder_missing_a_file_names_it(tmp_path, capsys, missing):
    """A TrajectoryN folder without its IMU or DVL file is an A-KIT folder with a file missing, as ``smooth`` says,
    not "not a format graphnav reads"."""
    folder = tmp_path / "Trajectory1"
    folder.mkdir()
    for kind in {"IMU", "DVL", "GT"} - {missing}:
        (folder / f"{kind}_trajectory1.csv").write_text("Time [s]\n")
    d = describe(folder)
    assert d["format"] == "akit" and d["usable"] is False
    assert f"{missing}_trajectory1.csv: {missing} file not found" in d["reason"]
    assert cli.main(["info", str(folder)]) == 0
    assert f"{missing} file not found" in capsys.readouterr().out
    with pytest.raises(DataError, match=f"{missing} file not found"):      # smooth's reader says the same
        from graphnav.io.loaders import read_mission
        read_mission(folder)


def test_info_and_smooth_agree_on_a_written_folder_whose_dvl_is_days_away(tmp_path, capsys):
    """A folder ``graphnav simulate`` wrote with its DVL and beams files moved three days: the paper's beam noise
    hides the simulator's accelerations, so the clock cannot be found; info says the mission is not usable, and
    why, and smooth fails with the same error naming the DVL file, both spans and what to do (before: info said
    "usable yes" with every ping refused, and smooth failed with "navigator: 151 of 151 dvl samples refused")."""
    from graphnav.io.export import write_akit
    from graphnav.io.loaders import read_mission
    from test_clock import shift_file_stamps
    paths = write_akit(simulate_mission(150.0, seed=5), tmp_path)
    for kind in ("DVL", "beams"):
        shift_file_stamps(paths[kind], 3 * 86400.0)
    folder = tmp_path / "Trajectory1"
    d = describe(folder, prepare=prepare)
    assert d["format"] == "akit" and not d["usable"]
    assert d["reason"].startswith(f"{paths['DVL']}, field 'Time [s]': DVL stamps [259200.000, 259350.000] s lie "
                                  "outside the IMU span [0.000, 150.000] s")
    assert "give dvl_time_offset_s" in d["reason"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError) as err:
            prepare(read_mission(folder))
    assert str(err.value) == d["reason"]
    assert cli.main(["smooth", "--data", str(folder), "--out", str(tmp_path / "out"), "--no-plots"]) != 0
    assert d["reason"] in capsys.readouterr().err


def test_info_does_not_call_usable_a_log_whose_dvl_lies_off_the_imu_clock(sim, tmp_path):
    """A CSV log whose column map declares the DVL on the IMU clock (``"clock": "imu"``) while its stamps are a day
    later: not usable, naming the DVL file and both spans (before: usable, with every ping refused)."""
    def write(path, header, columns):
        rows = [",".join(header)] + [",".join(f"{x:.12g}" for x in row) for row in np.column_stack(columns)]
        path.write_text("\n".join(rows) + "\n")
    write(tmp_path / "imu.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"], [sim.imu.t, sim.imu.f_b, sim.imu.omega_b])
    write(tmp_path / "dvl.csv", ["t", "b1", "b2", "b3", "b4"], [sim.dvl.t + 86400.0, sim.dvl.beams])
    cfg = sim.config.to_dict()
    cfg["csv_columns"] = {
        "imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"]},
        "dvl": {"file": "dvl.csv", "t": "t", "beams": ["b1", "b2", "b3", "b4"], "clock": "imu"}}
    (tmp_path / "config.json").write_text(json.dumps(cfg))
    d = describe(tmp_path, tmp_path / "config.json", prepare=prepare)
    assert d["format"] == "csv" and not d["usable"], d
    assert str(tmp_path / "dvl.csv") in d["reason"] and "outside the IMU span [0.000, 30.000] s" in d["reason"]


def test_info_on_a_json_lines_stream_counts_samples_sharing_a_stamp(sim, tmp_path):
    """A 100 Hz IMU in packets of 20 sharing one stamp (a driver stamping each read on receipt) showed 5 Hz, the
    packets' rate, where the Navigator restamps them and runs at 100 Hz: the samples are counted, and the note and
    warning say how their stamps are read."""
    from graphnav.estimators.replay import mission_records
    from graphnav.io.streamio import write_records
    records = list(mission_records(sim))
    imu = [r for r in records if r["type"] == "imu"]
    for i, r in enumerate(imu):
        r["t"] = imu[min(i // 20 * 20 + 19, len(imu) - 1)]["t"]
    path = tmp_path / "stream.jsonl"
    with path.open("w") as fh:
        write_records(records, fh)
    d = describe(path)
    assert d["streams"]["imu"]["rate_hz"] == pytest.approx(100.0, rel=1e-6)
    assert any("packets of 20" in n for n in d["streams"]["imu"]["notes"])
    assert any("packets of 20" in w for w in d["warnings"])


def test_info_on_a_json_lines_stream_warns_of_a_step_of_the_imu_clock_naming_the_line(sim, tmp_path):
    """A JSON-lines stream's IMU stamps stepping +5 ms half-way showed nothing in graphnav info, where a log's are
    warned and counted: the same check names the file, the line and the field (in the warnings info shows), and
    counts the sample as doubted; the clean stream says nothing."""
    import dataclasses
    from graphnav.core.screening import CLOCK_STEP
    from graphnav.estimators.replay import mission_records
    from graphnav.io.streamio import write_records
    n = sim.imu.t.size
    t = sim.imu.t + np.where(np.arange(n) >= n // 2, 0.005, 0.0)
    path = tmp_path / "stream.jsonl"
    with path.open("w") as fh:
        write_records(mission_records(dataclasses.replace(sim, imu=dataclasses.replace(sim.imu, t=t))), fh)
    line = next(i for i, s in enumerate(path.read_text().splitlines(), start=1)
                if s.startswith(f'{{"type":"imu","t":{float(t[n // 2])!r},'))
    d = describe(path)
    said = [w for w in d["warnings"] if "off its period" in w]
    assert len(said) == 1 and said[0].startswith(f"imu: {path}, line {line}, field 't': the IMU clock steps +5 ms")
    assert d["streams"]["imu"]["doubted"] == {CLOCK_STEP: 1}
    clean = tmp_path / "clean.jsonl"
    with clean.open("w") as fh:
        write_records(mission_records(sim), fh)
    d = describe(clean)
    assert not [w for w in d["warnings"] if "IMU clock" in w] and "doubted" not in d["streams"]["imu"]


def _whole_ms_imu(sim, rate: float, duration_s: float = 10.0):
    """``sim``'s IMU resampled at ``rate`` (Hz) for ``duration_s`` and stamped in whole ms (s) with up to 0.5 ms of
    uniform jitter: steps of 6 to 9 ms at 128 Hz, their median 8 ms (125 Hz)."""
    import dataclasses
    t = np.arange(int(duration_s * rate)) / rate
    stamps = np.round(1e3 * (t + np.random.default_rng(7).uniform(-5e-4, 5e-4, t.size))) / 1e3
    return dataclasses.replace(sim.imu, t=stamps, **{k: np.column_stack([np.interp(t, sim.imu.t, getattr(
        sim.imu, k)[:, j]) for j in range(3)]) for k in ("f_b", "omega_b")})


def test_a_csv_log_shows_the_imu_rate_the_loaders_read_whole_ms_stamps_with_jitter(sim, tmp_path, capsys):
    """A 128 Hz IMU logged in whole ms with 0.5 ms of jitter (steps of 6 to 9 ms, the median 8 ms) showed 125 Hz as
    read (``describe`` without the prepare step, the mission's ``meta``) while its readers and screening read 128 Hz:
    the shown rate is now theirs, as read and as ``graphnav info`` prepares it."""
    from graphnav.io.loaders import read_mission
    rate = 128.0
    imu = _whole_ms_imu(sim, rate)
    stamps_ms = np.round(1e3 * imu.t)
    rows = ["ms,ax,ay,az,gx,gy,gz"] + [",".join(f"{x:.12g}" for x in r) for r in np.column_stack([stamps_ms, imu.f_b,
                                                                                                    imu.omega_b])]
    (tmp_path / "imu.csv").write_text("\n".join(rows) + "\n")
    keep = sim.dvl.t <= imu.t[-1]
    rows = ["ms,b1,b2,b3,b4"] + [",".join(f"{x:.12g}" for x in r) for r in np.column_stack(
        [1e3 * sim.dvl.t[keep], np.where(sim.dvl.valid, sim.dvl.beams, np.nan)[keep]])]
    (tmp_path / "dvl.csv").write_text("\n".join(rows) + "\n")
    cfg = sim.config.to_dict()
    cfg.update(imu_rate_hz=rate, csv_columns={
        "time_unit": "ms",
        "imu": {"file": "imu.csv", "t": "ms", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"]},
        "dvl": {"file": "dvl.csv", "t": "ms", "beams": ["b1", "b2", "b3", "b4"]}})
    config = tmp_path / "config.json"
    config.write_text(json.dumps(cfg))
    assert np.median(np.diff(stamps_ms)) == 8.0                     # the median step's 125 Hz
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert read_mission(tmp_path, config).meta["streams"]["imu"]["rate_hz"] == pytest.approx(rate, rel=1e-3)
        assert describe(tmp_path, config)["streams"]["imu"]["rate_hz"] == pytest.approx(rate, rel=1e-3)
    assert cli.main(["info", str(tmp_path), "--config", str(config), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["streams"]["imu"]["rate_hz"] == pytest.approx(rate, rel=1e-3)


@pytest.mark.parametrize("form", ["bag", "akit"])
def test_a_bag_and_an_akit_folder_show_the_imu_rate_the_loaders_read_whole_ms_stamps_with_jitter(sim, tmp_path, form):
    """The same 128 Hz IMU in whole ms written as a ROS 2 bag and as an A-KIT folder showed 125 Hz as read (the
    median step) and shows 128 Hz (``graphnav.core.imu_timing.shown_rate_hz``); the DVL keeps its median rate."""
    import dataclasses

    from graphnav.io.bags import write_mission_bag
    from graphnav.io.export import write_akit
    from graphnav.io.loaders import read_mission
    mission = dataclasses.replace(sim, imu=_whole_ms_imu(sim, 128.0, 20.0),
                                  config=dataclasses.replace(sim.config, imu_rate_hz=128.0))
    path = write_mission_bag(mission, tmp_path / "m.mcap") if form == "bag" else \
        write_akit(mission, tmp_path)["IMU"].parent
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        streams = read_mission(path).meta["streams"]
    assert streams["imu"]["rate_hz"] == pytest.approx(128.0, rel=1e-3)
    assert streams["dvl"]["rate_hz"] == pytest.approx(1 / np.median(np.diff(sim.dvl.t)), rel=1e-3)
