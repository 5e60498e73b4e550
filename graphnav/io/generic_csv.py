"""A team's own CSV logs, loaded without code through a column map in the SensorConfig JSON.

The map is ``csv_columns`` of the configuration; one entry per stream (``imu`` and ``dvl`` required,
``depth`` and ``gt`` optional), each naming its file (relative to the data folder; omitted = the data file
itself, for one merged log whose rows leave the other sensors' cells empty), its stamp column and its value
columns::

    "csv_columns": {
      "time_unit": "s",
      "imu":   {"file": "imu.csv", "t": "stamp", "f_b": ["ax", "ay", "az"], "omega_b": ["gx", "gy", "gz"],
                "accel_unit": "m/s^2", "gyro_unit": "deg/s", "frame": "frd"},
      "dvl":   {"file": "dvl.csv", "t": "stamp", "beams": ["b1", "b2", "b3", "b4"], "valid": ["ok1", "ok2", "ok3", "ok4"],
                "v_b": ["vx", "vy", "vz"], "velocity_unit": "mm/s"},
      "depth": {"file": "depth.csv", "t": "stamp", "pressure": "p", "pressure_unit": "dbar"},
      "gt":    {"file": "nav.csv", "t": "stamp", "p_n": ["n", "e", "d"], "v_n": ["vn", "ve", "vd"],
                "euler": ["roll", "pitch", "yaw"], "angle_unit": "deg", "velocity_sigma": [0.007, 0.007, 0.002]}
    }

``velocity_sigma`` (optional) is the reference's own velocity error, m/s north, east, down (``graphnav calibrate``
prints an upper bound of it): the printed velocity NEES is then also given with it added to the estimate's
covariance, since a DVL-aided estimate can be as good as the reference it is scored against.

Units: ``time_unit`` s / ms / us / ns (global or per stream); ``accel_unit`` m/s^2 or g; ``gyro_unit`` rad/s
or deg/s; ``velocity_unit`` m/s, cm/s, mm/s or kn. A unit left out is detected from the data
(:mod:`graphnav.io.units`: stamps from the sample step, g from |f|, deg/s from the rates, mm/s from the
speeds), converted with a warning and noted in ``meta["streams"]``; a declared unit the data contradict is
a DataError; ``pressure_unit`` Pa, kPa, bar or dbar (absolute Pa minus
``atmospheric_pressure_pa``; bar/dbar taken as gauge, as DVL/CTD pressure sensors report), or ``depth`` in m
(positive down; ``"positive": "up"`` declares a depth positive up, negated on reading, as ``bag_topics.depth.positive``
does for a bag's depth topic; a declared convention the
data contradict is a DataError, an undeclared positive-up depth above the surface is turned with a warning);
``angle_unit`` rad or deg (left out: detected from the attitude's turn rate against the gyro, converted with a
warning when degrees). The reference's north/east must move with its ``v_n`` and its down change
with its down velocity (a DataError naming the columns otherwise; its down may be relative or absolute).
``frame`` frd or flu for the IMU (the latter negates y and z), or auto; the prepare step checks the axes against
the data (the GT attitude, or gravity and the tilt kinematics): data that contradict a declared frd or flu are a
DataError naming the columns; without ``frame`` or with ``auto`` FRD is taken and corrected from the data (a warning).
A key a stream does not accept
(:data:`graphnav.core.config.CSV_COLUMN_KEYS`, e.g. a misspelt ``velocity_units``) is a ConfigError naming the
configuration file, the stream and the key, with the closest accepted one.

Files: leading ``#`` comment lines are skipped; the separator is the one of ``,`` ``;`` tab the header line uses
most, or a stream's ``delimiter``; in a ``;`` or tab separated file a number with one decimal comma (``0,25``) is
read as ``0.25`` (each noted in the stream's notes); a row with more non-empty cells than the header that a decimal
comma explains (``0,25`` in a comma-separated file is two cells) is a DataError naming its lines, since its values
would be read under other columns; a quoted one there (``"0,25"``, one cell) is a DataError naming its line with the
same advice (``"1,250"`` may be 1250 written with a thousands separator); cells past the header no decimal comma
explains (a column a logger appends without naming it, a separator inside a note) are not read, and their rows are
warned about with their lines and counted.

DVL: ``beams`` (along-beam velocities of the head) with optional ``valid`` flag columns (non-zero = valid;
without them every finite beam is valid; RDI's -32768 / -32.768 flags are invalid), or only ``v_b`` (a DVL
that logs body velocity): the beams are then the exact projections ``T_b v_b`` of that velocity on the
configured beam geometry (no noise added; ``meta["beams_from_v_b"]``), and a ping with any non-finite axis
has no valid beam. The ``valid`` flags apply to ``v_b`` too (a velocity needs three valid beams); a ping whose
velocity (or four beams) is exactly 0 on every axis has no bottom lock, and is refused (warned with its lines,
counted), when the file's other values are finer than 1 mm/s or the pings around it are under way
(:func:`graphnav.core.screening.no_bottom_lock`); a hovering vehicle's zeros in a log at 1 mm/s are kept.
``frame`` says which frame the ``v_b`` columns are in: body (default), flu, instrument (turned by ``dvl.C_d_b``),
ned or enu (with the DVL's ``euler`` roll, pitch, heading columns and their ``angle_unit``); an
undeclared earth-frame, knots or FLU velocity is refused (:mod:`graphnav.io.dvl_frame`,
:mod:`graphnav.calibration.dvl_scale`), and so is a velocity with its y negated (or an IMU mirrored) where the
vehicle's sideways velocity changes enough to show it (a current, a lever arm, sideslip in turns); a declared
vehicle frame the earth-frame checks contradict is kept, warned about and counted; a declared earth frame is checked
turned to body by its attitude columns: columns in the vehicle's frame, which the attitude then turns with the vehicle,
are refused naming the key and ``body`` where the body kinematics say so clearly, else kept, warned about and
counted. Instead of CSV columns, ``"dvl": {"pd0": "file.000"}`` reads a
Teledyne PD0 file (:mod:`graphnav.io.pd0`) recorded in any RDI frame (beam, instrument, ship or earth: rotated back to
beams; 3-beam solutions become ``DvlData.v_d``), whose stamps are Unix seconds: the IMU stamps must then be Unix too;
what the file read and refused is in ``meta["streams"]``.

Every stream ends on one clock starting at the first IMU stamp (``meta["t0_s"]`` keeps the offset). The DVL
may run on a clock of its own (seconds or days away): with ``"dvl": {"clock": "auto"}`` (default) its offset
is estimated from the data and applied when the mission is prepared (:func:`graphnav.calibration.preparation.prepare`
through :func:`graphnav.calibration.clock.align_stream_clocks`, noted in ``meta["streams"]["dvl"]`` and
``meta["clock_offsets"]``); ``"clock": "imu"`` declares the DVL stamps on the
IMU clock already (refused where the data put them clearly elsewhere,
:func:`graphnav.calibration.preparation._check_declared_clock`).
Bad input is reported with the file, the 1-based line and the column (:class:`graphnav.core.errors.DataError`).
An IMU, depth or reference row with an empty, NaN or infinite cell is refused (counted, warned with its line and
column), as are reference rows whose velocity the vehicle cannot have or whose position jumps where its velocity
does not, before the reference's unit and sign checks; an
infinite DVL value is a beam that is not a measurement. A row written twice exactly, or again under half a step
later with the same values, is dropped (counted, warned);
a stamp on two different rows, or going back, is a DataError unless ``repair`` (``--repair-stamps``) drops the later
row and sorts the rest (counted, warned), as for an A-KIT folder.
"""
from __future__ import annotations

