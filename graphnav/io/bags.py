"""ROS bags (ROS 1 ``.bag``, ROS 2 sqlite3 ``.db3``, MCAP, rosbag2 folders) in and out, through ``rosbags``
(pure Python, no ROS install).

Reading (:func:`load_bag`): a bag is recognised by its content (:func:`is_bag`: ROS 1's ``#ROSBAG V2.0``,
MCAP's and sqlite3's magic bytes, a folder with ``metadata.yaml``), whatever its name. Topics are chosen by
message type and plausibility; ``topics={"imu": "/imu/data", ...}`` (CLI ``--topic imu=/imu/data``)
overrides the choice. Streams and the types read:

* ``imu``: ``sensor_msgs/msg/Imu`` (``linear_acceleration`` -> ``f_b``, ``angular_velocity`` -> ``omega_b``);
* ``dvl``: ``marine_acoustic_msgs/msg/Dvl`` (beams with ``beam_velocities_valid``/``num_good_beams``, the
  geometry from ``beam_unit_vec``, the velocity when ``num_good_beams >= 3``), Water Linked's
  ``dvl_msgs/msg/DVL`` (``DVLBeam`` list; ``velocity`` with ``velocity_valid`` and ``covariance``), or, when
  there is no DVL message, a velocity-only ``geometry_msgs/msg/TwistWithCovarianceStamped`` (see
  :mod:`graphnav.io.bag_convert` for its frame). The instrument's velocity goes to ``DvlData.v_d``. A vendor's own
  DVL message is read through the fields the configuration's ``bag_topics.dvl`` names (:mod:`graphnav.io.bag_fields`);
* ``depth``: the most plausible of the ``sensor_msgs/msg/FluidPressure`` topics and the ``std_msgs/Float64``/
  ``Float32`` topics named like depth (water pressure range, not all zeros, varying), the surface pressure
  estimated when the record starts at the surface, depths range-checked. A depth topic is metres positive down;
  the configuration's ``"bag_topics": {"depth": {"positive": "up"}}`` declares one positive up (negated on
  reading, noted), with the name and meaning of ``csv_columns.depth.positive``: a declared convention the data
  contradict is a DataError, not turned (:func:`graphnav.io.units.depth_convention`); on a pressure topic the key
  is a ConfigError;
* ``heading``: an AHRS (a ``sensor_msgs/msg/Imu`` whose orientation is filled), a ``Float64``/``Float32``
  topic named like heading or compass (a compass heading: clockwise from north), or a ``geometry_msgs/msg/PoseWithCovarianceStamped`` orientation, into
  ``Mission.heading`` (the replay feeds it to ``Navigator.add_heading``; the aligner uses it instead of
  gyrocompassing). A bag without any says so when it is prepared (:mod:`graphnav.calibration.preparation`);
* ``fix``: ``sensor_msgs/msg/NavSatFix`` GNSS fixes into ``Mission.fixes`` (the replay feeds them to
  ``Navigator.add_position_fix``): no-fix messages refused, sigma from ``position_covariance``;
* ``gt`` (optional reference for scoring): ``nav_msgs/msg/Odometry``.

Message definitions: the bag's own (MCAP, rosbag2 >= Iron, ROS 1) first, else :mod:`graphnav.io.bag_msgs`.
Stamps: :mod:`graphnav.io.bag_stamps` (header stamps when sane, else receive time; DVL/IMU clock offsets
recorded, never dropped). A message published twice (every value but its header repeating an earlier message's at
its header stamp, or the message before it under half a step later) is dropped, warned about naming the topic and
the message, and counted, as a log's row written twice is (once, when the IMU's topic is also the heading); a
message of a topic other than a ``sensor_msgs/Imu`` one (whose close steps are its clock's jitter or packets) under a
fifth of a step after the one before with other values is kept and doubted
(:func:`graphnav.io.bag_convert.decoded_stream`, :func:`_record`). The mission clock starts at the first IMU stamp
(``meta["t0_unix_ns"]``); every stream off the IMU's clock is moved onto it through the receive clock
(:func:`_onto_imu_clock`). What each stream read, used and refused, and every repair, is in ``meta["streams"]``.

Writing (:func:`write_odometry_bag`): the estimates as ``nav_msgs/msg/Odometry`` in REP-103 frames
(``odom`` ENU, ``base_link`` FLU) with the covariances in the frames and order ROS defines:
``pose.covariance`` (x, y, z, rotation about the fixed x, y, z axes) in ``odom`` ENU, ``twist.covariance``
in ``base_link`` FLU. What the estimator does not provide (the angular rate; the position of the paper's 12-state
EKF) carries :data:`UNKNOWN_VARIANCE` on its diagonal, never a zero that would claim certainty.
"""
from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from graphnav.core.config import SensorConfig
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.imu_timing import shown_rate_hz
from graphnav.core.mission import Mission
from graphnav.core.screening import say_close_samples
from graphnav.core.streams import add_note, count_doubted, count_read, count_refused, set_span
from graphnav.io import bag_convert as conv
from graphnav.io import bag_fields
from graphnav.io.bag_convert import ENU_NED, FLU_FRD, PRESSURE, TWIST_DVL, Stream, flu_frd
from graphnav.io.bag_driver import write_driver_bag  # noqa: F401 - the driver-like bag, next to write_mission_bag
from graphnav.io.bag_msgs import (DVL_MSGS_DVL_A50, DVL_MSGS_DVL_V3, DVL_MSGS_DVLBEAM,  # noqa: F401
                                  MARINE_ACOUSTIC_DVL, MARINE_DVL, WL_BEAM, WL_DVL, bag_kind, fit_definition,
                                  readable_path, require_rosbags, typestore)

IMU = "sensor_msgs/msg/Imu"
FLOATS = ("std_msgs/msg/Float64", "std_msgs/msg/Float32")
POSE = "geometry_msgs/msg/PoseWithCovarianceStamped"
ODOM = "nav_msgs/msg/Odometry"
NAVSATFIX = "sensor_msgs/msg/NavSatFix"

