"""A team's own CSV logs through the column map of the SensorConfig JSON: units, one merged file with empty
cells, body-velocity-only DVLs, and errors naming file, line and column."""
from __future__ import annotations

import dataclasses
import io
import json
import re
import warnings

import numpy as np
import pytest

from graphnav import cli
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.rotations import C_b_n_to_euler
from graphnav.commands.common import print_summary
from graphnav.io.units import DEGREES_BY_TURN_DOUBT, GYRO_SMALL_DOUBT
from graphnav.missions import load_mission
from graphnav.sim.simulate import simulate_mission

T0 = 1_700_000_000.0   # Unix seconds, as loggers write them


@pytest.fixture(scope="module")
def sim():
    return simulate_mission(duration_s=40.0, seed=5)


def _write(path, header, columns):
    rows = [",".join(header)]
    for row in np.column_stack(columns):
        rows.append(",".join("" if not np.isfinite(x) else f"{x:.12g}" for x in row))
    path.write_text("\n".join(rows) + "\n")


def _config(tmp_path, mission, cmap):
    cfg = mission.config.to_dict()
    cfg["csv_columns"] = cmap
    path = tmp_path / "config.json"
    path.write_text(json.dumps(cfg))
    return path


#: An A-KIT trajectory's IMU and DVL files as a column map reads them (:func:`_akit_as_column_map`).
AKIT_COLUMN_MAP = {
    "time_unit": "s",
    "imu": {"file": "imu.csv", "t": "Time [s]", "f_b": ["ACC X [m/s^2]", "ACC Y [m/s^2]", "ACC Z [m/s^2]"],
            "omega_b": ["GYRO X [rad/s]", "GYRO Y [rad/s]", "GYRO Z [rad/s]"]},
    "dvl": {"file": "dvl.csv", "t": "Time [s]", "v_b": ["DVL X [m/s]", "DVL Y [m/s]", "DVL Z [m/s]"]}}


def _akit_as_column_map(akit_dir, folder, name="Trajectory1", imu_edit=None):
    """(folder, its config.json): the trajectory's IMU and DVL files copied to ``folder`` as ``imu.csv`` and
    ``dvl.csv`` with a column map naming their columns; ``imu_edit``: a change to the IMU file's lines (header
    first)."""
    folder.mkdir(parents=True, exist_ok=True)
    n = name.replace("Trajectory", "")
    for stream, edit in (("IMU", imu_edit), ("DVL", None)):
        lines = (akit_dir / name / f"{stream}_trajectory{n}.csv").read_text().splitlines()
        (folder / f"{stream.lower()}.csv").write_text("\n".join(edit(lines) if edit else lines) + "\n")
    (folder / "config.json").write_text(json.dumps({"csv_columns": AKIT_COLUMN_MAP}))
    return folder, folder / "config.json"


