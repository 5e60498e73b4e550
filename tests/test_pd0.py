"""Teledyne RDI PD0 through MHKiT's dolfyn.

No PD0 sample ships in the installed packages (MHKiT's and dolfyn's wheels carry no example data), so the test
writes a *synthetic* PD0 file following the Workhorse PD0 layout that dolfyn's reader expects (firmware
16.30: header 0x7F7F with data-type offsets, 59-byte fixed leader 0x0000, 65-byte variable leader 0x0080
with the Y2K clock, one water-profile cell 0x0100, 85-byte bottom track 0x0600, checksum), with the bottom-
track beam velocities of a simulated mission in mm/s and -32768 where a beam is invalid.
"""
from __future__ import annotations

import datetime as dt
import json
import re
import struct
import warnings

import numpy as np
import pytest

from graphnav import cli
from graphnav.core.errors import DataError
from graphnav.io.pd0 import read_pd0_log
from graphnav.missions import load_mission
from graphnav.sim.simulate import simulate_mission

pytest.importorskip("mhkit.dolfyn", reason="graphnav[pd0] not installed (scripts/setup_env.sh installs it)")

START = dt.datetime(2024, 5, 1, 12, 0, 0, tzinfo=dt.timezone.utc)


def _ensemble(number: int, when: dt.datetime, beams_mms: np.ndarray, pressure_dpa: int, coord_ex: int = 0) -> bytes:
    fixed = struct.pack("<H", 0x0000) + bytes([16, 30]) + struct.pack("<H", 0b0100_1010 | (0b0000_0010 << 8))
    # sim flag, lag, beams, cells, pings, cell size cm, blank cm, mode, corr, code reps, %gd, err vel mm/s,
    # TPP min/s/hundredths, EX, EA, EB, EZ, sensors available, bin 1 cm, pulse cm, ref layer, false target,
    # spare, lag cm, CPU serial (8), bandwidth, power, spare, serial, beam angle.
    fixed += bytes([0, 0, 4, 1]) + struct.pack("<HHH", 1, 100, 50) + bytes([1, 64, 5, 0])
    fixed += struct.pack("<H", 2000) + bytes([0, 1, 0, coord_ex]) + struct.pack("<hh", 0, 0) + bytes([0x7D, 0x3D])
    fixed += struct.pack("<HH", 150, 120) + bytes([1, 5, 50, 0]) + struct.pack("<H", 30) + bytes(8)
    fixed += struct.pack("<H", 0) + bytes([255, 0]) + struct.pack("<I", 1234) + bytes([30])
    assert len(fixed) == 59
    hundredths = when.microsecond // 10000
    rtc = bytes([when.year % 100, when.month, when.day, when.hour, when.minute, when.second, hundredths])
    var = struct.pack("<H", 0x0080) + struct.pack("<H", number & 0xFFFF) + rtc + bytes([number >> 16])
    var += struct.pack("<HHH", 0, 1500, 100) + struct.pack("<Hhhhh", 9000, 0, 0, 35, 1500) + bytes([0, 0, 0])
    var += bytes([0, 0, 0]) + bytes(8) + struct.pack("<I", 0) + bytes(2) + struct.pack("<II", pressure_dpa & 0xFFFFFFFF, 0)
    var += bytes(1) + bytes([when.year // 100]) + bytes([when.year % 100]) + rtc[1:]
    assert len(var) == 65
    vel = struct.pack("<H", 0x0100) + struct.pack("<4h", 0, 0, 0, 0)
    bt = struct.pack("<H", 0x0600) + bytes(14) + struct.pack("<4H", *[1000] * 4)
    bt += struct.pack("<4h", *beams_mms.astype(int)) + bytes([200] * 4) + bytes([80] * 4) + bytes([100] * 4)
    bt += bytes(26) + bytes(7) + bytes(4) + bytes(4)
    assert len(bt) == 85
    blocks = [fixed, var, vel, bt]
    n_hdr = 6 + 2 * len(blocks)
    offsets, pos = [], n_hdr
    for b in blocks:
        offsets.append(pos)
        pos += len(b)
    header = bytes([0x7F, 0x7F]) + struct.pack("<H", pos) + bytes([0, len(blocks)]) + struct.pack(f"<{len(blocks)}H", *offsets)
    body = header + b"".join(blocks)
    return body + struct.pack("<H", sum(body) & 0xFFFF)


def write_pd0(path, mission, coord_ex: int = 0, raw_mms: np.ndarray | None = None,
              pressure_dpa: np.ndarray | None = None, t_s: np.ndarray | None = None) -> None:
    """The mission's DVL pings as PD0 ensembles (beam coordinates, mm/s, -32768 where invalid; or ``raw_mms``
    (M,4) as the bottom-track velocities) with the depth as pressure (decapascal, gauge), numbered from 1 and
    stamped at the pings' times (or ``t_s``, s after :data:`START`)."""
    dvl = mission.dvl
    beams = np.where(dvl.valid, np.round(dvl.beams * 1000.0), -32768) if raw_mms is None else raw_mms
    depth = np.interp(dvl.t, mission.depth.t, mission.depth.depth)
    p_dpa = np.round(depth * 1025.0 * mission.config.gravity_mps2 / 10.0).astype(np.int64)
    if pressure_dpa is not None:
        p_dpa = pressure_dpa
    with open(path, "wb") as f:
        for k, t in enumerate(dvl.t if t_s is None else t_s):
            f.write(_ensemble(k + 1, START + dt.timedelta(seconds=float(t)), beams[k], int(p_dpa[k]), coord_ex))


def _load_written_pd0(sim, tmp_path, **written):
    """The module's mission written as a PD0 file (``written``: :func:`write_pd0`'s options) beside its IMU, GT and
    configuration, loaded: (mission, the warnings)."""
    mission, root = sim
    write_pd0(tmp_path / "dvl.000", mission, **written)
    return _load_pd0_beside_imu(sim, tmp_path)


def _load_pd0_beside_imu(sim, tmp_path):
    """``tmp_path / "dvl.000"`` loaded beside the module's IMU, GT and configuration: (mission, the warnings)."""
    _, root = sim
    for name in ("imu.csv", "nav.csv", "config.json"):
        (tmp_path / name).write_bytes((root / name).read_bytes())
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        return load_mission(tmp_path / "dvl.000", tmp_path / "config.json"), rec


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    from graphnav.core.config import SensorConfig
    root = tmp_path_factory.mktemp("pd0")
    config = SensorConfig()
    # A convex RDI head in graphnav's DVL frame (x toward beam 3, y toward beam 2, z along the beams), 30 deg.
    config.dvl.psi_rad = np.deg2rad([270.0, 90.0, 0.0, 180.0])
    config.dvl.theta_rad = np.deg2rad(30.0)
    mission = simulate_mission(duration_s=40.0, seed=7, config=config, dropout=True)
    assert (~mission.dvl.valid).any()
    write_pd0(root / "dvl.000", mission)
    t0 = START.timestamp()
    rows = ["t,ax,ay,az,gx,gy,gz"] + [",".join(f"{x:.12g}" for x in (t + t0, *f, *w))
                                       for t, f, w in zip(mission.imu.t, mission.imu.f_b, mission.imu.omega_b)]
    (root / "imu.csv").write_text("\n".join(rows) + "\n")
    from graphnav.core.rotations import C_b_n_to_euler
    g = mission.gt
    rows = ["t,n,e,d,vn,ve,vd,roll,pitch,yaw"] + [",".join(f"{x:.12g}" for x in (t + t0, *p, *v, *e)) for t, p, v, e
                                                  in zip(g.t, g.p_n, g.v_n, C_b_n_to_euler(g.C_b_n))]
    (root / "nav.csv").write_text("\n".join(rows) + "\n")
    cfg = mission.config.to_dict()
    cfg["csv_columns"] = {"imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"]},
                          "gt": {"file": "nav.csv", "t": "t", "p_n": ["n", "e", "d"], "v_n": ["vn", "ve", "vd"],
                                 "euler": ["roll", "pitch", "yaw"]}}
    (root / "config.json").write_text(json.dumps(cfg))
    return mission, root