import csv
import dataclasses
import re
from collections import Counter
from pathlib import Path

import numpy as np

from graphnav.core.config import SensorConfig, check_column_map
from graphnav.core.dvl import no_lock_pings, ping_velocity_b
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.imu_timing import shown_rate_hz
from graphnav.core.mission import DepthData, DvlData, GroundTruth, ImuData, Mission
from graphnav.core.screening import (
    NO_BOTTOM_LOCK,
    gt_refusals,
    imu_implausible,
    imu_unmeasured,
    not_finite,
    on_resolution_grid,
    refuse_rows,
    refuse_zeroed_filler,
    stamp_order,
    unit_check_rows,
    warn_no_bottom_lock,
    with_position_spikes,
    zero_pings,
    zeroed_filler,
    zeroed_stamps_error,
)
from graphnav.core.streams import add_note, count_read, count_refused, say_doubted
from graphnav.io.dvl_frame import columns_to_body
from graphnav.io.pd0 import pd0_geometry, read_pd0
from graphnav.io.units import (ANGLE_UNITS, DECLARED_UNITS, check_declared_time_span, check_stamp_bound,
                               declared_scale, dvl_values_in_mps, dvl_velocity_units, imu_units, say_mmps,
                               stamps_in_seconds)

TIME_UNITS, ACCEL_UNITS, GYRO_UNITS, VELOCITY_UNITS = (DECLARED_UNITS[k]
                                                       for k in ("time", "accel", "gyro", "velocity"))
PRESSURE_UNITS = {"Pa": 1.0, "kPa": 1e3, "bar": 1e5, "dbar": 1e4}
STREAMS = ("imu", "dvl", "depth", "gt")


def uses_column_map(path: str | Path, config: SensorConfig | None) -> bool:
    """True when ``path`` (a CSV file or folder) is to be read through the configuration's column map."""
    path = Path(path)
    has_map = config is not None and bool(config.csv_columns)
    if path.is_file() and path.suffix.lower() == ".csv":
        if not has_map:
            raise ConfigError(f"{path}: a CSV mission needs a column map: give --config with a 'csv_columns' "
                              "entry (see graphnav.io.generic_csv)")
        return True
    return has_map and path.is_dir()


#: Separators a column-map file may use, detected from its header line: the most frequent there (a tie: the first).
DELIMITERS = (",", ";", "\t")


#: A number's integer part and the digits after a decimal comma, as a comma-separated row splits ``-0,25e-3``.
_INTEGER_PART, _FRACTION_PART = re.compile(r"[+-]?\d+"), re.compile(r"\d+(?:[eE][+-]?\d+)?")


#: Why a quoted cell holding a number with a decimal comma (``"0,5"``) of a ','-separated file is refused: quoted,
#: it is one cell, but ``"1,250"`` may be 1250 with a thousands separator as well as 1.25.
QUOTED_DECIMAL_COMMA = "a decimal comma in a quoted cell of a ','-separated file"


def decimal_comma_number(cell: str) -> float | None:
    """The number ``cell`` holds written with one decimal comma (``0,5``: 0.5), None when it holds no such number."""
    if cell.count(",") != 1 or "." in cell:
        return None
    try:
        return float(cell.replace(",", "."))
    except ValueError:
        return None


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return not cell.strip()
    return True


def _zero_led_digits(row: list[str]) -> bool:
    """True when a cell of digits led by a zero (``0245``: no number is written so) follows an integer part: the
    digits after a decimal comma, whatever else the row holds."""
    cells = [cell.strip() for cell in row]
    return any(_INTEGER_PART.fullmatch(a) and len(b) > 1 and b[0] == "0" and b.isdigit()
               for a, b in zip(cells, cells[1:]))


