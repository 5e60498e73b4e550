"""Real RDI files (``<data>/real-formats/pd0``, MHKiT/dolfyn's example data) against dolfyn's own reading and
rotations: ping counts, velocities in RDI's instrument and earth frames, the DVL frame's handedness, bad
pressure words, the ADCP refusal and recognising PD0 by content. Skipped when the folder is absent."""
from __future__ import annotations

import contextlib
import functools
import io
import json
import re
import shutil
import struct
import warnings

import numpy as np
import pytest

from graphnav import cli
from graphnav.core.config import SensorConfig
from graphnav.core.dvl import DvlGeometry
from graphnav.core.errors import DataError
from graphnav.io import paths, pd0
from graphnav.io.dvl_files import read_dvl
from graphnav.io.inspect import describe

pytest.importorskip("mhkit.dolfyn", reason="graphnav[pd0] not installed (scripts/setup_env.sh installs it)")

BOTTOM_TRACK = {"RDI_withBT.000": "earth", "winriver01.PD0": "ship", "RiverPro_test01.PD0": "beam"}


@pytest.fixture(scope="module")
def pd0_dir():
    root = paths.real_formats_dir()
    if root is None or not (root / "pd0").is_dir():
        pytest.skip("real PD0 files not found: set GRAPHNAV_DATA or place them at ../shared/data/real-formats/pd0")
    return root / "pd0"


@functools.lru_cache(maxsize=8)          # read once per module run; callers never modify the dataset
def _dolfyn(path, stored_matrix: bool = True):
    """dolfyn's dataset of ``path`` with RDI's -32768 as NaN, rotating only the bottom track, and (where the
    file stores one) the instrument's own beam matrix, as graphnav uses it."""
    pd0._import_dolfyn()
    from mhkit.dolfyn.io.rdi import read_rdi
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        ds = read_rdi(str(path), userdata=False)
    vel = ds["vel_bt"].values
    vel[np.isclose(vel, -32.768)] = np.nan
    ds.attrs["rotate_vars"] = ["vel_bt"]
    matrix = pd0.scan_pd0(path).beam_matrix
    if stored_matrix and matrix is not None:
        ds["beam2inst_orientmat"].values[:] = matrix
    return ds


def _rotate(ds, frame):
    from mhkit.dolfyn.rotate.api import rotate2
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        return rotate2(ds, frame, inplace=False)["vel_bt"].values.astype(float)


