"""Teledyne RDI PD0 (the binary ensembles of Workhorse / Pathfinder / Pioneer / Tasman DVLs) through ``dolfyn``.

The reader is dolfyn's ``read_rdi``, as maintained inside MHKiT (``mhkit.dolfyn``; the standalone ``dolfyn``
1.3.0 on PyPI imports ``numpy.RankWarning`` and ``scipy.integrate.cumtrapz``, both removed, and does not
import with numpy 2). What graphnav takes from each ensemble:

* bottom-track beam velocities ``vel_bt`` (the PD0 bottom-track block ``0x0600``, mm/s as int16, scaled to
  m/s by dolfyn). RDI marks a beam without bottom lock with -32768 (-32.768 m/s after scaling); such beams,
  NaN and anything beyond :data:`graphnav.core.mission.MAX_DVL_SPEED_MPS` are invalid per beam
  (:meth:`graphnav.core.mission.DvlData.sanitized`). The ensemble must be in beam coordinates (``EX`` command
  bits 00); earth/instrument-coordinate files would hold velocities, not beams, and are refused;
* the clock (variable leader RTC) as the ping stamp. dolfyn keeps an ensemble only when another header
  follows it (it treats the end of a file as a possibly cut-off ensemble), so a file's last ping is lost;
* depth: the pressure sensor (dbar -> m with the configured water density), else none.

Beam geometry and sign, from the RDI coordinate-transformation formulae (P/N 951-6079-00, section 5:
``u = c a (B1 - B2)``, ``v = c a (B4 - B3)``, ``w = -b (B1 + B2 + B3 + B4)``, beam velocity positive toward
the transducer, c = 1 convex / -1 concave): the beams point along +z of the RDI instrument frame, beam 1/2
along -x/+x and 3/4 along +y/-y for a convex head (mirrored for concave). For bottom track the "water" is
the seabed, whose velocity relative to the head is ``-v``; "toward the transducer" along an outward beam
``u_i`` is then ``(-v) . (-u_i) = v . u_i``: exactly graphnav's beam (the head's velocity along the
beam), so the values are taken as they are. The loader sets ``dvl.theta_rad`` from the file's beam angle
and ``dvl.psi_rad`` from the head pattern (convex: 180, 0, 90, 270 deg); ``dvl.C_d_b`` of the configuration
must therefore turn the RDI instrument frame into the body frame (e.g. a 45 deg yaw for a head mounted
with beam 3 at 45 deg to starboard of forward).

A PD0 file holds the DVL only: the IMU comes from the CSV column map of the configuration
(:mod:`graphnav.io.generic_csv`, whose ``dvl`` entry may name a PD0 file) on the same clock (Unix seconds).
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.mission import DepthData, DvlData

#: Beam azimuths (deg) of the RDI instrument frame by head pattern (see the module docstring).
RDI_PSI_DEG = {"convex": (180.0, 0.0, 90.0, 270.0), "concave": (0.0, 180.0, 270.0, 90.0)}
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
    vel[raw_bad] = PD0_BAD * 1e-3     # dolfyn's float32 scaling leaves -32.76800003; the exact flag is counted
    # Every beam is offered as valid; sanitized() turns RDI's flag (and NaN, out-of-range) into invalid, with a
    # warning that counts them.
    dvl = DvlData(t, vel, np.ones_like(vel, dtype=bool), None, f"{source}:vel_bt").sanitized()
    depth = None
    if "pressure" in ds and np.any(np.asarray(ds["pressure"].values) > 0):
        # dbar is gauge pressure on RDI instruments: 1 dbar = 1e4 Pa.
        p_pa = np.asarray(ds["pressure"].values, float) * 1e4
        depth = DepthData(t.copy(), p_pa / (config.water_density_kgpm3 * config.gravity_mps2), f"{source}:pressure")
    pattern = str(ds.attrs.get("beam_pattern", "convex"))
    meta = {"pd0_beam_angle_deg": float(ds.attrs.get("beam_angle", np.nan)), "pd0_beam_pattern": pattern,
            "pd0_invalid_beams": int(raw_bad.sum()), "pd0_ensembles": int(len(t)),
            "pd0_instrument": str(ds.attrs.get("inst_model", ""))}
    return dvl, depth, meta


def pd0_geometry(config: SensorConfig, meta: dict) -> SensorConfig:
    """A copy of ``config`` with the beam inclination and azimuths of the PD0 file (see the module docstring)."""
    import dataclasses
    theta = meta["pd0_beam_angle_deg"]
    if not np.isfinite(theta) or theta <= 0:
        return config
    psi = RDI_PSI_DEG.get(meta["pd0_beam_pattern"], RDI_PSI_DEG["convex"])
    dvl = dataclasses.replace(config.dvl, theta_rad=float(np.deg2rad(theta)), psi_rad=np.deg2rad(psi))
    return dataclasses.replace(config, dvl=dvl)
