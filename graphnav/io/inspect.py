"""What a file or folder holds and whether graphnav will use it: the library behind ``graphnav info``.

:func:`describe` takes anything graphnav reads -- an A-KIT ``TrajectoryN`` folder, a CSV log with the
configuration's column map, a ROS 2 bag, a PD0 DVL file, a JSON-lines stream file -- and returns a plain dict
(JSON-ready): the format, the instrument(s), the DVL frame, each stream's samples read / used / refused with
the reasons (``Mission.meta["streams"]``, :mod:`graphnav.core.streams`), rates and time span, DVL speed and
beams per ping, depth range, and the notes and warnings the loaders made. It never refuses to describe: an
input graphnav cannot use is described with the reason (``usable`` False, ``reason``). Only a path that is
none of these formats gives ``format`` None.

With ``prepare`` (``graphnav info`` passes :func:`graphnav.calibration.preparation.prepare`), an A-KIT folder
gets its IMU axes and time offsets estimated against the GT, a log its DVL clock: a few seconds.
"""
from __future__ import annotations

import datetime as dt
import json
import re
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.errors import GraphnavError
from graphnav.core.imu_timing import imu_rate_hz, restamp_shared_stamps
from graphnav.core.mission import IMU_RATE_TOLERANCE
from graphnav.core.screening import say_imu_stamp_steps
from graphnav.core.streams import count_read, count_refused, stream_entry

#: File suffixes of a JSON-lines stream file (others are recognised by their first record).
JSONL_SUFFIXES = (".jsonl", ".ndjson", ".json")
#: A clock above this (s) is Unix time and is also shown as UTC.
UNIX_CLOCK_MIN_S = 1e8

FORMAT_NAMES = {"akit": "A-KIT TrajectoryN folder (IMU/DVL/GT CSV files)", "csv": "CSV log with the column map",
                "rosbag2": "ROS 2 bag", "pd0": "Teledyne RDI PD0 DVL file", "jsonl": "JSON-lines stream file",
                "missions": "folder of missions"}


# --- which format ------------------------------------------------------------------------------------------
def _is_jsonl(path: Path) -> bool:
    if not path.is_file():
        return False
    from graphnav.io.streamio import FIELDS
    try:
        with path.open(encoding="utf-8") as fh:
            for line in fh:
                if line.strip():
                    rec = json.loads(line)
                    return isinstance(rec, dict) and rec.get("type") in FIELDS
    except (UnicodeDecodeError, json.JSONDecodeError, OSError):
        return path.suffix.lower() in JSONL_SUFFIXES[:2]
    return path.suffix.lower() in JSONL_SUFFIXES[:2]


def _is_akit(path: Path) -> bool:
    """A folder with any of the A-KIT files (``IMU_*.csv``, ``DVL_*.csv``, ``GT_*.csv``) or named ``TrajectoryN``.

    One file is enough: a folder that lacks the IMU or the DVL file is still meant as an A-KIT folder, and reading
    it names the missing file, as ``graphnav smooth`` does (the GT file is optional)."""
    from graphnav.io.loaders import AKIT_COLUMNS
    return path.is_dir() and (re.fullmatch(r"Trajectory\d+", path.name) is not None
                              or any(any(path.glob(f"{k}_*.csv")) for k in AKIT_COLUMNS))


def _mission_folders(path: Path) -> list[str]:
    from graphnav.io import bags
    from graphnav.io.loaders import list_akit
    if not path.is_dir():
        return []
    found = [d.name for d in list_akit(path)]
    found += sorted(p.name for p in path.iterdir() if bags.is_bag(p))
    return found


def detect_format(path: str | Path, config: SensorConfig | None = None) -> str | None:
    """``"rosbag2"``, ``"pd0"``, ``"jsonl"``, ``"csv"``, ``"akit"``, ``"missions"`` (a folder of A-KIT folders or
    bags) or None (not something graphnav reads)."""
    from graphnav.io import bags, dvl_files
    path = Path(path)
    if not path.exists():
        return None
    if bags.is_bag(path):
        return "rosbag2"
    if dvl_files.is_dvl_file(path):
        return "pd0"
    if _is_jsonl(path):
        return "jsonl"
    if path.is_file() and path.suffix.lower() == ".csv":
        return "csv"
    if path.is_dir() and config is not None and config.csv_columns:
        return "csv"
    if _is_akit(path):
        return "akit"
    if _mission_folders(path):
        return "missions"
    return None


