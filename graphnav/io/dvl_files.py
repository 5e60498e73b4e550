"""A DVL log on its own, from any DVL file: :func:`read_dvl` -> :class:`graphnav.core.dvl_log.DvlLog`.

* **PD0** (Teledyne RDI ``.pd0``, ``.000``; VmDAS ``.ENR``/``.ENS``/``.ENX``; any name: the file is recognised
  by its content, :func:`graphnav.io.pd0.looks_like_pd0`): every RDI frame, see :mod:`graphnav.io.pd0`.
* **CSV of DVL velocities**: a header row, a time column (``t``, ``time``, ``time_s`` or ``timestamp``,
  seconds) and three velocity columns (``vx, vy, vz``, ``v_x, v_y, v_z`` or ``vel_x, vel_y, vel_z``; m/s, in
  graphnav's DVL frame ``d``), optionally ``valid`` (0/1). Empty or non-finite velocities are pings without a
  measurement (counted); anything that is not a number is an error naming the line and column.
"""
from __future__ import annotations

import csv
import warnings
from pathlib import Path

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.dvl_log import DvlLog
from graphnav.core.errors import DataError
from graphnav.core.mission import invalid_dvl_values
from graphnav.io import pd0

#: Accepted header names of the CSV columns (lower case).
CSV_TIME = ("t", "time", "time_s", "timestamp")
CSV_VELOCITY = (("vx", "vy", "vz"), ("v_x", "v_y", "v_z"), ("vel_x", "vel_y", "vel_z"))

#: A gap (s) between a DVL log's pings with a velocity longer than this is refused by a dead reckoning, not bridged:
#: the hour of :data:`graphnav.io.pd0.JOIN_SPLIT_S`, past which two recordings are two deployments. A surfacing or a
#: lost bottom lock within a dive is shorter; an hour or days without a velocity over ground is the vehicle out of
#: the water or the clock set on, and nothing in the log says where the vehicle went, so no track may join the two.
BRIDGE_MAX_S = pd0.JOIN_SPLIT_S


def is_dvl_file(path: str | Path) -> bool:
    """A file that holds a DVL only: PD0/VmDAS ensembles (recognised by content or by a PD0 name)."""
    path = Path(path)
    return path.is_file() and (pd0.looks_like_pd0(path) or pd0.has_pd0_suffix(path))


def holds_dvl_only(path: str | Path, config: SensorConfig | None) -> bool:
    """True when ``path`` is a DVL file and the configuration names no IMU to go with it (``csv_columns``)."""
    return is_dvl_file(path) and (config is None or "imu" not in (config.csv_columns or {}))


def pd0_header(path: str | Path) -> dict:
    """What a PD0 file holds, whether graphnav can use it or not: the instrument (model, frequency, beam angle,
    pattern, orientation, coordinates), ensembles, time span (Unix s) and whether it has bottom track."""
    ds = pd0._read_rdi(Path(path))
    t = ds["time"].values.astype("datetime64[ns]").astype(np.int64) / 1e9
    scan = pd0.scan_pd0(path)
    instrument = pd0._instrument(ds, scan, "file" if scan.beam_matrix is not None else "nominal")
    instrument["coordinates"] = instrument.pop("coordinate_system")
    return {"instrument": instrument, "ensembles": int(len(t)),
            "span_s": [float(t[0]), float(t[-1])] if len(t) else None,
            "bottom_track": "vel_bt" in ds, "variables": sorted(str(v) for v in ds.data_vars)}


def long_gaps_said(log: DvlLog, ok: np.ndarray | None = None) -> str:
    """What a dead reckoning of ``log`` must not bridge: its pings with a velocity (``ok``, default
    ``v_d_valid``) more than :data:`BRIDGE_MAX_S` apart, each gap named by the pings either side (the file's
    ensemble and byte where the log has them) and where to cut the log so that each side is dead-reckoned on its
    own; "" when there are none."""
    t = np.asarray(log.t, float)
    i_ok = np.flatnonzero(np.asarray(log.v_d_valid, bool) if ok is None else ok)
    far = np.flatnonzero(np.diff(t[i_ok]) > BRIDGE_MAX_S)
    if not len(far):
        return ""

    def ping(i: int) -> str:
        at = f" ({pd0._utc(t[i])} UTC)" if t[i] > 1e8 else ""       # Unix s (inspect's UNIX_CLOCK_MIN_S)
        return f"{log.where[i] if log.where is not None else f'ping {i + 1}'} at t = {t[i]:.3f} s{at}"
    said = []
    for k in far:
        a, b = int(i_ok[k]), int(i_ok[k + 1])
        inside = f", {b - a - 1} ping(s) without one between" if b - a > 1 else ""
        said.append(f"{pd0._gap_words(t[b] - t[a])} from {ping(a)} to {ping(b)}{inside}")
    cuts = " and ".join(log.where[int(i_ok[k + 1])] if log.where is not None else f"ping {int(i_ok[k + 1]) + 1}"
                        for k in far)
    return (f"{len(far)} gap(s) without a velocity over ground longer than {pd0._gap_words(BRIDGE_MAX_S)}: "
            f"{'; '.join(said)}. A dead reckoning cannot bridge that (the vehicle recovered and put in again, or the "
            "clock set on: nothing in the log says where it went); dead-reckon each side on its own: cut the log "
            f"before {cuts}")