@functools.lru_cache(maxsize=16)
def _read(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return read_dvl(path)


def _read_warned(path):
    """``read_dvl(path)`` and the messages of the warnings it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_dvl(path)
    return log, [str(w.message) for w in caught]


@pytest.mark.parametrize("name", sorted(BOTTOM_TRACK))
def test_pings_read_and_valid_match_dolfyn(pd0_dir, name):
    log = _read(pd0_dir / name)
    ds = _dolfyn(pd0_dir / name)
    vel = ds["vel_bt"].values
    n = vel.shape[1]
    assert log.frame == BOTTOM_TRACK[name] == log.instrument["coordinate_system"]
    assert log.counts["read"] == len(log) == n
    # dolfyn does not read a complete file's last ensemble; the byte scan counts it (RDI_withBT is cut short).
    assert log.counts["ensembles in file"] == n + (name != "RDI_withBT.000")
    if BOTTOM_TRACK[name] == "beam":
        dolfyn_valid = np.isfinite(vel).sum(axis=0) >= 3
        assert log.counts["beams recovered"] == int(dolfyn_valid.sum())
    else:
        dolfyn_valid = np.all(np.isfinite(vel[:3]), axis=0)
        four = dolfyn_valid & np.isfinite(vel[3])
        assert log.counts["beams recovered"] == int(four.sum())
        np.testing.assert_array_equal(log.three_beam, dolfyn_valid & ~four)
    np.testing.assert_array_equal(log.v_d_valid, dolfyn_valid)
    assert log.counts["valid"] == int(dolfyn_valid.sum())
    assert log.counts["read"] == log.counts["valid"] + log.counts["no bottom lock"] + log.counts.get(
        "fewer than 3 beams", 0)


@pytest.mark.parametrize("name", ["RDI_withBT.000", "RiverPro_test01.PD0"])
def test_instrument_frame_velocity_equals_dolfyns(pd0_dir, name):
    """graphnav's v_d, taken back to RDI's instrument frame (the seabed relative to the head), is dolfyn's
    ``rotate2(ds, 'inst')`` of the same file (earth: undoing the instrument's attitude; beam: the beam matrix)."""
    log = _read(pd0_dir / name)
    inst = _rotate(_dolfyn(pd0_dir / name), "inst")[:3].T
    ours = -(log.v_d @ pd0.C_D_RDI)
    use = log.v_d_valid & np.all(np.isfinite(inst), axis=1)
    assert use.sum() > 200
    assert np.max(np.abs(ours[use] - inst[use])) < 1e-4


@pytest.mark.parametrize("name", sorted(BOTTOM_TRACK))
def test_earth_frame_velocity_equals_dolfyns(pd0_dir, name):
    """``v_n`` is the head's NED velocity: minus dolfyn's East-North-Up bottom track (for the ship-frame file
    dolfyn's own ship -> earth, an independent check of undoing the ship frame's tilts)."""
    log = _read(pd0_dir / name)
    ds = _dolfyn(pd0_dir / name)
    enu = ds["vel_bt"].values[:3].astype(float).T if ds.coord_sys == "earth" else _rotate(ds, "earth")[:3].T
    ned_head = -enu @ pd0.C_NED_ENU.T
    use = log.v_d_valid & np.all(np.isfinite(ned_head), axis=1)
    assert use.sum() > 200
    assert np.max(np.abs(log.v_n[use] - ned_head[use])) < 1e-4


def test_real_beams_solve_to_dolfyns_velocity_with_right_handed_geometry(pd0_dir):
    """The RiverPro file's recorded beams, solved with graphnav's DVL geometry from the file (DvlSpec theta/psi,
    C_d_b = I), give dolfyn's instrument velocity through the proper rotation C_D_RDI; the old convention
    (RDI's X/Y as x_d/y_d with beams along +z: azimuths 180, 0, 90, 270) solves to a mirror image, (-u, -v, +w)
    of dolfyn's instrument velocity."""
    path = pd0_dir / "RiverPro_test01.PD0"
    log = _read(path)
    assert np.isclose(np.linalg.det(pd0.C_D_RDI), 1.0)
    spec = SensorConfig().dvl
    spec.theta_rad, spec.psi_rad = log.instrument["beam_theta_rad"], np.asarray(log.instrument["beam_psi_rad"])
    np.testing.assert_allclose(np.rad2deg(spec.psi_rad), [270, 90, 0, 180], atol=0.6)   # stored, calibrated
    v_d = DvlGeometry.from_spec(spec).velocity_from_beams(log.beams, log.beam_valid, allow_missing=True)
    inst = _rotate(_dolfyn(path), "inst")[:3].T
    use = np.all(np.isfinite(v_d), axis=1) & np.all(np.isfinite(inst), axis=1)
    head_rdi = -inst[use]                     # dolfyn's bottom track is the seabed relative to the head
    assert np.max(np.abs(v_d[use] - head_rdi @ pd0.C_D_RDI.T)) < 5e-3   # one mean inclination: 0.2 % of 1.9 m/s
    # The same (calibrated) beams with RDI's X, Y taken as x_d, y_d: azimuth 90 deg - psi (180, 0, 90, 270).
    spec.psi_rad = np.mod(np.pi / 2 - spec.psi_rad, 2 * np.pi)
    v_old = DvlGeometry.from_spec(spec).velocity_from_beams(log.beams, log.beam_valid, allow_missing=True)[use]
    assert np.max(np.abs(v_old - head_rdi)) > 0.1                                      # not RDI's frame...
    assert np.max(np.abs(v_old - head_rdi * [1, 1, -1])) < 5e-3                       # ...but its mirror image


def test_a_mirrored_beam_matrix_is_refused(pd0_dir):
    matrix = pd0.scan_pd0(pd0_dir / "RiverPro_test01.PD0").beam_matrix
    theta, psi = pd0.rdi_geometry(matrix)
    assert np.rad2deg(theta) == pytest.approx(20.0, abs=0.2)
    mirrored = matrix * np.array([[1.0], [-1.0], [1.0], [1.0]])      # RDI's Y row negated: a reflection
    with pytest.raises(DataError, match="mirrored"):
        pd0.rdi_geometry(mirrored)


def test_stored_beam_matrix_is_dolfyns_nominal_one_within_calibration(pd0_dir):
    stored = pd0.scan_pd0(pd0_dir / "RiverPro_test01.PD0").beam_matrix
    nominal = _dolfyn(pd0_dir / "RiverPro_test01.PD0", stored_matrix=False)["beam2inst_orientmat"].values
    assert stored[2].min() > 0                       # w = +b (B1 + B2 + B3 + B4): beams along RDI's -Z
    np.testing.assert_allclose(stored, nominal, atol=0.02)
    assert pd0.scan_pd0(pd0_dir / "RDI_withBT.000").beam_matrix is None


def test_bad_pressure_words_never_become_depth(pd0_dir):
    path = pd0_dir / "RDI_withBT.000"
    with pytest.warns(RuntimeWarning, match="bad pressure word"):
        log = read_dvl(path)
    no_sensor = _dolfyn(path)["pressure"].values > 4e6          # 0xFFFFFFFF decapascal
    assert no_sensor.sum() == log.counts["bad pressure word"] == 31
    assert np.all(np.isnan(log.depth_m[no_sensor]))
    assert np.all(np.isfinite(log.depth_m[~no_sensor]))
    assert np.nanmax(log.depth_m) < 10.0


def test_an_adcp_file_without_bottom_track_is_refused(pd0_dir):
    with pytest.raises(DataError, match="no bottom track"):
        read_dvl(pd0_dir / "sentinelv_b5.pd0")


@pytest.mark.parametrize("name", ["log.ENR", "LOG.ens", "survey.EnX", "deployment.001", "capture.bin"])
def test_pd0_is_recognised_by_content_under_any_name(pd0_dir, tmp_path, name):
    copy = tmp_path / name
    shutil.copyfile(pd0_dir / "winriver01.PD0", copy)
    assert pd0.is_pd0(copy)
    log = _read(copy)
    assert log.frame == "ship" and log.counts["read"] == 261


def test_a_file_named_pd0_without_ensembles_is_refused(tmp_path):
    fake = tmp_path / "notes.PD0"
    fake.write_text("t,vx,vy,vz\n0,1,2,3\n")
    assert not pd0.is_pd0(fake) and pd0.has_pd0_suffix(fake)
    with pytest.raises(DataError, match="holds no PD0 ensemble"):
        read_dvl(fake)


def test_ship_frame_file_loads_as_a_mission_with_beams_and_three_beam_velocities(pd0_dir, tmp_path):
    """The mission path (a PD0 file plus an IMU CSV of the config) on a ship-frame file: beams recovered for
    4-beam pings, the 3-beam solutions as DVL-frame velocities, counted in meta['streams']."""
    from graphnav.missions import load_mission
    shutil.copyfile(pd0_dir / "winriver01.PD0", tmp_path / "dvl.PD0")
    t_dvl = _read(tmp_path / "dvl.PD0").t
    t = np.arange(t_dvl[0] - 1.0, t_dvl[-1] + 1.0, 0.01)
    rows = ["t,ax,ay,az,gx,gy,gz"] + [f"{x:.3f},0,0,-9.81,0,0,0" for x in t]
    (tmp_path / "imu.csv").write_text("\n".join(rows) + "\n")
    cfg = SensorConfig().to_dict()
    cfg["csv_columns"] = {"imu": {"file": "imu.csv", "t": "t", "f_b": ["ax", "ay", "az"],
                                  "omega_b": ["gx", "gy", "gz"]}}
    (tmp_path / "config.json").write_text(json.dumps(cfg))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        m = load_mission(tmp_path / "dvl.PD0", tmp_path / "config.json")
    assert m.dvl.valid.all(axis=1).sum() == 250
    assert m.dvl.v_d_valid.sum() == 11 and not (m.dvl.v_d_valid & m.dvl.valid.any(axis=1)).any()
    np.testing.assert_allclose(np.rad2deg(m.config.dvl.psi_rad), [270, 90, 0, 180], atol=1e-4)
    streams = m.meta["streams"]["dvl"]
    assert streams["read"] == 262 and streams["used"] == 261
    assert streams["refused"] == {"not read by dolfyn (last ensemble)": 1}
    assert any("3-beam" in note for note in streams["notes"])
    # the recovered beams solve back to the instrument's own (ship-frame-derived) velocity
    log = _read(tmp_path / "dvl.PD0")
    v = DvlGeometry.from_spec(m.config.dvl).velocity_from_beams(m.dvl.beams, m.dvl.valid, allow_missing=True)
    four = m.dvl.valid.all(axis=1)
    assert np.max(np.abs(v[four] - log.v_d[four])) < 1e-5


def test_csv_of_dvl_velocities(tmp_path):
    path = tmp_path / "dvl.csv"
    path.write_text("time,vx,vy,vz\n0.0,1.0,0.1,0.0\n1.0,,0.1,0.0\n2.0,-32.768,0,0\n3.0,1.1,0.0,0.05\n")
    with pytest.warns(RuntimeWarning, match="2 of 4"):
        log = read_dvl(path)
    assert log.frame == "dvl" and log.counts == {"read": 4, "valid": 2,
                                                 "no velocity (empty, non-finite or flagged)": 2}
    np.testing.assert_allclose(log.v_d[3], [1.1, 0.0, 0.05])
    path.write_text("time,vx,vy,vz\n0.0,1.0,abc,0.0\n")
    with pytest.raises(DataError, match=r"line 2, field 'vy'"):
        read_dvl(path)


def test_a_corrupt_ensemble_is_left_out_not_fatal(pd0_dir, tmp_path):
    """dolfyn stops on a corrupt ensemble; graphnav reads the checksummed ones, counts and warns."""
    raw = bytearray((pd0_dir / "winriver01.PD0").read_bytes())
    start = pd0.scan_pd0(pd0_dir / "winriver01.PD0").spans[100][0]
    raw[start + 700] ^= 0x55
    (tmp_path / "corrupt.PD0").write_bytes(bytes(raw))
    with pytest.warns(RuntimeWarning, match="1 ensemble.s. with a wrong checksum"):
        log = read_dvl(tmp_path / "corrupt.PD0")
    assert log.counts["bad checksum (ensemble left out)"] == 1
    assert log.counts["ensembles in file"] == 261 and log.counts["read"] == 260


def test_an_ensemble_written_twice_is_read_once_not_a_crash(pd0_dir, tmp_path):
    """A logger that wrote ensembles again right after themselves (byte for byte): dolfyn fails on the file
    (a time dimension of two lengths) and graphnav's clean-up of that failure recursed without end (before:
    RecursionError on RiverPro_test01.PD0, and 'time stamp duplicated' on winriver01.PD0 with an IMU). The copies
    are left out, counted and warned about, and the pings read are the clean file's."""
    src = pd0_dir / "RiverPro_test01.PD0"
    raw = src.read_bytes()
    a, b = pd0.scan_pd0(src).spans[100]
    (tmp_path / "twice.PD0").write_bytes(raw[:b] + raw[a:b] * 3 + raw[b:])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = read_dvl(src)
    with pytest.warns(RuntimeWarning, match=r"3 ensemble\(s\) written twice \(identical byte for byte"):
        log = read_dvl(tmp_path / "twice.PD0")
    assert log.counts["ensemble written twice (copy left out)"] == 3
    assert log.counts["read"] == clean.counts["read"] == 272
    np.testing.assert_array_equal(log.t, clean.t)
    np.testing.assert_array_equal(log.beams, clean.beams)


@pytest.mark.parametrize("damage", ["copied with others between", "appended to itself"])
def test_riverpro_copies_anywhere_are_read_once_not_refused_in_dolfyn_words(pd0_dir, tmp_path, damage):
    """RiverPro_test01.PD0 with an ensemble copied after another (A B A) or appended to itself: dolfyn refused both
    ("conflicting sizes for dimension 'time'", not naming the copy); graphnav leaves the copies out, names them by
    their ensemble numbers and reads the clean file's pings."""
    src = pd0_dir / "RiverPro_test01.PD0"
    raw, spans = src.read_bytes(), pd0.scan_pd0(src).spans
    a, b = spans[10]
    damaged = raw[:spans[11][1]] + raw[a:b] + raw[spans[11][1]:] if damage.startswith("copied") else raw + raw
    named = f"ensemble 408 (byte {spans[11][1]})" if damage.startswith("copied") else \
        f"ensembles 398-670 (bytes {len(raw)}-{len(raw) + spans[-1][0]})"
    (tmp_path / src.name).write_bytes(damaged)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = read_dvl(src)
    with pytest.warns(RuntimeWarning, match=re.escape(f"left out: {named}; 273 read once")):
        log = read_dvl(tmp_path / src.name)
    assert log.counts["read"] == clean.counts["read"] == 272
    np.testing.assert_array_equal(log.t, clean.t)
    np.testing.assert_array_equal(log.beams, clean.beams)


def test_rdi_with_bt_appended_to_itself_has_no_corrupt_ensemble(pd0_dir, tmp_path):
    """RDI_withBT.000 (cut at 1,000,000 bytes inside ensemble 1722) appended to itself: the first copy's cut end is
    followed by the second copy's first ensemble, so its checksum fails; its bytes are those of the ensemble the
    file ends in, cut too, so it is a copy (counted with the others, named), not a corrupt ensemble. It was warned
    about and counted as a wrong checksum. The pings are the file's alone."""
    src = pd0_dir / "RDI_withBT.000"
    raw = src.read_bytes()
    (tmp_path / src.name).write_bytes(raw + raw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = read_dvl(src)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_dvl(tmp_path / src.name)
    assert not [w for w in caught if "checksum" in str(w.message)]
    said = [str(w.message) for w in caught if "written twice" in str(w.message)]
    assert len(said) == 1 and "left out: ensemble 1722 (byte 999901), ensembles 1-1721 (bytes 1000000-" in said[0]
    assert said[0].endswith("(ensemble 1722 (byte 999901) is cut short after 99 bytes by the next ensemble and the "
                            "same as the one the file ends in, cut too: the cut end of a file with a copy of it "
                            "joined behind, not a corrupt ensemble)")
    assert log.counts == {**clean.counts, "ensemble written twice (copy left out)": 1722}
    np.testing.assert_array_equal(log.t, clean.t)
    np.testing.assert_array_equal(log.beams, clean.beams, strict=True)


def test_bytes_a_logger_wrote_between_two_ensembles_are_skipped_and_both_read(pd0_dir, tmp_path):
    """winriver01.PD0 with a CR LF after its 101st ensemble and a logger's time tag after its 151st: the bytes are
    skipped, warned about naming the ensemble they follow and counted, and every ensemble is read as in the clean
    file. dolfyn, finding no header where an ensemble ends, lost the ensemble before each (2 pings fewer, counted
    as "not read by dolfyn (last ensemble)", and the pings after named by the wrong ensembles)."""
    src = pd0_dir / "winriver01.PD0"
    raw, scan = src.read_bytes(), pd0.scan_pd0(src)
    parts = [raw[a:b] for a, b in scan.spans]
    parts[100] += b"\r\n"
    parts[150] += b"$TIME,12:00:01\r\n"
    (tmp_path / src.name).write_bytes(b"".join(parts))
    clean = _read(src)
    log, said = _read_warned(tmp_path / src.name)
    said = [s for s in said if "between ensembles" in s]
    assert said == [f"{tmp_path / src.name}: 18 byte(s) between ensembles belong to none and are skipped: 2 after "
                    f"ensemble {scan.numbers[100]} at byte {scan.spans[100][1]} (b'\\r\\n') and 1 more place(s); the "
                    "ensembles either side are whole (their checksums hold) and read"]
    assert log.counts == {**clean.counts, pd0.STRAY_BYTES: 18}
    assert log.where[:101] == clean.where[:101] and log.where[101].startswith(f"ensemble {scan.numbers[101]} ")
    np.testing.assert_array_equal(log.t, clean.t)
    np.testing.assert_array_equal(log.beams, clean.beams)
    np.testing.assert_array_equal(log.v_d, clean.v_d)


def test_two_instruments_joined_after_a_cut_are_refused_naming_where_the_second_begins(pd0_dir, tmp_path):
    """winriver01.PD0 cut halfway through its 201st ensemble with RiverPro_test01.PD0 joined behind: the cut ensemble
    is named as cut short by the next one, not corrupt, and the file is refused naming the ensembles where the
    instrument changes and the byte to cut at. dolfyn's "IndexError: arrays used as indices must be of integer (or
    boolean) type" was all a user got."""
    first, second = pd0_dir / "winriver01.PD0", pd0_dir / "RiverPro_test01.PD0"
    spans = pd0.scan_pd0(first).spans
    a, b = spans[200]
    joined = first.read_bytes()[:a + 1500]
    (tmp_path / "joined.PD0").write_bytes(joined + second.read_bytes())
    with pytest.warns(RuntimeWarning) as caught:
        with pytest.raises(DataError, match=re.escape(
                f"the instrument (firmware, beams or serial number of the fixed leader) changes from ensemble 423 "
                f"(byte {spans[199][0]}) to ensemble 398 (byte {len(joined)}): recordings of two instruments joined "
                f"in one file; load each from a file of its own (the bytes before {len(joined)} and from "
                f"{len(joined)} on); dolfyn reads one instrument per file (cannot read as PD0: ")):
            read_dvl(tmp_path / "joined.PD0")
    said = [str(w.message) for w in caught]
    assert not [s for s in said if "corrupt" in s]
    assert [s for s in said if f"ensemble 424 (byte {a}) after 1500 of its {b - a} bytes" in s]


def test_a_time_tag_holding_0x7f7f_between_two_ensembles_is_skipped_not_called_corrupt(pd0_dir, tmp_path):
    """winriver01.PD0 with a logger's time tag whose bytes hold 0x7F 0x7F (read as a header, its checksum failing)
    after its 101st ensemble: the 17 bytes are skipped and counted as bytes between ensembles, and every ensemble is
    read as in the clean file. They were called an ensemble with a wrong checksum (corrupt) left out, though no
    ensemble was lost, and the bytes were not counted."""
    src = pd0_dir / "winriver01.PD0"
    raw, scan = src.read_bytes(), pd0.scan_pd0(src)
    parts = [raw[a:b] for a, b in scan.spans]
    parts[100] += b"$TIME\x7f\x7f12:00:01\r\n"
    (tmp_path / src.name).write_bytes(b"".join(parts))
    clean = _read(src)
    log, said = _read_warned(tmp_path / src.name)
    assert not [s for s in said if "corrupt" in s]
    assert [s for s in said if "between ensembles" in s] == [
        f"{tmp_path / src.name}: 17 byte(s) between ensembles belong to none and are skipped: 17 after ensemble "
        f"{scan.numbers[100]} at byte {scan.spans[100][1]} (b'$TIME\\x7f\\x7f12:00:01\\r'...); the ensembles either "
        "side are whole (their checksums hold) and read"]
    assert log.counts == {**clean.counts, pd0.STRAY_BYTES: 17}
    np.testing.assert_array_equal(log.t, clean.t)
    np.testing.assert_array_equal(log.v_d, clean.v_d)


def test_an_ensemble_whose_clock_is_no_date_in_a_file_in_time_order_is_refused_naming_it(pd0_dir, tmp_path):
    """winriver01.PD0 with the month of its 51st ensemble's clock zeroed (no date) and every other ensemble in order:
    refused naming the ensemble and what to do, by the loader and by ``graphnav smooth``. dolfyn stamped it
    1677-09-21, and dead reckoning alone stopped with a traceback (a 60.9 GiB array to fill the "gap")."""
    src = pd0_dir / "winriver01.PD0"
    raw, scan = src.read_bytes(), pd0.scan_pd0(src)
    parts = [bytearray(raw[a:b]) for a, b in scan.spans]
    ens = parts[50]
    offsets = struct.unpack_from(f"<{ens[5]}H", ens, 6)
    leader = next(o for o in offsets if struct.unpack_from("<H", ens, o)[0] == 0x0080)
    ens[leader + 5] = 0                                        # the RTC's month (and the Y2K clock's, when kept)
    if ens[leader + 58:leader + 65] == raw[scan.spans[50][0] + leader + 4:scan.spans[50][0] + leader + 11]:
        ens[leader + 59] = 0
    struct.pack_into("<H", ens, len(ens) - 2, sum(ens[:-2]) & 0xFFFF)
    path = tmp_path / src.name
    path.write_bytes(b"".join(parts))
    said = (f"field 'time': the ensembles cannot be put in time order: ensemble {scan.numbers[50]} (byte "
            f"{scan.spans[50][0]}) has a clock that is no date: it cannot be placed in time; remove that ensemble "
            "(its bytes) from a copy of the file")
    with pytest.raises(DataError, match=re.escape(said)):
        _read(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert cli.main(["smooth", "--data", str(path), "--no-plots", "--out", str(tmp_path / "out")]) != 0


def test_two_instruments_that_dolfyn_reads_as_one_are_refused_naming_where_the_second_begins(pd0_dir, tmp_path):
    """RDI_withBT.000 (a 600 kHz Workhorse in earth coordinates, cut inside its last ensemble) with winriver01.PD0 (a
    300 kHz Workhorse in ship coordinates) joined behind: dolfyn reads both without an error, and the 1982 pings were
    read as one log in the first one's earth frame (the second's sorted before it by their clock). Refused, naming
    where the instrument changes and the byte to cut at, as where dolfyn fails."""
    first, second = pd0_dir / "RDI_withBT.000", pd0_dir / "winriver01.PD0"
    spans, size = pd0.scan_pd0(first).spans, first.stat().st_size
    (tmp_path / "joined.PD0").write_bytes(first.read_bytes() + second.read_bytes())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=re.escape(
                f"the instrument (firmware, beams or serial number of the fixed leader) changes from ensemble 1721 "
                f"(byte {spans[-1][0]}) to ensemble 224 (byte {size}): recordings of two instruments joined in one "
                f"file; load each from a file of its own (the bytes before {size} and from {size} on); a DVL log is "
                "one instrument's")):
            read_dvl(tmp_path / "joined.PD0")


def _retimed(src, seconds) -> list[bytearray]:
    """The ensembles of ``src`` (in file order) with their clocks (the variable leader's RTC, and its Y2K copy where
    the firmware keeps one) set to ``seconds`` (Unix s, to the hundredth) and their checksums made good again."""
    import datetime as dt
    raw, scan = src.read_bytes(), pd0.scan_pd0(src)
    parts = [bytearray(raw[a:b]) for a, b in scan.spans]
    for ens, when in zip(parts, seconds):
        offsets = struct.unpack_from(f"<{ens[5]}H", ens, 6)
        leader = next(o for o in offsets if struct.unpack_from("<H", ens, o)[0] == 0x0080)
        at = dt.datetime.fromtimestamp(round(float(when), 2), dt.timezone.utc)
        clock = bytes([at.year % 100, at.month, at.day, at.hour, at.minute, at.second, at.microsecond // 10000])
        if ens[leader + 58:leader + 65] == ens[leader + 4:leader + 11]:
            ens[leader + 57], ens[leader + 58:leader + 65] = at.year // 100, clock
        ens[leader + 4:leader + 11] = clock
        struct.pack_into("<H", ens, len(ens) - 2, sum(ens[:-2]) & 0xFFFF)
    return parts


def _clock(src) -> np.ndarray:
    """The clock of each ensemble of ``src`` in file order (Unix s)."""
    raw = src.read_bytes()
    return np.array([pd0._leader(raw, a)[1] for a, _ in pd0.scan_pd0(src).spans])


def _read_for_a_mission(path):
    """``pd0.read_pd0(path)``'s DVL stream, its metadata and the messages of the warnings it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        dvl, _, meta = pd0.read_pd0(path)
    return dvl, meta, [str(w.message) for w in caught]


def test_a_dvl_clock_that_stops_is_dead_reckoned_at_the_ping_period_not_squeezed(pd0_dir, tmp_path):
    """winriver01.PD0 (262 pings 1.3 s apart) whose clock gives its first 100 pings the first one's time, ticks once
    to the 101st's and stops there: the 161 pings read after the tick are dead-reckoned at the ping period its stall
    ended in (1.30 s), 338 s and 648 m of track as the clean file's 339 s and 650 m, said to be a clock that stood
    still. They were squeezed into the 130 s of the tick (259 s and 499 m of track), warned about only as times
    shared within the clock's tick."""
    src = pd0_dir / "winriver01.PD0"
    true = _clock(src)
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, np.where(np.arange(len(true)) < 100, true[0], true[100]))))
    dvl, meta, said = _read_for_a_mission(path)
    n = len(dvl.t)
    np.testing.assert_allclose(dvl.t, true[:n], rtol=0, atol=1.3)
    assert dvl.t[-1] - dvl.t[0] > 338.0
    assert meta["streams"]["dvl"]["doubted"] == {pd0.STALLED_TIME: n - 2}
    note = [s for s in said if "stood still" in s]
    assert len(note) == 1 and ("after its last time (2017-04-05 08:11:28.81) it never ran on: those 161 pings are "
                               "dead-reckoned at the ping period (1.301 s, what its stalls ended in)") in note[0]


def test_a_dvl_clock_stalled_across_the_pause_between_bursts_puts_the_next_burst_after_it(pd0_dir, tmp_path):
    """winriver01.PD0 retimed to bursts of 10 pings every 30 s, its clock standing still from the 8th ping of the 6th
    burst to the 1st of the 7th (4 pings at one time, then on): the 7th burst's first ping is put the ping period
    before the time the clock jumped to, within 0.05 s of its time. It was put on from the stalled time at the ping
    period, 17 s early (before the pause)."""
    src = pd0_dir / "winriver01.PD0"
    clean = _clock(src)
    k = np.arange(len(clean))
    true = clean[0] + 30.0 * (k // 10) + clean - clean[k // 10 * 10]
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, np.where((k >= 57) & (k <= 60), true[57], true))))
    dvl, meta, said = _read_for_a_mission(path)
    np.testing.assert_allclose(dvl.t, true[:len(dvl.t)], rtol=0, atol=0.05)
    assert meta["streams"]["dvl"]["doubted"] == {pd0.STALLED_TIME: 3}
    assert [s for s in said if "1 of them after the pause between bursts it stood still across" in s]