def _separate_files(tmp_path, m):
    """IMU in g and deg/s with ms stamps; DVL beams in mm/s with validity flags; pressure in dbar; GT in deg."""
    _write(tmp_path / "imu.csv", ["time_ms", "ax", "ay", "az", "gx", "gy", "gz"],
           [(m.imu.t + T0) * 1e3, m.imu.f_b / 9.80665, np.degrees(m.imu.omega_b)])
    beams = np.where(m.dvl.valid, m.dvl.beams * 1e3, -32768.0)
    _write(tmp_path / "dvl.csv", ["time_ms", "b1", "b2", "b3", "b4", "ok1", "ok2", "ok3", "ok4"],
           [(m.dvl.t + T0) * 1e3, beams, m.dvl.valid.astype(float)])
    _write(tmp_path / "depth.csv", ["time_ms", "p_dbar"],
           [(m.depth.t + T0) * 1e3, m.depth.depth * 1025.0 * m.config.gravity_mps2 / 1e4])
    _write(tmp_path / "nav.csv", ["time_ms", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [(m.gt.t + T0) * 1e3, m.gt.p_n, m.gt.v_n, np.degrees(C_b_n_to_euler(m.gt.C_b_n))])
    return {
        "time_unit": "ms",
        "imu": {"file": "imu.csv", "t": "time_ms", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"],
                "accel_unit": "g", "gyro_unit": "deg/s"},
        "dvl": {"file": "dvl.csv", "t": "time_ms", "beams": ["b1", "b2", "b3", "b4"],
                "valid": ["ok1", "ok2", "ok3", "ok4"], "velocity_unit": "mm/s"},
        "depth": {"file": "depth.csv", "t": "time_ms", "pressure": "p_dbar", "pressure_unit": "dbar"},
        "gt": {"file": "nav.csv", "t": "time_ms", "p_n": ["n", "e", "d"], "v_n": ["vn", "ve", "vd"],
               "euler": ["roll", "pitch", "yaw"], "angle_unit": "deg"},
    }


def test_separate_files_with_units(sim, tmp_path):
    cfg = _config(tmp_path, sim, _separate_files(tmp_path, sim))
    m = load_mission(tmp_path, cfg)
    assert m.meta["t0_s"] == pytest.approx(T0)
    np.testing.assert_allclose(m.imu.t, sim.imu.t, atol=1e-6)
    np.testing.assert_allclose(m.imu.f_b, sim.imu.f_b, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(m.imu.omega_b, sim.imu.omega_b, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(m.dvl.valid, sim.dvl.valid)
    np.testing.assert_allclose(m.dvl.beams[m.dvl.valid], sim.dvl.beams[sim.dvl.valid], atol=1e-9)
    np.testing.assert_allclose(m.depth.depth, sim.depth.depth, atol=1e-9)
    np.testing.assert_allclose(m.gt.C_b_n, sim.gt.C_b_n, atol=1e-9)


def test_beams_and_velocity_in_whole_mm_s_undeclared_are_said_read_as_mm_s_once_naming_both(sim, tmp_path):
    """Beams and the velocity, both in whole mm/s with no velocity_unit: detected as mm/s and converted, which was
    warned and noted twice, naming neither's columns. Once now, naming both, as a bag's DVL fields are."""
    cmap = _separate_files(tmp_path, sim)
    beams = np.where(sim.dvl.valid, np.round(sim.dvl.beams * 1e3), np.nan)
    _write(tmp_path / "dvl.csv", ["time_ms", "b1", "b2", "b3", "b4", "ok1", "ok2", "ok3", "ok4", "vx", "vy", "vz"],
           [(sim.dvl.t + T0) * 1e3, beams, sim.dvl.valid.astype(float), np.round(sim.dvl.v_b * 1e3)])
    del cmap["dvl"]["velocity_unit"]
    cmap["dvl"]["v_b"] = ["vx", "vy", "vz"]
    cfg = _config(tmp_path, sim, cmap)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(tmp_path, cfg, prepare=False)
    said = [str(w.message) for w in caught if "read as mm/s" in str(w.message)]
    assert len(said) == 1 and re.fullmatch(r".*dvl\.csv: DVL velocities read as mm/s \(median speed \d+ in beams "
                                           r"'b1, b2, b3, b4', \d+ in v_b 'vx, vy, vz'\) and converted to m/s",
                                           said[0]), said
    assert len([n for n in m.meta["streams"]["dvl"]["notes"] if "read as mm/s" in n]) == 1
    np.testing.assert_allclose(m.dvl.beams[m.dvl.valid], sim.dvl.beams[m.dvl.valid], atol=5e-4)
    np.testing.assert_allclose(m.dvl.v_b, sim.dvl.v_b, atol=5e-4)


def test_merged_log_and_body_velocity_dvl_through_smooth(sim, tmp_path, capsys):
    # One file, one row per IMU sample; the DVL body velocity only on the ping rows and the reference only on
    # its 10 Hz rows (empty cells elsewhere).
    m = sim
    n = len(m.imu.t)
    ping = np.searchsorted(m.imu.t, m.dvl.t)
    v_b = np.full((n, 3), np.nan)
    v_b[ping] = m.gt.v_b[np.searchsorted(m.gt.t, m.dvl.t)]
    dvl_t = np.full(n, np.nan)
    dvl_t[ping] = m.dvl.t
    ref = np.full((n, 10), np.nan)
    rows = np.searchsorted(m.imu.t, m.gt.t)
    ref[rows] = np.column_stack([m.gt.t, m.gt.p_n, m.gt.v_n, C_b_n_to_euler(m.gt.C_b_n)])
    _write(tmp_path / "log.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz", "dvl_t", "vx", "vy", "vz",
                                  "gt_t", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [m.imu.t, m.imu.f_b, m.imu.omega_b, dvl_t, v_b, ref])
    cmap = {"imu": {"t": "t", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"]},
            "dvl": {"t": "dvl_t", "v_b": ["vx", "vy", "vz"]}}
    # Without a gt entry the mission has no reference (scoring is then skipped by the commands).
    mission = load_mission(tmp_path / "log.csv", _config(tmp_path, m, cmap))
    assert mission.meta["beams_from_v_b"] and mission.gt is None and mission.depth is None
    assert len(mission.dvl.t) == len(m.dvl.t) and mission.dvl.valid.all()
    # ... and smooths from a sensor alignment (levelling, DVL velocity; the heading as a compass would give it:
    # 40 s are too short to gyrocompass), unscored.
    out = tmp_path / "no_gt"
    heading_deg = float(np.degrees(C_b_n_to_euler(m.gt.C_b_n[:1])[0, 2]))
    assert cli.main(["smooth", "--data", str(tmp_path / "log.csv"), "--config", str(tmp_path / "config.json"),
                     "--method", "Graph-TC", "--init", "sensors", "--initial-heading", f"{heading_deg:.3f}",
                     "--out", str(out), "--no-plots"]) == 0
    assert json.loads((out / "summary.json").read_text())["accuracy"] == {"ground_truth": False}
    from graphnav.evaluation.metrics import vrmse
    from graphnav.io.outputs import read_trajectory_csv
    no_gt_vrmse = vrmse(read_trajectory_csv(out / "trajectory.csv"), m.gt)
    cmap["gt"] = {"t": "gt_t", "p_n": ["n", "e", "d"], "v_n": ["vn", "ve", "vd"], "euler": ["roll", "pitch", "yaw"]}
    cfg = _config(tmp_path, m, cmap)
    out = tmp_path / "out"
    assert cli.main(["smooth", "--data", str(tmp_path / "log.csv"), "--config", str(cfg), "--method", "Graph-TC",
                     "--out", str(out), "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    # Beams projected from an exact body velocity: the smoother follows the truth closely, from the reference
    # or from the sensor alignment.
    # 0.058 m/s with the DVL error states (on by default), which have no error to find here
    assert summary["accuracy"]["vrmse_mission_mps"] < 0.065
    assert no_gt_vrmse < 0.1


def test_reference_units_left_out_are_detected_and_contradictions_named(sim, tmp_path):
    """The reference of the column map checked like the A-KIT GT (graphnav.io.units): roll/pitch/yaw in degrees
    without ``angle_unit`` converted with a warning (they used to be read as radians, silently); a declared
    'rad' the rates contradict, north/east in km against m/s and a down column of the other sign refused naming
    the file and columns."""
    cmap = _separate_files(tmp_path, sim)
    del cmap["gt"]["angle_unit"]
    with pytest.warns(RuntimeWarning, match=r"nav.csv: attitude columns 'roll', 'pitch', 'yaw' read as degrees"):
        m = load_mission(tmp_path, _config(tmp_path, sim, cmap))
    np.testing.assert_allclose(m.gt.C_b_n, sim.gt.C_b_n, atol=1e-9)
    assert any("read as degrees" in n for n in m.meta["streams"]["gt"]["notes"])
    cmap["gt"]["angle_unit"] = "rad"
    with pytest.raises(DataError, match=r"nav.csv, field 'roll/pitch/yaw': attitude after the declared unit 'rad'"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))
    cmap["gt"]["angle_unit"] = "deg"
    nav = (tmp_path / "nav.csv").read_text().splitlines()
    rows = [[float(x) for x in line.split(",")] for line in nav[1:]]
    for edit, match in ((lambda r: [r[0], r[1] / 1e3, r[2] / 1e3] + r[3:],
                         r"field 'n/e': the positions move 0.001x as far as the velocity says.*'vn', 've'"),
                        (lambda r: r[:3] + [-r[3]] + r[4:],
                         r"field 'd': the down position 'd' changes against 'vd'")):
        (tmp_path / "nav.csv").write_text("\n".join([nav[0]] + [",".join(f"{x:.12g}" for x in edit(r))
                                                                for r in rows]) + "\n")
        with pytest.raises(DataError, match=match):
            load_mission(tmp_path, _config(tmp_path, sim, cmap))


def test_errors_name_file_line_and_column(sim, tmp_path):
    cmap = _separate_files(tmp_path, sim)
    lines = (tmp_path / "dvl.csv").read_text().splitlines()
    lines[5] = lines[5].replace(",", ",x", 1)
    (tmp_path / "dvl.csv").write_text("\n".join(lines) + "\n")
    cfg = _config(tmp_path, sim, cmap)
    with pytest.raises(DataError, match=r"dvl.csv, line 6, field 'b1': not a number"):
        load_mission(tmp_path, cfg)
    cmap["dvl"]["beams"] = ["b1", "b2", "b3", "beam4"]
    with pytest.raises(DataError, match=r"line 1, field 'beam4'"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))
    cmap["imu"]["gyro_unit"] = "rpm"
    with pytest.raises(ConfigError, match=r"csv_columns.imu.gyro_unit = 'rpm'"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))
    with pytest.raises(ConfigError, match="column map"):
        load_mission(tmp_path / "imu.csv", None)


def test_gyro_declared_deg_per_s_on_rad_per_s_data_names_the_file_and_columns(sim, tmp_path):
    # a new user's log in rad/s with gyro_unit "deg/s": the rates come out 57.3x too small and the run diverged
    cmap = _separate_files(tmp_path, sim)
    _write(tmp_path / "imu.csv", ["time_ms", "ax", "ay", "az", "gx", "gy", "gz"],
           [(sim.imu.t + T0) * 1e3, sim.imu.f_b / 9.80665, sim.imu.omega_b])
    with pytest.raises(DataError, match=r"imu.csv, field 'gx/gy/gz': the declared gyro unit 'deg/s' looks wrong"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))


def test_a_declared_reference_error_is_added_to_the_printed_velocity_nees(tmp_path, capsys):
    """``gt.velocity_sigma`` declares the reference's own velocity error: the summary's velocity NEES is also given
    with it added to the covariance, and is smaller for it; a malformed value names the key."""
    sim = simulate_mission(duration_s=120.0, seed=5)     # the NEES is scored after the first 60 s
    cmap = _separate_files(tmp_path, sim)
    cmap["gt"]["velocity_sigma"] = [0.02, 0.02, 0.01]
    cfg = _config(tmp_path, sim, cmap)
    assert load_mission(tmp_path, cfg).meta["gt_velocity_sigma_n"] == [0.02, 0.02, 0.01]
    assert cli.main(["smooth", "--data", str(tmp_path), "--config", str(cfg), "--out", str(tmp_path / "out"),
                     "--no-plots"]) == 0
    velocity = json.loads((tmp_path / "out" / "summary.json").read_text())["accuracy"]["consistency"]["velocity"]
    assert velocity["nees_with_reference_error"] < velocity["nees"]
    assert f"{velocity['nees_with_reference_error']:.2f} with the reference's own error" in capsys.readouterr().out
    for bad in ([0.02, -0.01], "123", [True, False, True], [0.02, float("nan"), 0.01]):
        cmap["gt"]["velocity_sigma"] = bad
        with pytest.raises(ConfigError, match=r"csv_columns.gt.velocity_sigma"):
            load_mission(tmp_path, _config(tmp_path, sim, cmap))
    cmap["gt"]["velocity_sigma"] = None                  # null: not declared
    assert "gt_velocity_sigma_n" not in load_mission(tmp_path, _config(tmp_path, sim, cmap)).meta


def test_empty_cells_and_imu_spikes_are_refused_rows_naming_file_line_and_column(sim, tmp_path):
    """As in an A-KIT folder: an IMU row with an empty cell, an IMU row with a spike within full scale (5 rad/s
    on gz, written in deg/s) and a reference row with an empty cell are refused, counted and warned about with the
    file's line and the column map's column; the rest is read."""
    cmap = _separate_files(tmp_path, sim)

    def edit(name, row, column, change):
        lines = (tmp_path / name).read_text().splitlines()
        fields = lines[row + 1].split(",")
        fields[column] = change(fields[column])
        lines[row + 1] = ",".join(fields)
        (tmp_path / name).write_text("\n".join(lines) + "\n")
    edit("imu.csv", 1000, 2, lambda s: "")
    edit("imu.csv", 2000, 6, lambda s: f"{float(s) + np.degrees(5.0):.12g}")
    edit("nav.csv", 100, 2, lambda s: "")
    with pytest.warns(RuntimeWarning) as rec:
        m = load_mission(tmp_path, _config(tmp_path, sim, cmap))
    messages = [str(w.message) for w in rec]
    streams = m.meta["streams"]
    assert streams["imu"]["refused"] == {"empty or NaN in 'ay'": 1, "spike in 'gz'": 1}
    assert streams["imu"]["read"] == len(sim.imu.t) and len(m.imu.t) == len(sim.imu.t) - 2
    assert streams["gt"]["refused"] == {"empty or NaN in 'e'": 1} and len(m.gt.t) == len(sim.gt.t) - 1
    for name, stream, reason, line in (("imu.csv", "imu", "empty or NaN in 'ay'", 1002),
                                       ("imu.csv", "imu", "spike in 'gz'", 2002),
                                       ("nav.csv", "gt", "empty or NaN in 'e'", 102)):
        assert any(s.startswith(f"{tmp_path / name}: 1 {stream} sample(s) refused (1 {reason}) at line(s) {line};")
                   for s in messages), messages


def _edit_line(path, line, change):
    """Replace 1-based file ``line`` of ``path`` by ``change(fields)`` (a list of its fields)."""
    lines = path.read_text().splitlines()
    lines[line - 1] = ",".join(change(lines[line - 1].split(",")))
    path.write_text("\n".join(lines) + "\n")


def _insert_copy(path, line, change=lambda fields: fields):
    """Write 1-based file ``line`` of ``path`` twice, the copy as ``change(fields)``."""
    lines = path.read_text().splitlines()
    lines.insert(line, ",".join(change(lines[line - 1].split(","))))
    path.write_text("\n".join(lines) + "\n")


def _load_recording(path, cfg, **kwargs):
    from graphnav.io.loaders import read_mission
    with pytest.warns(Warning) as rec:
        m = read_mission(path, cfg, **kwargs)
    return m, [str(w.message) for w in rec]


def _jittered_stamps(path, rng, jitter_ms):
    """Move each stamp (ms) of a column-map file by a whole number of ms up to ``jitter_ms`` (a logger's clock)."""
    lines = path.read_text().splitlines()
    for i in range(1, len(lines)):
        cells = lines[i].split(",")
        cells[0] = repr(float(cells[0]) + float(rng.integers(-jitter_ms, jitter_ms + 1)))
        lines[i] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def test_a_row_written_twice_1_ms_later_is_dropped_from_a_jittered_column_map_log(sim, tmp_path):
    """An IMU and a DVL row each written again 1 ms later with the same values, in a log whose stamps jitter by up to
    2 ms (IMU) and 20 ms (DVL): kept before, an extra IMU sample (warned as a step of the IMU clock) and a DVL ping
    counted twice. Each is the same sample: dropped, warned naming the file and line, and counted; the log reads as
    the clean one."""
    from graphnav.core import screening
    cmap = _separate_files(tmp_path, sim)
    rng = np.random.default_rng(3)
    _jittered_stamps(tmp_path / "imu.csv", rng, 2)
    _jittered_stamps(tmp_path / "dvl.csv", rng, 20)
    cfg = _config(tmp_path, sim, cmap)
    clean = load_mission(tmp_path, cfg, prepare=False)
    for name, line in (("imu.csv", 1501), ("dvl.csv", 21)):
        _insert_copy(tmp_path / name, line, lambda f: [repr(float(f[0]) + 1.0)] + f[1:])
    m, messages = _load_recording(tmp_path, cfg)
    for stream in ("imu", "dvl"):
        np.testing.assert_array_equal(getattr(m, stream).t, getattr(clean, stream).t)
    np.testing.assert_array_equal(m.imu.f_b, clean.imu.f_b)
    np.testing.assert_array_equal(m.dvl.beams, clean.dvl.beams)
    for name, line in (("imu.csv", 1502), ("dvl.csv", 22)):
        assert f"{tmp_path / name}: 1 row(s) repeating the row before them in every value up to 1 ms later (the same " \
               f"sample written twice, its stamp nudged) dropped, at line(s) {line}" in messages, messages
    for stream in ("imu", "dvl"):
        assert m.meta["streams"][stream]["refused"] == {screening.NUDGED_COPY: 1}


def test_a_dvl_ping_1_ms_after_another_with_other_values_is_kept_and_doubted(sim, tmp_path):
    """Two DVL pings 1 ms apart with other values in a jittered column-map log (a row written twice with another
    reading, or two pings stamped together on receipt): nothing tells the right one, so both are kept, but they were
    kept without a word; now warned about with the line and counted as doubted. The clean log says nothing."""
    from graphnav.core import screening
    cmap = _separate_files(tmp_path, sim)
    _jittered_stamps(tmp_path / "dvl.csv", np.random.default_rng(5), 20)
    cfg = _config(tmp_path, sim, cmap)
    clean = load_mission(tmp_path, cfg, prepare=False)
    assert not clean.meta["streams"]["dvl"].get("doubted")
    _insert_copy(tmp_path / "dvl.csv", 21, lambda f: [repr(float(f[0]) + 1.0), str(float(f[1]) + 5.0)] + f[2:])
    m, messages = _load_recording(tmp_path, cfg)
    assert len(m.dvl.t) == len(clean.dvl.t) + 1
    assert any(s.startswith(f"{tmp_path / 'dvl.csv'}: 1 dvl row(s) stamped under a fifth of the median step")
               and "at line(s) 22" in s for s in messages), messages
    assert m.meta["streams"]["dvl"]["doubted"] == {screening.CLOSE_SAMPLES: 1}


def test_an_imu_at_rest_with_coarse_counts_keeps_its_repeated_samples_jitter_moved_close():
    """An IMU at rest in coarse counts repeats its reading from sample to sample; where jitter moves two samples
    under half a period apart their rows are equal too: samples, not a row written twice (its readings repeat as often
    across whole periods). Noisy readings on a clock jittering by up to 2 ms, one row written again 1 ms later, lose
    that row only."""
    from graphnav.core.screening import nudged_copies
    rng = np.random.default_rng(4)
    n = 3000
    t = np.arange(n) * 0.01 + rng.uniform(-0.004, 0.004, n)
    at_rest = np.round(rng.normal(0.0, 0.02, (n, 6)) / 0.05) * 0.05 + [0, 0, -9.8, 0, 0, 0]
    rows = np.column_stack([t, at_rest])
    close = np.diff(t) < 0.005
    assert close.sum() > 100 and np.all(rows[1:, 1:][close] == rows[:-1, 1:][close], axis=1).sum() > 10
    assert nudged_copies(t, rows)[0].size == 0
    t = np.arange(n) * 0.01 + rng.uniform(-0.002, 0.002, n)
    noisy = np.column_stack([t, at_rest + rng.normal(0.0, 1e-3, (n, 6))])
    twice = np.insert(noisy, 1001, noisy[1000] + [0.001, 0, 0, 0, 0, 0, 0], axis=0)
    kept, later = nudged_copies(twice[:, 0], twice)
    assert kept.tolist() == [1001] and later == pytest.approx(0.001)


def test_samples_moved_close_where_readings_repeat_are_kept_though_the_file_moves_elsewhere():
    """An IMU at rest with coarse counts on a clock jittering by up to 1 ms for its first 60 s (before a dive), then
    moving with noisy readings on a clean clock: its readings repeat at whole steps only in those 60 s, so judged over
    the file 1434-1467 of its samples (seeds 0-2) jitter moved close were dropped as rows written twice. A 4 Hz depth
    held on 1 cm counts with 30 % of its samples read with the next one 1 ms later lost 500 of 3000. Judged near the
    row, all are kept; a row written again 1 ms later among the moving readings is still dropped."""
    from graphnav.core.screening import nudged_copies
    n_rest, n_move = 24000, 120000
    for seed in range(3):
        rng = np.random.default_rng(10 + seed)
        t = np.arange(n_rest + n_move) / 400.0
        t[:n_rest] += rng.uniform(-0.001, 0.001, n_rest)
        rest = np.round(rng.normal(0.0, 0.01, (n_rest, 6)) / 0.05) * 0.05 + [0, 0, -9.8, 0, 0, 0]
        moving = rng.normal(0.0, 0.05, (n_move, 6)) + [0, 0, -9.8, 0, 0, 0]
        rows = np.column_stack([t, np.vstack([rest, moving])])
        assert nudged_copies(t, rows)[0].size == 0
        twice = np.insert(rows, 100000, rows[99999] + [0.001, 0, 0, 0, 0, 0, 0], axis=0)
        assert nudged_copies(twice[:, 0], twice)[0].tolist() == [100000]
    rng = np.random.default_rng(1)
    t = np.arange(3000) * 0.25
    late = np.flatnonzero(rng.random(2999) < 0.3)
    t[late] = t[late + 1] - 0.001
    depth = np.round((20.0 + rng.normal(0.0, 0.003, 3000)) / 0.01) * 0.01
    assert late.size > 800 and nudged_copies(t, np.column_stack([t, depth]))[0].size == 0


def test_a_dvl_changing_its_ping_rate_is_neither_copies_nor_close_rows():
    """A DVL pinging at 2 Hz for 3000 s, then at 20 Hz for 300 s near the bottom, at rest on 1 mm/s counts: judged
    against the file's median step every fast ping was under a fifth of a step (5999 doubted as two samples where the
    stream makes one) and 3358 were dropped as rows written twice. Judged against the steps near them, none; a row
    written again 1 ms later among the slow pings is still dropped, and one with other values still doubted."""
    from graphnav.core.screening import CLOSE_SAMPLES, nudged_copies, say_close_samples
    rng = np.random.default_rng(0)
    t = np.concatenate([np.arange(0.0, 3000.0, 0.5), 3000.0 + np.arange(0.0, 300.0, 0.05)])
    v = np.round(rng.normal(0.0, 3e-4, (len(t), 3)) / 1e-3) * 1e-3 + 0.5
    v[:3000] += rng.normal(0.0, 0.01, (3000, 3))
    rows = np.column_stack([t, v])
    assert nudged_copies(t, rows)[0].size == 0
    meta = {}
    say_close_samples(t, np.arange(len(t)) + 2, "dvl.csv", "dvl", meta)
    assert not meta.get("streams", {}).get("dvl", {}).get("doubted")
    twice = np.insert(rows, 1000, rows[999] + [0.001, 0, 0, 0], axis=0)
    assert nudged_copies(twice[:, 0], twice)[0].tolist() == [1000]
    other = np.insert(rows, 1000, rows[999] + [0.001, 0.01, 0, 0], axis=0)
    with pytest.warns(RuntimeWarning, match="1 dvl row"):
        say_close_samples(other[:, 0], np.arange(len(other)) + 2, "dvl.csv", "dvl", meta)
    assert meta["streams"]["dvl"]["doubted"] == {CLOSE_SAMPLES: 1}


def test_a_row_written_twice_is_dropped_and_two_rows_under_one_stamp_need_repair_stamps(sim, tmp_path):
    """As in an A-KIT folder: an IMU row written twice exactly is dropped, warned about with its line and counted;
    a repeated stamp with other values is refused naming the file, line, column and --repair-stamps, which drops
    the later row and sorts swapped DVL rows (warned, counted) for a column-map log too."""
    cmap = _separate_files(tmp_path, sim)
    cfg = _config(tmp_path, sim, cmap)
    clean = load_mission(tmp_path, cfg, prepare=False)
    _insert_copy(tmp_path / "imu.csv", 1001)
    m, messages = _load_recording(tmp_path, cfg)
    assert f"{tmp_path / 'imu.csv'}: 1 row(s) repeating an earlier row exactly (same stamp and values) dropped, " \
           "at line(s) 1002" in messages
    assert m.meta["streams"]["imu"]["refused"] == {"repeats an earlier row exactly": 1}
    assert m.meta["streams"]["imu"]["read"] == len(sim.imu.t) + 1
    np.testing.assert_array_equal(m.imu.f_b, clean.imu.f_b)
    _edit_line(tmp_path / "imu.csv", 1002, lambda f: f[:-1] + ["0.5"])
    _insert_copy(tmp_path / "dvl.csv", 11)
    lines = (tmp_path / "dvl.csv").read_text().splitlines()
    lines[20], lines[21] = lines[21], lines[20]          # file lines 21 and 22 swapped
    (tmp_path / "dvl.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"imu.csv, line 1002, field 'time_ms': time stamp duplicated.*--repair-stamps"):
        load_mission(tmp_path, cfg, prepare=False)
    m, messages = _load_recording(tmp_path, cfg, repair=True)
    assert m.meta["streams"]["imu"]["refused"] == {"duplicated stamp (repair)": 1}
    assert m.meta["streams"]["dvl"]["refused"] == {"repeats an earlier row exactly": 1}
    assert any(s.startswith(f"{tmp_path / 'dvl.csv'}: 0 duplicated and 1 out-of-order stamp(s) repaired")
               for s in messages), messages
    np.testing.assert_array_equal(m.imu.t, clean.imu.t)
    np.testing.assert_array_equal(m.imu.f_b, clean.imu.f_b)
    np.testing.assert_array_equal(m.dvl.t, clean.dvl.t)
    np.testing.assert_array_equal(m.dvl.beams, clean.dvl.beams)
    import argparse

    from graphnav.commands.common import add_mission_arguments, recorded_mission
    parser = argparse.ArgumentParser()
    add_mission_arguments(parser)
    with pytest.warns(Warning):
        prepared = recorded_mission(parser.parse_args(["--data", str(tmp_path), "--config", str(cfg),
                                                       "--repair-stamps"]))
    assert prepared.meta["prepared"] and len(prepared.imu.t) == len(clean.imu.t)


def test_an_infinite_cell_refuses_its_row_as_an_empty_one_does(sim, tmp_path):
    """inf, -inf, Infinity and 1e999 (past float range) in an IMU or reference cell refuse that row, warned with
    the file, line and column and counted; in a DVL beam they are a beam that is not a measurement (invalid,
    warned). The whole load used to stop (the reference) or count the IMU row as beyond full scale."""
    cmap = _separate_files(tmp_path, sim)
    cfg = _config(tmp_path, sim, cmap)

    def cell(column, text):
        return lambda f: f[:column] + [text] + f[column + 1:]
    _edit_line(tmp_path / "imu.csv", 502, cell(2, "inf"))
    _edit_line(tmp_path / "imu.csv", 602, cell(4, "-Infinity"))
    _edit_line(tmp_path / "nav.csv", 12, cell(5, "1e999"))
    _edit_line(tmp_path / "nav.csv", 22, cell(1, "-inf"))
    _edit_line(tmp_path / "dvl.csv", 12, cell(2, "inf"))
    m, messages = _load_recording(tmp_path, cfg)
    streams = m.meta["streams"]
    assert streams["imu"]["refused"] == {"infinite in 'ay'": 1, "infinite in 'gx'": 1}
    assert streams["gt"]["refused"] == {"infinite in 'n'": 1, "infinite in 've'": 1}
    for name, text in (("imu.csv", "2 imu sample(s) refused (1 infinite in 'ay'; 1 infinite in 'gx') at line(s) 502, "
                                   "602"),
                       ("nav.csv", "2 gt sample(s) refused (1 infinite in 'n'; 1 infinite in 've') at line(s) 12, 22")):
        assert any(s.startswith(f"{tmp_path / name}: {text};") for s in messages), messages
    assert len(m.imu.t) == len(sim.imu.t) - 2 and len(m.gt.t) == len(sim.gt.t) - 2
    assert np.all(np.isfinite(m.imu.f_b)) and np.all(np.isfinite(m.gt.p_n))
    others = np.arange(4) != 1                   # the file's b2 is beam 2
    assert not m.dvl.valid[10, 1] and np.array_equal(m.dvl.valid[10, others], sim.dvl.valid[10, others])
    assert any(s.startswith(f"{tmp_path / 'dvl.csv'}: 1 beam value(s)") for s in messages), messages


def test_a_reference_velocity_spike_is_refused_before_its_down_sign_is_checked(sim, tmp_path):
    """A reference whose down position changes against its down velocity (a vehicle heaving +-1 m) is refused
    naming both columns; one 'vd' of 30 m/s used to hide that (the sign check ran before the screening refused the
    spike, and the flipped depth was read as it came). Now the spike row is refused first, with its line, as in the
    A-KIT reader."""
    cmap = _separate_files(tmp_path, sim)
    t = sim.gt.t
    p, v = sim.gt.p_n.copy(), sim.gt.v_n.copy()
    p[:, 2], v[:, 2] = -(15.0 + np.sin(0.3 * t)), 0.3 * np.cos(0.3 * t)
    v[100, 2] = 30.0
    _write(tmp_path / "nav.csv", ["time_ms", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [(t + T0) * 1e3, p, v, np.degrees(C_b_n_to_euler(sim.gt.C_b_n))])
    cfg = _config(tmp_path, sim, cmap)
    with pytest.warns(RuntimeWarning, match=r"nav.csv: 1 gt sample\(s\) refused \(1 GT speed > 4 m/s\) at line\(s\) "
                                            "102"):
        with pytest.raises(DataError, match=r"field 'd': the down position 'd' changes against 'vd'"):
            load_mission(tmp_path, cfg, prepare=False)
    p[:, 2] = -p[:, 2]
    _write(tmp_path / "nav.csv", ["time_ms", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [(t + T0) * 1e3, p, v, np.degrees(C_b_n_to_euler(sim.gt.C_b_n))])
    with pytest.warns(RuntimeWarning):
        m = load_mission(tmp_path, cfg, prepare=False)
    assert m.meta["streams"]["gt"]["refused"] == {"GT speed > 4 m/s": 1}
    np.testing.assert_allclose(m.gt.p_n[:, 2], np.delete(p[:, 2], 100), atol=1e-9)


def test_a_stream_key_the_column_map_does_not_know_is_refused_naming_the_file_stream_and_key(sim, tmp_path):
    """A misspelt unit or frame key of a stream ('velocity_units', 'axes') used to be ignored: the unit was then
    detected, the frame taken as FRD (an FLU IMU diverged to 335 m/s). Every stream's keys are checked, naming the
    configuration file, the stream and the key, with the closest accepted key."""
    from graphnav.core.config import SensorConfig
    from graphnav.io.generic_csv import load_csv_mission
    cmap = _separate_files(tmp_path, sim)
    cmap["dvl"]["velocity_units"] = cmap["dvl"].pop("velocity_unit")
    cfg = _config(tmp_path, sim, cmap)
    with pytest.raises(ConfigError, match=rf"^{cfg}: unknown key 'csv_columns.dvl.velocity_units'; did you mean "
                                          r"'csv_columns.dvl.velocity_unit'\?$"):
        load_mission(tmp_path, cfg)
    cmap["dvl"]["velocity_unit"] = cmap["dvl"].pop("velocity_units")
    cmap["imu"]["axes"] = "flu"
    with pytest.raises(ConfigError, match=rf"^{_config(tmp_path, sim, cmap)}: unknown key 'csv_columns.imu.axes'; "
                                          "csv_columns.imu accepts file, t, .*frame$"):
        load_mission(tmp_path, cfg)
    del cmap["imu"]["axes"]
    cmap["gt"]["angle_units"] = "deg"
    with pytest.raises(ConfigError, match=r"^configuration: unknown key 'csv_columns.gt.angle_units'; did you mean "
                                          r"'csv_columns.gt.angle_unit'\?$"):
        load_csv_mission(tmp_path, SensorConfig(csv_columns=cmap))      # a map built in code is checked too
    cmap["gt"] = "nav.csv"
    with pytest.raises(ConfigError, match=r"key 'csv_columns.gt': expected a JSON object"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))


def _velocity_log(tmp_path, m, flags):
    """A DVL that logs its body velocity (m/s) with a bottom-lock column ``flags`` (M,)."""
    v_b = m.gt.v_b[np.searchsorted(m.gt.t, m.dvl.t)]
    _write(tmp_path / "dvl.csv", ["time_ms", "vx", "vy", "vz", "bl"], [(m.dvl.t + T0) * 1e3, v_b, flags])
    return v_b


def test_a_dvl_velocity_of_exactly_zero_or_flagged_invalid_is_not_a_measurement(sim, tmp_path):
    """A body-velocity DVL without bottom lock: pings logged 0, 0, 0 are refused (warned with their file lines,
    counted); a declared 'valid' column now applies to 'v_b' (it applied to 'beams' only: the flagged pings'
    velocity was used)."""
    from graphnav.core.screening import NO_BOTTOM_LOCK
    from graphnav.io.stream_counts import NO_VALID_BEAM
    cmap = _separate_files(tmp_path, sim)
    flags = np.ones(len(sim.dvl.t))
    flags[20:25] = 0
    v_b = _velocity_log(tmp_path, sim, flags)
    lines = (tmp_path / "dvl.csv").read_text().splitlines()
    for i in range(11, 16):                              # pings 10-14, file lines 12-16
        lines[i] = lines[i].split(",")[0] + ",0,0.0,0,1"
    (tmp_path / "dvl.csv").write_text("\n".join(lines) + "\n")
    cmap["dvl"] = {"file": "dvl.csv", "t": "time_ms", "v_b": ["vx", "vy", "vz"], "valid": ["bl"] * 4,
                   "velocity_unit": "m/s"}
    m, messages = _load_recording(tmp_path, _config(tmp_path, sim, cmap))
    assert m.meta["streams"]["dvl"]["refused"] == {NO_BOTTOM_LOCK: 5, NO_VALID_BEAM: 5}
    bad = np.zeros(len(sim.dvl.t), bool)
    bad[10:15] = bad[20:25] = True
    assert not m.dvl.valid[bad].any() and m.dvl.valid[~bad].all()
    assert np.isnan(m.dvl.v_b[bad]).all()
    np.testing.assert_allclose(m.dvl.v_b[~bad], v_b[~bad], atol=1e-9)
    dvl = tmp_path / "dvl.csv"
    assert any(s.startswith(f"{dvl}: 5 DVL ping(s) with a velocity of exactly 0 on every axis (a ping without bottom "
                            "lock: the log's resolution is finer than 1 mm/s or the vehicle is under way) refused at "
                            "line(s) 12, 13, 14, 15, 16") for s in messages), messages
    assert any(s.startswith(f"{dvl}: 5 of {len(bad)} DVL ping(s) have no valid beam (first at line 22,")
               and s.endswith("nothing is measured there; only the hybrid methods use them, with the beams their "
                              "completer regresses") for s in messages), messages


def _as_dialect(path, sep, decimal=".", comments=()):
    lines = path.read_text().splitlines()
    body = [line.replace(",", sep).replace(".", decimal) for line in lines]
    path.write_text("\n".join([f"# {c}" for c in comments] + body) + "\n")


def test_semicolon_tab_and_comment_lines_read_as_the_comma_file(sim, tmp_path):
    """Files separated by ';' (with decimal commas, as European spreadsheets write them) or tabs, and comment
    lines before the header, read as the comma file does (they stopped at 'column(s) ... not in the header
    ['t;ax;...']'), noted in the stream's notes; a declared delimiter is used as given; a cell that is no number
    either way stays a DataError naming its line."""
    cmap = _separate_files(tmp_path, sim)
    cfg = _config(tmp_path, sim, cmap)
    clean = load_mission(tmp_path, cfg, prepare=False)
    _as_dialect(tmp_path / "imu.csv", ";", ",", comments=("logged by vehicle X, firmware 1.2", "units: g, deg/s"))
    _as_dialect(tmp_path / "dvl.csv", "\t")
    _as_dialect(tmp_path / "nav.csv", ";", comments=("reference",))
    m = load_mission(tmp_path, cfg, prepare=False)
    for stream in ("imu", "dvl", "gt"):
        for a, b in zip(dataclasses.astuple(getattr(m, stream)), dataclasses.astuple(getattr(clean, stream))):
            if isinstance(a, np.ndarray):
                np.testing.assert_array_equal(a, b)
    notes = m.meta["streams"]["imu"]["notes"]
    imu = tmp_path / "imu.csv"
    assert f"{imu}: 2 comment line(s) before the header skipped" in notes
    assert f"{imu}: separated by ';'" in notes
    assert any(n.startswith(f"{imu}: ") and n.endswith("number(s) with a decimal comma read") for n in notes)
    assert f"{tmp_path / 'dvl.csv'}: separated by '\\t'" in m.meta["streams"]["dvl"]["notes"]
    cmap["dvl"]["delimiter"] = ","
    with pytest.raises(DataError, match=r"dvl.csv, line 1, field 'time_ms': column\(s\)"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap), prepare=False)
    cmap["dvl"]["delimiter"] = "\t"
    load_mission(tmp_path, _config(tmp_path, sim, cmap), prepare=False)
    lines = imu.read_text().splitlines()
    cells = lines[12].split(";")
    lines[12] = ";".join(cells[:1] + ["1.234,5"] + cells[2:])    # no number with a decimal point or comma
    imu.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"imu.csv, line 13, field 'ax': not a number: '1.234,5'"):
        load_mission(tmp_path, cfg, prepare=False)


def test_a_row_with_more_cells_than_the_header_is_refused_naming_its_line(sim, tmp_path):
    """A decimal comma in a comma-separated file splits a number into two cells, and the cells after it were read
    under the next columns' names (before: a gyro z read as its integer part with no word; a DVL file written so
    throughout was refused for a median speed of 1e13 m/s in its declared unit). Refused naming the file, the first
    line and how many; a trailing separator (an empty last cell) still reads as the clean file."""
    cmap = _separate_files(tmp_path, sim)
    cfg = _config(tmp_path, sim, cmap)
    clean = load_mission(tmp_path, cfg, prepare=False)
    imu, dvl = tmp_path / "imu.csv", tmp_path / "dvl.csv"
    text = imu.read_text()
    imu.write_text("\n".join(line + "," for line in text.splitlines()) + "\n")
    m = load_mission(tmp_path, cfg, prepare=False)
    np.testing.assert_array_equal(m.imu.omega_b, clean.imu.omega_b)
    lines = text.splitlines()
    cells = lines[1000].split(",")
    lines[1000] = ",".join(cells[:-1] + [cells[-1].replace(".", ",", 1)])      # line 1001: the gyro z
    imu.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"8 cells where the header \(line 1\) names 7: .*1 such line\(s\): 1001\. "
                                        r"Likely a decimal comma in a ','-separated file") as err:
        load_mission(tmp_path, cfg, prepare=False)
    assert err.value.source == str(imu) and err.value.line == 1001
    imu.write_text(text)
    rows = dvl.read_text().splitlines()
    dvl.write_text("\n".join(rows[:1] + [",".join(c.replace(".", ",") for c in row.split(",")) for row in rows[1:]])
                   + "\n")
    with pytest.raises(DataError, match=rf"line 2, .*{len(rows) - 1} such line\(s\): 2, 3, 4, "):
        load_mission(tmp_path, cfg, prepare=False)


def test_cells_past_the_header_no_decimal_comma_explains_are_warned_not_refused(sim, tmp_path):
    """A column a logger appends without naming it (a status word, a number with a decimal point) or a separator
    inside a note cell makes rows wider than the header, but no decimal comma can explain the cells past it: the
    named cells read as the clean file's, warned about with the lines and counted (refused before, as a decimal
    comma). A decimal comma in the same file is still refused."""
    cmap = _separate_files(tmp_path, sim)
    cfg = _config(tmp_path, sim, cmap)
    clean = load_mission(tmp_path, cfg, prepare=False)
    imu, dvl = tmp_path / "imu.csv", tmp_path / "dvl.csv"
    imu_text, dvl_rows = imu.read_text(), dvl.read_text().splitlines()
    imu.write_text("\n".join(imu_text.splitlines()[:1] + [line + ",OK,23.5" for line in imu_text.splitlines()[1:]])
                   + "\n")
    dvl.write_text("\n".join([dvl_rows[0] + ",note"] + [row + (",lock, 4 beams" if i % 9 == 0 else ",lock")
                                                        for i, row in enumerate(dvl_rows[1:])]) + "\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(tmp_path, cfg, prepare=False)
    np.testing.assert_array_equal(m.imu.omega_b, clean.imu.omega_b)
    np.testing.assert_array_equal(m.imu.f_b, clean.imu.f_b)
    np.testing.assert_array_equal(m.dvl.beams, clean.dvl.beams)
    said = [str(w.message) for w in caught if "more cells than the header" in str(w.message)]
    n_dvl = len(range(0, len(dvl_rows) - 1, 9))
    assert any(s.startswith(f"{imu}: {len(clean.imu.t)} row(s) with more cells than the header's 7 (lines 2, 3, ")
               for s in said), said
    assert any(s.startswith(f"{dvl}: {n_dvl} row(s) with more cells than the header's 10 (lines 2, 11, 20, ")
               for s in said), said
    assert m.meta["streams"]["dvl"]["doubted"]["cells past the header not read"] == n_dvl
    lines = [line + ",OK,23.5" for line in imu_text.splitlines()]
    lines[0] = imu_text.splitlines()[0]
    cells = lines[7].split(",")
    lines[7] = ",".join(cells[:6] + [cells[6].replace(".", ",", 1)] + cells[7:])     # line 8: a decimal comma too
    imu.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"1 such line\(s\): 8\. Likely a decimal comma"):
        load_mission(tmp_path, cfg, prepare=False)


def test_a_bad_depth_cell_refuses_its_row_and_dvl_warnings_name_lines(sim, tmp_path):
    """An empty, NaN or infinite depth cell refuses its row (warned with the line, counted) as for the other
    streams; it used to stop the load. A beam that is not a measurement is warned about at its file line (it
    named the ping's index)."""
    cmap = _separate_files(tmp_path, sim)
    cfg = _config(tmp_path, sim, cmap)
    for line, text in ((12, ""), (22, "nan"), (32, "inf")):
        _edit_line(tmp_path / "depth.csv", line, lambda f, text=text: [f[0], text])
    _edit_line(tmp_path / "dvl.csv", 42, lambda f: f[:2] + ["1e6"] + f[3:])
    m, messages = _load_recording(tmp_path, cfg)
    assert m.meta["streams"]["depth"]["refused"] == {"empty or NaN in 'p_dbar'": 2, "infinite in 'p_dbar'": 1}
    assert m.meta["streams"]["depth"]["read"] == len(sim.depth.t) and len(m.depth.t) == len(sim.depth.t) - 3
    assert any(s.startswith(f"{tmp_path / 'depth.csv'}: 3 depth sample(s) refused (2 empty or NaN in 'p_dbar'; 1 "
                            "infinite in 'p_dbar') at line(s) 12, 22, 32;") for s in messages), messages
    assert any(s.startswith(f"{tmp_path / 'dvl.csv'}: 1 beam value(s)") and "first at line 42," in s
               for s in messages), messages


def test_a_reference_position_its_velocity_cannot_explain_is_refused(sim, tmp_path):
    """1e308 (or a 20 m jump) in one reference position cell was accepted silently; the row is refused with its
    line, as a velocity spike is."""
    cmap = _separate_files(tmp_path, sim)
    cfg = _config(tmp_path, sim, cmap)
    _edit_line(tmp_path / "nav.csv", 52, lambda f: f[:1] + ["1e308"] + f[2:])
    _edit_line(tmp_path / "nav.csv", 152, lambda f: f[:2] + [f"{float(f[2]) + 20:.12g}"] + f[3:])
    m, messages = _load_recording(tmp_path, cfg)
    from graphnav.core.screening import GT_POSITION_SPIKE as reason
    assert m.meta["streams"]["gt"]["refused"] == {reason.format("n"): 1, reason.format("e"): 1}
    assert any(s.startswith(f"{tmp_path / 'nav.csv'}: 2 gt sample(s) refused (1 {reason.format('n')}; 1 "
                            f"{reason.format('e')}) at line(s) 52, 152;") for s in messages), messages
    np.testing.assert_allclose(m.gt.p_n, np.delete(sim.gt.p_n, [50, 150], axis=0), atol=1e-6)


def test_stamps_spanning_more_than_a_year_name_the_file_line(sim, tmp_path):
    """The 'more than a year' stamp error named the row's index as its line (line 11 for a row on file line 15,
    behind two comment lines and the header); it names the file line."""
    cmap = _separate_files(tmp_path, sim)
    cfg = _config(tmp_path, sim, cmap)
    imu = tmp_path / "imu.csv"
    lines = imu.read_text().splitlines()
    for i in range(12, len(lines)):                      # from file line 13 on (after the comments), a year later
        cells = lines[i].split(",")
        lines[i] = ",".join([f"{float(cells[0]) + 400 * 86400e3:.12g}"] + cells[1:])
    imu.write_text("\n".join(["# logger v2", "# stamps in ms"] + lines) + "\n")
    with pytest.raises(DataError, match="more than a year") as err:
        load_mission(tmp_path, cfg, prepare=False)
    assert (err.value.source, err.value.line, err.value.field) == (str(imu), 15, "time_ms")


def _scale_cells(path, columns, factor):
    """``path`` with the cells of ``columns`` (0-based) multiplied by ``factor`` on every row."""
    lines = path.read_text().splitlines()
    for i in range(1, len(lines)):
        cells = lines[i].split(",")
        for c in columns:
            cells[c] = f"{float(cells[c]) * factor:.12g}"
        lines[i] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def test_a_reference_velocity_in_other_units_is_named_by_the_unit_check(sim, tmp_path):
    """v_n written in cm/s was 'N of N gt samples refused (N GT speed > 4 m/s) ... check the units, the column
    map ...': the speed rule spoke before the unit check. The unit check names the columns and the factor; with
    the positions in cm too, the error names the velocity columns and the units that fit."""
    cfg = _config(tmp_path, sim, _separate_files(tmp_path, sim))
    nav = tmp_path / "nav.csv"
    _scale_cells(nav, [4, 5, 6], 100.0)
    with pytest.raises(DataError, match=r"the positions move 0\.01x as far as the velocity says") as err:
        load_mission(tmp_path, cfg, prepare=False)
    assert (err.value.source, err.value.field) == (str(nav), "n/e")
    _scale_cells(nav, [1, 2, 3], 100.0)
    with pytest.raises(DataError, match=r"velocity columns 'vn', 've', 'vd': median speed 207\.4 m/s.*cm/s "
                                        r"\(2\.07 m/s\)") as err:
        load_mission(tmp_path, cfg, prepare=False)
    assert (err.value.source, err.value.field) == (str(nav), "vn/ve/vd")
    assert "or the vehicle is faster than dvl.max_speed_mps (raise it" in str(err.value)    # a fast vehicle's way out


def test_a_reference_position_step_is_warned_and_kept_and_a_converging_start_is_no_spike(sim, tmp_path):
    """A step of the reference position (a USBL or GNSS reset) refused the two rows around it as 'GT position
    spike' and kept the step; the rows are kept and the step is warned about with its lines and noted. The first
    rows, compared with one side only, were refused when the reference converged (2 m per row); a first row that
    departs from rows agreeing with each other is still a spike."""
    from graphnav.core.screening import GT_POSITION_SPIKE as reason
    cfg = _config(tmp_path, sim, _separate_files(tmp_path, sim))
    nav = tmp_path / "nav.csv"
    clean = nav.read_text()
    for line in range(102, len(clean.splitlines()) + 1):
        _edit_line(nav, line, lambda f: f[:1] + [f"{float(f[1]) + 9.0:.12g}"] + f[2:])
    for line, offset in ((2, 6.0), (3, 4.0), (4, 2.0)):
        _edit_line(nav, line, lambda f: f[:2] + [f"{float(f[2]) + offset:.12g}"] + f[3:])
    m, messages = _load_recording(tmp_path, cfg)
    assert m.meta["streams"]["gt"]["refused"] == {}
    assert len(m.gt.t) == len(sim.gt.t)
    step = [s for s in messages if s.startswith(f"{nav}: 1 step(s) of the reference position")]
    assert len(step) == 1 and "9 m in 'n' between lines 101 and 102" in step[0] and "reset" in step[0], messages
    assert any("between lines 101 and 102" in n for n in m.meta["streams"]["gt"]["notes"])
    nav.write_text(clean)
    _edit_line(nav, 2, lambda f: f[:2] + [f"{float(f[2]) + 6.0:.12g}"] + f[3:])
    m, messages = _load_recording(tmp_path, cfg)
    assert m.meta["streams"]["gt"]["refused"] == {reason.format("e"): 1}


def _hover_log(tmp_path, seconds=120.0):
    """A hovering AUV's column-map log: IMU 100 Hz (rad/s, FRD) with a small attitude wobble and thruster
    accelerations, DVL 5 Hz v_b with 1 mm/s noise written with 3 decimals (1 mm/s resolution, as PD0 logs)."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, seconds, 0.01)
    roll, pitch = 0.01 * np.sin(2 * np.pi * t / 7.0), 0.01 * np.sin(2 * np.pi * t / 11.0 + 1)
    omega = np.column_stack([np.gradient(roll, t), np.gradient(pitch, t), np.zeros_like(t)])
    omega += rng.normal(0, 0.03 * np.pi / 180, omega.shape)
    f = 9.81 * np.column_stack([np.sin(pitch), -np.sin(roll) * np.cos(pitch), -np.cos(roll) * np.cos(pitch)])
    f += rng.normal(0, 0.01, f.shape)
    _write(tmp_path / "imu.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"], [t, f, omega])
    td = np.arange(0.1, seconds, 0.2)
    v = np.round(rng.normal(0, 0.001, (len(td), 3)), 3)
    _write(tmp_path / "dvl.csv", ["t", "vx", "vy", "vz"], [td, v])
    cfg = {"csv_columns": {"imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"],
                                   "omega_b": ["gx", "gy", "gz"], "gyro_unit": "rad/s", "accel_unit": "m/s^2",
                                   "frame": "frd"},
                           "dvl": {"file": "dvl.csv", "t": "t", "v_b": ["vx", "vy", "vz"], "velocity_unit": "m/s",
                                   "clock": "imu"}},
           "dvl": {"rate_hz": 5.0}}
    (tmp_path / "config.json").write_text(json.dumps(cfg))
    return v


def test_a_hovering_dvl_at_1_mm_s_resolution_keeps_its_pings_of_exactly_zero(tmp_path):
    """1 mm/s of noise written at 1 mm/s resolution rounds some pings of a hovering vehicle to 0, 0, 0: they are
    measurements of a vehicle at rest and are used (they were refused as 'no bottom lock')."""
    from graphnav.core.screening import NO_BOTTOM_LOCK
    from graphnav.io.loaders import read_mission
    v = _hover_log(tmp_path)
    zero = np.all(v == 0, axis=1)
    assert 20 < zero.sum() < 60
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = read_mission(tmp_path, tmp_path / "config.json")
    assert NO_BOTTOM_LOCK not in m.meta["streams"]["dvl"].get("refused", {})
    np.testing.assert_array_equal(m.dvl.v_b[zero], 0.0)
    assert m.dvl.valid[zero].all()


def test_a_reference_whose_stamps_jump_an_hour_is_named_as_a_jump_not_only_other_units(sim, tmp_path):
    """A reference alone put an hour ahead mid-log (a logger's time zone) was blamed on its units only: the error
    names the jump first."""
    cfg = _config(tmp_path, sim, _separate_files(tmp_path, sim))
    nav = tmp_path / "nav.csv"
    lines = nav.read_text().splitlines()
    for i in range(1 + len(lines) // 2, len(lines)):
        cells = lines[i].split(",")
        cells[0] = f"{float(cells[0]) + 3600e3:.12g}"            # ms stamps
        lines[i] = ",".join(cells)
    nav.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"its stamps jump by \+3600\.\d+ s after t = .*\+1 h to within a minute"):
        load_mission(tmp_path, cfg, prepare=False)


def _exchange_cells(path, a, b):
    """``path`` with the cells of 0-based columns ``a`` and ``b`` exchanged on every row but the header."""
    lines = path.read_text().splitlines()
    for i in range(1, len(lines)):
        cells = lines[i].split(",")
        cells[a], cells[b] = cells[b], cells[a]
        lines[i] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def test_a_reference_with_exchanged_or_negated_columns_is_refused_naming_the_columns_to_map(sim, tmp_path):
    """North and east exchanged in the velocity (or the positions) loaded with a warning of position steps and was
    scored against; the error names the pair and the mapping that reads it right. A down velocity or down position
    with its sign flipped is named by the attitude's pitch (it was 'one of the two columns')."""
    cfg = _config(tmp_path, sim, _separate_files(tmp_path, sim))
    nav = tmp_path / "nav.csv"
    clean = nav.read_text()
    cases = ((lambda: _exchange_cells(nav, 4, 5), "vn/ve", r"map csv_columns.gt.v_n as \['ve', 'vn', 'vd'\]"),
             (lambda: _exchange_cells(nav, 1, 2), "n/e", r"the position columns are wrong, north = 'e', east = 'n'; "
                                                         r"map csv_columns.gt.p_n as \['e', 'n', 'd'\]"),
             (lambda: _scale_cells(nav, [5], -1.0), "vn/ve", r"negate 've' \(a column map cannot negate a column\)"),
             (lambda: _scale_cells(nav, [6], -1.0), "vd", r"'vd' has its sign flipped"),
             (lambda: _scale_cells(nav, [3], -1.0), "d", r"'d' has its sign flipped"))
    for damage, field, message in cases:
        nav.write_text(clean)
        damage()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with pytest.raises(DataError, match=message) as err:
                load_mission(tmp_path, cfg, prepare=False)
        assert (err.value.source, err.value.field) == (str(nav), field)


def _hover_with_reference(root, gyro_scale=1.0, trim=(0.02, 0.05), ref_noise=0.0, seed=1, seconds=150.0,
                          mount_pitch=0.0, deg=False, yaw=0.7):
    """A hovering AUV's column-map log with a reference attitude (radians, no units declared): a trim of ``trim``
    (roll, pitch rad), a 0.3 mrad wobble, thruster accelerations of 0.2 m/s^2 (the tilt kinematics and the DVL cannot
    judge its gyro), the gyro multiplied by ``gyro_scale``, the reference's angles with ``ref_noise`` rad of noise.
    ``mount_pitch`` (rad): the IMU pitched against the body; ``deg``: the reference's angles written in degrees;
    ``yaw`` (rad): the heading."""
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 0.01)
    euler = np.column_stack([trim[0] + 3e-4 * np.sin(2 * np.pi * t / 7.0),
                             trim[1] + 3e-4 * np.sin(2 * np.pi * t / 11.0),
                             yaw + 5e-4 * np.sin(2 * np.pi * t / 30.0)])
    R = Rotation.from_euler("ZYX", euler[:, ::-1])
    omega = (R[:-1].inv() * R[1:]).as_rotvec() / 0.01
    omega = np.vstack([omega, omega[-1]]) + rng.normal(0, 5e-4, (t.size, 3))
    a = np.cumsum(rng.normal(0.0, 1.0, (t.size + 200, 3)), axis=0)
    a = (a[200:] - a[:-200]) * [0.2, 0.2, 0.06] / np.std(a[200:] - a[:-200], axis=0)
    v = np.cumsum(a, axis=0) * 0.01
    v -= np.column_stack([np.convolve(v[:, i], np.ones(3000) / 3000, "same") for i in range(3)])
    f = R.inv().apply(np.gradient(v, t, axis=0) - [0, 0, 9.80665]) + rng.normal(0, 0.01, (t.size, 3))
    if mount_pitch:
        f, omega = Rotation.from_euler("y", -mount_pitch).apply(np.vstack([f, omega])).reshape(2, -1, 3)
    _write(root / "imu.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"], [t, f, omega * gyro_scale])
    i, j = np.arange(0, t.size, 20), np.arange(0, t.size, 10)
    _write(root / "dvl.csv", ["t", "vx", "vy", "vz"],
           [t[i], R[i].inv().apply(v[i]) + rng.normal(0, 0.002, (i.size, 3))])
    _write(root / "nav.csv", ["t", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [t[j], np.cumsum(v, axis=0)[j] * 0.01 + [0, 0, 20.0], v[j],
            (euler[j] + rng.normal(0, ref_noise, (j.size, 3))) * (180 / np.pi if deg else 1.0)])
    cfg = {"csv_columns": {"imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"],
                                   "omega_b": ["gx", "gy", "gz"]},
                           "dvl": {"file": "dvl.csv", "t": "t", "v_b": ["vx", "vy", "vz"], "clock": "imu"},
                           "gt": {"file": "nav.csv", "t": "t", "p_n": ["n", "e", "d"], "v_n": ["vn", "ve", "vd"],
                                  "euler": ["roll", "pitch", "yaw"]}},
           "dvl": {"rate_hz": 5.0, "lever_arm_b": [0, 0, 0]}}
    (root / "config.json").write_text(json.dumps(cfg))
    return root / "config.json"


