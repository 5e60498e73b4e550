"""Training and evaluation data of the IMU-aware beam completer: A-KIT trajectories with IMU and DVL.

Each trajectory is loaded with :func:`graphnav.missions.load_akit` (IMU and DVL on the IMU clock, the DVL time
offset estimated, the IMU y axis corrected). Beams are made from the recorded DVL velocities with the DVL
error model (:func:`graphnav.core.dvl.make_beams`, default :class:`~graphnav.core.config.DvlSpec`, seed
``beam_seed + 100 * draw + N`` for trajectory N), as the loader does. A sample at ping k is the beam-only
sample of :mod:`graphnav.nets.data` plus the IMU window of the last ``n_imu`` samples up to the ping,
preintegrated (:func:`graphnav.nets.imu_window.preintegrate`).

The split is by trajectory (:data:`AKIT_SPLIT`): the validation trajectories are never trained on.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from graphnav.core.config import DvlSpec, imu_grade
from graphnav.core.dvl import make_beams
from graphnav.core.errors import DataError
from graphnav.core.mission import ImuData
from graphnav.missions import load_akit
from graphnav.sim.imu_errors import corrupt_imu

from .data import BeamSamples, _data_dir
from .imu_window import IMU_RATE_HZ, IMU_WINDOW_S, ImuFeatures, preintegrate

#: Split of the ten shared A-KIT trajectories (data README: 2, 3, 10, 13 steady at ~15 m; 1, 4, 6, 8 change
#: depth and speed; 5 has many turns; 11 starts at the surface, speeds down to 0.2 m/s). Validation takes
#: one of each of the first three kinds; 8 (the most turning: |yaw rate| > 2 deg/s half of the time) and
#: 11 (the only slow one) stay in training.
AKIT_SPLIT = {"train": (1, 2, 4, 8, 10, 11, 13), "val": (3, 5, 6)}


@dataclass
class ImuBeamSeries:
    """One trajectory: pings (``t`` (K,) s, ``v_b`` (K, 3) true DVL velocity, ``beams`` (K, 4), m/s) and the
    IMU stream (``f_b``, ``omega_b`` (M, 3)); ``imu_end[k]`` is the last IMU sample at or before ping k."""

    name: str
    t: np.ndarray
    v_b: np.ndarray
    beams: np.ndarray
    f_b: np.ndarray
    omega_b: np.ndarray
    imu_end: np.ndarray
    imu_rate_hz: float = IMU_RATE_HZ

    def imu_window(self, k: int, n_imu: int) -> tuple[np.ndarray, np.ndarray]:
        """``(f_b, omega_b)`` of the last ``n_imu`` IMU samples up to ping k (what an estimator passes)."""
        i1 = int(self.imu_end[k]) + 1
        if i1 < n_imu:
            raise DataError(f"ping {k}: only {i1} IMU samples before it, the window needs {n_imu}", self.name)
        return self.f_b[i1 - n_imu:i1], self.omega_b[i1 - n_imu:i1]

    def usable(self, n_past: int, n_imu: int) -> np.ndarray:
        """Pings with ``n_past`` finite pings before them, a finite ping and a full IMU window."""
        finite = np.all(np.isfinite(self.beams), axis=1)
        ok = np.zeros(len(self.beams), bool)
        for k in range(n_past, len(self.beams)):
            ok[k] = finite[k - n_past:k + 1].all() and self.imu_end[k] + 1 >= n_imu
        return ok

    def tail(self, fraction: float) -> "ImuBeamSeries":
        """The last ``fraction`` of the pings (the IMU stream is kept whole, so every window stays full)."""
        cut = int(round((1.0 - fraction) * len(self.beams)))
        return ImuBeamSeries(self.name, self.t[cut:], self.v_b[cut:], self.beams[cut:], self.f_b, self.omega_b,
                             self.imu_end[cut:], self.imu_rate_hz)

    def with_beams(self, beams: np.ndarray) -> "ImuBeamSeries":
        return ImuBeamSeries(self.name, self.t, self.v_b, beams, self.f_b, self.omega_b, self.imu_end,
                             self.imu_rate_hz)

    def with_imu_grade(self, grade: str, seed: int) -> "ImuBeamSeries":
        """A copy whose IMU stream carries the errors of IMU grade ``grade`` (:data:`graphnav.core.config.IMU_GRADES`,
        added by :func:`graphnav.sim.imu_errors.corrupt_imu` with ``seed``) on top of the recorded IMU's own."""
        imu = ImuData(np.arange(len(self.f_b)) / self.imu_rate_hz, self.f_b, self.omega_b, source=self.name)
        bad, _ = corrupt_imu(imu, imu_grade(grade), seed, rate_hz=self.imu_rate_hz)
        return ImuBeamSeries(self.name, self.t, self.v_b, self.beams, bad.f_b, bad.omega_b, self.imu_end,
                             self.imu_rate_hz)


