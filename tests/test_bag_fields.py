"""A DVL recorded in a vendor's own message type (here Water Linked's ROS 1 message, as a ROS 2 MCAP bag with its
definition embedded) is read through the fields ``bag_topics.dvl`` names, exactly as the same mission recorded in
the standard type; without the entry the error shows the entry built from the message's own fields."""
from __future__ import annotations

import json
import re
import warnings

import numpy as np
import pytest

from graphnav import cli
from graphnav.core.errors import ConfigError, DataError
from graphnav.io import bag_driver, bag_msgs, bags
from graphnav.missions import load_mission
from graphnav.sim.simulate import simulate_mission

VENDOR = "waterlinked_a50_ros_driver/msg/DVL"
VENDOR_BEAM = "waterlinked_a50_ros_driver/msg/DVLBeam"
FIELDS = {"topic": "/dvl/data", "v_b": "velocity", "velocity_valid": "velocity_valid", "beams": "beams[].velocity",
          "valid": "beams[].valid"}


def _vendor_copy(standard, path, storage="mcap", twist=False):
    """``standard`` (a bag with ``dvl_msgs/msg/DVL``) with its DVL messages recorded as the vendor's type (``twist``:
    each also published as a ``TwistWithCovarianceStamped`` on /dvl/twist, as drivers do beside their own message)."""
    from rosbags.rosbag2 import Reader, StoragePlugin, Writer
    from rosbags.typesys import get_types_from_msg
    store = bags.typestore()
    store.register(get_types_from_msg(bag_msgs.DVL_MSGS_DVLBEAM, VENDOR_BEAM))
    store.register(get_types_from_msg(bag_msgs.DVL_MSGS_DVL_A50.replace("DVLBeam", VENDOR_BEAM.replace("/msg", "")),
                                      VENDOR))
    T = store.types
    plugin = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}[storage]
    with Reader(standard) as reader, Writer(path, version=9, storage_plugin=plugin) as writer:
        conns = {}
        for conn, ns, raw in reader.messages():
            typ = VENDOR if conn.msgtype == bags.WL_DVL else conn.msgtype
            if conn.topic not in conns:
                conns[conn.topic] = writer.add_connection(conn.topic, typ, typestore=store)
            if typ == VENDOR:
                m = store.deserialize_cdr(raw, conn.msgtype)
                beams = [T[VENDOR_BEAM](id=b.id, velocity=b.velocity, distance=b.distance, rssi=b.rssi, nsd=b.nsd,
                                        valid=b.valid) for b in m.beams]
                raw = store.serialize_cdr(T[VENDOR](header=m.header, time=m.time, velocity=m.velocity, fom=m.fom,
                                                    altitude=m.altitude, beams=beams, velocity_valid=m.velocity_valid,
                                                    status=m.status, form=m.form), VENDOR)
                if twist:
                    if "/dvl/twist" not in conns:
                        conns["/dvl/twist"] = writer.add_connection("/dvl/twist", bags.TWIST_DVL, typestore=store)
                    cov = np.diag([1e-4, 1e-4, 1e-4, -1.0, -1.0, -1.0]).ravel()
                    msg = T[bags.TWIST_DVL](header=m.header, twist=T["geometry_msgs/msg/TwistWithCovariance"](
                        twist=T["geometry_msgs/msg/Twist"](linear=m.velocity, angular=m.velocity), covariance=cov))
                    writer.write(conns["/dvl/twist"], ns, store.serialize_cdr(msg, bags.TWIST_DVL))
            writer.write(conns[conn.topic], ns, raw)
    if storage == "sqlite3":
        bag_driver.strip_definitions(next(path.glob("*.db3")))
    return path


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    root = tmp_path_factory.mktemp("vendor")
    mission = simulate_mission(duration_s=40.0, seed=3)
    standard = bags.write_mission_bag(mission, root / "standard", dvl_type=bags.WL_DVL)
    vendor = _vendor_copy(standard, root / "vendor")
    plain = root / "plain.json"
    mission.config.save(plain)
    return mission, root, standard, vendor, plain