def test_pd0_bottom_track_beams_validity_and_depth(sim):
    mission, root = sim
    with pytest.warns(RuntimeWarning, match="-32768"):
        m = load_mission(root / "dvl.000", root / "config.json")
    # dolfyn keeps an ensemble only when another header follows it (a file's last ensemble may be cut off
    # by a logger), so the last ping is not read.
    sim_dvl = mission.dvl.take(slice(0, len(mission.dvl.t) - 1))
    np.testing.assert_allclose(m.dvl.t, sim_dvl.t, atol=1e-6)
    np.testing.assert_array_equal(m.dvl.valid, sim_dvl.valid)   # -32768 -> invalid, per beam
    np.testing.assert_allclose(m.dvl.beams[m.dvl.valid], sim_dvl.beams[sim_dvl.valid], atol=5e-4)  # mm/s
    assert m.meta["pd0_invalid_beams"] == int((~sim_dvl.valid).sum())
    assert m.meta["pd0_beam_angle_deg"] == 30 and m.meta["pd0_beam_pattern"] == "convex"
    np.testing.assert_allclose(m.config.dvl.psi_rad, mission.config.dvl.psi_rad)
    np.testing.assert_allclose(m.depth.depth, np.interp(sim_dvl.t, mission.depth.t, mission.depth.depth),
                               atol=2e-3)   # the dPa resolution


def test_pd0_mission_smooths_like_the_simulation(sim, tmp_path):
    mission, root = sim
    out = tmp_path / "out"
    assert cli.main(["smooth", "--data", str(root / "dvl.000"), "--config", str(root / "config.json"),
                     "--method", "Graph-TC", "--out", str(out), "--no-plots"]) == 0
    from graphnav.evaluation.metrics import vrmse
    from graphnav.io.outputs import read_trajectory_csv
    assert vrmse(read_trajectory_csv(out / "trajectory.csv"), mission.gt) < 0.1


def _rotated_mms(mission, frame: str) -> np.ndarray:
    """The simulated pings as an RDI bottom track in ``frame`` at the synthetic file's attitude (heading 90
    deg, no tilt): the seabed's velocity relative to the head plus RDI's error velocity
    ``(B1 + B2 - B3 - B4) / (2 sqrt(2) sin theta)``, mm/s, -32768 for pings with fewer than 4 beams. RDI's
    instrument X/Y/Z are graphnav's y_d, x_d, -z_d; without tilt the ship frame is the instrument frame; the
    earth frame at heading 90 deg is E = Y, N = -X, U = Z."""
    from graphnav.core.dvl import DvlGeometry
    dvl = mission.dvl
    T_d = DvlGeometry.from_spec(mission.config.dvl).T_d
    v_d = np.linalg.lstsq(T_d, np.where(dvl.valid, dvl.beams, 0.0).T, rcond=None)[0].T
    seabed = -np.stack([v_d[:, 1], v_d[:, 0], -v_d[:, 2]], axis=1)
    if frame == "earth":
        seabed = np.stack([seabed[:, 1], -seabed[:, 0], seabed[:, 2]], axis=1)
    b = np.where(dvl.valid, dvl.beams, 0.0)
    err = (b[:, 0] + b[:, 1] - b[:, 2] - b[:, 3]) / (2 * np.sqrt(2) * np.sin(mission.config.dvl.theta_rad))
    out = np.column_stack([seabed, err])
    return np.where(dvl.valid.all(axis=1, keepdims=True), np.round(out * 1000.0), -32768)


#: EX bits of each frame with tilts, 3-beam solutions and bin mapping on.
EX_BITS = {"instrument": 0b0000_1111, "ship": 0b0001_0111, "earth": 0b0001_1111}


@pytest.mark.parametrize("frame", sorted(EX_BITS))
def test_pd0_rotated_frames_come_back_to_beams(sim, tmp_path, frame):
    mission, root = sim
    dvl = mission.dvl
    write_pd0(tmp_path / "dvl.pd0", mission, coord_ex=EX_BITS[frame], raw_mms=_rotated_mms(mission, frame))
    for name in ("imu.csv", "nav.csv", "config.json"):
        (tmp_path / name).write_text((root / name).read_text())
    with pytest.warns(RuntimeWarning, match="no bottom lock"):
        m = load_mission(tmp_path / "dvl.pd0", tmp_path / "config.json")
    full = dvl.valid.all(axis=1)[:-1]            # dolfyn does not read the last ensemble
    np.testing.assert_array_equal(m.dvl.valid.all(axis=1), full)
    # Four rounded mm/s components spread over four beams: within 2 mm/s of the simulated beams.
    np.testing.assert_allclose(m.dvl.beams[full], dvl.beams[:-1][full], atol=2e-3)
    assert m.meta["pd0_frame"] == frame
    assert m.meta["streams"]["dvl"]["refused"]["no bottom lock"] == int((~full).sum())


def test_pd0_needs_an_imu(sim):
    mission, root = sim
    from graphnav.core.errors import ConfigError
    with pytest.raises(ConfigError, match="holds the DVL only"):
        load_mission(root / "dvl.000", None)


