"""Teledyne RDI PD0 (Workhorse / Pathfinder / Pioneer / Tasman / RiverPro DVLs and ADCPs, and VmDAS/WinRiver
ensemble files) through MHKiT's dolfyn, in every coordinate frame the instrument can record.

The reader is dolfyn's ``read_rdi`` as maintained inside MHKiT (``mhkit.dolfyn``), and every rotation between
RDI's frames is dolfyn's own (``rotate2``, its orientation matrix from the stored heading/pitch/roll, its
beam-to-instrument matrix); this module only adds what dolfyn does not do: recognising a PD0 file by its
content, the beam-to-instrument matrix the instrument stores (block ``0x3200``, which dolfyn skips), undoing
RDI's *ship* frame, sorting pings into 4-beam / 3-beam / no-lock, and mapping RDI's instrument frame to
graphnav's DVL frame ``d`` (:mod:`graphnav.core.dvl`, ``docs/decisions/dvl-frame.md``).

**Frames and signs.** RDI's instrument frame (``X, Y, Z``; dolfyn's ``inst``) has beam 1 toward -X, beam 2
toward +X, beam 3 toward +Y, beam 4 toward -Y for a convex head (the signs swap for a concave one) and the
beams pointing along **-Z**: the beam-to-instrument matrix (RDI P/N 951-6079-00 section 5, dolfyn's
``_calc_beam_orientmat`` and the ``0x3200`` matrix the instruments store) has ``w = +b (B1 + B2 + B3 + B4)``
with beam velocities positive toward the transducer. Bottom-track velocities are the seabed's velocity
relative to the head (WinRiver's boat velocity is their negative). graphnav's DVL frame is the instrument's
forward-right-down frame: ``x_d`` along RDI's +Y (beam 3, the instrument's heading reference), ``y_d``
along RDI's +X (beam 2), ``z_d`` along RDI's -Z (the beams' side), i.e. ``v_d = C_D_RDI @ v_rdi`` with
:data:`C_D_RDI` a proper rotation. graphnav's beam (the head's velocity along the outward beam unit vector)
then equals RDI's bottom-track beam velocity as recorded, and a convex head has beam azimuths 270, 90, 0,
180 deg in ``d``. (Before this module settled it, graphnav took RDI's X and Y as ``x_d, y_d`` with beams along
+z: a reflection of RDI's frame, which solved to (-u, -v, +w) of dolfyn's instrument velocity.)

**What a ping becomes** (:func:`read_pd0_log`):

* ``beam`` files: the four bottom-track beams as they are; RDI marks a beam without lock with -32768.
* ``inst``/``ship``/``earth`` files: the instrument rotated the velocities itself with its own heading, pitch
  and roll (tilts only when the ``EX`` "use tilts" bit is set; the ship frame has no heading). A ping whose
  four components (X/Y/Z or E/N/U plus the error velocity) are valid is rotated back to the instrument frame
  and to beams with dolfyn's rotations; a ping whose error velocity is flagged but whose three velocity
  components are valid is a *3-beam solution* (``EX`` xxx1x, RDI's percent-good 1 = 100): its beams cannot be
  recovered (the missing beam was filled by assuming a zero error velocity), so it only gives ``v_d``.
* Every usable ping gives ``v_d`` (head velocity in ``d``) and ``v_n`` (head velocity in NED from the
  instrument's attitude; RDI's earth frame is East-North-Up).
* the clock (variable leader RTC) as Unix-second stamps. dolfyn keeps an ensemble only when another header
  follows it (the end of a file may be cut), so a complete file's last ensemble is not read; it is counted. A
  file that ends inside an ensemble (a copy or download cut short) has that ensemble left out, warned about and
  counted (``counts``, and a note of the DVL stream), as a corrupt ensemble (wrong checksum) is, and so are
  bytes before the first ensemble (a logger that started mid-ensemble or wrote a preamble), bytes between two whole
  ensembles (a CR LF or time tag a logger wrote, a header written twice; both ensembles are read), bytes after the
  last one and a second recording joined behind the first without a cut (its numbers start again: warned and
  read on where its clock runs on by less than :data:`JOIN_SPLIT_S`, an hour; refused where it runs on longer,
  another deployment whose gap no track may bridge, naming each recording and the byte to cut at; refused where it
  runs back or the frame of its velocities differs) and an
  ensemble written again byte for byte anywhere after itself (a logger's retry, a file appended to itself: the
  same ping twice, which dolfyn cannot read or reads as time running back); an ensemble cut short by the next one
  whose bytes are those of an ensemble read whole (or of the one the file ends in) is such a copy too: the cut end
  of a file with a copy of it joined behind, not a corrupt ensemble.
* ensembles stored out of time order are put in order by their own clock (the variable leader's RTC) when their
  ensemble numbers agree (counted on across a roll-over 65535 -> 0 without the high byte, also where other
  ensembles of the file carry it), warned about and
  counted; ensembles that share a time (a clock of 1 s resolution on an instrument pinging faster) are ordered by
  their numbers and keep that time (a mission's DVL stream, :func:`read_pd0`, spreads them within the clock's
  tick: :func:`spread_shared_times`, warned and counted as doubted; a clock that stood still for several pings on
  a clock that otherwise gives each ping its own time or more than its other ticks hold on a clock slower than the
  pings, or more than :data:`FROZEN_CLOCK_PINGS` on any clock, has them spread up to the jump at the ping period at
  most, dead-reckoned at it after the clock's last time, and put after the pause between bursts it stood across
  where the bursts' size or interval tells where (said where it cannot), said so; a DVL file dead-reckoned alone is
  spread alike); a file
  whose clock and numbers disagree (a clock set back mid-file, two different ensembles with one time and one number,
  two recordings overlapping in time) is refused naming the ensembles (:func:`_time_order` says why), and so is one
  of fewer than :data:`MIN_ENSEMBLES` ensembles, which dolfyn cannot read.
* depth from the pressure sensor (dbar -> m with the configured water density). A pressure word of
  0xFFFFFFFF (no sensor: 4.29e6 dbar) or a depth outside :data:`DEPTH_RANGE_M` is invalid, counted, warned. A
  pressure is positive down by its physics, so there is no convention to declare (``csv_columns.depth.positive`` is
  for a ``depth`` column, refused with a ``pressure``); a PD0 file without a pressure sensor takes its depth from
  ``csv_columns.depth``, where the key applies.

A PD0 file holds the DVL only: for a mission, the IMU comes from the CSV column map of the configuration
(:mod:`graphnav.io.generic_csv`, whose ``dvl`` entry may name a PD0 file) on the same clock (Unix seconds).
The loader sets ``dvl.theta_rad`` and ``dvl.psi_rad`` from the file's beam matrix (:func:`pd0_geometry`); the
configuration's ``dvl.C_d_b`` turns ``d`` into the body frame: ``I`` for a down-looking head with beam 3
forward, a 45 deg yaw for beam 3 at 45 deg to starboard.
"""
from __future__ import annotations

import contextlib
import dataclasses
import datetime
import hashlib
import io
import re
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.dvl_log import COUNT_NOTES, DvlLog
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.mission import MAX_DVL_SPEED_MPS, DepthData, DvlData
from graphnav.core.rotations import C_NED_ENU
from graphnav.core.screening import located

#: File name endings of PD0 ensembles: RDI's own ``.pd0`` and numbered ``.000``, ``.001``, ...; VmDAS's raw
#: ``.ENR``, averaged ``.ENS`` and ``.ENX`` (any case). A file is read as PD0 by its content
#: (:func:`looks_like_pd0`), whatever its name.
PD0_SUFFIXES = (".pd0", ".enr", ".ens", ".enx")
#: RDI's instrument frame (X, Y, Z) to graphnav's DVL frame d (forward = RDI +Y, right = RDI +X, down = RDI -Z).
C_D_RDI = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
#: RDI's bad-velocity marker in raw counts (mm/s).
PD0_BAD = -32768
#: A pressure word of 0xFFFFFFFF (decapascal) is RDI's "no pressure sensor"; dolfyn scales it to this, dbar.
PRESSURE_NO_SENSOR_DBAR = 0xFFFFFFFF * 1e-3
#: Depths (m, positive down) a pressure reading can mean: a few metres above the surface (a sensor in air,
#: gauge offsets) to the deepest ocean trench.
DEPTH_RANGE_M = (-5.0, 11000.0)
#: Bytes searched for the first ensemble header when recognising a file.
SNIFF_BYTES = 1 << 16
#: dolfyn's name of each frame of the EX bits -> graphnav's (:attr:`DvlLog.frame`).
FRAME_NAMES = {"beam": "beam", "inst": "instrument", "ship": "ship", "earth": "earth"}


# ---------------------------------------------------------------------------------------------- content


@dataclass
class Pd0Scan:
    """What a byte-level pass over a PD0 file finds.

    Attributes:
        ensembles: complete ensembles with a valid checksum (an ensemble repeated right after itself once).
        bad_checksum: headers (0x7F 0x7F) followed by a full-length ensemble whose checksum fails (but the cut
            copies, ``cut_copies``, and the ensembles cut short, ``cut_short``).
        trailing_bytes: bytes after the last complete ensemble (a file cut by a logger).
        beam_matrix: (4,4) beam-to-instrument matrix of block 0x3200 of the first ensemble (rows X, Y, Z,
            error; scaled counts / 10000), or None.
        cut_bytes: bytes of the ensemble the file ends in when it is cut (a header 0x7F 0x7F after the last
            complete or corrupt ensemble whose length runs past the end of the file), 0 when none.
        cut_length: the length (bytes, with the checksum) that cut ensemble's header gives, 0 when none (or cut
            inside its header).
        cut_offset: the byte offset of that cut ensemble, 0 when none.
        leading_bytes: bytes before the first ensemble header (complete or corrupt), skipped: a logger that
            started mid-ensemble or wrote its own preamble; it is the first ensemble's byte offset.
        repeated: checksummed ensembles identical byte for byte to an earlier one (left out of ``spans``).
        numbers: each kept ensemble's number (the variable leader's, as ``spans``; -1 without a variable leader).
        copies: ``(number, byte offset)`` of each copy left out (``repeated`` of them), in file order, a cut copy
            (``cut_copies``) among them.
        cut_copies: ``(number, byte offset, bytes present, byte offset of the whole one)`` of each ensemble cut short
            inside the file by the next one whose bytes are the start of an ensemble read whole elsewhere (the cut
            end of a file with a copy of it joined behind): a copy, counted in ``repeated``, not in ``bad_checksum``.
        moved: kept ensembles that the time order puts elsewhere than the file does (``spans`` is in time order).
        order_note: where the file's order first runs back in time (for the warning), "" when it never does.
        unplaced: why the ensembles cannot be put in time order (the file is refused), "" when they can.
        cut_short: ``(number, byte offset, bytes present, length with the checksum, byte offset of the next one)`` of
            each ensemble cut short inside the file by the next one that is no copy (``cut_copies``) and holds its
            number and clock: a file cut there with another recording joined behind (or bytes a logger lost), left
            out; not in ``bad_checksum``. One cut before its number and clock cannot be told from a corrupt one.
        stray: ``(byte offset, bytes, its first 16 bytes)`` of each run of bytes between two ensembles that belongs
            to neither (a CR LF or a time tag a logger wrote between them, a header written again before the whole
            ensemble, bytes before the ensemble the file ends in), skipped.
        tail_bytes: bytes after the last ensemble of a file that ends in no cut one (a CR LF a logger wrote), skipped.
        joins: ``(number, byte offset, number, byte offset, gap s)`` of each place a second recording begins behind the
            first without a cut: the ensemble numbers start again and the clock jumps on (:func:`_joins`).
    """

    ensembles: int
    bad_checksum: int
    trailing_bytes: int
    beam_matrix: np.ndarray | None
    spans: list = dataclasses.field(default_factory=list, repr=False)   # (start, end) byte range of each one
    cut_bytes: int = 0
    cut_length: int = 0
    cut_offset: int = 0
    leading_bytes: int = 0
    repeated: int = 0
    numbers: list = dataclasses.field(default_factory=list, repr=False)
    copies: list = dataclasses.field(default_factory=list, repr=False)
    moved: int = 0
    order_note: str = ""
    unplaced: str = ""
    cut_copies: list = dataclasses.field(default_factory=list, repr=False)
    stray: list = dataclasses.field(default_factory=list, repr=False)
    cut_short: list = dataclasses.field(default_factory=list, repr=False)
    tail_bytes: int = 0
    joins: list = dataclasses.field(default_factory=list, repr=False)