# --- the description ---------------------------------------------------------------------------------------
def describe(path: str | Path, config: SensorConfig | str | Path | None = None,
             topics: dict[str, str] | None = None, prepare: Callable | None = None) -> dict:
    """Describe ``path`` (module docstring).

    Args:
        path: a file or folder.
        config: a :class:`SensorConfig`, or the path of its JSON (the column map of a CSV log; the IMU that
            goes with a PD0 file).
        topics: bag stream -> topic overrides, as ``--topic``.
        prepare: applied to a mission once read (``graphnav info`` passes
            :func:`graphnav.calibration.preparation.prepare`: the axis signs, time offsets and clock offsets it
            estimates are then described too); None describes the mission as read.

    Returns:
        A JSON-ready dict: ``path``, ``format`` (None: not a file graphnav knows), ``usable``, ``use`` (what
        graphnav does with it), ``reason`` (why not usable), ``instrument``, ``dvl_frame``, ``clock``,
        ``time_span_s``, ``duration_s``, ``streams`` (per stream: ``source``, ``read``, ``used``,
        ``refused`` {reason: n}, ``rate_hz``, ``span_s``, ``notes``; ``usable`` False and ``reason`` for a stream
        left out), ``left_out`` {stream: reason} (an optional stream graphnav does not use: a depth or reference
        off the IMU span; the time span leaves it out), ``dvl`` (``speed_mps`` median/max, ``beams_per_ping``),
        ``depth_m`` (min/max), ``warnings`` (what reading it warned).
    """
    path = Path(path)
    config_path = None
    if isinstance(config, (str, Path)):
        config_path, config = config, None
    out = {"path": str(path), "format": None, "usable": False, "use": None, "reason": None, "instrument": {},
           "dvl_frame": None, "clock": None, "time_span_s": None, "duration_s": None, "streams": {}, "dvl": {},
           "depth_m": None, "warnings": []}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if config_path is not None:
                config = SensorConfig.load(config_path)
            fmt = detect_format(path, config)
            out["format"] = fmt
            if fmt is None:
                out["reason"] = ("not found" if not path.exists() else
                                 "not a format graphnav reads (A-KIT folder, CSV with a column map, ROS 2 bag, "
                                 "PD0, JSON-lines stream)")
            elif fmt == "missions":
                names = _mission_folders(path)
                out.update(usable=True, use="graphnav smooth / bench over every mission", missions=names,
                           reason=None)
            elif fmt == "pd0" and (config is None or "imu" not in (config.csv_columns or {})):
                out.update(_describe_dvl_file(path, config))
            elif fmt == "jsonl":
                out.update(_describe_jsonl(path, config))
            else:
                out.update(_describe_mission_path(path, config, config_path, topics, prepare))
        except GraphnavError as exc:
            out.update(usable=False, reason=str(exc))
        except (OSError, UnicodeDecodeError, ValueError) as exc:    # a damaged file is described, not a traceback
            out.update(usable=False, reason=f"cannot read {path}: {type(exc).__name__}: {exc}")
    out["warnings"] = _unique(str(w.message) for w in caught)
    out["format_name"] = FORMAT_NAMES.get(out["format"])
    return _jsonable(out)


def _unique(items) -> list[str]:
    seen = []
    for item in items:
        if item not in seen:
            seen.append(item)
    return seen


def _jsonable(obj):
    from graphnav.io.outputs import to_jsonable
    return to_jsonable(obj)


def _span(streams: dict) -> tuple[list[float] | None, float | None]:
    """The span (s) of the streams the mission uses: not of one left out (``usable`` False), days off the IMU's."""
    spans = [e["span_s"] for e in streams.values() if e.get("span_s") and e.get("usable", True)]
    if not spans:
        return None, None
    t0, t1 = min(s[0] for s in spans), max(s[1] for s in spans)
    return [t0, t1], t1 - t0


def _speed_stats(v: np.ndarray) -> dict | None:
    v = np.asarray(v, float)
    ok = np.all(np.isfinite(v), axis=1) if v.ndim == 2 and len(v) else np.zeros(0, bool)
    if not ok.any():
        return None
    speed = np.linalg.norm(v[ok], axis=1)
    return {"median": float(np.median(speed)), "max": float(np.max(speed)), "pings": int(ok.sum())}


def _beams_per_ping(valid: np.ndarray) -> dict:
    n = np.asarray(valid, bool).sum(axis=1)
    return {str(k): int(np.sum(n == k)) for k in range(4, -1, -1) if np.any(n == k)}