def test_a_clock_of_whole_seconds_ticking_every_2_s_spreads_1_hz_pings_a_second_apart(pd0_dir, tmp_path):
    """winriver01.PD0 retimed to 1 Hz pings on a clock that ticks every 2 s (DOS time, whole even seconds; two pings
    per time): the second ping of each time is put 1 s after it, on its time, not 0.5 s (the cap of a clock of whole
    seconds). A clock of whole seconds in bursts every 10 s keeps the second (the synthetic bursts test)."""
    src = pd0_dir / "winriver01.PD0"
    true = 2.0 * np.round(_clock(src)[0] / 2.0) + np.arange(262.0)
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, 2.0 * np.floor(true / 2.0))))
    dvl, meta, said = _read_for_a_mission(path)
    np.testing.assert_allclose(dvl.t, true[:len(dvl.t)], rtol=0, atol=1e-6)
    assert meta["streams"]["dvl"]["doubted"] == {pd0.SPREAD_TIME: 130}
    assert [s for s in said if "at most 1.000 s after the time recorded" in s]


@pytest.mark.parametrize("second", ["3 days later", "an hour earlier", "clock restarted at 2000-01-01"])
def test_a_second_recording_joined_without_a_cut_is_named_not_read_as_one_recording(pd0_dir, tmp_path, second):
    """winriver01.PD0 with itself joined behind, retimed 3 days later, an hour earlier or to a clock restarted at
    2000-01-01 (the ensemble numbers start again at 224): each is refused naming the byte to cut at; days later
    naming both recordings (their ensembles and times) as two deployments, not a gap to bridge. All were read as one
    recording without a word (days later, a gap) or sorted second-first "with which their ensemble numbers agree";
    then days later was read as one log with a gap, which a DVL dead reckoning bridged (366 km "travelled")."""
    src = pd0_dir / "winriver01.PD0"
    raw, spans, clock = src.read_bytes(), pd0.scan_pd0(src).spans, _clock(src)
    retimed = {"3 days later": clock + 3 * 86400.0, "an hour earlier": clock - 3600.0,
               "clock restarted at 2000-01-01": 946684800.0 + clock - clock[0]}[second]
    path = tmp_path / src.name
    path.write_bytes(raw + b"".join(_retimed(src, retimed)))
    where = f"ensemble 224 (byte {len(raw)}) after ensemble 485 (byte {spans[-1][0]}) starts the ensemble numbers again"
    if second == "3 days later":
        named = ".*".join(re.escape(part) for part in (
            f"2 recordings joined in one file without a cut, ensemble 224 (byte {len(raw)}) starting the ensemble "
            f"numbers again 3 day(s) ({retimed[0] - clock[-1]:.0f} s) after ensemble 485 (byte {spans[-1][0]}): "
            f"recording 1: ensembles 224-485, from "
            f"{pd0._utc(clock[0])} to {pd0._utc(clock[-1])} UTC (bytes 0-{len(raw) - 1}); recording 2: ensembles "
            f"224-485, from {pd0._utc(retimed[0])} to {pd0._utc(retimed[-1])} UTC",
            "another deployment, not a pause to bridge",
            f"cut the file at byte {len(raw)} (e.g. head -c {len(raw)} {src.name} > first.pd0; tail -c "
            f"+{len(raw) + 1} {src.name} > second.pd0)"))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with pytest.raises(DataError, match=named):
                read_dvl(path)
            assert cli.main(["smooth", "--data", str(path), "--no-plots", "--out", str(tmp_path / "out")]) != 0
        assert not (tmp_path / "out" / "trajectory.csv").exists()           # no track bridging the 3 days
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=re.escape(where) + r" and its clock is \d+\.\d\d s before: a second "
                           r"recording joined behind the first without a cut .*" + re.escape(
                               f"load each recording from a file of its own (the bytes before {len(raw)} and from "
                               f"{len(raw)} on)")):
            read_dvl(path)