def _config(root, name, fields):
    cfg = json.loads((root / "plain.json").read_text())
    cfg["bag_topics"] = {"dvl": fields}
    (root / name).write_text(json.dumps(cfg))
    return root / name


def test_a_vendor_dvl_message_reads_and_smooths_as_the_standard_one(recorded, capsys):
    mission, root, standard, vendor, plain = recorded
    mapped = _config(root, "mapped.json", FIELDS)
    with pytest.warns(RuntimeWarning):
        a, b = load_mission(vendor, mapped), load_mission(standard, plain)
    for name in ("t", "beams", "valid", "v_b", "v_d", "v_d_valid"):
        np.testing.assert_array_equal(getattr(a.dvl, name), getattr(b.dvl, name), err_msg=name)
    assert a.meta["streams"]["dvl"]["read"] == b.meta["streams"]["dvl"]["read"] == len(mission.dvl.t)
    assert a.meta["streams"]["dvl"]["refused"] == b.meta["streams"]["dvl"]["refused"]
    out = {}
    for name, bag, cfg in (("vendor", vendor, mapped), ("standard", standard, plain)):
        with pytest.warns(RuntimeWarning, match="no heading source in the bag"):
            assert cli.main(["smooth", "--data", str(bag), "--config", str(cfg), "--method", "Graph-TC", "--out",
                             str(root / f"out_{name}"), "--no-plots"]) == 0
            out[name] = json.loads((root / f"out_{name}" / "summary.json").read_text())["accuracy"]
    assert out["vendor"]["vrmse_mission_mps"] == out["standard"]["vrmse_mission_mps"] < 0.1
    assert out["vendor"]["final_horizontal_position_error_m"] == out["standard"]["final_horizontal_position_error_m"]
    capsys.readouterr()
    assert cli.main(["info", str(vendor), "--config", str(mapped)]) == 0
    said = capsys.readouterr().out
    assert f"dvl_message   {VENDOR}" in said
    assert '"beams": "beams[].velocity", "valid": "beams[].valid", "frame": "instrument"' in said
    assert "DVL frame       the message's fields named by bag_topics.dvl" in said


def test_without_the_entry_the_error_shows_it_filled_in_from_the_message(recorded):
    _, root, _, vendor, plain = recorded
    example = ('"bag_topics": {"dvl": {"topic": "/dvl/data", "v_b": "velocity", "velocity_valid": "velocity_valid", '
               '"beams": "beams[].velocity", "valid": "beams[].valid", "frame": "instrument", "velocity_unit": "m/s"}}')
    with pytest.raises(DataError, match="no dvl topic") as err:
        load_mission(vendor, plain)
    assert example in str(err.value) and "or republish it as" in str(err.value)
    with pytest.raises(DataError, match=f"/dvl/data has type {VENDOR}") as err:
        load_mission(vendor, plain, topics={"dvl": "/dvl/data"})
    assert example in str(err.value)


def test_a_field_the_message_does_not_have_is_named_with_the_fields_it_has(recorded):
    _, root, _, vendor, _ = recorded
    with pytest.raises(DataError, match=r"bag_topics.dvl.valid = 'beams\[\].ok': /dvl/data \(" + VENDOR
                       + r"\) has no field 'beams\[\].ok'; beams\[\] has id \(int64\), velocity \(float64\), "
                       r"distance \(float64\), rssi \(float64\), nsd \(float64\), valid \(bool\)"):
        load_mission(vendor, _config(root, "typo.json", {**FIELDS, "valid": "beams[].ok"}))
    with pytest.raises(DataError, match=r"has no field 'speed'; the message has header \(std_msgs/msg/Header\), "
                                        r"time \(float64\), velocity \(geometry_msgs/msg/Vector3: x, y, z\)"):
        load_mission(vendor, _config(root, "speed.json", {**FIELDS, "v_b": "speed"}))
    with pytest.raises(DataError, match=r"'beams' of /dvl/data .* is a list .*: a field of its elements is "
                                        r"'beams\[\].velocity'"):
        load_mission(vendor, _config(root, "list.json", {**FIELDS, "beams": "beams.velocity"}))
    with pytest.raises(ConfigError, match="unknown key 'bag_topics.dvl.velocity_vaild'; did you mean "
                                          "'bag_topics.dvl.velocity_valid'"):
        load_mission(vendor, _config(root, "key.json", {**FIELDS, "velocity_vaild": "velocity_valid"}))
    with pytest.raises(ConfigError, match="bag_topics.dvl needs 'topic'"):
        load_mission(vendor, _config(root, "notopic.json", {"v_b": "velocity"}))


