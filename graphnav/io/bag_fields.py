"""A DVL recorded in a vendor's own message type (Water Linked's ROS 1 ``waterlinked_a50_ros_driver/DVL``, UUV
Simulator's ``uuv_sensor_msgs/DVL``, a Nortek or Teledyne driver's), read through the fields the configuration
names, in the column map's words (``csv_columns.dvl``)::

    "bag_topics": {"dvl": {"topic": "/dvl/data", "v_b": "velocity", "velocity_valid": "velocity_valid",
                           "beams": "beams[].velocity", "valid": "beams[].valid",
                           "frame": "instrument", "velocity_unit": "m/s"}}

A field is a path in the message: ``a.b`` a field of a sub-message, ``beams[].velocity`` that field of every
element of a list (in list order: beam 1 first), ``beams[2].velocity`` or ``raw_velocity[3]`` that of one element
(counted from 0; past the end of some messages' lists: NaN there, warned and counted; of every message's: refused).
``v_b`` names a ``Vector3`` or three number fields (a list of three paths), ``beams`` four (an array, a list's field, or four paths; three of a three-beam DVL, beam 4 then
NaN and invalid), ``valid`` the beams' flags (bool or integer fields, non-zero = valid; left out: every finite beam
is), ``velocity_valid`` the velocity's own flag (left out: a finite velocity is valid, and with ``valid`` given only
over three valid beams, as a column map's). Velocities may be integer fields (a raw driver's int16 mm/s, declared
by ``velocity_unit``); a bool is no velocity and a float no flag.
``frame`` (the column map's: ``instrument``, ``body``/``frd``, ``flu``) defaults to ``instrument``: every DVL
message graphnav reads holds the instrument's own velocity; ``velocity_unit`` (m/s, cm/s, mm/s, kn) left out is
m/s, mm/s detected from the speeds as for a column map. Earth frames need the head's attitude per ping and are
refused. The message's definition comes from the bag (ROS 1, MCAP, rosbag2 from Iron on); a bag without it cannot be
read this way.
"""
from __future__ import annotations

import json
import re
import warnings

import numpy as np

from graphnav.core.errors import ConfigError, DataError
from graphnav.core.streams import add_note, count_doubted

KEY = "bag_topics.dvl"
#: The keys of :data:`KEY` that name fields of the message, and how many values each gives per message.
FIELD_KEYS = {"v_b": 3, "velocity_valid": 1, "beams": 4, "valid": 4}
VECTOR3 = "geometry_msgs/msg/Vector3"


def named_fields(spec: dict) -> tuple[str | None, str | None]:
    """``(velocity, beams)``: the fields :data:`KEY` ``spec`` names for the velocity and the beams, as a message about
    the stream names them (``'velocity'``, ``'beams[].velocity'``), None for one not named."""
    return tuple(", ".join(_paths(spec, key)) if key in spec else None for key in ("v_b", "beams"))


def _paths(spec: dict, key: str) -> list[str]:
    value = spec[key]
    paths = [value] if isinstance(value, str) else value
    if not isinstance(paths, list) or not paths or not all(isinstance(p, str) and p for p in paths):
        raise ConfigError(f"{KEY}.{key} = {value!r}: a field of the message ('velocity', 'beams[].velocity') or a "
                          "list of them")
    # split on '.' an index such as [1.5] reads as a field 'beams[1' the message lacks: the index is what is wrong
    bad = next((p for p in paths if any(("[" in part or "]" in part) and not re.fullmatch(r"\w+\[\d*\]", part)
                                        for part in p.split("."))), None)
    if bad is not None:
        raise ConfigError(f"{KEY}.{key} = {value!r}: {bad!r} has an index that is no whole number from 0: name one "
                          "element as 'list[2]' (counted from 0), every element as 'list[]'")
    return paths


def _fields(fielddefs: dict, msgtype: str) -> list[tuple[str, tuple]]:
    return list(fielddefs[msgtype][1])


