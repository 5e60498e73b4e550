"""A bag recorded the way a small AUV's real drivers record it, from a mission: for tests and demos of what the
bag loader repairs.

What :func:`write_driver_bag` reproduces (each switchable): an IMU driver that leaves every header stamp at
zero and fills the orientation (an AHRS), optionally with its gyro in deg/s; Water Linked's ``dvl_msgs/DVL``
in the definition the driver was built with, stamped by the driver with a few stamps repeated, optionally on
a DVL clock days away from the IMU's; a leak sensor publishing ``FluidPressure`` zeros and a housing pressure
sensor beside the real water pressure; a recording that starts at the surface; a sqlite3 bag without
embedded definitions (rosbag2 before Iron).
"""
from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from graphnav.core.dvl import beam_matrix
from graphnav.core.errors import ConfigError
from graphnav.core.mission import Mission
from graphnav.io.bag_convert import ENU_NED, FLU_FRD, flu_frd
from graphnav.io.bag_msgs import DVL_MSGS_DVL_V3, WL_BEAM, WL_DVL, typestore

IMU_TOPIC, DVL_TOPIC, PRESSURE_TOPIC = "/imu/data", "/dvl/data", "/pressure"
LEAK_TOPIC, HOUSING_TOPIC = "/leak/pressure", "/housing/pressure"


def _header(store, t_ns: int, frame_id: str):
    T = store.types
    return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=int(t_ns // 1_000_000_000),
                                                                          nanosec=int(t_ns % 1_000_000_000)),
                                    frame_id=frame_id)


def _ns(t0_ns: int, t: float) -> int:
    return int(t0_ns + round(float(t) * 1e9))


def _imu_messages(mission: Mission, store, t0_ns: int, zero_stamps: bool, ahrs: bool, gyro_deg: bool,
                  heading_sigma_rad: float):
    T = store.types
    V3 = T["geometry_msgs/msg/Vector3"]
    f, w = flu_frd(mission.imu.f_b), flu_frd(mission.imu.omega_b)
    if gyro_deg:
        w = np.degrees(w)
    if ahrs:
        if mission.gt is None:
            raise ConfigError("an AHRS orientation needs the mission's ground truth attitude")
        C_b_n = mission.gt.at(np.clip(mission.imu.t, mission.gt.t[0], mission.gt.t[-1]))[2]
        q = Rotation.from_matrix(np.einsum("ij,kjl,lm->kim", ENU_NED, C_b_n, FLU_FRD)).as_quat()
        cov = np.diag([np.radians(1.0) ** 2, np.radians(1.0) ** 2, heading_sigma_rad ** 2]).reshape(9)
    else:
        q, cov = np.tile([0.0, 0.0, 0.0, 1.0], (len(mission.imu.t), 1)), np.array([-1.0] + [0.0] * 8)
    out = []
    for k, t in enumerate(mission.imu.t):
        rx = _ns(t0_ns, t)
        out.append((rx, IMU_TOPIC, "sensor_msgs/msg/Imu", T["sensor_msgs/msg/Imu"](
            header=_header(store, 0 if zero_stamps else rx, "imu_link"),
            orientation=T["geometry_msgs/msg/Quaternion"](x=q[k, 0], y=q[k, 1], z=q[k, 2], w=q[k, 3]),
            orientation_covariance=cov, angular_velocity=V3(x=w[k, 0], y=w[k, 1], z=w[k, 2]),
            angular_velocity_covariance=np.zeros(9), linear_acceleration=V3(x=f[k, 0], y=f[k, 1], z=f[k, 2]),
            linear_acceleration_covariance=np.zeros(9))))
    return out