def _ensembles(raw: bytes, limit: int | None = None):
    """(offset, length without checksum, checksum ok) of each 0x7F7F-headed ensemble, in order."""
    data = np.frombuffer(raw, dtype=np.uint8)
    csum = np.concatenate([[0], np.cumsum(data, dtype=np.int64)])
    pos, n = 0, len(raw)
    while True:
        i = raw.find(b"\x7f\x7f", pos)
        if i < 0 or i + 6 > n or (limit is not None and i > limit):
            return
        length = raw[i + 2] | (raw[i + 3] << 8)
        if length < 6 or i + length + 2 > n:
            pos = i + 1
            continue
        ok = (int(csum[i + length] - csum[i]) & 0xFFFF) == (raw[i + length] | (raw[i + length + 1] << 8))
        if not ok and not _header_form(raw, i, length):      # a 0x7F 0x7F in bytes of another kind (a time tag)
            pos = i + 1
            continue
        yield i, length, ok
        pos = i + length + 2 if ok else i + 1


def _header_form(raw: bytes, start: int, length: int) -> bool:
    """Whether the bytes at ``start`` have the form of an ensemble's header (RDI P/N 951-6079-00): at least one data
    type, and the first one's offset just past the header's own offsets (the fixed leader follows the header), within
    ``length``. A corrupt ensemble keeps it; a 0x7F 0x7F that a logger's time tag or CR LF run happens to hold does
    not, and is skipped with the bytes around it."""
    n_types = raw[start + 5]
    return n_types > 0 and 6 + 2 * n_types <= length and struct.unpack_from("<H", raw, start + 6)[0] == 6 + 2 * n_types


def _beam_matrix(raw: bytes, start: int) -> np.ndarray | None:
    """Block 0x3200 (16 int16, row-major, scaled by 10000) of the ensemble at ``start``, if present."""
    n_types = raw[start + 5]
    offsets = struct.unpack_from(f"<{n_types}H", raw, start + 6)
    for off in offsets:
        if struct.unpack_from("<H", raw, start + off)[0] == 0x3200:
            return np.array(struct.unpack_from("<16h", raw, start + off + 2), float).reshape(4, 4) / 1e4
    return None


def scan_pd0(path: str | Path) -> Pd0Scan:
    """Count the complete, checksummed ensembles of a PD0 file and read its stored beam matrix; leave out the copies
    of an ensemble (byte for byte the same as an earlier one, anywhere in the file) and put the rest in time order
    (:func:`_time_order`)."""
    raw = Path(path).read_bytes()
    spans, bad, bad_end, first, copies, end, seen, stray = [], [], 0, None, [], 0, set(), []
    for start, length, ok in _ensembles(raw):
        first = start if first is None else first
        if ok:
            if start < bad_end:        # a whole ensemble inside one that fails: that one was cut short here
                bad[-1][2] = bad_end = start
            elif start > max(end, bad_end) and (end or bad_end):      # bytes between two ensembles
                at = max(end, bad_end)
                stray.append((at, start - at, raw[at:min(start, at + 16)]))
            end = start + length + 2
            digest = hashlib.blake2b(memoryview(raw)[start:end], digest_size=16).digest()
            if digest in seen:
                copies.append((_leader(raw, start)[0], start))
            else:
                seen.add(digest)
                spans.append((start, end))
        elif start >= bad_end:         # a 0x7F7F inside a corrupt ensemble is not another ensemble
            bad_end = start + length + 2
            bad.append([start, length + 2, bad_end])
    cut_offset, cut_bytes, cut_length = _cut_ensemble(raw, max(end, bad_end))
    cut = [b for b in bad if b[2] - b[0] < b[1]]
    cut_copies = _cut_copies(raw, cut, spans, cut_offset if cut_bytes else None)
    copied = {start for _, start, _, _ in cut_copies}
    cut_short = [(_leader(raw[a:stop], 0)[0], a, stop - a, length, stop) for a, length, stop in cut
                 if a not in copied and _leader(raw[a:stop], 0)[0] >= 0]
    headers = _headers_again(raw, [c for c in cut if c[0] not in copied and _leader(raw[c[0]:c[2]], 0)[0] < 0], spans)
    last = max(end, bad_end)
    if cut_bytes and cut_offset > last and spans:        # bytes between the last whole ensemble and the cut one
        stray.append((last, cut_offset - last, raw[last:min(cut_offset, last + 16)]))
    stray = sorted(stray + [(a, n, raw[a:a + min(n, 16)]) for a, n in headers])
    tail = len(raw) - last if spans and not cut_bytes else 0
    copies = sorted(copies + [(number, start) for number, start, _, _ in cut_copies], key=lambda c: c[1])
    numbers, seconds = (np.array(x) for x in zip(*[_leader(raw, a) for a, _ in spans])) if spans else ([], [])
    order, note, unplaced = _time_order(np.asarray(numbers, int), np.asarray(seconds, float), spans)
    spans = [spans[i] for i in order]
    joins = _joins(np.asarray(numbers, int)[order], np.asarray(seconds, float)[order], spans) if not unplaced else []
    return Pd0Scan(len(spans), len(bad) - len(cut_copies) - len(cut_short) - len(headers),
                   len(raw) - end if spans else len(raw),
                   _beam_matrix(raw, spans[0][0]) if spans else None, spans, cut_bytes, cut_length, cut_offset,
                   first or 0, len(copies), [int(numbers[i]) for i in order], copies,
                   int((order != np.arange(len(order))).sum()), note, unplaced, cut_copies, stray, cut_short, tail,
                   joins)


def _headers_again(raw: bytes, cut: list, spans: list) -> list:
    """``(byte offset, bytes)`` of each ensemble start cut before its number and clock (``cut``: ``[start, length
    with the checksum, where the next one starts]``) that is the first bytes of the whole ensemble right behind it
    again, between two whole ensembles (``spans``, in file order) whose numbers run on by one: a header a logger
    wrote and then wrote again with the whole ensemble (a retry), no ping lost, so bytes between ensembles, not a
    corrupt ensemble. Where the numbers skip one, that ping's rest was lost and it stays a corrupt one."""
    ends = {b: a for a, b in spans}
    starts = {a for a, _ in spans}
    found = []
    for start, _, stop in cut:
        n = stop - start
        if stop in starts and start in ends and raw[start:stop] == raw[stop:stop + n] \
                and (_leader(raw, stop)[0] - _leader(raw, ends[start])[0]) & 0xFFFF == 1:
            found.append((start, n))
    return found


def _cut_copies(raw: bytes, cut: list, spans: list, end_cut: int | None) -> list:
    """``(number, byte offset, bytes present, byte offset of the whole ensemble or None)`` of each ensemble that
    another cuts short inside the file (``cut``: ``[start, length with the checksum, where the next one starts]``)
    and whose bytes are the start of a whole ensemble read (``spans``), or are those of the ensemble the end of the
    file cuts (at ``end_cut``, None: none) as far as both go: the cut end of a file with a copy of it joined behind
    (a file appended to itself, a download resumed from the start). Its checksum fails only because the next
    ensemble's bytes take the place of its rest, so it is no corrupt ensemble. Only bytes that reach past the
    variable leader's number and clock tell which ping they are: the header and fixed leader before them are the
    same in every ensemble of an instrument, so an ensemble cut before them (bytes a logger lost, another file
    joined behind) stays a corrupt one."""
    found = []
    for start, length, stop in cut:
        present = raw[start:stop]
        if _leader(present, 0)[0] < 0:      # cut before its number and clock: which ping it was cannot be told
            continue
        whole = next((a for a, b in spans if b - a == length and raw[a:a + len(present)] == present), None)
        if whole is not None:
            found.append((_leader(raw, whole)[0], start, len(present), whole))
            continue
        tail = raw[end_cut:] if end_cut is not None else b""
        if _leader(tail, 0)[0] >= 0 and tail[2:4] == present[2:4] and tail[:len(present)] == present[:len(tail)]:
            found.append((_leader(present, 0)[0], start, len(present), None))      # its own bytes only
    return found


def _leader(raw: bytes, start: int) -> tuple[int, float]:
    """(ensemble number, time in Unix s) of the ensemble at ``start`` as its variable leader (block 0x0080) gives
    them: the number's low word (bytes 2-3) and high byte (byte 11), and the real-time clock (bytes 4-10: year of
    the century, month, day, hour, minute, second, hundredths); the century is the Y2K clock's (byte 57, before
    the same seven bytes again: Workhorse firmware from 16.05, read so by dolfyn) or else 20, as dolfyn reads it;
    (-1, NaN) without a variable leader, NaN for a clock that is no date."""
    try:
        offsets = struct.unpack_from(f"<{raw[start + 5]}H", raw, start + 6)
        off = next(start + o for o in offsets if struct.unpack_from("<H", raw, start + o)[0] == 0x0080)
        number = struct.unpack_from("<H", raw, off + 2)[0] + (raw[off + 11] << 16)
        y, mo, d, h, mi, s, hundredths = raw[off + 4:off + 11]
    except (StopIteration, struct.error, ValueError, IndexError):     # a block that runs past the file
        return -1, float("nan")
    y2k = raw[off + 57:off + 65]
    century = y2k[0] if len(y2k) == 8 and y2k[1:] == raw[off + 4:off + 11] else 20
    try:
        when = datetime.datetime(100 * century + y if y < 100 else y, mo, d, h, mi, s, hundredths * 10000,
                                 tzinfo=datetime.timezone.utc)
    except ValueError:
        return number, float("nan")
    return number, when.timestamp()


def _time_order(numbers: np.ndarray, t: np.ndarray, spans: list) -> tuple[np.ndarray, str, str]:
    """The order (indexes into ``spans``) that puts the ensembles in time by their own clock ``t`` (Unix s) and,
    at one time, by their numbers; a note of where the file first runs back in that order, and why the ensembles
    cannot be ordered ("" when they can).

    An ensemble stored out of place (a logger that wrote its buffer out of order, files of one instrument joined
    in the wrong order) is moved to its time: its clock and its number both say where it belongs. Ensembles that
    share a time (a clock of 1 s resolution, or one writing zero hundredths, on an instrument pinging faster than
    1 Hz) are ordered by their numbers (:func:`_in_time`). The order is refused when the clock and the numbers
    disagree, as an AUV engineer would not guess: the clock runs back while the numbers run on (the clock was set
    back mid-file; sorting by the clock would interleave two stretches of pings, sorting by number would trust a
    clock known to be wrong), two different ensembles carry one time and one number (which is the instrument's
    cannot be told), sorting would interleave the numbers of two recordings that overlap in time, or a clock that
    is no date has to be placed (also in a file that needs no moving: dolfyn gives it a time no reader can use). A
    file that never runs back in time or in number within one time keeps its order.
    """
    order = np.arange(len(t))
    named = [f"ensemble {n} (byte {a})" for n, (a, _) in zip(numbers, spans)]
    numbers = _rolled_over(numbers, t)
    known = np.flatnonzero(np.isfinite(t))
    by_time = known[np.lexsort((numbers[known], t[known]))]          # one time and one number side by side
    twins = by_time[1:][(np.diff(t[by_time]) == 0) & (np.diff(numbers[by_time]) == 0)]
    if len(twins):
        i, j = sorted(np.flatnonzero((t == t[twins[0]]) & (numbers == numbers[twins[0]]))[:2])
        return order, "", (f"{named[i]} and {named[j]} hold the same time ({_utc(t[i])}) and number but differ: "
                           "which one the instrument recorded then cannot be told; if you know, remove the other's "
                           "bytes from a copy of the file")
    dt_s, dn = np.diff(t[known]), np.diff(numbers[known])
    back = known[:-1][(dt_s < 0) | ((dt_s == 0) & (dn < 0))]
    if not len(back):
        if len(known) < len(t):            # dolfyn stamps it 1677-09-21, which no reader after can place either
            bad = int(np.flatnonzero(~np.isfinite(t))[0])
            return order, "", (f"{named[bad]} has a clock that is no date: it cannot be placed in time; remove that "
                               "ensemble (its bytes) from a copy of the file")
        return order, "", ""
    nxt = {int(i): int(j) for i, j in zip(known[:-1], known[1:])}
    note = _back_note(named, t, int(back[0]), nxt[int(back[0])])
    if len(known) < len(t):
        bad = int(np.flatnonzero(~np.isfinite(t))[0])
        return order, note, (f"{note}, and {named[bad]} has a clock that is no date: it cannot be placed in time; "
                             "remove that ensemble (its bytes) from a copy of the file")
    for i in back:
        j = nxt[int(i)]
        if t[j] < t[i] and numbers[j] >= numbers[i]:
            return order, note, (f"the clock runs back {t[i] - t[j]:.2f} s from {named[i]} to {named[j]} while the "
                                 "ensemble numbers run on: the instrument's clock was set back mid-file, so the "
                                 f"ensembles cannot be placed in time; cut the file at byte {spans[j][0]} and load "
                                 "each part with its own clock offset (dvl_time_offset_s)")
    in_time = _in_time(numbers, t)
    if _numbers_back(numbers[in_time]) > _numbers_back(numbers):       # a number not after the one before it
        return order, note, (f"{note}, and in time order the ensemble numbers would interleave: two recordings "
                             "that overlap in time, which cannot be told apart; load each recording from a file "
                             "of its own")
    moved = in_time != order
    if not moved.any():            # only restarts or roll-overs within one second: the file's order is the time's
        return order, "", ""
    joined = next((int(i) for i in back if t[nxt[int(i)]] < t[i] and not _runs_on(numbers[i], numbers[nxt[int(i)]])),
                  None)
    if joined is not None and _numbers_back(numbers[in_time]) >= _numbers_back(numbers):   # sorting would not help
        i, j = joined, nxt[joined]
        return order, note, (f"{named[j]} after {named[i]} starts the ensemble numbers again and its clock is "
                             f"{t[i] - t[j]:.2f} s before: a second recording joined behind the first without a cut "
                             "(its clock restarted or was set back), which sorting by the clock would interleave or "
                             "put first; load each recording from a file of its own (the bytes before "
                             f"{spans[j][0]} and from {spans[j][0]} on)")
    i = next(int(i) for i in back if moved[i] or moved[nxt[int(i)]])
    return in_time, _back_note(named, t, i, nxt[i]), ""