def _kind(node: tuple) -> str:
    """A field's type as a .msg file writes it (``float64``, ``pkg/msg/Name[]``)."""
    kind, what = node
    if kind.name in ("ARRAY", "SEQUENCE"):
        inner, size = what
        return f"{_kind(inner)}[{size or ''}]"
    return what[0] if kind.name == "BASE" else what


def _array(kind: str) -> tuple[str, int | None]:
    """A list or array type's element type and size (``pkg/msg/Beam[4]`` -> ``("pkg/msg/Beam", 4)``; 0: unbounded,
    ``float64[]``); any other type as it is, with None."""
    match = re.fullmatch(r"(.+)\[(\d*)\]", kind)
    return (match.group(1), int(match.group(2) or 0)) if match else (kind, None)


def fields_of(fielddefs: dict, msgtype: str) -> str:
    """The fields of ``msgtype`` with their types, a list's or sub-message's one level down."""
    out = []
    for name, node in _fields(fielddefs, msgtype):
        kind = _kind(node)
        inner = _array(kind)[0]
        sub = f": {', '.join(n for n, _ in _fields(fielddefs, inner))}" if inner in fielddefs and \
            inner != "std_msgs/msg/Header" else ""
        out.append(f"{name} ({kind}{sub})")
    return ", ".join(out)


def check_paths(spec: dict, fielddefs: dict, msgtype: str, source: str, topic: str) -> None:
    """DataError naming the bag, topic, message type and the fields it has for a path of ``spec`` not in
    ``msgtype``, for a type whose definition the bag does not carry, and for a key whose fields are not the numbers
    it needs (:data:`FIELD_KEYS`: how many; :data:`NEEDS`: of which type)."""
    if msgtype not in fielddefs:
        raise DataError(f"{topic} has type {msgtype}, whose definition the bag does not embed (rosbag2 sqlite3 before "
                        f"Iron): its fields cannot be read by {KEY}; record it as MCAP or with ROS 2 Iron or later, or "
                        "republish it as a type graphnav reads", source, field=topic)
    where = f"{topic} ({msgtype})"
    for key in FIELD_KEYS:
        if key not in spec:
            continue
        total: int | None = 0
        for path in _paths(spec, key):
            kind, lists = _walk(key, path, fielddefs, msgtype, source, topic)
            typ, count = _numbers(fielddefs, kind)
            if typ not in NEEDS[key][0]:
                raise DataError(f"{KEY}.{key} = {spec[key]!r}: {path!r} of {where} is {kind}{WHY.get(typ, '')}; "
                                f"{key} needs {NEEDS[key][1]}", source, field=topic)
            for size in lists:
                count = count * size if count is not None and size else None
            total = total + count if total is not None and count is not None else None
        if total is not None and not FEWEST.get(key, FIELD_KEYS[key]) <= total <= FIELD_KEYS[key]:
            raise DataError(f"{KEY}.{key} = {spec[key]!r} names {total} number{'s' * (total != 1)} of {where} and "
                            f"needs {FIELD_KEYS[key]}: {NEEDS[key][1]}{by_index(spec, key, total)}", source,
                            field=topic)


#: The fewest numbers a key of :data:`FIELD_KEYS` takes from fields of a fixed size: a three-beam DVL's beams and
#: flags (beam 4 padded NaN and invalid, as a list of three is per message).
FEWEST = {"beams": 3, "valid": 3}
#: The type of number each key of :data:`FIELD_KEYS` takes, and what it needs in words. Velocities may be integers
#: (raw drivers publish int16 mm/s; the declared unit says so); a bool is no velocity and a float no flag.
NEEDS = {"v_b": (("float", "int", "vector3"), "three numbers, a Vector3 or three float or integer fields"),
         "velocity_valid": (("bool", "int"), "one flag, a bool or integer field"),
         "beams": (("float", "int"), "four along-beam velocities, float or integer fields (a float64[4], a list's "
                                     "field or four paths such as 'beams[0].velocity'; three of a three-beam DVL)"),
         "valid": (("bool", "int"), "four flags, bool or integer fields (a list's bool field or four paths such as "
                                    "'beams[0].valid'; three of a three-beam DVL)")}