def test_bytes_before_a_cut_last_ensemble_at_the_end_and_a_header_written_again_are_counted(pd0_dir, tmp_path):
    """Bytes that are no ensemble, each read as the clean file: a logger's tag between RDI_withBT.000's last whole
    ensemble and the one the file ends in (cut), a CR LF at the end of winriver01.PD0, and the header of
    winriver01.PD0's 101st ensemble written again before it. They are counted and warned about (bytes between
    ensembles, bytes after the last one). The first two were not counted (and the tag cost dolfyn the last whole
    ensemble), the header was counted and warned about as a corrupt ensemble."""
    cut, winriver = pd0_dir / "RDI_withBT.000", pd0_dir / "winriver01.PD0"
    raw, end = cut.read_bytes(), pd0.scan_pd0(cut).spans[-1][1]
    tagged = tmp_path / "tagged" / cut.name
    tagged.parent.mkdir()
    tagged.write_bytes(raw[:end] + b"\r\n$TAG\r\n" + raw[end:])
    raw, spans = winriver.read_bytes(), pd0.scan_pd0(winriver).spans
    ended = tmp_path / "ended" / winriver.name
    ended.parent.mkdir()
    ended.write_bytes(raw + b"\r\n")
    a = spans[100][0]
    header = tmp_path / "header" / winriver.name
    header.parent.mkdir()
    header.write_bytes(raw[:a] + raw[a:a + 6 + 2 * raw[a + 5]] + raw[a:])
    for path, src, key, n in ((tagged, cut, pd0.STRAY_BYTES, 8), (ended, winriver, pd0.TRAILING_BYTES, 2),
                              (header, winriver, pd0.STRAY_BYTES, 20)):
        clean = _read(src)
        log, said = _read_warned(path)
        assert log.counts == {**clean.counts, key: n}
        assert not [s for s in said if "corrupt" in s]
        assert [s for s in said if f"{n} byte(s)" in s]
        np.testing.assert_array_equal(log.t, clean.t)
        np.testing.assert_array_equal(log.v_d, clean.v_d)