#: Message types each stream accepts, in order of preference when several topics match.
STREAM_TYPES: dict[str, tuple[str, ...]] = {
    "imu": (IMU,),
    "dvl": (MARINE_DVL, WL_DVL, TWIST_DVL),
    "depth": (PRESSURE, *FLOATS),
    "heading": (IMU, *FLOATS, POSE, ODOM),
    "gt": (ODOM,),
    "fix": (NAVSATFIX,),
}
REQUIRED_STREAMS = ("imu", "dvl")
#: Words that make a Float64/Float32 topic a depth or a heading.
DEPTH_WORDS = ("depth",)
HEADING_WORDS = ("heading", "compass")     # not "yaw": a ROS yaw is ENU (counter-clockwise from east)
#: Messages of a dvl_msgs/DVL topic without an embedded definition that a candidate definition must decode.
FIT_MESSAGES = 20


def is_bag(path: str | Path) -> bool:
    """True for a ROS 1 bag, an MCAP or sqlite3 file (by their magic bytes) or a rosbag2 folder."""
    return bag_kind(path) is not None


def parse_topics(items: list[str] | None) -> dict[str, str]:
    """``["imu=/imu/data", "dvl=/dvl"]`` -> ``{"imu": "/imu/data", ...}`` (the CLI's ``--topic``)."""
    out = {}
    for item in items or []:
        stream, sep, topic = item.partition("=")
        if not sep or stream not in STREAM_TYPES or not topic:
            raise ConfigError(f"--topic {item!r}: expected STREAM=TOPIC with STREAM one of {sorted(STREAM_TYPES)}")
        out[stream] = topic
    return out


def _named(topic: str, words: tuple[str, ...]) -> bool:
    return any(w in topic.lower() for w in words)


def _candidates(available: dict[str, str], stream: str) -> list[str]:
    """The topics that may hold ``stream``, by type preference then name."""
    out = []
    for typ in STREAM_TYPES[stream]:
        topics = sorted(t for t, ty in available.items() if ty == typ)
        if typ in FLOATS:
            topics = [t for t in topics if _named(t, DEPTH_WORDS if stream == "depth" else HEADING_WORDS)]
        if stream == "heading" and typ == ODOM:
            topics = []          # an Odometry is the reference unless named with --topic heading=...
        out += topics
    return out


def _way_forward(stream: str, bag: _Bag, topic: str | None = None) -> str:
    """What a user can do with a stream recorded in a message type graphnav does not read (a vendor's own DVL
    message): name its fields in the configuration (an example from the message's own fields), or republish it."""
    if stream != "dvl":
        return ""
    return (bag_fields.way_forward(bag.reader.typestore.fielddefs, bag.available, topic)
            + f"; or republish it as {TWIST_DVL} (the body-frame velocity, read velocity-only) or as {MARINE_DVL} "
              "and record the bag again, or export the bag's streams to CSV (read with a csv_columns map)")


def _choose_topics(bag: _Bag, topics: dict[str, str], source: str, wanted: tuple[str, ...],
                   required: tuple[str, ...], dvl_fields: dict | None = None) -> dict[str, list[str]]:
    """Stream -> candidate topics: the override alone (checked), else every topic of an accepted type; the DVL
    topic of ``dvl_fields`` (``bag_topics.dvl``) whatever its type, its fields checked."""
    available = bag.available
    chosen: dict[str, list[str]] = {}
    if dvl_fields and "dvl" in wanted:
        topics = {**topics, "dvl": _mapped_topic(topics, dvl_fields)}
    for stream in wanted:
        types = STREAM_TYPES[stream]
        if stream in topics:
            topic = topics[stream]
            if topic not in available:
                raise DataError(f"topic {topic} (given for {stream}) is not in the bag; it has "
                                f"{sorted(available)}", source, field=topic)
            if stream == "dvl" and dvl_fields:
                bag_fields.check_paths(dvl_fields, bag.reader.typestore.fielddefs, available[topic], source, topic)
            elif available[topic] not in types:
                raise DataError(f"topic {topic} has type {available[topic]}, which graphnav cannot read as "
                                f"{stream} (accepted: {', '.join(types)}){_way_forward(stream, bag, topic)}", source,
                                field=topic)
            chosen[stream] = [topic]
            continue
        found = _candidates(available, stream)
        if stream == "dvl" and found:
            beams = [t for t in found if available[t] != TWIST_DVL]
            found = beams or found
            if not beams:
                warnings.warn(f"{source}: no DVL message; the velocity-only {found[0]} ({TWIST_DVL}) is used as the "
                              f"DVL{_vendor_dvl_hint(bag)}", RuntimeWarning, stacklevel=3)
        if found:
            chosen[stream] = found
    for stream in required:
        if stream not in chosen:
            raise DataError(f"no {stream} topic: need a topic of type {' or '.join(STREAM_TYPES[stream])}; the bag "
                            f"has {', '.join(f'{t} ({ty})' for t, ty in sorted(available.items())) or 'no topics'}"
                            f"{_way_forward(stream, bag)}", source, field=stream)
    return chosen


def _vendor_dvl_hint(bag: _Bag) -> str:
    """What a bag whose DVL falls back to a twist can do when it also has a topic named like a DVL in a type graphnav
    does not read (a vendor's DVL message, with its beams): read that topic through ``bag_topics.dvl``."""
    read = {ty for types in STREAM_TYPES.values() for ty in types}
    vendor = sorted(t for t, ty in bag.available.items() if ty not in read and bag_fields.looks_like_dvl(t, ty))
    if not vendor:
        return ""
    return (f"; {vendor[0]} ({bag.available[vendor[0]]}) looks like the DVL's own message, whose beams the twist "
            "lacks" + bag_fields.way_forward(bag.reader.typestore.fielddefs, bag.available, vendor[0]))


