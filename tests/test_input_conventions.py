"""Inputs in another convention than declared: an IMU frame the data contradict (column-map CSV, bags), a depth
positive up or in other units, a clock that jumps by an hour."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from graphnav.core.errors import DataError
from graphnav.core.rotations import C_b_n_to_euler
from graphnav.io import bags
from graphnav.io.bag_convert import FLU_FRD
from graphnav.missions import load_mission
from graphnav.sim.simulate import simulate_mission
from test_generic_csv import _config, _write


@pytest.fixture(scope="module")
def sim():
    return simulate_mission(duration_s=60.0, seed=5)


def _csv(tmp_path, m, *, f_b=None, omega_b=None, frame="frd", gt=True):
    """``m`` as a column-map CSV folder (IMU rows ``f_b``/``omega_b`` when given); returns the configuration path."""
    _write(tmp_path / "imu.csv", ["t", "ax", "ay", "az", "gx", "gy", "gz"],
           [m.imu.t, m.imu.f_b if f_b is None else f_b, m.imu.omega_b if omega_b is None else omega_b])
    _write(tmp_path / "dvl.csv", ["t", "b1", "b2", "b3", "b4"], [m.dvl.t, np.nan_to_num(m.dvl.beams, nan=-32.768)])
    _write(tmp_path / "depth.csv", ["t", "depth"], [m.depth.t, m.depth.depth])
    _write(tmp_path / "nav.csv", ["t", "n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw"],
           [m.gt.t, m.gt.p_n, m.gt.v_n, C_b_n_to_euler(m.gt.C_b_n)])
    imu = {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"]}
    if frame is not None:
        imu["frame"] = frame
    cmap = {"time_unit": "s", "imu": imu, "dvl": {"file": "dvl.csv", "t": "t", "beams": ["b1", "b2", "b3", "b4"]},
            "depth": {"file": "depth.csv", "t": "t", "depth": "depth"}}
    if gt:
        cmap["gt"] = {"file": "nav.csv", "t": "t", "p_n": ["n", "e", "d"], "v_n": ["vn", "ve", "vd"],
                      "euler": ["roll", "pitch", "yaw"], "angle_unit": "rad"}
    return _config(tmp_path, m, cmap)


def _load(path, config):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(path, config)
    return m, [str(w.message) for w in caught]


@pytest.mark.parametrize("gt", [True, False])
def test_an_upside_down_imu_declared_frd_is_refused_and_corrected_with_auto(sim, tmp_path, gt):
    flip = np.array([1.0, -1.0, -1.0])           # FLU, or rolled 180 deg
    clean, said = _load(tmp_path, _csv(tmp_path, sim, gt=gt))
    assert not [s for s in said if "contradict" in s]
    with pytest.raises(DataError, match=r"imu\.csv.*ax/ay/az/gx/gy/gz.*contradict csv_columns\.imu\.frame 'frd'.*"
                                        r"\(1, -1, -1\).*upside down.*frame to 'flu'"):
        load_mission(tmp_path, _csv(tmp_path, sim, f_b=sim.imu.f_b * flip, omega_b=sim.imu.omega_b * flip, gt=gt))
    for frame in ("auto", None):          # asked for, or no frame declared: corrected with a warning and a note
        m, said = _load(tmp_path, _csv(tmp_path, sim, f_b=sim.imu.f_b * flip, omega_b=sim.imu.omega_b * flip,
                                       frame=frame, gt=gt))
        assert [s for s in said if "imu.csv: the IMU data contradict" in s and "multiplied" in s]
        assert any("(1, -1, -1)" in n for n in m.meta["streams"]["imu"]["notes"])
        np.testing.assert_allclose(m.imu.f_b, clean.imu.f_b, atol=1e-9)
        np.testing.assert_allclose(m.imu.omega_b, clean.imu.omega_b, atol=1e-12)


def test_an_imu_turned_90_deg_about_z_is_named(sim, tmp_path):
    f, w = sim.imu.f_b, sim.imu.omega_b        # x to starboard: x_imu = y_b, y_imu = -x_b
    turned = [np.column_stack([a[:, 1], -a[:, 0], a[:, 2]]) for a in (f, w)]
    with pytest.raises(DataError, match=r"imu\.csv.*mounted turned.*its x axis points starboard, its y axis points "
                                        r"aft"):
        load_mission(tmp_path, _csv(tmp_path, sim, f_b=turned[0], omega_b=turned[1]))


def _turned_about_z(a, yaw_deg):
    """Body-frame rows ``a`` (N,3) as an IMU mounted turned ``yaw_deg`` about z reads them (its axes Rz(yaw)^T body's:
    90 puts its x to starboard)."""
    c, s = np.cos(np.deg2rad(yaw_deg)).round(12), np.sin(np.deg2rad(yaw_deg)).round(12)
    return a @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize("yaw, points", [(90, "its x axis points starboard, its y axis points aft"),
                                         (180, "its x axis points aft, its y axis points port"),
                                         (270, "its x axis points port, its y axis points forward")])
def test_an_imu_turned_about_z_without_a_reference_is_refused_by_the_dvl(sim, tmp_path, yaw, points):
    """Gravity cannot see a turn about z; the DVL's velocity changes against the accelerometer can."""
    clean, _ = _load(tmp_path, _csv(tmp_path, sim, gt=False))
    assert not [n for n in clean.meta["streams"]["imu"]["notes"] if "mounting" in n]
    turned = [_turned_about_z(a, yaw) for a in (sim.imu.f_b, sim.imu.omega_b)]
    for frame, what in (("frd", "csv_columns.imu.frame 'frd'"), (None, "the FRD axes taken for csv_columns.imu")):
        with pytest.raises(DataError, match=rf"imu\.csv, field 'ax/ay/az/gx/gy/gz': the IMU's axes are turned {yaw} "
                                            rf"deg about z against {what}.*{points}.*before graphnav reads them"):
            load_mission(tmp_path, _csv(tmp_path, sim, f_b=turned[0], omega_b=turned[1], frame=frame, gt=False))