def test_a_clock_of_whole_seconds_that_stops_dead_reckons_at_the_ping_period_not_its_median_step(pd0_dir, tmp_path):
    """winriver01.PD0 (pings 1.31 s apart) on a clock of whole seconds (steps of 1 s and 2 s, median 1 s) whose last
    30 pings share one time: they are dead-reckoned at the period its steps give (1.306 s), within the clock's
    second of their times. They were dead-reckoned at its median step, 1.000 s: the last ping 9.2 s early."""
    src = pd0_dir / "winriver01.PD0"
    true = _clock(src)
    recorded = np.floor(true)
    recorded[-30:] = recorded[-30]
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, recorded)))
    dvl, meta, said = _read_for_a_mission(path)
    np.testing.assert_allclose(dvl.t, true[:len(dvl.t)], rtol=0, atol=1.0)
    assert meta["streams"]["dvl"]["doubted"] == {pd0.STALLED_TIME: 28}
    assert [s for s in said if "dead-reckoned at the ping period (1.306 s, its steps)" in s]


@pytest.mark.parametrize("stall", ["through a whole burst", "across two pauses", "at the end of the file"])
def test_a_dvl_clock_stalled_across_several_pauses_or_to_the_end_puts_each_burst_after_its_pause(pd0_dir, tmp_path,
                                                                                                   stall):
    """winriver01.PD0 retimed to bursts of 10 pings 1.3 s apart every 30 s, its clock standing still from the 9th
    ping of the 6th burst through the whole 7th (12 pings), from the 6th of the 6th burst to the last of the 8th (25
    pings), or from the 7th of the last burst but one to the end of the file: every ping lands on its time (0.05 s),
    each burst after its pause. The bursts before the last pause were put without their pause, 17 s early (34 s with
    two), and the burst after a stall to the end of the file 17 s early."""
    src = pd0_dir / "winriver01.PD0"
    k = np.arange(len(_clock(src)))
    true = _clock(src)[0] + 30.0 * (k // 10) + 1.3 * (k % 10)
    first, end = {"through a whole burst": (58, 70), "across two pauses": (55, 80),
                  "at the end of the file": (len(k) - 5, len(k))}[stall]
    recorded = true.copy()
    recorded[first:end] = true[first]
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, recorded)))
    dvl, meta, said = _read_for_a_mission(path)
    np.testing.assert_allclose(dvl.t, true[:len(dvl.t)], rtol=0, atol=0.05)
    assert [s for s in said if "of them after the pause between bursts it stood still across" in s]