#: Why a field of this type is not what a key of :data:`NEEDS` takes (the types a key takes never get here).
WHY = {"vector3": " (a velocity's three components are not four beams)", "bool": " (a flag is no velocity)",
       "float": " (a float is no flag)"}


def by_index(spec: dict, key: str, count: int) -> str:
    """For ``count`` numbers more than ``key`` takes: how to name the ones it takes by index, with the indices of its
    own path (a five-beam DVL's four slanted beams)."""
    n, paths = FIELD_KEYS[key], _paths(spec, key)
    if count <= n:
        return ""
    if len(paths) > 1:
        return f"; name each of the {n} by index ('list[2].field', 'array[3]')"
    path = paths[0]
    each = path.replace("[]", "[{}]", 1) if "[]" in path else path + "[{}]"
    return f"; name the {n} it takes by index, e.g. {[each.format(i) for i in range(n)]}"


def _walk(key: str, path: str, fielddefs: dict, msgtype: str, source: str, topic: str) -> tuple[str, list]:
    """The type at the end of ``path`` and the sizes of the lists walked into with ``[]`` on the way (0: unbounded;
    ``[i]`` picks one element and adds none); a DataError naming the fields there are for a path ``msgtype`` does
    not have, and for an index past the end of a fixed array."""
    typ, walked, parts, lists = msgtype, [], path.split("."), []
    for i, part in enumerate(parts):
        name, index = _part(part)
        fields = dict(_fields(fielddefs, typ)) if typ in fielddefs else {}
        kind = _kind(fields[name]) if name in fields else None
        listed = kind is not None and kind.endswith("]")
        # a whole array may end a path; a list's elements are walked into with [] or one of them picked with [i]
        if part == name and listed and i < len(parts) - 1:
            rest = parts[i + 1:]
            raise DataError(f"{KEY}.{key} = {path!r}: {'.'.join(walked + [name])!r} of {topic} ({msgtype}) "
                            f"is a list ({kind}): a field of its elements is "
                            f"{'.'.join(walked + [name + '[]'] + rest)!r}, of one element "
                            f"{'.'.join(walked + [name + '[0]'] + rest)!r}", source, field=topic)
        if kind is None or (part != name and not listed):
            what = f"{'.'.join(walked) or 'the message'} has {fields_of(fielddefs, typ)}" if fields else \
                f"{'.'.join(walked)} is a number"
            raise DataError(f"{KEY}.{key} = {path!r}: {topic} ({msgtype}) has no "
                            f"{'list' if kind else 'field'} {'.'.join(walked + [part])!r}; {what}",
                            source, field=topic)
        if part != name:
            element, size = _array(kind)
            if index is None:
                lists.append(size)
            elif size and index >= size:
                raise DataError(f"{KEY}.{key} = {path!r}: {'.'.join(walked + [name])!r} of {topic} ({msgtype}) is "
                                f"{kind}: its elements are [0] to [{size - 1}]", source, field=topic)
            kind = element
        walked.append(part)
        typ = _array(kind)[0]
    return kind, lists


def _part(part: str) -> tuple[str, int | None]:
    """A path's step as ``(field name, index)``: ``beams[2]`` -> ``("beams", 2)``; ``beams[]`` and ``beams`` give
    no index (a name that is no field stays whole, for the error to name)."""
    match = re.fullmatch(r"(\w+)\[(\d*)\]", part)
    if not match:
        return part, None
    return match.group(1), int(match.group(2)) if match.group(2) else None