@dataclass
class ImuBeamSamples(BeamSamples):
    """:class:`BeamSamples` plus the preintegrated IMU window of each sample (``imu``)."""

    imu: ImuFeatures | None = None

    @staticmethod
    def concatenate(parts: list["ImuBeamSamples"]) -> "ImuBeamSamples":
        return ImuBeamSamples(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("past", "beams", "v_b")),
                              imu=ImuFeatures.concatenate([p.imu for p in parts]))


def graded_series(series: list[ImuBeamSeries], grade: str | None, seed: int) -> list[ImuBeamSeries]:
    """``series`` with IMU grade ``grade``'s errors added to each one's IMU (seed ``seed`` + its trajectory
    number, :meth:`ImuBeamSeries.with_imu_grade`); ``grade`` None or ``"recorded"``: ``series`` as they are."""
    if grade is None or grade == "recorded":
        return list(series)
    return [s.with_imu_grade(grade, seed + int(s.name.removeprefix("Trajectory"))) for s in series]


def akit_imu_series(numbers, data_dir: str | Path | None = None, beam_seed: int = 0, draw: int = 0,
                    spec: DvlSpec | None = None) -> list[ImuBeamSeries]:
    """The A-KIT trajectories ``numbers`` (e.g. ``AKIT_SPLIT["val"]``) with beams of noise draw ``draw``."""
    d = _data_dir(data_dir, "akit")
    spec = spec or DvlSpec()
    out = []
    for number in numbers:
        folder = d / f"Trajectory{number}"
        if not folder.is_dir():
            raise DataError(f"trajectory folder {folder.name} not found", str(d))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)    # the loader's warnings are its own tests' business
            m = load_akit(folder)
        v = m.dvl.v_b
        rate = 1.0 / float(np.median(np.diff(m.imu.t)))
        beams = np.full((len(v), 4), np.nan)
        ok = np.all(np.isfinite(v), axis=1)
        beams[ok] = make_beams(v[ok], spec, beam_seed + 100 * draw + number)
        imu_end = np.searchsorted(m.imu.t, m.dvl.t, side="right") - 1
        out.append(ImuBeamSeries(folder.name, m.dvl.t, v, beams, m.imu.f_b, m.imu.omega_b, imu_end, rate))
    return out


def imu_windows(series: ImuBeamSeries | list[ImuBeamSeries], n_past: int, n_imu: int,
                ping_dt: float = 1.0, pings: slice | None = None) -> ImuBeamSamples:
    """All usable samples of ``series`` (optionally only pings in ``pings``), IMU preintegrated."""
    series = [series] if isinstance(series, ImuBeamSeries) else series
    parts = []
    for s in series:
        ok = s.usable(n_past, n_imu)
        if pings is not None:
            sel = np.zeros_like(ok)
            sel[pings] = True
            ok &= sel
        k = np.flatnonzero(ok)
        if k.size == 0:
            continue
        idx = (s.imu_end[k] + 1)[:, None] - n_imu + np.arange(n_imu)
        parts.append(ImuBeamSamples(s.beams[k[:, None] - n_past + np.arange(n_past)], s.beams[k], s.v_b[k],
                                    preintegrate(s.f_b[idx], s.omega_b[idx], n_past, s.imu_rate_hz, ping_dt)))
    if not parts:
        raise DataError(f"no series has a usable ping (n_past={n_past}, IMU window {n_imu})", "beam samples")
    return ImuBeamSamples.concatenate(parts)


def n_imu_samples(window_s: float = IMU_WINDOW_S, rate_hz: float = IMU_RATE_HZ) -> int:
    """Number of IMU samples in a window of ``window_s`` seconds at ``rate_hz``."""
    return int(round(window_s * rate_hz))
