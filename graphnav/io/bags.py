"""ROS 2 bags (sqlite3 ``.db3`` and MCAP) in and out, through ``rosbags`` (pure Python, no ROS install).

Reading (:func:`load_bag`): a bag folder (with ``metadata.yaml``) or a bare ``.mcap`` / ``.db3`` file.
Topics are chosen by message type; ``topics={"imu": "/imu/data", ...}`` (CLI ``--topic imu=/imu/data``)
overrides the choice. Streams and the types read:

* ``imu``: ``sensor_msgs/msg/Imu`` (``linear_acceleration`` -> ``f_b``, ``angular_velocity`` -> ``omega_b``);
* ``dvl``: ``marine_acoustic_msgs/msg/Dvl`` (the community message: ``beam_velocity[4]`` with validity
  from ``beam_velocities_valid``, ``num_good_beams`` and the per-beam values; ``beam_unit_vec[4]`` gives
  the beam geometry when filled) or Water Linked's ``dvl_msgs/msg/DVL`` with its ``DVLBeam`` list (``id``,
  ``velocity``, ``valid``);
* ``depth``: ``sensor_msgs/msg/FluidPressure`` (``depth = (p - p_atm) / (rho g)`` with
  ``SensorConfig.water_density_kgpm3`` and ``atmospheric_pressure_pa``) or ``std_msgs/msg/Float64``/``Float32``
  holding depth in m, positive down (no header: the bag's receive time is used);
* ``gt`` (optional reference for scoring): ``nav_msgs/msg/Odometry``.

Frames. graphnav works in FRD body / NED navigation. ROS' REP-103 uses FLU body / ENU world; a ``frame_id``
ending in ``_frd`` / ``_ned`` (the marine and PX4 convention) marks FRD / NED data. The readers convert
per message from its ``frame_id`` (``child_frame_id`` for the Odometry body). The DVL messages are in the
DVL's own frame (marine_acoustic_msgs: z along the DVL axis, x vehicle forward; for a down-looking DVL
that is graphnav's DVL frame d), turned into the body frame with ``SensorConfig.dvl.C_d_b``.

Stamps are the messages' header stamps (the time of validity), on one clock; the mission clock starts at
the first IMU stamp (``meta["t0_unix_ns"]`` keeps it, so the written estimates carry absolute stamps).

Writing (:func:`write_odometry_bag`): the estimates as ``nav_msgs/msg/Odometry`` in REP-103 frames
(``odom`` ENU, ``base_link`` FLU) with the velocity covariance in ``twist.covariance``; what the estimator
does not provide (pose covariance, angular rate) is left at zero, ROS' "unknown".
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from graphnav.core.config import SensorConfig
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.mission import DepthData, DvlData, GroundTruth, ImuData, Mission

#: Water Linked's ROS 2 DVL messages (package ``dvl_msgs``), registered from their ``.msg`` text because
#: sqlite3 bags recorded before ROS 2 Iron carry no message definitions. Source: github.com/paagutie/dvl_msgs
#: (``msg/DVL.msg``, the package Water Linked's ROS 2 driver publishes), whose beam message is the same as
#: Water Linked's own ``waterlinked/dvl-a50-ros-driver`` ``msg/DVLBeam.msg`` (id, velocity, distance,
#: rssi, nsd, valid). Bags that embed their definitions (MCAP, rosbag2 >= Iron) use those instead.
DVL_MSGS_DVLBEAM = """\
int64 id
float64 velocity
float64 distance
float64 rssi
float64 nsd
bool valid
"""
DVL_MSGS_DVL = """\
std_msgs/Header header
float64 time
geometry_msgs/Vector3 velocity
float64 fom
float64[] covariance
float64 altitude
DVLBeam[] beams
bool velocity_valid
int64 status
int64 time_of_validity
int64 time_of_transmission
string form
"""
#: The community DVL message, ``marine_acoustic_msgs/msg/Dvl`` from apl-ocean-engineering/marine_msgs
#: (``marine_acoustic_msgs/msg/Dvl.msg``; constants omitted: they are not serialized).
MARINE_ACOUSTIC_DVL = """\
std_msgs/Header header
uint8 velocity_mode
uint8 dvl_type
geometry_msgs/Vector3 velocity
float64[9] velocity_covar
float64 altitude
float64 course_gnd
float64 speed_gnd
uint8 num_good_beams
float32 sound_speed
bool beam_ranges_valid
bool beam_velocities_valid
geometry_msgs/Vector3[4] beam_unit_vec
float64[4] range
float32[4] range_covar
float32[4] beam_quality
float32[4] beam_velocity
float32[4] beam_velocity_covar
"""
MARINE_DVL = "marine_acoustic_msgs/msg/Dvl"
WL_DVL = "dvl_msgs/msg/DVL"
WL_BEAM = "dvl_msgs/msg/DVLBeam"

#: Message types each stream accepts, in order of preference when several topics match.
STREAM_TYPES: dict[str, tuple[str, ...]] = {
    "imu": ("sensor_msgs/msg/Imu",),
    "dvl": (MARINE_DVL, WL_DVL),
    "depth": ("sensor_msgs/msg/FluidPressure", "std_msgs/msg/Float64", "std_msgs/msg/Float32"),
    "gt": ("nav_msgs/msg/Odometry",),
}
REQUIRED_STREAMS = ("imu", "dvl")
BAG_SUFFIXES = (".mcap", ".db3")

#: FLU <-> FRD (its own inverse) and ENU <-> NED (its own inverse).
FLU_FRD = np.diag([1.0, -1.0, -1.0])
ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def _require_rosbags():
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise ConfigError("reading/writing ROS 2 bags needs the 'rosbags' package: pip install 'graphnav[ros]'") \
            from None


def typestore():
    """The ROS 2 Humble typestore of rosbags plus the two DVL message families above."""
    _require_rosbags()
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    store = get_typestore(Stores.ROS2_HUMBLE)
    types = {}
    types.update(get_types_from_msg(DVL_MSGS_DVLBEAM, WL_BEAM))
    types.update(get_types_from_msg(DVL_MSGS_DVL, WL_DVL))
    types.update(get_types_from_msg(MARINE_ACOUSTIC_DVL, MARINE_DVL))
    store.register(types)
    return store


def is_bag(path: str | Path) -> bool:
    """True for a ``.mcap``/``.db3`` file or a rosbag2 folder (one with ``metadata.yaml``)."""
    path = Path(path)
    if path.is_file():
        return path.suffix in BAG_SUFFIXES
    return path.is_dir() and (path / "metadata.yaml").exists()


def _stamp(msg) -> int:
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def _frame_is(frame_id: str, suffix: str) -> bool:
    return frame_id.lower().rstrip("/").endswith(suffix)


def _vec(v) -> np.ndarray:
    return np.array([v.x, v.y, v.z], dtype=float)


def _quat(q) -> np.ndarray:
    return np.array([q.x, q.y, q.z, q.w], dtype=float)


@dataclass
class _Stream:
    topic: str
    msgtype: str
    t_ns: np.ndarray
    rows: list


def parse_topics(items: list[str] | None) -> dict[str, str]:
    """``["imu=/imu/data", "dvl=/dvl"]`` -> ``{"imu": "/imu/data", ...}`` (the CLI's ``--topic``)."""
    out = {}
    for item in items or []:
        stream, sep, topic = item.partition("=")
        if not sep or stream not in STREAM_TYPES or not topic:
            raise ConfigError(f"--topic {item!r}: expected STREAM=TOPIC with STREAM one of {sorted(STREAM_TYPES)}")
        out[stream] = topic
    return out


def _choose_topics(available: dict[str, str], topics: dict[str, str], source: str,
                   wanted: tuple[str, ...] = tuple(STREAM_TYPES), required: tuple[str, ...] = REQUIRED_STREAMS
                   ) -> dict[str, str]:
    """Stream -> topic: the overrides (checked), else the topic of an accepted type (first by preference)."""
    chosen = {}
    for stream, types in STREAM_TYPES.items():
        if stream not in wanted:
            continue
        if stream in topics:
            topic = topics[stream]
            if topic not in available:
                raise DataError(f"topic {topic} (given for {stream}) is not in the bag; it has "
                                f"{sorted(available)}", source, field=topic)
            if available[topic] not in types:
                raise DataError(f"topic {topic} has type {available[topic]}, which graphnav cannot read as "
                                f"{stream} (accepted: {', '.join(types)})", source, field=topic)
            chosen[stream] = topic
            continue
        for typ in types:
            matches = sorted(t for t, ty in available.items() if ty == typ)
            if len(matches) > 1:
                warnings.warn(f"{source}: several {typ} topics {matches}; using {matches[0]} for {stream} "
                              f"(choose with --topic {stream}=TOPIC)", RuntimeWarning, stacklevel=3)
            if matches:
                chosen[stream] = matches[0]
                break
    for stream in required:
        if stream not in chosen:
            raise DataError(f"no {stream} topic: need a topic of type {' or '.join(STREAM_TYPES[stream])}; the bag "
                            f"has {', '.join(f'{t} ({ty})' for t, ty in sorted(available.items())) or 'no topics'}",
                            source, field=stream)
    return chosen


def read_streams(path: str | Path, topics: dict[str, str] | None = None, wanted: tuple[str, ...] = tuple(STREAM_TYPES),
                 required: tuple[str, ...] = REQUIRED_STREAMS) -> dict[str, _Stream]:
    """The raw messages of each stream (header stamps in ns, deserialized messages), stamps checked to
    increase strictly per topic."""
    _require_rosbags()
    from rosbags.highlevel import AnyReader, AnyReaderError
    path = Path(path)
    source = str(path)
    if not path.exists():
        raise DataError("bag not found", source)
    default = typestore()
    try:
        reader = AnyReader([path], default_typestore=default)
        reader.open()
    except (AnyReaderError, Exception) as exc:  # rosbags raises several reader error types
        raise DataError(f"cannot open as a ROS 2 bag: {type(exc).__name__}: {exc}", source) from None
    try:
        # A bag may embed definitions for some types only (e.g. recorded by a mix of nodes): fill the rest.
        missing = {k: v for k, v in default.fielddefs.items() if k not in reader.typestore.fielddefs}
        reader.typestore.register(missing)
        available = {c.topic: c.msgtype for c in reader.connections}
        chosen = _choose_topics(available, topics or {}, source, wanted, required)
        out = {}
        for stream, topic in chosen.items():
            conns = [c for c in reader.connections if c.topic == topic]
            msgtype = conns[0].msgtype
            stamps, rows = [], []
            for conn, log_ns, raw in reader.messages(connections=conns):
                try:
                    msg = reader.deserialize(raw, conn.msgtype)
                except Exception as exc:  # noqa: BLE001 - any decoding failure is reported with the topic
                    raise DataError(f"message {len(rows)} of type {conn.msgtype} cannot be decoded: {exc}",
                                    source, field=topic) from None
                stamps.append(_stamp(msg) if hasattr(msg, "header") else int(log_ns))
                rows.append(msg)
            if not rows:
                raise DataError(f"topic {topic} ({stream}) has no messages", source, field=topic)
            t_ns = np.array(stamps, dtype=np.int64)
            step = np.diff(t_ns)
            bad = np.flatnonzero(step <= 0)
            if bad.size:
                i = int(bad[0]) + 1
                kind = "duplicated" if step[bad[0]] == 0 else "out of order"
                raise DataError(f"topic {topic} ({stream}): header stamp {kind} at message {i} "
                                f"({t_ns[i - 1] / 1e9:.9f} s then {t_ns[i] / 1e9:.9f} s); "
                                f"{bad.size} such message(s)", source, i, topic)
            out[stream] = _Stream(topic, msgtype, t_ns, rows)
        return out
    finally:
        reader.close()


# --- one converter per stream ------------------------------------------------------------------------------
def _imu(s: _Stream, t0_ns: int, source: str) -> ImuData:
    f = np.array([_vec(m.linear_acceleration) for m in s.rows])
    w = np.array([_vec(m.angular_velocity) for m in s.rows])
    if not _frame_is(s.rows[0].header.frame_id, "_frd"):
        f, w = f @ FLU_FRD, w @ FLU_FRD
    return ImuData((s.t_ns - t0_ns) / 1e9, f, w, f"{source}:{s.topic}")


def _dvl(s: _Stream, t0_ns: int, config: SensorConfig, source: str) -> tuple[DvlData, dict]:
    n = len(s.rows)
    beams = np.full((n, 4), np.nan)
    valid = np.zeros((n, 4), bool)
    v_d = np.full((n, 3), np.nan)
    info: dict = {"dvl_message": s.msgtype}
    if s.msgtype == MARINE_DVL:
        mismatch = 0
        unit = None
        for i, m in enumerate(s.rows):
            b = np.asarray(m.beam_velocity, float)
            ok = np.isfinite(b) & bool(m.beam_velocities_valid)
            beams[i], valid[i] = b, ok
            if int(ok.sum()) != int(m.num_good_beams) and m.beam_velocities_valid:
                mismatch += 1
            v_d[i] = _vec(m.velocity)
            vecs = np.array([_vec(u) for u in m.beam_unit_vec])
            if unit is None and np.allclose(np.linalg.norm(vecs, axis=1), 1.0, atol=1e-3):
                unit = vecs
        if mismatch:
            warnings.warn(f"{source}:{s.topic}: {mismatch} ping(s) where num_good_beams differs from the finite "
                          "beam velocities; the per-beam values are used", RuntimeWarning, stacklevel=3)
        info["dvl_num_good_beams_mismatch"] = mismatch
        if unit is not None:
            info["beam_unit_vec_d"] = unit.tolist()
    else:
        unknown_id = 0
        for i, m in enumerate(s.rows):
            for k, beam in enumerate(m.beams):
                j = int(beam.id) if 0 <= int(beam.id) < 4 else k
                unknown_id += not 0 <= int(beam.id) < 4
                if j < 4:
                    beams[i, j], valid[i, j] = float(beam.velocity), bool(beam.valid)
            if m.velocity_valid:
                v_d[i] = _vec(m.velocity)
        if unknown_id:
            warnings.warn(f"{source}:{s.topic}: {unknown_id} DVLBeam id(s) outside 0..3; list position used",
                          RuntimeWarning, stacklevel=3)
    v_b = v_d @ config.dvl.C_d_b.T
    if np.any(~np.all(np.isfinite(v_b), axis=1) & (valid.sum(axis=1) >= 3)):
        # The instrument's own velocity is optional (the estimators use the beams); a DVL that leaves it
        # unset on pings with enough beams gives none at all rather than a partial stream.
        v_b = None
        info["dvl_v_b"] = "not used: missing on pings with >= 3 valid beams"
    dvl = DvlData((s.t_ns - t0_ns) / 1e9, np.where(valid, beams, np.nan), valid, v_b, f"{source}:{s.topic}")
    return dvl.sanitized(), info


def _depth(s: _Stream, t0_ns: int, config: SensorConfig, source: str) -> DepthData:
    if s.msgtype == "sensor_msgs/msg/FluidPressure":
        p = np.array([m.fluid_pressure for m in s.rows], float)
        depth = (p - config.atmospheric_pressure_pa) / (config.water_density_kgpm3 * config.gravity_mps2)
    else:
        depth = np.array([m.data for m in s.rows], float)
    return DepthData((s.t_ns - t0_ns) / 1e9, depth, f"{source}:{s.topic}")


def _gt(s: _Stream, t0_ns: int, source: str) -> GroundTruth:
    p = np.array([_vec(m.pose.pose.position) for m in s.rows])
    q = np.array([_quat(m.pose.pose.orientation) for m in s.rows])
    v_child = np.array([_vec(m.twist.twist.linear) for m in s.rows])
    bad = np.flatnonzero(np.abs(np.linalg.norm(q, axis=1) - 1.0) > 1e-3)
    if bad.size:
        raise DataError(f"orientation quaternion not unit length (|q| = {np.linalg.norm(q[bad[0]]):.4f})",
                        f"{source}:{s.topic}", int(bad[0]), "pose.pose.orientation")
    C_child_world = Rotation.from_quat(q).as_matrix()
    world_ned = _frame_is(s.rows[0].header.frame_id, "_ned")
    child_frd = _frame_is(s.rows[0].child_frame_id, "_frd")
    A = np.eye(3) if world_ned else ENU_NED            # world -> NED
    B = np.eye(3) if child_frd else FLU_FRD            # FRD body -> child
    C_b_n = A @ C_child_world @ B
    p_n = p @ A.T
    v_n = np.einsum("kij,kj->ki", C_b_n, v_child @ B)  # twist is in the child frame; B is symmetric
    return GroundTruth((s.t_ns - t0_ns) / 1e9, p_n, v_n, C_b_n, None, f"{source}:{s.topic}")


def load_odometry(path: str | Path, topic: str | None = None):
    """The ``nav_msgs/msg/Odometry`` of a bag (e.g. what :func:`write_odometry_bag` wrote) as a
    :class:`~graphnav.core.solution.NavSolution` in NED/FRD with absolute stamps (Unix s) and the velocity
    covariance from ``twist.covariance`` (None when it is all zero)."""
    from graphnav.core.solution import NavSolution
    s = read_streams(path, {"gt": topic} if topic else {}, wanted=("gt",), required=("gt",))["gt"]
    gt = _gt(s, 0, str(path))
    child_frd = _frame_is(s.rows[0].child_frame_id, "_frd")
    B = np.eye(3) if child_frd else FLU_FRD
    cov_child = np.array([np.asarray(m.twist.covariance, float).reshape(6, 6)[:3, :3] for m in s.rows])
    cov = None
    if np.any(cov_child):
        R = np.einsum("kij,jl->kil", gt.C_b_n, B)          # child -> NED
        cov = np.einsum("kij,kjl,kml->kim", R, cov_child, R)
    return NavSolution(s.topic, gt.t, gt.p_n, gt.v_n, gt.C_b_n, cov_v_n=cov)


def load_bag(path: str | Path, config: SensorConfig | None = None, topics: dict[str, str] | None = None,
             name: str | None = None) -> Mission:
    """A :class:`Mission` from a ROS 2 bag (folder, ``.mcap`` or ``.db3``); see the module docstring."""
    import dataclasses
    path = Path(path)
    config = dataclasses.replace(config) if config is not None else SensorConfig()
    source = str(path)
    streams = read_streams(path, topics)
    t0_ns = int(streams["imu"].t_ns[0])
    imu = _imu(streams["imu"], t0_ns, source)
    dvl, info = _dvl(streams["dvl"], t0_ns, config, source)
    if "beam_unit_vec_d" in info:
        # The messages carry the beam geometry: use it (theta from the mean z component, psi per beam).
        u = np.asarray(info["beam_unit_vec_d"])
        theta = float(np.arccos(np.clip(np.mean(u[:, 2]), -1, 1)))
        psi = np.arctan2(u[:, 1], u[:, 0])
        if np.max(np.abs(u[:, 2] - np.cos(theta))) > 1e-3:
            warnings.warn(f"{source}: beam_unit_vec inclinations differ ({np.degrees(np.arccos(u[:, 2]))} deg); "
                          f"using their mean {np.degrees(theta):.2f} deg", RuntimeWarning, stacklevel=2)
        config.dvl = dataclasses.replace(config.dvl, theta_rad=theta, psi_rad=psi)
    depth = _depth(streams["depth"], t0_ns, config, source) if "depth" in streams else None
    gt = _gt(streams["gt"], t0_ns, source) if "gt" in streams else None
    meta = {"source": source, "format": "rosbag2", "t0_unix_ns": t0_ns,
            "topics": {k: f"{s.topic} ({s.msgtype})" for k, s in streams.items()}, **info}
    if depth is None:
        meta["depth_source"] = "none"
    return Mission(name or (path.stem if path.is_file() else path.name), imu, dvl, config, gt, depth, meta)


# --- writing -----------------------------------------------------------------------------------------------
def _writer(path: Path, storage: str):
    _require_rosbags()
    from rosbags.rosbag2 import StoragePlugin, Writer
    plugins = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}
    if storage not in plugins:
        raise ConfigError(f"bag storage {storage!r}: choose mcap or sqlite3")
    if path.exists():
        raise ConfigError(f"{path} exists already; rosbag2 writers only create new bags")
    return Writer(path, version=9, storage_plugin=plugins[storage])