def _numbers(fielddefs: dict, kind: str) -> tuple[str, int | None]:
    """What a field of type ``kind`` holds: ``float``, ``int``, ``bool``, ``vector3`` (x, y, z) or its type when it
    holds no numbers, and how many (None: as many as its list holds)."""
    element, size = _array(kind)
    if size is not None:
        typ, count = _numbers(fielddefs, element)
        return typ, count * size if size and count else None
    if [n for n, _ in fielddefs.get(kind, ([], []))[1]] == ["x", "y", "z"]:
        return "vector3", 3
    if kind.startswith("float"):
        return "float", 1
    if re.fullmatch(r"u?int\d+|byte|char", kind):
        return "int", 1
    return kind, 1


def values(rows: list, path: str, short: dict | None = None) -> list[np.ndarray]:
    """The numbers at ``path`` in each message (a ``Vector3`` gives x, y, z); an element ``[i]`` past the end of a
    message's list is NaN (a beam the message lacks), and ``short`` gets ``{message index: (list, its length)}``."""
    def at(msg, parts, i):
        if not parts:
            return [msg.x, msg.y, msg.z] if hasattr(msg, "x") else msg
        (name, index), rest = _part(parts[0]), parts[1:]
        if parts[0].endswith("[]"):
            return [at(m, rest, i) for m in getattr(msg, name)]
        if index is not None:
            items = getattr(msg, name)
            if index < len(items):
                return at(items[index], rest, i)
            if short is not None:
                short[i] = (name, len(items))
            return np.nan
        return at(getattr(msg, name), rest, i)
    parts = path.split(".")
    return [np.ravel(np.asarray(at(m, parts, i), float)) for i, m in enumerate(rows)]


#: Why pings of a bag's DVL are counted as doubted when an index of :data:`KEY` is past the end of their list.
SHORT_LIST_DOUBT = f"{KEY}.{{key}} past the end of the message's list: the beam read as missing"


def _past_the_end(short: dict, n: int, spec: dict, key: str, path: str, source: str, topic: str, msgtype: str,
                  meta: dict | None, message_names: list[str] | None) -> None:
    """``short`` (:func:`values`) of ``path`` over ``n`` messages: past the end of every message's list a DataError
    naming the key, the topic and the lengths seen (the path names nothing the bag holds); of some, a warning naming
    the first message and their count as doubted in ``meta`` (a message lacking a beam)."""
    if not short:
        return
    name = next(iter(short.values()))[0]
    lengths = sorted({length for _, length in short.values()})
    seen = " or ".join(str(x) for x in lengths) + f" element{'s' * (lengths != [1])}"
    if len(short) == n:
        raise DataError(f"{KEY}.{key} = {spec[key]!r}: {path!r} is past the end of every message's list {name!r} of "
                        f"{topic} ({msgtype}): {seen} ([0] to [{lengths[-1] - 1}]); name an element it has, or "
                        f"'{name}[]' for each", source, field=topic)
    first = min(short)
    at = message_names[first] if message_names is not None else f"message {first}"
    text = (f"{KEY}.{key}: {path!r} is past the end of the list {name!r} in {len(short)} of {n} messages of {topic} "
            f"({seen}), first at {at}: the beam is read as missing there")
    if meta is not None:
        add_note(meta, "dvl", text)
        count_doubted(meta, "dvl", SHORT_LIST_DOUBT.format(key=key), len(short))
    warnings.warn(f"{source}:{topic}: {text}", RuntimeWarning, stacklevel=4)


def table(s, spec: dict, key: str, source: str, meta: dict | None = None,
          message_names: list[str] | None = None) -> np.ndarray:
    """(M, n) values of ``spec[key]`` (n from :data:`FIELD_KEYS`) in the messages of topic ``s``
    (:class:`graphnav.io.bag_convert.Stream`); a message with fewer beams or beam flags (a beam list cut short) is
    padded with NaN, one with more, or a velocity or its flag short of values, is a DataError naming the topic,
    message and field; an index past the end of message lists: :func:`_past_the_end` (``message_names``: each message
    named for a warning)."""
    n, rows, topic = FIELD_KEYS[key], s.rows, s.topic
    paths = _paths(spec, key)
    try:
        cols = []
        for p in paths:
            short: dict = {}
            cols.append(values(rows, p, short))
            _past_the_end(short, len(rows), spec, key, p, source, topic, s.msgtype, meta, message_names)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{KEY}.{key} = {spec[key]!r} does not name numbers (a Vector3 or numbers): {exc}", source,
                        field=topic) from None
    out = np.full((len(rows), n), np.nan)
    for i in range(len(rows)):
        row = np.concatenate([c[i] for c in cols])
        if row.size > n or (row.size < n and key not in ("beams", "valid")):
            raise DataError(f"{KEY}.{key} names {row.size} values in message {i} and needs {n}: {NEEDS[key][1]}"
                            f"{by_index(spec, key, row.size)}", source, field=f"{topic} {', '.join(paths)}")
        out[i, :row.size] = row
    return out