def test_pd0_pressure_that_is_not_a_depth_is_invalid_and_counted(sim, tmp_path):
    """0xFFFFFFFF (no sensor) and a 12 km depth never become depths: NaN in the log, dropped from the mission's
    depth stream, counted per reason in meta['streams'] and warned about."""
    from graphnav.io.dvl_files import read_dvl
    from graphnav.io.pd0 import read_pd0
    mission, root = sim
    n = len(mission.dvl.t)
    p = np.full(n, 5000, dtype=np.int64)                       # 5000 daPa: about 5 m
    p[[3, 7]] = 0xFFFFFFFF
    p[11] = round(12000.0 * 1025.0 * 9.81 / 10.0)
    write_pd0(tmp_path / "p.000", mission, pressure_dpa=p)
    # named by the ensemble's number and byte offset, as the DVL's messages are, not the index into the arrays
    with pytest.warns(RuntimeWarning, match=r"bad pressure word.*first at ensemble \d+ \(byte \d+\); marked") as said:
        log = read_dvl(tmp_path / "p.000")
    assert f"{log.where[3]}; marked" in next(str(w.message) for w in said if "bad pressure word" in str(w.message))
    assert f"{log.where[11]}; marked" in next(str(w.message) for w in said if "out of range" in str(w.message))
    assert log.counts["bad pressure word"] == 2 and log.counts["depth out of range"] == 1
    assert np.isnan(log.depth_m[[3, 7, 11]]).all() and np.isfinite(np.delete(log.depth_m, [3, 7, 11])).all()
    with pytest.warns(RuntimeWarning, match="depth out of range"):
        _, depth, meta = read_pd0(tmp_path / "p.000")
    assert len(depth.t) == n - 1 - 3 and depth.depth.max() < 6.0      # the last ensemble is not read
    assert meta["streams"]["depth"]["refused"] == {"bad pressure word": 2, "depth out of range": 1}


def test_rdi_beam_geometry_in_the_dvl_frame():
    """RDI's nominal beam matrices (dolfyn's) in graphnav's frame: convex 270, 90, 0, 180 deg, concave 90, 270,
    180, 0 deg, both at the beam angle, through a proper rotation; a beam velocity equals u_i . v_d."""
    from graphnav.io import pd0
    pd0._import_dolfyn()
    from mhkit.dolfyn.rotate.rdi import _calc_beam_orientmat
    assert np.linalg.det(pd0.C_D_RDI) == pytest.approx(1.0)
    for convex, psi in ((True, [270, 90, 0, 180]), (False, [90, 270, 180, 0])):
        b2i = _calc_beam_orientmat(25, convex).astype(float)
        theta, az = pd0.rdi_geometry(b2i)
        assert np.rad2deg(theta) == pytest.approx(25.0, abs=1e-5)
        np.testing.assert_allclose(np.rad2deg(az), psi, atol=1e-5)
        # a head velocity v_d: RDI's beams of the seabed's motion (-v in RDI's frame) are u_i . v_d
        v_d = np.array([1.2, -0.3, 0.2])
        beams = np.linalg.inv(b2i)[:, :3] @ (-(pd0.C_D_RDI.T @ v_d))
        np.testing.assert_allclose(beams, pd0.rdi_beam_vectors_d(b2i) @ v_d, atol=1e-6)


def _fake_ensemble(length: int) -> bytes:
    """A PD0 ensemble of ``length`` bytes before its checksum with no data block (header, zeros, checksum)."""
    body = bytes([0x7F, 0x7F]) + struct.pack("<H", length) + bytes(length - 4)
    return body + struct.pack("<H", sum(body) & 0xFFFF)


def test_a_file_cut_inside_an_ensemble_is_found(tmp_path):
    """The scan finds an ensemble the end of the file cuts (its offset, the bytes present, the length its header
    gives); a whole file and trailing bytes that are no header give none."""
    from graphnav.io.pd0 import scan_pd0
    whole = _fake_ensemble(40) + _fake_ensemble(42)     # two ensembles (the same bytes twice are one, repeated)
    path = tmp_path / "cut.pd0"
    path.write_bytes(whole + _fake_ensemble(60)[:25])
    scan = scan_pd0(path)
    assert (scan.ensembles, scan.cut_offset, scan.cut_bytes, scan.cut_length) == (2, len(whole), 25, 62)
    path.write_bytes(whole + b"\x7f\x7f\x10")          # cut inside the header: its length is lost
    assert (scan_pd0(path).cut_bytes, scan_pd0(path).cut_length) == (3, 0)
    for tail in (b"", b"\r\n"):
        path.write_bytes(whole + tail)
        assert scan_pd0(path).cut_bytes == 0


def test_a_cut_last_ensemble_is_warned_about_and_counted(sim, tmp_path):
    """A PD0 file that ends inside an ensemble (a copy cut short) reads its complete ensembles, and says so: a
    warning naming the file and the cut, a count in the log and a note of the DVL stream. It was dropped without a
    word."""
    from graphnav.io.inspect import describe
    from graphnav.io.pd0 import CUT_ENSEMBLE, read_pd0
    mission, root = sim
    raw = (root / "dvl.000").read_bytes()
    cut = tmp_path / "cut.000"
    cut.write_bytes(raw[:len(raw) - 30])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_pd0_log(cut)
    said = [str(w.message) for w in caught if "ends inside an ensemble" in str(w.message)]
    assert len(said) == 1 and said[0].startswith(f"{cut}: the file ends inside an ensemble (")
    n = len(mission.dvl.t)
    assert log.counts[CUT_ENSEMBLE] == 1 and log.counts["ensembles in file"] == n - 1 and len(log.t) == n - 1
    assert CUT_ENSEMBLE not in log.refused()           # not a ping read: as a corrupt ensemble, a note
    with pytest.warns(RuntimeWarning, match="ends inside an ensemble"):
        _, _, meta = read_pd0(cut)
    assert f"1 {CUT_ENSEMBLE}" in meta["streams"]["dvl"]["notes"]
    assert f"1 {CUT_ENSEMBLE}" in describe(cut)["streams"]["dvl"]["notes"]
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=".*ends inside an ensemble")
        assert CUT_ENSEMBLE not in read_pd0_log(root / "dvl.000").counts


@pytest.mark.parametrize("content", [b"", b"not a pd0\n"], ids=["empty", "text"])
def test_info_on_a_pd0_name_without_ensembles_leaves_no_file_open(tmp_path, content):
    """dolfyn leaves its file open when it fails; ``info`` closes it (it warned ``ResourceWarning: unclosed
    file``)."""
    from graphnav.io.inspect import describe
    path = tmp_path / "x.pd0"
    path.write_bytes(content)
    d = describe(path)
    assert d["format"] == "pd0" and not d["usable"] and "holds no PD0 ensemble" in d["reason"]
    assert not [w for w in d["warnings"] if "ResourceWarning" in w], d["warnings"]


def test_smooth_of_a_dvl_file_alone_names_the_method_and_the_options_it_ignores(sim, tmp_path):
    """A PD0 file without an IMU is dead-reckoned: the warning names the method asked for, and the options that
    apply to the IMU/DVL estimators (--compare, --window-start) are named as ignored in the summary too."""
    _, root = sim
    out = tmp_path / "dr"
    with pytest.warns(RuntimeWarning) as caught:
        assert cli.main(["smooth", "--data", str(root / "dvl.000"), "--method", "TC", "--compare", "Graph-HN", "LC",
                         "--window-start", "5", "--no-plots", "--out", str(out)]) == 0
    said = json.loads((out / "summary.json").read_text())["warnings"]
    assert said[0].endswith("not graphnav's IMU/DVL estimator (TC). To run the estimator, give the IMU in the "
                            "configuration's csv_columns map (--config with \"csv_columns\": {\"imu\": {\"file\": ..., "
                            "\"t\": ..., \"f_b\": [...], \"omega_b\": [...]}, \"dvl\": {\"pd0\": \"dvl.000\"}}; see "
                            "graphnav.io.generic_csv)")
    assert said[1] == f"{root / 'dvl.000'}: --compare Graph-HN LC, --window-start 5.0 ignored: they apply to the " \
                      "IMU/DVL estimators"
    assert said[1] in [str(w.message) for w in caught]