def _depth_range(depth) -> dict | None:
    if depth is None:
        return None
    d = np.asarray(depth, float)
    d = d[np.isfinite(d)]
    return {"min": float(d.min()), "max": float(d.max())} if d.size else None


# --- missions (A-KIT, CSV, bags, PD0 with an IMU) ----------------------------------------------------------
def _describe_mission_path(path: Path, config, config_path, topics, prepare) -> dict:
    from graphnav.io.loaders import read_mission
    mission = read_mission(path, config_path, topics=topics) if config is None or config_path is not None \
        else _read_with_config(path, config, topics)
    if prepare is None:
        from graphnav.io.bags import warn_depth_turn_unconfirmed
        warn_depth_turn_unconfirmed(mission)
        return describe_mission(mission)
    return describe_mission(prepare(mission))


def _read_with_config(path: Path, config: SensorConfig, topics):
    """``read_mission`` for an in-memory configuration (it takes a JSON path)."""
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "config.json"
        config.save(cfg)
        from graphnav.io.loaders import read_mission
        return read_mission(path, cfg, topics=topics)


def _mission_instrument(mission) -> tuple[dict, str]:
    meta = mission.meta
    fmt = meta.get("format")
    inst = {"imu": mission.imu.source, "dvl": mission.dvl.source}
    if mission.depth is not None:
        inst["depth"] = mission.depth.source
    if mission.gt is not None:
        inst["ground_truth"] = mission.gt.source
    if fmt in ("rosbag2", "ros1"):
        inst.update(topics=meta.get("topics"), dvl_message=meta.get("dvl_message"))
        frame = "DVL frame of the message (beams; the instrument velocity turned to body with C_d_b)"
        if "dvl_fields" in meta:        # a vendor's message, read through bag_topics.dvl
            inst["dvl_fields"] = meta["dvl_fields"]
            frame = (f"the message's fields named by bag_topics.dvl (beams; the velocity in its declared "
                     f"{meta['dvl_fields']['frame']} frame, turned to body)")
    elif "pd0_instrument" in meta:
        inst["dvl_instrument"] = {"model": meta["pd0_instrument"], "beam_angle_deg": meta["pd0_beam_angle_deg"],
                                  "beam_pattern": meta["pd0_beam_pattern"]}
        frame = "beam (PD0 bottom track)"
    elif fmt == "csv":
        frame = "body velocity v_b (beams projected on the configured geometry)" if meta.get("beams_from_v_b") \
            else "beam (along-beam velocities)"
    elif meta.get("written_beams"):
        written = meta["written_beams"]
        frame = (f"DVL frame of the configuration (the body frame unless the DVL is mounted off it): the files hold "
                 f"the DVL velocity, and the beams graphnav wrote beside it ({written['pings']} pings, "
                 f"{written.get('few_beams', 0)} with fewer than three beams; {written['made']} made by the DVL "
                 "error model)")
    else:
        frame = "body: the files hold the DVL velocity in the body frame; beams made by the DVL error model"
    return inst, frame


def describe_mission(mission) -> dict:
    """The description of a loaded :class:`~graphnav.core.mission.Mission` (see :func:`describe`)."""
    from graphnav.core.dvl import beam_velocity_b
    from graphnav.io.stream_counts import ensure_streams
    streams = ensure_streams(mission)
    inst, frame = _mission_instrument(mission)
    dvl = mission.dvl
    v = beam_velocity_b(dvl, mission.config.dvl)
    span, duration = _span(streams)
    use = "IMU/DVL estimators: graphnav smooth / online --data PATH"
    refused = _refused_stream(streams)
    return {
        "usable": refused is None, "use": use if refused is None else None, "reason": refused,
        "mission": mission.name, "instrument": inst, "dvl_frame": frame,
        "clock": _mission_clock(mission),
        "time_span_s": span, "duration_s": duration, "streams": streams, "ground_truth": mission.gt is not None,
        "dvl": {"speed_mps": _speed_stats(v), "beams_per_ping": _beams_per_ping(dvl.valid)},
        "depth_m": _depth_range(None if mission.depth is None else mission.depth.depth),
        "left_out": {name: e["reason"] for name, e in streams.items() if e.get("usable", True) is False},
    }