def example(fielddefs: dict, msgtype: str | None, topic: str) -> dict:
    """A filled-in :data:`KEY` entry for ``topic`` from its type's own fields (the likeliest velocity, flags and
    beam list), for an error message to show; placeholders where the type gives none."""
    spec = {"topic": topic, "v_b": "velocity", "velocity_valid": "velocity_valid", "beams": "beams[].velocity",
            "valid": "beams[].valid", "frame": "instrument", "velocity_unit": "m/s"}
    found: dict = {}
    if msgtype in fielddefs:
        _likely(fielddefs, msgtype, "", found)
    if "v_b" not in found and "beams" not in found:
        return spec
    return {k: found.get(k, v) for k, v in spec.items() if k not in FIELD_KEYS or k in found}


def _likely(fielddefs: dict, msgtype: str, prefix: str, found: dict) -> None:
    """Into ``found``: the fields of ``msgtype`` (names starting with ``prefix``) likeliest to be each
    :data:`FIELD_KEYS` entry, those named like a velocity first; sub-messages searched for a Vector3 too."""
    for name, node in sorted(_fields(fielddefs, msgtype), key=lambda f: not _velocity(f[0]) and "linear" not in f[0]):
        kind, path = _kind(node), prefix + name
        inner = _array(kind)[0]
        if kind == VECTOR3:
            found.setdefault("v_b", path)
        elif kind == "bool" and "valid" in name:
            found.setdefault("velocity_valid", path)
        elif kind in fielddefs and kind != "std_msgs/msg/Header" and not prefix:
            _likely(fielddefs, kind, path + ".", found)
        elif kind.endswith("]") and inner in fielddefs:
            sub = {n: _kind(k) for n, k in _fields(fielddefs, inner)}
            vel = [n for n, k in sub.items() if _velocity(n) and k.startswith("float")]
            flags = [n for n, k in sub.items() if k == "bool"]
            if vel and "beams" not in found:
                found["beams"] = f"{path}[].{vel[0]}"
                if flags:
                    found["valid"] = f"{path}[].{flags[0]}"
        elif kind.startswith("float") and kind.endswith("]") and _velocity(name):
            found.setdefault("beams", path)


def _velocity(name: str) -> bool:
    """A field named like a velocity, not like its covariance."""
    return "vel" in name and "cov" not in name


def looks_like_dvl(topic: str, msgtype: str) -> bool:
    """A topic whose name or message type says DVL."""
    return "dvl" in f"{topic} {msgtype}".lower()


def way_forward(fielddefs: dict, available: dict[str, str], topic: str | None) -> str:
    """What to write in the configuration to read ``topic`` (or the likeliest DVL topic of ``available``), with
    its own fields."""
    if topic is None:
        named = sorted(t for t, ty in available.items() if looks_like_dvl(t, ty))
        topic = named[0] if named else "/dvl/data"
    msgtype = available.get(topic)
    text = json.dumps({"bag_topics": {"dvl": example(fielddefs, msgtype, topic)}})[1:-1]
    missing = (f" (the bag does not embed the definition of {msgtype}: record it as MCAP or with ROS 2 Iron or later)"
               if msgtype and msgtype not in fielddefs else "")
    return (f". A DVL in its vendor's message type is read by naming its fields in the configuration, e.g. {text}"
            f"{missing}: check the frame and unit against the driver's documentation (docs/decisions/bags.md)")