def test_a_second_recording_in_another_frame_joined_without_a_cut_is_refused_naming_the_byte(pd0_dir, tmp_path):
    """winriver01.PD0 (ship frame) with itself joined behind 3 days later set up in the earth frame (the EX bits of
    its fixed leaders): refused naming the two ensembles, the frames and the byte to cut at. It was read as one log
    in the earth frame, the first recording's ship-frame velocities turned as earth ones, warned only as a join."""
    src = pd0_dir / "winriver01.PD0"
    raw = src.read_bytes()
    parts = _retimed(src, _clock(src) + 3 * 86400.0)
    for ens in parts:
        offsets = struct.unpack_from(f"<{ens[5]}H", ens, 6)
        fixed = next(o for o in offsets if ens[o:o + 2] == b"\x00\x00")
        ens[fixed + 25] |= 0x18                                           # EX bits 3-4: earth
        struct.pack_into("<H", ens, len(ens) - 2, sum(ens[:-2]) & 0xFFFF)
    path = tmp_path / src.name
    path.write_bytes(raw + b"".join(parts))
    last = pd0.scan_pd0(src).spans[-1][0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(DataError, match=re.escape(
                f"changes from ship in ensemble 485 (byte {last}) to earth in ensemble 224 (byte {len(raw)}): "
                f"recordings set up differently joined in one file") + ".*" + re.escape(
                f"load each from a file of its own (the bytes before {len(raw)} and from {len(raw)} on)")):
            read_dvl(path)


def test_an_instrument_restarted_seconds_later_in_the_same_file_is_named_as_a_second_recording(pd0_dir, tmp_path):
    """winriver01.PD0 with itself joined behind 5 s after its last ping (numbers starting again at 224, the clock
    running on by under 10 of its 1.31 s steps): warned naming where the second recording begins and counted, read
    as one log. It was read without a word; one ensemble number out of line (324 written as 5) is no restart."""
    src = pd0_dir / "winriver01.PD0"
    raw, spans, clock = src.read_bytes(), pd0.scan_pd0(src).spans, _clock(src)
    path = tmp_path / "restarted" / src.name
    path.parent.mkdir()
    path.write_bytes(raw + b"".join(_retimed(src, clock - clock[0] + clock[-1] + 5.0)))
    log, said = _read_warned(path)
    assert [s for s in said if "recording(s) joined" in s] == [
        f"{path}: 1 recording(s) joined behind another without a cut: ensemble 224 (byte {len(raw)}) after ensemble "
        f"485 (byte {spans[-1][0]}) starts the ensemble numbers again 5.00 s later; read as one log with a gap of no "
        f"pings there (to load one recording, cut the file at byte {len(raw)})"]
    assert log.counts[pd0.JOINED_RECORDING] == 1 and len(log.t) == 2 * len(spans) - 1
    parts = [bytearray(raw[a:b]) for a, b in spans]
    leader = next(o for o in struct.unpack_from(f"<{parts[100][5]}H", parts[100], 6)
                  if struct.unpack_from("<H", parts[100], o)[0] == 0x0080)
    struct.pack_into("<H", parts[100], leader + 2, 5)
    struct.pack_into("<H", parts[100], len(parts[100]) - 2, sum(parts[100][:-2]) & 0xFFFF)
    path = tmp_path / "glitch" / src.name
    path.parent.mkdir()
    path.write_bytes(b"".join(parts))
    log, said = _read_warned(path)
    assert pd0.JOINED_RECORDING not in log.counts and not [s for s in said if "joined" in s]


def test_a_dvl_clock_that_stops_and_runs_on_from_where_it_stood_is_said_to_have_lost_the_time(pd0_dir, tmp_path):
    """winriver01.PD0 whose clock stands still for 50 pings (from its 101st) and then runs on from where it stood,
    one step (1.31 s) on: the 50 pings take 65.5 s at the ping period, so the clock lost about 64.2 s and every time
    after is that early; the warning says so and what to give instead. It said only that the clock "then jumped
    1.31 s" and the pings were spread up to it, as if the times after were right."""
    src = pd0_dir / "winriver01.PD0"
    true = _clock(src)
    recorded = true.copy()
    recorded[100:150] = true[100]
    recorded[150:] -= true[149] - true[100]
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, recorded)))
    dvl, meta, said = _read_for_a_mission(path)
    assert meta["streams"]["dvl"]["doubted"] == {pd0.STALLED_TIME: 49}
    note = [s for s in said if "stood still" in s]
    assert len(note) == 1 and ("after the 50 pings at 2017-04-05 08:11:28.81 it ran on only 1.31 s where they take "
                               "65.5 s at the ping period: the clock lost about 64.2 s there") in note[0]
    assert "(a CSV of DVL velocities: t, vx, vy, vz)" in note[0]


