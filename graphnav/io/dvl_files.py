"""A DVL file on its own, as a :class:`~graphnav.core.dvl_log.DvlLog`: what ``graphnav info`` describes and
``graphnav smooth`` dead-reckons when there is no IMU.

Today's reader is the PD0 one (:func:`graphnav.io.pd0.read_pd0`): bottom track in beam coordinates. From it:

* ``beams`` / ``beam_valid``: the bottom-track beams as :func:`~graphnav.io.pd0.read_pd0` gives them (RDI's
  -32768 flags invalid);
* ``v_d``: the least-squares head velocity of pings with >= 3 valid beams, in graphnav's DVL frame with the
  file's beam angle and head pattern (:func:`~graphnav.io.pd0.pd0_geometry`); ``three_beam`` marks 3-beam pings;
* ``v_n``: the head's velocity over the seabed in NED from the instrument's own heading, pitch and roll,
  through dolfyn's rotation to its earth frame (``rotate2(ds, "earth")``, East-North-Up): RDI's bottom-track
  velocity is the seabed's relative to the head, so the head's is its negative. Only on 4-beam pings
  (dolfyn's beam-to-instrument transformation has no 3-beam solution); measured against the GPS the
  RiverPro test file carries: the dead-reckoned track ends 18 m from the GPS's after 198 m;
* ``attitude_deg``: heading, pitch, roll as stored; ``depth_m``: the pressure sensor's depth, if any.

Files in earth, ship or instrument coordinates and files without bottom track are refused with the reason
(:func:`read_pd0`); :func:`pd0_header` still tells what such a file holds.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.dvl import beam_matrix
from graphnav.core.dvl_log import DvlLog
from graphnav.core.errors import DataError
from graphnav.io import pd0

#: dolfyn's dataset attributes reported as the instrument's metadata, under graphnav's names.
PD0_INSTRUMENT_ATTRS = {"inst_make": "make", "inst_model": "model", "inst_type": "type", "freq": "frequency_khz",
                        "beam_angle": "beam_angle_deg", "beam_pattern": "beam_pattern", "orientation": "orientation",
                        "n_beams": "n_beams", "coord_sys": "coordinates", "fs": "ping_rate_hz",
                        "SerialNum": "serial"}


def is_dvl_file(path: str | Path) -> bool:
    """A file :func:`read_dvl` reads (today: PD0, ``.pd0`` or RDI's numbered ``.000``)."""
    return pd0.is_pd0(path)


def holds_dvl_only(path: str | Path, config: SensorConfig | None) -> bool:
    """True when ``path`` is a DVL file and the configuration names no IMU to go with it (``csv_columns``)."""
    return is_dvl_file(path) and (config is None or "imu" not in (config.csv_columns or {}))


def _instrument(ds) -> dict:
    out = {}
    for key, name in PD0_INSTRUMENT_ATTRS.items():
        if key in ds.attrs:
            value = ds.attrs[key]
            out[name] = value.item() if hasattr(value, "item") else value
    return out


def pd0_header(path: str | Path) -> dict:
    """What a PD0 file holds, whether graphnav can use it or not: the instrument (model, frequency, beam angle,
    pattern, orientation, coordinates), ensembles, time span (Unix s) and whether it has bottom track."""
    ds = pd0._read_rdi(Path(path))
    t = ds["time"].values.astype("datetime64[ns]").astype(np.int64) / 1e9
    return {"instrument": _instrument(ds), "ensembles": int(len(t)),
            "span_s": [float(t[0]), float(t[-1])] if len(t) else None,
            "bottom_track": "vel_bt" in ds, "variables": sorted(str(v) for v in ds.data_vars)}


def _v_n_from_dolfyn(ds, four_beams: np.ndarray) -> np.ndarray:
    """Head velocity over the seabed in NED (M,3) on 4-beam pings, through dolfyn's own earth rotation."""
    from mhkit.dolfyn.rotate.api import rotate2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        earth = rotate2(ds, "earth", inplace=False)
    seabed_enu = np.asarray(earth["vel_bt"].values, float)[:3].T     # (M,3), the seabed relative to the head
    head_enu = -seabed_enu
    v_n = np.column_stack([head_enu[:, 1], head_enu[:, 0], -head_enu[:, 2]])
    v_n[~four_beams] = np.nan
    return v_n


def read_dvl(path: str | Path, config: SensorConfig | None = None) -> DvlLog:
    """The DVL log of a file on its own (module docstring).

    Raises:
        DataError: not a DVL file graphnav reads, or a file it cannot use (no bottom track, not in beam
            coordinates), with the reason.
    """
    path = Path(path)
    if not is_dvl_file(path):
        raise DataError("not a DVL file graphnav reads (Teledyne RDI PD0: .pd0 or .000-style)", str(path))
    config = config or SensorConfig()
    dvl, depth, meta = pd0.read_pd0(path, config)
    ds = pd0._read_rdi(path)
    geometry = pd0.pd0_geometry(config, meta).dvl
    T_d = beam_matrix(geometry.theta_rad, geometry.psi_rad)
    n_valid = dvl.valid.sum(axis=1)
    v_d = np.full((len(dvl.t), 3), np.nan)
    for pattern in np.unique(dvl.valid, axis=0):
        rows = np.all(dvl.valid == pattern, axis=1)
        if pattern.sum() >= 3:
            v_d[rows] = np.linalg.lstsq(T_d[pattern], dvl.beams[rows][:, pattern].T, rcond=None)[0].T
    v_d_valid = n_valid >= 3
    attitude = np.column_stack([np.asarray(ds[k].values, float) for k in ("heading", "pitch", "roll")]) \
        if all(k in ds for k in ("heading", "pitch", "roll")) else None
    v_n = _v_n_from_dolfyn(ds, n_valid == 4) if attitude is not None else None
    counts = {"read": int(len(dvl.t)), "valid": int(v_d_valid.sum())}
    if (~v_d_valid).any():
        counts["fewer than 3 valid bottom-track beams"] = int((~v_d_valid).sum())
    instrument = _instrument(ds)
    return DvlLog(t=dvl.t, v_d=v_d, v_d_valid=v_d_valid, frame="beam", beams=dvl.beams, beam_valid=dvl.valid,
                  attitude_deg=attitude, depth_m=None if depth is None else depth.depth, v_n=v_n,
                  three_beam=n_valid == 3, instrument=instrument, counts=counts, source=str(path))