def test_declared_frame_and_unit_and_a_bag_without_the_definition(recorded, tmp_path):
    import dataclasses
    mission, root, standard, vendor, plain = recorded

    def read(**fields):
        config = dataclasses.replace(mission.config, bag_topics={"dvl": {"topic": "/dvl/data", "v_b": "velocity",
                                                                         **fields}})
        return bags.load_bag(vendor, config).dvl
    # a velocity-only map: the instrument's velocity, no beams; declared FLU or in knots, turned and converted
    base = read()
    assert not base.valid.any() and base.v_d_valid.all()
    np.testing.assert_allclose(read(frame="flu").v_d * [1, -1, -1], base.v_d, atol=1e-12)
    np.testing.assert_allclose(read(velocity_unit="kn").v_d, base.v_d * 1852 / 3600, atol=1e-12)
    with pytest.raises(ConfigError, match=r"bag_topics.dvl.velocity_unit = 'knots': choose one of"):
        read(velocity_unit="knots")
    with pytest.raises(ConfigError, match=r"bag_topics.dvl.frame = 'ned': an earth-frame velocity"):
        read(frame="ned")
    with pytest.raises(ConfigError, match=r"bag_topics.dvl.frame = 'fru': choose one of"):
        read(frame="fru")
    # rosbag2 sqlite3 before Iron embeds no definition: the fields cannot be read, and the error says so
    nodefs = _vendor_copy(standard, tmp_path / "nodefs", storage="sqlite3")
    with pytest.raises(DataError, match=f"/dvl/data has type {VENDOR}, whose definition the bag does not embed"):
        load_mission(nodefs, _config(root, "mapped.json", FIELDS))
    with pytest.raises(DataError, match=f"the bag does not embed the definition of {VENDOR}"):
        load_mission(nodefs, plain)