@pytest.mark.parametrize("seed", [1, 2])
def test_a_hovering_vehicle_with_its_imu_turned_is_refused_naming_either_instrument(seed):
    """A hovering AUV's velocity points no one way: a turn between the IMU and the DVL (q 2.9e6-7.1e6) cannot be put on
    either, so both are named with their fixes (it was only the DVL's yaw warning, and the run went on turned)."""
    import dataclasses
    from graphnav.calibration.dvl_scale import check_velocity_against_imu, turn_about_z
    from test_units import _hovering_with_dvl, sim_config
    imu, dvl = _hovering_with_dvl(seed=seed)
    frame = {"what": "csv_columns.imu.frame 'frd'", "fields": "ax/ay/az/gx/gy/gz"}
    for yaw, C_d_b in ((90, r"\[\[0, 1, 0\], \[-1, 0, 0\]"), (180, r"\[\[-1, 0, 0\], \[0, -1, 0\]")):
        turned = dataclasses.replace(imu, f_b=_turned_about_z(imu.f_b, yaw), omega_b=_turned_about_z(imu.omega_b, yaw))
        with warnings.catch_warnings():
            warnings.simplefilter("error")          # no DVL yaw warning beside the refusal
            with pytest.raises(DataError, match=rf"imu\.csv, field 'ax/ay/az/gx/gy/gz': the IMU's axes and the DVL "
                               rf"velocity \(dvl\.csv\) are turned {yaw} deg about z .* cannot say which instrument .*"
                               rf"IMU turned against .*before graphnav reads them.*; DVL turned .*dvl\.C_d_b {C_d_b}"):
                check_velocity_against_imu(turned, dvl, sim_config(), {}, imu_frame=frame)
        # the DVL's fix as named: its velocity in a frame turned against the IMU's, which is the body's
        cfg = sim_config()
        cfg.dvl.C_d_b = turn_about_z(yaw).T
        in_d = dataclasses.replace(dvl, v_b=None, v_d=dvl.v_b, v_d_valid=np.ones(len(dvl.t), bool))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            check_velocity_against_imu(turned, in_d, cfg, {}, imu_frame=frame)