def test_a_second_recording_days_later_whose_numbers_run_on_is_not_dead_reckoned_across(pd0_dir, tmp_path):
    """winriver01.PD0 with itself joined behind 3 days later, its ensemble numbers running on (486-747, as an
    instrument that stopped pinging and went on, or a clock set on): no join the numbers show, read as one log
    with a 259200 s gap. `smooth --data` alone refuses to dead-reckon across it, naming the gap and the ensemble
    and byte to cut before, and writes no track; it bridged the gap, 366 km "travelled", warned only as a guess."""
    src = pd0_dir / "winriver01.PD0"
    raw, spans, clock = src.read_bytes(), pd0.scan_pd0(src).spans, _clock(src)
    second = _retimed(src, clock + clock[-1] - clock[0] + 3 * 86400.0)
    for k, ens in enumerate(second):        # ensemble numbers 486 on: the variable leader's number, checksum again
        leader = next(o for o in struct.unpack_from(f"<{ens[5]}H", ens, 6)
                      if struct.unpack_from("<H", ens, o)[0] == 0x0080)
        struct.pack_into("<H", ens, leader + 2, 486 + k)
        struct.pack_into("<H", ens, len(ens) - 2, sum(ens[:-2]) & 0xFFFF)
    path = tmp_path / src.name
    path.write_bytes(raw + b"".join(second))
    said = io.StringIO()
    with warnings.catch_warnings(), contextlib.redirect_stderr(said):
        warnings.simplefilter("ignore")
        assert cli.main(["smooth", "--data", str(path), "--no-plots", "--out", str(tmp_path / "out")]) != 0
    assert not (tmp_path / "out" / "trajectory.csv").exists()           # no track bridging the 3 days
    assert (f"1 gap(s) without a velocity over ground longer than 1 h (3600 s): 3 day(s) (259200 s) from ensemble 485 "
            f"(byte "
            f"{spans[-1][0]}) at t = {clock[-1]:.3f} s ({pd0._utc(clock[-1])} UTC) to ensemble 486 (byte {len(raw)})"
            ) in said.getvalue()
    assert f"dead-reckon each side on its own: cut the log before ensemble 486 (byte {len(raw)})" in said.getvalue()
    described = describe(path)                  # graphnav info says it before smooth is run
    assert "cut the file at its gap(s) of over an hour first" in described["use"]
    assert [n for n in described["streams"]["dvl"]["notes"] if n.startswith("1 gap(s) without a velocity over ground")]