def split_numbers(row: list[str], numeric: list[bool]) -> bool:
    """True when ``row`` (cells of a comma-separated row) needs and allows joining adjacent cells that are a number's
    integer part and a decimal comma's digits to be one cell per column, with a number in every column ``numeric``
    marks: the cells past the header could then be halves of numbers."""
    cells = [cell.strip() for cell in row]
    while len(cells) > len(numeric) and not cells[-1]:
        cells.pop()
    if len(cells) <= len(numeric):
        return False
    ends = {0}                                  # cells taken so far, after each column
    for want_number in numeric:
        ends = {i + k for i in ends for k in (1, 2) if i + k <= len(cells) and (
            (k == 1 and (not want_number or _is_number(cells[i]))) or
            (k == 2 and _INTEGER_PART.fullmatch(cells[i]) and _FRACTION_PART.fullmatch(cells[i + 1])))}
    return len(cells) in ends


class _Table:
    """One CSV file read as text columns, with the line number of every row. Leading lines starting with ``#``
    (a logger's comments) are skipped; the separator is ``delimiter`` or the :data:`DELIMITERS` one the header
    line uses most. In a file separated by ``;`` or tabs a number with one decimal comma (``0,25``, as European
    spreadsheets write it) is read as a decimal point."""

    def __init__(self, path: Path, delimiter: str | None = None):
        self.path = path
        try:
            with open(path, newline="", encoding="utf-8-sig") as f:
                lines = f.read().splitlines()
        except OSError as exc:
            raise DataError(f"cannot read file: {exc}", str(path)) from None
        except UnicodeDecodeError as exc:
            raise DataError(f"not UTF-8 text: {exc}", str(path)) from None
        self.comments = next((i for i, line in enumerate(lines) if not line.lstrip().startswith("#")), len(lines))
        if self.comments == len(lines) or not lines[self.comments].strip():
            raise DataError("empty file, expected a header line", str(path), self.comments + 1)
        head = lines[self.comments]
        if delimiter is None:
            delimiter = max(DELIMITERS, key=head.count)
        elif len(delimiter) != 1:
            raise ConfigError(f"{path}: csv_columns delimiter {delimiter!r}: give one character (',', ';', '\\t')")
        self.delimiter, self.decimal_commas = delimiter, 0
        rows = list(csv.reader(lines[self.comments:], delimiter=delimiter))
        self.header = [h.strip() for h in rows[0]]
        self.rows = rows[1:]
        self._check_row_widths()

    def _check_row_widths(self) -> None:
        """A row with more cells than the header (empty trailing cells aside) has its values under other columns'
        names when a decimal comma split a number in a comma-separated file (``0,25`` is two cells): read by position
        they would be wrong numbers with no error, so such a file is refused naming its lines. A wider row no decimal
        comma can explain (a text cell or a number with a decimal point past the header: a column a logger appends
        without naming it, a separator inside a note) keeps its named cells; the lines are in :attr:`unnamed_lines`
        (warned by the stream reading them)."""
        width, first = len(self.header), self.comments + 2
        wide = [(i + first, len(row), row) for i, row in enumerate(self.rows)
                if len(row) > width and any(cell.strip() for cell in row[width:])]
        split = self._decimal_comma_lines(wide) if wide and self.delimiter == "," else []
        self.unnamed_lines = np.array([n for n, _, _ in wide]) if wide and not split else np.array([], int)
        if not split:
            return
        line, cells = split[0]
        shown = ", ".join(str(n) for n, _ in split[:10]) + (f" (and {len(split) - 10} more)" if len(split) > 10 else "")
        raise DataError(f"{cells} cells where the header (line {self.comments + 1}) names {width}: the values would be "
                        f"read under the wrong columns; {len(split)} such line(s): {shown}. Likely a decimal comma in "
                        f"a {self.delimiter!r}-separated file (write decimal points, or separate the cells by ';' or "
                        "tab), or a column missing from the header", str(self.path), line, self.header[-1])

    def _decimal_comma_lines(self, wide: list) -> list[tuple[int, int]]:
        """(line, cells) of the ``wide`` rows (line, cells, row) a decimal comma can explain (:func:`split_numbers`).
        Where most of the first thousand cannot, the width most of those have is a logger's unnamed columns after
        the header's: a row is then judged against that width (a decimal comma in it still makes it wider)."""
        columns = self._numeric_columns()
        explained = [split_numbers(row, columns) for _, _, row in wide[:1000]]
        if 2 * sum(explained) < len(explained):
            appended = Counter(cells for (_, cells, _), e in zip(wide, explained) if not e).most_common(1)[0][0]
            columns = columns + [False] * (appended - len(columns))
        return [(line, cells) for line, cells, row in wide if split_numbers(row, columns) or _zero_led_digits(row)]

    def _numeric_columns(self) -> list[bool]:
        """Which header columns hold numbers in most of the first thousand rows as wide as the header or narrower
        (none with every row wider: their cells may be halves of numbers)."""
        width = len(self.header)
        rows = [row for row in self.rows[:1000] if row and len(row) <= width]
        return [sum(_is_number(row[j]) for row in rows if j < len(row)) * 2 > len(rows) for j in range(width)]

    def notes(self) -> list[str]:
        """What reading the file took beyond a plain comma-separated table, for the stream's notes."""
        return ([f"{self.comments} comment line(s) before the header skipped"] if self.comments else []) + (
            [f"separated by {self.delimiter!r}"] if self.delimiter != "," else []) + (
            [f"{self.decimal_commas} number(s) with a decimal comma read"] if self.decimal_commas else [])

    def _number(self, cell: str, line: int, name: str) -> float:
        try:
            return float(cell) if cell else np.nan
        except ValueError:
            value = decimal_comma_number(cell)
            if value is not None and self.delimiter == ",":
                raise DataError(f"not a number: {cell!r}, {QUOTED_DECIMAL_COMMA} (write decimal points, or separate "
                                "the cells by ';' or tab)", str(self.path), line, name) from None
            if value is None:
                raise DataError(f"not a number: {cell!r}", str(self.path), line, name) from None
            self.decimal_commas += 1
            return value

    def columns(self, names: list[str], stream: str) -> tuple[np.ndarray, np.ndarray]:
        """(values (n, len(names)) with NaN for empty cells, 1-based line numbers) of the rows where any of
        ``names`` is non-empty."""
        missing = [c for c in names if c not in self.header]
        if missing:
            raise DataError(f"column(s) {missing} of csv_columns.{stream} not in the header {self.header}",
                            str(self.path), self.comments + 1, missing[0])
        idx = [self.header.index(c) for c in names]
        values, lines = [], []
        first = self.comments + 2
        for i, row in enumerate(self.rows):
            cells = [row[j].strip() if j < len(row) else "" for j in idx]
            if not any(cells):
                continue
            values.append([self._number(cell, i + first, name) for name, cell in zip(names, cells)])
            lines.append(i + first)
        if not values:
            raise DataError(f"no rows with values for csv_columns.{stream}", str(self.path), first, names[0])
        return np.array(values, float), np.array(lines)