def _steady(monkeypatch, seed, speed_mps, duration_s=400.0):
    """A simulated mission (navigation-grade IMU) on one straight leg at a steady ``speed_mps``: the simulator's
    plan without its turns, speed and depth changes, keeping its sea-state wobble (0.0: a vehicle holding station)."""
    import graphnav.sim.simulate as sim_module
    plan = sim_module.plan_trajectory

    def straight(*args, **kwargs):
        traj = plan(*args, **kwargs)
        traj.yaw, traj.pitch, traj.speed = sim_module.SmoothSteps(), sim_module.SmoothSteps(), sim_module.SmoothSteps()
        traj.speed0 = speed_mps
        return traj
    monkeypatch.setattr(sim_module, "plan_trajectory", straight)
    return simulate_mission(duration_s, "navigation", seed)


@pytest.mark.parametrize("seed, speed", [(1, 1.5), (3, 0.0)])
def test_a_steady_vehicle_is_not_refused_as_turned_and_a_turned_imu_on_it_is(monkeypatch, seed, speed):
    """A straight leg at 1.5 m/s, or a vehicle holding station: the scale fit explains 0.02-0.03 of the velocity's
    changes, so its best offset was noise (11.5 s and 7.5 s off), and there the IMU as read was refused as turned 180
    deg (q 54 and 234); an IMU turned 270 deg was named turned 90. Each fit is read at its own best offset now."""
    _judged_as_read_and_turned(_steady(monkeypatch, seed, speed), (90, 180, 270))


def _judged_as_read_and_turned(m, yaws):
    """``m``'s IMU fits its DVL as read, without a warning or a note that it could not judge, and turned by each of
    ``yaws`` deg about z it is refused naming that turn (as a column-map log without reference is checked)."""
    import dataclasses
    from graphnav.calibration.dvl_scale import check_velocity_against_imu
    frame = {"what": "csv_columns.imu.frame 'frd'", "fields": "ax/ay/az/gx/gy/gz"}
    meta = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_velocity_against_imu(m.imu, m.dvl, m.config, meta, imu_frame=frame)
    assert not meta.get("streams", {}).get("imu", {}).get("notes"), meta       # judged: fits the IMU as read
    for yaw in yaws:
        turned = dataclasses.replace(m.imu, f_b=_turned_about_z(m.imu.f_b, yaw),
                                     omega_b=_turned_about_z(m.imu.omega_b, yaw))
        with pytest.raises(DataError, match=rf"turned {yaw} deg about z"):
            check_velocity_against_imu(turned, m.dvl, m.config, {}, imu_frame=frame)


@pytest.mark.parametrize("seed, yaw", [(0, 270), (6, 90)])
def test_a_minute_long_log_is_judged_over_the_same_windows_at_every_offset(seed, yaw):
    """A 60 s manoeuvring log has three 20 s windows. Searched within +-20 s, every wrong turn's best offset left one
    of them out (the one it explains worst) and fitted the other two better than the right axes fit all three: the
    IMU as read and turned 270 / 90 deg were not judged (|q| 19-30). Every offset is scored over the same windows."""
    _judged_as_read_and_turned(simulate_mission(60.0, "navigation", seed), (yaw,))


def test_a_log_too_short_to_check_the_imu_turn_says_so(tmp_path):
    short = simulate_mission(duration_s=30.0, seed=5)
    m, _ = _load(tmp_path, _csv(tmp_path, short, gt=False))
    assert [n for n in m.meta["streams"]["imu"]["notes"] if "mounting about z not checked against the DVL" in n]


def test_a_bag_imu_turned_about_z_without_a_reference_is_refused_by_the_dvl(sim, tmp_path):
    import dataclasses
    config = tmp_path / "config.json"
    sim.config.save(config)
    turned = dataclasses.replace(sim, gt=None, imu=dataclasses.replace(
        sim.imu, f_b=_turned_about_z(sim.imu.f_b, 90), omega_b=_turned_about_z(sim.imu.omega_b, 90)))
    with pytest.raises(DataError, match=r"/imu/data.*turned 90 deg about z against the IMU frame_id 'imu_link'.*"
                                        r"its x axis points starboard"):
        load_mission(bags.write_mission_bag(turned, tmp_path / "turned"), config)