def _refused_stream(streams: dict) -> str | None:
    """Why the estimators cannot use the mission: its IMU or DVL stream refused for more than
    :data:`~graphnav.core.screening.MAX_REFUSED_FRACTION` (they would end the run, ``graphnav smooth`` with an
    error), or None. DVL pings outside the IMU span are not counted against it: the estimators skip them (a DVL
    that logged longer than the IMU), and a DVL off the IMU clock is the prepare step's error
    (:func:`graphnav.io.stream_counts.check_dvl_on_imu_clock`)."""
    from graphnav.core.screening import MAX_REFUSED_FRACTION
    from graphnav.io.stream_counts import OUTSIDE_IMU_SPAN
    for name in ("imu", "dvl"):
        entry = streams.get(name) or {}
        refused = {r: n for r, n in (entry.get("refused") or {}).items() if r != OUTSIDE_IMU_SPAN}
        read = (entry.get("read") or 0) - (entry.get("refused") or {}).get(OUTSIDE_IMU_SPAN, 0)
        if read > 0 and sum(refused.values()) > MAX_REFUSED_FRACTION * read:
            reasons = ", ".join(f"{n} {r}" for r, n in sorted(refused.items(), key=lambda kv: -kv[1]) if n)
            return (f"{entry.get('source') or name}: {sum(refused.values())} of {read} {name} samples refused "
                    f"({reasons}): more than {MAX_REFUSED_FRACTION:.0%} of the stream, which the estimators refuse")
    return None


def _mission_clock(mission) -> str:
    """What the mission's stamps count: seconds from the first IMU stamp (the loaders that move the clock there
    keep its Unix time), or the files' own Unix seconds (an A-KIT folder keeps its files' stamps)."""
    if "t0_unix_ns" in mission.meta:
        return f"seconds from the first IMU stamp (Unix {mission.meta['t0_unix_ns'] / 1e9:.3f} s)"
    if len(mission.imu.t) and mission.imu.t[0] > UNIX_CLOCK_MIN_S:
        return "Unix seconds (the files' own clock)"
    return "seconds from the first IMU stamp"


# --- a DVL file on its own ---------------------------------------------------------------------------------
def describe_dvl_log(log) -> dict:
    """The description of a :class:`~graphnav.core.dvl_log.DvlLog` (a DVL file without an IMU)."""
    meta: dict = {}
    used = np.asarray(log.v_d_valid, bool)
    entry = count_read(meta, "dvl", log.t, log.source)
    entry["refused"] = log.refused()
    entry["read"] = int(used.sum()) + sum(entry["refused"].values())   # a refused ensemble was still in the file
    entry["used"] = int(used.sum())
    if log.depth_m is not None and np.isfinite(log.depth_m).any():
        count_read(meta, "depth", log.t[np.isfinite(log.depth_m)], f"{log.source}:depth")
    if log.attitude_deg is not None:
        good = np.all(np.isfinite(log.attitude_deg), axis=1)
        count_read(meta, "attitude", log.t[good], f"{log.source}:heading/pitch/roll")
    from graphnav.io.pd0 import left_out_notes
    stream_entry(meta, "dvl")["notes"].extend(left_out_notes(log.counts))
    if log.v_n is not None:
        stream_entry(meta, "dvl")["notes"].append(
            f"velocity over ground in NED on {int(np.all(np.isfinite(log.v_n), axis=1).sum())} of {len(log.t)} "
            "ping(s), from the instrument's own attitude (dead reckoning interpolates the others)")
    if log.three_beam is not None and np.any(log.three_beam):
        stream_entry(meta, "dvl")["notes"].append(f"{int(np.sum(log.three_beam))} 3-beam ping(s)")
    from graphnav.io.dvl_files import long_gaps_said
    far = long_gaps_said(log, None if log.v_n is None else np.all(np.isfinite(log.v_n), axis=1))
    if far:             # what smooth refuses to dead-reckon across, said before it is run
        stream_entry(meta, "dvl")["notes"].append(far)
    streams = meta["streams"]
    span, duration = _span(streams)
    out = {
        "usable": True, "reason": None,
        "use": "DVL dead reckoning only (no IMU): graphnav smooth --data FILE writes a DVL-DR track"
               + ("; cut the file at its gap(s) of over an hour first (the dvl note says where): smooth refuses to "
                  "bridge them" if far else "") + "; for the IMU/DVL estimators give the IMU in the configuration's "
               "csv_columns map (--config)",
        "instrument": log.instrument, "dvl_frame": log.frame,
        "clock": "Unix seconds (the instrument's clock)" if len(log.t) and log.t[0] > UNIX_CLOCK_MIN_S
        else "the log's own clock, s",
        "time_span_s": span, "duration_s": duration, "streams": streams,
        "dvl": {"speed_mps": _speed_stats(np.where(used[:, None], log.v_d, np.nan)),
                "beams_per_ping": None if log.beam_valid is None else _beams_per_ping(log.beam_valid)},
        "depth_m": _depth_range(log.depth_m),
    }
    return out