def _names(spec: dict, key: str, n: int, stream: str, required: bool = True) -> list[str] | None:
    cols = spec.get(key)
    if cols is None:
        if required:
            raise ConfigError(f"csv_columns.{stream} needs '{key}' ({n} column name(s))")
        return None
    cols = [cols] if isinstance(cols, str) else list(cols)
    if len(cols) != n:
        raise ConfigError(f"csv_columns.{stream}.{key}: {n} column name(s) expected, got {cols}")
    return cols


def _unit_named(spec: dict, key: str) -> dict:
    """The DVL columns of ``spec[key]`` and the key a unit error tells a user to declare
    (:func:`graphnav.io.units.dvl_velocity_units`)."""
    return {"columns": ", ".join(_names(spec, key, {"v_b": 3, "beams": 4}[key], "dvl")),
            "fix": f"declare csv_columns.dvl.velocity_unit ({', '.join(VELOCITY_UNITS)})",
            "key": "csv_columns.dvl.velocity_unit"}


def _in_mps(values: np.ndarray, path: Path, spec: dict, key: str, declared: str | None, mmps: dict, **kw
            ) -> np.ndarray:
    """A column map's DVL ``values`` of ``spec[key]`` in m/s (:func:`graphnav.io.units.dvl_values_in_mps`, ``kw``
    its ``beams`` and ranking arguments); where mm/s were detected, their median speed as read and columns in
    ``mmps[key]``, for the one warning of the DVL's units (:func:`graphnav.io.units.say_mmps`)."""
    named = _unit_named(spec, key)
    values, med = dvl_values_in_mps(values, str(path), declared, **named, **kw)
    if med is not None:
        mmps[key] = f"{med:.4g} in {key} '{named['columns']}'"
    return values


def _say_unnamed_cells(table: _Table, lines: np.ndarray, stream: str, meta: dict) -> None:
    """Warn about and count the rows of ``stream`` (file ``lines``) with cells past the header's columns that no
    decimal comma explains (:meth:`_Table._check_row_widths`): their named cells are read, the rest is not."""
    wide = lines[np.isin(lines, table.unnamed_lines)]
    if wide.size:
        shown = ", ".join(str(n) for n in wide[:10]) + (f" (and {wide.size - 10} more)" if wide.size > 10 else "")
        say_doubted(meta, stream, str(table.path), f"{wide.size} row(s) with more cells than the header's "
                    f"{len(table.header)} (lines {shown}): the cells past the header's last column "
                    f"{table.header[-1]!r} are not read (unnamed columns a logger appended, or a separator inside a "
                    "text cell); name them in the header if a column is missing from it",
                    "cells past the header not read", int(wide.size), stacklevel=3)


def _read(root: Path, data_file: Path | None, spec: dict, stream: str, groups: dict[str, int],
          time_unit: str | None, tables: dict, meta: dict, repair: bool = False,
          t_imu: np.ndarray | None = None, imu_rate_hz: float | None = None) -> tuple[np.ndarray, dict, Path]:
    """Stamps (s, on the file's clock, increasing) and value groups of one stream (:func:`stamp_order`: rows
    repeating an earlier one exactly, or the row before it in every value under half a step later, dropped; with
    ``repair`` rows with a repeated stamp too, and sorted; each counted; an IMU's filler rows whose stamp is zeroed
    too, :func:`graphnav.core.screening.zeroed_filler`, taken out before the stamps are judged and counted as
    filler). ``t_imu``: the IMU's stamps (s, the file's clock), which a declared time unit's span is checked
    against (:func:`graphnav.io.units.check_declared_time_span`); ``imu_rate_hz``: the configured IMU rate (Hz),
    which tells an IMU slower than its logger's clock from one losing samples."""
    if "t" not in spec:
        raise ConfigError(f"csv_columns.{stream} needs 't' (the stamp column)")
    path = root / spec["file"] if "file" in spec else data_file
    if path is None:
        raise ConfigError(f"csv_columns.{stream} needs 'file' (the data path is a folder)")
    if path not in tables:
        tables[path] = _Table(path, spec.get("delimiter"))
    table = tables[path]
    names = {k: _names(spec, k, n, stream, required=False) for k, n in groups.items()}
    flat = [spec["t"]] + [c for cols in names.values() if cols for c in cols]
    values, lines = table.columns(flat, stream)
    for note in table.notes():
        add_note(meta, stream, f"{path}: {note}")
    _say_unnamed_cells(table, lines, stream, meta)
    zeroed = np.zeros(len(lines), bool)
    if stream == "imu" and len(flat) == 7:
        # filler rows whose stamp is zeroed too: no time, taken out before the stamps are judged (counted below)
        zeroed = zeroed_filler(values[:, 0], values[:, 1:], str(path), lines)
    zeroed_lines, values, lines = lines[zeroed], values[~zeroed], lines[~zeroed]
    t = values[:, 0]
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise DataError("empty or non-finite stamp", str(path), int(lines[bad[0]]), spec["t"])
    # a declared unit is applied (the span is still checked); without one it is detected from the step
    unit = spec.get("time_unit", time_unit)
    if unit is not None:
        declared_scale(spec, "time_unit", TIME_UNITS, time_unit, f"csv_columns.{stream}")
    key = f"csv_columns.{stream}.time_unit" if "time_unit" in spec else "csv_columns.time_unit"
    # the IMU is read first: a global unit its stamps passed, another stream's contradict, is that stream's to declare
    own = None if stream == "imu" or "time_unit" in spec else f"csv_columns.{stream}.time_unit"
    try:
        t = stamps_in_seconds(t, stream, str(path), meta, declared=unit, field=spec["t"], lines=lines, key=key,
                              stream_key=own)
    except DataError as e:
        # rows stamped 0 behind a clock far from 0 (Unix time) were refused as a span over a year or an IMU gap to
        # split the mission at, naming the line after them: they are to be deleted, as stamp_order says where it can
        raise zeroed_stamps_error(t, lines, zeroed_lines, str(path), spec["t"]) or e
    if t_imu is not None and len(t_imu):
        if unit is not None:
            check_declared_time_span(t, t_imu, stream, str(path), unit, key, spec["t"], own)
        check_stamp_bound(t, float(t_imu[0]), stream, str(path), unit, key, spec["t"], lines, own)
    kept, dropped, t_kept = stamp_order(t, values, lines, str(path), spec["t"], repair, meta, stream,
                                         imu_rate_hz, filler_lines=zeroed_lines)
    if dropped or zeroed_lines.size:
        _count_read(meta, stream, t, path)       # the rows dropped were read
        for reason, n in dropped.items():
            count_refused(meta, stream, reason, n)
        refuse_zeroed_filler(meta, str(path), zeroed_lines)
    t, values, lines = t_kept, values[kept], lines[kept]
    out, j = {}, 1
    for key, cols in names.items():
        if cols:
            out[key] = values[:, j:j + len(cols)]
            j += len(cols)
    out["_lines"] = lines
    return t, out, path