def _mapped_topic(topics: dict[str, str], dvl_fields: dict) -> str:
    """The DVL topic ``bag_topics.dvl`` names; ``--topic dvl=...`` may only repeat it."""
    topic = dvl_fields.get("topic")
    if not isinstance(topic, str) or not topic:
        raise ConfigError(f"{bag_fields.KEY} needs 'topic': the DVL topic whose fields it names")
    if topics.get("dvl", topic) != topic:
        raise ConfigError(f"--topic dvl={topics['dvl']} and {bag_fields.KEY}.topic {topic} name different topics")
    return topic


def _pick_one(stream: str, topics: list[str], source: str) -> str:
    if len(topics) > 1:
        warnings.warn(f"{source}: several {stream} topics {topics}; using {topics[0]} "
                      f"(choose with --topic {stream}=TOPIC)", RuntimeWarning, stacklevel=3)
    return topics[0]


class _Bag:
    """An open bag: its connections, the typestore of its own definitions (completed with graphnav's) and the
    decoding of one topic's messages."""

    def __init__(self, reader, source: str, meta: dict):
        self.reader, self.source, self.meta = reader, source, meta
        default = typestore()
        missing = {k: v for k, v in default.fielddefs.items() if k not in reader.typestore.fielddefs}
        reader.typestore.register(missing)
        self.available = {c.topic: c.msgtype for c in reader.connections}

    def _embedded(self, conns) -> bool:
        from rosbags.interfaces import MessageDefinitionFormat
        return all(c.msgdef.format != MessageDefinitionFormat.NONE for c in conns)

    def _decoder(self, topic: str, conns):
        """How to decode ``topic``: the bag's typestore, or for a ``dvl_msgs/DVL`` without its definition the
        released variant that fits the recorded bytes."""
        msgtype = conns[0].msgtype
        if msgtype != WL_DVL or not self.reader.is2 or self._embedded(conns):
            if msgtype == WL_DVL:
                self.meta["dvl_definition"] = "embedded in the bag"
            return self.reader.deserialize
        raws = [raw for _, _, raw in self.reader.messages(connections=conns)][:FIT_MESSAGES]
        try:
            name, store = fit_definition(raws)
        except ValueError as exc:
            raise DataError(f"{WL_DVL} without an embedded definition matches none of the released ones: {exc}",
                            self.source, field=topic) from None
        self.meta["dvl_definition"] = f"{name} (the bag embeds none; it decodes the recorded messages exactly)"
        add_note(self.meta, "dvl", f"message definition: {self.meta['dvl_definition']}")
        return store.deserialize_cdr

    def topic(self, topic: str) -> tuple[str, np.ndarray | None, np.ndarray, list]:
        """(msgtype, header stamps ns or None, receive stamps ns, decoded messages) of ``topic``."""
        conns = [c for c in self.reader.connections if c.topic == topic]
        msgtype = conns[0].msgtype
        decode = self._decoder(topic, conns)
        header, receive, rows = [], [], []
        for conn, log_ns, raw in self.reader.messages(connections=conns):
            try:
                msg = decode(raw, conn.msgtype)
            except Exception as exc:  # noqa: BLE001 - any decoding failure is reported with the topic
                raise DataError(f"message {len(rows)} of type {conn.msgtype} cannot be decoded: {exc}",
                                self.source, len(rows), topic) from None
            if hasattr(msg, "header"):
                header.append(int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec))
            receive.append(int(log_ns))
            rows.append(msg)
        if not rows:
            raise DataError(f"topic {topic} has no messages", self.source, field=topic)
        head = np.array(header, np.int64) if len(header) == len(rows) else None
        return msgtype, head, np.array(receive, np.int64), rows


#: The magic an MCAP file begins and ends with; a file that begins with it but does not end with it was cut.
MCAP_MAGIC = b"\x89MCAP0\r\n"


def _cut_mcap(path: Path) -> Path | None:
    """The MCAP file of ``path`` (the file, or one in a bag folder) that begins with the MCAP magic but does not end
    with it: a recording cut mid-write (the recorder killed, the disk full, the power lost); None when there is none."""
    for f in ([path] if path.is_file() else sorted(path.glob("*.mcap"))):
        with open(f, "rb") as fh:
            head = fh.read(len(MCAP_MAGIC))
            fh.seek(max(0, f.stat().st_size - len(MCAP_MAGIC)))
            if head == MCAP_MAGIC and fh.read() != MCAP_MAGIC:
                return f
    return None


def _open_reader(path: Path, source: str):
    require_rosbags()
    from rosbags.highlevel import AnyReader
    reader = AnyReader([path], default_typestore=typestore())
    try:
        reader.open()
    except Exception as exc:  # noqa: BLE001 - rosbags raises several reader error types
        cut = _cut_mcap(path)
        if cut is not None:
            raise DataError(f"cannot open as a ROS bag: {cut} ends before its MCAP footer, a recording cut mid-write "
                            "(the recorder killed, the disk full, the power lost); the mcap CLI's `mcap recover "
                            f"{cut.name} -o recovered.mcap` rewrites the chunks that were complete into a new file "
                            f"({type(exc).__name__}: {exc})", source) from None
        raise DataError(f"cannot open as a ROS bag: {type(exc).__name__}: {exc}", source) from None
    return reader


