"""The one mission data model shared by the simulator, the loaders, the EKF, the graph and the benchmark.

A :class:`Mission` holds time-stamped streams on one clock (the IMU's; loaders apply time offsets and
record them in the configuration), plus the :class:`~graphnav.config.SensorConfig`.

Frames: ``f_b``, ``omega_b`` in the body frame (FRD); ``beams`` are along-beam velocities of the DVL head
(m/s); ground-truth ``p_n``, ``v_n`` in local NED (m, m/s) and ``C_b_n`` body-to-NED.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .config import SensorConfig
from .errors import DataError


def _check_time(t: np.ndarray, source: str) -> None:
    if t.ndim != 1:
        raise DataError(f"time stamps must be 1-D, got shape {t.shape}", source, field="t")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise DataError("time stamp is not finite", source, int(bad[0]), "t")
    step = np.diff(t)
    bad = np.flatnonzero(step <= 0)
    if bad.size:
        kind = "duplicated" if step[bad[0]] == 0 else "out of order"
        raise DataError(f"time stamp {kind} ({t[bad[0]]:.6f} s then {t[bad[0] + 1]:.6f} s)",
                        source, int(bad[0]) + 1, "t")


def _check_array(a: np.ndarray, shape_tail: tuple, n: int, source: str, name: str,
                 finite: np.ndarray | None = None) -> None:
    if a.shape != (n,) + shape_tail:
        raise DataError(f"shape {a.shape}, expected {(n,) + shape_tail}", source, field=name)
    values_ok = np.isfinite(a)
    if finite is not None:
        values_ok |= ~finite
    bad = np.argwhere(~values_ok)
    if bad.size:
        raise DataError("value is not finite", source, int(bad[0][0]), name)


@dataclass
class ImuData:
    """IMU samples. t (N,) s; f_b (N,3) specific force, m/s^2; omega_b (N,3) angular rate, rad/s."""

    t: np.ndarray
    f_b: np.ndarray
    omega_b: np.ndarray
    source: str = "imu"

    def validate(self) -> None:
        _check_time(self.t, self.source)
        _check_array(self.f_b, (3,), len(self.t), self.source, "f_b")
        _check_array(self.omega_b, (3,), len(self.t), self.source, "omega_b")

    def take(self, idx) -> "ImuData":
        return ImuData(self.t[idx], self.f_b[idx], self.omega_b[idx], self.source)


@dataclass
class DvlData:
    """DVL pings.

    Attributes:
        t: (M,) s.
        beams: (M,4) along-beam velocity of the DVL head, m/s (NaN allowed where not valid).
        valid: (M,4) bool, True where the beam returned a usable measurement.
        v_b: optional (M,3) velocity of the DVL head in the body frame as the instrument reported it, m/s.
    """

    t: np.ndarray
    beams: np.ndarray
    valid: np.ndarray
    v_b: np.ndarray | None = None
    source: str = "dvl"

    def validate(self) -> None:
        _check_time(self.t, self.source)
        if self.valid.shape != (len(self.t), 4) or self.valid.dtype != bool:
            raise DataError(f"valid mask must be bool of shape {(len(self.t), 4)}, got "
                            f"{self.valid.dtype} {self.valid.shape}", self.source, field="valid")
        _check_array(self.beams, (4,), len(self.t), self.source, "beams", finite=self.valid)
        if self.v_b is not None:
            _check_array(self.v_b, (3,), len(self.t), self.source, "v_b",
                         finite=np.repeat(self.valid.sum(axis=1, keepdims=True) >= 3, 3, axis=1))

    def take(self, idx) -> "DvlData":
        return DvlData(self.t[idx], self.beams[idx], self.valid[idx],
                       None if self.v_b is None else self.v_b[idx], self.source)

    @property
    def n_valid(self) -> np.ndarray:
        """Number of valid beams per ping (M,)."""
        return self.valid.sum(axis=1)


@dataclass
class DepthData:
    """Depth samples: t (N,) s; depth (N,) m, positive down (NED down of the IMU)."""

    t: np.ndarray
    depth: np.ndarray
    source: str = "depth"

    def validate(self) -> None:
        _check_time(self.t, self.source)
        _check_array(self.depth, (), len(self.t), self.source, "depth")

    def take(self, idx) -> "DepthData":
        return DepthData(self.t[idx], self.depth[idx], self.source)


@dataclass
class GroundTruth:
    """Reference trajectory of the IMU.

    Attributes:
        t: (K,) s.
        p_n: (K,3) NED position relative to ``origin_lla``, m.
        v_n: (K,3) NED velocity, m/s.
        C_b_n: (K,3,3) body-to-NED rotation.
        origin_lla: (lat rad, lon rad, alt m) of the NED origin, or None when unknown (simulation).
    """

    t: np.ndarray
    p_n: np.ndarray
    v_n: np.ndarray
    C_b_n: np.ndarray
    origin_lla: tuple[float, float, float] | None = None
    source: str = "gt"

    def validate(self) -> None:
        _check_time(self.t, self.source)
        n = len(self.t)
        _check_array(self.p_n, (3,), n, self.source, "p_n")
        _check_array(self.v_n, (3,), n, self.source, "v_n")
        _check_array(self.C_b_n, (3, 3), n, self.source, "C_b_n")

    def take(self, idx) -> "GroundTruth":
        return GroundTruth(self.t[idx], self.p_n[idx], self.v_n[idx], self.C_b_n[idx],
                           self.origin_lla, self.source)

    @property
    def v_b(self) -> np.ndarray:
        """Body-frame velocity (K,3), m/s."""
        return np.einsum("kji,kj->ki", self.C_b_n, self.v_n)

    @property
    def lla(self) -> np.ndarray | None:
        """(K,3) [lat rad, lon rad, alt m] when the origin is known."""
        if self.origin_lla is None:
            return None
        from .earth import ned_to_lla
        return ned_to_lla(self.p_n, self.origin_lla)


@dataclass
class Mission:
    """One mission: IMU, DVL, optional depth and ground truth, and the sensor configuration.

    All stamps share the IMU clock. ``validate()`` is called on construction.
    """

    name: str
    imu: ImuData
    dvl: DvlData
    config: SensorConfig = field(default_factory=SensorConfig)
    gt: GroundTruth | None = None
    depth: DepthData | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check every stream; raise :class:`DataError` naming stream, index and field."""
        for stream in (self.imu, self.dvl, self.gt, self.depth):
            if stream is not None:
                stream.validate()

    @property
    def t0(self) -> float:
        return float(self.imu.t[0])

    @property
    def t1(self) -> float:
        return float(self.imu.t[-1])

    @property
    def duration(self) -> float:
        return self.t1 - self.t0

    def slice(self, t_start: float, t_end: float) -> "Mission":
        """The part of the mission with ``t_start <= t <= t_end`` (s) in every stream."""
        def sel(t):
            return (t >= t_start) & (t <= t_end)
        return dataclasses.replace(
            self,
            imu=self.imu.take(sel(self.imu.t)),
            dvl=self.dvl.take(sel(self.dvl.t)),
            gt=None if self.gt is None else self.gt.take(sel(self.gt.t)),
            depth=None if self.depth is None else self.depth.take(sel(self.depth.t)),
            meta={**self.meta, "slice": (t_start, t_end)},
        )

    def with_outage(self, *outages) -> "Mission":
        """A copy with the given :class:`~graphnav.scenarios.Outage` windows applied to the DVL valid mask."""
        valid = self.dvl.valid.copy()
        for outage in outages:
            valid &= ~outage.mask(self.dvl.t)
        dvl = dataclasses.replace(self.dvl, valid=valid)
        return dataclasses.replace(self, dvl=dvl,
                                   meta={**self.meta, "outages": [*self.meta.get("outages", []), *outages]})

    def with_dvl_valid(self, valid: np.ndarray) -> "Mission":
        """A copy with the DVL valid mask replaced (e.g. by a random dropout pattern)."""
        return dataclasses.replace(self, dvl=dataclasses.replace(self.dvl, valid=np.asarray(valid, bool)))