def test_the_entry_shown_is_built_from_the_fields_of_other_drivers_messages():
    """UUV Simulator's message (beams with no flags) and WHOI ds_sensor_msgs (an array of beam velocities beside its
    covariance): the example names their velocity and beams, not a covariance, and no flag they do not have."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from graphnav.io import bag_fields
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg("float64 range\nfloat64 velocity\nfloat64 velocity_covariance\n"
                                      "geometry_msgs/PoseStamped pose", "uuv_sensor_msgs/msg/DVLBeam"))
    store.register(get_types_from_msg("std_msgs/Header header\ngeometry_msgs/Vector3 velocity\n"
                                      "float64[9] velocity_covariance\nfloat64 altitude\n"
                                      "uuv_sensor_msgs/DVLBeam[] beams", "uuv_sensor_msgs/msg/DVL"))
    store.register(get_types_from_msg("std_msgs/Header header\ngeometry_msgs/Vector3 velocity\n"
                                      "float64[9] velocity_covar\nfloat64[4] raw_velocity\n"
                                      "float64[4] raw_velocity_covar", "ds_sensor_msgs/msg/Dvl"))
    rest = {"frame": "instrument", "velocity_unit": "m/s"}
    assert bag_fields.example(store.fielddefs, "uuv_sensor_msgs/msg/DVL", "/dvl") == {
        "topic": "/dvl", "v_b": "velocity", "beams": "beams[].velocity", **rest}
    assert bag_fields.example(store.fielddefs, "ds_sensor_msgs/msg/Dvl", "/dvl") == {
        "topic": "/dvl", "v_b": "velocity", "beams": "raw_velocity", **rest}


def test_a_declared_velocity_unit_the_imu_contradicts_is_refused_naming_the_key(recorded):
    """The DVL in m/s declared cm/s or mm/s: every speed 100-1000x too small, which no speed range tells from a
    hovering vehicle's. It loaded without a word; the IMU's accelerations now fit the velocity's changes far better
    in m/s, and the error names the topic, the fields, the key, the declared unit and the one that fits."""
    _, root, _, vendor, _ = recorded
    for unit in ("cm/s", "mm/s"):
        cfg = _config(root, "unit.json", {**FIELDS, "velocity_unit": unit})
        with pytest.raises(DataError, match=rf"vendor:/dvl/data, field .*: declared '{unit}' "
                                            r"\(bag_topics\.dvl\.velocity_unit\), but the IMU's accelerations fit "
                                            r"the velocity's changes .*x better in 'm/s' .*: set "
                                            r"bag_topics\.dvl\.velocity_unit to 'm/s'$"):
            load_mission(vendor, cfg)
    with pytest.warns(RuntimeWarning):
        m = load_mission(vendor, _config(root, "right.json", {**FIELDS, "velocity_unit": "m/s"}))
    assert "doubted" not in m.meta["streams"]["dvl"]


def test_a_twist_used_beside_a_vendor_dvl_message_says_how_to_read_the_vendor_one(recorded, tmp_path):
    """A driver publishing its own DVL message and a twist: without bag_topics.dvl the twist is used (velocity only),
    and the warning now names the vendor topic and the entry that reads it with its beams."""
    _, root, standard, _, plain = recorded
    both = _vendor_copy(standard, tmp_path / "both", twist=True)
    with pytest.warns(RuntimeWarning) as caught:
        m = load_mission(both, plain)
    said = [str(w.message) for w in caught if "no DVL message" in str(w.message)]
    assert said and "/dvl/twist (geometry_msgs/msg/TwistWithCovarianceStamped) is used as the DVL; /dvl/data " \
        f"({VENDOR}) looks like the DVL's own message, whose beams the twist lacks" in said[0], said
    assert '"bag_topics": {"dvl": {"topic": "/dvl/data", "v_b": "velocity"' in said[0]
    assert not m.dvl.valid.any()                    # velocity only, as before


@pytest.mark.parametrize("key, value, said", [
    ("beams", "velocity", r"'velocity' of /dvl/data \(.*\) is geometry_msgs/msg/Vector3 \(a velocity's three "
                          r"components are not four beams\); beams needs four along-beam velocities, float or "
                          r"integer fields"),
    ("beams", "beams[].valid", r"'beams\[\]\.valid' of .* is bool \(a flag is no velocity\); beams needs four"),
    ("valid", "beams[].velocity", r"is float64 \(a float is no flag\); valid needs four flags, bool or integer"),
    ("velocity_valid", "fom", r"is float64 \(a float is no flag\); velocity_valid needs one flag"),
    ("v_b", "velocity_valid", r"'velocity_valid' of .* is bool \(a flag is no velocity\); v_b needs three numbers"),
    ("v_b", "status", r"names 1 number of /dvl/data \(.*\) and needs 3: three numbers"),
    ("v_b", "velocity.x", r"names 1 number of /dvl/data \(.*\) and needs 3: three numbers"),
    ("v_b", ["velocity.x", "velocity.y"], r"names 2 numbers .* and needs 3"),
    ("beams", ["beams[].velocity", "fom"], None),   # a list's count is known only per message: checked there
])
def test_fields_that_are_not_the_numbers_a_key_needs_are_refused_naming_the_key(recorded, key, value, said):
    """A Vector3 named as the beams loaded as three valid beams (vx, vy, vz) a ping, on which Graph-TC diverged; a
    bool list as the beams loaded every beam at 1 m/s; floats as flags read every beam valid; a velocity of fewer
    than three numbers ended in "median DVL speed nan ... declare bag_topics.dvl.velocity_unit". Each is refused
    before reading, naming the key, the field's type or count and what the key needs."""
    _, root, _, vendor, _ = recorded
    cfg = _config(root, "wrong.json", {**FIELDS, key: value})
    with pytest.raises(DataError, match=rf"bag_topics\.dvl\.{key} = .*{said}" if said else
                       r"bag_topics\.dvl\.beams names 5 values in message 0 and needs 4"):
        load_mission(vendor, cfg)


BEAM = ("vendor/msg/Beam", "float32 velocity\nuint8 valid\n")