def _header(store, t_ns: int, frame_id: str):
    T = store.types
    return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=int(t_ns // 1_000_000_000),
                                                                          nanosec=int(t_ns % 1_000_000_000)),
                                    frame_id=frame_id)


#: Velocity variance, (m/s)^2, an Odometry message carries when its estimate is diverged ("do not use").
DIVERGED_VARIANCE = 1e6


def odometry_messages(solution, store, t0_unix_ns: int = 0) -> list[tuple[int, object]]:
    """(stamp ns, ``nav_msgs/msg/Odometry``) per epoch of a :class:`~graphnav.core.solution.NavSolution`, in
    REP-103 frames (``odom`` ENU, ``base_link`` FLU); the NED velocity covariance, rotated into FLU, fills
    the linear block of ``twist.covariance``. An epoch whose health is ``diverged``
    (``solution.info["health_state"]``) carries :data:`DIVERGED_VARIANCE` on that block's diagonal instead:
    Odometry has no status field, and a consumer that weighs by covariance then ignores it."""
    T = store.types
    health = (solution.info or {}).get("health_state") or [None] * len(solution.t)
    C_flu_enu = np.einsum("ij,kjl,lm->kim", ENU_NED, solution.C_b_n, FLU_FRD)
    q = Rotation.from_matrix(C_flu_enu).as_quat()
    p_enu = solution.p_n @ ENU_NED.T
    v_flu = np.einsum("kji,kj->ki", solution.C_b_n, solution.v_n) @ FLU_FRD
    V3 = T["geometry_msgs/msg/Vector3"]
    out = []
    for k in range(len(solution.t)):
        t_ns = int(t0_unix_ns + round(float(solution.t[k]) * 1e9))
        twist_cov = np.zeros((6, 6))
        if solution.cov_v_n is not None:
            R = FLU_FRD @ solution.C_b_n[k].T
            twist_cov[:3, :3] = R @ solution.cov_v_n[k] @ R.T
        if health[k] == "diverged":
            twist_cov[:3, :3] = np.eye(3) * DIVERGED_VARIANCE
        out.append((t_ns, T["nav_msgs/msg/Odometry"](
            header=_header(store, t_ns, "odom"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=p_enu[k, 0], y=p_enu[k, 1], z=p_enu[k, 2]),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=q[k, 0], y=q[k, 1], z=q[k, 2], w=q[k, 3])),
                covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=V3(x=v_flu[k, 0], y=v_flu[k, 1], z=v_flu[k, 2]),
                                                   angular=V3(x=0.0, y=0.0, z=0.0)),
                covariance=twist_cov.reshape(36)))))
    return out


