"""Sensor configuration shared by the simulator, the loaders and every estimator.

Units are SI. Noise densities are continuous-time (per sqrt(Hz)); a discrete sample at rate f has
standard deviation ``density * sqrt(f)``. Frames: body b is FRD (x forward, y right, z down), n is local
NED, the DVL frame d is fixed to the body by ``C_d_b`` (DVL-to-body, ``v_b = C_d_b @ v_d``).

A configuration round-trips through JSON (:meth:`SensorConfig.save` / :meth:`SensorConfig.load`), which is
how ``graphnav calibrate`` hands calibrated values to later runs (``--config``).
"""
from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from graphnav.core.errors import ConfigError

DEG = np.pi / 180.0
DEG_PER_HOUR = DEG / 3600.0
MICRO_G = 9.80665e-6


@dataclass
class ImuSpec:
    """IMU error model. All white noise is continuous-time density; biases are 1-sigma.

    Attributes:
        name: grade name.
        accel_noise_density: accelerometer white noise (velocity random walk), m/s^2/sqrt(Hz).
        gyro_noise_density: gyro white noise (angle random walk), rad/s/sqrt(Hz).
        accel_bias_rw: accelerometer bias random walk, m/s^3/sqrt(Hz).
        gyro_bias_rw: gyro bias random walk, rad/s^2/sqrt(Hz).
        accel_bias_sigma: constant (turn-on) accelerometer bias 1-sigma, m/s^2.
        gyro_bias_sigma: constant (turn-on) gyro bias 1-sigma, rad/s.
    """

    name: str = "navigation"
    accel_noise_density: float = 20 * MICRO_G
    gyro_noise_density: float = 0.0025 * DEG / 60.0
    accel_bias_rw: float = 1e-6
    gyro_bias_rw: float = 1e-9
    accel_bias_sigma: float = 50 * MICRO_G
    gyro_bias_sigma: float = 0.01 * DEG_PER_HOUR


#: IMU grades of the simulator and of the benchmark's IMU degradation.
#: navigation: a FOG INS like the iXblue Phins; tactical: a small-AUV tactical IMU; mems: an industrial MEMS.
IMU_GRADES: dict[str, ImuSpec] = {
    "navigation": ImuSpec(),
    "tactical": ImuSpec(name="tactical", accel_noise_density=0.05 / 60.0,
                        gyro_noise_density=0.1 * DEG / 60.0, accel_bias_rw=2e-5,
                        gyro_bias_rw=1e-7, accel_bias_sigma=1e-3 * 9.80665,
                        gyro_bias_sigma=1.0 * DEG_PER_HOUR),
    "mems": ImuSpec(name="mems", accel_noise_density=0.1 / 60.0,
                    gyro_noise_density=0.3 * DEG / 60.0, accel_bias_rw=1e-4,
                    gyro_bias_rw=1e-6, accel_bias_sigma=5e-3 * 9.80665,
                    gyro_bias_sigma=10.0 * DEG_PER_HOUR),
}


def imu_grade(name: str) -> ImuSpec:
    """The :class:`ImuSpec` preset called ``name`` (navigation, tactical, mems)."""
    try:
        return dataclasses.replace(IMU_GRADES[name])
    except KeyError:
        raise ConfigError(f"unknown IMU grade '{name}'; choose one of {sorted(IMU_GRADES)}") from None