def _retyped(standard, path, msgdef, build):
    """``standard`` with its DVL messages recorded as ``vendor/msg/Dvl`` (``msgdef``, with :data:`BEAM` defined),
    each built by ``build(message, types)`` from the standard one."""
    from rosbags.rosbag2 import Reader, StoragePlugin, Writer
    from rosbags.typesys import get_types_from_msg
    store = bags.typestore()
    store.register(get_types_from_msg(BEAM[1], BEAM[0]))
    store.register(get_types_from_msg("std_msgs/Header header\n" + msgdef, "vendor/msg/Dvl"))
    with Reader(standard) as reader, Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {}
        for conn, ns, raw in reader.messages():
            typ = "vendor/msg/Dvl" if conn.msgtype == bags.WL_DVL else conn.msgtype
            if conn.topic not in conns:
                conns[conn.topic] = writer.add_connection(conn.topic, typ, typestore=store)
            if typ != conn.msgtype:
                m = store.deserialize_cdr(raw, conn.msgtype)
                raw = store.serialize_cdr(store.types[typ](header=m.header, **build(m, store.types)), typ)
            writer.write(conns[conn.topic], ns, raw)
    return path


def _beams(m, types, n):
    """The standard message's beams as ``n`` vendor beams: the first four as recorded, a fifth (a vertical beam) at
    0.01 m/s."""
    return [types[BEAM[0]](velocity=np.float32(m.beams[i].velocity if i < 4 else 0.01),
                           valid=np.uint8(m.beams[i].valid if i < 4 else 1)) for i in range(n)]


def _read(bag, config, **fields):
    import dataclasses
    return bags.load_bag(bag, dataclasses.replace(config, bag_topics={"dvl": {"topic": "/dvl/data", **fields}})).dvl


def test_a_three_beam_dvl_in_a_fixed_array_reads_as_a_list_of_three(recorded, tmp_path):
    """A three-beam DVL's ``Beam[3]`` was refused ("names 3 numbers ... needs 4") while the same beams in an
    unbounded list loaded; both now load alike, beam 4 NaN and invalid."""
    mission, _, standard, _, _ = recorded
    ref = bags.load_bag(standard, mission.config).dvl
    fields = {"v_b": "velocity", "velocity_valid": "velocity_valid", "beams": "beams[].velocity",
              "valid": "beams[].valid"}
    read = {}
    for size in ("3", ""):
        bag = _retyped(standard, tmp_path / f"beams{size or 'list'}", f"geometry_msgs/Vector3 velocity\nvendor/Beam"
                       f"[{size}] beams\nbool velocity_valid\n", lambda m, T: dict(
                           velocity=m.velocity, beams=_beams(m, T, 3), velocity_valid=m.velocity_valid))
        read[size] = _read(bag, mission.config, **fields)
    for name in ("t", "beams", "valid", "v_d", "v_d_valid"):
        np.testing.assert_array_equal(getattr(read["3"], name), getattr(read[""], name), err_msg=name)
    dvl = read["3"]
    assert np.isnan(dvl.beams[:, 3]).all() and not dvl.valid[:, 3].any()
    np.testing.assert_array_equal(dvl.valid[:, :3], ref.valid[:, :3])
    np.testing.assert_allclose(dvl.beams[:, :3][ref.valid[:, :3]], ref.beams[:, :3][ref.valid[:, :3]], atol=1e-6)
    np.testing.assert_array_equal(dvl.v_d, ref.v_d)
    with pytest.raises(DataError, match=r"'velocity\.x' names 1 number of /dvl/data .* and needs 4: four along-beam"):
        _read(bag, mission.config, beams="velocity.x")