def _describe_dvl_file(path: Path, config) -> dict:
    from graphnav.io.dvl_files import pd0_header, read_dvl
    try:
        log = read_dvl(path, config)
    except GraphnavError as exc:
        reason = str(exc)
    else:
        return describe_dvl_log(log)
    out = {"usable": False, "reason": reason, "use": None}
    try:
        head = pd0_header(path)
    except GraphnavError:
        return out
    meta: dict = {}
    if head["span_s"]:
        entry = stream_entry(meta, "ensembles")
        entry.update(source=str(path), read=head["ensembles"], used=0, refused={"file not usable": head["ensembles"]},
                     rate_hz=head["instrument"].get("ping_rate_hz"), span_s=head["span_s"])
    span, duration = _span(meta.get("streams", {}))
    out.update(instrument=head["instrument"], dvl_frame=head["instrument"].get("coordinates"),
               clock="Unix seconds (the instrument's clock)", time_span_s=span, duration_s=duration,
               streams=meta.get("streams", {}), bottom_track=head["bottom_track"])
    return out


# --- a JSON-lines stream file ------------------------------------------------------------------------------
def _describe_jsonl(path: Path, config) -> dict:
    from graphnav.core.dvl import DvlGeometry
    from graphnav.io.streamio import StreamReader
    with path.open(encoding="utf-8") as fh:
        reader = StreamReader(fh, str(path))
        records = list(reader)
    config = config or (reader.config.over(SensorConfig()) if reader.config else SensorConfig())
    by_type: dict[str, list[dict]] = {}
    for rec in records:
        by_type.setdefault(rec["type"], []).append(rec)
    meta: dict = {}
    for kind, recs in by_type.items():
        t = np.array([r["t"] for r in recs], float)
        entry = count_read(meta, kind, t, str(path))
        if kind == "imu":
            restamped = _checked_imu_stamps(t, meta, str(path), np.array([r["_line"] for r in recs]))
            rate = imu_rate_hz(restamped, config.imu_rate_hz, IMU_RATE_TOLERANCE)
            entry["rate_hz"] = float(rate) if np.isfinite(rate) else None
    lines = stream_entry(meta, "lines")
    lines.update(source=str(path), read=reader.n_records + reader.n_bad, used=reader.n_records)
    if reader.n_bad:
        lines["refused"]["not a valid record (not JSON, unknown type or missing field)"] = reader.n_bad
    dvl = {}
    if "dvl" in by_type:
        beams = np.array([[np.nan if b is None else b for b in r["beams"]] for r in by_type["dvl"]], float)
        valid = np.array([r.get("valid") or [b is not None for b in r["beams"]] for r in by_type["dvl"]], bool)
        valid &= np.isfinite(beams)
        none = ~valid.any(axis=1)
        count_refused(meta, "dvl", "no valid beam", int(none.sum()))
        v = DvlGeometry.from_spec(config.dvl).velocity_from_beams(beams, valid, allow_missing=True)
        dvl = {"speed_mps": _speed_stats(v), "beams_per_ping": _beams_per_ping(valid)}
    depth = None
    if "depth" in by_type:
        depth = _depth_range([r["depth_m"] for r in by_type["depth"]])
    streams = meta.get("streams", {})
    span, duration = _span({k: e for k, e in streams.items() if k != "lines"})
    stream_entry(meta, "lines")["notes"].append("config line: " + ("yes" if reader.config else "no"))
    return {"usable": bool(records), "reason": None if records else "the stream holds no measurement record",
            "use": "graphnav online --stream FILE (sample by sample)", "instrument": {"stream": str(path)},
            "dvl_frame": ("DVL frame (dvl_velocity records)" if "dvl_velocity" in by_type and "dvl" not in by_type
                          else "beam (along-beam velocities)"),
            "clock": "the stream's clock, s (IMU clock)",
            "time_span_s": span, "duration_s": duration, "streams": streams, "dvl": dvl, "depth_m": depth}


