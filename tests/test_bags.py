"""ROS 2 bags: a simulated mission recorded with rosbags' own writer (MCAP and sqlite3, both DVL message
families) is read back through the CLI (`graphnav smooth` / `online`), the estimates come out as an
Odometry bag, and bad bags fail with errors that name the topic."""
from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest

from graphnav import cli
from graphnav.core.errors import ConfigError, DataError
from graphnav.evaluation.methods import run_method
from graphnav.evaluation.metrics import vrmse
from graphnav.io import bags
from graphnav.missions import load_mission
from graphnav.sim.simulate import simulate_mission

T0_NS = 1_700_000_000_123_456_789


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    root = tmp_path_factory.mktemp("bags")
    mission = simulate_mission(duration_s=40.0, seed=3, dvl_stamp_offset_s=0.37)
    config = root / "config.json"
    mission.config.save(config)
    paths = {
        "mcap": bags.write_mission_bag(mission, root / "run_mcap", storage="mcap", t0_unix_ns=T0_NS),
        "sqlite3_wl": bags.write_mission_bag(mission, root / "run_wl", storage="sqlite3",
                                             dvl_type=bags.WL_DVL, t0_unix_ns=T0_NS, depth_as_pressure=False),
    }
    return mission, config, paths, root


def test_roundtrip_streams_match_the_mission(sim):
    mission, config, paths, _ = sim
    for key, folder in paths.items():
        for path in (folder, folder / f"{folder.name}{'.mcap' if key == 'mcap' else '.db3'}"):
            m = load_mission(path, config)
            assert m.meta["t0_unix_ns"] == T0_NS
            np.testing.assert_allclose(m.imu.t, mission.imu.t - mission.imu.t[0], atol=2e-9)
            np.testing.assert_allclose(m.imu.f_b, mission.imu.f_b, atol=1e-12)   # FLU in the bag, FRD back
            np.testing.assert_allclose(m.imu.omega_b, mission.imu.omega_b, atol=1e-12)
            np.testing.assert_array_equal(m.dvl.valid, mission.dvl.valid)
            np.testing.assert_allclose(m.dvl.beams[m.dvl.valid], mission.dvl.beams[mission.dvl.valid], atol=1e-6)
            np.testing.assert_allclose(m.dvl.t, mission.dvl.t, atol=2e-9)
            np.testing.assert_allclose(m.depth.depth, mission.depth.depth, atol=1e-9)
            np.testing.assert_allclose(m.gt.p_n, mission.gt.p_n, atol=1e-9)   # ENU odometry back to NED
            np.testing.assert_allclose(m.gt.v_n, mission.gt.v_n, atol=1e-9)
            np.testing.assert_allclose(m.gt.C_b_n, mission.gt.C_b_n, atol=1e-9)
    m = load_mission(paths["mcap"], config)
    assert m.meta["dvl_message"] == bags.MARINE_DVL
    # The marine_acoustic_msgs message carries the beam geometry; it agrees with the configuration.
    np.testing.assert_allclose(m.config.dvl.theta_rad, mission.config.dvl.theta_rad, atol=1e-6)
    np.testing.assert_allclose(np.cos(m.config.dvl.psi_rad), np.cos(mission.config.dvl.psi_rad), atol=1e-6)