def test_five_beams_are_named_by_index(recorded, tmp_path):
    """Five beams (four slanted and a vertical one) in a list or a ``float64[5]`` were refused advising "four
    paths", which no path could name; an element is now named by index, and the error shows how."""
    mission, _, standard, _, _ = recorded
    ref = bags.load_bag(standard, mission.config).dvl

    def five(m, types):
        beams = _beams(m, types, 5)
        return dict(velocity=m.velocity, beams=beams,
                    beam_vel=np.array([b.velocity if b.valid else np.nan for b in beams], float))
    bag = _retyped(standard, tmp_path / "five", "geometry_msgs/Vector3 velocity\nvendor/Beam[] beams\n"
                   "float64[5] beam_vel\n", five)
    with pytest.raises(DataError, match=r"beams names 5 values in message 0 and needs 4: .*; name the 4 it takes by "
                                        r"index, e.g. \['beams\[0\]\.velocity', 'beams\[1\]\.velocity', "
                                        r"'beams\[2\]\.velocity', 'beams\[3\]\.velocity'\]$"):
        _read(bag, mission.config, v_b="velocity", beams="beams[].velocity")
    with pytest.raises(DataError, match=r"'beam_vel' names 5 numbers of /dvl/data .* e.g. \['beam_vel\[0\]', "
                                        r"'beam_vel\[1\]', 'beam_vel\[2\]', 'beam_vel\[3\]'\]$"):
        _read(bag, mission.config, v_b="velocity", beams="beam_vel")
    with pytest.raises(DataError, match=r"'beam_vel' of /dvl/data .* is float64\[5\]: its elements are \[0\] to "
                                        r"\[4\]"):
        _read(bag, mission.config, v_b="velocity", beams=[f"beam_vel[{i}]" for i in (1, 2, 3, 5)])
    listed = _read(bag, mission.config, v_b="velocity", beams=[f"beams[{i}].velocity" for i in range(4)],
                   valid=[f"beams[{i}].valid" for i in range(4)])
    array = _read(bag, mission.config, v_b="velocity", beams=[f"beam_vel[{i}]" for i in range(4)])
    for dvl in (listed, array):
        np.testing.assert_array_equal(dvl.valid, ref.valid)
        np.testing.assert_allclose(dvl.beams[ref.valid], ref.beams[ref.valid], atol=1e-6)
        np.testing.assert_array_equal(dvl.v_d, ref.v_d)
    # an element past the end of every message's list names nothing the bag holds (its own test below)
    with pytest.raises(DataError, match=r"past the end of every message's list"):
        _read(bag, mission.config, v_b="velocity", beams=[f"beams[{i}].velocity" for i in (0, 1, 2, 7)])


@pytest.mark.parametrize("beams", ["beam_vel[1.5]", ["beams[0].velocity", "beams[-1].velocity"], "beams[x].velocity",
                                   "beam_vel[1]]"])
def test_an_index_that_is_no_whole_number_is_refused_naming_the_key_and_the_path(recorded, tmp_path, beams):
    """``beam_vel[1.5]`` was refused as a field named 'beam_vel[1.5]' the message does not have, listing its fields
    (``beams[-1].velocity`` as 'beams[-1]'): the index, not the field, is what is wrong."""
    mission, _, standard, _, _ = recorded
    bag = _retyped(standard, tmp_path / "five", "geometry_msgs/Vector3 velocity\nvendor/Beam[] beams\n"
                   "float64[5] beam_vel\n", lambda m, T: dict(velocity=m.velocity, beams=_beams(m, T, 5),
                                                                beam_vel=np.zeros(5)))
    bad = beams if isinstance(beams, str) else beams[1]
    with pytest.raises(ConfigError, match=rf"^bag_topics\.dvl\.beams = .*: {re.escape(repr(bad))} has an index that "
                                          r"is no whole number from 0: name one element as 'list\[2\]' .*, every "
                                          r"element as 'list\[\]'"):
        _read(bag, mission.config, v_b="velocity", beams=beams)