def _checked_imu_stamps(t: np.ndarray, meta: dict, source: str, lines: np.ndarray) -> np.ndarray:
    """An IMU's stamps ``t`` (s, file order; ``lines``: their lines) restamped as the loaders restamp samples sharing
    a stamp (:func:`~graphnav.core.imu_timing.restamp_shared_stamps`, noted in ``meta``: a driver's packets, 100 Hz in
    packets of 20, are the samples they hold, not 5 Hz), for the sample rate (s); a step of the IMU clock or a gap
    warned about and counted as a file's is (:func:`~graphnav.core.screening.say_imu_stamp_steps`, on the stamps in
    time order: a stream may be late)."""
    restamped = restamp_shared_stamps(t, source, meta)
    order = np.argsort(t, kind="stable")
    say_imu_stamp_steps(t[order], np.sort(restamped), source, "t", meta, lines=lines[order], stacklevel=3)
    return restamped


# --- human output ------------------------------------------------------------------------------------------
def _when(t: float) -> str:
    if t > UNIX_CLOCK_MIN_S:
        return dt.datetime.fromtimestamp(t, dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
    return f"{t:.3f} s"


def _fmt(x, unit: str = "", digits: int = 3) -> str:
    return "-" if x is None else f"{x:.{digits}g}{unit}"


def format_description(d: dict) -> str:
    """A short aligned table of a :func:`describe` dict, for a terminal."""
    rows: list[tuple[str, str]] = [("path", d["path"]), ("format", d.get("format_name") or "unknown")]
    rows.append(("usable", ("yes: " + d["use"]) if d.get("usable") else f"no: {d.get('reason')}"))
    rows += [("left out", f"{name}: not usable: {why}") for name, why in (d.get("left_out") or {}).items()]
    inst = d.get("instrument") or {}
    for k, v in inst.items():
        rows.append((f"  {k}", json.dumps(v) if isinstance(v, (dict, list)) else str(v)))
    if d.get("dvl_frame"):
        rows.append(("DVL frame", d["dvl_frame"]))
    if d.get("time_span_s"):
        t0, t1 = d["time_span_s"]
        rows.append(("time span", f"{_when(t0)} .. {_when(t1)} ({d['duration_s']:.1f} s)"))
    if d.get("clock"):
        rows.append(("clock", d["clock"]))
    dvl = d.get("dvl") or {}
    speed = dvl.get("speed_mps")
    if speed:
        rows.append(("DVL speed", f"median {speed['median']:.3f} m/s, max {speed['max']:.3f} m/s "
                                  f"({speed['pings']} pings)"))
    if dvl.get("beams_per_ping"):
        rows.append(("beams per ping", ", ".join(f"{k}: {n}" for k, n in dvl["beams_per_ping"].items())))
    if d.get("depth_m"):
        rows.append(("depth", f"{d['depth_m']['min']:.2f} .. {d['depth_m']['max']:.2f} m"))
    if "ground_truth" in d:
        rows.append(("ground truth", "yes" if d["ground_truth"] else "no"))
    if d.get("missions"):
        rows.append(("missions", ", ".join(d["missions"])))
    width = max(len(k) for k, _ in rows)
    lines = [f"{k:<{width}}  {v}" for k, v in rows]
    streams = d.get("streams") or {}
    if streams:
        lines.append("")
        head = ("stream", "read", "used", "refused", "rate Hz", "span s")
        table = [head] + [(name, str(e.get("read")), str(e.get("used")), str(sum((e.get("refused") or {}).values())),
                           _fmt(e.get("rate_hz"), digits=4),
                           "-" if not e.get("span_s") else f"{e['span_s'][1] - e['span_s'][0]:.1f}")
                          for name, e in streams.items()]
        w = [max(len(r[i]) for r in table) for i in range(len(head))]
        lines += ["  ".join(c.ljust(w[i]) if i == 0 else c.rjust(w[i]) for i, c in enumerate(r)) for r in table]
        for name, e in streams.items():
            for reason, n in (e.get("refused") or {}).items():
                if n:
                    lines.append(f"  {name}: {n} refused: {reason}")
            for reason, n in (e.get("doubted") or {}).items():
                lines.append(f"  {name}: {n} read despite a doubt: {reason}")
            for note in e.get("notes") or []:
                lines.append(f"  {name}: {note}")
    if d.get("warnings"):
        lines.append("")
        lines += [f"warning: {w}" for w in d["warnings"]]
    return "\n".join(lines)