def _dvl_messages(mission: Mission, store, t0_ns: int, duplicate: int, clock_offset_s: float, latency_s: float,
                  velocity_sigma: float):
    """Water Linked's message: beams by id, the velocity (least squares over the valid beams, as the A50's
    own solution) valid with >= 3 beams; header stamps on the DVL's clock, ``duplicate`` of them repeated."""
    T = store.types
    V3 = T["geometry_msgs/msg/Vector3"]
    cfg, dvl = mission.config, mission.dvl
    A = beam_matrix(cfg.dvl.theta_rad, cfg.dvl.psi_rad)
    with_cov = any(name == "covariance" for name, _ in store.fielddefs[WL_DVL][1])
    n = len(dvl.t)
    dup = set(np.linspace(n // 4, 3 * n // 4, duplicate).astype(int).tolist()) if duplicate and n > 4 else set()
    out, prev = [], None
    for k, t in enumerate(dvl.t):
        ok = dvl.valid[k]
        v = np.linalg.lstsq(A[ok], dvl.beams[k][ok], rcond=None)[0] if ok.sum() >= 3 else np.zeros(3)
        stamp = _ns(t0_ns, t + clock_offset_s)
        if k in dup and prev is not None:
            stamp = prev
        prev = stamp
        beams = [T[WL_BEAM](id=j, velocity=float(dvl.beams[k, j]) if ok[j] else 0.0, distance=10.0 if ok[j] else -1.0,
                            rssi=-40.0, nsd=-60.0, valid=bool(ok[j])) for j in range(4)]
        fields = dict(header=_header(store, stamp, "dvl_link"), time=float(k * 1e3 / max(cfg.dvl.rate_hz, 1e-9)),
                      velocity=V3(x=v[0], y=v[1], z=v[2]), fom=velocity_sigma, altitude=10.0, beams=beams,
                      velocity_valid=bool(ok.sum() >= 3), status=0, form="json_v3")
        if with_cov:
            fields.update(covariance=np.diag(np.full(3, velocity_sigma ** 2)).reshape(9),
                          time_of_validity=_ns(t0_ns, t) // 1000,
                          time_of_transmission=_ns(t0_ns, t + latency_s) // 1000)
        out.append((_ns(t0_ns, t + latency_s), DVL_TOPIC, WL_DVL, T[WL_DVL](**fields)))
    return out


def _pressure_messages(mission: Mission, store, t0_ns: int, p_atm: float, surface_s: float, leak: bool,
                       housing: bool):
    T = store.types
    cfg = mission.config
    rho_g = cfg.water_density_kgpm3 * cfg.gravity_mps2
    t, d = mission.depth.t, mission.depth.depth
    if surface_s > 0:
        # the recorder starts while the vehicle floats: depth 0 before the mission, at the depth stream's rate
        step = float(np.median(np.diff(t)))
        t_s = t[0] - step * np.arange(int(surface_s / step), 0, -1)
        t, d = np.concatenate([t_s, t]), np.concatenate([np.zeros(len(t_s)), d])
    P = T["sensor_msgs/msg/FluidPressure"]
    out = []
    for k, (tk, dk) in enumerate(zip(t, d)):
        ns = _ns(t0_ns, tk)
        out.append((ns, PRESSURE_TOPIC, "sensor_msgs/msg/FluidPressure",
                    P(header=_header(store, ns, "pressure_link"), fluid_pressure=float(p_atm + rho_g * dk),
                      variance=0.0)))
        if leak:
            out.append((ns, LEAK_TOPIC, "sensor_msgs/msg/FluidPressure",
                        P(header=_header(store, ns, "leak_link"), fluid_pressure=0.0, variance=0.0)))
        if housing:
            # the sealed hull: about one atmosphere, warming slowly
            out.append((ns, HOUSING_TOPIC, "sensor_msgs/msg/FluidPressure",
                        P(header=_header(store, ns, "housing_link"), fluid_pressure=float(99_000.0 + 0.5 * k),
                          variance=0.0)))
    return out


def strip_definitions(db3: str | Path) -> None:
    """Remove the message definitions from a rosbag2 sqlite3 file, as rosbag2 before Iron records it."""
    with sqlite3.connect(db3) as con:
        con.execute("DELETE FROM message_definitions")
        con.execute("UPDATE topics SET type_description_hash = ''")


def write_driver_bag(mission: Mission, path: str | Path, *, storage: str = "mcap",
                     dvl_definition: str = DVL_MSGS_DVL_V3, embed_definitions: bool = True,
                     t0_unix_ns: int = 1_700_000_000_000_000_000, zero_imu_stamps: bool = True, ahrs: bool = True,
                     gyro_deg: bool = False, duplicate_dvl_stamps: int = 3, dvl_clock_offset_s: float = 0.0,
                     dvl_latency_s: float = 0.05, leak_sensor: bool = True, housing_sensor: bool = True,
                     atmospheric_pressure_pa: float = 100_800.0, surface_s: float = 5.0,
                     heading_sigma_rad: float = float(np.radians(2.0)), dvl_velocity_sigma: float = 0.01) -> Path:
    """Record ``mission`` as a real small AUV's drivers would (see the module docstring) into a new rosbag2
    folder ``path``; returns ``path``.

    The IMU's receive time is the mission time (``t0_unix_ns + t``); the DVL is received ``dvl_latency_s``
    after its time of validity and stamped on a clock ``dvl_clock_offset_s`` away. ``embed_definitions=False``
    (sqlite3 only) strips the definitions after writing.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    path = Path(path)
    if path.exists():
        raise ConfigError(f"{path} exists already; rosbag2 writers only create new bags")
    if not embed_definitions and storage != "sqlite3":
        raise ConfigError("a bag without embedded definitions is a sqlite3 bag (MCAP always embeds them)")
    store = typestore(dvl_definition)
    msgs = _imu_messages(mission, store, t0_unix_ns, zero_imu_stamps, ahrs, gyro_deg, heading_sigma_rad)
    msgs += _dvl_messages(mission, store, t0_unix_ns, duplicate_dvl_stamps, dvl_clock_offset_s, dvl_latency_s,
                          dvl_velocity_sigma)
    if mission.depth is not None:
        msgs += _pressure_messages(mission, store, t0_unix_ns, atmospheric_pressure_pa, surface_s, leak_sensor,
                                   housing_sensor)
    msgs.sort(key=lambda m: m[0])
    plugin = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}[storage]
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conns = {}
        for rx, topic, typ, msg in msgs:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, typ, typestore=store)
            writer.write(conns[topic], rx, store.serialize_cdr(msg, typ))
    if not embed_definitions:
        strip_definitions(next(path.glob("*.db3")))
    return path