@dataclass
class DvlSpec:
    """DVL geometry and error model (``../shared/docs/method.md``).

    Beam i (index i-1 here, i = 1..4) has unit vector in the DVL frame
    ``[cos(psi_i) sin(theta), sin(psi_i) sin(theta), cos(theta)]``.

    Attributes:
        theta_rad: beam inclination from the DVL z axis, rad.
        psi_rad: beam azimuths in the DVL frame, rad (4,).
        C_d_b: DVL-to-body rotation (3,3).
        lever_arm_b: DVL position relative to the IMU in the body frame, m (3,).
        beam_noise_std: white noise of one beam measurement, m/s.
        beam_bias: bias of each beam, m/s (4,) (used to make beams; estimators do not know it).
        scale_factor: scale factor error per DVL axis, unitless (3,) (used to make beams).
        rate_hz: nominal DVL ping rate, Hz.
        velocity_scale_correction: scale error of the DVL's *reported* velocities, unitless, as measured by
            ``graphnav calibrate``; the real-data loaders divide the recorded velocities by ``1 + value``
            (0 = none). Unlike ``scale_factor`` it describes the instrument, not the synthetic beam model.
        max_speed_mps, max_vertical_mps, max_accel_mps2, jump_tolerance_mps: the vehicle's envelope; a
            reported DVL velocity (body frame) outside it is not bottom-track of this vehicle (no bottom
            lock, water-track, a decoding error) and the loaders mark the ping invalid
            (:func:`graphnav.core.dvl.implausible_pings`): speed above ``max_speed_mps`` (m/s), ``|v_z|`` above
            ``max_vertical_mps`` (m/s), or a ping that departs from the median of its neighbours by more
            than ``1.5 * max_accel_mps2 * dt + jump_tolerance_mps`` (dt: spacing to the nearest valid ping,
            s; 1.5 dt bounds the departure of a vehicle reversing its acceleration at the ping; the
            tolerance covers DVL noise). Defaults for a survey AUV such as Snapir: the ten shared A-KIT
            trajectories reach 2.78 m/s, ``|v_z|`` 0.81 m/s, 1.08 m/s between consecutive pings and 0.78
            m/s from their neighbours' median (the jump limit at 1 Hz is 2.0 m/s), and none of their pings
            is flagged (nor any of the simulated missions'); no-bottom-lock samples on real logs report
            ``|v_z|`` up to 2 m/s.
    """

    theta_rad: float = 20.0 * DEG
    psi_rad: np.ndarray = field(default_factory=lambda: np.deg2rad([45.0, 135.0, 225.0, 315.0]))
    C_d_b: np.ndarray = field(default_factory=lambda: np.eye(3))
    lever_arm_b: np.ndarray = field(default_factory=lambda: np.zeros(3))
    beam_noise_std: float = 0.042
    beam_bias: np.ndarray = field(default_factory=lambda: np.full(4, 0.01))
    scale_factor: np.ndarray = field(default_factory=lambda: np.full(3, 0.007))
    rate_hz: float = 1.0
    velocity_scale_correction: float = 0.0
    max_speed_mps: float = 4.0
    max_vertical_mps: float = 1.0
    max_accel_mps2: float = 1.0
    jump_tolerance_mps: float = 0.5

    def __post_init__(self):
        self.psi_rad = np.asarray(self.psi_rad, dtype=float).reshape(4)
        self.C_d_b = np.asarray(self.C_d_b, dtype=float).reshape(3, 3)
        self.lever_arm_b = np.asarray(self.lever_arm_b, dtype=float).reshape(3)
        self.beam_bias = np.asarray(self.beam_bias, dtype=float).reshape(4)
        self.scale_factor = np.asarray(self.scale_factor, dtype=float).reshape(3)
        if not np.allclose(self.C_d_b @ self.C_d_b.T, np.eye(3), atol=1e-6):
            raise ConfigError("dvl.C_d_b is not a rotation matrix")


@dataclass
class SensorConfig:
    """Everything an estimator needs to know about the sensors of one mission.

    Attributes:
        imu: IMU error model the estimators assume.
        dvl: DVL geometry and error model.
        imu_rate_hz: nominal IMU rate, Hz.
        lat_rad: mission latitude for gravity and Earth rate, rad.
        gravity_mps2: gravity magnitude at the navigation origin, m/s^2 (down in NED); elsewhere the Earth
            model (:class:`graphnav.core.earth.EarthModel`) adds its change with position.
        earth_rotation: whether Earth rotation is modelled (IMU simulation and estimators).
        gravity_variation: whether gravity varies with position (tilts with the distance from the origin,
            grows with depth); False: the constant ``[0, 0, gravity_mps2]`` of a flat Earth (17 m in 400 s of
            free inertial navigation at 2 m/s), kept to measure what the variation is worth.
        dvl_time_offset_s: offset already added to the raw DVL stamps to put them on the IMU clock, s.
        gt_time_offset_s: offset already added to the raw ground-truth stamps, s.
        imu_axis_signs: signs already applied to the raw IMU axes (x, y, z) to make them FRD.
        depth_noise_std: depth sensor white noise, m.
        water_density_kgpm3: water density for depth from pressure (bags, PD0, CSV), kg/m^3 (1025: sea water).
        atmospheric_pressure_pa: surface pressure subtracted from an absolute pressure reading, Pa.
        csv_columns: column map of a team's own CSV logs (:mod:`graphnav.io.generic_csv`); empty when unused.
    """

    imu: ImuSpec = field(default_factory=ImuSpec)
    dvl: DvlSpec = field(default_factory=DvlSpec)
    imu_rate_hz: float = 100.0
    lat_rad: float = 32.85 * DEG
    gravity_mps2: float = 9.7949
    earth_rotation: bool = True
    gravity_variation: bool = True
    dvl_time_offset_s: float = 0.0
    gt_time_offset_s: float = 0.0
    imu_axis_signs: np.ndarray = field(default_factory=lambda: np.ones(3))
    depth_noise_std: float = 0.05
    water_density_kgpm3: float = 1025.0
    atmospheric_pressure_pa: float = 101325.0
    csv_columns: dict = field(default_factory=dict)

    def __post_init__(self):
        self.imu_axis_signs = np.asarray(self.imu_axis_signs, dtype=float).reshape(3)

    # --- JSON round trip -------------------------------------------------------------------------
    def to_dict(self) -> dict:
        def plain(obj):
            if dataclasses.is_dataclass(obj):
                return {f.name: plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
            if isinstance(obj, np.ndarray):
                return obj.tolist()
            return obj
        return plain(self)

    @classmethod
    def from_dict(cls, data: dict, source: str = "<config>") -> "SensorConfig":
        data = dict(data)
        try:
            imu = ImuSpec(**data.pop("imu", {}))
            dvl = DvlSpec(**data.pop("dvl", {}))
            return cls(imu=imu, dvl=dvl, **data)
        except TypeError as exc:
            raise ConfigError(f"{source}: {exc}") from None

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=2) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> "SensorConfig":
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ConfigError(f"{path}: cannot read configuration: {exc}") from None
        return cls.from_dict(data, source=str(path))