def read_streams(path: str | Path, topics: dict[str, str] | None = None, wanted: tuple[str, ...] = tuple(STREAM_TYPES),
                 required: tuple[str, ...] = REQUIRED_STREAMS, meta: dict | None = None, dvl_fields: dict | None = None
                 ) -> dict[str, list[Stream]]:
    """Stream -> the decoded candidate topics (the override alone when given), stamps chosen per topic by
    :func:`graphnav.io.bag_stamps.choose_stamps`, messages published twice dropped
    (:func:`graphnav.io.bag_convert.decoded_stream`); notes and counts go to ``meta``. ``dvl_fields``: the
    configuration's ``bag_topics.dvl`` (:mod:`graphnav.io.bag_fields`), whose topic is the DVL's. The IMU's topics
    are read first: the other topics' header clocks are judged against its (the mission's) clock."""
    from graphnav.io.bag_stamps import header_minus_receive_s
    path = Path(path)
    source = str(path)
    meta = {} if meta is None else meta
    if not path.exists():
        raise DataError("bag not found", source)
    kind = bag_kind(path)
    if kind is None:
        raise DataError("not a ROS bag: no ROS 1 '#ROSBAG V2.0', MCAP or sqlite3 header, and no metadata.yaml "
                        "in a folder", source)
    meta["bag_kind"] = kind
    with readable_path(path, kind) as readable:
        reader = _open_reader(readable, source)
        try:
            bag = _Bag(reader, source, meta)
            chosen = _choose_topics(bag, topics or {}, source, wanted, required, dvl_fields)
            decoded: dict[str, Stream] = {}
            out: dict[str, list[Stream]] = {}
            clock_s = 0.0       # the IMU's header minus receive time: the mission's clock seen from the recorder's
            for stream, names in sorted(chosen.items(), key=lambda kv: kv[0] != "imu"):
                for topic in names:
                    if topic not in decoded:
                        msgtype, head, rx, rows = bag.topic(topic)
                        decoded[topic] = conv.decoded_stream(topic, msgtype, head, rx, rows, stream,
                                                             f"{source}:{topic}", clock_s)
                    out.setdefault(stream, []).append(decoded[topic])
                if stream == "imu" and names:
                    s = decoded[names[0]]
                    clock_s = header_minus_receive_s(s.t_ns, s.receive_ns, s.stamp_kind)
            return {stream: out[stream] for stream in chosen if stream in out}
        finally:
            reader.close()


def _record(meta: dict, stream: str, s: Stream, t0_ns: int, source: str, warned: bool = False) -> None:
    """Counts and notes of a chosen topic (refused when its stamps jump by days,
    :func:`graphnav.io.bag_convert.check_stamp_jump`): what it read (including messages its stamps could not order
    and those written twice, warned about here unless ``warned``: the IMU's topic read again as the heading; the
    stamps repaired and doubted), and, but for a ``sensor_msgs/Imu`` topic (whose steps
    :func:`graphnav.io.bag_convert.imu` says), the messages stamped on the point of the one before them, doubted
    (:func:`graphnav.core.screening.say_close_samples`), as a log's rows are."""
    conv.check_stamp_jump(s, t0_ns, source)
    t = (s.t_ns - t0_ns) / 1e9
    dropped = s.n_read - len(t)
    count_read(meta, stream, np.concatenate([t, np.full(dropped, np.nan)]), f"{source}:{s.topic} ({s.msgtype})",
               shown_rate_hz(stream, t))
    for entry in s.log.values():
        for reason, n in entry["refused"].items():
            count_refused(meta, stream, reason, n)
        for reason, n in entry.get("doubted", {}).items():
            count_doubted(meta, stream, reason, n)
        for note in entry["notes"]:
            add_note(meta, stream, note)
    if not warned:
        conv.warn_written_twice(s, t0_ns, source)
    if s.msgtype != IMU:        # an AHRS's close steps are its clock's jitter or packets, as the IMU's are
        say_close_samples(t, None, f"{source}:{s.topic}", stream, meta, where=conv.messages(s, t0_ns), stacklevel=4)


def _heading_stream(streams: dict[str, list[Stream]], topics: dict[str, str], imu_topic: str, source: str,
                    meta: dict) -> Stream | None:
    """The heading source: the override, else an AHRS (the IMU topic itself first), a heading topic, a pose."""
    cands = streams.get("heading", [])
    if "heading" in topics:
        return cands[0]
    checked = {s.topic: conv.ahrs_check(s.rows) for s in cands if s.msgtype == IMU}
    for topic, (ok, why) in checked.items():
        if not ok:
            add_note(meta, "heading", f"{topic} is not an AHRS: {why}")
    ahrs = sorted((s for s in cands if s.msgtype == IMU and checked[s.topic][0]), key=lambda s: s.topic != imu_topic)
    rest = [s for s in cands if s.msgtype != IMU]
    ordered = ahrs + rest
    if len(ordered) > 1:
        warnings.warn(f"{source}: several heading sources {[s.topic for s in ordered]}; using {ordered[0].topic} "
                      "(choose with --topic heading=TOPIC)", RuntimeWarning, stacklevel=3)
    return ordered[0] if ordered else None


def _apply_beam_geometry(config: SensorConfig, info: dict, source: str) -> SensorConfig:
    """The marine_acoustic_msgs message carries the beam geometry: use it (theta from the mean z component,
    psi per beam)."""
    if "beam_unit_vec_d" not in info:
        return config
    u = np.asarray(info["beam_unit_vec_d"])
    theta = float(np.arccos(np.clip(np.mean(u[:, 2]), -1, 1)))
    psi = np.arctan2(u[:, 1], u[:, 0])
    if np.max(np.abs(u[:, 2] - np.cos(theta))) > 1e-3:
        warnings.warn(f"{source}: beam_unit_vec inclinations differ ({np.degrees(np.arccos(u[:, 2]))} deg); "
                      f"using their mean {np.degrees(theta):.2f} deg", RuntimeWarning, stacklevel=3)
    config.dvl = dataclasses.replace(config.dvl, theta_rad=theta, psi_rad=psi)
    return config