def read_dvl(path: str | Path, config: SensorConfig | None = None) -> DvlLog:
    """The DVL log of a file (PD0/VmDAS by content, else a CSV of DVL velocities by its header).

    ``config`` gives the water density and gravity for depth from pressure (default :class:`SensorConfig`).

    Raises:
        DataError: the file is missing, not a DVL format graphnav reads, or bad (the message names where).
    """
    path = Path(path)
    if not path.is_file():
        raise DataError("no such file", str(path))
    if pd0.looks_like_pd0(path):
        return pd0.read_pd0_log(path, config)
    if pd0.has_pd0_suffix(path):
        raise DataError("named like a PD0 file but holds no PD0 ensemble (header 0x7F 0x7F with a valid "
                        "checksum): a truncated download or another format?", str(path))
    if path.suffix.lower() in (".csv", ".txt"):
        return read_dvl_csv(path)
    raise DataError("not a DVL file graphnav reads: PD0/VmDAS ensembles (recognised by content) or a CSV of "
                    "DVL velocities (t, vx, vy, vz)", str(path))


def _column(header: list[str], names: tuple[str, ...]) -> int | None:
    low = [h.strip().lower() for h in header]
    return next((low.index(n) for n in names if n in low), None)


def read_dvl_csv(path: str | Path) -> DvlLog:
    """A CSV of DVL-frame velocities (see the module docstring) as a :class:`DvlLog` with ``frame="dvl"``."""
    path = Path(path)
    source = str(path)
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise DataError("empty file", source)
    header, body = rows[0], rows[1:]
    i_t = _column(header, CSV_TIME)
    i_v = next((idx for idx in ([_column(header, (n,)) for n in names] for names in CSV_VELOCITY)
                if None not in idx), None)
    if i_t is None or i_v is None:
        raise DataError(f"the header needs a time column ({', '.join(CSV_TIME)}) and three velocity columns "
                        f"({'; '.join(', '.join(n) for n in CSV_VELOCITY)}); got {header}", source, 1)
    i_ok = _column(header, ("valid",))
    cols = [i_t, *i_v] + ([i_ok] if i_ok is not None else [])
    data = np.full((len(body), len(cols)), np.nan)
    for r, row in enumerate(body):
        for c, j in enumerate(cols):
            text = row[j].strip() if j < len(row) else ""
            if not text:
                continue
            try:
                data[r, c] = float(text)
            except ValueError:
                raise DataError(f"not a number: {text!r}", source, r + 2, header[j]) from None
    t, v = data[:, 0], data[:, 1:4]
    if not np.all(np.isfinite(t)):
        raise DataError("empty or non-finite time", source, int(np.flatnonzero(~np.isfinite(t))[0]) + 2,
                        header[i_t])
    flagged = np.any(invalid_dvl_values(v), axis=1)
    valid = ~flagged & ((np.nan_to_num(data[:, 4]) != 0) if i_ok is not None else True)
    counts = {"read": len(t), "valid": int(valid.sum())}
    if flagged.any():
        counts["no velocity (empty, non-finite or flagged)"] = int(flagged.sum())
    if i_ok is not None and (~valid & ~flagged).any():
        counts["marked invalid in the file"] = int((~valid & ~flagged).sum())
    if counts["valid"] < len(t):
        warnings.warn(f"{source}: {len(t) - counts['valid']} of {len(t)} ping(s) without a valid velocity",
                      RuntimeWarning, stacklevel=2)
    return DvlLog(t=t, v_d=np.where(valid[:, None], v, np.nan), v_d_valid=valid, frame="dvl",
                  instrument={"format": "csv"}, counts=counts, source=source)
