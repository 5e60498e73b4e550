"""ROS 2 bags: a simulated mission recorded with rosbags' own writer (MCAP and sqlite3, both DVL message
families) is read back through the CLI (`graphnav smooth` / `online`), the estimates come out as an
Odometry bag, and bad bags fail with errors that name the topic."""
from __future__ import annotations

import json

import numpy as np
import pytest

from graphnav import cli
from graphnav.core.errors import ConfigError, DataError
from graphnav.evaluation.methods import run_method
from graphnav.io import bags
from graphnav.io.loaders import load_mission
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
    from graphnav.evaluation.metrics import vrmse
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
    with pytest.raises(DataError, match=r"no dvl topic.*/dvl/twist \(geometry_msgs/msg/TwistStamped\)"):
        load_mission(odd, config)
    # Through the CLI: exit code 1 and the topic in the message.
    assert cli.main(["smooth", "--data", str(odd), "--config", str(config), "--topic", "dvl=/dvl/twist",
                     "--out", str(tmp_path / "x"), "--no-plots"]) == 1
    with pytest.raises(ConfigError, match="STREAM=TOPIC"):
        bags.parse_topics(["dvl:/dvl"])


def test_bench_finds_a_folder_of_bags(sim, tmp_path):
    from graphnav.evaluation.bench import find_trajectories
    _, config, paths, root = sim
    found = find_trajectories(str(root), config_path=str(config))
    assert [s.name for s in found] == ["run_mcap", "run_wl"]
    assert [s.name for s in find_trajectories(str(paths["mcap"] / "run_mcap.mcap"))] == ["run_mcap"]
