"""The DVL messages real drivers publish, the typestore that reads them, and telling a bag's kind by content.

Message definitions (``.msg`` text; comments and constants dropped: they are not serialized):

* ``dvl_msgs/msg/DVL`` + ``DVLBeam``: Water Linked's DVL-A50 message. Its ROS 1 driver
  (``waterlinked/dvl-a50-ros-driver``, ``msg/DVL.msg``, ``msg/DVLBeam.msg``) defines header, time, velocity, fom,
  altitude, beams, velocity_valid, status, form; the ROS 2 package ``dvl_msgs`` that Water Linked's documentation
  pointed ROS 2 users to (``paagutie/dvl_msgs``, used by ``paagutie/dvl-a50``) started as the same message
  (:data:`DVL_MSGS_DVL_A50`) and later added the JSON protocol v3 fields covariance, time_of_validity and
  time_of_transmission (:data:`DVL_MSGS_DVL_V3`, as other projects reading these bags copy it). A bag without
  embedded definitions (sqlite3, rosbag2 before Iron) does not say which one it holds, so
  :func:`fit_definition` tries both on the recorded bytes and keeps the one that decodes them exactly.
* ``marine_acoustic_msgs/msg/Dvl``: the community message (``apl-ocean-engineering/marine_msgs``,
  ``marine_acoustic_msgs/msg/Dvl.msg``, released in ROS 2 Humble..Kilted), which Water Linked's current ROS 2
  driver (``waterlinked/waterlinked_dvl``) publishes.

A bag's own definitions (MCAP, rosbag2 >= Iron, every ROS 1 bag) are always preferred to these.
"""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

from graphnav.core.errors import ConfigError

DVL_MSGS_DVLBEAM = """\
int64 id
float64 velocity
float64 distance
float64 rssi
float64 nsd
bool valid
"""
#: The A50 message as first released (Water Linked's ROS 1 driver; dvl_msgs for ROS 2 before protocol v3).
DVL_MSGS_DVL_A50 = """\
std_msgs/Header header
float64 time
geometry_msgs/Vector3 velocity
float64 fom
float64 altitude
DVLBeam[] beams
bool velocity_valid
int64 status
string form
"""
#: dvl_msgs with the JSON protocol v3 fields (velocity covariance, validity and transmission times in us).
DVL_MSGS_DVL_V3 = """\
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
#: Candidate definitions of ``dvl_msgs/msg/DVL`` for a bag that does not embed it, in the order tried.
DVL_MSGS_VARIANTS = {"dvl_msgs v3 (covariance, time_of_validity)": DVL_MSGS_DVL_V3,
                     "dvl_msgs A50 (Water Linked's first release)": DVL_MSGS_DVL_A50}
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

#: The first bytes of each bag kind (ROS 1 v2.0, MCAP, sqlite3).
MAGIC = {"ros1": b"#ROSBAG V2.0", "mcap": b"\x89MCAP0\r\n", "sqlite3": b"SQLite format 3\x00"}
#: The suffix each kind must carry for rosbags' readers, which choose by suffix.
SUFFIX = {"ros1": ".bag", "mcap": ".mcap", "sqlite3": ".db3"}


def require_rosbags():
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise ConfigError("reading/writing ROS bags needs the 'rosbags' package: pip install 'graphnav[ros]'") \
            from None


def typestore(dvl_definition: str = DVL_MSGS_DVL_V3):
    """The ROS 2 Humble typestore of rosbags plus the DVL messages (``dvl_msgs/msg/DVL`` as
    ``dvl_definition``)."""
    require_rosbags()
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    store = get_typestore(Stores.ROS2_HUMBLE)
    types = {}
    types.update(get_types_from_msg(DVL_MSGS_DVLBEAM, WL_BEAM))
    types.update(get_types_from_msg(dvl_definition, WL_DVL))
    types.update(get_types_from_msg(MARINE_ACOUSTIC_DVL, MARINE_DVL))
    store.register(types)
    return store


def bag_kind(path: str | Path) -> str | None:
    """``"ros1"``, ``"mcap"``, ``"sqlite3"`` for a file with that magic, ``"rosbag2"`` for a folder with
    ``metadata.yaml``, else None (whatever the name or extension)."""
    path = Path(path)
    if path.is_dir():
        return "rosbag2" if (path / "metadata.yaml").is_file() else None
    if not path.is_file():
        return None
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        return None
    for kind, magic in MAGIC.items():
        if head.startswith(magic):
            return kind
    return None


@contextmanager
def readable_path(path: Path, kind: str):
    """``path``, or a link to it carrying the suffix rosbags' readers choose the format by (a ROS 1 bag
    named ``.log``, an MCAP file without extension)."""
    want = SUFFIX.get(kind)
    if want is None or path.suffix == want:
        yield path
        return
    with tempfile.TemporaryDirectory(prefix="graphnav-bag-") as tmp:
        link = Path(tmp) / f"{path.stem or 'bag'}{want}"
        os.symlink(path.resolve(), link)
        yield link


def fit_definition(raws: list[bytes]) -> tuple[str, object]:
    """The ``dvl_msgs/msg/DVL`` variant (name, typestore) that decodes every one of ``raws`` (CDR) exactly;
    raises ``ValueError`` naming what each variant did when none does."""
    failures = []
    for name, text in DVL_MSGS_VARIANTS.items():
        store = typestore(text)
        try:
            for raw in raws:
                store.deserialize_cdr(raw, WL_DVL)
        except Exception as exc:  # noqa: BLE001 - rosbags raises several decoding errors
            failures.append(f"{name}: {exc}")
            continue
        return name, store
    raise ValueError("; ".join(failures))