def load_bag(path: str | Path, config: SensorConfig | None = None, topics: dict[str, str] | None = None,
             name: str | None = None, atmospheric_pressure_configured: bool = False, screen: bool = True) -> Mission:
    """A :class:`Mission` from a ROS bag (see the module docstring), screened as every reader's rows are
    (:func:`graphnav.io.screened.screen_mission`: IMU messages beyond full scale or spiking, DVL pings outside the
    vehicle's envelope, depth and reference samples out of range, each refused and counted); read alone it kept them
    (a 500 m/s^2 IMU message used without a word), where ``graphnav smooth`` refused them.

    ``atmospheric_pressure_configured``: subtract ``config.atmospheric_pressure_pa`` as given instead of
    estimating the surface pressure from the first seconds of the record. ``screen=False``: the mission as read, only
    its messages holding no measurement refused (to screen later, once)."""
    from graphnav.io.bag_stamps import compare_clocks, header_minus_receive_s, latency_rate
    path = Path(path)
    config = dataclasses.replace(config) if config is not None else SensorConfig()
    topics = topics or {}
    source = str(path)
    meta: dict = {"source": source}
    streams = read_streams(path, topics, meta=meta, dvl_fields=config.bag_topics.get("dvl"))
    imu_s = streams["imu"][0] if "imu" in topics else _pick_one("imu", streams["imu"], source)
    steps: list = []
    stepped = conv.header_clock_steps_removed(imu_s, source, meta, steps)
    clock_s = header_minus_receive_s(stepped.t_ns, stepped.receive_ns, stepped.stamp_kind)
    clock_rate = latency_rate(stepped.t_ns, stepped.receive_ns)[0] if stepped.stamp_kind == "header" else None
    # the IMU's topic read again as the heading (an AHRS) moves with it; the other topics whose header clock stepped
    # with the IMU's move back with it, then each other topic's own header clock steps are taken out as the IMU's
    own: dict[int, Stream] = {id(imu_s): stepped}
    for kind, found in streams.items():
        for s in found:
            if kind != "imu" and id(s) not in own:      # a topic read for two streams is moved (and warned) once
                shared = conv.shared_clock_step_removed(s, steps, kind, source, meta)
                own[id(s)] = conv.header_clock_drift_removed(
                    conv.header_clock_steps_removed(shared, source, meta, kind=kind, clock_s=clock_s), source, meta,
                    kind, clock_rate)
    streams = {kind: [own.get(id(s), s) for s in found] for kind, found in streams.items()}
    imu_s = stepped
    dvl_s = streams["dvl"][0] if "dvl" in topics else _pick_one("dvl", streams["dvl"], source)
    t0_ns = int(imu_s.t_ns[0])
    meta.update({"format": "ros1" if meta["bag_kind"] == "ros1" else "rosbag2", "t0_unix_ns": t0_ns})
    _record(meta, "imu", imu_s, t0_ns, source)
    imu = conv.imu(imu_s, t0_ns, source, meta)
    _record(meta, "dvl", dvl_s, t0_ns, source)
    dvl, info = conv.dvl(dvl_s, t0_ns, config, source, meta)
    meta["dvl_ping_where"] = conv.messages(dvl_s, t0_ns)
    config = _apply_beam_geometry(config, info, source)
    depth = None
    positive = conv.declared_positive(config)
    cands = {s.topic: (s, conv.depth_candidate(s, config, atmospheric_pressure_configured, positive))
             for s in streams.get("depth", [])}
    chosen = conv.choose_depth(cands, source, meta) if cands else None
    conv.check_declared_positive(positive, cands[chosen][0] if chosen else None, source, meta)
    if chosen:
        s, cand = cands[chosen]
        _record(meta, "depth", s, t0_ns, source)
        depth = conv.depth(s, cand, t0_ns, source, meta, positive)
    heading = None
    h = _heading_stream(streams, topics, imu_s.topic, source, meta)
    if h is not None:
        _record(meta, "heading", h, t0_ns, source, warned=h is imu_s)
        heading = conv.heading(h, t0_ns, source, meta)
        meta["heading_source"] = f"{h.topic} ({h.msgtype})"
    else:
        meta["heading_source"] = "none"        # prepare says whether the configured gyro can gyrocompass
    gt = fixes = g = f = None
    if streams.get("gt"):
        g = streams["gt"][0] if "gt" in topics else _pick_one("gt", streams["gt"], source)
        _record(meta, "gt", g, t0_ns, source)
        gt = conv.gt(g, t0_ns, source)
    if streams.get("fix"):
        f = streams["fix"][0] if "fix" in topics else _pick_one("fix", streams["fix"], source)
        _record(meta, "fix", f, t0_ns, source)
        fixes = conv.fixes(f, t0_ns, source, meta)
    used = {"imu": imu_s, "dvl": dvl_s, **({"depth": cands[chosen][0]} if chosen else {}),
            **({"heading": h} if h is not None else {})}
    compare_clocks({k: (s.t_ns, s.receive_ns, s.stamp_kind) for k, s in used.items()}, meta, source)
    meta["topics"] = {k: f"{s.topic} ({s.msgtype})" for k, s in used.items()}
    meta.update(info)
    imu, depth = _units(imu, depth, config, meta)
    read = {"dvl": (dvl_s, dvl), "depth": (cands[chosen][0] if chosen else None, depth),
            "heading": (h, heading), "gt": (g, gt), "fix": (f, fixes)}
    dvl, depth, heading, gt, fixes = (_onto_imu_clock(imu, imu_s, stream, s, data, meta)
                                      for stream, (s, data) in read.items())
    _reference_turn(imu, gt, meta)
    frame_id = imu_s.rows[0].header.frame_id
    # a frame_id is a convention, not a user's declaration: the prepare step corrects the axes the data contradict
    meta.update(prepared=False, prepare={"format": "bag", "dvl_clock": "auto", "imu_frame": {
        "declared": None, "fields": imu_s.topic, "what": f"the IMU frame_id {frame_id!r} of {imu_s.topic} ("
        + ("FRD" if conv.frame_is(frame_id, "_frd") else "REP-103 FLU: no _frd suffix") + ")"}})
    unit = (config.bag_topics.get("dvl") or {}).get("velocity_unit")
    if unit:                    # a declared unit the data may not contradict (the prepare step checks it)
        meta["prepare"]["dvl_unit"] = {"unit": unit, "key": f"{bag_fields.KEY}.velocity_unit"}
    if depth is None:
        meta["depth_source"] = "none"
    elif positive:              # a declared convention the data may not contradict (the prepare step checks it)
        meta["prepare"]["depth_positive"] = positive
    elif meta.get("depth_turned_up"):       # turned by the reader: the vertical velocity must confirm it
        meta["prepare"]["depth_turned_up"] = True
    mission = Mission(name or (path.stem if path.is_file() else path.name), imu, dvl, config, gt, depth, meta,
                      heading=heading, fixes=fixes)
    if not screen:
        return mission
    from graphnav.io.screened import screen_mission
    return screen_mission(mission)