def test_an_index_past_the_end_of_the_message_lists_is_refused_or_warned_and_counted(recorded, tmp_path):
    """``beams[7].velocity`` on four-beam lists read beam 4 as missing in every ping, without a word. Past the end
    of every message's list it is refused naming the key, the topic and the lengths seen; past the end of some
    messages' lists (a beam the message lacks) it is warned about, naming the first message, and counted."""
    mission, _, standard, _, _ = recorded
    bag = _retyped(standard, tmp_path / "short", "geometry_msgs/Vector3 velocity\nvendor/Beam[] beams\n",
                   lambda m, T: dict(velocity=m.velocity, beams=_beams(m, T, 4)))
    fields = dict(v_b="velocity", beams=[f"beams[{i}].velocity" for i in (0, 1, 2, 7)])
    with pytest.raises(DataError, match=r"bag_topics\.dvl\.beams = .*: 'beams\[7\]\.velocity' is past the end of "
                                        r"every message's list 'beams' of /dvl/data \(vendor/msg/Dvl\): 4 elements "
                                        r"\(\[0\] to \[3\]\)"):
        _read(bag, mission.config, **fields)
    # every tenth message has three beams: their beam 4 is missing
    bag = _retyped(standard, tmp_path / "some", "geometry_msgs/Vector3 velocity\nvendor/Beam[] beams\n",
                   lambda m, T: dict(velocity=m.velocity, beams=_beams(m, T, 3 if m.header.stamp.sec % 10 == 0 else 4)))
    import dataclasses
    dvl_topic = {"topic": "/dvl/data", "v_b": "velocity", "beams": [f"beams[{i}].velocity" for i in range(4)]}
    config = dataclasses.replace(mission.config, bag_topics={"dvl": dvl_topic})
    with pytest.warns(RuntimeWarning, match=r"bag_topics\.dvl\.beams: 'beams\[3\]\.velocity' is past the end of the "
                                            r"list 'beams' in (\d+) of (\d+) messages of /dvl/data \(3 elements\), "
                                            r"first at message 0 \(t = 0\.000 s\)"):
        m = bags.load_bag(bag, config)
    short = np.isnan(m.dvl.beams[:, 3])
    assert short.sum() == 5 and not m.dvl.valid[short, 3].any()
    assert m.meta["streams"]["dvl"]["doubted"] == {
        "bag_topics.dvl.beams past the end of the message's list: the beam read as missing": 5}


def _int16_mm_s(standard, path):
    """``standard`` with its DVL velocity and beams as a raw driver's int16 mm/s (vx, vy, vz; beam_vel, -32768 for
    no beam; beam_ok)."""
    return _retyped(standard, path, "int16 vx\nint16 vy\nint16 vz\nint16[4] beam_vel\nuint8[4] beam_ok\n",
                    lambda m, T: dict(vx=np.int16(round(m.velocity.x * 1000)), vy=np.int16(round(m.velocity.y * 1000)),
                                      vz=np.int16(round(m.velocity.z * 1000)), beam_vel=np.array(
                                          [round(b.velocity * 1000) if b.valid else -32768 for b in m.beams], np.int16),
                                      beam_ok=np.array([b.valid for b in m.beams], np.uint8)))


def test_integer_velocities_read_in_their_declared_unit(recorded, tmp_path):
    """A raw driver's int16 mm/s velocities were refused as needing float fields; they read in the declared unit,
    -32768 (no beam) invalid, within the 0.5 mm/s of rounding to integers."""
    mission, _, standard, _, _ = recorded
    ref = bags.load_bag(standard, mission.config).dvl
    bag = _int16_mm_s(standard, tmp_path / "int16")
    dvl = _read(bag, mission.config, v_b=["vx", "vy", "vz"], beams="beam_vel", valid="beam_ok", velocity_unit="mm/s")
    np.testing.assert_array_equal(dvl.valid, ref.valid)
    np.testing.assert_allclose(dvl.beams[ref.valid], ref.beams[ref.valid], atol=5e-4)
    np.testing.assert_allclose(dvl.v_d, ref.v_d, atol=5e-4)
    np.testing.assert_array_equal(dvl.v_d_valid, ref.v_d_valid)