def _runs_on(before: int, after: int) -> bool:
    """Whether ensemble number ``after`` follows ``before`` (ensembles lost between allowed, across a roll-over of the
    low word too): a step forward of less than half of 65536."""
    return 0 < (int(after) - int(before)) & 0xFFFF <= 0x8000


#: A second recording joined behind the first without a cut: the ensemble numbers start again and the clock jumps
#: on by more than this many of the file's median steps, or on by less and the numbers run on from where they
#: started again (an instrument restarted within seconds keeps its time, but is restarted: its set-up may differ).
JOIN_GAP_STEPS = 10


def _joins(numbers: np.ndarray, t: np.ndarray, spans: list) -> list:
    """``(number, byte offset, number, byte offset, gap s)`` of each place where, in time order (``numbers``, clock
    ``t`` Unix s, ``spans``), the ensemble numbers start again (not after the one before) while the clock jumps on by
    more than :data:`JOIN_GAP_STEPS` median steps, or on by less and the next number runs on from the new one and is
    still behind the old one (a single number out of line is no restart): a second recording (the instrument
    restarted, files of two recordings concatenated) joined behind the first without a cut."""
    if len(t) < 3 or min(numbers) < 0:
        return []
    dt_s = np.diff(t)
    step = float(np.median(dt_s[dt_s > 0])) if np.any(dt_s > 0) else 0.0
    restarted = [i + 2 == len(t) or _runs_on(numbers[i + 1], numbers[i + 2]) and _runs_on(numbers[i + 2], numbers[i])
                 for i in range(len(dt_s))]
    return [(int(numbers[i]), spans[i][0], int(numbers[i + 1]), spans[i + 1][0], float(dt_s[i]))
            for i in np.flatnonzero((dt_s > JOIN_GAP_STEPS * step) | ((dt_s > 0) & np.array(restarted)))
            if not _runs_on(numbers[i], numbers[i + 1])]