def test_a_column_map_dvl_in_an_unknown_unit_is_refused_naming_its_columns_and_the_key(tmp_path):
    """A column map's DVL in cm/s was refused naming 'v_b/v_d' (no column of the file) and advising "declare the
    velocity unit" (no key of the map): now its columns and csv_columns.dvl.velocity_unit. The columns are listed
    as the check of a declared unit against the IMU lists them ('vx, vy, vz', not 'vx/vy/vz')."""
    cfg = _hover_with_reference(tmp_path)
    dvl = np.loadtxt(tmp_path / "dvl.csv", delimiter=",", skiprows=1)
    _write(tmp_path / "dvl.csv", ["t", "vx", "vy", "vz"], [dvl[:, 0], dvl[:, 1:] * 100])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=r"cm/s \(0\.\d+ m/s\) or mm/s \(0\.0\d+ m/s\) \(most plausible first: "
                                            r"the IMU's .*\)\? declare csv_columns\.dvl\.velocity_unit \(m/s, cm/s, "
                                            r"mm/s, kn\)$") as err:
            load_mission(tmp_path, cfg)
    assert err.value.source == str(tmp_path / "dvl.csv") and err.value.field == "vx, vy, vz"


def _imu_notes(m):
    return " | ".join(m.meta["streams"]["imu"]["notes"])


