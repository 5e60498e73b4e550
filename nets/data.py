"""Training and evaluation data of the missing-beam regressor.

Beams are made from recorded DVL velocities (body frame, m/s, 1 Hz) with the DVL error model
(:func:`graphnav.core.dvl.make_beams`, seeded), as in the paper. One sample at ping k is
``past = beams[k-N:k]`` (N, 4), ``measured = beams[k, kept]`` and ``target = beams[k, missing]``, with the
true DVL velocity ``v = V[k]`` for the velocity metric. Samples never span two recordings, nor the
train/validation split of ``V.npy`` (first 75 % train, last 25 % validation, the published split).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import make_beams
from graphnav.core.errors import DataError
from graphnav.io import paths
from graphnav.io.loaders import (
    AKIT_COLUMNS,
    BEAMSNET_TRAIN_FRACTION,
    akit_files,
    list_akit,
    load_beamsnet,
    read_csv,
)

TRAIN_FRACTION = BEAMSNET_TRAIN_FRACTION

#: Yaw (deg, about body z) that turns the BeamsNet velocities into the vehicle body frame. In ``V.npy`` the
#: horizontal velocity points at -44.8 deg (median course over pings faster than 0.5 m/s; 5-95 %: -59 to
#: -38 deg), while the A-KIT body-frame DVL velocities of the same vehicle point at -1.6 deg (-17 to 15):
#: the BeamsNet files are in a frame turned 45 deg from the body (the DVL mounting). Beams made from the
#: unrotated file would teach the network a velocity direction the estimators never see.
BEAMSNET_YAW_DEG = 45.0

#: Ping rate (Hz) of the recordings the networks are trained on: the A-KIT and BeamsNet DVLs ping at 1 Hz.
RECORDED_PING_RATE_HZ = 1.0


def training_spec(spec: DvlSpec | None = None) -> DvlSpec:
    """The DVL the training beams are made for: ``spec``'s beams and errors (default :class:`DvlSpec`, the Snapir's)
    at the recordings' ping rate, :data:`RECORDED_PING_RATE_HZ` (the beams come from their velocities, one a ping,
    whatever the rate of the DVL they are made for): what a model card records and the estimators bind to."""
    return dataclasses.replace(spec or DvlSpec(), rate_hz=RECORDED_PING_RATE_HZ)


@dataclass
class BeamSeries:
    """One continuous recording: true DVL velocity ``v_b`` (K, 3) and the beams made from it (K, 4), m/s."""

    name: str
    v_b: np.ndarray
    beams: np.ndarray


@dataclass
class BeamSamples:
    """Windowed samples of one or more series (all m/s).

    Attributes:
        past: (S, N, 4) the N full beam vectors before the ping, oldest first.
        beams: (S, 4) the full beam vector of the ping (measured and would-be-missing beams).
        v_b: (S, 3) the true DVL velocity of the ping.
    """

    past: np.ndarray
    beams: np.ndarray
    v_b: np.ndarray

    def __len__(self) -> int:
        return len(self.beams)


def windows(series: BeamSeries | list[BeamSeries], n_past: int) -> BeamSamples:
    """All samples with a full window of ``n_past`` past pings inside each series."""
    series = [series] if isinstance(series, BeamSeries) else series
    past, beams, v = [], [], []
    for s in series:
        k = np.arange(n_past, len(s.beams))
        if k.size == 0:
            continue
        past.append(s.beams[k[:, None] - n_past + np.arange(n_past)])
        beams.append(s.beams[k])
        v.append(s.v_b[k])
    if not past:
        raise DataError(f"no series is longer than n_past={n_past} pings", "beam samples")
    return BeamSamples(np.concatenate(past), np.concatenate(beams), np.concatenate(v))


def _load_velocities(folder: Path, key: str) -> np.ndarray:
    """``V`` or ``V_test`` of the BeamsNet folder as (K, 3), read and checked by the project loader."""
    return load_beamsnet(folder)[key].T.copy()


def _data_dir(data_dir: str | Path | None, which: str) -> Path:
    if data_dir is not None:
        return Path(data_dir)
    d = paths.beamsnet_dir() if which == "beamsnet" else paths.akit_dir()
    if d is None:
        raise DataError(f"{which} data folder not found; set GRAPHNAV_DATA or pass the folder", which)
    return d


def yaw_rotation(yaw_deg: float) -> np.ndarray:
    """Rotation about z by ``yaw_deg`` (3,3): ``v_body = R @ v``."""
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def beamsnet_series(split: str, data_dir: str | Path | None = None, seed: int = 0,
                    spec: DvlSpec | None = None, align_yaw_deg: float = BEAMSNET_YAW_DEG) -> BeamSeries:
    """The BeamsNet May 2021 data as one beam series.

    Args:
        split: ``train`` (first 75 % of ``V.npy``), ``val`` (last 25 %), ``all`` (``V.npy`` whole) or
            ``test`` (``V_test.npy``).
        seed: seed of the beam noise; the beams of ``V.npy`` are made once and then split, so train and
            validation come from one noise draw whatever the split.
        align_yaw_deg: yaw applied to the velocities before making beams (see ``BEAMSNET_YAW_DEG``);
            0 keeps the files' frame, as the paper did.
    """
    d = _data_dir(data_dir, "beamsnet")
    spec = spec or DvlSpec()
    rot = yaw_rotation(align_yaw_deg)
    if split == "test":
        v = _load_velocities(d, "V_test") @ rot.T
        return BeamSeries("V_test", v, make_beams(v, spec, seed))
    v = _load_velocities(d, "V") @ rot.T
    beams = make_beams(v, spec, seed)
    cut = int(TRAIN_FRACTION * len(v))         # as graphnav.io.loaders.beamsnet_split
    if split == "all":
        return BeamSeries("V", v, beams)
    if split == "train":
        return BeamSeries("V[:75%]", v[:cut], beams[:cut])
    if split == "val":
        return BeamSeries("V[75%:]", v[cut:], beams[cut:])
    raise DataError(f"unknown split '{split}'; choose train, val, all or test", "beamsnet", field="split")


def akit_series(data_dir: str | Path | None = None, seed: int = 0,
                spec: DvlSpec | None = None) -> list[BeamSeries]:
    """Beams made from the DVL velocities of every A-KIT trajectory (``TrajectoryN/DVL_trajectoryN.csv``).

    The DVL files hold the measured DVL velocity in the body frame (read and checked by
    :func:`graphnav.io.loaders.read_csv`); each trajectory gets its own noise draw (``seed + N``). Invalid
    (NaN) pings split a trajectory into separate series, so no window spans a gap.
    """
    d = _data_dir(data_dir, "akit")
    spec = spec or DvlSpec()
    out = []
    for traj in list_akit(d):
        number = int(traj.name.removeprefix("Trajectory"))
        dvl = read_csv(akit_files(traj)["DVL"], AKIT_COLUMNS["DVL"], nan_ok=AKIT_COLUMNS["DVL"][1:])
        v = dvl[:, 1:4]
        beams = make_beams(v, spec, seed + number)
        ok = np.all(np.isfinite(v), axis=1)
        edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
        for part, (i0, i1) in enumerate(zip(edges[::2], edges[1::2])):
            name = traj.name if part == 0 else f"{traj.name}#{part}"
            out.append(BeamSeries(name, v[i0:i1], beams[i0:i1]))
    if not out:
        raise DataError("no TrajectoryN folder with IMU, DVL and GT files found", str(d))
    return out