def _rolled_over(numbers: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The ensemble numbers counted on across a roll-over without the high byte (65535 -> 0, an instrument that
    leaves the variable leader's byte 11 at 0), in the order of the clock ``t`` (Unix s): a step of the low word of
    more than half of 65536 between ensembles next in time whose high byte stays the same is the low word wrapping,
    not a restart, so sorting by number and the agreement of numbers with the clock see 65535, 65536. That holds in a
    file where other ensembles carry the high byte too (a step where it changes, 65535 -> 65536 written with it, is
    taken as it is). Numbers as they are when any has no variable leader (-1)."""
    if not len(numbers) or numbers.min() < 0:
        return numbers
    by_time = np.argsort(np.where(np.isfinite(t), t, np.inf), kind="stable")
    step = np.diff(numbers[by_time] & 0xFFFF)
    same_high = np.diff(numbers[by_time] >> 16) == 0
    wraps = np.where(same_high & (np.abs(step) > 0x8000), -np.sign(step), 0)
    unrolled = numbers.copy()
    unrolled[by_time[1:]] += 0x10000 * np.cumsum(wraps)
    return unrolled


def _back_note(named: list, t: np.ndarray, i: int, j: int) -> str:
    """Where the file runs back from ensemble ``i`` to ``j`` stored after it, in time or (at one time) in number."""
    if t[j] < t[i]:
        return f"{named[j]} is {t[i] - t[j]:.2f} s before {named[i]} stored ahead of it"
    return f"{named[j]} holds the time of {named[i]} stored ahead of it and an earlier number"


def _in_time(numbers: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Indexes that put the clock ``t`` in order; ensembles at one time in the file's order, or in their numbers'
    where that leaves fewer numbers not after the one before them, with the ensembles either side (a swap within
    one second is undone; a restart at 1 or a roll-over without the high byte within one second is kept)."""
    order = np.argsort(t, kind="stable")
    t_in, n_in = t[order], numbers[order]
    starts = np.flatnonzero(np.r_[True, t_in[1:] != t_in[:-1]])
    ends = np.r_[starts[1:], len(order)]
    for a in np.unique(np.searchsorted(starts, np.flatnonzero((t_in[1:] == t_in[:-1]) & (n_in[1:] <= n_in[:-1])),
                                       side="right") - 1):
        first, last = starts[a], ends[a]
        group = order[first:last]
        by_number = group[np.argsort(numbers[group], kind="stable")]
        before, after = order[max(first - 1, 0):first], order[last:last + 1]
        as_filed, as_numbered = (numbers[np.r_[before, g, after]] for g in (group, by_number))
        if _numbers_back(as_numbered) < _numbers_back(as_filed):
            order[first:last] = by_number
    return order


def _numbers_back(numbers: np.ndarray) -> int:
    """How many ensemble numbers are not after the one before them (restarts, roll-overs without the high byte)."""
    return int((np.diff(numbers) <= 0).sum())


def _utc(t: float) -> str:
    return datetime.datetime.fromtimestamp(t, datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%S.%f")[:-4]


def _cut_ensemble(raw: bytes, end: int) -> tuple[int, int, int]:
    """(byte offset, bytes present, length its header gives with the checksum) of the ensemble the end of ``raw``
    cuts: a header 0x7F 0x7F at or after byte ``end`` (the end of the last whole ensemble) whose length runs past
    the end of the file; (0, 0, 0) when there is none."""
    i = raw.find(b"\x7f\x7f", end)
    if i < 0:
        return 0, 0, 0
    if i + 4 > len(raw):                     # cut inside the header: its length is lost
        return i, len(raw) - i, 0
    length = (raw[i + 2] | (raw[i + 3] << 8)) + 2
    return (i, len(raw) - i, length) if i + length > len(raw) else (0, 0, 0)


def _read_good_ensembles(path: Path, scan: Pd0Scan):
    """dolfyn's dataset of only the checksummed ensembles of ``path``, each once and in time order: dolfyn itself
    stops with an error on a corrupt ensemble (it parses on past a failed checksum) and on one repeated (a time
    dimension of two lengths), and keeps ensembles out of order as they are, so those are cut out or moved into a
    temporary copy. The ensemble the end of the file cuts is kept behind them, as in the file: dolfyn reads the
    last whole ensemble only when another header follows it."""
    import tempfile
    raw = path.read_bytes()
    with tempfile.TemporaryDirectory(prefix="graphnav-pd0-") as tmp:
        clean = Path(tmp) / path.name
        clean.write_bytes(b"".join(raw[a:b] for a, b in scan.spans) + raw[scan.cut_offset:] * bool(scan.cut_bytes))
        return _read_rdi(clean, source=str(path))


def looks_like_pd0(path: str | Path) -> bool:
    """True when the file's first 0x7F 0x7F header (within :data:`SNIFF_BYTES`) starts an ensemble whose
    checksum is right: what makes a file PD0, whatever its extension."""
    path = Path(path)
    if not path.is_file():
        return False
    with open(path, "rb") as f:
        raw = f.read(SNIFF_BYTES + (1 << 16))
    return any(ok for _, _, ok in _ensembles(raw, limit=SNIFF_BYTES))


def has_pd0_suffix(path: str | Path) -> bool:
    """A name RDI or VmDAS gives PD0 files (:data:`PD0_SUFFIXES` or ``.NNN``), any case."""
    suffix = Path(path).suffix.lower()
    return suffix in PD0_SUFFIXES or re.fullmatch(r"\.\d{3}", suffix) is not None


def is_pd0(path: str | Path) -> bool:
    """A PD0 file, recognised by content (:func:`looks_like_pd0`)."""
    return looks_like_pd0(path)


# ---------------------------------------------------------------------------------------------- geometry


def rdi_beam_vectors_d(beam2inst: np.ndarray) -> np.ndarray:
    """(4,3) outward beam unit vectors in graphnav's DVL frame from a 4x4 RDI beam-to-instrument matrix.

    Beam velocities ``B`` (positive toward the transducer) of a water/seabed velocity ``V`` relative to the
    head (RDI instrument frame) are ``B = A V`` with ``A`` the first three columns of ``inv(beam2inst)``; a
    beam velocity toward the transducer is ``-V . u`` for the outward unit vector ``u``, so ``u = -A_i``.
    """
    A = np.linalg.inv(np.asarray(beam2inst, float))[:, :3]
    u_rdi = -A / np.linalg.norm(A, axis=1, keepdims=True)
    return u_rdi @ C_D_RDI.T


def check_beam_handedness(u_d: np.ndarray, source: str = "beam matrix") -> None:
    """Refuse a beam geometry that is not RDI's in a right-handed frame: every beam along +z of ``d``, and in
    RDI's numbering ``((u1 - u2) x (u3 - u4)) . z_d > 0`` (true for convex and concave heads alike; a mirrored
    matrix or frame has it negative)."""
    u_d = np.asarray(u_d, float)
    if np.any(u_d[:, 2] <= 0):
        raise DataError(f"beam(s) {np.flatnonzero(u_d[:, 2] <= 0) + 1} do not point along +z of the DVL frame",
                        source, field="beam2inst")
    if np.cross(u_d[0] - u_d[1], u_d[2] - u_d[3])[2] <= 0:
        raise DataError("the beam geometry is mirrored (beams 1-2 x beams 3-4 along -z): a left-handed "
                        "beam-to-instrument matrix or frame", source, field="beam2inst")


def rdi_geometry(beam2inst: np.ndarray, source: str = "beam matrix") -> tuple[float, np.ndarray]:
    """Beam inclination (mean over the beams, rad) and azimuths (4,) in ``d`` of an RDI beam matrix (the
    :class:`~graphnav.core.config.DvlSpec` ``theta_rad``, ``psi_rad``). A convex 20 deg head gives 20 deg and
    270, 90, 0, 180 deg."""
    u_d = rdi_beam_vectors_d(beam2inst)
    check_beam_handedness(u_d, source)
    theta = float(np.mean(np.arccos(np.clip(u_d[:, 2], -1.0, 1.0))))
    psi = np.mod(np.arctan2(u_d[:, 1], u_d[:, 0]), 2 * np.pi)
    return theta, np.where(psi > 2 * np.pi - 1e-9, 0.0, psi)      # -0 (float32 matrices) reads as 0, not 2 pi


# ---------------------------------------------------------------------------------------------- dolfyn


def _import_dolfyn() -> None:
    """Import dolfyn's reader and rotations with the warning filters restored afterwards: importing
    ``mhkit.dolfyn`` runs ``warnings.simplefilter("ignore", RuntimeWarning)`` (in ``dolfyn/binned.py``), which
    would otherwise silence every RuntimeWarning graphnav raises for the rest of the process."""
    try:
        with warnings.catch_warnings():
            import mhkit.dolfyn.io.rdi  # noqa: F401
            import mhkit.dolfyn.rotate.api  # noqa: F401
            import mhkit.dolfyn.rotate.rdi  # noqa: F401
    except ImportError:
        raise ConfigError("reading PD0 needs MHKiT's dolfyn: pip install 'graphnav[pd0]'") from None


def _read_rdi(path: Path, source: str | None = None):
    _import_dolfyn()
    from mhkit.dolfyn.io.rdi import read_rdi
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")   # dolfyn's notes on missing userdata and similar; it prints progress
            return read_rdi(str(path), userdata=False)
    except Exception as exc:  # noqa: BLE001 - dolfyn raises plain Exceptions on corrupt files
        _close_readers(exc.__traceback__)
        raise DataError(f"cannot read as PD0: {type(exc).__name__}: {exc}", source or str(path)) from None


def _close_readers(tb) -> None:
    """Close the file dolfyn's reader opened when it failed: dolfyn never closes it, and the failure's traceback
    (the DataError's context) keeps the reader alive, so the file stayed open and Python warned about it later
    (``ResourceWarning: unclosed file``) in whatever the caller did next."""
    while tb is not None:
        # dolfyn's own frames only: another library's ``self`` (an xarray Dataset half built from a corrupt file)
        # can recurse without end in its attribute lookup
        dolfyn = str(tb.tb_frame.f_globals.get("__name__", "")).startswith("mhkit.dolfyn")
        reader = tb.tb_frame.f_locals.get("self") if dolfyn else None
        for holder in (reader, getattr(reader, "f", None)):        # _RDIReader.f is a bin_reader; bin_reader.f the file
            f = getattr(holder, "f", None)
            if isinstance(f, io.IOBase):
                f.close()
        tb = tb.tb_next


def _bt_dataset(ds, vel: np.ndarray, coord_sys: str):
    """A copy of ``ds`` holding only the bottom-track velocities ``vel`` (4,N) in ``coord_sys``, for dolfyn's
    rotations (which rotate every variable of ``rotate_vars``)."""
    keep = [k for k in ("heading", "pitch", "roll", "orientmat", "beam2inst_orientmat") if k in ds]
    sub = ds[keep].copy(deep=True).assign_coords({c: ds[c] for c in ("beam", "dir") if c in ds.coords})
    sub["vel_bt"] = ds["vel_bt"].copy(data=np.asarray(vel, np.float64))
    sub.attrs = dict(ds.attrs, rotate_vars=["vel_bt"], coord_sys=coord_sys)
    return sub


def _orientmat(ds, heading: bool = True, tilts: bool = True):
    """dolfyn's orientation matrix (inst -> ENU) from the stored attitude, without heading and/or tilts."""
    from mhkit.dolfyn.rotate.rdi import _calc_orientmat
    sub = ds[["heading", "pitch", "roll"]].copy(deep=True)
    sub.attrs = dict(ds.attrs, coord_sys="earth")      # ship handling off: the tilts are applied or zeroed here
    if not heading:
        sub["heading"][:] = 0.0
    if not tilts:
        sub["pitch"][:] = 0.0
        sub["roll"][:] = 0.0
    return _calc_orientmat(sub)


def _rotate(ds, vel: np.ndarray, coord_sys: str, out: str, orientmat=None) -> np.ndarray:
    """``vel`` (4,N) from ``coord_sys`` to ``out`` with dolfyn's ``rotate2`` (``orientmat`` replacing the
    dataset's for the inst <-> earth step)."""
    from mhkit.dolfyn.rotate.api import rotate2
    sub = _bt_dataset(ds, vel, coord_sys)
    if orientmat is not None:
        sub["orientmat"] = orientmat
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        return np.asarray(rotate2(sub, out, inplace=False)["vel_bt"].values, float)


def instrument_velocity(ds, vel: np.ndarray) -> np.ndarray:
    """(4,N) bottom-track velocity in RDI's instrument frame (X, Y, Z, error) from the file's frame, with
    dolfyn's rotations: earth -> inst with the stored attitude (tilts only when the EX bits say they were
    used); ship -> inst by undoing the tilts (the ship frame is the earth rotation without heading); beam ->
    inst with the beam-to-instrument matrix."""
    coord = str(ds.attrs["coord_sys"]).lower()
    tilts = str(ds.attrs.get("use_pitchroll", "yes")).lower() == "yes"
    if coord == "inst":
        return np.asarray(vel, float)
    if coord == "beam":
        return _rotate(ds, vel, "beam", "inst")
    omat = _orientmat(ds, heading=coord == "earth", tilts=tilts)
    return _rotate(ds, vel, "earth", "inst", orientmat=omat)


def beams_from_instrument(ds, inst: np.ndarray) -> np.ndarray:
    """(4,N) beam velocities from instrument-frame (X, Y, Z, error) velocities (dolfyn's inverse
    beam-to-instrument matrix); NaN where a component is NaN."""
    return _rotate(ds, inst, "inst", "beam")


def earth_velocity(ds, inst: np.ndarray) -> np.ndarray:
    """(3,N) East-North-Up velocity from instrument-frame velocities with dolfyn's orientation matrix of the
    stored heading, pitch and roll."""
    return _rotate(ds, inst, "inst", "earth", orientmat=_orientmat(ds))[:3]


# ---------------------------------------------------------------------------------------------- reading


def _stamps(ds) -> np.ndarray:
    return ds["time"].values.astype("datetime64[ns]").astype(np.int64) / 1e9


def _flagged(vel: np.ndarray) -> np.ndarray:
    """RDI's -32768 (dolfyn's float32 -32.768), NaN, or beyond what a DVL can measure."""
    with np.errstate(invalid="ignore"):
        return np.isclose(vel, PD0_BAD * 1e-3) | ~np.isfinite(vel) | (np.abs(vel) > MAX_DVL_SPEED_MPS)


def _depth(ds, config: SensorConfig, counts: dict, source: str, where: list[str]) -> np.ndarray | None:
    """Depth (m, down) from the pressure sensor, NaN where the word is 0xFFFFFFFF or the depth implausible (warned
    about naming the ensembles, ``where``); None when the instrument has no pressure sensor (every word zero or
    0xFFFFFFFF)."""
    if "pressure" not in ds:
        return None
    p_dbar = np.asarray(ds["pressure"].values, float)
    no_sensor = p_dbar > 0.999 * PRESSURE_NO_SENSOR_DBAR
    if np.all(no_sensor | (p_dbar == 0)):
        return None
    # dbar is gauge pressure on RDI instruments: 1 dbar = 1e4 Pa.
    depth = p_dbar * 1e4 / (config.water_density_kgpm3 * config.gravity_mps2)
    out_of_range = ~no_sensor & ((depth < DEPTH_RANGE_M[0]) | (depth > DEPTH_RANGE_M[1]))
    for reason, mask in (("bad pressure word", no_sensor), ("depth out of range", out_of_range)):
        if mask.any():
            counts[reason] = int(mask.sum())
            warnings.warn(f"{source}: {int(mask.sum())} pressure reading(s) are not a depth ({reason}: "
                          f"{'0xFFFFFFFF, no sensor' if reason == 'bad pressure word' else DEPTH_RANGE_M} ), "
                          f"first at {located(np.flatnonzero(mask), where=where, first=True)}; marked invalid",
                          RuntimeWarning, stacklevel=3)
    return np.where(no_sensor | out_of_range, np.nan, depth)


def _instrument(ds, scan: Pd0Scan, matrix_source: str) -> dict:
    a = ds.attrs
    return {"make": "Teledyne RDI", "model": str(a.get("inst_model", "")), "type": str(a.get("inst_type", "")),
            "frequency_khz": float(a["carrier_freq"]) if "carrier_freq" in a else None,
            "beam_angle_deg": float(a.get("beam_angle", np.nan)), "beam_pattern": str(a.get("beam_pattern", "")),
            "n_beams": int(a.get("n_beams", 4)), "orientation": str(a.get("orientation", "")),
            "coordinate_system": FRAME_NAMES.get(str(a.get("coord_sys", "")).lower(), str(a.get("coord_sys"))),
            "ex_bits": {"frame": str(a.get("coord_sys", "")), "tilts_used": a.get("use_pitchroll") == "yes",
                        "three_beam_allowed": a.get("use_3beam") == "yes",
                        "bin_mapping": a.get("bin_mapping") == "yes"},
            "serial": int(a["serialnum"]) if "serialnum" in a else None,
            "firmware": str(a.get("firmware_ver", "")), "pings_per_ensemble": int(a.get("pings_per_ensemble", 1)),
            "beam_matrix": matrix_source, "ensembles_in_file": scan.ensembles,
            "heading_misalign_deg": float(a.get("heading_misalign_deg", 0.0)),
            "magnetic_var_deg": float(a.get("magnetic_var_deg", 0.0))}




#: The :attr:`DvlLog.counts` key of an ensemble the end of the file cuts (not read, as a corrupt one is not).
CUT_ENSEMBLE = "cut ensemble at the end of the file (left out)"
#: The :attr:`DvlLog.counts` key of the bytes before the first ensemble (skipped; a number of bytes, not pings).
LEADING_BYTES = "byte(s) before the first ensemble (skipped)"
#: The :attr:`DvlLog.counts` key of the ensembles cut short inside the file by the next one (left out, not read).
CUT_SHORT_ENSEMBLE = "ensemble cut short by the next one (left out)"
#: The :attr:`DvlLog.counts` key of the bytes between two ensembles that belong to neither (skipped; bytes, not pings).
STRAY_BYTES = "byte(s) between ensembles (skipped)"
#: The :attr:`DvlLog.counts` key of the bytes after the last ensemble of a file ending in no cut one (skipped; bytes).
TRAILING_BYTES = "byte(s) after the last ensemble (skipped)"
#: The :attr:`DvlLog.counts` key of the places a second recording begins behind another without a cut (read on).
JOINED_RECORDING = "recording joined behind another (numbers start again)"
#: The :attr:`DvlLog.counts` key of the ensembles written again, byte for byte (left out, not read).
REPEATED_ENSEMBLE = "ensemble written twice (copy left out)"
#: The :attr:`DvlLog.counts` key of the ensembles stored out of time order (moved to their time, read).
SORTED_ENSEMBLE = "ensemble stored out of time order (sorted)"
#: Complete ensembles dolfyn needs to read a file: it keeps an ensemble only when another header follows it, and
#: divides by the time between the first two it keeps (a ZeroDivisionError with fewer).
MIN_ENSEMBLES = 3


def _warn_cut(scan: Pd0Scan, source: str) -> None:
    """Warn that the file ends inside an ensemble (a copy or a download cut short, a logger stopped mid-write)."""
    of = f" of the {scan.cut_length} its header gives" if scan.cut_length else ""
    warnings.warn(f"{source}: the file ends inside an ensemble ({scan.cut_bytes} byte(s){of}, from byte "
                  f"{scan.cut_offset}): a file cut short; that ensemble is left out, {scan.ensembles} complete "
                  "one(s) read",
                  RuntimeWarning, stacklevel=3)


def _warn_cut_short(scan: Pd0Scan, source: str) -> None:
    """Warn that ensembles are cut short inside the file by the next one (:attr:`Pd0Scan.cut_short`), the first
    two named: a file cut there with another recording joined behind, not a corrupt ensemble."""
    said = [f"ensemble {n} (byte {a}) after {k} of its {length} bytes by the ensemble at byte {nxt}"
            for n, a, k, length, nxt in scan.cut_short[:2]]
    more = f" and {len(scan.cut_short) - 2} more" if len(scan.cut_short) > 2 else ""
    warnings.warn(f"{source}: {len(scan.cut_short)} ensemble(s) cut short by the next one left out: "
                  f"{'; '.join(said)}{more} (a file cut there with another recording joined behind, or bytes a "
                  f"logger lost; its rest is not in the file, so its checksum fails); {scan.ensembles} whole ones "
                  "read", RuntimeWarning, stacklevel=4)


def _warn_stray(scan: Pd0Scan, source: str) -> None:
    """Warn that bytes that belong to no ensemble lie between two whole ones (a logger's CR LF or time tag):
    they are skipped and both ensembles read (dolfyn, finding no header where the first one ends, would lose it)."""
    at, n, head = scan.stray[0]
    after = next((f"after ensemble {k} " for k, (_, b) in zip(scan.numbers, scan.spans) if b == at), "")
    more = f" and {len(scan.stray) - 1} more place(s)" if len(scan.stray) > 1 else ""
    cut = scan.cut_bytes and any(a + k == scan.cut_offset for a, k, _ in scan.stray)
    either = ("the ensembles either side are whole (their checksums hold) and read" if not cut else "the ensembles "
              "before them are whole (their checksums hold) and read; the last ones lie before the ensemble the file "
              "ends in, cut")
    warnings.warn(f"{source}: {sum(k for _, k, _ in scan.stray)} byte(s) between ensembles belong to none and are "
                  f"skipped: {n} {after}at byte {at} ({head!r}{'...' if n > len(head) else ''}){more}; {either}",
                  RuntimeWarning, stacklevel=4)


def _warn_joins(scan: Pd0Scan, source: str) -> None:
    """Warn that a second recording begins behind the first without a cut (:attr:`Pd0Scan.joins`), naming where."""
    n, a, m, b, gap = scan.joins[0]
    more = f" and {len(scan.joins) - 1} more" if len(scan.joins) > 1 else ""
    warnings.warn(f"{source}: {len(scan.joins)} recording(s) joined behind another without a cut: ensemble {m} (byte "
                  f"{b}) after ensemble {n} (byte {a}) starts the ensemble numbers again {_gap_words(gap)} later"
                  f"{more}; read as one log with a gap of no pings there (to load one recording, cut the file at byte "
                  f"{b})", RuntimeWarning, stacklevel=4)


#: A second recording that begins more than this long (s) after the first ends is another deployment, not a pause of
#: one: an hour without the instrument is longer than an AUV's surfacing or a restart of the DVL within a dive, and is
#: a vehicle recovered and put in again (a battery change, another day). Nothing in the file says where the vehicle
#: went between the two, so no track may join them: the file is refused, naming each recording and where to cut it.
JOIN_SPLIT_S = 3600.0


def _refuse_far_joins(raw: bytes, scan: Pd0Scan, source: str) -> None:
    """Refuse a file in which a second recording begins more than :data:`JOIN_SPLIT_S` after the first ends
    (:attr:`Pd0Scan.joins`): read as one log, the gap of hours or days between them would be bridged (a DVL dead
    reckoning carried the last velocity over 3 days: 366 km "travelled"). The message names each recording (its
    ensemble numbers, first and last time, bytes) and the bytes to cut the file at, so that each is navigated on its
    own; joins of less (an instrument restarted within seconds) are read on, warned (:func:`_warn_joins`)."""
    far = [j for j in scan.joins if j[4] > JOIN_SPLIT_S]
    if not far:
        return
    firsts = [0] + [next(i for i, (a, _) in enumerate(scan.spans) if a == j[3]) for j in far] + [len(scan.spans)]
    said = []
    for k, (i, j) in enumerate(zip(firsts, firsts[1:]), 1):
        lo, hi = min(a for a, _ in scan.spans[i:j]), max(b for _, b in scan.spans[i:j])
        said.append(f"recording {k}: ensembles {scan.numbers[i]}-{scan.numbers[j - 1]}, from "
                    f"{_utc(_leader(raw, scan.spans[i][0])[1])} to {_utc(_leader(raw, scan.spans[j - 1][0])[1])} UTC "
                    f"(bytes {lo}-{hi - 1})")
    cuts = " and ".join(str(j[3]) for j in far)
    name = Path(source).name
    raise DataError(f"{len(far) + 1} recordings joined in one file without a cut, "
                    + "; ".join(f"ensemble {m} (byte {b}) starting the ensemble numbers again {_gap_words(gap)} after "
                                f"ensemble {n} (byte {a})" for n, a, m, b, gap in far)
                    + f": {'; '.join(said)}. A gap longer than {_gap_words(JOIN_SPLIT_S)} between two recordings is "
                    "another deployment, not a pause to bridge (nothing says where the vehicle went between them); "
                    f"navigate each on its own: cut the file at byte {cuts} (e.g. head -c {far[0][3]} {name} > "
                    f"first.pd0; tail -c +{far[0][3] + 1} {name} > second.pd0)", source, field="time")


def _gap_words(gap_s: float) -> str:
    """A gap in s as a user reads it: seconds, minutes, hours or days to three figures, hours and days with their
    seconds (a gap of 3601 s reads "1 h (3601 s)", not the "1 h" of the one-hour limit it is over)."""
    for unit, size in (("day(s)", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if gap_s >= size:
            n = gap_s / size
            words = f"{n:.3g} {unit}" if n < 100 else f"{n:.0f} {unit}"
            return words if size < 3600.0 else f"{words} ({gap_s:.0f} s)"
    return f"{gap_s:.2f} s"


def _warn_leading(scan: Pd0Scan, source: str) -> None:
    """Warn that the file does not start with an ensemble (a logger that started mid-ensemble, a preamble, a
    file glued behind another): those bytes are skipped, and a whole ensemble may be among them."""
    n = scan.leading_bytes
    warnings.warn(f"{source}: the first ensemble starts at byte {n}; the {n} byte(s) before it are no PD0 ensemble "
                  "and are skipped (a logger that started mid-ensemble or wrote a preamble)", RuntimeWarning,
                  stacklevel=3)


def _warn_trailing(scan: Pd0Scan, source: str) -> None:
    """Warn that bytes that are no ensemble follow the last one (a logger's CR LF or time tag at the end)."""
    n = scan.tail_bytes
    warnings.warn(f"{source}: the {n} byte(s) after the last ensemble are no PD0 ensemble and are skipped (a logger's "
                  "CR LF or time tag at the end of the file)", RuntimeWarning, stacklevel=3)


def left_out_notes(counts: dict) -> list[str]:
    """The notes of a DVL stream on the parts of the file that were left out or moved before any ping was read
    (corrupt ensembles, copies, ensembles out of time order, one cut by the end of the file, bytes before the
    first and between two), from :attr:`DvlLog.counts`."""
    return [f"{counts[key]} {key}" for key in ("bad checksum (ensemble left out)", CUT_SHORT_ENSEMBLE,
                                               REPEATED_ENSEMBLE, SORTED_ENSEMBLE,
                                               CUT_ENSEMBLE, LEADING_BYTES, STRAY_BYTES, TRAILING_BYTES,
                                               JOINED_RECORDING)
            if counts.get(key)]


def _warn_counts(counts: dict, source: str) -> None:
    refused = {k: v for k, v in counts.items() if k not in COUNT_NOTES and v}
    flagged = counts.get("flagged beams", 0)
    three = counts.get("3-beam solution", 0)
    if refused or flagged or three:
        warnings.warn(f"{source}: of {counts['read']} ping(s), {counts['valid']} give a velocity"
                      + (f" ({three} of them 3-beam solutions: a velocity without beams)" if three else "")
                      + "".join(f"; {v} {k}" for k, v in refused.items())
                      + (f"; {flagged} beam value(s) flagged -32768 (no lock) marked invalid" if flagged else ""),
                      RuntimeWarning, stacklevel=3)


@dataclass
class _Pings:
    """What the bottom track of one file gives per ping: beams (M,4) and their validity, the head's velocity
    ``v_d`` (M,3, NaN where none), RDI instrument-frame velocities ``inst`` (4,M), 3-beam flags, counts."""

    beams: np.ndarray
    beam_valid: np.ndarray
    v_d: np.ndarray
    inst: np.ndarray
    three_beam: np.ndarray
    counts: dict


def _beam_pings(vel: np.ndarray, u_d: np.ndarray) -> _Pings:
    """Beam-coordinate bottom track (4,M): beams as recorded, ``v_d`` by least squares over >= 3 valid beams on
    the beam vectors ``u_d`` (4,3) of the file's matrix."""
    bad = _flagged(vel)
    beam_valid = ~bad.T
    beams = np.where(beam_valid, vel.T, np.nan)
    n_valid = beam_valid.sum(axis=1)
    v_d = np.full((len(beams), 3), np.nan)
    for pattern in np.unique(beam_valid[n_valid >= 3], axis=0):
        rows = np.all(beam_valid == pattern, axis=1)
        v_d[rows] = np.linalg.lstsq(u_d[pattern], beams[rows][:, pattern].T, rcond=None)[0].T
    inst = np.vstack([(-v_d @ C_D_RDI).T, np.full((1, len(beams)), np.nan)])     # d -> RDI (C_D_RDI orthogonal)
    counts = {"flagged beams": int(bad.sum()), "no bottom lock": int((n_valid == 0).sum()),
              "fewer than 3 beams": int(((n_valid > 0) & (n_valid < 3)).sum()),
              "beams recovered": int((n_valid >= 3).sum())}
    return _Pings(beams, beam_valid, v_d, inst, n_valid == 3, counts)


def _rotated_pings(ds, vel: np.ndarray) -> _Pings:
    """Instrument/ship/earth bottom track (4,M: three components and the error velocity): back to RDI's
    instrument frame and, where all four are valid, to beams; a flagged error velocity with three valid
    components is a 3-beam solution (a velocity, no beams)."""
    bad = _flagged(vel)
    four = ~bad.any(axis=0)
    three_beam = ~bad[:3].any(axis=0) & bad[3]
    clean = np.where(bad, np.nan, vel)
    clean[3, three_beam] = 0.0         # RDI's 3-beam solution assumes a zero error velocity
    inst = instrument_velocity(ds, clean)
    beams = beams_from_instrument(ds, np.where(four, inst, np.nan)).T
    beam_valid = np.repeat(four[:, None], 4, axis=1) & np.all(np.isfinite(beams), axis=1, keepdims=True)
    v_d = np.where((four | three_beam)[:, None], -inst[:3].T @ C_D_RDI.T, np.nan)
    counts = {"no bottom lock": int((~(four | three_beam)).sum()), "3-beam solution": int(three_beam.sum()),
              "beams recovered": int(beam_valid.all(axis=1).sum())}
    return _Pings(np.where(beam_valid, beams, np.nan), beam_valid, v_d, inst, three_beam, counts)


def _dataset(path: Path, scan: Pd0Scan):
    """dolfyn's dataset of a PD0 file (corrupt ensembles and copies left out, ensembles out of order sorted, each
    with a warning); refuses a file whose ensembles cannot be put in time order, one of fewer than
    :data:`MIN_ENSEMBLES` ensembles and one without bottom track."""
    source = str(path)
    if scan.bad_checksum:
        warnings.warn(f"{source}: {scan.bad_checksum} ensemble(s) with a wrong checksum (corrupt) left out; "
                      f"{scan.ensembles} good ones read", RuntimeWarning, stacklevel=3)
    if scan.repeated:
        whole = scan.repeated - len(scan.cut_copies)
        how = ("identical byte for byte to an earlier one" if not scan.cut_copies else
               f"{whole} identical byte for byte to an earlier one, {len(scan.cut_copies)} cut short and the same as "
               "far as its bytes go" if whole else "cut short and the same as an earlier one as far as its bytes go")
        warnings.warn(f"{source}: {scan.repeated} ensemble(s) written twice ({how}: a logger's retry, or a file "
                      f"appended to itself) left out: {_copies_named(scan.copies)}; {scan.ensembles} read once"
                      + _cut_copies_named(scan.cut_copies), RuntimeWarning, stacklevel=3)
    change = _instrument_change(path.read_bytes(), scan)
    one_instrument = ("a DVL log is one instrument's (the first one's frame and beam geometry would be taken for the "
                      "pings of both)")
    if scan.unplaced:
        if change:          # two instruments' recordings joined: why their clocks and numbers disagree
            raise DataError(f"{change}; {one_instrument}", source)
        raise DataError(f"the ensembles cannot be put in time order: {scan.unplaced}", source, field="time")
    frame = "" if change else _frame_change(path.read_bytes(), scan)
    if frame:
        raise DataError(frame, source)
    if scan.moved:
        warnings.warn(f"{source}: {scan.moved} ensemble(s) stored out of time order ({scan.order_note}) sorted by "
                      "their own clock (the variable leader's), with which their ensemble numbers agree",
                      RuntimeWarning, stacklevel=3)
    if scan.ensembles < MIN_ENSEMBLES:
        raise DataError(f"only {scan.ensembles} complete ensemble(s) with a valid checksum"
                        + (f" ({', '.join(f'ensemble {n}' for n in scan.numbers)})" if scan.ensembles else "")
                        + f": too short to read; a PD0 file needs at least {MIN_ENSEMBLES} (dolfyn reads an "
                        "ensemble only when another follows it, and its ping rate from two)", source)
    if scan.stray:
        _warn_stray(scan, source)
    if scan.joins:
        if not change:           # two instruments' recordings are refused for that, below
            _refuse_far_joins(path.read_bytes(), scan, source)
        _warn_joins(scan, source)
    if scan.cut_short:
        _warn_cut_short(scan, source)
    try:
        if scan.bad_checksum or scan.repeated or scan.moved or scan.stray or scan.cut_short:
            ds = _read_good_ensembles(path, scan)
        else:
            ds = _read_rdi(path)
    except DataError as exc:
        if not change:
            raise
        raise DataError(f"{change}; dolfyn reads one instrument per file ({exc.message})", source) from None
    if change:          # dolfyn read them as one: the first one's frame, beams and geometry would be taken for all
        raise DataError(f"{change}; {one_instrument}", source)
    if "vel_bt" not in ds:
        raise DataError("no bottom track in the file (PD0 block 0x0600 absent): an ADCP current-profile "
                        "recording without bottom tracking gives no velocity over the seabed", source,
                        field="vel_bt")
    return ds


#: Bytes of the fixed leader (block 0x0000) that name the instrument: firmware version and revision, number of beams,
#: serial number (RDI P/N 951-6079-00); the rest (cells, orientation bits, ...) may change within one recording.
INSTRUMENT_BYTES = (2, 3, 8, 54, 55, 56, 57)


def _instrument_change(raw: bytes, scan: Pd0Scan) -> str:
    """Where the instrument (firmware, beams, serial: :data:`INSTRUMENT_BYTES` of the fixed leader) first changes
    between ensembles next in the file, said with what a user can do; "" when it never does: recordings of two
    instruments joined in one file, which dolfyn cannot read."""
    in_file = sorted(zip((a for a, _ in scan.spans), scan.numbers))
    for (a, n), (b, m) in zip(in_file, in_file[1:]):
        if _fixed_bytes(raw, a, INSTRUMENT_BYTES) != _fixed_bytes(raw, b, INSTRUMENT_BYTES):
            return (f"the instrument (firmware, beams or serial number of the fixed leader) changes from ensemble {n} "
                    f"(byte {a}) to ensemble {m} (byte {b}): recordings of two instruments joined in one file; load "
                    f"each from a file of its own (the bytes before {b} and from {b} on)")
    return ""


def _fixed_bytes(raw: bytes, start: int, which: tuple) -> bytes:
    """The bytes ``which`` (offsets) of the fixed leader of the ensemble at byte ``start``; b"" without one."""
    offsets = struct.unpack_from(f"<{raw[start + 5]}H", raw, start + 6)
    fixed = next((start + o for o in offsets if raw[start + o:start + o + 2] == b"\x00\x00"), None)
    return b"" if fixed is None else bytes(raw[fixed + i] for i in which if fixed + i < len(raw))


#: The fixed leader's byte of the EX command (coordinate transformation): bits 3-4 the frame of the velocities.
EX_BYTE = 25
#: The frame of each value of the EX bits 3-4 (RDI P/N 951-6079-00), graphnav's names (:attr:`DvlLog.frame`).
EX_FRAMES = ("beam", "instrument", "ship", "earth")


def _frame_change(raw: bytes, scan: Pd0Scan) -> str:
    """Where the frame of the velocities (the EX bits of the fixed leader) first changes between ensembles next in
    time (:attr:`Pd0Scan.spans`), said with what a user can do; "" when it never does: a second recording set up in
    another frame joined behind the first, which dolfyn would read in one frame."""
    def frame(start: int) -> str:
        ex = _fixed_bytes(raw, start, (EX_BYTE,))
        return EX_FRAMES[(ex[0] >> 3) & 3] if ex else ""
    for (a, _), (b, _), n, m in zip(scan.spans, scan.spans[1:], scan.numbers, scan.numbers[1:]):
        if frame(a) != frame(b):
            return (f"the frame of the velocities (EX bits of the fixed leader) changes from {frame(a)} in ensemble "
                    f"{n} (byte {a}) to {frame(b)} in ensemble {m} (byte {b}): recordings set up differently joined in "
                    f"one file, which dolfyn would read in one frame (the pings of one turned as the other's); load "
                    f"each from a file of its own (the bytes before {b} and from {b} on)")
    return ""


def _copies_named(copies: list) -> str:
    """The copies left out, ``(number, byte offset)`` in file order, as runs of consecutive ensemble numbers:
    "ensembles 1-262 (bytes 380081-757200)" for a file appended to itself, the first four runs."""
    runs: list[list] = []
    for number, start in copies:
        if runs and number == runs[-1][1] + 1:
            runs[-1][1], runs[-1][3] = number, start
        else:
            runs.append([number, number, start, start])
    said = [f"ensemble {a} (byte {s})" if a == b else f"ensembles {a}-{b} (bytes {s}-{e})" for a, b, s, e in runs[:4]]
    return ", ".join(said) + (f" and {len(runs) - 4} more run(s)" if len(runs) > 4 else "")


def _cut_copies_named(cut_copies: list) -> str:
    """What the warning on copies adds about the cut ones (:attr:`Pd0Scan.cut_copies`), the first two; "" for none."""
    said = [f"ensemble {n} (byte {s}) is cut short after {k} bytes by the next ensemble and "
            + (f"read whole from byte {w}" if w is not None else "the same as the one the file ends in, cut too")
            for n, s, k, w in cut_copies[:2]]
    more = f" and {len(cut_copies) - 2} more" if len(cut_copies) > 2 else ""
    return (f" ({'; '.join(said)}{more}: the cut end of a file with a copy of it joined behind, not a corrupt "
            "ensemble)") if said else ""


def read_pd0_log(path: str | Path, config: SensorConfig | None = None) -> DvlLog:
    """A PD0 file's bottom track as a :class:`~graphnav.core.dvl_log.DvlLog` (see the module docstring).

    ``counts`` (pings unless said): ``ensembles in file`` (complete, checksummed), ``read`` (by dolfyn),
    ``valid`` (a velocity ``v_d``), ``beams recovered`` (>= 3 beams for beam files, all four for rotated ones),
    ``no bottom lock``, ``fewer than 3 beams`` (beam files), ``3-beam solution`` (rotated files: velocity
    without beams), ``not read by dolfyn (last ensemble)``, ``flagged beams`` (beam values, beam files),
    ``bad pressure word`` and ``depth out of range`` (pressure readings), ``bad checksum (ensemble left out)``
    (corrupt ensembles, not part of ``read``), :data:`CUT_SHORT_ENSEMBLE` (cut short by the next ensemble, not part
    of ``read``), :data:`REPEATED_ENSEMBLE` (copies left out, not part of ``read``),
    :data:`SORTED_ENSEMBLE` (ensembles moved to their time, read),
    :data:`CUT_ENSEMBLE` (1 when the file ends inside an ensemble, not part of ``read``), :data:`LEADING_BYTES`
    (bytes before the first ensemble, skipped), :data:`STRAY_BYTES` (bytes between two, skipped). ``instrument``
    holds the fixed leader (model, frequency, beam angle and pattern, orientation, EX bits, serial, firmware),
    where the beam matrix came from and the geometry in ``d`` (``beam_theta_rad``, ``beam_psi_rad``). ``v_n`` of
    instrument, ship and beam files uses the stored heading as recorded (RDI's heading alignment ``EB`` and magnetic
    variation ``EV``, in ``instrument``, are applied by the instrument only to ship/earth outputs).

    Raises:
        DataError: not PD0 by content, unreadable, fewer than :data:`MIN_ENSEMBLES` ensembles, ensembles that cannot
            be put in time order, no bottom-track block (an ADCP profile file), or a stored beam matrix that is
            mirrored.
    """
    path = Path(path)
    source = str(path)
    config = config or SensorConfig()
    if not looks_like_pd0(path):
        raise DataError("not a PD0 file: no ensemble header 0x7F 0x7F with a valid checksum in the first "
                        f"{SNIFF_BYTES} bytes", source)
    scan = scan_pd0(path)
    ds = _dataset(path, scan)
    matrix_source = "nominal (beam angle and pattern)"
    if scan.beam_matrix is not None:
        ds["beam2inst_orientmat"] = ds["beam2inst_orientmat"].copy(data=scan.beam_matrix)
        matrix_source = "stored in the file (0x3200)"
    b2i = np.asarray(ds["beam2inst_orientmat"].values, float)
    theta, psi = rdi_geometry(b2i, source)

    t = _stamps(ds)
    vel = np.asarray(ds["vel_bt"].values, float)[:4]              # dolfyn: (dir, time)
    coord = str(ds.attrs.get("coord_sys", "beam")).lower()
    counts = {"ensembles in file": scan.ensembles, "read": len(t)}
    if scan.bad_checksum:
        counts["bad checksum (ensemble left out)"] = scan.bad_checksum
    if scan.repeated:
        counts[REPEATED_ENSEMBLE] = scan.repeated
    if scan.moved:
        counts[SORTED_ENSEMBLE] = scan.moved
    if scan.cut_short:
        counts[CUT_SHORT_ENSEMBLE] = len(scan.cut_short)
    if scan.stray:
        counts[STRAY_BYTES] = sum(n for _, n, _ in scan.stray)
    if scan.leading_bytes:
        counts[LEADING_BYTES] = scan.leading_bytes
        _warn_leading(scan, source)
    if scan.joins:
        counts[JOINED_RECORDING] = len(scan.joins)
    if scan.tail_bytes:
        counts[TRAILING_BYTES] = scan.tail_bytes
        _warn_trailing(scan, source)
    if scan.cut_bytes:
        counts[CUT_ENSEMBLE] = 1
        _warn_cut(scan, source)
    if scan.ensembles > len(t):
        counts["not read by dolfyn (last ensemble)"] = scan.ensembles - len(t)
    pings = _beam_pings(vel, rdi_beam_vectors_d(b2i)) if coord == "beam" else _rotated_pings(ds, vel)
    counts.update(pings.counts)
    v_d_valid = np.all(np.isfinite(pings.v_d), axis=1)
    counts["valid"] = int(v_d_valid.sum())
    if coord == "earth":
        enu = np.where(v_d_valid, np.where(_flagged(vel[:3]), np.nan, vel[:3]), np.nan)
    else:
        enu = earth_velocity(ds, np.where(v_d_valid, pings.inst, np.nan))
    v_n = -(C_NED_ENU @ enu).T                     # the seabed's velocity relative to the head, negated
    where = _ensemble_names(ds, scan)
    depth = _depth(ds, config, counts, source, where)
    _warn_counts(counts, source)
    attitude = np.stack([np.asarray(ds[k].values, float) for k in ("heading", "pitch", "roll")], axis=1)
    instrument = _instrument(ds, scan, matrix_source)
    instrument.update(beam_theta_rad=theta, beam_psi_rad=psi.tolist())
    return DvlLog(t=t, v_d=pings.v_d, v_d_valid=v_d_valid, frame=FRAME_NAMES.get(coord, coord), beams=pings.beams,
                  beam_valid=pings.beam_valid, attitude_deg=attitude, depth_m=depth,
                  v_n=np.where(v_d_valid[:, None], v_n, np.nan), three_beam=pings.three_beam & v_d_valid,
                  instrument=instrument, counts=counts, source=source, where=where)


def _ensemble_names(ds, scan: Pd0Scan) -> list[str]:
    """Each ping's ensemble number (the variable leader's, as the scan read it: dolfyn counts the high byte as
    65535) and byte offset in the file, for messages: dolfyn's pings are the scan's ensembles (``spans``, in time
    order)."""
    return [f"ensemble {n} (byte {start})" for n, (start, _) in zip(scan.numbers[:len(ds["time"])], scan.spans)]


def read_pd0(path: str | Path, config: SensorConfig | None = None) -> tuple[DvlData, DepthData | None, dict]:
    """Bottom-track beams (Unix-second stamps), the DVL-frame velocity of the pings whose beams cannot be
    used (3-beam solutions), and the pressure depth of a PD0 file in any RDI frame; also a dict of metadata
    (``pd0_*`` keys, ``streams``: what was read and refused, :mod:`graphnav.core.streams`). Pings that share a time
    are spread within their clock's tick (:func:`spread_shared_times`; the stream's ``doubted``
    :data:`SPREAD_TIME`), those of a clock that stood still up to its next time (:data:`STALLED_TIME`)."""
    from graphnav.core.streams import add_note, count_read, count_refused, say_doubted
    config = config or SensorConfig()
    log = read_pd0_log(path, config)
    source = log.source
    spread, notes = with_spread_times(log)
    t = spread.t
    beams_ok = log.beam_valid.sum(axis=1) >= 3
    v_d_used = log.v_d_valid & ~beams_ok              # beams win where they exist: one measurement per ping
    dvl = DvlData(t, np.where(log.beam_valid, log.beams, np.nan), log.beam_valid.copy(), None,
                  f"{source}:vel_bt", v_d=np.where(v_d_used[:, None], log.v_d, np.nan), v_d_valid=v_d_used)
    meta: dict = {"pd0_beam_angle_deg": log.instrument["beam_angle_deg"],
                  "pd0_beam_pattern": log.instrument["beam_pattern"],
                  "pd0_beam_theta_rad": log.instrument["beam_theta_rad"],
                  "pd0_beam_psi_rad": log.instrument["beam_psi_rad"],
                  "pd0_frame": log.frame, "pd0_invalid_beams": int((~log.beam_valid).sum()),
                  "dvl_resolution_mps": 0.001,     # whole mm/s in any frame: beams rotated back are off that grid
                  "pd0_ensembles": len(log), "pd0_instrument": log.instrument["model"], "pd0_counts": log.counts,
                  "dvl_ping_where": log.where}
    entry = count_read(meta, "dvl", t, f"{source}:vel_bt")
    for text, reason, n in notes:
        say_doubted(meta, "dvl", source, text, reason, n, stacklevel=3)
    unread = log.counts.get("not read by dolfyn (last ensemble)", 0)
    entry["read"] += unread              # in the file, so read; then refused with its reason
    entry["used"] += unread
    # pings with 1-2 valid beams are used (the graph and the tightly coupled EKF take single beams)
    for reason in ("no bottom lock", "not read by dolfyn (last ensemble)"):
        count_refused(meta, "dvl", reason, log.counts.get(reason, 0))
    for note in left_out_notes(log.counts):
        add_note(meta, "dvl", note)
    if log.counts.get("fewer than 3 beams"):
        add_note(meta, "dvl", f"{log.counts['fewer than 3 beams']} ping(s) with 1-2 valid beams: the beams are used, "
                              "no velocity can be solved from them")
    if log.frame != "beam":
        add_note(meta, "dvl", f"bottom track recorded in {log.frame} coordinates: "
                 f"{log.counts['beams recovered']} ping(s) rotated back to beams with the instrument's own "
                 f"attitude (dolfyn's rotations)")
    if v_d_used.any():
        add_note(meta, "dvl", f"{int(v_d_used.sum())} 3-beam solution(s) used as DVL-frame velocities (their "
                 "beams cannot be recovered)")
    depth = None
    if log.depth_m is not None:
        ok = np.isfinite(log.depth_m)
        count_read(meta, "depth", t, f"{source}:pressure")
        for reason in ("bad pressure word", "depth out of range"):
            count_refused(meta, "depth", reason, log.counts.get(reason, 0))
        if ok.any():
            depth = DepthData(t[ok], log.depth_m[ok], f"{source}:pressure")
            meta["depth_where"] = [log.where[i] for i in np.flatnonzero(ok)]
    return dvl, depth, meta


#: The ``doubted`` reason (:mod:`graphnav.core.streams`) of the pings whose stamp :func:`spread_shared_times` moved.
SPREAD_TIME = "ensemble time shared with the ping before (stamp spread after it)"


#: The ``doubted`` reason of the pings whose stamp :func:`spread_shared_times` moved because their clock stood still.
STALLED_TIME = "DVL clock stood still (stamp spread up to its next time)"


#: The tick of a clock whose every time is a whole second (its hundredths zero): the true time of a ping it stamps
#: lies in the second after.
WHOLE_SECOND_TICK_S = 1.0


def spread_shared_times(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stamps ``t`` (Unix s, in time order) with the pings that share one time spread after the first of them, and
    which were moved: an instrument pinging faster than its clock ticks (a clock of whole seconds, one that repeats
    a time) gives several ensembles one time, which a mission's DVL stream (one stamp per ping) cannot hold. The
    ``k`` pings at a time ``T`` are put ``min(T' - T, tick) / k`` apart from ``T`` in ensemble order, ``T'`` the next
    time and ``tick`` the clock's: the median step between its distinct times, at most the second a clock of whole
    seconds vouches for (pings in bursts would otherwise be spread over the pause between bursts) or 2 s for one
    stepping by 2 s (:func:`_clock_resolution`), RDI's 0.01 s when it gives one time only. A gap after them is not
    spread over. Pings of a clock that stood still (:func:`_stalled_groups`) are put ``min((T' - T) / k, period)``
    apart instead: they were taken at the ping period up to the time the clock jumped to, and after its last time at
    the period (dead-reckoned); those of a stall across the pause between bursts are put after it
    (:func:`_after_pauses`)."""
    spread, moved, _, _ = _spread(t)
    return spread, moved


def _spread(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """:func:`spread_shared_times`' stamps and pings moved, (M,) bool the pings moved because the clock stood still
    (:func:`_stalled_groups`), and the ping period they were spread at (s, NaN when none), of stamps ``t`` (s, in
    time order)."""
    t = np.asarray(t, float)
    if len(t) < 2 or np.all(np.diff(t) > 0):
        return t, np.zeros(len(t), bool), np.zeros(len(t), bool), float("nan")
    starts, sizes, room = _time_groups(t)
    resolution = _clock_resolution(t[starts])
    tick = float(np.median(room[:-1])) if len(starts) > 1 else 0.01
    if resolution >= WHOLE_SECOND_TICK_S:
        tick = min(tick, resolution)
    step = np.minimum(room, tick) / sizes
    stalled, period = _stalled_groups(sizes, room, resolution)
    step[stalled] = np.minimum(room[stalled] / sizes[stalled], period)
    rank = np.arange(len(t)) - np.repeat(starts, sizes)
    spread = _after_pauses(t, t + rank * np.repeat(step, sizes), (starts, sizes, room), stalled, period)
    return spread, rank > 0, np.repeat(stalled, sizes) & (rank > 0), period


#: A step of a clock that runs longer than this many ping periods is a pause between bursts of pings.
PAUSE_PERIODS = 2.0


def _after_pauses(t: np.ndarray, spread: np.ndarray, groups: tuple, stalled: np.ndarray, period: float
                  ) -> np.ndarray:
    """``spread`` (s) with the pings of a clock that stood still across the pause between two bursts put after it:
    on an instrument pinging in bursts of ``n`` (the pings between the pauses where the clock ran, the same number
    each time), the stall's pings from the next burst on are taken at the ``period`` (s) up to the time the clock
    jumped to, instead of on from its stalled time (which put the next burst's first ping a pause early); bursts of
    irregular size that start at a fixed interval are placed by it (:func:`_after_pause_by_cycle`). ``groups``
    are :func:`_time_groups`' runs, ``stalled`` which stood still (:func:`_stalled_groups`)."""
    starts, sizes, room = groups
    if not stalled.any() or not np.isfinite(period):
        return spread
    paused = ~stalled & (sizes == 1) & np.isfinite(room) & (room > PAUSE_PERIODS * period)
    pauses = starts[paused]
    if len(pauses) < 2:
        return spread
    burst = int(np.min(np.diff(pauses)))
    if burst < 2 or np.any(np.diff(pauses) % burst):
        return _after_pause_by_cycle(t, spread, groups, stalled, period, pauses)
    pause_s = float(np.median(room[paused]))       # from a burst's last ping to the next one's first
    spread = spread.copy()
    for g in np.flatnonzero(stalled & (room > (sizes + PAUSE_PERIODS) * period)):
        first, end = starts[g], starts[g] + sizes[g]
        before = pauses[pauses < first]
        if not len(before):
            continue
        pause = before[-1] + burst * int(np.ceil((first - before[-1]) / burst))      # the last ping of its burst
        if pause < end - 1:
            after = np.arange(pause + 1, end)
            ends = np.arange(pause, end, burst)          # the last pings of the bursts it stood across
            if np.isfinite(room[g]):                     # back from the jump over the pauses still ahead of each
                ahead = np.sum(ends[None, :] >= after[:, None], axis=1)
                spread[after] = t[first] + room[g] - (end - after) * period - ahead * (pause_s - period)
            else:                                        # never ran on: on from its time over the pauses behind each
                behind = np.sum(ends[None, :] < after[:, None], axis=1)
                spread[after] = t[first] + (after - first) * period + behind * (pause_s - period)
    return spread


def _burst_cycle(t: np.ndarray, pauses: np.ndarray, period: float) -> float:
    """The time (s) from one burst's first ping to the next one's of pings in bursts of irregular size (``pauses``:
    the index of each burst's last ping, its clock running; ``t`` s) when the bursts start at a fixed interval (each
    step between the first pings of bursts a whole number of the shortest, within half a ``period`` s); NaN when
    fewer than three bursts start after a pause or they start irregularly too."""
    firsts = t[pauses + 1]
    steps = np.diff(firsts)
    if len(steps) < 2:
        return float("nan")
    cycle = float(np.min(steps))
    whole = np.round(steps / cycle)
    if cycle <= 0 or np.any(np.abs(steps - whole * cycle) > 0.5 * period):
        return float("nan")
    return float(np.sum(steps) / np.sum(whole))


def _after_pause_by_cycle(t: np.ndarray, spread: np.ndarray, groups: tuple, stalled: np.ndarray, period: float,
                          pauses: np.ndarray) -> np.ndarray:
    """:func:`_after_pauses` for bursts of irregular size that start at a fixed interval (:func:`_burst_cycle`): the
    pings of a stall that the clock jumped out of inside a burst, from that burst's start (the last burst start
    before the jump, a whole number of intervals after one the clock gave) up to the jump, are that burst's first
    pings, at the ``period``; the others stay on from the stalled time. Only a stall across one pause is placed so:
    how many pings of the bursts between two pauses it stood across cannot be told (said by :func:`_stall_note`)."""
    starts, sizes, room = groups
    cycle = _burst_cycle(t, pauses, period)
    if not np.isfinite(cycle):
        return spread
    spread = spread.copy()
    for g in np.flatnonzero(stalled & np.isfinite(room) & (room > (sizes + PAUSE_PERIODS) * period)):
        first, end = starts[g], starts[g] + sizes[g]
        known = t[pauses + 1][pauses + 1 <= first]
        if not len(known):
            continue
        jump = t[first] + room[g]
        start = known[-1] + cycle * np.floor((jump - known[-1]) / cycle + 1e-9)     # of the burst the jump is in
        after = int(np.round((jump - start) / period))
        if start <= t[first] + (sizes[g] - after - 1) * period or not 0 < after < sizes[g]:
            continue                         # no pause between the stalled time and the jump, or none of it after
        if start - cycle > t[first] + 0.5 * period:
            continue                         # a burst start between: it stood across several pauses (said)
        spread[end - after:end] = start + period * np.arange(after)
    return spread


#: The tick of a clock whose every time is an even second and whose times step by 2 s (DOS/FAT time, which a
#: logger's file system keeps to 2 s): the true time of a ping it stamps lies in the 2 s after.
EVEN_SECOND_TICK_S = 2.0


def _clock_resolution(times: np.ndarray) -> float:
    """What a clock's distinct ``times`` (Unix s, increasing) vouch for, s: RDI's 0.01 s, a second for a clock of whole
    seconds (hundredths zero), :data:`EVEN_SECOND_TICK_S` for one whose steps are all whole multiples of 2 s and no
    coarser (a clock of whole seconds in bursts at a fixed interval steps by the interval: it keeps the second)."""
    if not np.all(times == np.round(times)):
        return 0.01
    steps = np.round(np.diff(times)).astype(np.int64)
    return EVEN_SECOND_TICK_S if len(steps) and np.gcd.reduce(steps) == EVEN_SECOND_TICK_S else WHOLE_SECOND_TICK_S


def _time_groups(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The runs of one time in stamps ``t`` (s, in time order): their first index, size and the time to the next
    run's (inf after the last)."""
    starts = np.flatnonzero(np.r_[True, np.diff(t) != 0])
    return starts, np.diff(np.r_[starts, len(t)]), np.diff(np.r_[t[starts], np.inf])


#: A run of pings sharing one time is a stalled clock when it holds more pings than the clock's resolution can
#: at the ping period, by this many periods or more: half a period keeps the pairs a clock of whole seconds gives
#: an instrument pinging a little faster than 1 Hz.
STALL_MARGIN_PERIODS = 0.5


#: More pings than a DVL takes within one tick of its clock (2 s at most; DVLs ping at up to about 10 Hz): when
#: every ping of a log carries one time, its clock did not run; a run of more at one time is a clock that stood still.
FROZEN_CLOCK_PINGS = 20


def _own_times(sizes: np.ndarray) -> bool:
    """Whether a clock gives most pings a time of their own: at least half of its runs of one time (their ``sizes``,
    :func:`_time_groups`) but the last single, of three runs or more."""
    single = (sizes == 1)[:-1]
    return len(sizes) >= 3 and single.sum() >= 0.5 * len(single)


def _stalled_groups(sizes: np.ndarray, room: np.ndarray, resolution: float) -> tuple[np.ndarray, float]:
    """Which runs of one time (:func:`_time_groups`: their sizes and the time to the next run's, s) are a clock that
    stood still, and the ping period (s), on a clock of ``resolution`` s (:func:`_clock_resolution`). A clock that
    gives most pings a time of their own (at least half of the runs single) measures the ping period (the median
    step after a single ping); a run of ``k`` pings at one time on it could only have been taken within the clock's
    resolution if ``(k - 1)`` periods fit in it: more, by :data:`STALL_MARGIN_PERIODS`, and the clock stood still
    while the instrument pinged on. On any clock a run of more than :data:`FROZEN_CLOCK_PINGS` pings stood still; on
    a clock that then measures no period it is the time its stalls end in a tick per ping (the clock stood still,
    then jumped on to the right time), else the time per ping of its other runs. A run of two or more that a tick
    cannot hold ((k - 1) periods reach the resolution: 0.5 Hz pings on a clock of whole seconds, one of which repeats
    a time) after which the clock ran on as long as its pings take at the period (within
    :data:`STALL_MARGIN_PERIODS`) stood still too: the clock jumped on to the right time. On a clock slower than the
    pings (most runs shared) that ticks on one tick at a time, the pings its ticks hold measure the period
    (:func:`_tick_period`: 4 Hz pings on a clock of whole seconds, 4 a tick) and a run of more than a tick holds
    stood still as above; on one that steps further (pings in bursts) the shared times are its ticks."""
    stalled, period = np.zeros(len(sizes), bool), float("nan")
    if _own_times(sizes):
        steps = room[:-1][(sizes == 1)[:-1]]
        period = float(np.median(steps))
        if resolution >= WHOLE_SECOND_TICK_S:       # its steps are the period rounded to its tick: their mean is it
            period = float(np.mean(steps[steps <= period + resolution]))         # (gaps left out)
        stalled = ((sizes - 1 - STALL_MARGIN_PERIODS) * period > resolution) | (
            (sizes > 1) & ((sizes - 1) * period >= resolution - 1e-6) & np.isfinite(room)
            & (room >= (sizes - STALL_MARGIN_PERIODS) * period))
    else:
        period = _tick_period(sizes, room, resolution)
        if np.isfinite(period):
            stalled = (sizes - 1 - STALL_MARGIN_PERIODS) * period > resolution
    frozen = sizes > FROZEN_CLOCK_PINGS
    if not frozen.any() or np.isfinite(period):
        return stalled | frozen, period
    for runs in (frozen & np.isfinite(room), ~frozen & np.isfinite(room)):
        if runs.any():
            return stalled | frozen, float(room[runs].sum() / sizes[runs].sum())
    return stalled, period


#: Runs of pings between a clock's first and last that it ticked once after, fewest to measure a ping period by.
TICKED_RUNS = 3


def _tick_period(sizes: np.ndarray, room: np.ndarray, resolution: float) -> float:
    """The ping period (s) of a clock of whole seconds (or 2 s) slower than the pings that ticks on one tick at a time
    (its usual step, the median of ``room``, is its ``resolution``): the time per ping of the runs of one time
    (:func:`_time_groups`' ``sizes``, ``room`` s) after which it ticked once, but the first and last (which may hold
    part of a tick); NaN with fewer than :data:`TICKED_RUNS` such runs, or on a clock whose usual step is longer
    (pings in bursts: how fast they came within a burst its times cannot tell)."""
    inner, steps = sizes[1:-1], room[1:-1]
    ticked = np.isclose(steps, resolution)
    if resolution < WHOLE_SECOND_TICK_S or ticked.sum() < TICKED_RUNS or not np.isclose(np.median(steps), resolution):
        return float("nan")
    return float(steps[ticked].sum() / inner[ticked].sum())


def with_spread_times(log: DvlLog) -> tuple[DvlLog, list[tuple[str, str, int]]]:
    """``log`` with the pings that share a time spread (:func:`spread_shared_times`), and what to say about them:
    ``(note, doubted reason, pings)`` for the pings of a clock that stood still (:data:`STALLED_TIME`) and for the
    others moved (:data:`SPREAD_TIME`), each when there are any. A mission's DVL stream and a dead reckoning need
    one stamp per ping. A log whose stamps run back (a CSV out of time order) is left as it is: what is shared there
    cannot be told.

    Raises:
        DataError: more than :data:`FROZEN_CLOCK_PINGS` pings all carry one time: the clock did not run, and
            spreading them within a tick would put a whole recording into 0.01 s."""
    if np.any(np.diff(np.asarray(log.t, float)) < 0):
        return log, []
    if len(log.t) > FROZEN_CLOCK_PINGS and np.all(log.t == log.t[0]):
        raise DataError(f"all {len(log.t)} pings carry one time ({_utc(log.t[0])}): the DVL's clock did not run (not "
                        "set, or stopped), so when each ping was taken cannot be told; give each ping its time (a CSV "
                        "of DVL velocities: t, vx, vy, vz)", log.source, field="time")
    t, moved, stalled, period = _spread(log.t)
    where = log.where or [f"ping {k}" for k in range(len(t))]
    notes = [(_stall_note(log.t, t, stalled, where, period), STALLED_TIME, int(stalled.sum()))] if stalled.any() else []
    if (moved & ~stalled).any():
        notes.append((_spread_note(log.t, t, moved & ~stalled, where), SPREAD_TIME, int((moved & ~stalled).sum())))
    return (dataclasses.replace(log, t=t) if moved.any() else log), notes


def _spread_note(t: np.ndarray, spread: np.ndarray, moved: np.ndarray, where: list[str]) -> str:
    """The note on the pings :func:`spread_shared_times` moved within their clock's tick."""
    first = int(np.flatnonzero(moved)[0])
    return (f"{int(moved.sum())} of {len(t)} ping(s) share their ensemble's time (the variable leader's clock) with "
            f"the ping before (a clock that ticks slower than the instrument pings, or repeats a time): spread after "
            f"it in ensemble order within the clock's tick, at most {np.max((spread - t)[moved]):.3f} s after the "
            f"time recorded, first {where[first]} at {_utc(t[first])}; the DVL's own clock cannot tell these times "
            "better")


def _stall_note(t: np.ndarray, spread: np.ndarray, stalled: np.ndarray, where: list[str], period: float) -> str:
    """The note on the pings of a clock that stood still (:func:`_stalled_groups`), spread up to its jump at the ping
    ``period`` (s) at most, and dead-reckoned at it after the clock's last time when the clock never ran on."""
    first = int(np.flatnonzero(stalled)[0])
    head = int(np.flatnonzero(t == t[first])[0])
    run = int(np.sum(t == t[first]))
    nxt = t[t > t[first]]
    jump = f"then jumped {nxt[0] - t[first]:.2f} s" if len(nxt) else "to the end of the file"
    runs = int(np.sum(stalled[1:] & ~stalled[:-1]) + stalled[0])
    starts, sizes, room = _time_groups(t)
    own = _own_times(sizes)
    ticked = not own and np.isfinite(_tick_period(sizes, room, _clock_resolution(t[starts])))
    rank = np.arange(len(t)) - np.repeat(starts, sizes)
    after = stalled & (spread - t > rank * period + 1e-6)
    paused = int(np.sum(after))
    tail = (f"; {paused} of them after the pause between bursts it stood still across, put after each pause it stood "
            "across (as long as the clock's other pauses, or at the bursts' interval) at the ping period"
            ) if paused else ""
    tail += _unplaced_note(t, (starts, sizes, room), stalled, after, period)
    if stalled[-1]:
        tail += (f"; after its last time ({_utc(t[-1])}) it never ran on: those {int(np.sum(t == t[-1]))} pings are "
                f"dead-reckoned at the ping period ({period:.3f} s, "
                f"{'its steps' if own else 'its ticks' if ticked else 'what its stalls ended in'}), not squeezed into "
                "its tick")
    lost = (np.add.reduceat(stalled, starts) > 0) & (room < (sizes - 1 - STALL_MARGIN_PERIODS) * period)
    if lost.any():          # the clock ran on from where it stood, not from the right time: it lost the stall
        g = int(np.flatnonzero(lost)[0])
        need_s = sizes[g] * period
        tail += (f"; after the {sizes[g]} pings at {_utc(t[starts[g]])} it ran on only {room[g]:.2f} s where they take "
                 f"{need_s:.1f} s at the ping period: the clock lost about {need_s - room[g]:.1f} s "
                 "there (it ran on from where it stood), so those pings are squeezed into that step and every time "
                 "after it is that much early" + (f" ({int(lost.sum())} such stall(s))" if lost.sum() > 1 else "")
                 + "; give the pings their times if another clock has them (a CSV of DVL velocities: t, vx, vy, vz)")
    return (f"the DVL's clock stood still: {run} pings from {where[head]} share its time {_utc(t[first])}, "
            f"{jump}, " + ("while elsewhere it gives each ping a time of its own" if own else
                           f"more pings than its other ticks hold (a ping every {period:.3f} s)" if ticked else
                           "more pings than a DVL takes within one tick of its clock")
            + (f" ({runs} such stall(s), {int(stalled.sum())} ping(s) in all)" if runs > 1 else "")
            + ": spread evenly up to the next time at the ping period at most, at most "
            f"{np.max((spread - t)[stalled]):.3f} s after the time recorded{tail}; their times are a guess")


def _unplaced_note(t: np.ndarray, groups: tuple, stalled: np.ndarray, after: np.ndarray, period: float) -> str:
    """What :func:`_stall_note` says of the stalls of a clock pinging in bursts that stood across a pause (the clock
    jumped further than their pings take at the ``period`` s) but none of whose pings :func:`_after_pauses` could put
    after it (bursts of irregular size at no fixed interval, or several pauses stood across): where the pause falls
    among their pings cannot be told, so those after it are early; "" when there are none. ``groups`` are
    :func:`_time_groups`' runs, ``stalled`` and ``after`` (M,) the pings stalled and put after a pause."""
    starts, sizes, room = groups
    held = np.add.reduceat(stalled, starts) > 0
    bursts = np.sum(~held & (sizes == 1) & np.isfinite(room) & (room > PAUSE_PERIODS * period)) >= 2
    placed = np.add.reduceat(after, starts) > 0
    across = held & ~placed & np.isfinite(room) & (room > (sizes + PAUSE_PERIODS) * period)
    if not bursts or not across.any():
        return ""
    g = int(np.flatnonzero(across)[0])
    early = room[g] - sizes[g] * period
    return (f"; the {sizes[g]} pings at {_utc(t[starts[g]])} stood across a pause between bursts (the clock jumped "
            f"{room[g]:.2f} s, {early:.1f} s more than they take at the ping period)"
            + (f" ({int(across.sum())} such stall(s))" if across.sum() > 1 else "")
            + ": which of them came after the pause cannot be told from bursts of irregular size, so they are put on "
            f"from its time and those after the pause are up to {early:.1f} s early")


def pd0_geometry(config: SensorConfig, meta: dict) -> SensorConfig:
    """A copy of ``config`` with the beam inclination and azimuths (in ``d``) of the PD0 file's beam matrix."""
    theta = meta.get("pd0_beam_theta_rad")
    if theta is None or not np.isfinite(theta) or theta <= 0:
        return config
    dvl = dataclasses.replace(config.dvl, theta_rad=float(theta), psi_rad=np.asarray(meta["pd0_beam_psi_rad"]))
    return dataclasses.replace(config, dvl=dvl)


def gps_fixes(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The GPS fixes a PD0 file carries (WinRiver/VmDAS NMEA blocks, as dolfyn reads them): ``(t Unix s,
    lat rad, lon rad)`` of the finite fixes; empty arrays when the file has none."""
    ds = _read_rdi(Path(path))
    if "latitude_gps" not in ds:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    lat, lon = (np.radians(np.asarray(ds[k].values, float)) for k in ("latitude_gps", "longitude_gps"))
    t = ds["time_gps"].values.astype("datetime64[ns]").astype(np.int64) / 1e9
    ok = np.isfinite(lat) & np.isfinite(lon)
    return t[ok], lat[ok], lon[ok]