def _count_read(meta: dict, stream: str, t: np.ndarray, path: Path) -> None:
    """Count ``t`` as the stream's rows read, unless they are counted (:func:`_read` counts a stream whose rows it
    drops, with all the rows it read)."""
    if not meta.get("streams", {}).get(stream, {}).get("read"):
        count_read(meta, stream, t, str(path), shown_rate_hz(stream, t))


def load_csv_mission(data: str | Path, config: SensorConfig, pd0_file: Path | None = None,
                     repair: bool = False) -> Mission:
    """A :class:`Mission` from CSV logs described by ``config.csv_columns`` (see the module docstring).
    ``repair``: rows whose stamp repeats an earlier one are dropped (the first kept) and the rest sorted, warned
    about and counted, instead of a DataError (``--repair-stamps``)."""
    data = Path(data)
    cmap = config.csv_columns or {}
    check_column_map(cmap, "configuration")     # a configuration file's map was checked naming the file
    root, data_file = (data, None) if data.is_dir() else (data.parent, data)
    time_unit = cmap.get("time_unit")        # None: detected per stream (graphnav.io.units)
    tables: dict = {}
    config = dataclasses.replace(config)
    meta: dict = {"source": str(data), "format": "csv"}

    spec = cmap.get("imu")
    if not spec:
        raise ConfigError("csv_columns needs an 'imu' entry")
    t_imu, v, path = _read(root, data_file, spec, "imu", {"f_b": 3, "omega_b": 3}, time_unit, tables, meta, repair,
                           imu_rate_hz=config.imu_rate_hz)
    for key in ("f_b", "omega_b"):
        if key not in v:
            raise ConfigError(f"csv_columns.imu needs '{key}' (3 column names)")
    fields = _names(spec, "f_b", 3, "imu") + _names(spec, "omega_b", 3, "imu")
    # an empty, NaN or infinite cell refuses its row, and so does a logger's all-zero filler (before the unit and axis
    # checks, which need measurements); so do full scale and spikes once the units and the DVL are known, all with the
    # file's lines and columns (screen_mission leaves the IMU)
    _count_read(meta, "imu", t_imu, path)
    rows = np.hstack([v["f_b"], v["omega_b"]])
    t_imu, rows, imu_lines = refuse_rows(meta, "imu", imu_unmeasured(t_imu, v["f_b"], v["omega_b"], fields, str(path),
                                                                     v["_lines"]),
                                         str(path), v["_lines"], t_imu, rows, v["_lines"], fields=fields)
    f_b = rows[:, :3] * declared_scale(spec, "accel_unit", ACCEL_UNITS, "m/s^2", "csv_columns.imu")
    omega_b = rows[:, 3:] * declared_scale(spec, "gyro_unit", GYRO_UNITS, "rad/s", "csv_columns.imu")
    declared = {k: spec[f"{k}_unit"] for k in ("accel", "gyro") if f"{k}_unit" in spec}
    f_b, omega_b = imu_units(t_imu, f_b, omega_b, str(path), meta, declared, config.gravity_mps2, fields)
    frame = spec.get("frame", "frd")
    if frame not in ("frd", "flu", "auto"):
        raise ConfigError(f"csv_columns.imu.frame = {frame!r}: choose frd, flu or auto")
    if frame == "flu":
        f_b, omega_b = f_b * [1, -1, -1], omega_b * [1, -1, -1]
    imu_path = path

    spec = cmap.get("dvl") or {}
    if not spec and pd0_file is None:
        raise ConfigError("csv_columns needs a 'dvl' entry")
    depth, dvl_refused, dvl_lines, vdeclared = None, {}, None, None
    pd0 = pd0_file is not None or "pd0" in spec
    if pd0:
        dvl, depth, pd0_meta = read_pd0(pd0_file or root / spec["pd0"], config)
        meta.update(pd0_meta)
        config = pd0_geometry(config, pd0_meta)
    else:
        t_dvl, v, path = _read(root, data_file, spec, "dvl", {"beams": 4, "valid": 4, "v_b": 3, "euler": 3},
                               time_unit, tables, meta, repair, t_imu)
        vscale = declared_scale(spec, "velocity_unit", VELOCITY_UNITS, "m/s", "csv_columns.dvl")
        vdeclared = spec.get("velocity_unit")
        lines = dvl_lines = v["_lines"]
        flags = np.nan_to_num(v["valid"]) != 0 if "valid" in v else np.ones((len(t_dvl), 4), bool)
        # pings logged as 0, 0, 0: the file's resolution is judged as written, the speeds around them in m/s
        raw = v["v_b"] if "v_b" in v else v.get("beams", np.empty((0, 4)))
        zero, (on, off) = zero_pings(raw), on_resolution_grid(raw)
        no_lock = np.zeros(len(t_dvl), bool)
        v_b = None
        mmps: dict[str, str] = {}           # the columns detected as mm/s with their median speeds: said once
        if "beams" in v and vdeclared is None:
            beams_mps = _in_mps(v["beams"], path, spec, "beams", None, mmps, beams=True)
        if "v_b" in v:
            # a zero tells nothing of the unit: hidden from its detection, and 0 in any unit after it
            # the IMU's accelerations order the units a refusal names, for a velocity in the body's axes
            body = spec.get("frame", "body") in ("body", "frd")
            v_b = _in_mps(np.where(zero[:, None], np.nan, v["v_b"]) * vscale, path, spec, "v_b", vdeclared, mmps,
                          t=t_dvl, imu=(t_imu, f_b, omega_b) if body else None,
                          max_speed_mps=config.dvl.max_speed_mps)
        if mmps:
            say_mmps(meta, str(path), "median speed " + ", ".join(mmps[k] for k in ("beams", "v_b") if k in mmps))
        if "v_b" in v:
            v_b[zero] = 0.0
            no_lock = no_lock_pings(t_dvl, config.dvl, off > on, v=v_b)
            # the flags are per beam: a velocity needs three valid beams
            v_b[no_lock | (flags.sum(axis=1) < 3)] = np.nan
            v_b = columns_to_body(t_dvl, v_b, v.get("euler"), spec, config.dvl.C_d_b, t_imu, omega_b, str(path),
                                  meta, f_b, config.dvl, config.dvl_time_offset_s or 0.0)
        if "beams" in v:
            raw = v["beams"]
            if v_b is None:         # the columns a later message about the DVL names (the velocity's, with both)
                meta.setdefault("stream_fields", {})["dvl"] = _unit_named(spec, "beams")["columns"]
            if vdeclared is None:
                raw = beams_mps         # m/s (mm/s detected)
            flag = np.isin(raw, (-32768.0, -32.768))
            if vdeclared is not None:       # the declared unit's speeds judged as the velocity columns' are
                dvl_velocity_units(np.where(flag, np.nan, raw) * vscale, str(path), meta, vdeclared, beams=True,
                                   **_unit_named(spec, "beams"), max_speed_mps=config.dvl.max_speed_mps)
            beams = np.where(flag, -32.768, raw * vscale)
            # an empty cell is no beam; an infinite one is a beam that is not a measurement (sanitized warns)
            valid = flags & ~np.isnan(beams)
            if v_b is None:
                no_lock = no_lock_pings(t_dvl, config.dvl, off > on, beams=beams, valid=valid)
        elif v_b is not None:
            from graphnav.core.dvl import DvlGeometry
            T_b = DvlGeometry.from_spec(config.dvl).T_b
            beams = v_b @ T_b.T
            valid = flags & ~np.any(np.isnan(v_b), axis=1, keepdims=True)
            meta["beams_from_v_b"] = True
        else:
            raise ConfigError("csv_columns.dvl needs 'beams' (4 columns) or 'v_b' (3 columns)")
        warn_no_bottom_lock(no_lock, lines, str(path))
        meta["dvl_zeros_screened"] = True          # screen_mission would judge them again in m/s, without lines
        valid &= ~no_lock[:, None]
        dvl = DvlData(t_dvl, np.where(valid, beams, np.nan), valid, v_b, str(path)).sanitized(lines=lines)
        dvl_refused = {NO_BOTTOM_LOCK: no_lock}
    t_imu, f_b, omega_b, imu, t0 = _screened_imu(t_imu, f_b, omega_b, imu_lines, fields, dvl, config, meta, imu_path)
    dvl = dataclasses.replace(dvl, t=dvl.t - t0)
    if pd0:
        for entry in meta.get("streams", {}).values():     # spans on the mission's clock, like the streams
            if entry.get("span_s"):
                entry["span_s"] = [entry["span_s"][0] - t0, entry["span_s"][1] - t0]
        if depth is not None:
            depth = dataclasses.replace(depth, t=depth.t - t0)

    spec = cmap.get("depth")
    if spec:
        if depth is not None:
            raise ConfigError("csv_columns.depth given while the PD0 file has a pressure sensor; drop one")
        key = "depth" if "depth" in spec else "pressure" if "pressure" in spec else None
        if key is None:
            raise ConfigError("csv_columns.depth needs 'depth' (m, down) or 'pressure' (a column name)")
        t_d, v, path = _read(root, data_file, spec, "depth", {key: 1}, time_unit, tables, meta, repair, t_imu)
        # an empty, NaN or infinite cell refuses its row, as for the IMU and the reference
        _count_read(meta, "depth", t_d, path)
        t_d, x = refuse_rows(meta, "depth", not_finite(v[key], [spec[key]]), str(path), v["_lines"], t_d, v[key][:, 0])
        if key == "pressure":
            unit = spec.get("pressure_unit", "Pa")
            p = x * declared_scale(spec, "pressure_unit", PRESSURE_UNITS, "Pa", "csv_columns.depth")
            if unit in ("Pa", "kPa"):
                p = p - config.atmospheric_pressure_pa
            x = p / (config.water_density_kgpm3 * config.gravity_mps2)
        positive = spec.get("positive")
        if positive not in (None, "down", "up") or (positive and key == "pressure"):
            raise ConfigError(f"csv_columns.depth.positive = {positive!r}: choose down or up, for a 'depth' column")
        if positive == "up":
            x = -x
            add_note(meta, "depth", f"{path}: column '{spec[key]}' declared positive up: negated")
        depth = DepthData(t_d - t0, x, str(path))
        meta.setdefault("stream_fields", {})["depth"] = spec[key]     # named by a message about the stream
    if depth is None:
        meta["depth_source"] = "none"

    gt = None
    spec = cmap.get("gt")
    if spec:
        t_g, v, path = _read(root, data_file, spec, "gt", {"p_n": 3, "v_n": 3, "euler": 3}, time_unit, tables,
                             meta, repair, t_imu)
        keys = ("p_n", "v_n", "euler")
        for key in keys:
            if key not in v:
                raise ConfigError(f"csv_columns.gt needs '{key}' (3 column names)")
        # a row with an empty, NaN or infinite cell or an implausible velocity is refused before the unit and sign
        # checks, as the A-KIT reader does: one V Down spike would swamp the down position's fit to it
        _count_read(meta, "gt", t_g, path)
        fields = [c for key in keys for c in _names(spec, key, 3, "gt")]
        masks = gt_refusals(t_g, np.hstack([v[k] for k in keys]), fields, v["v_n"], config.dvl)
        rows, too_fast = unit_check_rows(masks, config.dvl)
        if too_fast:        # a velocity in other units: the unit checks say which, before the refusals' count
            from graphnav.io.units import reference_speed_error
            _reference_units(t_g[rows], {k: v[k][rows] for k in (*keys, "_lines")}, spec, t_imu, omega_b, path, meta)
            raise reference_speed_error(v["v_n"][rows], str(path), spec["v_n"], config.dvl.max_speed_mps)
        masks = with_position_spikes(masks, t_g, v["p_n"], v["v_n"], config.dvl, fields[:3], str(path), v["_lines"],
                                     meta)
        t_g, *kept = refuse_rows(meta, "gt", masks, str(path), v["_lines"], t_g, *(v[k] for k in (*keys, "_lines")))
        v = dict(zip((*keys, "_lines"), kept))
        meta["gt_screened"] = True
        from graphnav.core.rotations import euler_to_C_b_n
        e = _reference_units(t_g, v, spec, t_imu, omega_b, path, meta)
        gt = GroundTruth(t_g - t0, v["p_n"], v["v_n"], euler_to_C_b_n(e[:, 0], e[:, 1], e[:, 2]), None, str(path))
        if spec.get("velocity_sigma") is not None:
            meta["gt_velocity_sigma_n"] = _reference_sigma(spec["velocity_sigma"])
    clock = (cmap.get("dvl") or {}).get("clock", "auto")
    if clock not in ("auto", "imu"):
        raise ConfigError(f"csv_columns.dvl.clock = {clock!r}: choose auto or imu")
    # a DVL on a clock of its own is put on the IMU's by graphnav.calibration.preparation (estimated from the data)
    meta.update(prepared=False, prepare={"format": "csv", "dvl_clock": clock,
                                         "imu_frame": _imu_frame_fact(cmap["imu"])})
    if (cmap.get("depth") or {}).get("positive"):        # a declared convention the data may not contradict
        meta["prepare"]["depth_positive"] = cmap["depth"]["positive"]
    if vdeclared:                                         # a declared unit the data may not contradict either
        meta["prepare"]["dvl_unit"] = {"unit": vdeclared, "key": "csv_columns.dvl.velocity_unit"}
    _record_csv_streams(meta, cmap, imu, dvl, depth, gt, dvl_refused, dvl_lines)
    name = data.stem if data.is_file() else data.name
    return Mission(name, imu, dvl, config, gt, depth, meta)


