"""Teledyne RDI PD0 (the binary ensembles of Workhorse / Pathfinder / Pioneer / Tasman DVLs) through ``dolfyn``.

The reader is dolfyn's ``read_rdi``, as maintained inside MHKiT (``mhkit.dolfyn``; the standalone ``dolfyn``
1.3.0 on PyPI imports ``numpy.RankWarning`` and ``scipy.integrate.cumtrapz``, both removed, and does not
import with numpy 2). What graphnav takes from each ensemble:

* bottom-track beam velocities ``vel_bt`` (the PD0 bottom-track block ``0x0600``, mm/s as int16, scaled to
  m/s by dolfyn). RDI marks a beam without bottom lock with -32768 (-32.768 m/s after scaling); such beams,
  NaN and anything beyond :data:`graphnav.mission.MAX_DVL_SPEED_MPS` are invalid per beam
  (:meth:`graphnav.mission.DvlData.sanitized`). The ensemble must be in beam coordinates (``EX`` command
  bits 00); earth/instrument-coordinate files would hold velocities, not beams, and are refused;
* the clock (variable leader RTC) as the ping stamp;
* depth: the pressure sensor (dbar -> m with the configured water density), else none.

Beam geometry: dolfyn reports the beam angle (``beam_angle``, deg) and convex/concave heads; graphnav's beam
order and azimuths come from the :class:`~graphnav.config.SensorConfig` (``dvl.psi_rad``), the inclination
from the file. Sign: RDI beam velocity is positive toward the transducer (water moving toward the head),
the opposite of graphnav's "velocity of the head along the beam"; ``PD0_BEAM_SIGN`` flips it.

A PD0 file holds the DVL only: the IMU comes from the CSV column map of the configuration
(:mod:`graphnav.generic_csv`, whose ``dvl`` entry may name a PD0 file) on the same clock (Unix seconds).
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from .config import SensorConfig
from .errors import ConfigError, DataError
from .mission import DepthData, DvlData

#: RDI beam velocities are positive toward the transducer; graphnav's are the head's velocity along the beam.
PD0_BEAM_SIGN = -1.0
#: RDI's bad-velocity marker in raw counts (mm/s).
PD0_BAD = -32768


def is_pd0(path: str | Path) -> bool:
    """A ``.pd0`` file or an RDI numbered file (``.000``, ``.001``, ...)."""
    path = Path(path)
    return path.is_file() and (path.suffix.lower() == ".pd0" or re.fullmatch(r"\.\d{3}", path.suffix) is not None)


def _read_rdi(path: Path):
    try:
        from mhkit.dolfyn.io.rdi import read_rdi
    except ImportError:
        raise ConfigError("reading PD0 needs MHKiT's dolfyn: pip install 'graphnav[pd0]'") from None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")   # dolfyn's notes on missing userdata and similar
            return read_rdi(str(path), userdata=False)
    except Exception as exc:  # noqa: BLE001 - dolfyn raises plain Exceptions on corrupt files
        raise DataError(f"cannot read as PD0: {type(exc).__name__}: {exc}", str(path)) from None


def read_pd0(path: str | Path, config: SensorConfig | None = None) -> tuple[DvlData, DepthData | None, dict]:
    """Bottom-track beams (Unix-second stamps) and pressure depth of a PD0 file; also a dict of metadata."""
    path = Path(path)
    config = config or SensorConfig()
    source = str(path)
    ds = _read_rdi(path)
    if "vel_bt" not in ds:
        raise DataError("no bottom-track data (PD0 block 0x0600) in the file: is bottom tracking (BP) on?",
                        source, field="vel_bt")
    coord = str(ds.attrs.get("coord_sys", "beam")).lower()
    if coord != "beam":
        raise DataError(f"bottom track in {coord} coordinates; graphnav needs beam coordinates (EX00xxx)",
                        source, field="coord_sys")
    t = ds["time"].values.astype("datetime64[ns]").astype(np.int64) / 1e9
    vel = np.asarray(ds["vel_bt"].values, float).T           # dolfyn: (beam, time) -> (time, beam)
    if vel.shape[1] < 4:
        raise DataError(f"{vel.shape[1]} bottom-track beams; graphnav needs 4", source, field="vel_bt")
    vel = vel[:, :4]
    raw_bad = np.isclose(vel, PD0_BAD * 1e-3)
    beams = np.where(raw_bad, vel, PD0_BEAM_SIGN * vel)      # keep the flag recognisable for sanitized()
    dvl = DvlData(t, beams, np.ones_like(beams, dtype=bool), None, f"{source}:vel_bt").sanitized()
    depth = None
    if "pressure" in ds and np.any(np.asarray(ds["pressure"].values) > 0):
        # dbar is gauge pressure on RDI instruments: 1 dbar = 1e4 Pa.
        p_pa = np.asarray(ds["pressure"].values, float) * 1e4
        depth = DepthData(t.copy(), p_pa / (config.water_density_kgpm3 * config.gravity_mps2), f"{source}:pressure")
    meta = {"pd0_beam_angle_deg": float(ds.attrs.get("beam_angle", np.nan)),
            "pd0_invalid_beams": int(raw_bad.sum()), "pd0_ensembles": int(len(t)),
            "pd0_instrument": str(ds.attrs.get("inst_model", ""))}
    return dvl, depth, meta


def load_pd0(path: str | Path, config: SensorConfig | None = None):
    """A Mission from a PD0 file plus the IMU named in the configuration's CSV column map."""
    from .generic_csv import load_csv_mission
    if config is None or "imu" not in config.csv_columns:
        raise ConfigError(f"{path}: a PD0 file holds the DVL only; give the IMU in the configuration's "
                          "csv_columns map ('imu': {'file': ..., ...}, see graphnav.generic_csv)")
    return load_csv_mission(Path(path).parent, config, pd0_file=Path(path))