def warn_depth_turn_unconfirmed(mission: Mission) -> None:
    """Warn (at the caller's caller, as the caller's own warning would be) about and note a bag's depth topic the reader
    turned positive down (read as positive up, :func:`graphnav.io.bag_convert.turned_positive_up`) in a mission not
    prepared: only the prepare step's vertical motion confirms the turn. Kept turned: as read, the range check would
    have dropped every sample. For every path that hands on a mission unprepared (``load_mission(prepare=False)``,
    ``describe`` without ``prepare``)."""
    if not mission.meta.get("prepare", {}).get("depth_turned_up") or mission.meta.get("prepared"):
        return
    text = ("read as depth positive up and turned positive down, unconfirmed: the mission is not prepared, and only "
            "the prepare step checks the turn against the vehicle's vertical motion (prepare it, or declare "
            "bag_topics.depth.positive)")
    warnings.warn(f"{mission.depth.source}, field 'data': {text}", RuntimeWarning, stacklevel=3)
    add_note(mission.meta, "depth", text)


def _units(imu, depth, config: SensorConfig, meta: dict):
    """The IMU in SI (a driver's gyro in deg/s, an accelerometer in g: :func:`graphnav.io.units.check_units`;
    bag stamps are nanoseconds by definition) and the depth checked, each change warned about and noted in meta."""
    from graphnav.io.units import check_units
    checked = check_units({"imu": imu, "depth": depth}, config, meta, declared={"time": "s"})
    return checked["imu"], checked["depth"]


def _reference_turn(imu, gt, meta: dict) -> None:
    """The reference topic's attitude left for the prepare step to judge a gyro the tilt kinematics could not
    (:func:`graphnav.io.units.keep_reference_turn`): a quaternion has no unit to settle, so no tilt is needed."""
    from graphnav.core.rotations import C_b_n_to_euler
    from graphnav.io.units import keep_reference_turn
    if gt is not None and len(gt.t):
        keep_reference_turn(meta, gt.t, C_b_n_to_euler(gt.C_b_n), imu.t, imu.omega_b,
                            f"{gt.source}, field pose.pose.orientation", "a quaternion, whose angles have no unit")


#: How the clock notes name a stream.
_LABELS = {"dvl": "DVL", "gt": "GT", "fix": "fix"}


def _onto_imu_clock(imu, imu_s: Stream, stream: str, s: Stream | None, data, meta: dict):
    """``data`` (a stream read from topic ``s``, with stamps ``t`` in s from the first IMU stamp) on the IMU's
    clock. A stream whose span is off the IMU's (:func:`graphnav.core.timeseries.on_the_imu_clock`) is moved
    through the recorder's receive clock, which every message shares: by the difference of the two streams'
    header-minus-receive offsets (0 for a stream on receive time). Each move is warned about, noted and kept in
    ``meta["clock_offsets"]``. A stream still off is left so: the prepare step estimates the DVL's and reference's
    clock offset from the data (:mod:`graphnav.calibration.clock`) and leaves out a depth, reference or heading still
    off, optional all three (:func:`graphnav.io.stream_counts.warn_off_the_imu_clock`); fixes may all be taken before
    the IMU started (on deck) and are screened against its span by the estimators."""
    import dataclasses as dc

    from graphnav.core.timeseries import on_the_imu_clock
    if data is None or not len(data.t) or on_the_imu_clock(data.t, imu.t):
        return data
    source = meta.get("source", "bag")
    label = _LABELS.get(stream, stream)
    from graphnav.io.bag_stamps import header_minus_receive_s
    shift = (header_minus_receive_s(s.t_ns, s.receive_ns, s.stamp_kind)
             - header_minus_receive_s(imu_s.t_ns, imu_s.receive_ns, imu_s.stamp_kind))
    if shift:
        data = dc.replace(data, t=data.t - shift)
        set_span(meta, stream, data.t)
        note = (f"clock: {label} header stamps moved by {-shift:+.3f} s onto the IMU clock through the bag's "
                "receive clock (both streams' header-minus-receive offsets)")
        add_note(meta, stream, note)
        warnings.warn(f"{source}: {note}", RuntimeWarning, stacklevel=3)
        meta.setdefault("clock_offsets", {})[f"{stream}_from_receive_clock_s"] = -shift
    return data


def load_odometry(path: str | Path, topic: str | None = None):
    """The ``nav_msgs/msg/Odometry`` of a bag (e.g. what :func:`write_odometry_bag` wrote) as a
    :class:`~graphnav.core.solution.NavSolution` in NED/FRD with absolute stamps (Unix s) and the covariances
    in its conventions: velocity from ``twist.covariance``, position and attitude (``cov_p_n``, ``cov_rot_b``)
    from ``pose.covariance``; each None when its block is all zero or :data:`UNKNOWN_VARIANCE` in every message."""
    from graphnav.core.solution import NavSolution
    found = read_streams(path, {"gt": topic} if topic else {}, wanted=("gt",), required=("gt",))["gt"]
    s = found[0] if topic else _pick_one("gt", found, str(path))
    conv.warn_written_twice(s, 0, str(path))
    gt = conv.gt(s, 0, str(path))
    child_frd = conv.frame_is(s.rows[0].child_frame_id, "_frd")
    B = np.eye(3) if child_frd else FLU_FRD
    A = np.eye(3) if conv.frame_is(s.rows[0].header.frame_id, "_ned") else ENU_NED      # world <-> NED
    twist = np.array([np.asarray(m.twist.covariance, float).reshape(6, 6) for m in s.rows])
    pose = np.array([np.asarray(m.pose.covariance, float).reshape(6, 6) for m in s.rows])
    R = np.einsum("kij,jl->kil", gt.C_b_n, B)                                       # child -> NED
    cov_v = _known(twist[:, :3, :3])
    cov_p = _known(pose[:, :3, :3])
    cov_rot = _known(pose[:, 3:, 3:])
    return NavSolution(
        s.topic, gt.t, gt.p_n, gt.v_n, gt.C_b_n,
        cov_v_n=None if cov_v is None else np.einsum("kij,kjl,kml->kim", R, cov_v, R),
        cov_p_n=None if cov_p is None else A @ cov_p @ A.T,
        # rotation about the world's fixed axes -> NED -> body axes (right perturbation)
        cov_rot_b=None if cov_rot is None else np.einsum("kji,jl,klm,nm,knp->kip", gt.C_b_n, A, cov_rot, A, gt.C_b_n))