def _screened_imu(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray, lines: np.ndarray, fields: list, dvl,
                  config: SensorConfig, meta: dict, path: Path) -> tuple:
    """``(t, f_b, omega_b, imu, t0)``: the IMU rows (stamps s on the file's clock, m/s^2, rad/s, FRD) without those
    beyond full scale or spiking (:func:`graphnav.core.screening.imu_implausible`, refused with their file ``lines``
    and ``fields``), as an :class:`ImuData` on the mission's clock, which starts at the first row kept ``t0`` (s).
    The DVL as read (``dvl``, on the file's clock) tells a knock, which changed its velocity, from bad samples; the
    spans of the knocks kept (``meta["imu_shocks"]``) are put on the mission's clock."""
    t, f_b, omega_b = refuse_rows(meta, "imu", imu_implausible(t, f_b, omega_b, config, fields, meta, str(path),
                                                               (dvl.t, ping_velocity_b(dvl, config.dvl)), lines,
                                                               unmeasured=False),
                                  str(path), lines, t, f_b, omega_b, fields=fields)
    meta["imu_screened"] = True
    t0 = meta["t0_s"] = float(t[0])
    for span in meta.get("imu_shocks", []):
        span[:] = [span[0] - t0, span[1] - t0]
    return t, f_b, omega_b, ImuData(t - t0, f_b, omega_b, str(path)), t0