def read(s, spec: dict, C_d_b: np.ndarray, source: str, meta: dict, info: dict,
         message_names: list[str] | None = None):
    """``(beams, valid, v_d, v_ok, sigma)`` of a topic ``s`` (:class:`graphnav.io.bag_convert.Stream`) read through
    ``spec`` (:data:`KEY`), as the built-in messages give them: m/s, the velocity in the DVL frame (turned from the
    declared ``frame`` with ``C_d_b``), no sigma (the configuration's noise is used). The fields read are in
    ``info["dvl_fields"]`` and a note of the DVL stream. ``message_names``: each message named for a warning."""
    from graphnav.io.dvl_frame import EARTH_FRAMES, declared_frame, velocity_to_body
    from graphnav.io.units import DECLARED_UNITS, declared_scale, dvl_values_in_mps, say_mmps
    if "v_b" not in spec and "beams" not in spec:
        raise ConfigError(f"{KEY} needs 'beams' (the four along-beam velocities) or 'v_b' (the velocity)")
    units = DECLARED_UNITS["velocity"]
    unit = spec.get("velocity_unit")            # null as left out: m/s, mm/s detected from the speeds
    scale = 1.0 if unit is None else declared_scale(spec, "velocity_unit", units, "m/s", KEY)
    frame = declared_frame(spec, "instrument", KEY)
    if frame in EARTH_FRAMES:
        raise ConfigError(f"{KEY}.frame = {frame!r}: an earth-frame velocity needs the head's attitude at each ping; "
                          "give the beams, or a velocity in the instrument, body or flu frame")
    where = f"{source}:{s.topic}"
    fix = f"declare {KEY}.velocity_unit ({', '.join(units)})"
    n = len(s.rows)

    mmps = {}           # key -> its fields' median speed as read, where detected as mm/s: said once for both

    def in_mps(key, **kw):
        cells = table(s, spec, key, source, meta, message_names) * scale
        fields = ", ".join(_paths(spec, key))
        cells, med = dvl_values_in_mps(cells, where, unit, columns=fields, fix=fix, key=f"{KEY}.velocity_unit", **kw)
        if med is not None:
            mmps[key] = f"{med:.4g} in {key} '{fields}'"
        return cells
    beams = in_mps("beams", beams=True) if "beams" in spec else np.full((n, 4), np.nan)
    flags = table(s, spec, "valid", source, meta, message_names) if "valid" in spec else np.ones((n, 4))
    valid = (np.nan_to_num(flags) != 0) & np.isfinite(beams)
    v_d = np.full((n, 3), np.nan)
    if "v_b" in spec:
        v = in_mps("v_b")
        v_d = v if frame == "instrument" else velocity_to_body(v, frame, C_d_b) @ C_d_b    # v_d = C_d_b^T v_b
    if mmps:
        say_mmps(meta, where, "median speed " + ", ".join(mmps.values()))
    if "velocity_valid" in spec:
        v_ok = np.nan_to_num(table(s, spec, "velocity_valid", source, meta, message_names)[:, 0]) != 0
    else:       # as a column map's: a velocity needs three valid beams when the beams are flagged
        # the raw flags: with no beams named, every beam is NaN and would leave no velocity valid
        v_ok = np.all(np.isfinite(v_d), axis=1) & (((np.nan_to_num(flags) != 0).sum(axis=1) >= 3)
                                                   if "valid" in spec else True)
    info["dvl_fields"] = {k: spec[k] for k in ("topic", *FIELD_KEYS) if k in spec} | {"frame": frame,
                                                                                     "velocity_unit": unit or "m/s"}
    add_note(meta, "dvl", f"fields of {s.msgtype} named by {KEY}: {json.dumps(info['dvl_fields'])}")
    return beams, valid, v_d, v_ok, np.full((n, 3), np.nan)