def _known(blocks: np.ndarray) -> np.ndarray | None:
    """(K,3,3) covariance blocks, or None when no message carries one (all zero, or the unknown marker)."""
    unknown = np.all(blocks == 0, axis=(1, 2)) | np.all(np.isclose(blocks, np.eye(3) * UNKNOWN_VARIANCE), axis=(1, 2))
    return None if np.all(unknown) else blocks


def read_dvl_log(path: str | Path, topic: str | None = None, config: SensorConfig | None = None):
    """The DVL topic of a bag on its own, as a :class:`~graphnav.core.dvl_log.DvlLog` (stamps in Unix s,
    chosen as :func:`load_bag` chooses them; ``config`` gives ``C_d_b`` for a body-frame twist)."""
    from graphnav.core.dvl_log import DvlLog
    config = config or SensorConfig()
    meta: dict = {}
    found = read_streams(path, {"dvl": topic} if topic else {}, wanted=("dvl",), required=("dvl",), meta=meta,
                         dvl_fields=config.bag_topics.get("dvl"))["dvl"]
    s = found[0] if topic else _pick_one("dvl", found, str(path))
    _record(meta, "dvl", s, 0, str(path))
    dvl, info = conv.dvl(s, 0, config, str(path), meta)
    entry = meta["streams"]["dvl"]
    has_beams = bool(dvl.valid.any())
    return DvlLog(dvl.t, dvl.v_d, dvl.v_d_valid, "instrument" if has_beams else "dvl",
                  beams=dvl.beams if has_beams else None, beam_valid=dvl.valid if has_beams else None,
                  instrument={"message": s.msgtype, "topic": s.topic, "stamps": s.stamp_kind,
                              **({"definition": meta["dvl_definition"]} if "dvl_definition" in meta else {}), **info},
                  counts={"read": entry["read"], "valid": int(dvl.v_d_valid.sum()), **entry["refused"]},
                  source=f"{path}:{s.topic}")


# --- writing -----------------------------------------------------------------------------------------------
def _writer(path: Path, storage: str):
    require_rosbags()
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


#: Variance on the diagonal of a covariance block of an Odometry message whose estimate is diverged ("do not
#: use"), (m/s)^2, m^2 and rad^2 alike.
DIVERGED_VARIANCE = 1e6
#: Variance on the diagonal of a block the estimator does not estimate ("no information"): the angular rate
#: (the twist's angular part is written as zero), the position of the paper's 12-state EKF.
UNKNOWN_VARIANCE = 1e6


def odometry_covariances(solution) -> tuple[np.ndarray, np.ndarray]:
    """(pose, twist) covariances (K,6,6) of a :class:`~graphnav.core.solution.NavSolution` in ROS' frames and
    order (REP 103 / ``geometry_msgs``):

    - pose, in ``odom`` ENU: ``[x, y, z, rotation about the fixed x, y, z axes]``. Position ``A P_n A^T`` with
      ``A`` the NED-to-ENU axis permutation; rotation: the body-axes right perturbation
      ``C_b_n Exp(theta) = Exp(C_b_n theta) C_b_n`` is the NED-fixed-axes perturbation ``C_b_n theta``, so
      ``A C P_rot C^T A^T`` (the FRD-to-FLU change of the child frame does not change a fixed-axes perturbation).
    - twist, in ``base_link`` FLU: ``[linear, angular]``; linear ``F C^T P_v C F`` (``F`` = FRD-to-FLU),
      angular unknown.

    The position-attitude cross block is zero: the estimators carry separate marginals; for the same reason the
    attitude's share of the body-frame velocity's uncertainty (``[v_b]x P_rot [v_b]x^T``, about 1 mm/s at 1.5 m/s
    and 0.05 deg, against a velocity sigma of centimetres per second) is left out. A block the solution has
    no covariance for carries :data:`UNKNOWN_VARIANCE` on its diagonal; a diverged epoch
    (``solution.info["health_state"]``) :data:`DIVERGED_VARIANCE` on every diagonal: Odometry has no status
    field, and a consumer that weighs by covariance then ignores it."""
    K = len(solution.t)
    C = solution.C_b_n
    unknown = np.broadcast_to(np.eye(3) * UNKNOWN_VARIANCE, (K, 3, 3))
    pose = np.zeros((K, 6, 6))
    twist = np.zeros((K, 6, 6))
    pose[:, :3, :3] = unknown if solution.cov_p_n is None else ENU_NED @ solution.cov_p_n @ ENU_NED.T
    pose[:, 3:, 3:] = unknown if solution.cov_rot_b is None else np.einsum(
        "ij,kjl,klm,knm,pn->kip", ENU_NED, C, solution.cov_rot_b, C, ENU_NED)
    twist[:, :3, :3] = unknown if solution.cov_v_n is None else np.einsum(
        "ij,kli,klm,kmn,np->kjp", FLU_FRD, C, solution.cov_v_n, C, FLU_FRD)
    twist[:, 3:, 3:] = unknown
    health = (solution.info or {}).get("health_state") or [None] * K
    diverged = np.array([h == "diverged" for h in health], bool)
    for cov in (pose, twist):
        cov[diverged] = np.eye(6) * DIVERGED_VARIANCE
    # symmetric to the last bit: some consumers check it before they invert
    return 0.5 * (pose + np.swapaxes(pose, 1, 2)), 0.5 * (twist + np.swapaxes(twist, 1, 2))