def write_odometry_bag(solution, path: str | Path, *, t0_unix_ns: int = 0, topic: str = "/graphnav/odometry",
                       storage: str = "mcap") -> Path:
    """Write a :class:`~graphnav.core.solution.NavSolution` as ``nav_msgs/msg/Odometry`` (see
    :func:`odometry_messages`) into a new rosbag2 folder ``path``, stamps ``t0_unix_ns + t``. Returns ``path``."""
    path = Path(path)
    store = typestore()
    msgtype = "nav_msgs/msg/Odometry"
    with _writer(path, storage) as writer:
        conn = writer.add_connection(topic, msgtype, typestore=store)
        for t_ns, msg in odometry_messages(solution, store, t0_unix_ns):
            writer.write(conn, t_ns, store.serialize_cdr(msg, msgtype))
    return path


def write_mission_bag(mission: Mission, path: str | Path, *, storage: str = "mcap", dvl_type: str = MARINE_DVL,
                      t0_unix_ns: int = 1_700_000_000_000_000_000, depth_as_pressure: bool = True,
                      gt: bool = True) -> Path:
    """Record a mission as a ROS 2 bag the way a vehicle would (REP-103 FLU IMU, the DVL in its own frame,
    pressure, reference odometry): for tests, demos and handing simulated missions to ROS tools."""
    path = Path(path)
    store = typestore()
    T = store.types
    cfg = mission.config
    H = _header
    V3 = T["geometry_msgs/msg/Vector3"]
    msgs: list[tuple[int, str, object]] = []
    imu_f, imu_w = mission.imu.f_b @ FLU_FRD, mission.imu.omega_b @ FLU_FRD
    for k, t in enumerate(mission.imu.t):
        t_ns = t0_unix_ns + round(t * 1e9)
        msgs.append((t_ns, "/imu/data", T["sensor_msgs/msg/Imu"](
            header=H(store, t_ns, "imu_link"), orientation=T["geometry_msgs/msg/Quaternion"](x=0., y=0., z=0., w=1.),
            orientation_covariance=np.array([-1.0] + [0.0] * 8),
            angular_velocity=V3(x=imu_w[k, 0], y=imu_w[k, 1], z=imu_w[k, 2]), angular_velocity_covariance=np.zeros(9),
            linear_acceleration=V3(x=imu_f[k, 0], y=imu_f[k, 1], z=imu_f[k, 2]),
            linear_acceleration_covariance=np.zeros(9))))
    from graphnav.core.dvl import beam_matrix
    unit = beam_matrix(cfg.dvl.theta_rad, cfg.dvl.psi_rad)
    dvl = mission.dvl
    v_d = np.full((len(dvl.t), 3), np.nan) if dvl.v_b is None else dvl.v_b @ cfg.dvl.C_d_b
    for k, t in enumerate(dvl.t):
        t_ns = t0_unix_ns + round(t * 1e9)
        ok = dvl.valid[k]
        b = np.where(ok, dvl.beams[k], np.nan)
        vel = V3(x=v_d[k, 0], y=v_d[k, 1], z=v_d[k, 2])
        if dvl_type == MARINE_DVL:
            msg = T[MARINE_DVL](
                header=H(store, t_ns, "dvl_link"), velocity_mode=1, dvl_type=0, velocity=vel,
                velocity_covar=np.full(9, -1.0), altitude=10.0, course_gnd=0.0, speed_gnd=0.0,
                num_good_beams=int(ok.sum()), sound_speed=1500.0, beam_ranges_valid=False,
                beam_velocities_valid=bool(ok.any()), beam_unit_vec=[V3(x=u[0], y=u[1], z=u[2]) for u in unit],
                range=np.zeros(4), range_covar=np.full(4, -1.0, np.float32),
                beam_quality=np.zeros(4, np.float32), beam_velocity=b.astype(np.float32),
                beam_velocity_covar=np.full(4, -1.0, np.float32))
        elif dvl_type == WL_DVL:
            beams = [T[WL_BEAM](id=j, velocity=float(b[j]) if ok[j] else 0.0, distance=10.0, rssi=-40.0, nsd=-60.0,
                                valid=bool(ok[j])) for j in range(4)]
            msg = T[WL_DVL](header=H(store, t_ns, "dvl_link"), time=0.0, velocity=vel, fom=0.01,
                            covariance=np.zeros(9), altitude=10.0, beams=beams,
                            velocity_valid=bool(ok.sum() >= 3 and np.all(np.isfinite(v_d[k]))), status=0,
                            time_of_validity=t_ns // 1000, time_of_transmission=t_ns // 1000, form="json_v3")
        else:
            raise ConfigError(f"dvl_type {dvl_type!r}: choose {MARINE_DVL} or {WL_DVL}")
        msgs.append((t_ns, "/dvl/data", msg))
    if mission.depth is not None:
        for t, d in zip(mission.depth.t, mission.depth.depth):
            t_ns = t0_unix_ns + round(t * 1e9)
            if depth_as_pressure:
                p = cfg.atmospheric_pressure_pa + cfg.water_density_kgpm3 * cfg.gravity_mps2 * d
                msgs.append((t_ns, "/pressure", T["sensor_msgs/msg/FluidPressure"](
                    header=H(store, t_ns, "pressure_link"), fluid_pressure=float(p), variance=0.0)))
            else:
                msgs.append((t_ns, "/depth", T["std_msgs/msg/Float64"](data=float(d))))
    if gt and mission.gt is not None:
        from graphnav.core.solution import NavSolution
        g = mission.gt
        ref = NavSolution("GT", g.t, g.p_n, g.v_n, g.C_b_n)
        msgs += [(t_ns, "/reference/odometry", m) for t_ns, m in odometry_messages(ref, store, t0_unix_ns)]
    types = {"/imu/data": "sensor_msgs/msg/Imu", "/dvl/data": dvl_type,
             "/pressure": "sensor_msgs/msg/FluidPressure", "/depth": "std_msgs/msg/Float64",
             "/reference/odometry": "nav_msgs/msg/Odometry"}
    msgs.sort(key=lambda m: m[0])
    with _writer(path, storage) as writer:
        conns = {topic: writer.add_connection(topic, typ, typestore=store) for topic, typ in types.items()
                 if any(m[1] == topic for m in msgs)}
        for t_ns, topic, msg in msgs:
            writer.write(conns[topic], t_ns, store.serialize_cdr(msg, types[topic]))
    return path