def test_smooth_of_a_dvl_file_alone_spreads_ensembles_that_share_a_time_as_beside_an_imu(sim, tmp_path):
    """A PD0 file whose clock (with hundredths) repeats each time for three pings, dead-reckoned alone: the pings are
    spread within the clock's tick as beside an IMU (here onto the 1 s they were taken at), warned about and counted
    as doubted, and the track is the clean file's. It was refused: "ping stamps do not increase", no advice."""
    spread_key = "ensemble time shared with the ping before (stamp spread after it)"       # pd0.SPREAD_TIME
    mission, _ = sim
    t = mission.dvl.t
    write_pd0(tmp_path / "clean.000", mission, t_s=t + 0.37)
    write_pd0(tmp_path / "dvl.000", mission, t_s=3.0 * np.floor(t / 3.0) + 0.37)
    tracks = {}
    for name in ("clean", "dvl"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            assert cli.main(["smooth", "--data", str(tmp_path / f"{name}.000"), "--no-plots",
                             "--out", str(tmp_path / name)]) == 0
        tracks[name] = np.genfromtxt(tmp_path / name / "trajectory.csv", delimiter=",", skip_header=1)[:, :7]
    np.testing.assert_allclose(tracks["dvl"], tracks["clean"], rtol=0, atol=1e-6)
    summary = json.loads((tmp_path / "dvl" / "summary.json").read_text())
    n = len(tracks["dvl"])
    assert summary["streams"]["dvl"]["doubted"] == {spread_key: n - (n + 2) // 3}
    said = [s for s in summary["warnings"] if "share their ensemble's time" in s]
    assert len(said) == 1 and said[0].split(": ", 1)[1] in summary["streams"]["dvl"]["notes"]


def test_bytes_before_the_first_ensemble_are_warned_about_and_counted(sim, tmp_path):
    """A PD0 file that does not start with an ensemble (a logger that started mid-ensemble, a preamble) reads the
    same pings as the file without those bytes, and says so: a warning naming the file, the bytes and the first
    ensemble's offset, a count in the log and a note of the DVL stream (they were skipped without a word)."""
    from graphnav.io.inspect import describe
    from graphnav.io.pd0 import LEADING_BYTES, read_pd0
    mission, root = sim
    raw = (root / "dvl.000").read_bytes()
    junk = tmp_path / "junk.000"
    junk.write_bytes(b"$PRDIG,logger start\r\n" + raw[7:60] + raw)        # a preamble and a partial ensemble
    n = 21 + 53
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_pd0_log(junk)
    said = [str(w.message) for w in caught if "before it" in str(w.message)]
    assert said == [f"{junk}: the first ensemble starts at byte {n}; the {n} byte(s) before it are no PD0 ensemble "
                    "and are skipped (a logger that started mid-ensemble or wrote a preamble)"]
    clean = read_pd0_log(root / "dvl.000")
    np.testing.assert_array_equal(log.t, clean.t)
    np.testing.assert_array_equal(log.beams, clean.beams)
    assert log.counts[LEADING_BYTES] == n and LEADING_BYTES not in log.refused()
    assert {k: v for k, v in log.counts.items() if k != LEADING_BYTES} == clean.counts
    with pytest.warns(RuntimeWarning, match="before it are no PD0 ensemble"):
        _, _, meta = read_pd0(junk)
    assert f"{n} {LEADING_BYTES}" in meta["streams"]["dvl"]["notes"]
    assert f"{n} {LEADING_BYTES}" in describe(junk)["streams"]["dvl"]["notes"]
    assert LEADING_BYTES not in clean.counts


def test_pd0_pings_of_zero_mm_s_under_way_are_no_bottom_lock(sim, tmp_path):
    """A PD0 file whose bottom track reads 0 mm/s on all four beams for 10 pings between pings of a vehicle under
    way: refused as no bottom lock, counted and warned (the PD0 reader used them as a vehicle standing still)."""
    from graphnav.core.screening import NO_BOTTOM_LOCK
    mission, root = sim
    raw = np.where(mission.dvl.valid, np.round(mission.dvl.beams * 1000.0), -32768)
    raw[10:20] = 0
    m, rec = _load_written_pd0(sim, tmp_path, raw_mms=raw)
    assert m.meta["streams"]["dvl"]["refused"][NO_BOTTOM_LOCK] == 10
    assert not m.dvl.valid[10:20].any()
    # named by the ensemble number and byte offset, as the file holds them, not the ping's index in the arrays
    size = (tmp_path / "dvl.000").stat().st_size // len(mission.dvl.t)           # every ensemble is as long
    said = [str(w.message) for w in rec if NO_BOTTOM_LOCK in str(w.message)]
    assert said and f"at ensemble 11 (byte {10 * size}), ensemble 12 (byte {11 * size})," in said[0]
    assert "dvl_ping_where" not in m.meta


def test_a_hovering_dvl_in_an_earth_frame_pd0_keeps_its_pings_of_zero_mm_s(sim, tmp_path):
    """A PD0 file in the earth frame of a hovering vehicle: its 1 mm/s velocities round to 0, 0, 0 on some pings,
    which are measurements (kept): the file's resolution is PD0's whole mm/s, though the beams rotated back from
    the earth frame are off that grid."""
    from graphnav.core.mission import ImuData, Mission
    from graphnav.io.loaders import screen_mission
    from graphnav.io.pd0 import read_pd0
    mission, _ = sim
    rng = np.random.default_rng(2)
    raw = np.column_stack([rng.integers(-2, 3, (len(mission.dvl.t), 3)), np.zeros(len(mission.dvl.t))])
    raw[[5, 6, 20]] = 0
    write_pd0(tmp_path / "dvl.pd0", mission, coord_ex=EX_BITS["earth"], raw_mms=raw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dvl, depth, meta = read_pd0(tmp_path / "dvl.pd0", mission.config)
    zero = np.all(dvl.beams == 0, axis=1)
    assert zero[[5, 6, 20]].all() and not np.all(np.isin(dvl.beams[~zero], np.arange(-9, 10) / 1000.0))
    imu = ImuData(dvl.t[[0, -1]], np.zeros((2, 3)), np.zeros((2, 3)), "imu")
    m = screen_mission(Mission("hover", imu, dvl, mission.config, None, depth, {**meta, "imu_screened": True}))
    assert "velocity exactly 0 on every axis (no bottom lock)" not in m.meta["streams"]["dvl"].get("refused", {})
    assert m.dvl.valid[zero].all()


def test_a_depth_spike_in_a_pd0_file_is_named_by_its_ensemble(sim, tmp_path):
    """The screening's depth refusals named an index into the depth array; they name the ensemble and its byte."""
    mission, root = sim
    p = np.round(np.interp(mission.dvl.t, mission.depth.t, mission.depth.depth) * 1025.0
                 * mission.config.gravity_mps2 / 10.0).astype(np.int64)
    p[15] += round(30.0 * 1025.0 * mission.config.gravity_mps2 / 10.0)        # 30 m deeper for one ensemble
    m, rec = _load_written_pd0(sim, tmp_path, pressure_dpa=p)
    size = (tmp_path / "dvl.000").stat().st_size // len(mission.dvl.t)
    said = [str(w.message) for w in rec if "depth sample(s) refused" in str(w.message)]
    assert said and f"at ensemble 16 (byte {15 * size}); they are not used" in said[0]
    assert m.meta["streams"]["depth"]["refused"] == {"depth spike": 1} and "depth_where" not in m.meta


def _ensembles_of(path) -> list[bytes]:
    from graphnav.io.pd0 import scan_pd0
    raw = path.read_bytes()
    return [raw[a:b] for a, b in scan_pd0(path).spans]


def _quiet_read(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_pd0_log(path)


@pytest.mark.parametrize("damage", ["two swapped", "halves joined in the wrong order"])
def test_ensembles_stored_out_of_time_order_are_sorted_with_a_counted_warning(sim, tmp_path, damage):
    """Ensembles stored out of time order (two swapped; the file's two halves joined the wrong way round) are put
    in order by their own clock, with which their numbers agree: the pings of the clean file, a warning naming the
    first misplaced ensemble and a count. They were read in file order without a word (time running backwards in
    dead reckoning; with an IMU the file was refused naming a sample, not the ensemble)."""
    sorted_key = "ensemble stored out of time order (sorted)"        # pd0.SORTED_ENSEMBLE
    mission, root = sim
    ens, n = _ensembles_of(root / "dvl.000"), len(mission.dvl.t)
    size, t = len(ens[0]), mission.dvl.t
    if damage == "two swapped":
        parts, moved = ens[:10] + [ens[11], ens[10]] + ens[12:], 2
        first = f"ensemble 11 (byte {11 * size}) is {t[11] - t[10]:.2f} s before ensemble 12 (byte {10 * size})"
    else:
        parts, moved = ens[40:] + ens[:40], n
        first = f"ensemble 1 (byte {(n - 40) * size}) is {t[-1] - t[0]:.2f} s before ensemble {n} (byte " \
                f"{(n - 41) * size})"
    (tmp_path / "dvl.000").write_bytes(b"".join(parts))
    clean = _quiet_read(root / "dvl.000")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_pd0_log(tmp_path / "dvl.000")
    np.testing.assert_array_equal(log.t, clean.t)
    said = [str(w.message) for w in caught if "out of time order" in str(w.message)]
    assert said == [f"{tmp_path / 'dvl.000'}: {moved} ensemble(s) stored out of time order ({first} stored ahead "
                    "of it) sorted by their own clock (the variable leader's), with which their ensemble numbers "
                    "agree"]
    np.testing.assert_array_equal(log.beams, clean.beams)
    assert log.counts == {**clean.counts, sorted_key: moved}
    m, _ = _load_pd0_beside_imu(sim, tmp_path)                 # with an IMU: loaded, not refused
    assert f"{moved} {sorted_key}" in m.meta["streams"]["dvl"]["notes"]
    (tmp_path / "clean").mkdir()
    np.testing.assert_array_equal(m.dvl.t, _load_written_pd0(sim, tmp_path / "clean")[0].dvl.t)


@pytest.mark.parametrize("damage", ["appended to itself", "copied with others between"])
def test_ensembles_copied_anywhere_in_the_file_are_read_once(sim, tmp_path, damage):
    """A file appended to itself, or an ensemble written again after two others (A B C A): the copies (byte for
    byte the same as an earlier ensemble) are left out, counted and named by their ensemble numbers, and the pings
    read are the clean file's. Both were read in file order without a word (the copies a second time, time
    running backwards)."""
    from graphnav.io.pd0 import REPEATED_ENSEMBLE
    mission, root = sim
    raw, ens, n = (root / "dvl.000").read_bytes(), _ensembles_of(root / "dvl.000"), len(mission.dvl.t)
    size = len(ens[0])
    if damage == "appended to itself":
        damaged, copies, named = raw + raw, n, f"ensembles 1-{n} (bytes {len(raw)}-{len(raw) + (n - 1) * size})"
    else:
        damaged, copies, named = b"".join(ens[:13] + [ens[10]] + ens[13:]), 1, f"ensemble 11 (byte {13 * size})"
    (tmp_path / "dvl.000").write_bytes(damaged)
    clean = _quiet_read(root / "dvl.000")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_pd0_log(tmp_path / "dvl.000")
    said = [str(w.message) for w in caught if "written twice" in str(w.message)]
    assert said == [f"{tmp_path / 'dvl.000'}: {copies} ensemble(s) written twice (identical byte for byte to an "
                    f"earlier one: a logger's retry, or a file appended to itself) left out: {named}; {n} read once"]
    np.testing.assert_array_equal(log.t, clean.t)
    np.testing.assert_array_equal(log.beams, clean.beams)
    assert log.counts == {**clean.counts, REPEATED_ENSEMBLE: copies}


def test_ensembles_that_cannot_be_put_in_time_order_are_refused_naming_them(sim, tmp_path):
    """Where the clock and the ensemble numbers disagree, the file is refused naming the ensembles (it was read in
    file order without a word) and saying what a user can do: a clock set back mid-file while the numbers run on
    (cut the file there), two different ensembles at one time with one number, and two recordings overlapping in
    time whose numbers would interleave (a file for each)."""
    from graphnav.core.errors import DataError
    mission, root = sim
    t, size = mission.dvl.t, len(_ensembles_of(root / "dvl.000")[0])
    path = tmp_path / "dvl.000"
    back = t - np.where(np.arange(len(t)) >= 20, 4.5, 0.0)
    write_pd0(path, mission, t_s=back)
    with pytest.raises(DataError, match=rf"field 'time': the ensembles cannot be put in time order: the clock runs "
                                        rf"back {t[19] - back[20]:.2f} s from ensemble 20 \(byte {19 * size}\) to "
                                        rf"ensemble 21 \(byte {20 * size}\) while the ensemble numbers run on: .*; "
                                        rf"cut the file at byte {20 * size} and load each part with its own clock "
                                        r"offset \(dvl_time_offset_s\)"):
        read_pd0_log(path)
    write_pd0(tmp_path / "b.000", mission, raw_mms=np.full((len(t), 4), 100))     # other beams, same numbers
    ens, other = _ensembles_of(root / "dvl.000"), _ensembles_of(tmp_path / "b.000")
    path.write_bytes(b"".join(ens[:21] + [other[20]] + ens[21:]))
    with pytest.raises(DataError, match=rf"ensemble 21 \(byte {20 * size}\) and ensemble 21 \(byte {21 * size}\) "
                                        "hold the same time .* and number but differ"):
        read_pd0_log(path)
    write_pd0(tmp_path / "b.000", mission, t_s=t + 0.25)
    path.write_bytes((root / "dvl.000").read_bytes() + (tmp_path / "b.000").read_bytes())
    with pytest.raises(DataError, match="in time order the ensemble numbers would interleave: .*; load each "
                                        "recording from a file of its own"):
        read_pd0_log(path)


@pytest.mark.parametrize("count", [1, 2])
def test_a_pd0_file_of_one_or_two_ensembles_is_refused_in_graphnav_words(sim, tmp_path, count):
    """dolfyn refuses a file of one ensemble ("No header in this file") and of two (ZeroDivisionError); graphnav
    says how many ensembles the file holds and how many it needs. Three read (two pings: dolfyn's last is kept
    only when a header follows)."""
    from graphnav.core.errors import DataError
    _, root = sim
    ens = _ensembles_of(root / "dvl.000")
    path = tmp_path / "dvl.000"
    path.write_bytes(b"".join(ens[:count]))
    named = ", ".join(f"ensemble {k + 1}" for k in range(count))
    with pytest.raises(DataError, match=rf"dvl.000: only {count} complete ensemble\(s\) with a valid checksum "
                                        rf"\({named}\): too short to read; a PD0 file needs at least 3"):
        read_pd0_log(path)
    path.write_bytes(b"".join(ens[:3]))
    assert len(_quiet_read(path).t) == 2


def _read_with_two_swapped(path, ens: list[bytes], i: int):
    """``ens`` written to ``path`` with the ``i``-th (0-based) and the next swapped, read: (the log, the warnings on
    the time order)."""
    path.write_bytes(b"".join(ens[:i] + [ens[i + 1], ens[i]] + ens[i + 2:]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_pd0_log(path)
    return log, [str(w.message) for w in caught if "out of time order" in str(w.message)]


def _assert_sorted_as(log, clean, said: list[str], first: str) -> None:
    """``log`` read as ``clean`` with two ensembles moved to their time, warned about first as ``first``."""
    assert said and said[0].startswith(first)
    np.testing.assert_array_equal(log.t, clean.t)
    np.testing.assert_array_equal(log.beams, clean.beams)
    assert log.counts == {**clean.counts, "ensemble stored out of time order (sorted)": 2}     # pd0.SORTED_ENSEMBLE


def _numbered(mission, numbers, t_s=None) -> bytes:
    """The mission's pings as ensembles numbered ``numbers`` (the high byte as ``numbers >> 16``), at the pings'
    times or ``t_s`` (s after :data:`START`)."""
    beams = np.where(mission.dvl.valid, np.round(mission.dvl.beams * 1000.0), -32768)
    t_s = mission.dvl.t if t_s is None else t_s
    return b"".join(_ensemble(int(n), START + dt.timedelta(seconds=float(s)), b, 1000)
                    for n, s, b in zip(numbers, t_s, beams))


def test_a_dvl_pinging_faster_than_its_clock_ticks_reads_in_the_order_of_its_ensemble_numbers(sim, tmp_path):
    """A clean file from an instrument pinging at 2 Hz whose clock gives whole seconds (zero hundredths): two
    ensembles share each time. It reads in file order without a word on the order (it was refused: "hold the same
    time but differ"); two swapped within one second are put back by their numbers, warned and counted; numbers
    that restart within one second keep the file's order."""
    sorted_key = "ensemble stored out of time order (sorted)"        # pd0.SORTED_ENSEMBLE
    mission, _ = sim
    t_s = np.floor(mission.dvl.t / 2.0)
    path = tmp_path / "dvl.000"
    write_pd0(path, mission, t_s=t_s)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        clean = read_pd0_log(path)
    assert not [w for w in caught if "time order" in str(w.message)] and sorted_key not in clean.counts
    np.testing.assert_array_equal(clean.t, START.timestamp() + t_s[:-1])
    ens = _ensembles_of(path)
    size = len(ens[0])
    assert t_s[10] == t_s[11] and not np.array_equal(clean.beams[10], clean.beams[11], equal_nan=True)
    log, said = _read_with_two_swapped(path, ens, 10)
    _assert_sorted_as(log, clean, said, f"{path}: 2 ensemble(s) stored out of time order (ensemble 11 (byte "
                      f"{11 * size}) holds the time of ensemble 12 (byte {10 * size}) stored ahead of it and an "
                      "earlier number)")
    # numbers restarting at 1 within one second (the instrument restarted): the file's order is kept, not the
    # numbers' (which would put ensemble 1 before the two ahead of it)
    path.write_bytes(_numbered(mission, np.r_[np.arange(1, 12), np.arange(1, len(t_s) - 10)], t_s))
    restarted = _quiet_read(path)
    assert sorted_key not in restarted.counts
    np.testing.assert_array_equal(restarted.t, clean.t)
    np.testing.assert_array_equal(restarted.beams, clean.beams)


def test_a_pd0_file_across_the_turn_of_1999_reads_in_the_order_of_its_y2k_clock(sim, tmp_path):
    """A clean file recorded across midnight of 1999-12-31 (a Workhorse's variable leader gives the century in its
    Y2K clock, which dolfyn reads): its pings read in file order at their stamps. The order was taken from the
    two-digit year as 20YY, so 2099 ran back to 2000 and the file was refused as a clock set back mid-file."""
    mission, _ = sim
    start = dt.datetime(1999, 12, 31, 23, 59, 50, tzinfo=dt.timezone.utc)
    beams = np.where(mission.dvl.valid, np.round(mission.dvl.beams * 1000.0), -32768)[:20]
    path = tmp_path / "dvl.000"
    path.write_bytes(b"".join(_ensemble(k + 1, start + dt.timedelta(seconds=k), beams[k], 1000) for k in range(20)))
    log = _quiet_read(path)
    np.testing.assert_allclose(log.t, start.timestamp() + np.arange(19), atol=1e-6)


def test_two_ensembles_swapped_across_a_roll_over_without_the_high_byte_are_sorted(sim, tmp_path):
    """Ensemble numbers that roll over 65535 -> 0 without the high byte (byte 11 left at 0), with the ensembles
    numbered 65535 and 0 swapped: put back in time order, warned and counted, the pings of the clean file. It was
    refused as a clock set back mid-file. A clock set back across the roll-over is still refused."""
    from graphnav.core.errors import DataError
    mission, _ = sim
    t, n = mission.dvl.t, len(mission.dvl.t)
    numbers = (65530 + np.arange(n)) % 65536                        # 65535 is the 6th ensemble, 0 the 7th
    path = tmp_path / "dvl.000"
    path.write_bytes(_numbered(mission, numbers))
    clean = _quiet_read(path)
    ens = _ensembles_of(path)
    size = len(ens[0])
    log, said = _read_with_two_swapped(path, ens, 5)
    _assert_sorted_as(log, clean, said, f"{path}: 2 ensemble(s) stored out of time order (ensemble 65535 (byte "
                      f"{6 * size}) is {t[6] - t[5]:.2f} s before ensemble 0 (byte {5 * size}) stored ahead of it)")
    back = t - np.where(np.arange(n) >= 8, 4.5, 0.0)                # set back after ensemble 1, numbers running on
    path.write_bytes(_numbered(mission, numbers, t_s=back))
    with pytest.raises(DataError, match=r"the clock runs back [0-9.]+ s from ensemble 1 \(byte "
                                        rf"{7 * size}\) to ensemble 2 \(byte {8 * size}\) while the ensemble numbers "
                                        "run on"):
        read_pd0_log(path)


def test_ensembles_sharing_a_time_load_beside_an_imu_spread_within_their_clock_tick(sim, tmp_path):
    """A DVL pinging at 1 Hz whose clock repeats each time for 2 s (two ensembles per time) reads alone at its
    recorded times, and beside an IMU loads (it was refused: "time stamp duplicated") with the second ping of each
    time spread within the 2 s tick of a clock whose times step by 2 s (1 s after it, its time; it was put 0.5 s
    after, within the second a clock of whole seconds vouches for), warned about and counted as doubted; the first
    of each keeps its time."""
    spread_key = "ensemble time shared with the ping before (stamp spread after it)"       # pd0.SPREAD_TIME
    mission, _ = sim
    t_s = 2.0 * np.floor(mission.dvl.t / 2.0)
    assert np.all(t_s[:-1:2] == t_s[1::2])
    m, rec = _load_written_pd0(sim, tmp_path, t_s=t_s)
    n = len(m.dvl.t)                                                 # dolfyn leaves the last ensemble
    expected = t_s[:n] + np.where(np.arange(n) % 2, 1.0, 0.0)         # the mission's stamps start at its first
    np.testing.assert_allclose(m.dvl.t - m.dvl.t[0], expected, atol=1e-6)
    dvl = m.meta["streams"]["dvl"]
    assert dvl["doubted"] == {spread_key: n // 2}
    said = [str(w.message) for w in rec if "share their ensemble's time" in str(w.message)]
    assert said == [f"{tmp_path / 'dvl.000'}: {n // 2} of {n} ping(s) share their ensemble's time (the variable "
                    "leader's clock) with the ping before (a clock that ticks slower than the instrument pings, or "
                    "repeats a time): spread after it in ensemble order within the clock's tick, at most 1.000 s "
                    f"after the time recorded, first ensemble 2 (byte {len(_ensembles_of(tmp_path / 'dvl.000')[0])}) "
                    "at 2024-05-01 12:00:00.00; the DVL's own clock cannot tell these times better"]
    assert said[0].split(": ", 1)[1] in dvl["notes"]
    np.testing.assert_array_equal(_quiet_read(tmp_path / "dvl.000").t, START.timestamp() + t_s[:n])


def test_pings_in_bursts_on_a_clock_of_whole_seconds_are_spread_within_their_second_not_over_the_pause():
    """Bursts of 4 pings 0.25 s apart every 10 s on a clock of whole seconds (4 ensembles per time): spread 0.25 s
    apart within the second their clock vouches for, not 2.5 s apart over the pause between bursts (up to 7.5 s after
    the time recorded); a clock with hundredths repeating a time keeps the step between its times."""
    from graphnav.io.pd0 import spread_shared_times
    t0 = 1.7e9
    true = t0 + (10.0 * np.arange(6)[:, None] + 0.25 * np.arange(4)[None, :]).ravel()
    spread, moved = spread_shared_times(np.floor(true))
    np.testing.assert_allclose(spread - t0, true - t0, atol=1e-6)
    assert moved.sum() == 18
    repeated = t0 + np.repeat(np.arange(0.0, 10.0, 2.0), 2) + 0.37             # each time of a hundredths clock twice
    spread, _ = spread_shared_times(repeated)
    np.testing.assert_allclose(np.diff(spread - t0), 1.0, atol=1e-6)


def test_a_file_cut_in_its_last_ensemble_with_the_whole_file_appended_has_no_corrupt_ensemble(sim, tmp_path):
    """A copy cut inside its last ensemble with the whole file appended behind it: the cut ensemble is the cut end
    of the first copy, whole in the second, so it is a copy (counted with them, named), not a corrupt ensemble; the
    pings are the clean file's. It was warned about and counted as a wrong checksum (corrupt), and then the warning
    called every copy "identical byte for byte to an earlier one", the cut one too."""
    from graphnav.io.pd0 import REPEATED_ENSEMBLE
    mission, root = sim
    raw, n = (root / "dvl.000").read_bytes(), len(mission.dvl.t)
    size = len(raw) // n
    cut = raw[:len(raw) - size // 2]
    (tmp_path / "dvl.000").write_bytes(cut + raw)
    clean = _quiet_read(root / "dvl.000")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_pd0_log(tmp_path / "dvl.000")
    assert not [w for w in caught if "checksum" in str(w.message)]
    said = [str(w.message) for w in caught if "written twice" in str(w.message)]
    assert said == [f"{tmp_path / 'dvl.000'}: {n} ensemble(s) written twice ({n - 1} identical byte for byte to an "
                    "earlier one, 1 cut short and the same as far as its bytes go: a logger's retry, or a file "
                    f"appended to itself) left out: ensemble {n} (byte "
                    f"{(n - 1) * size}), ensembles 1-{n - 1} (bytes {len(cut)}-{len(cut) + (n - 2) * size}); {n} read "
                    f"once (ensemble {n} (byte {(n - 1) * size}) is cut short after {len(cut) - (n - 1) * size} bytes "
                    f"by the next ensemble and read whole from byte {len(cut) + (n - 1) * size}: the cut end of a file "
                    "with a copy of it joined behind, not a corrupt ensemble)"]
    assert log.counts == {**clean.counts, REPEATED_ENSEMBLE: n}
    np.testing.assert_array_equal(log.t, clean.t)
    np.testing.assert_array_equal(log.beams, clean.beams)


@pytest.mark.parametrize("kept", [10, 40, 80])
def test_an_ensemble_cut_before_its_number_and_clock_stays_corrupt_not_a_copy(sim, tmp_path, kept):
    """An ensemble of which only the header and fixed leader are left (bytes a logger lost mid-file, or another
    recording joined behind a cut): those bytes are the same in every ensemble of the instrument, so they cannot
    say the ping is a copy of one read whole. It is counted and warned about as a corrupt ensemble, no copy is
    named; it was called the cut end of a copy ("ensemble written twice") of the file's first ensemble."""
    from graphnav.io.pd0 import REPEATED_ENSEMBLE
    mission, root = sim
    raw, n = (root / "dvl.000").read_bytes(), len(mission.dvl.t)
    size = len(raw) // n
    assert 80 < 6 + 2 * 4 + 59 + 12 < size          # header of 4 blocks, fixed leader, variable leader to its clock
    k = n // 2
    path = tmp_path / "dvl.000"
    path.write_bytes(raw[:k * size + kept] + raw[(k + 1) * size:])
    clean = _quiet_read(root / "dvl.000")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_pd0_log(path)
    said = [str(w.message) for w in caught]
    assert not [s for s in said if "written twice" in s]
    assert [s for s in said if "1 ensemble(s) with a wrong checksum (corrupt) left out" in s]
    assert REPEATED_ENSEMBLE not in log.counts
    assert log.counts["bad checksum (ensemble left out)"] == 1
    np.testing.assert_array_equal(log.t, np.delete(clean.t, k))


def test_a_dvl_clock_that_stands_still_then_jumps_has_its_pings_spread_up_to_the_jump(sim, tmp_path):
    """A clock with hundredths that stands still for 5 s (pings 11-15 of a 1 Hz DVL stamped with the 11th's time) and
    then jumps back to the right time: those pings are spread evenly up to the jump, onto the times they were taken
    at, warned about as a clock that stood still and counted as doubted. They were squeezed into the clock's 1 s
    tick (0.2 s apart, up to 3.2 s early) and called a clock slower than the pings."""
    from graphnav.io.pd0 import read_pd0
    stalled_key = "DVL clock stood still (stamp spread up to its next time)"        # pd0.STALLED_TIME
    mission, _ = sim
    t = mission.dvl.t
    stalled = (t >= t[10]) & (t < t[10] + 5.0)
    path = tmp_path / "dvl.000"
    write_pd0(path, mission, t_s=np.where(stalled, t[10], t) + 0.37)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        dvl, _, meta = read_pd0(path)
    np.testing.assert_allclose(dvl.t - START.timestamp(), t[:len(dvl.t)] + 0.37, rtol=0, atol=1e-6)
    assert meta["streams"]["dvl"]["doubted"] == {stalled_key: 4}
    said = [str(w.message) for w in caught if "stood still" in str(w.message)]
    size = len(_ensembles_of(path)[0])
    assert said == [f"{path}: the DVL's clock stood still: 5 pings from ensemble 11 (byte {10 * size}) share its time "
                    "2024-05-01 12:00:10.37, then jumped 5.00 s, while elsewhere it gives each ping a time of its "
                    "own: spread evenly up to the next time at the ping period at most, at most 4.000 s after the "
                    "time recorded; their times are a guess"]


def test_a_roll_over_without_the_high_byte_in_a_file_where_other_ensembles_carry_it_is_sorted(sim, tmp_path):
    """Ensemble numbers rolling over 65535 -> 0 without the high byte while later ensembles of the file carry it
    (65560 on written with byte 11 = 1), with the ensembles numbered 65535 and 0 swapped: put back in time order,
    warned and counted, the pings of the clean file. Any number above 65535 switched the roll-over off, and the swap
    was refused with the advice for a clock set back mid-file (cut the file, a clock offset for each part)."""
    mission, _ = sim
    t, n = mission.dvl.t, len(mission.dvl.t)
    full = 65530 + np.arange(n)                                    # 65535 is the 6th ensemble, 0 the 7th
    numbers = np.where((full > 0xFFFF) & (full < 65560), full & 0xFFFF, full)
    path = tmp_path / "dvl.000"
    path.write_bytes(_numbered(mission, numbers))
    clean = _quiet_read(path)
    ens = _ensembles_of(path)
    log, said = _read_with_two_swapped(path, ens, 5)
    _assert_sorted_as(log, clean, said, f"{path}: 2 ensemble(s) stored out of time order (ensemble 65535 (byte "
                      f"{6 * len(ens[0])}) is {t[6] - t[5]:.2f} s before ensemble 0 (byte {5 * len(ens[0])}) stored "
                      "ahead of it)")


def test_a_file_cut_inside_an_ensemble_with_another_recording_joined_behind_names_the_cut_ensemble(sim, tmp_path):
    """A recording cut halfway through an ensemble (after its number and clock) with another recording of the
    instrument (an hour later, numbered from 1) joined behind: the cut ensemble is named as cut short by the next
    one, counted so and left out, no corrupt ensemble; every whole ensemble of both is read. It was warned about
    and counted as an ensemble with a wrong checksum (corrupt)."""
    cut_short_key = "ensemble cut short by the next one (left out)"        # pd0.CUT_SHORT_ENSEMBLE
    mission, root = sim
    raw, n = (root / "dvl.000").read_bytes(), len(mission.dvl.t)
    size, k = len(raw) // n, n // 2
    write_pd0(tmp_path / "later.000", mission, t_s=mission.dvl.t + 3600.0)
    path = tmp_path / "dvl.000"
    path.write_bytes(raw[:k * size + size // 2] + (tmp_path / "later.000").read_bytes())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_pd0_log(path)
    said = [str(w.message) for w in caught]
    assert not [s for s in said if "checksum (corrupt)" in s]
    assert [s for s in said if "cut short" in s] == [
        f"{path}: 1 ensemble(s) cut short by the next one left out: ensemble {k + 1} (byte {k * size}) after "
        f"{size // 2} of its {size} bytes by the ensemble at byte {k * size + size // 2} (a file cut there with "
        "another recording joined behind, or bytes a logger lost; its rest is not in the file, so its checksum "
        f"fails); {k + n} whole ones read"]
    assert log.counts[cut_short_key] == 1 and "bad checksum (ensemble left out)" not in log.counts
    assert cut_short_key not in log.refused()
    clean = _quiet_read(root / "dvl.000")
    np.testing.assert_array_equal(log.t[:k], clean.t[:k])
    np.testing.assert_array_equal(log.t[k:] - 3600.0, clean.t[:len(log.t) - k])


def test_a_dvl_clock_that_never_ran_is_refused_not_squeezed_into_a_hundredth(sim, tmp_path, capsys):
    """Every ping of a PD0 file carrying one time (a clock not set, or stopped, for the whole recording): dead-reckoned
    alone and read for a mission it is refused, naming the time and what to do. Dead reckoning alone gave a track of
    all its pings within 0.01 s (0.02 m for a 650 m run, warned only as pings spread within the clock's tick), and a
    mission's DVL stream had them all within 0.01 s."""
    from graphnav.io.pd0 import read_pd0
    mission, _ = sim
    path = tmp_path / "dvl.000"
    write_pd0(path, mission, t_s=np.full(len(mission.dvl.t), 10.37))
    said = (r"field 'time': all \d+ pings carry one time \(2024-05-01 12:00:10.37\): the DVL's clock did not run "
            r"\(not set, or stopped\), so when each ping was taken cannot be told; give each ping its time")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=said):
            read_pd0(path)
        assert cli.main(["smooth", "--data", str(path), "--no-plots", "--out", str(tmp_path / "out")]) != 0
    assert re.search(said, capsys.readouterr().err)
    assert not (tmp_path / "out" / "trajectory.csv").exists()