def test_a_stall_of_few_pings_on_a_clock_slower_than_the_pings_is_spread_up_to_its_jump(pd0_dir, tmp_path):
    """winriver01.PD0 retimed to 4 Hz pings on a clock of whole seconds (4 pings a tick), its clock standing still
    for 12 pings (3 s, from the 101st) and then jumping on to the right time: the 12 pings are spread up to the jump
    at the period its ticks hold (0.25 s), each within 0.15 s of its time, said to be a clock that stood still. They
    were spread within one tick (the last 1.93 s early), as pings sharing a time."""
    src = pd0_dir / "winriver01.PD0"
    clean = _clock(src)
    true = np.floor(clean[0]) + 0.1 + 0.25 * np.arange(len(clean))
    recorded = np.floor(true)
    recorded[100:112] = recorded[100]
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, recorded)))
    dvl, meta, said = _read_for_a_mission(path)
    np.testing.assert_allclose(dvl.t, true[:len(dvl.t)], rtol=0, atol=0.15)
    assert meta["streams"]["dvl"]["doubted"][pd0.STALLED_TIME] == 11
    assert [s for s in said if "12 pings from ensemble" in s and "more pings than its other ticks hold (a ping every "
            "0.250 s)" in s]


def test_a_repeated_time_of_pings_2_s_apart_on_a_clock_of_whole_seconds_is_put_a_period_on(pd0_dir, tmp_path):
    """winriver01.PD0 retimed to 0.5 Hz pings on a clock of whole seconds (every step 2 s, as a 2 s clock's) whose
    101st ping repeats the 100th's time: the repeat is put the ping period (2 s) on, on its time, said to be a clock
    that stood still. It was put 1 s on (spread within a 2 s tick), as a time shared with the ping before."""
    src = pd0_dir / "winriver01.PD0"
    clean = _clock(src)
    true = np.floor(clean[0]) + 0.3 + 2.0 * np.arange(len(clean))
    recorded = np.floor(true)
    recorded[100] = recorded[99]
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, recorded)))
    dvl, meta, said = _read_for_a_mission(path)
    np.testing.assert_allclose(dvl.t, true[:len(dvl.t)], rtol=0, atol=0.35)
    assert meta["streams"]["dvl"]["doubted"] == {pd0.STALLED_TIME: 1}
    assert [s for s in said if "2 pings from ensemble" in s and "stood still" in s]


def _bursts(clean, sizes, starts_s):
    """Ping times (s) of bursts of ``sizes`` pings 1.3 s apart starting ``starts_s`` after ``clean[0]``, cycled."""
    t = []
    for b in range(len(clean)):
        t += list(clean[0] + starts_s[b % len(starts_s)] + 60.0 * (b // len(starts_s)) + 1.3 * np.arange(
            sizes[b % len(sizes)]))
        if len(t) >= len(clean):
            return np.array(t[:len(clean)])


@pytest.mark.parametrize("starts", ["every 30 s", "irregularly"])
def test_a_stall_across_the_pause_between_bursts_of_irregular_size_is_placed_by_their_interval(pd0_dir, tmp_path,
                                                                                             starts):
    """winriver01.PD0 retimed to bursts of 10, 9, 11, 8 and 12 pings 1.3 s apart, its clock standing still from the
    last ping of the 6th burst through the 4th of the 7th (5 pings at one time, then on to the right time). Bursts
    starting every 30 s: the 4 pings after the pause are counted back from the jump to the burst's start, each on its
    time (0.05 s); they were put on from the stalled time, 17 s early. Bursts starting irregularly: where the pause
    falls among the 5 cannot be told, and the note says so and how early the pings after it may be (it said
    nothing)."""
    src = pd0_dir / "winriver01.PD0"
    clean = _clock(src)
    true = _bursts(clean, [10, 9, 11, 8, 12], [0.0, 30.0] if starts == "every 30 s" else [0.0, 37.0])
    last = int(np.flatnonzero(np.diff(true) > 10.0)[5])          # the last ping of the 6th burst
    recorded = true.copy()
    recorded[last:last + 5] = true[last]
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, recorded)))
    dvl, meta, said = _read_for_a_mission(path)
    assert meta["streams"]["dvl"]["doubted"] == {pd0.STALLED_TIME: 4}
    if starts == "every 30 s":
        np.testing.assert_allclose(dvl.t, true[:len(dvl.t)], rtol=0, atol=0.05)
        assert [s for s in said if "4 of them after the pause between bursts it stood still across" in s]
        return
    early = recorded[last + 5] - recorded[last] - 5 * 1.3
    assert [s for s in said if f"the 5 pings at {pd0._utc(recorded[last])} stood across a pause between bursts" in s
            and f"which of them came after the pause cannot be told from bursts of irregular size, so they are put "
            f"on from its time and those after the pause are up to {early:.1f} s early" in s]


def test_a_stall_across_two_pauses_between_bursts_starting_every_30_s_is_said_not_placed_in_part(pd0_dir, tmp_path):
    """The bursts of 10, 9, 11, 8 and 12 pings starting every 30 s, the clock standing still from the last ping of
    the 6th burst through the whole 7th into the 8th (13 pings at one time): which of them came after which pause
    cannot be told, so the note says so and how early they may be (35.3 s). The 8th burst's 3 were put at the
    interval and the 7th's 9 left on from the stalled time, 17 s early, without a word of them."""
    src = pd0_dir / "winriver01.PD0"
    clean = _clock(src)
    true = _bursts(clean, [10, 9, 11, 8, 12], [0.0, 30.0])
    ends = np.flatnonzero(np.diff(true) > 10.0)
    last = int(ends[5])                                              # the last ping of the 6th burst
    recorded = true.copy()
    recorded[last:ends[6] + 4] = true[last]
    path = tmp_path / src.name
    path.write_bytes(b"".join(_retimed(src, recorded)))
    dvl, meta, said = _read_for_a_mission(path)
    assert meta["streams"]["dvl"]["doubted"] == {pd0.STALLED_TIME: 12}
    early = recorded[ends[6] + 4] - recorded[last] - 13 * 1.3
    assert [s for s in said if f"the 13 pings at {pd0._utc(recorded[last])} stood across a pause between bursts" in s
            and f"those after the pause are up to {early:.1f} s early" in s]
    assert not [s for s in said if "of them after the pause between bursts it stood still across" in s]