def test_a_bag_imu_in_frd_without_the_frd_frame_id_is_corrected(sim, tmp_path):
    """A driver that publishes FRD rates under a REP-103 frame_id: read as FLU, the axes are turned back."""
    import dataclasses
    config = tmp_path / "config.json"
    sim.config.save(config)
    clean = load_mission(bags.write_mission_bag(sim, tmp_path / "clean"), config)
    frd = dataclasses.replace(sim, imu=dataclasses.replace(sim.imu, f_b=sim.imu.f_b @ FLU_FRD,
                                                           omega_b=sim.imu.omega_b @ FLU_FRD))
    m, said = _load(bags.write_mission_bag(frd, tmp_path / "frd"), config)
    assert [s for s in said if "frame_id 'imu_link' of /imu/data (REP-103 FLU" in s and "(1, -1, -1)" in s]
    np.testing.assert_allclose(m.imu.f_b, clean.imu.f_b, atol=1e-9)
    np.testing.assert_allclose(m.imu.omega_b, clean.imu.omega_b, atol=1e-12)


def _depth_case(tmp_path, sim, depth, *, gt=True, **config):
    """The CSV folder of ``sim`` with its depth column replaced by ``depth`` (and configuration keys)."""
    path = _csv(tmp_path, sim, gt=gt)
    _write(tmp_path / "depth.csv", ["t", "depth"], [sim.depth.t, depth])
    cfg = json.loads(path.read_text())
    cfg.update(config)
    path.write_text(json.dumps(cfg))
    return path


@pytest.mark.parametrize("gt", [True, False])
def test_a_depth_positive_up_is_turned_down_when_the_vertical_velocity_says_so(sim, tmp_path, gt):
    # the range widened so that the positive-up depths (-22.6 .. -1.8 m) reach the check
    m, said = _load(tmp_path, _depth_case(tmp_path, sim, -sim.depth.depth, gt=gt, depth_range_m=[-30, 6000]))
    assert [s for s in said if "depth.csv: column 'depth' read as depth positive up and turned positive down" in s]
    np.testing.assert_allclose(m.depth.depth, sim.depth.depth, atol=1e-9)


def test_a_pressure_in_bar_as_depth_and_a_depth_above_the_surface_are_refused(sim, tmp_path):
    bar = sim.depth.depth * 1025.0 * 9.80665 / 1e5 + 1.01325
    with pytest.raises(DataError, match=r"depth\.csv, field 'depth': the depth does not follow the vehicle's vertical "
                                        r"motion: its changes are 0\.1\d*x .*pressure mapped as 'depth'"):
        load_mission(tmp_path, _depth_case(tmp_path, sim, bar))
    still = np.full(len(sim.depth.t), -3.0) + 0.01 * np.random.default_rng(0).standard_normal(len(sim.depth.t))
    with pytest.raises(DataError, match=r"depth\.csv, field 'depth': depth -3.* above the sea surface"):
        load_mission(tmp_path, _depth_case(tmp_path, sim, still))


def test_an_absolute_pressure_in_dbar_as_depth_is_warned_about(sim, tmp_path):
    dbar = sim.depth.depth * 1025.0 * 9.80665 / 1e4 + 10.1325
    m, said = _load(tmp_path, _depth_case(tmp_path, sim, dbar))
    assert [s for s in said if "depth.csv: column 'depth' is 10.2 m deeper than the GT's down" in s
            and "absolute pressure in dbar" in s]
    assert any("absolute pressure in dbar" in n for n in m.meta["streams"]["depth"]["notes"])


def _jump(tmp_path, sim, streams, at_s=30.0, by_s=3600.0):
    """The CSV folder of ``sim`` with the stamps of ``streams`` (csv file names) moved by ``by_s`` from ``at_s`` on."""
    path = _csv(tmp_path, sim)
    for name in streams:
        lines = (tmp_path / name).read_text().splitlines()
        rows = [[float(x) for x in line.split(",")] for line in lines[1:]]
        for row in rows:
            row[0] += by_s if row[0] >= at_s else 0.0
        _write(tmp_path / name, lines[0].split(","), [np.array(rows)])
    return path


def test_a_clock_jump_in_every_stream_is_an_imu_gap_before_any_reference_check(sim, tmp_path):
    config = _jump(tmp_path, sim, ("imu.csv", "dvl.csv", "depth.csv", "nav.csv"))
    line = 2 + int(np.searchsorted(sim.imu.t, 30.0))
    with pytest.raises(DataError, match=rf"imu\.csv, line {line}, field 't': IMU gap of 3600.* \+1 h to within a "
                                        r"minute, a time zone"):
        load_mission(tmp_path, config)