def _reference_units(t: np.ndarray, v: dict, spec: dict, t_imu: np.ndarray, omega_b: np.ndarray, path: Path,
                     meta: dict) -> np.ndarray:
    """The reference's roll, pitch, yaw (K,3) in rad, and its positions checked against its velocity
    (:mod:`graphnav.io.units`, as the A-KIT GT's): an undeclared ``angle_unit`` detected from the attitude's
    turn rate against the gyro (``omega_b`` rad/s at ``t_imu`` s), a declared one confirmed; north/east moving
    with ``v_n`` and down changing with its down axis, else DataError naming the columns."""
    from graphnav.io.units import (
        check_reference_axes,
        check_reference_displacement,
        displacement_ratio,
        reference_attitude_units,
        reference_depth,
    )
    declared = spec.get("angle_unit")
    euler = v["euler"] * declared_scale(spec, "angle_unit", ANGLE_UNITS, "rad", "csv_columns.gt")
    euler = reference_attitude_units(t, euler, t_imu, omega_b, str(path), spec["euler"], meta, declared)
    p_n, v_n = v["p_n"], v["v_n"]
    check_reference_displacement(displacement_ratio(t, p_n[:, :2], v_n[:, :2])[0], str(path),
                                 spec["p_n"][:2] + spec["v_n"][:2], t=t)
    check_reference_axes(t, p_n[:, :2], v_n[:, :2], euler[:, 2], str(path), [*spec["p_n"], *spec["v_n"]],
                         ("p_n", "v_n"))
    # a reference's down is taken in the frame its file gives (relative or absolute): its sign only
    reference_depth(t, p_n[:, 2], v_n[:, 2], str(path), (spec["p_n"][2], spec["v_n"][2]), meta, lines=v["_lines"],
                    v_pitch=-np.linalg.norm(v_n, axis=1) * np.sin(euler[:, 1]))
    return euler