def test_a_hovering_log_whose_gyro_is_57_times_too_small_is_judged_by_its_reference_attitude(tmp_path):
    """A hovering AUV's gyro 57.3x too small (rad/s data divided by 57.3) was read with a note that its scale went
    unchecked: the tilt kinematics and the DVL cannot tell the scales apart, and the reference's turn rate against the
    gyro's could equally be a reference in degrees. Its roll and pitch against the accelerometer's tilt settle the
    reference's unit as radians, and its turn then judges the gyro: a warning naming the gyro columns and the
    reference (a clean log in degrees gives the same numbers, see below); with the reference declared in radians,
    refused."""
    cfg = _hover_with_reference(tmp_path, np.pi / 180)
    with pytest.warns(RuntimeWarning, match=r"imu.csv: the gyro rates look 57.3x too small for rad/s: the reference "
                                            r"attitude \(.*nav.csv, columns roll/pitch/yaw\) turns 5\d\.\dx as fast.*"
                                            r"field gx/gy/gz.*Declare the reference's angle_unit"):
        m = load_mission(tmp_path, cfg)
    assert "look 57.3x too small" in _imu_notes(m)
    config = json.loads(cfg.read_text())
    config["csv_columns"]["gt"]["angle_unit"] = "rad"
    cfg.write_text(json.dumps(config))
    with pytest.raises(DataError, match=r"too small for rad/s: the reference attitude \(.*nav.csv, columns "
                                        r"roll/pitch/yaw\) turns 5\d\.\dx as fast") as err:
        load_mission(tmp_path, cfg)
    assert err.value.source.endswith("imu.csv") and err.value.field == "gx/gy/gz"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mission(tmp_path, _hover_with_reference(tmp_path))
    assert "gyro's scale judged against the reference attitude" in _imu_notes(m)
    np.testing.assert_allclose(C_b_n_to_euler(m.gt.C_b_n)[:, 1].mean(), 0.05, atol=1e-3)