def test_a_clock_jump_in_the_dvl_alone_is_named(sim, tmp_path):
    m, said = _load(tmp_path, _jump(tmp_path, sim, ("dvl.csv",)))
    jump = [s for s in said if "dvl.csv: the DVL stamps jump by +3601.000 s between ping indexes 29 and 30" in s
            and "+1 h to within a minute" in s]
    assert jump and "outside the IMU span" in jump[0]
    assert any("stamps jump" in n for n in m.meta["streams"]["dvl"]["notes"])


def _declare_depth(path, positive):
    cfg = json.loads(path.read_text())
    cfg["csv_columns"]["depth"]["positive"] = positive
    path.write_text(json.dumps(cfg))
    return path


def test_a_depth_convention_is_declared_in_the_column_map_and_data_that_contradict_it_are_refused(sim, tmp_path):
    """The depth refusal asked 'a depth positive up?' while a column map had no key to say so. ``positive: up`` is
    read as declared (no warning, no turn from the data); a declared convention the vertical velocity contradicts
    is a DataError naming the key and the value that fits; the refusal of a depth above the surface names the key."""
    up = -sim.depth.depth
    m, said = _load(tmp_path, _declare_depth(_depth_case(tmp_path, sim, up), "up"))
    assert not [s for s in said if "turned positive down" in s]
    assert any("declared positive up: negated" in n for n in m.meta["streams"]["depth"]["notes"])
    np.testing.assert_allclose(m.depth.depth, sim.depth.depth, atol=1e-9)
    path = _declare_depth(_depth_case(tmp_path, sim, up, depth_range_m=[-30, 6000]), "down")
    with pytest.raises(DataError, match=r"depth\.csv, field 'depth': declared positive 'down' \(csv_columns\.depth\."
                                        r"positive\), but its changes are -1\.\d*x .*set it to 'up'"):
        load_mission(tmp_path, path)
    still = np.full(len(sim.depth.t), -3.0) + 0.01 * np.random.default_rng(0).standard_normal(len(sim.depth.t))
    with pytest.raises(DataError, match=r"above the sea surface.*csv_columns\.depth\.positive 'up'"):
        load_mission(tmp_path, _depth_case(tmp_path, sim, still))


def test_without_a_gt_an_axis_correction_says_x_was_taken_forward(sim, tmp_path):
    """Without a GT an IMU upside down and one pitched 180 deg (x aft) need signs a turn about z apart, which only a
    heading reference tells: the warning says x was taken forward, not that the axes are right for certain."""
    flip = np.array([1.0, -1.0, -1.0])
    m, said = _load(tmp_path, _csv(tmp_path, sim, f_b=sim.imu.f_b * flip, omega_b=sim.imu.omega_b * flip,
                                   frame="auto", gt=False))
    assert [s for s in said if "multiplied by them" in s and "x taken forward, an assumption" in s
            and "pitched 180 deg, x aft and z up, needs (-1, 1, -1)" in s], said


def test_the_dvl_noise_estimate_skips_second_differences_across_dropped_pings():
    """The floor's noise estimate took second differences across gaps, where the velocity has also changed: half the
    pings of a slowly turning DVL dropped read as several times the noise. Now only consecutive pings count."""
    from types import SimpleNamespace

    from graphnav.calibration.dvl_scale import velocity_change_rms
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 400.0, 1.0)
    v = np.column_stack([np.sin(t / 5.0), np.cos(t / 7.0), 0 * t]) + rng.normal(0, 0.01, (t.size, 3))
    keep = rng.random(t.size) < 0.5

    def noise(tt, vv):
        n = len(tt) // 10 * 10
        t_w = tt[:n].reshape(-1, 10)
        model = SimpleNamespace(t=t_w, v=vv[:n].reshape(-1, 10, 3), real=np.ones(t_w.shape, bool))
        return velocity_change_rms(model)[1]
    full, dropped = noise(t, v), noise(t[keep], v[keep])
    assert 0.005 < full < 0.02 and 0.5 < dropped / full < 1.5