def _imu_frame_fact(spec: dict) -> dict:
    """What the prepare step checks the IMU axes against (:func:`graphnav.calibration.preparation.prepare`): the
    frame ``frd`` or ``flu`` the column map declares (contradicting data are an error), or None for ``"auto"`` or no
    ``frame`` (FRD taken, corrected from the data with a warning)."""
    frame = spec.get("frame")
    what = (f"csv_columns.imu.frame {frame!r}" if frame in ("frd", "flu") else
            "the FRD axes taken for csv_columns.imu" + (" (frame 'auto')" if frame else " (no frame given)"))
    fields = _names(spec, "f_b", 3, "imu") + _names(spec, "omega_b", 3, "imu")
    return {"declared": frame if frame in ("frd", "flu") else None, "what": what, "fields": "/".join(fields)}


def _reference_sigma(value) -> list[float]:
    """``csv_columns.gt.velocity_sigma``: the reference's own velocity error, m/s per NED axis (3 numbers >= 0)."""
    numbers = isinstance(value, (list, tuple)) and all(
        isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)
    sigma = [float(x) for x in value] if numbers else []
    if len(sigma) != 3 or not all(np.isfinite(x) and x >= 0 for x in sigma):
        raise ConfigError(f"csv_columns.gt.velocity_sigma = {value!r}: give the reference's velocity error as 3 "
                          "numbers >= 0, m/s north, east, down (graphnav calibrate prints an upper bound)")
    return sigma


def _record_csv_streams(meta: dict, cmap: dict, imu, dvl, depth, gt, dvl_refused: dict,
                        dvl_lines: np.ndarray | None) -> None:
    """``meta["streams"]`` of a column-map mission: counts and what the loader did (units, frames, clock);
    ``dvl_refused``: reason -> (M,) pings the reader refused, ``dvl_lines``: the file line of each ping (a CSV)."""
    from graphnav.io.stream_counts import record_streams
    # the PD0 reader counts its own DVL and depth, with its reasons (a CSV stream _read counted is counted here)
    done = {k for k, e in meta.get("streams", {}).items() if e["read"]} if "pd0_instrument" in meta else set()
    record_streams(meta, imu=imu, dvl=None if "dvl" in done else dvl, depth=None if "depth" in done else depth,
                   gt=gt, dvl_refused=dvl_refused, dvl_lines=dvl_lines)
    from graphnav.core.streams import set_span
    for name, stream in (("dvl", dvl), ("depth", depth)):
        if name in done and stream is not None:
            set_span(meta, name, stream.t)        # the stamps as the mission holds them (a clock offset added)
    add_note(meta, "imu", f"clock starts at the first IMU stamp ({meta['t0_s']:.6f} s on the file's clock)")
    spec = cmap.get("imu") or {}
    units = [f"{k} {spec[k]}" for k in ("accel_unit", "gyro_unit") if spec.get(k) not in (None, "m/s^2", "rad/s")]
    if units:
        add_note(meta, "imu", f"converted to SI from {', '.join(units)}")
    if spec.get("frame") == "flu":
        add_note(meta, "imu", "FLU axes turned to FRD (y and z negated)")
    if meta.get("beams_from_v_b"):
        add_note(meta, "dvl", "the file has no beams: beams are the exact projections of its v_b on the configured "
                              "geometry (no noise)")
    if "pd0_instrument" in meta:
        add_note(meta, "dvl", f"PD0 bottom track of a {meta['pd0_instrument'] or 'RDI'} "
                              f"({meta['pd0_beam_angle_deg']:g} deg beams, {meta['pd0_beam_pattern']})")
    if depth is None:
        add_note(meta, "depth", "no depth stream")


def load_pd0(path: str | Path, config: SensorConfig | None = None, repair: bool = False):
    """A Mission from a PD0 file plus the IMU named in the configuration's CSV column map (``repair``: as
    :func:`load_csv_mission`'s, for the CSV files)."""
    if config is None or "imu" not in config.csv_columns:
        raise ConfigError(f"{path}: a PD0 file holds the DVL only; give the IMU in the configuration's "
                          "csv_columns map ('imu': {'file': ..., ...}, see graphnav.io.generic_csv); "
                          "`graphnav smooth --data FILE` dead-reckons the DVL alone (DVL-DR)")
    return load_csv_mission(Path(path).parent, config, pd0_file=Path(path), repair=repair)