def test_integer_mm_s_beams_and_velocity_undeclared_are_said_read_as_mm_s_once_naming_both(recorded, tmp_path):
    """The int16 mm/s velocities above with no velocity_unit: detected as mm/s and converted, which was warned and
    noted twice, once for the beams and once for the velocity. Once now, naming both fields."""
    mission, _, standard, _, _ = recorded
    ref = bags.load_bag(standard, mission.config).dvl
    bag = _int16_mm_s(standard, tmp_path / "int16")
    import dataclasses
    config = dataclasses.replace(mission.config, bag_topics={"dvl": {
        "topic": "/dvl/data", "v_b": ["vx", "vy", "vz"], "beams": "beam_vel", "valid": "beam_ok"}})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = bags.load_bag(bag, config)
    said = [str(w.message) for w in caught if "read as mm/s" in str(w.message)]
    assert len(said) == 1 and said[0].endswith("/dvl/data: DVL velocities read as mm/s (median speed 564 in beams "
                                               "'beam_vel', 2137 in v_b 'vx, vy, vz') and converted to m/s"), said
    assert len([n for n in m.meta["streams"]["dvl"]["notes"] if "read as mm/s" in n]) == 1
    np.testing.assert_allclose(m.dvl.beams[ref.valid], ref.beams[ref.valid], atol=5e-4)
    np.testing.assert_allclose(m.dvl.v_d, ref.v_d, atol=5e-4)


def test_beam_flags_without_the_beams_leave_the_velocity_valid_where_three_beams_were(recorded):
    """The beams' flags named without the beams (a velocity-only reading that keeps the driver's beam flags): every
    beam was NaN, so no ping had three valid beams and every velocity was dropped. The flags count as read, as a
    column map's do."""
    mission, root, standard, vendor, plain = recorded
    fields = {"topic": "/dvl/data", "v_b": "velocity", "valid": "beams[].valid"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = load_mission(vendor, _config(root, "flags_only.json", fields), prepare=False)
        b = load_mission(vendor, _config(root, "velocity_only.json", {"topic": "/dvl/data", "v_b": "velocity"}),
                         prepare=False)
    assert a.dvl.v_d_valid.sum() == b.dvl.v_d_valid.sum() > 0.9 * len(mission.dvl.t)


def test_reading_the_named_fields_notes_them_in_the_dvl_stream():
    """The fields ``bag_topics.dvl`` named are said in the DVL stream's notes by the reading itself, as recorded for
    ``graphnav info``, whoever reads them."""
    from types import SimpleNamespace as Msg

    from graphnav.io import bag_fields
    rows = [Msg(velocity=Msg(x=1.0, y=0.01 * i, z=0.0)) for i in range(5)]
    meta, info = {}, {}
    bag_fields.read(Msg(topic="/dvl/data", msgtype=VENDOR, rows=rows), {"topic": "/dvl/data", "v_b": "velocity"},
                    np.eye(3), "vendor.mcap", meta, info)
    assert info["dvl_fields"] == {"topic": "/dvl/data", "v_b": "velocity", "frame": "instrument",
                                  "velocity_unit": "m/s"}
    assert meta["streams"]["dvl"]["notes"] == [f"fields of {VENDOR} named by bag_topics.dvl: "
                                               + json.dumps(info["dvl_fields"])]


@pytest.mark.parametrize("fields, named", [(None, "velocity"), (FIELDS, "velocity"),
                                           ({"topic": "/dvl/data", "beams": "beams[].velocity",
                                             "valid": "beams[].valid"}, r"beams\[\]\.velocity")])
def test_the_envelope_refusing_a_bag_dvl_names_the_topic_and_the_fields(recorded, fields, named):
    """A DVL faster than the vehicle's envelope (``dvl.max_speed_mps`` 1 m/s for a 2.1 m/s mission) is refused for
    over half its pings beyond it: the refusal named the topic but ``field 'dvl'``, the stream. It names the message's
    fields now, as a column map's refusal names its columns: the velocity's (the standard message's, or those
    ``bag_topics.dvl`` names), the beams' where only they are read."""
    _, root, standard, vendor, _ = recorded
    cfg = json.loads((root / "plain.json").read_text())
    cfg["dvl"]["max_speed_mps"] = 1.0
    if fields:
        cfg["bag_topics"] = {"dvl": fields}
    (root / "slow.json").write_text(json.dumps(cfg))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=rf"{'vendor' if fields else 'standard'}:/dvl/data \(.*\), field "
                                            rf"'{named}': \d+ of \d+ dvl samples refused \(\d+ outside the envelope "
                                            r"\(speed\)\): more than 50% of the stream"):
            load_mission(vendor if fields else standard, root / "slow.json")