def test_smooth_reads_the_bag_and_writes_an_odometry_bag(sim, tmp_path, capsys):
    mission, config, paths, _ = sim
    bag = paths["mcap"] / "run_mcap.mcap"
    out = tmp_path / "out"
    assert cli.main(["smooth", "--data", str(bag), "--config", str(config), "--method", "Graph-TC",
                     "--out", str(out), "--no-plots", "--bag", "mcap"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    # Same estimate as on the mission itself (the bag loses nothing the estimator uses).
    direct = run_method(mission, "Graph-TC", "none")
    assert summary["accuracy"]["vrmse_mission_mps"] == pytest.approx(vrmse(direct, mission.gt), rel=1e-3)
    assert summary["accuracy"]["vrmse_mission_mps"] < 0.1     # 40 s incl. the initial convergence
    # The Odometry bag: absolute stamps, REP-103 frames, velocity covariance; read back as a reference.
    from graphnav.io.outputs import read_trajectory_csv
    sol = read_trajectory_csv(out / "trajectory.csv")
    ref = bags.load_odometry(out / "trajectory_bag")
    assert ref.t[0] == pytest.approx((T0_NS / 1e9) + sol.t[0], abs=1e-6)
    np.testing.assert_allclose(ref.p_n, sol.p_n, atol=1e-6)
    np.testing.assert_allclose(ref.v_n, sol.v_n, atol=1e-6)
    np.testing.assert_allclose(np.sqrt(np.diagonal(ref.cov_v_n, axis1=1, axis2=2)),
                               np.sqrt(np.diagonal(sol.cov_v_n, axis1=1, axis2=2)), rtol=1e-4, atol=1e-9)


def test_online_reads_the_sqlite_bag_with_water_linked_dvl(sim, tmp_path):
    _, config, paths, _ = sim
    out = tmp_path / "online"
    assert cli.main(["online", "--data", str(paths["sqlite3_wl"]), "--config", str(config), "--method", "Graph-TC",
                     "--out", str(out), "--no-plots", "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["accuracy"]["vrmse_mission_mps"] < 0.1


def _bag_with(tmp_path, name, rows, store=None):
    """A bag with the given (topic, msgtype, t_ns, message) rows, written in that order."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    store = store or bags.typestore()
    path = tmp_path / name
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for topic, typ, t_ns, msg in rows:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, typ, typestore=store)
            w.write(conns[topic], t_ns, store.serialize_cdr(msg, typ))
    return path


def _imu_msg(store, t_ns):
    T = store.types
    V3 = T["geometry_msgs/msg/Vector3"]
    return T["sensor_msgs/msg/Imu"](
        header=bags._header(store, t_ns, "imu"), orientation=T["geometry_msgs/msg/Quaternion"](x=0., y=0., z=0., w=1.),
        orientation_covariance=np.zeros(9), angular_velocity=V3(x=0., y=0., z=0.),
        angular_velocity_covariance=np.zeros(9), linear_acceleration=V3(x=0., y=0., z=9.8),
        linear_acceleration_covariance=np.zeros(9))


def test_bad_bags_name_the_topic(sim, tmp_path):
    _, config, paths, root = sim
    store = bags.typestore()
    # Missing DVL topic.
    only_imu = _bag_with(tmp_path, "only_imu", [("/imu", "sensor_msgs/msg/Imu", k * 10_000_000, _imu_msg(store, k * 10_000_000))
                                                for k in range(1, 5)])
    with pytest.raises(DataError, match="no dvl topic"):
        load_mission(only_imu, config)
    # Unsorted header stamps on /imu.
    stamps = [10, 20, 15, 30]
    unsorted = _bag_with(tmp_path, "unsorted", [("/imu", "sensor_msgs/msg/Imu", k * 1_000_000, _imu_msg(store, s * 1_000_000))
                                                for k, s in enumerate(stamps, 1)])
    with pytest.warns(RuntimeWarning, match=r"unsorted:/imu: stamps: header stamps 1 non-monotonic \(first at "
                      r"message 2\); the bag's receive time is used"):
        imu = bags.read_streams(unsorted, {"imu": "/imu"}, wanted=("imu",), required=("imu",))["imu"][0]
    assert imu.stamp_kind == "receive" and imu.t_ns.tolist() == [1_000_000, 2_000_000, 3_000_000, 4_000_000]
    # A topic override naming a topic of the wrong type, and one that is absent.
    with pytest.raises(DataError, match="/imu/data has type sensor_msgs/msg/Imu"):
        load_mission(paths["mcap"], config, topics={"dvl": "/imu/data"})
    with pytest.raises(DataError, match="topic /nope"):
        load_mission(paths["mcap"], config, topics={"imu": "/nope"})
    # An unknown DVL type is not taken for a DVL: the error lists what the bag has.
    T = store.types
    odd = _bag_with(tmp_path, "odd", [("/imu", "sensor_msgs/msg/Imu", 1, _imu_msg(store, 1)),
                                      ("/dvl/twist", "geometry_msgs/msg/TwistStamped", 2, T["geometry_msgs/msg/TwistStamped"](
                                          header=bags._header(store, 2, "dvl"), twist=T["geometry_msgs/msg/Twist"](
                                              linear=T["geometry_msgs/msg/Vector3"](x=1., y=0., z=0.),
                                              angular=T["geometry_msgs/msg/Vector3"](x=0., y=0., z=0.))))])
    with pytest.raises(DataError, match=r"no dvl topic.*/dvl/twist \(geometry_msgs/msg/TwistStamped\)") as err:
        load_mission(odd, config)
    assert "or republish it as geometry_msgs/msg/TwistWithCovarianceStamped" in str(err.value)   # a way forward
    # first: name its fields in the configuration, the velocity found in the message's own definition
    assert '"bag_topics": {"dvl": {"topic": "/dvl/twist", "v_b": "twist.linear", "frame": "instrument"' \
        in str(err.value)
    assert "read with a csv_columns map" in str(err.value)
    # Through the CLI: exit code 1 and the topic in the message.
    assert cli.main(["smooth", "--data", str(odd), "--config", str(config), "--topic", "dvl=/dvl/twist",
                     "--out", str(tmp_path / "x"), "--no-plots"]) == 1
    with pytest.raises(ConfigError, match="STREAM=TOPIC"):
        bags.parse_topics(["dvl:/dvl"])


def test_a_gyro_57_times_too_small_is_refused_naming_the_topic(sim, tmp_path):
    import dataclasses
    mission, config, _, _ = sim
    imu = dataclasses.replace(mission.imu, omega_b=np.radians(mission.imu.omega_b))    # converted twice
    path = bags.write_mission_bag(dataclasses.replace(mission, imu=imu), tmp_path / "small_gyro")
    with pytest.raises(DataError, match=r"small_gyro:/imu/data, field 'omega_b': gyro rates too small for rad/s"):
        load_mission(path, config)


def test_bench_finds_a_folder_of_bags(sim, tmp_path):
    from graphnav.evaluation.bench import find_trajectories
    _, config, paths, root = sim
    found = find_trajectories(str(root), config_path=str(config))
    assert [s.name for s in found] == ["run_mcap", "run_wl"]
    assert [s.name for s in find_trajectories(str(paths["mcap"] / "run_mcap.mcap"))] == ["run_mcap"]


# --- bags as real drivers record them -----------------------------------------------------------------------
from graphnav.io import bag_driver, bag_msgs  # noqa: E402
from graphnav.io.bag_stamps import HEADER_CLOCK_STALL  # noqa: E402


@pytest.fixture(scope="module")
def driver(tmp_path_factory):
    root = tmp_path_factory.mktemp("driver")
    mission = simulate_mission(duration_s=40.0, seed=5)
    return mission, root


def _load(path, config, **kw):
    """The mission and every warning its loading gave (``config`` a SensorConfig, or a path/None through
    load_mission), read and prepared."""
    import warnings

    from graphnav.calibration.preparation import prepare
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = prepare(bags.load_bag(path, config, **kw)) if hasattr(config, "dvl") else load_mission(path, config, **kw)
    return m, [str(w.message) for w in caught]


def test_driver_bag_loads_and_reports_each_repair(driver):
    """MCAP with embedded definitions, zero IMU stamps, repeated DVL stamps, a leak sensor and a housing sensor
    beside the water pressure, an AHRS: every repair is warned about and recorded."""
    mission, root = driver
    path = bag_driver.write_driver_bag(mission, root / "drv", atmospheric_pressure_pa=100_800.0)
    m, warned = _load(path, mission.config)
    streams = m.meta["streams"]
    # IMU: header stamps all zero -> receive time (the mission clock, exactly)
    assert any("/imu/data: stamps: all header stamps are zero; the bag's receive time is used" in w for w in warned)
    assert m.meta["clock"]["stamps"] == {"imu": "receive", "dvl": "header", "depth": "header", "heading": "receive"}
    assert abs(m.meta["clock"]["header_minus_receive_s"]["depth"]) < 1e-9
    np.testing.assert_allclose(m.imu.t, mission.imu.t, atol=2e-9)
    np.testing.assert_allclose(m.imu.omega_b, mission.imu.omega_b, atol=1e-12)
    assert streams["imu"]["read"] == streams["imu"]["used"] == len(mission.imu.t)
    # DVL: 3 header stamps repeating the one before (the driver's clock stalled) -> those pings alone stamped from
    # their receive time less the latency of the pings around them (0.05 s); the others keep theirs; no ping lost
    assert "the header clock stalls: 3 message(s) repeat the stamp before them" in streams["dvl"]["notes"][0]
    assert streams["dvl"]["doubted"] == {HEADER_CLOCK_STALL: 3}
    np.testing.assert_allclose(m.dvl.t, mission.dvl.t, atol=2e-9)
    np.testing.assert_array_equal(m.dvl.valid, mission.dvl.valid)
    assert streams["dvl"]["read"] == len(mission.dvl.t)
    # the A50's own velocity, valid with >= 3 beams, its covariance as sigma
    ok = mission.dvl.valid.sum(axis=1) >= 3
    np.testing.assert_array_equal(m.dvl.v_d_valid, ok)
    from graphnav.core.dvl import beam_matrix
    A = beam_matrix(mission.config.dvl.theta_rad, mission.config.dvl.psi_rad)
    k = int(np.flatnonzero(ok & (mission.dvl.valid.sum(axis=1) == 4))[0])
    np.testing.assert_allclose(m.dvl.v_d[k], np.linalg.lstsq(A, mission.dvl.beams[k], rcond=None)[0], atol=1e-9)
    np.testing.assert_allclose(m.dvl.v_d_sigma[ok], 0.01)
    # depth: the water pressure, not the leak sensor's zeros nor the housing's flat atmosphere; surface
    # pressure estimated from the 5 s at the surface (100.8 kPa, not the configured 101.325 kPa)
    choice = m.meta["depth_choice"]
    assert choice["chosen"] == "/pressure"
    assert "all zeros" in choice["candidates"]["/leak/pressure"]
    assert "does not vary" in choice["candidates"]["/housing/pressure"]
    assert any("depth from /pressure" in w and "/leak/pressure" in w for w in warned)
    assert "estimated at the surface" in streams["depth"]["notes"][0] and "100800 Pa" in streams["depth"]["notes"][0]
    inside = m.depth.t >= 0
    np.testing.assert_allclose(m.depth.depth[inside], mission.depth.depth, atol=1e-6)
    np.testing.assert_allclose(m.depth.depth[~inside], 0.0, atol=1e-6)
    # heading: the AHRS orientation (REP-103 FLU/ENU in the bag) is the GT heading, roll and pitch
    assert m.meta["heading_source"] == "/imu/data (sensor_msgs/msg/Imu)"
    from scipy.spatial.transform import Rotation
    zyx = Rotation.from_matrix(mission.gt.at(m.heading.t)[2]).as_euler("ZYX")
    np.testing.assert_allclose(np.angle(np.exp(1j * (m.heading.yaw - zyx[:, 0]))), 0.0, atol=1e-9)
    np.testing.assert_allclose(m.heading.pitch, zyx[:, 1], atol=1e-9)
    np.testing.assert_allclose(m.heading.roll, zyx[:, 2], atol=1e-9)
    np.testing.assert_allclose(m.heading.sigma, np.radians(2.0))
    assert not any("no heading source" in w for w in warned)


def test_heading_reaches_the_navigator_and_the_aligner(driver):
    """The replay feeds Mission.heading to add_heading: the aligner takes its heading from it."""
    from graphnav.estimators.align import align_mission
    from graphnav.estimators.replay import replay
    mission, root = driver
    m, _ = _load(root / "drv", mission.config) if (root / "drv").exists() else _load(
        bag_driver.write_driver_bag(mission, root / "drv"), mission.config)
    kinds = {kind for kind, _, _ in replay(m)}
    assert kinds == {"imu", "dvl", "depth", "heading"}
    al = align_mission(m)
    assert al.heading_source == "heading"


def test_dvl_clock_days_away_and_a_gyro_in_deg_s_are_repaired(driver):
    """Header stamps of a DVL clock 6 days behind and a gyro in deg/s: the gyro converted to rad/s, the DVL put
    on the IMU clock through the receive clock, each repair warned about and recorded."""
    mission, root = driver
    six_days = -6 * 86400.0
    path = bag_driver.write_driver_bag(mission, root / "offset", duplicate_dvl_stamps=0, dvl_clock_offset_s=six_days,
                                       leak_sensor=False, housing_sensor=False, gyro_deg=True)
    m, warned = _load(path, mission.config)
    np.testing.assert_allclose(m.imu.omega_b, mission.imu.omega_b, atol=1e-9)
    assert any("gyro read as deg/s" in n for n in m.meta["streams"]["imu"]["notes"])
    assert len(m.dvl.t) == len(mission.dvl.t)
    # on the IMU clock up to the recorder's 0.05 s latency (left to the fine DVL time-offset calibration)
    np.testing.assert_allclose(m.dvl.t, mission.dvl.t + 0.05, atol=1e-6)
    clock = m.meta["clock"]
    assert clock["stamps"]["dvl"] == "header" and clock["dvl_imu_overlap_s"] == 0.0
    assert clock["dvl_minus_imu_start_s"] == pytest.approx(six_days, abs=1e-6)
    assert clock["header_minus_receive_s"]["dvl"] == pytest.approx(six_days - 0.05, abs=1e-6)
    assert m.meta["clock_offsets"]["dvl_from_receive_clock_s"] == pytest.approx(-(six_days - 0.05), abs=1e-6)
    assert any("do not overlap the IMU's" in w and "6.00 days" in w for w in warned)
    assert any("onto the IMU clock through the bag's receive clock" in w for w in warned)
    assert m.meta["streams"]["dvl"]["refused"].get("outside the IMU time span", 0) <= 1


def test_driver_bag_end_to_end_through_smooth_and_info(tmp_path, capsys):
    """A bag as a real vehicle's drivers write it (zero IMU stamps, DVL clock 6 days away, embedded definitions,
    leak and housing pressure topics, gyro in deg/s, an AHRS) runs through ``graphnav smooth`` and
    ``graphnav info``, and navigates as well as the same mission loaded clean."""
    import json

    from graphnav import cli
    from graphnav.io.outputs import read_trajectory_csv
    mission = simulate_mission(duration_s=120.0, seed=3)
    path = bag_driver.write_driver_bag(mission, tmp_path / "drv.mcap", duplicate_dvl_stamps=0, gyro_deg=True,
                                       dvl_clock_offset_s=-6 * 86400.0)
    assert cli.main(["info", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["usable"] and d["streams"]["dvl"]["used"] >= len(mission.dvl.t) - 1
    assert cli.main(["smooth", "--data", str(path), "--out", str(tmp_path / "out"), "--no-plots",
                     "--method", "Graph-TC"]) == 0
    sol = read_trajectory_csv(tmp_path / "out" / "trajectory.csv")
    # the bag's clock starts at the first IMU stamp, the simulation's at 0: the same instants
    t_truth = sol.t - sol.t[0] + mission.imu.t[0]
    inside = (t_truth > 30.0) & (t_truth < mission.t1)          # after the alignment from the sensors
    _, v_true, _ = mission.gt.at(t_truth[inside])
    err = float(np.sqrt(np.mean(np.sum((sol.v_n[inside] - v_true) ** 2, axis=1))))
    print(f"velocity RMSE from the repaired driver bag: {err:.4f} m/s")
    assert err < 0.1, f"velocity RMSE {err:.3f} m/s from the repaired bag"


@pytest.mark.parametrize("definition, name", [(bag_msgs.DVL_MSGS_DVL_A50, "A50"), (bag_msgs.DVL_MSGS_DVL_V3, "v3")])
def test_sqlite_bag_without_definitions_fits_the_released_message(driver, definition, name):
    """rosbag2 before Iron embeds no definitions: the dvl_msgs variant that decodes the bytes exactly is used."""
    mission, root = driver
    path = bag_driver.write_driver_bag(mission, root / f"nodefs_{name}", storage="sqlite3", dvl_definition=definition,
                                       embed_definitions=False, leak_sensor=False, housing_sensor=False)
    db3 = next(path.glob("*.db3"))
    m, _ = _load(db3, mission.config)
    assert name in m.meta["dvl_definition"] and "embeds none" in m.meta["dvl_definition"]
    np.testing.assert_array_equal(m.dvl.valid, mission.dvl.valid)
    np.testing.assert_allclose(m.dvl.beams[m.dvl.valid], mission.dvl.beams[mission.dvl.valid], atol=1e-12)
    assert (m.dvl.v_d_sigma is not None) == (name == "v3")
    # the other definition cannot decode these bytes
    other = bag_msgs.DVL_MSGS_DVL_V3 if name == "A50" else bag_msgs.DVL_MSGS_DVL_A50
    from rosbags.rosbag2 import Reader
    with Reader(db3) as reader:
        raw = next(r for c, _, r in reader.messages() if c.msgtype == bags.WL_DVL)
    with pytest.raises(Exception):
        bag_msgs.typestore(other).deserialize_cdr(raw, bags.WL_DVL)


def test_embedded_definition_wins_over_the_built_in(driver):
    """An MCAP written with the first-release A50 message (not graphnav's built-in v3) reads with its own."""
    mission, root = driver
    path = bag_driver.write_driver_bag(mission, root / "a50", dvl_definition=bag_msgs.DVL_MSGS_DVL_A50,
                                       leak_sensor=False, housing_sensor=False)
    m, _ = _load(path, mission.config)
    assert m.meta["dvl_definition"] == "embedded in the bag"
    np.testing.assert_array_equal(m.dvl.valid, mission.dvl.valid)
    assert m.dvl.v_d_sigma is None and m.dvl.v_d_valid.any()
    # the MCAP file under another name is still an MCAP bag (its magic bytes)
    import shutil
    renamed = shutil.copy(next(path.glob("*.mcap")), root / "a50_copy.dat")
    assert bag_msgs.bag_kind(renamed) == "mcap"
    m2, _ = _load(renamed, mission.config)
    np.testing.assert_array_equal(m2.dvl.valid, mission.dvl.valid)


def _ros1_bag(mission, path, store):
    """A ROS 1 bag (IMU with filled header stamps, Water Linked's ROS 1 DVL message, pressure)."""
    from rosbags.rosbag1 import Writer
    T = store.types
    V3 = T["geometry_msgs/msg/Vector3"]
    t0 = 1_600_000_000_000_000_000
    msgs = []

    def hdr(ns, k, frame_id):
        return T["std_msgs/msg/Header"](seq=k, frame_id=frame_id,
                                        stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9))
    for k, t in enumerate(mission.imu.t):
        ns = t0 + round(t * 1e9)
        f, w = mission.imu.f_b[k] @ bags.FLU_FRD, mission.imu.omega_b[k] @ bags.FLU_FRD
        msgs.append((ns, "/imu", "sensor_msgs/msg/Imu", T["sensor_msgs/msg/Imu"](
            header=hdr(ns, k, "imu"), orientation=T["geometry_msgs/msg/Quaternion"](x=0., y=0., z=0., w=1.),
            orientation_covariance=np.array([-1.0] + [0.0] * 8),
            angular_velocity=V3(x=w[0], y=w[1], z=w[2]), angular_velocity_covariance=np.zeros(9),
            linear_acceleration=V3(x=f[0], y=f[1], z=f[2]), linear_acceleration_covariance=np.zeros(9))))
    for k, t in enumerate(mission.dvl.t):
        ns = t0 + round(t * 1e9)
        ok = mission.dvl.valid[k]
        beams = [T[bags.WL_BEAM](id=j, velocity=float(mission.dvl.beams[k, j]) if ok[j] else 0.0, distance=1.0,
                                 rssi=0.0, nsd=0.0, valid=bool(ok[j])) for j in range(4)]
        msgs.append((ns, "/dvl/data", bags.WL_DVL, T[bags.WL_DVL](
            header=hdr(ns, k, "dvl"),
            time=0.0, velocity=V3(x=0., y=0., z=0.), fom=0.0, altitude=1.0, beams=beams, velocity_valid=False, status=0,
            form="json_v2")))
    msgs.sort(key=lambda m: m[0])
    with Writer(path) as writer:
        conns = {}
        for ns, topic, typ, msg in msgs:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, typ, typestore=store)
            writer.write(conns[topic], ns, store.serialize_ros1(msg, typ))
    return path


def test_ros1_bag_is_read_by_content(driver, tmp_path):
    """A ROS 1 bag, named .log: recognised by its '#ROSBAG V2.0' magic, read with its embedded definitions."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    mission, _ = driver
    store = get_typestore(Stores.ROS1_NOETIC)
    types = get_types_from_msg(bag_msgs.DVL_MSGS_DVLBEAM, bags.WL_BEAM)
    types.update(get_types_from_msg(bag_msgs.DVL_MSGS_DVL_A50.replace("std_msgs/Header", "Header"), bags.WL_DVL))
    store.register(types)
    bag = _ros1_bag(mission, tmp_path / "run.bag", store)
    renamed = bag.rename(tmp_path / "run.log")
    assert bags.is_bag(renamed) and bag_msgs.bag_kind(renamed) == "ros1"
    m, warned = _load(renamed, None)         # through load_mission: routed by content
    assert m.meta["format"] == "ros1" and m.meta["clock"]["stamps"] == {"imu": "header", "dvl": "header"}
    from graphnav.io.inspect import describe_mission      # graphnav info names its topics as a ROS 2 bag's
    assert describe_mission(m)["instrument"]["dvl_message"] == bags.WL_DVL
    np.testing.assert_allclose(m.imu.f_b, mission.imu.f_b, atol=1e-12)
    np.testing.assert_array_equal(m.dvl.valid, mission.dvl.valid)
    np.testing.assert_allclose(m.dvl.t, mission.dvl.t, atol=2e-9)
    # no heading source: said up front, naming what to add
    assert any("no heading source in the bag" in w and "--topic heading=TOPIC" in w for w in warned)
    assert m.meta["heading_source"] == "none" and m.heading is None
    # not a bag: a clear error
    junk = tmp_path / "junk.bag"
    junk.write_text("hello")
    assert not bags.is_bag(junk)
    with pytest.raises(DataError, match="not a ROS bag"):
        bags.read_streams(junk)


def test_velocity_only_dvl_heading_topics_and_depth_range(driver, tmp_path):
    """A TwistWithCovarianceStamped DVL (DVL frame) into v_d with its sigma and validity; a compass heading in
    degrees and a pose orientation as heading sources; depth samples above the surface or deeper than the ocean
    dropped and counted."""
    mission, _ = driver
    store = bags.typestore()
    T = store.types
    V3, t0 = T["geometry_msgs/msg/Vector3"], 1_650_000_000_000_000_000
    H = bags._header
    from scipy.spatial.transform import Rotation
    rows = [("/imu", "sensor_msgs/msg/Imu", t0 + round(t * 1e9), _imu_msg(store, t0 + round(t * 1e9)))
            for t in mission.imu.t[::10]]
    A = bag_driver.beam_matrix(mission.config.dvl.theta_rad, mission.config.dvl.psi_rad)
    v_true = np.array([np.linalg.lstsq(A, b, rcond=None)[0] for b in np.nan_to_num(mission.dvl.beams)])
    invalid = {3, 7}
    for k, t in enumerate(mission.dvl.t):
        ns = t0 + round(t * 1e9)
        cov = np.zeros((6, 6))
        cov[:3, :3] = np.diag([0.02 ** 2, 0.03 ** 2, 0.01 ** 2])
        cov[0, 0] = -1.0 if k in invalid else cov[0, 0]
        rows.append(("/dvl/twist", bags.TWIST_DVL, ns, T[bags.TWIST_DVL](
            header=H(store, ns, "dvl_link"), twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=V3(x=v_true[k, 0], y=v_true[k, 1], z=v_true[k, 2]),
                                                   angular=V3(x=0., y=0., z=0.)), covariance=cov.reshape(36)))))
    C = mission.gt.at(mission.gt.t)[2]
    yaw = Rotation.from_matrix(C).as_euler("ZYX")[:, 0]
    q_enu = Rotation.from_matrix(np.einsum("ij,kjl,lm->kim", bags.ENU_NED, C, bags.FLU_FRD)).as_quat()
    for k, t in enumerate(mission.gt.t):
        ns = t0 + round(t * 1e9) + 1
        compass = T["std_msgs/msg/Float64"](data=float(np.degrees(yaw[k]) % 360))
        rows.append(("/compass/heading", "std_msgs/msg/Float64", ns, compass))
        pose = T["geometry_msgs/msg/PoseWithCovariance"](pose=T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=0., y=0., z=0.),
            orientation=T["geometry_msgs/msg/Quaternion"](x=q_enu[k, 0], y=q_enu[k, 1], z=q_enu[k, 2], w=q_enu[k, 3])),
            covariance=np.diag([0, 0, 0, 0, 0, np.radians(1.5) ** 2]).reshape(36))
        rows.append(("/nav/pose", bags.POSE, ns, T[bags.POSE](header=H(store, ns, "map"), pose=pose)))
    cfg = mission.config
    d = mission.depth.depth.copy()
    d[[5, 9]] = [-5.0, 20000.0]
    for t, dk in zip(mission.depth.t, d):
        ns = t0 + round(t * 1e9) + 2
        rows.append(("/pressure", "sensor_msgs/msg/FluidPressure", ns, T["sensor_msgs/msg/FluidPressure"](
            header=H(store, ns, "p"), fluid_pressure=float(101325 + cfg.water_density_kgpm3 * cfg.gravity_mps2 * dk),
            variance=0.0)))
    rows.sort(key=lambda r: r[2])
    path = _bag_with(tmp_path, "twist", rows, store)
    m, warned = _load(path, cfg)
    # DVL: velocity only, in the DVL frame, covariance -> sigma, -1 -> invalid
    assert not m.dvl.valid.any() and m.dvl.v_b is None
    ok = np.ones(len(mission.dvl.t), bool)
    ok[list(invalid)] = False
    np.testing.assert_array_equal(m.dvl.v_d_valid, ok)
    np.testing.assert_allclose(m.dvl.v_d[ok], v_true[ok], atol=1e-12)
    np.testing.assert_allclose(m.dvl.v_d_sigma[ok], np.tile([0.02, 0.03, 0.01], (ok.sum(), 1)))
    assert m.meta["streams"]["dvl"]["refused"] == {"no valid beam and no valid velocity": 2}
    assert any("velocity-only" in n for n in m.meta["streams"]["dvl"]["notes"])
    assert any("no DVL message; the velocity-only /dvl/twist" in w for w in warned)
    # depth: two impossible samples dropped with their reasons
    assert m.meta["streams"]["depth"]["refused"] == {"above the surface by more than 1 m": 1, "deeper than 11000 m": 1}
    assert len(m.depth.t) == len(mission.depth.t) - 2
    # heading: the compass (degrees, clockwise from north) preferred to the pose, with a warning
    assert m.meta["heading_source"] == "/compass/heading (std_msgs/msg/Float64)"
    assert any("several heading sources" in w for w in warned)
    np.testing.assert_allclose(np.angle(np.exp(1j * (m.heading.yaw - yaw))), 0.0, atol=1e-9)
    assert "degrees" in m.meta["streams"]["heading"]["notes"][-1]
    # the pose's orientation when asked for, with its own yaw variance
    m2, _ = _load(path, cfg, topics={"heading": "/nav/pose"})
    np.testing.assert_allclose(np.angle(np.exp(1j * (m2.heading.yaw - yaw))), 0.0, atol=1e-9)
    np.testing.assert_allclose(m2.heading.sigma, np.radians(1.5))


def test_mems_imu_aligns_on_the_ahrs_of_the_bag(tmp_path):
    """A MEMS IMU cannot gyrocompass: with the bag's AHRS the Navigator aligns on its heading and navigates;
    without it the loader says so up front, naming the gyro's limit and what to add."""
    from graphnav.estimators.runs import run_graph
    mission = simulate_mission(duration_s=60.0, imu_grade="mems", seed=2)
    m, _ = _load(bag_driver.write_driver_bag(mission, tmp_path / "ahrs", dvl_latency_s=0.0), mission.config)
    sol = run_graph(m, init="sensors")
    assert sol.info["alignment"]["heading_source"] == "heading"
    assert vrmse(sol, mission.gt) < 0.15          # measured 0.065 m/s (0.056 over 120 s)
    _, warned = _load(bag_driver.write_driver_bag(mission, tmp_path / "none", ahrs=False), mission.config)
    assert any("no heading source" in w and "cannot do" in w and "add an AHRS/compass topic" in w for w in warned)


def test_dvl_log_of_a_bag(driver):
    """read_dvl_log: the DVL topic alone (Unix stamps, the instrument's velocity, beams, counts)."""
    mission, root = driver
    path = root / "drv" if (root / "drv").exists() else bag_driver.write_driver_bag(mission, root / "drv")
    log = bags.read_dvl_log(path)
    assert log.frame == "instrument" and log.instrument["message"] == bags.WL_DVL
    np.testing.assert_allclose(log.t, 1_700_000_000 + mission.dvl.t + 0.05, atol=1e-6)
    np.testing.assert_array_equal(log.beam_valid, mission.dvl.valid)
    assert log.counts["read"] == len(mission.dvl.t) and log.counts["valid"] == int(log.v_d_valid.sum())


def test_imu_messages_with_a_nan_are_refused_and_counted_not_the_whole_bag(tmp_path):
    """A driver bag with NaN or infinite values in 20 of its IMU messages: those messages are refused, warned about
    (topic, message index, time) and counted as a CSV row would be, and the rest navigates (the whole bag was
    refused, its error naming a 'line' of a bag)."""
    mission = simulate_mission(duration_s=40.0, seed=5)
    bad = np.arange(100, 2100, 100)
    mission.imu.f_b[bad, 0] = np.nan          # after the mission's own checks: what a driver may record
    mission.imu.omega_b[bad[::2], 2] = np.inf
    path = bag_driver.write_driver_bag(mission, tmp_path / "nans", leak_sensor=False, housing_sensor=False)
    m, warned = _load(path, mission.config)
    # under the reason a column map's row gets, naming the message's field (the first one not finite)
    assert m.meta["streams"]["imu"]["refused"] == {"empty or NaN in 'linear_acceleration.x'": bad.size}
    assert len(m.imu.t) == len(mission.imu.t) - bad.size and np.all(np.isfinite(m.imu.f_b))
    assert any("/imu/data: 20 imu sample(s) refused (20 empty or NaN in 'linear_acceleration.x') at message 100 "
               "(t = 1.000 s), message 200 (t = 2.000 s)" in w for w in warned)
    mission.imu.f_b[::2, 0] = np.nan           # more than half: an error naming the stream
    path = bag_driver.write_driver_bag(mission, tmp_path / "mostly", leak_sensor=False, housing_sensor=False)
    with pytest.raises(DataError, match=r"imu samples refused \(\d+ empty or NaN in 'linear_acceleration.x'\): "
                                        r"more than 50%"):
        _load(path, mission.config)



def test_all_zero_imu_messages_are_refused_as_a_loggers_filler_naming_topic_and_message(tmp_path):
    """A driver writing IMU messages of all zeros while its IMU delivered nothing (0.5 s of them and one alone): they
    were read as measurements of no acceleration and no turn (only the run dropped them, after the DVL clock search
    had used them). Now they are refused as the filler they are, warned about once with the topic, the first message
    and its time, counted under their own reason, and the gap they leave is the run's to bridge (their stamps are the
    IMU's clock still ticking, no samples lost: no stamp gap warned, as in a column map)."""
    mission = simulate_mission(duration_s=40.0, seed=5)
    rows = [700, *range(2000, 2050)]
    mission.imu.f_b[rows] = 0.0
    mission.imu.omega_b[rows] = 0.0
    path = bag_driver.write_driver_bag(mission, tmp_path / "filler", leak_sensor=False, housing_sensor=False)
    m, warned = _load(path, mission.config)
    filler = "all-zero IMU row (a logger's filler: zero specific force is impossible under gravity)"
    assert m.meta["streams"]["imu"]["refused"] == {filler: 51}
    assert len(m.imu.t) == len(mission.imu.t) - 51 and np.all(np.any(m.imu.f_b != 0.0, axis=1))
    said = [w for w in warned if "all-zero IMU" in w]
    assert len(said) == 1 and f"/imu/data: 51 imu sample(s) refused (51 {filler}) at message 700 (t = 7.000 s), " \
        "message 2000 (t = 20.000 s)" in said[0]
    assert not any("in the stamps" in w for w in warned) and "doubted" not in m.meta["streams"]["imu"]


#: The IMU message's six fields, the columns of the same IMU written as a column map.
IMU_FIELDS = ["linear_acceleration.x", "linear_acceleration.y", "linear_acceleration.z",
              "angular_velocity.x", "angular_velocity.y", "angular_velocity.z"]


def _as_column_map(mission, root):
    """``mission``'s IMU (FRD, the values as they are: NaN, inf and zeros written so) and DVL beams as a column map
    in ``root`` (Unix stamps, the IMU's columns named as the IMU message's fields); returns its configuration file."""
    root.mkdir(parents=True)
    for name, header, rows in (("imu", ["t", *IMU_FIELDS], [mission.imu.f_b, mission.imu.omega_b]),
                               ("dvl", ["t", "b1", "b2", "b3", "b4"], [mission.dvl.beams])):
        t = (mission.imu.t if name == "imu" else mission.dvl.t) + 1.7e9
        table = np.column_stack([t, *rows])
        (root / f"{name}.csv").write_text("\n".join([",".join(header)] + [",".join(
            "" if name == "dvl" and np.isnan(x) else f"{x:.12g}" for x in r) for r in table]) + "\n")
    cfg = mission.config.to_dict()
    cfg["csv_columns"] = {"imu": {"file": "imu.csv", "t": "t", "f_b": IMU_FIELDS[:3], "omega_b": IMU_FIELDS[3:]},
                          "dvl": {"file": "dvl.csv", "t": "t", "beams": ["b1", "b2", "b3", "b4"]}}
    (root / "config.json").write_text(json.dumps(cfg))
    return root / "config.json"


def _read_both(mission, tmp_path, kinds=("bag", "csv")):
    """``mission`` written as a driver bag and as a column map, each of ``kinds`` read (not prepared): ``{"bag":
    (mission, warnings), "csv": (mission, warnings)}``."""
    import warnings

    from graphnav.io.loaders import read_mission
    config = _as_column_map(mission, tmp_path / "csv")
    bag = bag_driver.write_driver_bag(mission, tmp_path / "bag", leak_sensor=False, housing_sensor=False)
    out = {}
    for kind, path in (("bag", bag), ("csv", tmp_path / "csv")):
        if kind not in kinds:
            continue
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            out[kind] = read_mission(path, config if kind == "csv" else None), [str(w.message) for w in caught]
    return out


def test_a_damaged_imu_is_refused_in_a_bag_as_in_a_column_map(tmp_path):
    """The same IMU with filler rows, a dead accelerometer beside a live gyro (alone and after filler), NaN and
    infinite values, written as a driver bag and as a column map: the bag refused NaN and filler by rules of its own,
    under reasons of its own ('not finite' for all 5 rows) in two warnings, and its 12 dead-accelerometer rows only
    later in a third. Now both go through the one screening: the same reasons and counts in one warning each, and
    the same rows kept."""
    mission = simulate_mission(duration_s=40.0, seed=5)
    f, w = mission.imu.f_b, mission.imu.omega_b
    f[[300, 1500, *range(2000, 2010)]], w[[300, 1500, *range(2000, 2010)]] = 0.0, 0.0
    f[[700, 2500, *range(2010, 2020)]] = 0.0
    f[900, 1], w[1100, 2], f[2600:2603, 2] = np.nan, np.inf, np.nan
    read = _read_both(mission, tmp_path)
    (bag, bag_warned), (csv, csv_warned) = read["bag"], read["csv"]
    refused = csv.meta["streams"]["imu"]["refused"]
    assert refused == {"all-zero IMU row (a logger's filler: zero specific force is impossible under gravity)": 12,
                       "accelerometer all zero beside a live gyro (a dead accelerometer: zero specific force is "
                       "impossible under gravity)": 12, "empty or NaN in 'linear_acceleration.y'": 1,
                       "empty or NaN in 'linear_acceleration.z'": 3, "infinite in 'angular_velocity.z'": 1}
    assert bag.meta["streams"]["imu"]["refused"] == refused

    def said(warned):      # the refusal of each, without the file and where it holds the rows
        return [re.sub(r"^.*?: (\d+ imu sample)", r"\1", re.sub(r"\) at .*", ")", w)) for w in warned
                if "imu sample(s) refused" in w]
    assert said(bag_warned) == said(csv_warned) and len(said(csv_warned)) == 1
    assert said(bag_warned)[0].startswith("29 imu sample(s) refused (12 all-zero IMU row")
    assert len(bag.imu.t) == len(csv.imu.t) == len(mission.imu.t) - 29
    np.testing.assert_allclose(bag.imu.t - bag.imu.t[0], csv.imu.t - csv.imu.t[0], atol=1e-6)
    np.testing.assert_allclose(bag.imu.f_b, csv.imu.f_b, rtol=1e-9)
    np.testing.assert_allclose(bag.imu.omega_b, csv.imu.omega_b, rtol=1e-9, atol=1e-15)


def test_a_bag_warns_no_stamp_gap_where_it_refused_messages_as_a_column_map(tmp_path):
    """0.2 s of a logger's filler, then 0.2 s of NaN beside a true gap of 0.3 s (30 messages not written): the bag
    warned 'a gap of 0.2 s in the stamps (20 periods ... 20 samples lost, or the clock stepped ...)' where it had
    refused messages whose stamps were all there, and counted it as doubted, which a column map of the same rows
    does not (its stamps are judged before any row is refused). Now the bag warns and counts the true gap only, as the
    column map does."""
    mission = simulate_mission(duration_s=40.0, seed=5)
    mission.imu.f_b[1000:1020], mission.imu.omega_b[1000:1020] = 0.0, 0.0
    mission.imu.f_b[2000:2020, 1] = np.nan
    keep = np.r_[0:2500, 2530:len(mission.imu.t)]           # 30 samples lost at 25 s: a true gap
    mission.imu = dataclasses.replace(mission.imu, t=mission.imu.t[keep], f_b=mission.imu.f_b[keep],
                                      omega_b=mission.imu.omega_b[keep])
    read = _read_both(mission, tmp_path)
    gap = "stamped after a gap in the IMU data (whole periods: samples lost, bridged)"
    for kind, (m, warned) in read.items():
        assert m.meta["streams"]["imu"]["doubted"] == {gap: 1}, kind
        said = [w for w in warned if "in the stamps" in w]
        assert len(said) == 1 and "a gap of 0.3 s in the stamps (30 periods" in said[0], (kind, said)
    assert "message 2500 (t = 25.300 s)" in read["bag"][1][[i for i, w in enumerate(read["bag"][1])
                                                             if "in the stamps" in w][0]]


def test_filler_then_a_dead_accelerometer_past_the_bridge_limit_stops_a_bag_as_a_column_map(tmp_path):
    """400 s of a logger's filler then 210 s of a dead accelerometer (a 10 Hz IMU): together a 610 s gap, which the
    column map refuses as the IMU stopping. The bag's own filler check left the dead rows out and saw 400 s, bridged;
    those rows then reached the unit check, which refused the bag for an accelerometer of median 0 ('not gravity in
    m/s^2'). Now the bag names the 610 s gap as the column map does."""
    from graphnav.core.config import SensorConfig
    config = SensorConfig()
    config.imu_rate_hz = 10.0
    mission = simulate_mission(duration_s=800.0, seed=5, config=config)
    mission.imu.f_b[1000:7100] = 0.0
    mission.imu.omega_b[1000:5000] = 0.0
    gap = (r"IMU gap left by 6100 {} without a measurement \(4000 all-zero: a logger's filler; 2100 of a "
           r"dead accelerometer: its three values 0 beside a live gyro\) of 610\.1 s after t = ")
    for kind, rows in (("csv", r"IMU row\(s\)"), ("bag", r"message\(s\) of /imu/data")):
        with pytest.raises(DataError, match=gap.format(rows)):
            _read_both(mission, tmp_path / kind, (kind,))


def test_a_bags_nan_run_past_the_bridge_limit_is_refused_naming_the_message_after_it(tmp_path):
    """700 s of IMU messages with a NaN (a 10 Hz IMU): the IMU stopping, as in a column map, whose error names the
    file line after the gap. The bag's named no message, only the time of the one before the gap (its warnings name
    messages); now it names the message after it and its time, as its warnings and its stamp errors do. The run was
    said to be '7000 IMU row(s)' (a bag has no rows): it is the topic's messages."""
    from graphnav.core.config import SensorConfig
    config = SensorConfig()
    config.imu_rate_hz = 10.0
    mission = simulate_mission(duration_s=1000.0, seed=5, config=config)
    mission.imu.f_b[2000:9000, 1] = np.nan
    path = bag_driver.write_driver_bag(mission, tmp_path / "bag", leak_sensor=False, housing_sensor=False)
    with pytest.raises(DataError, match=r"bag:/imu/data: message 9000 \(t = 900\.000 s\): IMU gap left by 7000 "
                                        r"message\(s\) of /imu/data without a measurement \(NaN or infinite values\) "
                                        r"of 700\.1 s after t = 199\.900 s"):
        _load(path, None)
    mission.imu.f_b[2000:9000], mission.imu.omega_b[2000:9000] = 0.0, 0.0
    path = bag_driver.write_driver_bag(mission, tmp_path / "filler", leak_sensor=False, housing_sensor=False)
    with pytest.raises(DataError, match=r"message 9000 \(t = 900\.000 s\): IMU gap left by 7000 all-zero message\(s\) "
                                        r"of /imu/data \(a logger's filler\) of 700\.1 s"):
        _load(path, None)


def test_an_imu_mostly_without_a_measurement_is_refused_saying_what_to_check_not_the_units(tmp_path):
    """An accelerometer dead (three zeros) on 55 % of the rows, then NaN on 55 %: refused as more than half of the
    IMU, saying 'check the units and the configuration's sensor ranges' (a bag's dead accelerometer used to be told
    'median |f_b| = 0: not gravity', naming the field), though zeros and NaN are so in any unit and range. Now the
    refusal, of a bag and of a column map, says to check the accelerometer, or the sensor and its logger (and a column
    map's columns)."""
    mission = simulate_mission(duration_s=20.0, seed=5)
    f = mission.imu.f_b.copy()
    mission.imu.f_b[:1100] = 0.0
    for kind in ("bag", "csv"):
        # named by the accelerometer's fields (they were 'imu', no field of a message or column of a file)
        with pytest.raises(DataError, match=r"field 'linear_acceleration.x, linear_acceleration.y, "
                                            r"linear_acceleration.z': "
                                            r"1100 of 2001 imu samples refused \(1100 accelerometer all zero .*more "
                                            r"than 50% of the stream; check the accelerometer: three values of "
                                            r"exactly 0 beside the gyro's are no measurement in any unit") as e:
            _read_both(mission, tmp_path / f"dead-{kind}", (kind,))
        assert "units" not in str(e.value).split("check ")[-1].replace("in any unit", "")
    mission.imu.f_b[:] = f
    mission.imu.f_b[:1100, 2] = np.nan
    for kind, column_map in (("bag", ""), ("csv", r", or the column map \(a column named that holds no numbers\)")):
        with pytest.raises(DataError, match=r"field 'linear_acceleration.z': 1100 of 2001 imu samples refused .*"
                                            r"check the sensor and its logger or driver: an empty, NaN or infinite "
                                            rf"value is no measurement in any unit{column_map}$"):
            _read_both(mission, tmp_path / f"nan-{kind}", (kind,))


def test_a_bag_and_a_column_map_look_for_imu_rows_without_a_measurement_once(tmp_path, monkeypatch):
    """The filler gap check (and the rest of the refusal of rows holding no measurement) ran twice on a bag's IMU
    and on a column map's: at read and again in the screening of the rows kept. It runs once now."""
    from graphnav.core import screening
    calls = []
    check = screening.check_filler_gaps
    monkeypatch.setattr(screening, "check_filler_gaps", lambda *a, **kw: calls.append(1) or check(*a, **kw))
    mission = simulate_mission(duration_s=20.0, seed=5)
    mission.imu.f_b[[300, 900]] = 0.0
    read = _read_both(mission, tmp_path)
    assert [m.meta["streams"]["imu"]["refused"][screening.ACCEL_ZERO] for m, _ in read.values()] == [2, 2]
    assert len(calls) == 2                 # once for the bag, once for the column map


def test_an_imu_clock_days_away_moves_every_stream_onto_it(tmp_path, capsys):
    """IMU header stamps 3 days ahead of the other streams' (which are stamped at receive time): the DVL, the
    depth and the GT are all moved onto the IMU clock through the receive clock, so ``info`` and the prepared
    mission agree and the mission navigates (the depth and GT stayed 3 days away: 'usable' in info, then every
    depth sample refused in smooth). A depth recorded days after the rest, which no clock relates, is one error
    naming both topics and both spans, in info as when read."""
    import dataclasses
    mission = simulate_mission(duration_s=40.0, seed=3)
    three_days = 3 * 86400.0
    path = bags.write_mission_bag(mission, tmp_path / "imu_days", imu_clock_offset_s=three_days)
    m, warned = _load(path, None)
    np.testing.assert_allclose(m.dvl.t, mission.dvl.t, atol=1e-6)
    np.testing.assert_allclose(m.depth.t, mission.depth.t, atol=1e-6)
    np.testing.assert_allclose(m.gt.t, mission.gt.t, atol=1e-6)
    for stream, label in (("dvl", "DVL"), ("depth", "depth"), ("gt", "GT")):
        assert m.meta["clock_offsets"][f"{stream}_from_receive_clock_s"] == pytest.approx(three_days, abs=1e-6)
        assert any(f"clock: {label} header stamps moved by +259200.000 s onto the IMU clock" in w for w in warned)
        assert m.meta["streams"][stream]["span_s"][0] == pytest.approx(0.0, abs=0.2)
    assert cli.main(["info", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["usable"] and d["time_span_s"][0] == pytest.approx(0.0, abs=0.2)
    from graphnav.estimators.replay import replay
    kinds = [kind for kind, _, _ in replay(m)]
    assert kinds.count("depth") == len(mission.depth.t)

    # a depth days after the rest, which no clock relates: optional, left out with a warning as a log's depth is
    # (it was an error refusing the whole bag, while a column map's was warned about)
    late = dataclasses.replace(mission, depth=dataclasses.replace(mission.depth, t=mission.depth.t + three_days))
    path = bags.write_mission_bag(late, tmp_path / "depth_days")
    m, warned = _load(path, None)
    assert m.depth is None and m.meta["streams"]["depth"]["usable"] is False
    assert any("field 'header.stamp': the depth stamps [259200.000, 259240.000] s lie off the IMU span [0.000, "
               "40.000] s" in w and "the depth is left out" in w for w in warned), warned
    assert cli.main(["info", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["usable"] and "depth" in d["left_out"] and d["time_span_s"][1] < 41.0


def test_dvl_messages_of_exactly_zero_under_way_are_no_bottom_lock(sim, tmp_path):
    """A bag whose DVL reports 0 on every beam for 10 pings between pings of a vehicle under way (a driver's
    no-lock ping): refused, counted and warned with the topic (the bag reader used them as a vehicle at rest)."""
    import dataclasses
    import warnings
    from graphnav.core.screening import NO_BOTTOM_LOCK
    mission, config, _, _ = sim
    beams = mission.dvl.beams.copy()
    valid = mission.dvl.valid.copy()
    beams[10:20], valid[10:20] = 0.0, True
    zeroed = dataclasses.replace(mission, dvl=dataclasses.replace(mission.dvl, beams=beams, valid=valid))
    path = bags.write_mission_bag(zeroed, tmp_path / "zero", storage="mcap", t0_unix_ns=T0_NS)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        m = load_mission(path, config)
    assert m.meta["streams"]["dvl"]["refused"] == {NO_BOTTOM_LOCK: 10}
    assert not m.dvl.valid[10:20].any()
    # named by the topic's message index and its time, not the ping's index in the arrays
    said = [str(w.message) for w in rec if NO_BOTTOM_LOCK in str(w.message)]
    assert said and "/dvl" in said[0]
    assert f"at message 10 (t = {mission.dvl.t[10]:.3f} s), message 11 (t = {mission.dvl.t[11]:.3f} s)," in said[0]


def test_a_depth_topic_positive_up_is_declared_in_the_configuration(sim, tmp_path):
    """A Float64 depth topic positive up lost every sample as 'above the surface' with no key to say so:
    ``bag_topics.depth.positive`` declares it as ``csv_columns.depth.positive`` declares a column (negated, noted);
    declared down, the refusal says which key; on a pressure topic the key is a ConfigError."""
    import dataclasses
    import warnings
    mission = sim[0]
    up = dataclasses.replace(mission, depth=dataclasses.replace(mission.depth, depth=-mission.depth.depth))
    path = bags.write_mission_bag(up, tmp_path / "up", storage="mcap", t0_unix_ns=T0_NS, depth_as_pressure=False)

    def config(positive):
        cfg = mission.config.to_dict()
        cfg["bag_topics"] = {"depth": {"positive": positive}}
        (tmp_path / f"{positive}.json").write_text(json.dumps(cfg))
        return tmp_path / f"{positive}.json"

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        m = load_mission(path, config("up"))
        np.testing.assert_allclose(m.depth.depth, np.interp(m.depth.t, mission.depth.t, mission.depth.depth),
                                   atol=1e-6)
        assert any("declared positive up (bag_topics.depth.positive): negated" in n
                   for n in m.meta["streams"]["depth"]["notes"])
        with pytest.warns(RuntimeWarning, match="a depth topic positive up\\? declare bag_topics.depth.positive 'up'"):
            with pytest.raises(DataError, match="401 of 401 depth samples refused"):
                load_mission(path, config("down"))
        # declared up on a topic positive down: the hint names the other convention, not the one declared
        down = bags.write_mission_bag(mission, tmp_path / "down", storage="mcap", t0_unix_ns=T0_NS,
                                      depth_as_pressure=False)
        with pytest.warns(RuntimeWarning, match="a depth topic positive down\\? declare bag_topics.depth.positive "
                                                "'down' \\(declared 'up'\\)"):
            with pytest.raises(DataError, match="depth samples refused"):
                load_mission(down, config("up"))
        with pytest.raises(ConfigError, match="bag_topics.depth.positive = 'sideways': choose down or up"):
            load_mission(path, config("sideways"))
        with pytest.raises(ConfigError, match="unknown key 'bag_topics.depth.positiv'; did you mean "
                                              "'bag_topics.depth.positive'"):
            cfg = mission.config.to_dict()
            cfg["bag_topics"] = {"depth": {"positiv": "up"}}
            (tmp_path / "typo.json").write_text(json.dumps(cfg))
            load_mission(path, tmp_path / "typo.json")
        with pytest.raises(ConfigError, match="bag_topics.depth.positive = 'up': the depth is read from the "
                                              "pressure topic /pressure"):
            load_mission(sim[2]["mcap"], config("up"))


def test_bad_dvl_and_depth_messages_are_named_by_topic_message_and_time(sim, tmp_path):
    """A flagged beam (RDI -32.768), a ping without a valid beam and a depth sample above the surface are warned
    about with the topic, the message's index in it and its time, not an index into the arrays."""
    import copy
    import dataclasses
    import warnings
    mission, config, _, _ = sim
    beams, valid = mission.dvl.beams.copy(), mission.dvl.valid.copy()
    beams[7, 1], valid[7, 1] = -32.768, True
    valid[12] = False
    depth = mission.depth.depth.copy()
    depth[5] = -5.0
    dvl = copy.copy(mission.dvl)           # a flag in the file: DvlData itself refuses one
    dvl.beams, dvl.valid = beams, valid
    bad = copy.copy(mission)
    bad.dvl, bad.depth = dvl, dataclasses.replace(mission.depth, depth=depth)
    path = bags.write_mission_bag(bad, tmp_path / "bad", storage="mcap", t0_unix_ns=T0_NS, depth_as_pressure=False)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        bags.load_bag(path, mission.config)
    said = [str(w.message) for w in rec]
    t_dvl, t_depth = mission.dvl.t - mission.imu.t[0], mission.depth.t - mission.imu.t[0]
    assert [s for s in said if "/dvl/data: 1 beam value(s)" in s and "not measurements" in s
            and f"first at message 7 (t = {t_dvl[7]:.3f} s)" in s]
    assert [s for s in said if "/dvl/data: 1 DVL ping(s) with no valid beam and no valid velocity" in s
            and f"first at message 12 (t = {t_dvl[12]:.3f} s)" in s]
    assert [s for s in said if "/depth: 1 depth sample(s) above the surface" in s
            and f"first at message 5 (t = {t_depth[5]:.3f} s)" in s]


def test_an_undeclared_depth_topic_positive_up_is_turned_with_a_warning_as_a_csv_column(sim, tmp_path):
    """A Float64 depth topic positive up, undeclared, was refused sample by sample as 'above the surface'; it is
    turned with a warning naming the topic and field, kept when the vertical motion confirms it (as a column map's
    depth is), refused naming the key when the motion contradicts it."""
    import dataclasses
    import warnings
    mission = simulate_mission(duration_s=60.0, seed=5)      # dives enough for the vertical motion to tell
    config = tmp_path / "config.json"
    mission.config.save(config)
    up = dataclasses.replace(mission, depth=dataclasses.replace(mission.depth, depth=-mission.depth.depth))
    path = bags.write_mission_bag(up, tmp_path / "up", storage="mcap", t0_unix_ns=T0_NS, depth_as_pressure=False)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        m = load_mission(path, config)
    np.testing.assert_allclose(m.depth.depth, np.interp(m.depth.t, mission.depth.t, mission.depth.depth), atol=1e-6)
    said = [str(w.message) for w in rec if "read as depth positive up and turned" in str(w.message)]
    n = len(mission.depth.t)
    assert len(said) == 1 and f"/depth, field 'data': {n} of {n} samples above the surface" in said[0]
    assert not m.meta["streams"]["depth"]["refused"]
    # not prepared, nothing has confirmed the turn: kept turned (as read, every sample is above the surface), warned
    with pytest.warns(RuntimeWarning, match=r"up:/depth, field 'data': read as depth positive up and turned "
                                            r"positive down, unconfirmed: the mission is not prepared"):
        m = load_mission(path, config, prepare=False)
    assert any("unconfirmed" in n for n in m.meta["streams"]["depth"]["notes"])
    # described without prepare (graphnav info's reader alone): the same warning and note, from the same function
    from graphnav.calibration.preparation import prepare
    from graphnav.io.inspect import describe
    desc = describe(path, config)
    assert [w for w in desc["warnings"] if "field 'data': read as depth positive up and turned positive down, "
            "unconfirmed: the mission is not prepared" in w]
    assert any("unconfirmed" in n for n in desc["streams"]["depth"]["notes"])
    assert not [w for w in describe(path, config, prepare=prepare)["warnings"] if "unconfirmed" in w]
    # positive down with its zero 40 m off: above the surface too, but turned it rises while the vehicle dives
    off = dataclasses.replace(mission, depth=dataclasses.replace(mission.depth, depth=mission.depth.depth - 40.0))
    path = bags.write_mission_bag(off, tmp_path / "off", storage="mcap", t0_unix_ns=T0_NS, depth_as_pressure=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(DataError, match="read as positive up .* and turned, but the vertical motion does not "
                                            "confirm it.*declare bag_topics.depth.positive"):
            load_mission(path, config)


def test_a_hovering_bag_whose_gyro_is_57_times_too_small_is_refused_by_its_reference_topic(tmp_path):
    """A hovering AUV's gyro 57.3x too small (rad/s data divided by 57.3) was read from a bag with only a note that
    its scale went unchecked: the tilt kinematics and the DVL cannot tell the scales apart. The reference topic's
    quaternion (no unit to settle) turns 57x as fast as the rates: refused, naming the bag, topics and fields."""
    import warnings

    from test_generic_csv import hovering_mission
    path = bags.write_mission_bag(hovering_mission(tmp_path, np.pi / 180), tmp_path / "hover_small")
    with pytest.raises(DataError, match=r"too small for rad/s: the reference attitude \(.*hover_small:/reference/"
                                        r"odometry, field pose.pose.orientation\) turns 5\d\.\dx as fast") as err:
        load_mission(path)
    assert err.value.source.endswith("hover_small:/imu/data") and err.value.field == "omega_b"
    path = bags.write_mission_bag(hovering_mission(tmp_path), tmp_path / "hover")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = load_mission(path)
    notes = " | ".join(m.meta["streams"]["imu"]["notes"])
    assert "gyro's scale judged against the reference attitude" in notes and "not judged" not in notes


def test_a_depth_spike_in_a_bag_is_named_by_topic_message_and_time(sim, tmp_path):
    """The screening's depth refusals named an index into the depth array; they name the message and its time."""
    import dataclasses
    import warnings
    mission, config, _, _ = sim
    depth = mission.depth.depth.copy()
    depth[30] += 30.0
    bad = dataclasses.replace(mission, depth=dataclasses.replace(mission.depth, depth=depth))
    path = bags.write_mission_bag(bad, tmp_path / "spike", storage="mcap", t0_unix_ns=T0_NS, depth_as_pressure=False)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        m = load_mission(path, config)
    t_depth = mission.depth.t - mission.imu.t[0]
    said = [str(w.message) for w in rec if "depth sample(s) refused" in str(w.message)]
    assert said and f"at message 30 (t = {t_depth[30]:.3f} s); they are not used" in said[0]
    assert m.meta["streams"]["depth"]["refused"] == {"depth spike": 1}


def test_a_step_of_the_imu_clock_or_a_gap_in_a_bag_is_warned_naming_the_message_and_counted(sim, tmp_path):
    """A bag's IMU header stamps stepping +5 ms half-way (no whole number of periods: the clock stepped) or +0.5 s
    (50 whole periods: a gap) loaded without a word, where a column-map log's are warned and counted: the same check
    now names the bag and topic, the message and its time, and the field, and counts the sample after the step as
    doubted; the clean bag says nothing."""
    import dataclasses
    import re
    import warnings
    from graphnav.core.screening import CLOCK_STEP, IMU_GAP
    mission, config, paths, _ = sim
    n = mission.imu.t.size
    said = {CLOCK_STEP: r"the IMU clock steps \+5 ms off its period \(\+0.5 periods: no whole number",
            IMU_GAP: r"a gap of 0.5 s in the stamps \(50 periods, a whole number: 50 samples lost"}
    for step, reason in ((0.005, CLOCK_STEP), (0.5, IMU_GAP), (0.0, None)):
        t = mission.imu.t + np.where(np.arange(n) >= n // 2, step, 0.0)
        path = (bags.write_mission_bag(dataclasses.replace(mission, imu=dataclasses.replace(mission.imu, t=t)),
                                       tmp_path / f"step{step:g}", t0_unix_ns=T0_NS) if step else paths["mcap"])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            m = load_mission(path, config, prepare=False)
        steps = [str(w.message) for w in caught if "off its period" in str(w.message) or "a gap of" in str(w.message)]
        if reason is None:
            assert not steps and "doubted" not in m.meta["streams"]["imu"]
            continue
        at = f"message {n // 2} (t = {t[n // 2] - t[0]:.3f} s)"
        assert len(steps) == 1 and re.search(said[reason], steps[0])
        assert steps[0].startswith(f"imu: {path}:/imu/data, {at}, field 'header.stamp': ")
        assert m.meta["streams"]["imu"]["doubted"] == {reason: 1}


def _with_compass(tmp_path, mission, offset_s: float):
    """A bag of ``mission`` plus a 1 Hz compass heading topic (Float64: receive time) received ``offset_s`` late."""
    from rosbags.rosbag2 import Reader
    from scipy.spatial.transform import Rotation
    store = bags.typestore()
    with Reader(bags.write_mission_bag(mission, tmp_path / f"src_{offset_s:g}")) as r:
        rows = [(c.topic, c.msgtype, t, store.deserialize_cdr(raw, c.msgtype)) for c, t, raw in r.messages()]
    yaw = Rotation.from_matrix(mission.gt.C_b_n).as_euler("ZYX")[:, 0]
    t0 = 1_700_000_000_000_000_000
    rows += [("/compass/heading", "std_msgs/msg/Float64", t0 + round((t + offset_s) * 1e9),
              store.types["std_msgs/msg/Float64"](data=float(np.degrees(y) % 360)))
             for t, y in zip(mission.gt.t[::10], yaw[::10])]
    return _bag_with(tmp_path, f"compass_{offset_s:g}", sorted(rows, key=lambda row: row[2]), store)


def test_a_heading_off_the_imu_span_is_left_out_and_said_not_usable(tmp_path, capsys):
    """A compass topic received 3 days after the rest, which no clock relates: optional as a depth is (the aligner
    gyrocompasses without it), so it is left out with a warning, counted, marked not usable and shown by info, and
    the bag navigates; the gyro's ability to gyrocompass is said. It was a DataError refusing the whole bag."""
    mission = simulate_mission(duration_s=40.0, seed=3)
    m, warned = _load(_with_compass(tmp_path, mission, 0.0), None)
    assert m.heading is not None and m.meta["heading_source"].startswith("/compass/heading")
    path = _with_compass(tmp_path, mission, 3 * 86400.0)
    m, warned = _load(path, None)
    assert m.heading is None and m.meta["heading_source"] == "none"
    entry = m.meta["streams"]["heading"]
    assert entry["usable"] is False and entry["refused"] == {"outside the IMU time span": 41}
    assert any("field 'receive time': the heading stamps [259200.000, 259240.000] s lie off the IMU span [0.000, "
               "40.000] s" in w and "the heading is left out; choose another heading topic" in w for w in warned)
    assert any("no heading source in the bag (its heading topic, off the IMU span, is left out)" in w
               and "the configured gyro allows" in w for w in warned)
    assert cli.main(["info", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["usable"] and "heading" in d["left_out"] and d["time_span_s"][1] < 41.0
    sol = run_method(m, "Graph-TC")
    assert vrmse(sol, mission.gt) < 0.2


@pytest.mark.parametrize("gt", [True, False])
def test_a_dvl_mounted_turned_configured_as_not_is_warned_and_its_pings_counted(tmp_path, capsys, gt):
    """A bag whose DVL is mounted 45 deg about z with dvl.C_d_b left the identity: its velocity, turned from the IMU's
    axes, is warned about naming the topic, advising the mounting (a bag has no column map to declare), and its pings
    counted as read despite the doubt (`graphnav info` shows them), with a reference odometry in the bag and
    without."""
    import dataclasses
    import warnings
    from graphnav.calibration.dvl_scale import TURNED_DOUBT, turn_about_z
    from graphnav.core.config import SensorConfig
    cfg = SensorConfig()
    # 300 s with 5 mm/s beams: the velocity's changes fit the IMU well enough (r^2 0.97) to judge its turn
    cfg.dvl = dataclasses.replace(cfg.dvl, beam_noise_std=0.005, C_d_b=turn_about_z(45))
    mission = simulate_mission(300.0, seed=1, config=cfg)
    path = bags.write_mission_bag(mission, tmp_path / "turned", storage="mcap", t0_unix_ns=T0_NS, gt=gt)
    config = mission.config.to_dict()
    config["dvl"]["C_d_b"] = np.eye(3).tolist()
    (tmp_path / "config.json").write_text(json.dumps(config))
    with pytest.warns(RuntimeWarning, match=r"turned:/dvl/data: field 'velocity': the DVL velocity is turned "
                                            r"-4[45]\.\d deg about z from the IMU's axes") as said:
        m = load_mission(path, tmp_path / "config.json")
    assert m.meta["streams"]["dvl"]["doubted"] == {TURNED_DOUBT: len(mission.dvl.t)}
    # a bag's message fixes its frame: the advice is the mounting, not a column map's key
    turned = [str(w.message) for w in said if "about z from the IMU's axes" in str(w.message)]
    assert "give the DVL's mounting as dvl.C_d_b" in turned[0] and "csv_columns" not in turned[0]
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert cli.main(["info", str(path), "--config", str(tmp_path / "config.json")]) == 0
    assert f"dvl: {len(mission.dvl.t)} read despite a doubt: {TURNED_DOUBT}" in capsys.readouterr().out


@pytest.fixture(scope="module")
def noisy_sim():
    """200 s with 0.03 m/s beams: the DVL clock's best offset explains 0.16 of its velocity changes, 0.14 elsewhere
    (not clear, nor standing out)."""
    import dataclasses
    from graphnav.core.config import SensorConfig
    cfg = SensorConfig()
    cfg.dvl = dataclasses.replace(cfg.dvl, beam_noise_std=0.03)
    return simulate_mission(200.0, seed=0, config=cfg)


@pytest.mark.parametrize("late_s", [0.0, 30.0])
def test_a_noisier_dvl_off_its_header_stamps_is_warned_naming_the_offset_and_a_clean_one_is_not(noisy_sim, tmp_path,
                                                                                               late_s):
    """The DVL's header stamps 30 s late: the clock search's best offset (-29.94 s) explains 0.16 of its velocity
    changes against -0.10 at the stamps, but not clearly more than every other offset, so the stamps were kept with a
    note only (a bag's DVL stamps are usually on the IMU clock). Now a warning names the offset and the key, and the
    pings are counted; on the IMU clock the same bag loads silently as before."""
    import dataclasses
    import warnings
    from graphnav.calibration.preparation import CLOCK_NOT_FOUND
    mission = dataclasses.replace(noisy_sim, dvl=dataclasses.replace(noisy_sim.dvl, t=noisy_sim.dvl.t + late_s))
    path = bags.write_mission_bag(mission, tmp_path / "noisy", storage="mcap", t0_unix_ns=T0_NS, gt=False)
    noisy_sim.config.save(tmp_path / "config.json")
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        m = load_mission(path, tmp_path / "config.json")
    clock = [str(w.message) for w in said if "clock offset" in str(w.message)]
    np.testing.assert_allclose(m.dvl.t, noisy_sim.dvl.t + late_s, atol=1e-6)
    if not late_s:
        assert clock == [] and "doubted" not in m.meta["streams"]["dvl"]
        return
    assert len(clock) == 1 and re.search(r"noisy:/dvl/data: DVL clock offset not found .*at the best offset, "
                                         r"-29\.9\d\d s, .* give dvl_time_offset_s -29\.9\d\d", clock[0])
    assert "csv_columns" not in clock[0]
    assert m.meta["streams"]["dvl"]["doubted"] == {CLOCK_NOT_FOUND: len(noisy_sim.dvl.t)}


def _published_twice(clean, path, copies):
    """``clean`` rewritten to ``path`` with messages published again: ``copies`` {topic: [(index in the topic, header
    stamp ns later, receive time ns later, change of the copy or None)]}, each written after its original."""
    from rosbags.highlevel import AnyReader
    store = bags.typestore()
    rows, seen = [], {}
    with AnyReader([clean], default_typestore=store) as reader:
        for conn, t_ns, raw in reader.messages():
            k = seen[conn.topic] = seen.get(conn.topic, -1) + 1
            rows.append((t_ns, conn.topic, conn.msgtype, raw))
            for index, header_ns, receive_ns, change in copies.get(conn.topic, []):
                if index == k:
                    msg = store.deserialize_cdr(raw, conn.msgtype)
                    ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec + header_ns
                    msg.header.stamp.sec, msg.header.stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
                    if change:
                        change(msg)
                    rows.append((t_ns + receive_ns, conn.topic, conn.msgtype, store.serialize_cdr(msg, conn.msgtype)))
    rows.sort(key=lambda r: r[0])
    return _bag_with(path.parent, path.name, [(topic, typ, t_ns, store.deserialize_cdr(raw, typ))
                                              for t_ns, topic, typ, raw in rows], store)


def test_imu_and_dvl_messages_published_twice_are_dropped_or_doubted_naming_the_topic_and_message(sim, tmp_path):
    """An IMU and a DVL message published again 1 ms later with the same values were fused as two samples with no word
    (the ping weighed twice: the end position 9 cm off the clean bag's in 40 s), and one published again at the same
    header stamp put the whole topic on the recorder's receive time: now the copies are dropped as a log's rows
    written twice are, warned about naming the topic and the message, and counted, the header stamps kept; a DVL
    message 1 ms after another with other values is kept and doubted, as a log's row."""
    import warnings
    from graphnav.core.screening import CLOSE_SAMPLES, EXACT_COPY, NUDGED_COPY
    mission, config, paths, _ = sim
    clean = load_mission(paths["mcap"], config, prepare=False)
    ms = 1_000_000

    def load(name, copies):
        path = _published_twice(paths["mcap"], tmp_path / name, copies)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            m = load_mission(path, config, prepare=False)
        return path, m, [str(w.message) for w in caught if "row(s)" in str(w.message)]

    t_imu, t_dvl = clean.imu.t[2000], clean.dvl.t[20]
    for name, header_ns, reason, said in (
            ("nudged", ms, NUDGED_COPY, "repeating the row before them in every value up to 1 ms later (the same "
                                        "sample written twice, its stamp nudged) dropped, at message {i} (t = {t})"),
            ("same_stamp", 0, EXACT_COPY, "repeating an earlier row exactly (same stamp and values) dropped, at "
                                          "message {i} (t = {t})")):
        path, m, warned = load(name, {"/imu/data": [(2000, header_ns, ms, None)],
                                      "/dvl/data": [(20, header_ns, ms, None)]})
        np.testing.assert_array_equal(m.imu.t, clean.imu.t)
        np.testing.assert_array_equal(m.imu.f_b, clean.imu.f_b)
        np.testing.assert_array_equal(m.dvl.t, clean.dvl.t)
        np.testing.assert_array_equal(m.dvl.valid, clean.dvl.valid)
        assert m.meta["clock"]["stamps"] == {"imu": "header", "dvl": "header", "depth": "header"}
        for stream, topic, i, t in (("imu", "/imu/data", 2001, t_imu), ("dvl", "/dvl/data", 21, t_dvl)):
            assert m.meta["streams"][stream]["read"] == clean.meta["streams"][stream]["read"] + 1
            assert m.meta["streams"][stream]["refused"] == {reason: 1}
            text = said.format(i=i, t=f"{t + header_ns / 1e9:.3f} s")
            assert f"{path}:{topic}: 1 row(s) {text}" in warned, warned
        assert "doubted" not in m.meta["streams"]["imu"]
    # other values 1 ms later: two samples where the DVL makes one, both kept and doubted
    def other(msg):
        msg.beam_velocity = (msg.beam_velocity + np.float32(0.02)).astype(np.float32)

    path, m, warned = load("other", {"/dvl/data": [(20, ms, ms, other)]})
    assert len(m.dvl.t) == len(clean.dvl.t) + 1 and m.dvl.t[21] == pytest.approx(t_dvl + 1e-3, abs=1e-9)
    assert m.meta["streams"]["dvl"]["doubted"] == {CLOSE_SAMPLES: 1} and not m.meta["streams"]["dvl"]["refused"]
    assert any(w.startswith(f"{path}:/dvl/data: 1 dvl row(s) stamped under a fifth of the median step")
               and f"at message 21 (t = {t_dvl + 1e-3:.3f} s)" in w for w in warned), warned


def test_an_ahrs_imu_topic_read_as_the_heading_is_not_doubted_for_its_clock_and_its_copies_are_said_once(sim, tmp_path):
    """The IMU topic of an AHRS (orientation filled) is also the heading source. Stamped on receipt, one sample in
    seven 9 ms late (the next 1 ms after it), its heading was doubted as two samples where the stream makes one
    (571 of 4001 on this 40 s bag), though the IMU's own steps say nothing of it; and a message of it published
    twice was warned about twice. Now an IMU topic's close steps are left to the
    IMU's stamp checks, and its copy is warned about once (counted for both streams, as its other refusals)."""
    import warnings
    from rosbags.highlevel import AnyReader
    from scipy.spatial.transform import Rotation
    from graphnav.core.screening import NUDGED_COPY
    mission, config, paths, _ = sim
    store = bags.typestore()
    Q = store.types["geometry_msgs/msg/Quaternion"]
    rows, k = [], 0
    with AnyReader([paths["mcap"]], default_typestore=store) as reader:
        for conn, t_ns, raw in reader.messages():
            msg = store.deserialize_cdr(raw, conn.msgtype)
            if conn.topic == "/imu/data":
                q = Rotation.from_euler("z", 0.3 + 1e-4 * k).as_quat()
                msg.orientation = Q(x=q[0], y=q[1], z=q[2], w=q[3])
                msg.orientation_covariance = np.diag([1e-4] * 3).ravel()
                ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec + (9_000_000 if k % 7 == 3 else 0)
                msg.header.stamp.sec, msg.header.stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
                if k == 2001:
                    rows.append((conn.topic, conn.msgtype, t_ns, msg))
                    msg = store.deserialize_cdr(store.serialize_cdr(msg, conn.msgtype), conn.msgtype)
                    ns += 1_000_000
                    msg.header.stamp.sec, msg.header.stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
                    t_ns += 1_000_000
                k += 1
            rows.append((conn.topic, conn.msgtype, t_ns, msg))
    path = _bag_with(tmp_path, "ahrs", sorted(rows, key=lambda r: r[2]), store)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = load_mission(path, config, prepare=False)
    warned = [str(w.message) for w in caught]
    assert m.meta["heading_source"] == "/imu/data (sensor_msgs/msg/Imu)" and len(m.heading.t) == k
    assert "doubted" not in m.meta["streams"]["heading"], m.meta["streams"]["heading"]
    assert not [w for w in warned if "heading row(s)" in w]
    assert len([w for w in warned if "row(s) repeating the row before them" in w]) == 1, warned
    assert m.meta["streams"]["imu"]["refused"] == m.meta["streams"]["heading"]["refused"] == {NUDGED_COPY: 1}


def test_an_imu_header_clock_stepping_while_the_messages_keep_arriving_is_moved_back_not_bridged(sim, tmp_path):
    """The IMU's header clock steps +5 s half-way while its messages keep arriving every 10 ms (the receive time shows
    no gap): no sample was lost, but the step was read as a 5 s gap the run bridged, the second half 5 s off the DVL
    (online: 11 m from the clean bag's track in 150 s, 'recovered' at the end); a 2-day step refused the whole bag.
    Now the stamps after the step are moved back onto the clock before it, warned about naming the topic, the
    message and the field, and counted as doubted; a gap the receive time shares (samples lost) is left as it was."""
    from rosbags.highlevel import AnyReader

    from graphnav.io import bag_convert
    mission, config, paths, _ = sim
    n = mission.imu.t.size
    store = bags.typestore()

    def stepped(name, step_ns, receive_too):
        rows, k = [], 0
        with AnyReader([paths["mcap"]], default_typestore=store) as reader:
            for conn, t_ns, raw in reader.messages():
                msg = store.deserialize_cdr(raw, conn.msgtype)
                if conn.topic == "/imu/data":
                    if k >= n // 2:
                        ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec + step_ns
                        msg.header.stamp.sec, msg.header.stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
                        t_ns += step_ns if receive_too else 0
                    k += 1
                rows.append((conn.topic, conn.msgtype, t_ns, msg))
        return _bag_with(tmp_path, name, sorted(rows, key=lambda r: r[2]), store)

    for step_s in (5.0, 2 * 86400.0):
        path = stepped(f"step{step_s:g}", int(step_s * 1e9), receive_too=False)
        m, warned = _load(path, config)
        np.testing.assert_allclose(m.imu.t, mission.imu.t - mission.imu.t[0], atol=2e-9)
        said = [w for w in warned if "the header clock steps" in w]
        assert len(said) == 1 and said[0].startswith(
            f"{path}: /imu/data, message {n // 2} (t = {mission.imu.t[n // 2] + step_s:.3f} s), field 'header.stamp': "
            f"the header clock steps {step_s + 0.01:+.3f} s while the messages kept arriving (receive time +0.010 s)")
        assert m.meta["streams"]["imu"]["doubted"] == {bag_convert.HEADER_CLOCK_STEP: n - n // 2}
        assert not [w for w in warned if "a gap of" in w]
    # samples lost (the receive time steps with the header): still the gap the run bridges, nothing moved
    path = stepped("lost", 500_000_000, receive_too=True)
    m, warned = _load(path, config)
    assert m.imu.t[n // 2] - m.imu.t[n // 2 - 1] == pytest.approx(0.51, abs=1e-6)
    assert not [w for w in warned if "the header clock steps" in w]
    assert [w for w in warned if "a gap of 0.5 s" in w]
    # the clean bag: no step said
    m, warned = _load(paths["mcap"], config)
    assert not [w for w in warned if "the header clock steps" in w]
    assert bag_convert.HEADER_CLOCK_STEP not in m.meta["streams"]["imu"].get("doubted", {})


def test_a_header_clock_step_every_topic_shares_moves_them_all_back_with_the_imu(sim, tmp_path):
    """A time-sync unit (or the vehicle computer stamping every sensor) steps every topic's header clock +5 s half-way
    while the recorder's receive clock runs on: the IMU was moved back alone, the DVL, depth and reference left 5 s
    off it for the second half (the DVL's velocity compared with the IMU's of 5 s before). Now each topic whose header
    minus receive time steps with the IMU's moves back with it, warned naming the topic and message, counted as
    doubted; a topic on a clock of its own that did not step is left as it is."""
    from rosbags.highlevel import AnyReader

    from graphnav.io import bag_convert
    mission, config, paths, _ = sim
    t_step_ns = T0_NS + int(mission.imu.t[mission.imu.t.size // 2] * 1e9)
    store = bags.typestore()

    def stepped(name, which):
        rows = []
        with AnyReader([paths["mcap"]], default_typestore=store) as reader:
            for conn, t_ns, raw in reader.messages():
                msg = store.deserialize_cdr(raw, conn.msgtype)
                if t_ns >= t_step_ns and which(conn.topic) and hasattr(msg, "header"):
                    ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec + 5_000_000_000
                    msg.header.stamp.sec, msg.header.stamp.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
                rows.append((conn.topic, conn.msgtype, t_ns, msg))
        return _bag_with(tmp_path, name, sorted(rows, key=lambda r: r[2]), store)

    clean, _ = _load(paths["mcap"], config)
    m, warned = _load(stepped("all", lambda topic: True), config)
    for stream in ("imu", "dvl", "depth", "gt"):
        np.testing.assert_allclose(getattr(m, stream).t, getattr(clean, stream).t, atol=2e-9, err_msg=stream)
    n_dvl = int(np.sum(clean.dvl.t + clean.meta["t0_unix_ns"] / 1e9 >= t_step_ns / 1e9))
    assert m.meta["streams"]["dvl"]["doubted"] == {bag_convert.HEADER_CLOCK_STEP: n_dvl}
    said = [w for w in warned if "the header clock steps with the IMU's" in w]
    assert [w.split(",")[0] for w in said] == [f"{m.meta['source']}: {t}" for t in ("/dvl/data", "/pressure",
                                                                                      "/reference/odometry")], said
    assert "moved back by 5.000 s" in said[0]
    # the IMU's clock alone stepped: the other topics stay as they were
    m, warned = _load(stepped("imu", lambda topic: topic == "/imu/data"), config)
    for stream in ("imu", "dvl", "depth", "gt"):
        np.testing.assert_allclose(getattr(m, stream).t, getattr(clean, stream).t, atol=2e-9, err_msg=stream)
    assert not [w for w in warned if "the header clock steps with the IMU's" in w]
    assert "doubted" not in m.meta["streams"]["dvl"]


def test_an_imu_losing_samples_over_hours_has_no_header_clock_step_moved():
    """An hour's IMU topic at 110 Hz losing 1 % of its samples, header and receive time both gapping at each of its
    4000 losses: nothing is moved, warned or counted (the losses are samples lost, not a clock step). Its cost (it
    took 11 s when the latency of every message was computed again at each gap) is measured outside the tests."""
    from graphnav.io.bag_convert import Stream, header_clock_steps_removed
    rng = np.random.default_rng(3)
    kept = np.flatnonzero(rng.random(400_000) >= 0.01)
    t_ns = T0_NS + kept * 9_090_909
    s = Stream("/imu/data", "sensor_msgs/msg/Imu", t_ns, [None] * kept.size, "header",
               t_ns + 2_000_000 + rng.integers(0, 1_000_000, kept.size))
    meta: dict = {}
    assert header_clock_steps_removed(s, "bag", meta) is s and meta == {}


def test_a_bag_cut_mid_write_is_refused_saying_so_and_naming_the_file(sim, tmp_path):
    """A bag whose MCAP file was cut at 60 % of its bytes (the recorder killed) was refused with rosbags' 'File end
    magic is invalid.' alone: now the error names the MCAP file, says it was cut mid-write and how to recover its
    complete chunks, through the bag folder or the file, in smooth as in info; a whole bag still opens."""
    import shutil
    _, config, paths, _ = sim
    cut = tmp_path / "cut"
    shutil.copytree(paths["mcap"], cut)
    mcap = cut / "run_mcap.mcap"
    data = mcap.read_bytes()
    mcap.write_bytes(data[: int(len(data) * 0.6)])
    said = (rf"{re.escape(str(mcap))} ends before its MCAP footer, a recording cut mid-write "
            r".*`mcap recover run_mcap.mcap")
    for path in (cut, mcap):
        with pytest.raises(DataError, match=said):
            load_mission(path, config)
    assert cli.main(["smooth", "--data", str(cut), "--config", str(config), "--out", str(tmp_path / "out"),
                     "--no-plots"]) == 1
    assert load_mission(paths["mcap"], config).imu.t.size > 0


def _zeroed_header_bag(mission, path, rows, stall=()):
    """``mission`` as a driver bag with IMU header stamps, those of the messages ``rows`` written 0 (a logger's filler
    zeroing the stamp with the values), those of ``stall`` the stamp of the message before the first of them."""
    import unittest.mock

    write = bag_driver._imu_messages

    def zeroed(mission, store, *args):
        out = write(mission, store, *args)
        for k in rows:
            out[k][3].header = bag_driver._header(store, 0, "imu_link")
        for k in stall:
            out[k][3].header = bag_driver._header(store, out[stall[0] - 1][0], "imu_link")
        return out
    with unittest.mock.patch.object(bag_driver, "_imu_messages", zeroed):
        return bag_driver.write_driver_bag(mission, path, zero_imu_stamps=False, leak_sensor=False,
                                           housing_sensor=False)


def test_filler_messages_with_zeroed_header_stamps_are_filler_not_a_reason_for_receive_time(tmp_path):
    """21 IMU messages of a logger's filler (0.21 s) whose header stamps are zeroed too, as a column map's rows with
    their stamps zeroed: the topic was put on the bag's receive time ('21 header stamp(s) are zero', the recorder's
    latency and jitter in every stamp). They are taken out as filler first, as a column map's: counted and warned
    about as such, the topic on its header stamps, the gap they leave bridged. A topic whose every header stamp is
    zero (no header clock), or whose header clock also stalls beside the filler, is on its receive time as before, its
    filler refused with the other messages."""
    mission = simulate_mission(duration_s=40.0, seed=5)
    rows = list(range(2000, 2021))
    mission.imu.f_b[rows], mission.imu.omega_b[rows] = 0.0, 0.0
    m, warned = _load(_zeroed_header_bag(mission, tmp_path / "zeroed", rows), mission.config)
    imu = m.meta["streams"]["imu"]
    filler = "all-zero IMU row (a logger's filler: zero specific force is impossible under gravity)"
    assert imu["refused"] == {filler: 21} and imu["read"] == len(mission.imu.t)
    assert not [n for n in imu.get("notes", []) if "receive time" in n]
    assert len(m.imu.t) == len(mission.imu.t) - 21 and np.all(np.any(m.imu.f_b != 0.0, axis=1))
    assert any("/imu/data: 21 imu sample(s) refused (21 all-zero IMU row" in w and "header stamp zeroed too, "
               "received at message 2000 (t = 20.000 s)" in w for w in warned)
    keep = np.setdiff1d(np.arange(len(mission.imu.t)), rows)
    np.testing.assert_allclose(m.imu.t - m.imu.t[0], mission.imu.t[keep] - mission.imu.t[0], atol=1e-6)
    m, _ = _load(bag_driver.write_driver_bag(mission, tmp_path / "all", leak_sensor=False, housing_sensor=False),
                 mission.config)
    assert m.meta["streams"]["imu"]["refused"] == {filler: 21}
    assert any("receive time" in n for n in m.meta["streams"]["imu"]["notes"])
    # the header clock stalling on the 10 messages after the filler: on the receive time, where the filler's stamps
    # are, so it is refused with the messages holding no measurement and leaves no gap (none warned or doubted)
    m, warned = _load(_zeroed_header_bag(mission, tmp_path / "stall", rows, stall=range(2022, 2032)), mission.config)
    imu = m.meta["streams"]["imu"]
    assert imu["refused"] == {filler: 21} and len(m.imu.t) == len(mission.imu.t) - 21 and "doubted" not in imu
    assert any("receive time" in n for n in imu["notes"]) and not any("in the stamps" in w for w in warned)


def test_the_gap_filler_with_zeroed_header_stamps_leaves_is_no_samples_lost(tmp_path):
    """21 IMU messages of filler with their header stamps zeroed (0.21 s): refused as filler, and the gap they leave
    was warned about again as '21 samples lost' and counted as doubted. It is said once, as the filler refused."""
    from graphnav.core.screening import IMU_FILLER, IMU_GAP
    mission = simulate_mission(duration_s=40.0, seed=5)
    rows = list(range(2000, 2021))
    mission.imu.f_b[rows], mission.imu.omega_b[rows] = 0.0, 0.0
    m, warned = _load(_zeroed_header_bag(mission, tmp_path / "zeroed", rows), mission.config)
    imu = m.meta["streams"]["imu"]
    assert imu["refused"] == {IMU_FILLER: 21} and IMU_GAP not in imu.get("doubted", {})
    assert not [w for w in warned if "samples lost" in w]
    assert len([w for w in warned if IMU_FILLER in w]) == 1


def test_a_bag_loaded_then_screened_has_its_imu_screened_once(tmp_path, monkeypatch):
    """A bag read by ``load_bag`` (its IMU messages holding no measurement refused at read) and then screened by
    ``screen_mission``: each rule runs once. Screened a second time (the mission and its meta passed on), its IMU was
    screened again, the gap check and the full-scale and spike rules run twice on rows already screened. Now a mission
    screened once keeps its IMU as screened, and the mission read, screened again, is screened again (marked in the
    meta both share, its IMU was kept unscreened)."""
    from graphnav.core import screening
    from graphnav.io import loaders, screened
    calls = {"gaps": 0, "plausible": 0}
    gaps, plausible = screening.check_filler_gaps, screened.imu_implausible
    monkeypatch.setattr(screening, "check_filler_gaps", lambda *a, **k: calls.update(gaps=calls["gaps"] + 1) or
                        gaps(*a, **k))
    monkeypatch.setattr(screened, "imu_implausible", lambda *a, **k: calls.update(plausible=calls["plausible"] + 1) or
                        plausible(*a, **k))
    mission = simulate_mission(duration_s=20.0, seed=5)
    mission.imu.f_b[[300, 900]] = 0.0
    mission.imu.f_b[1200, 0] = 500.0
    path = bag_driver.write_driver_bag(mission, tmp_path / "bag", leak_sensor=False, housing_sensor=False)
    with pytest.warns(RuntimeWarning):
        raw = bags.load_bag(path, mission.config, screen=False)
        assert calls == {"gaps": 1, "plausible": 0}
        m = loaders.screen_mission(raw)
    assert calls == {"gaps": 1, "plausible": 1}
    refused = dict(m.meta["streams"]["imu"]["refused"])
    assert refused == {screening.ACCEL_ZERO: 2, "f_b beyond 156.906 m/s^2": 1} and len(m.imu.t) == 1998
    again = loaders.screen_mission(m)
    assert calls == {"gaps": 1, "plausible": 1}
    assert again.meta["streams"]["imu"]["refused"] == refused and len(again.imu.t) == 1998
    # the mission load_bag gave, screened again (its meta shared with the one screened): its IMU was kept unscreened,
    # the 500 m/s^2 row used without a word; only the mission screening returned is marked
    with pytest.warns(RuntimeWarning, match="f_b beyond 156.906 m/s"):
        twice = loaders.screen_mission(raw)
    assert calls["plausible"] == 2 and len(twice.imu.t) == 1998 and np.abs(twice.imu.f_b).max() < 100.0


def test_load_bag_alone_screens_the_bag_as_smooth_does(tmp_path):
    """``graphnav.io.load_bag`` alone (the public reader) never ran the full-scale and spike rules ``graphnav smooth``
    runs on a bag (``read_mission``): an IMU message of 500 m/s^2 was kept without a word.
    It screens the bag as every reader's rows are, each refusal once (``smooth``'s reading screens nothing again)."""
    import warnings

    from graphnav.io.loaders import read_mission
    mission = simulate_mission(duration_s=20.0, seed=5)
    mission.imu.f_b[1200, 0] = 500.0
    path = bag_driver.write_driver_bag(mission, tmp_path / "bag", leak_sensor=False, housing_sensor=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = bags.load_bag(path, mission.config)
    assert np.abs(m.imu.f_b).max() < 100.0 and m.meta["streams"]["imu"]["refused"] == {"f_b beyond 156.906 m/s^2": 1}
    assert any("f_b beyond 156.906 m/s^2" in str(w.message) for w in caught)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        read = read_mission(path)
    assert read.meta["streams"]["imu"]["refused"] == {"f_b beyond 156.906 m/s^2": 1}
    np.testing.assert_array_equal(read.imu.f_b, m.imu.f_b)


def test_filler_with_zeroed_stamps_beside_a_message_published_twice_keeps_the_header_stamps(tmp_path):
    """21 IMU messages of filler with their header stamps zeroed and, elsewhere, one message published again at its
    header stamp 1 ms later: each alone leaves the topic on its header stamps (the filler taken out, the copy dropped);
    together the copy's repeated stamp made the other stamps 'not sane' and the topic was put on its receive time ('21
    header stamp(s) are zero'). The copy is left out before the other stamps are judged: both are dropped under their
    reasons, the topic on its header stamps, each message named by its index in the topic."""
    import warnings

    from graphnav.core.screening import EXACT_COPY, IMU_FILLER
    mission = simulate_mission(duration_s=40.0, seed=5)
    rows = list(range(1000, 1021))
    mission.imu.f_b[rows], mission.imu.omega_b[rows] = 0.0, 0.0
    path = _published_twice(_zeroed_header_bag(mission, tmp_path / "zeroed", rows), tmp_path / "twice.mcap",
                            {"/imu/data": [(3000, 0, 1_000_000, None)]})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = bags.load_bag(path, mission.config)
    warned = [str(w.message) for w in caught]
    imu = m.meta["streams"]["imu"]
    assert m.meta["clock"]["stamps"]["imu"] == "header" and imu["refused"] == {IMU_FILLER: 21, EXACT_COPY: 1}
    assert not [n for n in imu.get("notes", []) if "receive time" in n]
    assert any("/imu/data: 1 row(s) repeating an earlier row exactly (same stamp and values) dropped, at message 3001 "
               "(t = 30.000 s)" in w for w in warned), warned
    assert any("21 imu sample(s) refused (21 all-zero IMU row" in w and "received at message 1000 (t = 10.000 s)" in w
               for w in warned)
    keep = np.setdiff1d(np.arange(len(mission.imu.t)), rows)
    np.testing.assert_allclose(m.imu.t - m.imu.t[0], mission.imu.t[keep] - mission.imu.t[0], atol=1e-6)