def odometry_messages(solution, store, t0_unix_ns: int = 0) -> list[tuple[int, object]]:
    """(stamp ns, ``nav_msgs/msg/Odometry``) per epoch of a :class:`~graphnav.core.solution.NavSolution`, in
    REP-103 frames (``odom`` ENU, ``base_link`` FLU), with the covariances of :func:`odometry_covariances`."""
    T = store.types
    C_flu_enu = np.einsum("ij,kjl,lm->kim", ENU_NED, solution.C_b_n, FLU_FRD)
    q = Rotation.from_matrix(C_flu_enu).as_quat()
    p_enu = solution.p_n @ ENU_NED.T
    v_flu = np.einsum("kji,kj->ki", solution.C_b_n, solution.v_n) @ FLU_FRD
    pose_cov, twist_cov = odometry_covariances(solution)
    V3 = T["geometry_msgs/msg/Vector3"]
    out = []
    for k in range(len(solution.t)):
        t_ns = int(t0_unix_ns + round(float(solution.t[k]) * 1e9))
        out.append((t_ns, T["nav_msgs/msg/Odometry"](
            header=_header(store, t_ns, "odom"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=p_enu[k, 0], y=p_enu[k, 1], z=p_enu[k, 2]),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=q[k, 0], y=q[k, 1], z=q[k, 2], w=q[k, 3])),
                covariance=pose_cov[k].reshape(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=V3(x=v_flu[k, 0], y=v_flu[k, 1], z=v_flu[k, 2]),
                                                   angular=V3(x=0.0, y=0.0, z=0.0)),
                covariance=twist_cov[k].reshape(36)))))
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
                      gt: bool = True, imu_clock_offset_s: float = 0.0, change=None) -> Path:
    """Record a mission as a ROS 2 bag the way a vehicle would (REP-103 FLU IMU, the DVL in its own frame,
    pressure, reference odometry): for tests, demos and handing simulated missions to ROS tools. Every message
    is received at its mission time ``t0_unix_ns + t``; ``imu_clock_offset_s`` (s) puts the IMU's header stamps
    on a clock that far from the other streams' (an IMU whose clock never synchronised). ``change(topic, k, msg,
    receive_ns)`` (``k``: the message's index in its topic), when given, may alter each message (its header stamp, a
    value) and returns its receive time, ns, or None to leave it out: a damaged recording (``graphnav faults``)."""
    path = Path(path)
    store = typestore()
    T = store.types
    cfg = mission.config
    H = _header
    V3 = T["geometry_msgs/msg/Vector3"]
    msgs: list[tuple[int, str, object]] = []
    imu_f, imu_w = flu_frd(mission.imu.f_b), flu_frd(mission.imu.omega_b)
    for k, t in enumerate(mission.imu.t):
        t_ns = t0_unix_ns + round(t * 1e9)
        msgs.append((t_ns, "/imu/data", T["sensor_msgs/msg/Imu"](
            header=H(store, t_ns + round(imu_clock_offset_s * 1e9), "imu_link"),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0., y=0., z=0., w=1.),
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
    if mission.fixes is not None:
        f = mission.fixes
        for k, t in enumerate(f.t):
            t_ns = t0_unix_ns + round(t * 1e9)
            var = float(f.sigma_m[k]) ** 2
            msgs.append((t_ns, "/gnss/fix", T[NAVSATFIX](
                header=H(store, t_ns, "gnss_link"), status=T["sensor_msgs/msg/NavSatStatus"](status=0, service=1),
                latitude=float(np.degrees(f.lat[k])), longitude=float(np.degrees(f.lon[k])), altitude=0.0,
                position_covariance=np.array([var, 0.0, 0.0, 0.0, var, 0.0, 0.0, 0.0, 4 * var]),
                position_covariance_type=2)))
    if gt and mission.gt is not None:
        from graphnav.core.solution import NavSolution
        g = mission.gt
        ref = NavSolution("GT", g.t, g.p_n, g.v_n, g.C_b_n)
        msgs += [(t_ns, "/reference/odometry", m) for t_ns, m in odometry_messages(ref, store, t0_unix_ns)]
    types = {"/imu/data": "sensor_msgs/msg/Imu", "/dvl/data": dvl_type,
             "/pressure": "sensor_msgs/msg/FluidPressure", "/depth": "std_msgs/msg/Float64",
             "/reference/odometry": "nav_msgs/msg/Odometry", "/gnss/fix": NAVSATFIX}
    if change is not None:
        msgs = _changed(msgs, change)
    msgs.sort(key=lambda m: m[0])
    with _writer(path, storage) as writer:
        conns = {topic: writer.add_connection(topic, typ, typestore=store) for topic, typ in types.items()
                 if any(m[1] == topic for m in msgs)}
        for t_ns, topic, msg in msgs:
            writer.write(conns[topic], t_ns, store.serialize_cdr(msg, types[topic]))
    return path


def _changed(msgs: list[tuple[int, str, object]], change) -> list[tuple[int, str, object]]:
    """``msgs`` (receive ns, topic, message; each topic's in its order) through ``change`` (see
    :func:`write_mission_bag`), those it returns None for left out."""
    seen: dict[str, int] = {}
    out = []
    for t_ns, topic, msg in msgs:
        k = seen[topic] = seen.get(topic, -1) + 1
        rx = change(topic, k, msg, t_ns)
        if rx is not None:
            out.append((int(rx), topic, msg))
    return out