@pytest.mark.parametrize("trim, ref_noise", [((0.0, 0.0), 0.0), ((0.02, 0.05), 0.003)])
def test_a_hovering_reference_that_cannot_settle_the_gyro_leaves_it_unjudged(tmp_path, trim, ref_noise):
    """A level vehicle (its roll and pitch cannot tell the reference's unit) or a reference whose turn is its noise
    (uncorrelated with the gyro's: 30x as fast): the gyro is read as before, with the note that its scale is
    unjudged."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mission(tmp_path, _hover_with_reference(tmp_path, np.pi / 180 if ref_noise == 0 else 1.0, trim,
                                                         ref_noise))
    assert "the gyro's scale is not judged" in _imu_notes(m) and "judged against the reference" not in _imu_notes(m)


@pytest.mark.parametrize("trim, mount_pitch, deg, judged", [((0.0005, 0.001), 0.05, True, False),
                                                            ((0.0005, 0.001), 0.087, True, False),
                                                            ((0.02, 0.05), 0.0, True, True),
                                                            ((0.0005, 0.001), 0.05, False, False)])
def test_a_clean_hovering_log_in_degrees_with_its_imu_tilted_is_not_refused(tmp_path, trim, mount_pitch, deg, judged):
    """A level vehicle (roll/pitch 0.03/0.06 deg) whose IMU is mounted pitched 3-5 deg, its reference in degrees: the
    accelerometer's tilt holds the mounting tilt, the degree numbers lie within 3x of it, and the reference was taken
    for radians, its turn 56x the gyro's, and a good gyro refused. A yaw of 40 cannot be radians (but for an unwrapped
    one): the tilt no longer settles the unit, and the gyro is left unjudged with its note. Its attitude was then kept
    as radians (roll/pitch/yaw 1.7/3.3/138 deg against 0.03/0.06/40): read as degrees it turns with the gyro, and is
    taken so. A trimmed vehicle in degrees and a level one in radians load as before."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mission(tmp_path, _hover_with_reference(tmp_path, trim=trim, mount_pitch=mount_pitch, deg=deg))
    assert ("judged against the reference" in _imu_notes(m)) == judged
    assert ("the gyro's scale is not judged" in _imu_notes(m)) != judged
    np.testing.assert_allclose(C_b_n_to_euler(m.gt.C_b_n).mean(axis=0), [*trim, 0.7], atol=1e-3)


def test_an_unwrapped_yaw_in_radians_with_a_gyro_57_times_too_small_is_read_as_degrees_with_a_counted_warning(
        tmp_path):
    """A damaged log (its yaw unwrapped to 7 rad, its gyro divided by 57.3) gives the numbers of a clean log in degrees
    whose IMU is mounted tilted: it loaded with notes only. Read as degrees it turns with the gyro, so it is taken so,
    with a warning naming the other reading and asking for angle_unit, counted as doubted; declared 'rad', refused."""
    cfg = _hover_with_reference(tmp_path, np.pi / 180, yaw=7.0)
    with pytest.warns(RuntimeWarning, match=r"nav.csv: attitude columns 'roll', 'pitch', 'yaw' read as degrees .* "
                                            r"turns 0\.9\d+x as fast as the gyro .* an unwrapped yaw in radians with a "
                                            r"gyro 57.3x too small .* declare the reference's angle_unit"):
        m = load_mission(tmp_path, cfg)
    np.testing.assert_allclose(C_b_n_to_euler(m.gt.C_b_n).mean(axis=0), np.radians([0.02, 0.05, 7.0]), atol=1e-4)
    assert m.meta["streams"]["gt"]["doubted"] == {DEGREES_BY_TURN_DOUBT: len(m.gt.t)}
    config = json.loads(cfg.read_text())
    config["csv_columns"]["gt"]["angle_unit"] = "rad"
    cfg.write_text(json.dumps(config))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=r"too small for rad/s") as err:
            load_mission(tmp_path, cfg)
    assert err.value.field == "gx/gy/gz"


def test_a_clean_log_in_degrees_heading_north_is_warned_about_not_refused(tmp_path, capsys):
    """Heading within 6.3 deg of north, the same level vehicle and tilted IMU cannot be told from radians and a gyro
    57.3x too small: a warning says both (it was a refusal of a clean log), the rates read as they are, and declaring
    the reference's angle_unit loads it without the warning (the gyro then unjudged: its level roll and pitch cannot
    settle anything)."""
    cfg = _hover_with_reference(tmp_path, trim=(0.0005, 0.001), mount_pitch=0.05, deg=True, yaw=0.05)
    with pytest.warns(RuntimeWarning, match=r"look 57.3x too small .* a reference in degrees on a level vehicle"):
        m = load_mission(tmp_path, cfg)
    raw = np.loadtxt(tmp_path / "imu.csv", delimiter=",", skiprows=1)[:, 4:7]
    np.testing.assert_allclose(np.median(np.abs(m.imu.omega_b)), np.median(np.abs(raw)), rtol=1e-6)
    # read despite the doubt: counted where a user scanning summary.json or `graphnav info` looks
    assert m.meta["streams"]["imu"]["doubted"] == {GYRO_SMALL_DOUBT: len(raw)}
    capsys.readouterr()
    assert cli.main(["info", str(tmp_path), "--config", str(cfg)]) == 0
    assert f"imu: {len(raw)} read despite a doubt: {GYRO_SMALL_DOUBT}" in capsys.readouterr().out
    out = io.StringIO()
    print_summary({"method": "smooth", "mission": "m", "epochs": 1, "duration_s": 1.0, "runtime_s": 1.0,
                   "realtime_factor": 1.0, "streams": m.meta["streams"]}, file=out)
    assert f"read despite a doubt (stream: reason: count): {{'imu': {{'{GYRO_SMALL_DOUBT}': {len(raw)}}}}}" \
        in out.getvalue()
    config = json.loads(cfg.read_text())
    config["csv_columns"]["gt"]["angle_unit"] = "deg"
    cfg.write_text(json.dumps(config))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mission(tmp_path, cfg)
    assert "the gyro's scale is not judged" in _imu_notes(m) and "look 57.3x too small" not in _imu_notes(m)
    np.testing.assert_allclose(C_b_n_to_euler(m.gt.C_b_n)[:, 2].mean(), 0.05, atol=1e-3)


def hovering_mission(root, gyro_scale=1.0):
    """The hovering AUV of :func:`_hover_with_reference` (its gyro's scale judged by neither the tilt kinematics nor
    the DVL) as read from its log, its gyro then multiplied by ``gyro_scale`` and its reference given a geodetic
    origin (so that a bag or an A-KIT folder can be written from it)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mission(root, _hover_with_reference(root), prepare=False)
    return dataclasses.replace(m, imu=dataclasses.replace(m.imu, omega_b=m.imu.omega_b * gyro_scale),
                               gt=dataclasses.replace(m.gt, origin_lla=np.array([0.5733, 0.6091, 0.0])))


def test_a_declared_dvl_velocity_unit_the_imu_contradicts_is_refused_naming_the_key(sim, tmp_path):
    """A DVL logging m/s declared cm/s or mm/s: speeds 100-1000x too small, and with 3 cm/s of noise its changes lie
    within that noise, so no check judged it and the log loaded without a word (an AUV at 2 cm/s). The IMU's
    accelerations fit its changes far better in m/s: refused naming the file, columns, key and the unit that fits."""
    cmap = _separate_files(tmp_path, sim)
    noise = np.random.default_rng(0).normal(0, 0.03, (len(sim.dvl.t), 3))
    v_b = sim.gt.v_b[np.searchsorted(sim.gt.t, sim.dvl.t)] + noise
    _write(tmp_path / "dvl.csv", ["time_ms", "vx", "vy", "vz"], [(sim.dvl.t + T0) * 1e3, v_b])
    for unit in ("cm/s", "mm/s"):
        cmap["dvl"] = {"file": "dvl.csv", "t": "time_ms", "v_b": ["vx", "vy", "vz"], "velocity_unit": unit}
        with pytest.raises(DataError, match=rf"dvl.csv, field 'vx, vy, vz': declared '{unit}' \(csv_columns.dvl."
                                            r"velocity_unit\), but .* median speed .* m/s in 'm/s': set csv_columns."
                                            r"dvl.velocity_unit to 'm/s'$"):
            load_mission(tmp_path, _config(tmp_path, sim, cmap))
    cmap["dvl"]["velocity_unit"] = "m/s"
    m = load_mission(tmp_path, _config(tmp_path, sim, cmap))
    np.testing.assert_allclose(m.dvl.v_b, v_b, atol=1e-9)


def test_a_declared_time_unit_the_sample_period_contradicts_is_refused_naming_the_key(sim, tmp_path):
    """Stamps in ms declared 's' (or in s declared 'ms'): the IMU ran at 100 kHz or 0.1 Hz by the declared unit; a
    declared unit was applied unchecked (a 0.04 s mission loaded). The detection's plausible periods now judge it."""
    cmap = _separate_files(tmp_path, sim)
    for declared, fits, key in (("s", "ms", "csv_columns.time_unit"), ("us", "ms", "csv_columns.time_unit")):
        cmap["time_unit"] = declared
        with pytest.raises(DataError, match=rf"imu.csv, field 'time_ms': the declared time unit '{declared}' \({key}\) "
                                            rf"makes the median stamp step .* no plausible imu sample period .*: the "
                                            rf"stamps look like {fits}; set {key} to '{fits}'$"):
            load_mission(tmp_path, _config(tmp_path, sim, cmap))
    cmap["time_unit"] = "ms"
    cmap["dvl"]["time_unit"] = "s"
    with pytest.raises(DataError, match=r"dvl.csv, field 'time_ms': the declared time unit 's' \(csv_columns.dvl."
                                        r"time_unit\) makes the median stamp step 1e\+03 s, no plausible dvl"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))


def test_a_declared_dvl_velocity_unit_is_judged_once_a_given_offset_puts_the_dvl_on_the_imu_clock(sim, tmp_path):
    """A DVL on a clock of its own (three days off) with dvl_time_offset_s given, m/s declared cm/s: the unit was
    checked before the given offset put the DVL on the IMU clock, and not after, so the log loaded at 1/100 of the
    vehicle's speed without a word. Now it is refused naming the key, as on the IMU clock."""
    cmap = _separate_files(tmp_path, sim)
    noise = np.random.default_rng(0).normal(0, 0.03, (len(sim.dvl.t), 3))
    v_b = sim.gt.v_b[np.searchsorted(sim.gt.t, sim.dvl.t)] + noise
    _write(tmp_path / "dvl.csv", ["time_ms", "vx", "vy", "vz"], [(sim.dvl.t + T0 + 3 * 86400.0) * 1e3, v_b])
    cmap["dvl"] = {"file": "dvl.csv", "t": "time_ms", "v_b": ["vx", "vy", "vz"], "velocity_unit": "cm/s"}
    cfg = _config(tmp_path, sim, cmap)
    cfg.write_text(json.dumps({**json.loads(cfg.read_text()), "dvl_time_offset_s": -3 * 86400.0}))
    with pytest.raises(DataError, match=r"declared 'cm/s' \(csv_columns.dvl.velocity_unit\), but .* set csv_columns."
                                        r"dvl.velocity_unit to 'm/s'$"):
        load_mission(tmp_path, cfg)


def test_a_declared_dvl_velocity_unit_too_large_is_refused_naming_the_key_and_the_unit_that_fits(sim, tmp_path):
    """mm/s declared cm/s: the speeds, 10x too large, were refused with the declared factor applied twice ('cm/s
    (0.013 m/s) or mm/s (0.0013 m/s)?') and advice to declare the unit already declared."""
    cmap = _separate_files(tmp_path, sim)
    v_b = sim.gt.v_b[np.searchsorted(sim.gt.t, sim.dvl.t)] * 1e3
    _write(tmp_path / "dvl.csv", ["time_ms", "vx", "vy", "vz"], [(sim.dvl.t + T0) * 1e3, v_b])
    cmap["dvl"] = {"file": "dvl.csv", "t": "time_ms", "v_b": ["vx", "vy", "vz"], "velocity_unit": "cm/s"}
    speed = np.median(np.linalg.norm(v_b, axis=1)) / 1e3
    with pytest.raises(DataError, match=rf"median DVL speed .* m/s in the declared unit 'cm/s' \(csv_columns.dvl."
                                        rf"velocity_unit\) is beyond the 10 m/s a DVL measures: 'mm/s' \({speed:.3g} "
                                        r"m/s\)\? set csv_columns.dvl.velocity_unit to the file's unit$"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))


def test_a_global_time_unit_only_the_dvl_contradicts_advises_the_dvl_key(sim, tmp_path):
    """IMU stamps in ms, the DVL's in s, csv_columns.time_unit 'ms': the advice was to set the global unit to 's',
    which breaks the IMU; it is the DVL's own key."""
    cmap = _separate_files(tmp_path, sim)
    _write(tmp_path / "dvl.csv", ["time_s", "b1", "b2", "b3", "b4", "ok1", "ok2", "ok3", "ok4"],
           [sim.dvl.t + T0, np.where(sim.dvl.valid, sim.dvl.beams * 1e3, -32768.0), sim.dvl.valid.astype(float)])
    cmap["dvl"]["t"] = "time_s"
    with pytest.raises(DataError, match=r"dvl.csv, field 'time_s': the declared time unit 'ms' \(csv_columns.time_unit"
                                        r"\) .* set csv_columns.dvl.time_unit to 's' \(this stream's own unit"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))


def test_beam_columns_in_a_declared_unit_too_large_are_refused_naming_the_key(sim, tmp_path):
    """Beam velocities in mm/s declared m/s: every beam was refused as beyond the DVL's range ('400 of 400 dvl samples
    refused ... check the units') without naming the key; the beams' speeds are judged in the declared unit as the
    velocity columns' are."""
    cmap = _separate_files(tmp_path, sim)         # its beams are in mm/s
    cmap["dvl"]["velocity_unit"] = "m/s"
    with pytest.raises(DataError, match=r"in the declared unit 'm/s' \(csv_columns.dvl.velocity_unit\) is beyond"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))


def _depth_log(tmp_path, m, stamps):
    """The mission's depth at 1 Hz as a ``depth`` column, stamped ``stamps(t)`` (t: s on the mission's clock)."""
    t = np.arange(m.depth.t[0], m.depth.t[-1] + 1e-9, 1.0)
    _write(tmp_path / "depth.csv", ["t", "depth"], [stamps(t), np.interp(t, m.depth.t, m.depth.depth)])
    return {"file": "depth.csv", "t": "t", "depth": "depth"}


def test_a_declared_time_unit_that_puts_a_stream_off_the_imu_span_is_refused_naming_the_key(sim, tmp_path):
    """A depth at 1 Hz stamped in s declared 'ms' steps 1 ms, a plausible depth period, and loaded 1.7e9 s before the
    IMU, unused, with a depth-spike warning as the only word; a reference the same way drew warnings of position
    steps; a 20 Hz DVL in ms declared 's' was refused as 'micro/nanoseconds read as seconds'. The span in the
    declared unit is now checked against the IMU's: refused naming the key and the unit that puts it there."""
    cmap = _separate_files(tmp_path, sim)
    cmap["depth"] = {**_depth_log(tmp_path, sim, lambda t: t + T0), "time_unit": "ms"}
    with pytest.raises(DataError, match=r"depth.csv, field 't': the declared time unit 'ms' \(csv_columns.depth."
                                        r"time_unit\) puts the depth stamps at \[-1698300000\.000, "
                                        r"-1698299999\.960\] s, sharing 0 % of the IMU's \[0\.000, 40\.000\] s .*; "
                                        r"in 's' they lie at \[0\.000, 40\.000\] s, "
                                        r"sharing 100 %: set csv_columns.depth.time_unit to 's'$"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))
    # the global unit, right for the IMU (ms), wrong for a reference stamped in s at 1 Hz: its own key is advised
    cmap = _separate_files(tmp_path, sim)
    g, k = sim.gt, np.arange(0, len(sim.gt.t), 10)
    _write(tmp_path / "nav.csv", ["t", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [g.t[k] + T0, g.p_n[k], g.v_n[k], np.degrees(C_b_n_to_euler(g.C_b_n[k]))])
    cmap["gt"]["t"] = "t"
    with pytest.raises(DataError, match=r"nav.csv, field 't': the declared time unit 'ms' \(csv_columns.time_unit\) "
                                        r".* set csv_columns.gt.time_unit to 's' \(this stream's own unit"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))
    # a 20 Hz DVL stamped in ms, declared s: 50 s steps are a plausible DVL period too
    cmap = _separate_files(tmp_path, sim)
    t = np.arange(0.0, 40.0, 0.05)
    v_b = np.column_stack([np.interp(t, sim.gt.t, sim.gt.v_b[:, i]) for i in range(3)])
    _write(tmp_path / "dvl.csv", ["t", "vx", "vy", "vz"], [(t + T0) * 1e3, v_b])
    cmap["dvl"] = {"file": "dvl.csv", "t": "t", "v_b": ["vx", "vy", "vz"], "time_unit": "s"}
    with pytest.raises(DataError, match=r"dvl.csv, field 't': the declared time unit 's' \(csv_columns.dvl.time_unit\)"
                                        r" .* set csv_columns.dvl.time_unit to 'ms'$"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))


def _another_missions_reference():
    """The reference of another simulated 40 s mission: no clock offset puts its turns on the log's gyro."""
    return simulate_mission(duration_s=40.0, seed=6).gt


def test_a_stream_off_the_imu_span_in_every_unit_is_warned_about_and_counted(sim, tmp_path):
    """A depth or reference on a clock of its own (5000 s late), whose unit explains nothing: the depth loaded
    without a word and was never used ('graphnav info': usable, 41 used), the reference too until scoring failed. They
    keep today's use, but are warned about naming the file, the stamp column and both spans, and counted; a DVL on
    a clock of its own in its declared unit is still found by the clock search. (The reference is another mission's,
    whose turns match the gyro's at no offset: this one's would be put on the IMU clock by them.)"""
    cmap = _separate_files(tmp_path, sim)
    cmap["depth"] = {**_depth_log(tmp_path, sim, lambda t: (t + T0 + 5000.0) * 1e3), "time_unit": "ms"}
    g = _another_missions_reference()
    _write(tmp_path / "nav.csv", ["time_ms", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [(g.t + T0 + 5000.0) * 1e3, g.p_n, g.v_n, np.degrees(C_b_n_to_euler(g.C_b_n))])
    with pytest.warns(RuntimeWarning) as caught:
        m = load_mission(tmp_path, _config(tmp_path, sim, cmap))
    said = [str(w.message) for w in caught]
    for name, field, what, n in (("depth", "t", "depth", 41), ("gt", "time_ms", "reference", 401)):
        assert any(re.search(rf"\b{name if name == 'depth' else 'nav'}\.csv: field '{field}': the {what} stamps "
                             r"\[5000\.000, 5040\.000\] s lie off the IMU span \[0\.000, 40\.000\] s \(sharing 0 % of "
                             rf"the shorter span\): a clock of its own; the {n} of {n} sample\(s\) outside", s)
                   for s in said), said
        assert m.meta["streams"][name]["refused"] == {"outside the IMU time span": n}
        assert m.meta["streams"][name]["used"] == 0


def _slow_log(root, hovering: bool, dvl_factor: float, declared: str | None, seed=1, seconds=200.0, speed=0.45,
              beams=False, noise=0.003):
    """A column-map log of a vehicle at ``speed`` +- 0.1 m/s turning gently, or (``hovering``) holding station on
    thrusters (0.05 m/s^2, about 0.15 m/s): IMU 100 Hz FRD with exact kinematics, a 1 Hz body velocity with ``noise``
    m/s of noise written times ``dvl_factor`` (1000: mm/s) and its unit ``declared`` (``beams``: as four beam
    columns)."""
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 0.01)
    if hovering:
        a = np.cumsum(rng.normal(0.0, 1.0, (t.size + 200, 3)), axis=0)
        a = (a[200:] - a[:-200]) * 0.05 / np.std(a[200:] - a[:-200], axis=0)
        v_b = np.cumsum(a, axis=0) * 0.01
        v_b -= np.column_stack([np.convolve(v_b[:, i], np.ones(3000) / 3000, "same") for i in range(3)])
        heading, tilt = 0.7 + 0.3 * np.sin(2 * np.pi * t / 100.0), 3e-4
    else:
        v_b = np.column_stack([speed + 0.1 * np.sin(2 * np.pi * t / 90.0), 0.02 * np.sin(2 * np.pi * t / 40.0),
                               0.01 * np.sin(2 * np.pi * t / 60.0)])
        heading, tilt = 1.0 + np.cumsum(0.03 * np.sin(2 * np.pi * t / 120.0)) * 0.01, 0.01
    R = Rotation.from_euler("ZYX", np.column_stack([heading, tilt * np.sin(2 * np.pi * t / 11.0 + 1),
                                                    tilt * np.sin(2 * np.pi * t / 7.0)]))
    f_b = R.inv().apply(np.gradient(R.apply(v_b), t, axis=0) - [0.0, 0.0, 9.80665]) + rng.normal(0, 0.01, v_b.shape)
    omega = (R[:-1].inv() * R[1:]).as_rotvec() / 0.01
    omega = np.vstack([omega, omega[-1]]) + rng.normal(0, 5e-4, v_b.shape)
    _write(root / "imu.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"], [t, f_b, omega])
    i = np.arange(0, t.size, 100)
    v_dvl = (v_b[i] + rng.normal(0, noise, (i.size, 3))) * dvl_factor
    dvl = {"file": "dvl.csv", "t": "t", "v_b": ["vx", "vy", "vz"], "clock": "imu"}
    if beams:
        from graphnav.core.config import DvlSpec
        from graphnav.core.dvl import DvlGeometry
        v_dvl = v_dvl @ DvlGeometry.from_spec(DvlSpec()).T_b.T
        dvl = {"file": "dvl.csv", "t": "t", "beams": ["b1", "b2", "b3", "b4"], "clock": "imu"}
    _write(root / "dvl.csv", ["t", *dvl.get("v_b", dvl.get("beams"))], [t[i], v_dvl])
    imu = {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"], "frame": "frd"}
    cfg = {"csv_columns": {"imu": imu, "dvl": dvl | ({"velocity_unit": declared} if declared else {})},
           "dvl": {"rate_hz": 1.0, "lever_arm_b": [0, 0, 0]}}
    (root / "config.json").write_text(json.dumps(cfg))
    return root / "config.json"


@pytest.mark.parametrize("hovering, refusal", [
    (False, r"dvl.csv, field 'vx, vy, vz': 1\d\d of 200 dvl samples refused \(1\d\d outside the envelope \(speed\)\): "
            r"more than 50% of the stream; "),
    ("beams", r"dvl.csv, field 'b1, b2, b3, b4': 1\d\d of 200 dvl samples refused \(1\d\d outside the envelope "
              r"\(speed\)\): more than 50% of the stream; "),
    (True, r"dvl.csv, field 'vx, vy, vz': declared 'cm/s' \(csv_columns.dvl.velocity_unit\), but the IMU's "
           r"accelerations fit the velocity's changes \d+x better in 'mm/s' \(x0.1; .*: set "
           r"csv_columns.dvl.velocity_unit to 'mm/s'$")])
def test_a_declared_unit_10x_too_large_on_a_slow_or_hovering_vehicle_is_named_as_the_likely_cause(tmp_path, hovering,
                                                                                                   refusal):
    """mm/s data declared cm/s: a slow vehicle (0.45 m/s) read at 4.5 m/s was refused by the vehicle's envelope with
    'check the units', a hovering one (0.15 m/s at 1.5 m/s) by the frame check as earth-fixed with the advice to
    declare csv_columns.dvl.frame 'ned'. In mm/s the speeds are plausible, the velocity vehicle-fixed and the IMU's
    accelerations explain it: the refusal names the unit and the key. The hovering one's kinematics (1.017x) are
    within what its noise allows (1.044): the frame check keeps it, and the declared unit's check refuses it, naming
    the unit and the key. Declared mm/s, both load. Logged as beam columns, the refusal names them (it named field
    'dvl')."""
    beams, hovering = hovering == "beams", hovering is True
    cfg = _slow_log(tmp_path, hovering, 1e3, "cm/s", beams=beams)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=refusal if hovering else refusal + (
                r"the declared unit is the likely cause: in 'mm/s' \(x0.1\) the median speed is 0.\d+ m/s, \d+ of 200 "
                r"pings within the vehicle's envelope, the velocity vehicle-fixed, the IMU's accelerations leaving "
                r"0.\d+ of its changes unexplained against \d.\d+ in 'cm/s': set csv_columns.dvl.velocity_unit to "
                r"'mm/s'$")):
            load_mission(tmp_path, cfg)
        load_mission(tmp_path, _slow_log(tmp_path, hovering, 1e3, "mm/s", beams=beams))


@pytest.mark.parametrize("seed", [1, 7])
def test_a_hovering_vehicle_with_a_noisy_dvl_is_not_warned_as_pointing_sideways(tmp_path, seed):
    """A vehicle holding station on thrusters (about 0.15 m/s) with 3 cm/s of DVL noise, its unit declared right: no
    fit judges the DVL's turn, and its mean direction was taken from the 8-11 of 200 pings over 0.3 m/s, one
    excursion pointing one way: 'points -132 deg about z from body x on average over the log', every ping counted as
    doubted. Those pings are under a fifth of the log now: its direction is not judged, nothing is said."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_mission(tmp_path, _slow_log(tmp_path, True, 1e3, "mm/s", seed=seed, noise=0.03))
    assert "doubted" not in m.meta["streams"]["dvl"]


def test_the_units_a_speed_beyond_a_dvl_names_come_most_plausible_first(tmp_path):
    """A hovering vehicle's velocity in mm/s (median about 150) with no unit declared: 'cm/s (1.5 m/s) or mm/s (0.15
    m/s)?', the larger speed first, though the IMU's accelerations explain mm/s and not cm/s; in cm/s declared m/s
    (median about 15), knots (7.7 m/s, beyond the vehicle's 4 m/s) came first. The IMU's fits now order them, and the
    message says so."""
    cfg = _slow_log(tmp_path, True, 1e3, None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=r"median DVL speed 1\d\d\.\d is beyond the 10 m/s a DVL measures: mm/s "
                                            r"\(0.1\d+ m/s\) or cm/s \(1.\d+ m/s\) \(most plausible first: the IMU's "
                                            r"accelerations leave 0.00\d+, 0.\d+ of the velocity's changes "
                                            r"unexplained\)\? declare csv_columns.dvl.velocity_unit"):
            load_mission(tmp_path, cfg)
        with pytest.raises(DataError, match=r"in the declared unit 'm/s' \(csv_columns.dvl.velocity_unit\) is beyond "
                                            r"the 10 m/s a DVL measures: 'cm/s' \(0.1\d+ m/s\) or .*'kn' "
                                            r"\(\d.\d+ m/s\).* \(most plausible first: the IMU's accelerations leave "
                                            r"0.00\d+, "):
            load_mission(tmp_path, _slow_log(tmp_path, True, 1e2, "m/s"))


def test_a_depth_or_reference_off_the_imu_span_is_left_out_and_said_not_usable(sim, tmp_path, capsys):
    """A depth and a reference 5000 s late, warned about and counted, were still in the mission: ``graphnav info``
    said usable with a time span of 0-5040 s, and ``smooth`` ended in a traceback scoring the reference. Both are
    optional: left out of the mission, marked not usable with the reason (info, summary), the span the IMU's. (The
    reference is another mission's: this one's turns would put it on the IMU clock.)"""
    cmap = _separate_files(tmp_path, sim)
    cmap["depth"] = {**_depth_log(tmp_path, sim, lambda t: (t + T0 + 5000.0) * 1e3), "time_unit": "ms"}
    g = _another_missions_reference()
    _write(tmp_path / "nav.csv", ["time_ms", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [(g.t + T0 + 5000.0) * 1e3, g.p_n, g.v_n, np.degrees(C_b_n_to_euler(g.C_b_n))])
    cfg = _config(tmp_path, sim, cmap)
    with pytest.warns(RuntimeWarning, match=r"the depth is left out; put the depth stamps on the IMU clock"):
        m = load_mission(tmp_path, cfg)
    assert m.depth is None and m.gt is None
    for name in ("depth", "gt"):
        entry = m.meta["streams"][name]
        assert entry["usable"] is False and entry["reason"].startswith("its stamps [5000.000, 5040.000] s lie off")
    assert cli.main(["info", str(tmp_path), "--config", str(cfg)]) == 0
    out = capsys.readouterr().out
    assert re.search(r"left out +depth: not usable: its stamps \[5000\.000, 5040\.000\] s lie off the IMU span", out)
    assert re.search(r"time span +0\.000 s \.\. 40\.000 s", out), out


def test_a_depth_on_a_clock_of_its_own_inside_the_imu_span_in_part_is_not_used_at_the_wrong_time(sim, tmp_path):
    """A depth 30 s late on a 40 s mission shares a quarter of the span: its 10 s inside the IMU span were used,
    30 s off, while the warning called the stream a clock of its own. None of it is used now, each sample counted."""
    cmap = _separate_files(tmp_path, sim)
    cmap["depth"] = {**_depth_log(tmp_path, sim, lambda t: t + T0 + 30.0), "time_unit": "s"}
    with pytest.warns(RuntimeWarning, match=r"the 30 of 41 sample\(s\) outside the IMU span and the 11 inside it are "
                                            r"not used: the depth is left out"):
        m = load_mission(tmp_path, _config(tmp_path, sim, cmap))
    from graphnav.io.stream_counts import OFF_THE_IMU_CLOCK, OUTSIDE_IMU_SPAN
    assert m.depth is None
    assert m.meta["streams"]["depth"]["refused"] == {OUTSIDE_IMU_SPAN: 30, OFF_THE_IMU_CLOCK: 11}


def test_a_depth_on_a_third_clock_is_left_out_when_the_dvl_clock_is_moved(sim, tmp_path):
    """With the DVL on its own clock (moved by the clock search) a depth on a third clock was a DataError ('give the
    depth offset', a key that does not exist), with the DVL on the IMU's clock a warning: one rule now, left out."""
    cmap = _separate_files(tmp_path, sim)
    beams = np.where(sim.dvl.valid, sim.dvl.beams * 1e3, -32768.0)
    _write(tmp_path / "dvl.csv", ["time_ms", "b1", "b2", "b3", "b4", "ok1", "ok2", "ok3", "ok4"],
           [(sim.dvl.t + T0 + 600.0) * 1e3, beams, sim.dvl.valid.astype(float)])
    cmap["depth"] = {**_depth_log(tmp_path, sim, lambda t: t + T0 + 5000.0), "time_unit": "s"}
    with pytest.warns(RuntimeWarning, match=r"the depth is left out"):
        m = load_mission(tmp_path, _config(tmp_path, sim, cmap))
    np.testing.assert_allclose(m.dvl.t, sim.dvl.t, atol=0.5)
    assert m.depth is None and m.meta["streams"]["depth"]["usable"] is False


def test_a_declared_time_unit_is_checked_on_a_stream_covering_part_of_the_imu_span(sim, tmp_path):
    """A 1 Hz reference over the first 40 % of the mission, stamped in s and declared 'ms', shares at most 40 % of
    the longer span in 's' too: it was warned about as 'a clock of its own', advising gt_time_offset_s. A unit that
    puts the stream inside the IMU span, its span within 31.6x of the IMU's, is now the unit advised."""
    cmap = _separate_files(tmp_path, sim)
    g, k = sim.gt, np.arange(0, 160, 10)
    _write(tmp_path / "nav.csv", ["t", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [g.t[k] + T0, g.p_n[k], g.v_n[k], np.degrees(C_b_n_to_euler(g.C_b_n[k]))])
    cmap["gt"] = {**cmap["gt"], "t": "t", "time_unit": "ms"}
    with pytest.raises(DataError, match=r"nav.csv, field 't': the declared time unit 'ms' \(csv_columns.gt.time_unit\)"
                                        r" .* in 's' they lie at \[0\.000, 15\.000\] s, sharing 100 %: set "
                                        r"csv_columns.gt.time_unit to 's'$"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))


def test_a_dvl_stamp_beyond_the_bound_names_its_line_and_the_declared_unit(sim, tmp_path):
    """A 20 Hz DVL on its own clock (600 s late) stamped in ms, declared 's': 50 s steps are a plausible period, no
    unit puts it on the IMU span, and the error said 'dvl.csv, line 0' (an index into the arrays; line 1 is the
    header) without the key. It names the first data line and the unit that fits now."""
    cmap = _separate_files(tmp_path, sim)
    t = np.arange(0.0, 40.0, 0.05)
    v_b = np.column_stack([np.interp(t, sim.gt.t, sim.gt.v_b[:, i]) for i in range(3)])
    _write(tmp_path / "dvl.csv", ["t", "vx", "vy", "vz"], [(t + T0 + 600.0) * 1e3, v_b])
    cmap["dvl"] = {"file": "dvl.csv", "t": "t", "v_b": ["vx", "vy", "vz"], "time_unit": "s"}
    with pytest.raises(DataError, match=r"dvl.csv, line 2, field 't': time stamp 1\.6983e\+12 s from the first IMU "
                                        r"stamp is beyond 1e\+10 s \(800 such stamp\(s\) in the declared unit 's', "
                                        r"csv_columns.dvl.time_unit\): the stamps look like ms; set "
                                        r"csv_columns.dvl.time_unit to 'ms'$"):
        load_mission(tmp_path, _config(tmp_path, sim, cmap))


def test_a_declared_unit_10x_too_large_on_a_vehicle_inside_the_envelope_is_warned_as_suspect_and_counted(tmp_path):
    """mm/s data declared cm/s on a vehicle at 0.25 m/s, read at 2.4 m/s: inside the envelope, vehicle-fixed, it
    loaded without a word; the IMU's accelerations fit mm/s about 2.5x better, under the 4x that refuses. Between 2x
    and 4x the unit is now suspect: a warning naming the key and the unit that fits, a note, the pings counted.
    Declared mm/s, nothing is said."""
    said = (r"dvl.csv: field 'vx, vy, vz': declared 'cm/s' \(csv_columns.dvl.velocity_unit\), but the IMU's "
            r"accelerations fit the velocity's changes [23]\.\d+x better in 'mm/s' .* under the 4x that refuses it: "
            r"kept in 'cm/s', suspect; set csv_columns.dvl.velocity_unit to 'mm/s' if the file is in it")
    with pytest.warns(RuntimeWarning, match=said):
        m = load_mission(tmp_path, _slow_log(tmp_path, False, 1e3, "cm/s", speed=0.25))
    from graphnav.calibration.dvl_scale import VELOCITY_UNIT_SUSPECT
    assert m.meta["streams"]["dvl"]["doubted"] == {VELOCITY_UNIT_SUSPECT: 200}
    assert any("suspect" in note for note in m.meta["streams"]["dvl"]["notes"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_mission(tmp_path, _slow_log(tmp_path, False, 1e3, "mm/s", speed=0.25))
    assert "doubted" not in m.meta["streams"]["dvl"]


def test_a_column_map_in_knots_without_a_unit_beyond_the_envelope_is_told_the_unit_to_declare(tmp_path):
    """A vehicle at 2.2 m/s logged in knots with no velocity_unit, read as m/s at 4.3 m/s: over half its pings beyond
    the vehicle's 4 m/s, refused saying only 'check the units, the column map and the configuration's sensor ranges'
    (A-KIT Trajectory5, 8 and 13 exported so). The unit the loader took is judged as a declared one is: the refusal
    names knots and the key to declare."""
    knot = 1852.0 / 3600.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        said = (r"dvl.csv, field 'vx, vy, vz': 200 of 200 dvl samples refused \(200 outside the envelope "
                r"\(speed\)\): more than 50% of the stream; the unit taken with none declared \('m/s'\) is the likely "
                r"cause: in 'kn' \(x0.5144\) the median speed is 2.2\d m/s, 200 of 200 pings within the vehicle's "
                r"envelope, .*: declare csv_columns.dvl.velocity_unit 'kn'$")
        with pytest.raises(DataError, match=said):
            load_mission(tmp_path, _slow_log(tmp_path, False, 1 / knot, None, speed=2.2))


def test_a_column_map_in_knots_without_a_unit_is_judged_by_the_imu_fits(tmp_path):
    """A velocity logged in knots with no velocity_unit is read as m/s; the speed-scale check refused it only where its
    fit explains 0.9 of the velocity's changes, advising 'velocity_unit' without the key's section. The IMU's fits of
    the declared-unit check now judge the unit the loader took too, naming the key to declare. In m/s, nothing."""
    knot = 1852.0 / 3600.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        said = (r"dvl.csv, field 'vx, vy, vz': no unit declared \(csv_columns.dvl.velocity_unit\): read in 'm/s', "
                r"but the IMU's accelerations fit the velocity's changes \d+\.?\d*x better in 'kn' .*: declare "
                r"csv_columns.dvl.velocity_unit 'kn'$")
        with pytest.raises(DataError, match=said):
            load_mission(tmp_path, _slow_log(tmp_path, False, 1 / knot, None, speed=1.5))
        warnings.simplefilter("error")
        load_mission(tmp_path, _slow_log(tmp_path, False, 1.0, None, speed=1.5))


@pytest.mark.parametrize("late_s", [16.0, 28.0])
def test_a_reference_on_a_clock_of_its_own_is_put_on_the_imu_clock_by_its_turns(sim, tmp_path, late_s):
    """A reference 16 s late on a 40 s log shares 60 % of the IMU span: kept, its time offset searched within +-2 s
    (+0.38 s found), and scored 16 s off (smooth: VRMSE 0.48 against 0.03 m/s). 28 s late it shares 30 %: left out,
    though the turns it records match the gyro's exactly at -28 s. Without a given gt_time_offset_s the clock search
    puts both on the IMU clock, warned about, noted, and the offset kept in the configuration, as an A-KIT GT."""
    cmap = _separate_files(tmp_path, sim)
    g = sim.gt
    _write(tmp_path / "nav.csv", ["time_ms", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [(g.t + T0 + late_s) * 1e3, g.p_n, g.v_n, np.degrees(C_b_n_to_euler(g.C_b_n))])
    cfg = json.loads(_config(tmp_path, sim, cmap).read_text())
    cfg["gt_time_offset_s"] = None
    (tmp_path / "config.json").write_text(json.dumps(cfg))
    with pytest.warns(RuntimeWarning, match=rf"reference clock offset -{late_s - 1:.0f}\.99\d s .* added to the "
                                            rf"reference stamps \[{late_s:.3f}, {late_s + 40:.3f}\] s"):
        m = load_mission(tmp_path, tmp_path / "config.json")
    np.testing.assert_allclose(m.gt.t, g.t, atol=1e-3)
    assert m.meta["streams"]["gt"].get("usable", True)
    assert m.config.gt_time_offset_s == pytest.approx(-late_s, abs=1e-3)
    assert any("reference clock offset" in n for n in m.meta["streams"]["gt"]["notes"])


def _shifted_reference(tmp_path, sim, shift_s, **cfg_keys):
    """The simulated log with its reference stamped ``shift_s`` late (s), and its configuration with ``cfg_keys``."""
    cmap = _separate_files(tmp_path, sim)
    g = sim.gt
    _write(tmp_path / "nav.csv", ["time_ms", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [(g.t + T0 + shift_s) * 1e3, g.p_n, g.v_n, np.degrees(C_b_n_to_euler(g.C_b_n))])
    cfg = json.loads(_config(tmp_path, sim, cmap).read_text())
    cfg.update(cfg_keys)
    (tmp_path / "config.json").write_text(json.dumps(cfg))
    return tmp_path / "config.json"


@pytest.mark.parametrize("late_s", [16.0, -16.0])
def test_a_given_reference_offset_the_clock_search_contradicts_is_doubted_with_the_offset_the_data_give(
        sim, tmp_path, late_s):
    """A configuration's gt_time_offset_s 0 (the simulator's configuration writes it) with the reference logged 16 s
    late was judged by the +-2 s fine search alone: "the data say +0.380 s". The clock search an offset not given
    gets names the offset the data give (-16 s), the score says it is doubted, and init auto does not start from a
    reference 16 s early (the vehicle 16 s along its path: VRMSE 18.9 m/s)."""
    from graphnav.calibration.preparation import reference_notes
    from graphnav.estimators.runs import initial_state
    cfg = _shifted_reference(tmp_path, sim, late_s, gt_time_offset_s=0.0)
    with pytest.warns(RuntimeWarning, match=r"gt_time_offset_s = \+0\.000 s is given, but the angles the reference "
                                            r"turns through match the gyro's at [+-]\d+\.\d+ s") as said:
        m = load_mission(tmp_path, cfg)
    data_say = re.search(r"match the gyro's at ([+-]\d+\.\d+) s", str(said[0].message)).group(1)
    assert float(data_say) == pytest.approx(-late_s, abs=2e-3) and "used as given" in str(said[0].message)
    np.testing.assert_allclose(m.gt.t, sim.gt.t + late_s, atol=1e-3)       # used as given
    assert m.meta["streams"]["gt"]["doubted"] == {"gt_time_offset_s used as given though the data disagree": 401}
    assert "the score is doubted" in reference_notes(m)["reference_time"]
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        assert initial_state(m, None, "auto", 0.0) is None
    assert any("aligned from the sensors" in str(w.message) for w in said)
    right = _shifted_reference(tmp_path, sim, late_s, gt_time_offset_s=-late_s)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_mission(tmp_path, right)
    assert "reference_time" not in reference_notes(m) and initial_state(m, None, "auto", 0.0) is not None


@pytest.mark.parametrize("late_s, right", [(16.0, False), (-16.0, False), (16.0, True)])
def test_a_reference_given_an_offset_checks_the_imu_axes_where_it_is_used(sim, tmp_path, late_s, right):
    """An IMU logged with its y axis the wrong way, no frame declared, and the reference logged 16 s late (early).
    With gt_time_offset_s 0 given (doubted, used as given) or the right -16 s given, the reference checked the axes at
    its stamps as read, 16 s off, and the gyro against its attitude saw nothing: the IMU kept y the wrong way, without
    a word. It now checks them where the data put it (a doubted offset, as an A-KIT folder's GT does) or at the
    offset given: the y axis is turned back with a warning."""
    flipped = dataclasses.replace(sim, imu=dataclasses.replace(sim.imu, f_b=sim.imu.f_b * [1, -1, 1],
                                                                omega_b=sim.imu.omega_b * [1, -1, 1]))
    cfg = _shifted_reference(tmp_path, flipped, late_s, gt_time_offset_s=-late_s if right else 0.0)
    with pytest.warns(RuntimeWarning, match=r"the IMU data contradict .*need axis signs \(1, -1, 1\)"):
        m = load_mission(tmp_path, cfg)
    np.testing.assert_array_equal(m.config.imu_axis_signs, [1, -1, 1])
    np.testing.assert_allclose(m.imu.omega_b, sim.imu.omega_b, atol=1e-9)
    doubted = {} if right else {"gt_time_offset_s used as given though the data disagree": 401}
    assert m.meta["streams"]["gt"].get("doubted", {}) == doubted


def test_a_given_reference_offset_that_leaves_it_off_the_imu_span_is_searched_and_the_data_decide(sim, tmp_path):
    """A configuration's gt_time_offset_s 0 with the reference logged 28 s late on a 40 s log (sharing 30 %): the
    reference was left out unsearched, though its turns match the gyro's at -28 s. It now gets the clock search a
    reference without a given offset gets: used as given it would be lost, so the offset the data give is used,
    warned about naming the configuration and the key, noted, counted as doubted and kept in the configuration."""
    from graphnav.calibration.preparation import reference_notes
    cfg = _shifted_reference(tmp_path, sim, 28.0, gt_time_offset_s=0.0)
    with pytest.warns(RuntimeWarning, match=r"config.json: gt_time_offset_s = \+0\.000 s is given, but the angles the "
                                            r"reference turns through match the gyro's at -2[78]\.\d+ s .* reference "
                                            r"would be left out: -2[78]\.\d+ s is used instead"):
        m = load_mission(tmp_path, cfg)
    np.testing.assert_allclose(m.gt.t, sim.gt.t, atol=1e-3)
    entry = m.meta["streams"]["gt"]
    assert entry.get("usable", True) and not entry.get("refused")
    assert entry["doubted"] == {"gt_time_offset_s off the IMU span: the offset the data give used instead": 401}
    assert m.config.gt_time_offset_s == pytest.approx(-28.0, abs=1e-3)
    assert "reference_time" not in reference_notes(m) and "gt_clock_doubted" not in m.meta


@pytest.mark.parametrize("late_s, reference", [(16.0, True), (16.0, False), (-5.0, False)])
def test_a_depth_on_a_clock_of_its_own_inside_the_imu_span_is_placed_by_the_vertical_motion_and_left_out(
        sim, tmp_path, late_s, reference):
    """A depth 16 s late on a 40 s log shares 60 % of the IMU span: it was kept and used 16 s off, no check saw it
    (the convention's 10 s windows leave a 40 s log too few). Its changes over 2 s windows match the vertical
    velocity (the reference's, else the DVL's turned by gravity) best at its stamps -16 s: it is left out, warned
    about naming the file and the stamp field, counted and marked not usable; the log loads without it."""
    cmap = _separate_files(tmp_path, sim)
    if not reference:
        del cmap["gt"]
    _write(tmp_path / "depth.csv", ["time_ms", "p_dbar"],
           [(sim.depth.t + T0 + late_s) * 1e3, sim.depth.depth * 1025.0 * sim.config.gravity_mps2 / 1e4])
    cfg = _config(tmp_path, sim, cmap)
    with pytest.warns(RuntimeWarning, match=r"depth.csv: field 'time_ms': the depth's changes match the .* best at "
                                            r"its stamps [+-]\d+\.\d s .* the depth is left out") as said:
        m = load_mission(tmp_path, cfg)
    found = float(re.search(r"best at its stamps ([+-]\d+\.\d) s", str(said[0].message)).group(1))
    assert found == pytest.approx(-late_s, abs=1.0)
    assert m.depth is None and m.dvl is not None
    entry = m.meta["streams"]["depth"]
    assert not entry["usable"] and sum(entry["refused"].values()) == len(sim.depth.t)


def test_a_depth_on_the_imu_clock_is_kept(sim, tmp_path):
    """The same log, its depth as simulated: its changes match the vertical velocity best at its stamps."""
    cfg = _config(tmp_path, sim, _separate_files(tmp_path, sim))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_mission(tmp_path, cfg)
    np.testing.assert_allclose(m.depth.t, sim.depth.t, atol=1e-6)


def test_a_reference_too_short_to_check_the_imu_axes_is_kept_unjudged_and_the_log_loads(sim, tmp_path):
    """A reference on the IMU clock at 1 Hz over the first 30 % of a 40 s log shares 9 intervals with the IMU span:
    too few to check the IMU axes against (10 needed), which refused the whole log. The reference is optional: the
    IMU alone checks the axes, and the reference is kept for the scores, warned about and counted as doubted."""
    cmap = _separate_files(tmp_path, sim)
    g = sim.gt
    k = np.flatnonzero((g.t < 12.0) & (np.abs(g.t - np.round(g.t)) < 1e-6))        # 1 Hz, 0..11 s
    _write(tmp_path / "nav.csv", ["time_ms", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [(g.t[k] + T0) * 1e3, g.p_n[k], g.v_n[k], np.degrees(C_b_n_to_euler(g.C_b_n[k]))])
    with pytest.warns(RuntimeWarning, match=r"nav.csv: the reference \[0.000, 11.000\] s shares 9 interval\(s\) .* "
                                            r"too few to check the IMU axes against it \(10 needed\); the IMU alone"):
        m = load_mission(tmp_path, _config(tmp_path, sim, cmap))
    np.testing.assert_allclose(m.gt.t, g.t[k], atol=1e-6)
    np.testing.assert_allclose(m.imu.omega_b, sim.imu.omega_b, atol=1e-6)
    assert m.meta["streams"]["gt"]["doubted"] == {"too short to check the IMU axes against": 12}


def test_a_column_map_imu_slower_than_its_logger_clock_is_read_at_the_configured_rate(sim, tmp_path):
    """A 98 Hz IMU logged in whole 10 ms (every 50th step 20 ms) read 100 Hz with its stamps as written, up to 10 ms
    late; the configuration's imu_rate_hz 98 reaches the reader, whose stamps then go on one even grid at 98 Hz,
    warned naming the key."""
    cmap = _separate_files(tmp_path, sim)
    true = T0 + np.arange(sim.imu.t.size) / 98.0
    _write(tmp_path / "imu.csv", ["time_ms", "ax", "ay", "az", "gx", "gy", "gz"],
           [np.floor(true * 100) * 10.0, sim.imu.f_b / 9.80665, np.degrees(sim.imu.omega_b)])
    cfg = sim.config.to_dict()
    cfg.update(csv_columns=cmap, imu_rate_hz=98.0)
    (tmp_path / "config.json").write_text(json.dumps(cfg))
    m, messages = _load_recording(tmp_path, tmp_path / "config.json")
    assert any("agree with the configured imu_rate_hz 98 Hz" in s for s in messages)
    assert np.max(np.abs(m.imu.t + m.meta["t0_s"] - true)) < 2e-4


def test_an_imu_stalled_for_2_s_is_refused_naming_its_lines_and_bridged_not_integrated(tmp_path):
    """An IMU driver re-sending its last reading for 2 s (200 rows, every value the same) was integrated as the
    vehicle's motion with no word: the end of a 40 s run 2 m from the clean run's, health never flagged (150 s: 32 m,
    then DIVERGED). The repeats are now refused as a stalled sensor, warned about with their lines and counted, and the
    run bridges them as a gap: the end within 0.3 m of the clean run's. An IMU whose counts are coarser than its noise
    repeats rows everywhere and keeps them."""
    from graphnav.core import screening
    from graphnav.evaluation.methods import run_method
    mission = simulate_mission(duration_s=40.0, seed=5)
    clean = run_method(mission, "Graph-TC", "none")
    k = 2000
    mission.imu.f_b[k:k + 200] = mission.imu.f_b[k]
    mission.imu.omega_b[k:k + 200] = mission.imu.omega_b[k]
    cfg = _config(tmp_path, mission, _separate_files(tmp_path, mission))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(tmp_path, cfg)
    sol = run_method(m, "Graph-TC", "none")
    assert np.linalg.norm(sol.p_n[-1, :2] - clean.p_n[-1, :2]) < 0.3
    stalled = screening.IMU_STALLED
    assert m.meta["streams"]["imu"]["refused"] == {stalled: 199}
    said = [str(w.message) for w in caught if "imu sample(s) refused" in str(w.message)]
    assert len(said) == 1 and f"imu.csv: 199 imu sample(s) refused (199 {stalled}) at line(s) {k + 3}, " in said[0]
    # counts coarser than the noise (1e-3 rad/s, 0.05 m/s^2 at rest): rows repeat everywhere, none is a stall
    rng = np.random.default_rng(0)
    t = np.arange(3000) * 0.01
    f = np.round((np.array([0.0, 0.0, -9.81]) + 1e-3 * rng.standard_normal((3000, 3))) / 0.05) * 0.05
    w = np.round((np.array([1e-5, 0.0, 4e-5]) + 1e-6 * rng.standard_normal((3000, 3))) / 1e-3) * 1e-3
    assert np.all(f[1:] == f[:-1], axis=1).mean() > 0.5 and not screening.imu_stalled(t, f, w).any()


def test_all_zero_imu_rows_are_refused_at_load_before_the_dvl_clock_search_and_said_once(tmp_path):
    """A logger's all-zero IMU rows (0.5 s of them and two single rows, stamps continuing) were loaded without a word
    and searched with as no acceleration and no turn: the DVL's clock, 12 s late, was placed 0.55 s off (a 2 s run:
    88 s off), and only the run dropped them. Now the loader refuses them first, under their own reason, in one
    warning naming the file, the count and the lines; the clock is found as in the clean log, and the run sees no
    filler to warn about again (it bridges the gap left as any IMU gap)."""
    from graphnav.core.config import SensorConfig
    from graphnav.evaluation.methods import run_method
    cfg = SensorConfig()
    cfg.dvl = dataclasses.replace(cfg.dvl, beam_noise_std=0.01)
    sim = simulate_mission(200.0, seed=1, config=cfg)
    rows = [5000, *range(8000, 8050), 15000]
    f_b, omega_b = sim.imu.f_b.copy(), sim.imu.omega_b.copy()
    f_b[rows], omega_b[rows] = 0.0, 0.0
    _write(tmp_path / "imu.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"], [sim.imu.t + T0, f_b, omega_b])
    _write(tmp_path / "dvl.csv", ["t", "b1", "b2", "b3", "b4"], [sim.dvl.t + T0 + 12.0, sim.dvl.beams])
    config = _config(tmp_path, sim, {
        "imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"]},
        "dvl": {"file": "dvl.csv", "t": "t", "beams": ["b1", "b2", "b3", "b4"], "clock": "auto"}})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(tmp_path, config)
        run_method(m, "TC", "none")
    np.testing.assert_allclose(m.dvl.t, sim.dvl.t, atol=0.1)
    filler = "all-zero IMU row (a logger's filler: zero specific force is impossible under gravity)"
    assert m.meta["streams"]["imu"]["refused"] == {filler: 52}
    assert len(m.imu.t) == len(sim.imu.t) - 52 and np.all(np.any(m.imu.f_b != 0.0, axis=1))
    said = [str(w.message) for w in caught if "all-zero IMU row" in str(w.message)]
    assert len(said) == 1 and f"imu.csv: 52 imu sample(s) refused (52 {filler}) at line(s) 5002, 8002, 8003" in said[0]


def test_a_quoted_decimal_comma_in_a_comma_separated_file_gets_the_decimal_comma_advice(akit_dir, tmp_path):
    """Trajectory1 as a column map with one cell written ``"0,5"`` (quoted: one cell of a comma-separated file) was
    refused as ``not a number: '0,5'`` without the advice the same cell unquoted gets (two cells: a decimal comma). It
    is refused with that advice, naming the file, line and column: ``"1,250"`` may be 1250 with a thousands separator,
    so the cell is not read as 0.5. In a ';'-separated file the same cell reads as 0.5."""
    def quoted(sep):
        def edit(lines):
            lines = [line.replace(",", sep) for line in lines]
            cells = lines[500].split(sep)
            lines[500] = sep.join([cells[0], '"0,5"', *cells[2:]])
            return lines
        return edit
    folder, config = _akit_as_column_map(akit_dir, tmp_path / "quoted", imu_edit=quoted(","))
    with pytest.raises(DataError, match=r"imu\.csv, line 501, field 'ACC X \[m/s\^2\]': not a number: '0,5', a "
                                        r"decimal comma in a quoted cell of a ','-separated file \(write decimal "
                                        r"points, or separate the cells by ';' or tab\)"):
        load_mission(folder, config)
    folder, config = _akit_as_column_map(akit_dir, tmp_path / "semicolons", imu_edit=quoted(";"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mission(folder, config)
    assert any(note.endswith("1 number(s) with a decimal comma read") for note in m.meta["streams"]["imu"]["notes"])
    assert len(m.imu.t) == 40000
