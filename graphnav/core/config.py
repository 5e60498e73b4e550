"""Sensor configuration shared by the simulator, the loaders and every estimator.

Units are SI. Noise densities are continuous-time (per sqrt(Hz)); a discrete sample at rate f has
standard deviation ``density * sqrt(f)``. Frames: body b is FRD (x forward, y right, z down), n is local
NED, the DVL frame d is fixed to the body by ``C_d_b`` (DVL-to-body, ``v_b = C_d_b @ v_d``).

A configuration round-trips through JSON (:meth:`SensorConfig.save` / :meth:`SensorConfig.load`), which is
how ``graphnav calibrate`` hands calibrated values to later runs (``--config``).

A configuration file is checked like input: every key against :data:`SCHEMA` (type, shape, range, unit),
unknown keys refused with a did-you-mean. A file may be partial: :func:`read_config` returns only the keys
it sets (:class:`ConfigOverrides`), and the loader lays them over its own defaults key by key
(``{}`` = no configuration).
"""
from __future__ import annotations

import dataclasses
import difflib
import inspect
import json
import math
import re
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
        accel_range_mps2: full scale of the accelerometers (per axis), m/s^2. A sample beyond it is not a
            measurement (a decoding error, a unit mix-up, a saturated sensor) and is refused
            (:mod:`graphnav.core.screening`). Default 16 g: the +-10..20 g full scale of the FOG and MEMS IMUs
            AUVs carry; an AUV's own accelerations are well under 1 g.
        gyro_range_rads: full scale of the gyros (per axis), rad/s; default 500 deg/s (AUV IMUs: 300-1000
            deg/s; an AUV turns at a few deg/s).
        accel_spike_floor_mps2: smallest departure of an accelerometer sample from the running median of its
            neighbours that is refused as a spike, m/s^2 (the spike test, :func:`graphnav.core.screening.imu_spikes`,
            refuses beyond the larger of this floor and 30 times the signal's local noise). Default 5 m/s^2, 14
            times the largest departure on the ten A-KIT trajectories (docs/decisions/screening.md); raise it for
            a vehicle whose vibration or shocks really jump this far from one sample to the next (a shock that
            rises over samples, each within the limit of the one before, is kept).
        gyro_spike_floor_rads: the same floor for the gyros, rad/s; default 0.1 rad/s (5.7 deg/s), 4.2 times the
            departure closest to its limit on the ten A-KIT trajectories.
    """

    name: str = "navigation"
    accel_noise_density: float = 20 * MICRO_G
    gyro_noise_density: float = 0.0025 * DEG / 60.0
    accel_bias_rw: float = 1e-6
    gyro_bias_rw: float = 1e-9
    accel_bias_sigma: float = 50 * MICRO_G
    gyro_bias_sigma: float = 0.01 * DEG_PER_HOUR
    accel_range_mps2: float = 16 * 9.80665
    gyro_range_rads: float = 500 * DEG
    accel_spike_floor_mps2: float = 5.0
    gyro_spike_floor_rads: float = 0.1


#: Where a simulated DVL's beam biases and scale factors come from (``graphnav.sim.simulate.simulate_mission``'s
#: ``dvl_errors``): the :class:`DvlSpec`'s values, or drawn per seed with them as sigmas.
DVL_ERROR_SOURCES = ("spec", "drawn")

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
    ``[cos(psi_i) sin(theta), sin(psi_i) sin(theta), cos(theta)]``: the right-handed frame ``d`` of
    :mod:`graphnav.core.dvl` (z along the beams' side; for an RDI head x toward beam 3, y toward beam 2, a
    convex head at psi = 270, 90, 0, 180 deg). ``C_d_b`` must be a rotation (det +1).

    Attributes:
        theta_rad: beam inclination from the DVL z axis, rad.
        psi_rad: beam azimuths in the DVL frame, rad (4,).
        C_d_b: DVL-to-body rotation (3,3).
        lever_arm_b: DVL position relative to the IMU in the body frame, m (3,).
        beam_noise_std: white noise of one beam measurement, m/s.
        beam_bias: bias of each beam, m/s (4,) (used to make beams; estimators do not know it).
        scale_factor: scale factor error per DVL axis, unitless (3,) (used to make beams).
        rate_hz: nominal DVL ping rate, Hz.
        velocity_noise_std: (3,) one-sigma per DVL axis (m/s) of a DVL-frame velocity ``v_d`` the instrument
            reports itself (``DvlData.v_d``, ``Navigator.add_dvl_velocity``) when a ping carries no sigma of its
            own; None (default): the four-beam least-squares sigma from ``beam_noise_std`` and the beam
            geometry (:meth:`graphnav.core.dvl.DvlGeometry.velocity_sigma_d`: 0.087, 0.087, 0.022 m/s for the
            defaults), the noise of the solution the instrument computes from the same beams.
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
    velocity_noise_std: np.ndarray | None = None
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
        if self.velocity_noise_std is not None:
            self.velocity_noise_std = np.broadcast_to(np.asarray(self.velocity_noise_std, dtype=float), (3,)).copy()
            if not np.all(np.isfinite(self.velocity_noise_std) & (self.velocity_noise_std > 0)):
                raise ConfigError(f"dvl.velocity_noise_std must be > 0 (m/s), got {self.velocity_noise_std.tolist()}")
        if not np.allclose(self.C_d_b @ self.C_d_b.T, np.eye(3), atol=1e-6):
            raise ConfigError("dvl.C_d_b is not a rotation matrix (its rows are not orthonormal)")
        if np.linalg.det(self.C_d_b) < 0:
            # An orthogonal matrix with det -1 is a reflection: it would mirror every DVL velocity (a DVL frame
            # taken as left-handed, e.g. an instrument's z axis flipped without turning another axis).
            raise ConfigError("dvl.C_d_b has determinant -1: a reflection, not a rotation; the DVL frame d is "
                              "right-handed (docs/decisions/dvl-frame.md), flip two axes or none")
        if not 0.0 < self.theta_rad < np.pi / 2:
            raise ConfigError(f"dvl.theta_rad = {self.theta_rad:g}: beams point along +z of the DVL frame, so the "
                              "inclination must be in (0, pi/2) rad")


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
        dvl_time_offset_s: offset already added to the raw DVL stamps to put them on the IMU clock, s; in a
            configuration file the offset to add. None (null, the default): not given, found from the data when the
            mission is prepared; a mission's configuration holds the offset added (0 before it is prepared).
        gt_time_offset_s: offset already added to the raw ground-truth stamps, s; None as for ``dvl_time_offset_s``.
        reference_position_b: position of the ground truth's (reference's) measurement point relative to the IMU,
            body frame, m (3,): the prepare step moves the reference by its negative to the IMU point, the point
            the estimators navigate, so that velocities are scored at one point (a reference 1.8 m from the IMU
            differs by omega x r, ~0.09 m/s in turns). ``graphnav calibrate`` writes it. None: the format's own,
            an A-KIT folder's the vehicle's (``AKIT_IMU_POSITION_B``), every other format's the IMU point itself.
        imu_axis_signs: signs already applied to the raw IMU axes (x, y, z) to make them FRD; in a configuration
            file the signs to apply (A-KIT folders, column-map logs and bags). None (null, the default): not given,
            detected when the mission is prepared; a mission's configuration holds the signs applied (1, 1, 1 before
            it is prepared).
        depth_noise_std: depth sensor white noise, m.
        water_density_kgpm3: water density for depth from pressure (bags, PD0, CSV), kg/m^3 (1025: sea water).
        atmospheric_pressure_pa: surface pressure subtracted from an absolute pressure reading, Pa.
        csv_columns: column map of a team's own CSV logs (:mod:`graphnav.io.generic_csv`); empty when unused.
        bag_topics: per stream of a ROS bag, what its messages cannot say (:mod:`graphnav.io.bags`,
            :data:`BAG_TOPIC_KEYS`): ``{"depth": {"positive": "up"}}`` declares a depth topic positive up (negated on
            reading), as ``csv_columns.depth.positive`` does for a column; ``{"dvl": {"topic": ..., "v_b":
            "velocity", ...}}`` names the fields of a DVL recorded in a vendor's own message type
            (:mod:`graphnav.io.bag_fields`); empty when unused.
        depth_range_m: (shallowest, deepest) depth the pressure sensor can report, m (positive down). The
            shallow end allows an uncompensated atmospheric pressure or a sensor above the waterline at the
            surface (-10 m); the deep end is the 6000 m rating of deep AUVs. Outside: refused.
        depth_jump_tolerance_m: a depth departing from the median of its neighbours by more than
            ``1.5 * dvl.max_vertical_mps * dt`` plus this (m) is a spike and refused (the sensor's noise and
            waves at the surface are well under it).
    """

    imu: ImuSpec = field(default_factory=ImuSpec)
    dvl: DvlSpec = field(default_factory=DvlSpec)
    imu_rate_hz: float = 100.0
    lat_rad: float = 32.85 * DEG
    gravity_mps2: float = 9.7949
    earth_rotation: bool = True
    gravity_variation: bool = True
    dvl_time_offset_s: float | None = None
    gt_time_offset_s: float | None = None
    reference_position_b: np.ndarray | None = None
    imu_axis_signs: np.ndarray | None = None
    depth_noise_std: float = 0.05
    water_density_kgpm3: float = 1025.0
    atmospheric_pressure_pa: float = 101325.0
    csv_columns: dict = field(default_factory=dict)
    bag_topics: dict = field(default_factory=dict)
    depth_range_m: tuple = (-10.0, 6000.0)
    depth_jump_tolerance_m: float = 1.0

    def __post_init__(self):
        self.depth_range_m = tuple(float(x) for x in self.depth_range_m)
        if len(self.depth_range_m) != 2 or not self.depth_range_m[0] < self.depth_range_m[1]:
            raise ConfigError(f"depth_range_m must be (shallowest, deepest), got {self.depth_range_m}")
        if self.imu_axis_signs is not None:
            self.imu_axis_signs = np.asarray(self.imu_axis_signs, dtype=float).reshape(3)
        if self.reference_position_b is not None:
            self.reference_position_b = np.asarray(self.reference_position_b, dtype=float).reshape(3)

    def as_applied(self) -> "SensorConfig":
        """This configuration with what is not given (:data:`FOUND_WHEN_PREPARED` None) as nothing applied yet:
        offsets 0 s, axis signs (1, 1, 1); a mission holds its configuration so (:class:`graphnav.core.mission.
        Mission`), ``prepare`` then records what it added."""
        unset = {key: NOTHING_APPLIED[key]() for key in FOUND_WHEN_PREPARED if getattr(self, key) is None}
        return dataclasses.replace(self, **unset) if unset else self

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
    def from_dict(cls, data, source: str = "<config>") -> "SensorConfig":
        """A configuration from a (possibly partial) dict of JSON values laid over the defaults, checked
        against :data:`SCHEMA` (:class:`ConfigError` naming ``source`` and the key on a bad value)."""
        return ConfigOverrides.parse(data, source).over(cls())

    def save(self, path: str | Path) -> None:
        """Write the configuration as JSON, whole or not at all (a temporary file renamed into place)."""
        import os
        path = Path(path)
        tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
        tmp.write_text(json.dumps(self.to_dict(), indent=2) + "\n")
        os.replace(tmp, path)

    @classmethod
    def load(cls, path: str | Path) -> "SensorConfig":
        """The configuration of a JSON file laid over the defaults of :class:`SensorConfig` (a loader lays
        it over its own defaults instead: :func:`read_config`)."""
        return read_config(path).over(cls())


# --- the schema of a configuration file ----------------------------------------------------------------------
@dataclass(frozen=True)
class Key:
    """What one configuration key holds.

    Attributes:
        kind: ``number``, ``bool``, ``text``, ``vector`` (numbers, ``size`` of them), ``rotation`` (3x3
            rotation matrix), ``signs`` (three of -1 / +1) or ``object`` (a JSON object).
        unit: SI unit (empty when unitless).
        low, high: allowed range of a number (or of each element of a vector), None = unbounded.
        low_open: ``low`` itself is not allowed (strictly positive quantities).
        size: number of elements of a vector.
        nullable: JSON ``null`` is allowed (the default derived from other keys).
    """

    kind: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    size: int = 0
    nullable: bool = False

    def expected(self) -> str:
        """The expected value in words, e.g. ``a number > 0 (rad/s/sqrt(Hz))``."""
        what = {"number": "a number", "bool": "true or false", "text": "a string",
                "vector": f"a list of {self.size} numbers", "rotation": "a 3x3 rotation matrix (3 lists of 3)",
                "signs": "a list of 3 signs, each -1 or 1", "object": "a JSON object"}[self.kind]
        if self.low is not None and self.high is not None:
            what += f" in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}]"
        elif self.low is not None:
            what += f" {'>' if self.low_open else '>='} {self.low:g}"
        elif self.high is not None:
            what += f" <= {self.high:g}"
        if self.kind == "vector" and (self.low is not None or self.high is not None):
            what += " each"
        return what + (f" ({self.unit})" if self.unit else "") + (" or null" if self.nullable else "")


_POSITIVE = {"low": 0.0, "low_open": True}
_NON_NEGATIVE = {"low": 0.0}
#: Largest time offset of a configuration, s: a file's clock may be days from the IMU's, or Unix time beside an IMU
#: file that starts at 0 (the prepare step's clock checks find such offsets and calibrate writes them), so any offset
#: a stamp can have (:data:`graphnav.core.screening.MAX_STAMP_S`). It was an hour, which refused writing the offset
#: of a DVL or GT three days away.
TIME_OFFSET_MAX_S = 1e10

#: Every key of a configuration file (``section.field`` for the IMU and DVL specs): type, unit and range.
#: Ranges refuse what cannot be a sensor of an AUV (a negative noise density, a 5000 m lever arm), not merely
#: unusual values. The meaning of each key is the dataclass docstring (:func:`describe`).
SCHEMA: dict[str, Key] = {
    "imu.name": Key("text"),
    "imu.accel_noise_density": Key("number", "m/s^2/sqrt(Hz)", high=10.0, **_POSITIVE),
    "imu.gyro_noise_density": Key("number", "rad/s/sqrt(Hz)", high=1.0, **_POSITIVE),
    "imu.accel_bias_rw": Key("number", "m/s^3/sqrt(Hz)", high=1.0, **_NON_NEGATIVE),
    "imu.gyro_bias_rw": Key("number", "rad/s^2/sqrt(Hz)", high=1.0, **_NON_NEGATIVE),
    "imu.accel_bias_sigma": Key("number", "m/s^2", high=10.0, **_NON_NEGATIVE),
    "imu.gyro_bias_sigma": Key("number", "rad/s", high=1.0, **_NON_NEGATIVE),
    "imu.accel_range_mps2": Key("number", "m/s^2", high=10000.0, **_POSITIVE),
    "imu.gyro_range_rads": Key("number", "rad/s", high=1000.0, **_POSITIVE),
    "imu.accel_spike_floor_mps2": Key("number", "m/s^2", high=10000.0, **_POSITIVE),
    "imu.gyro_spike_floor_rads": Key("number", "rad/s", high=1000.0, **_POSITIVE),
    "dvl.theta_rad": Key("number", "rad", high=math.pi / 2, **_POSITIVE),
    "dvl.psi_rad": Key("vector", "rad", low=-2 * math.pi, high=2 * math.pi, size=4),
    "dvl.C_d_b": Key("rotation"),
    "dvl.lever_arm_b": Key("vector", "m", low=-100.0, high=100.0, size=3),
    "dvl.beam_noise_std": Key("number", "m/s", high=10.0, **_POSITIVE),
    "dvl.beam_bias": Key("vector", "m/s", low=-10.0, high=10.0, size=4),
    "dvl.scale_factor": Key("vector", "", low=-0.5, high=0.5, size=3),
    "dvl.rate_hz": Key("number", "Hz", high=1000.0, **_POSITIVE),
    "dvl.velocity_noise_std": Key("vector", "m/s", high=10.0, size=3, nullable=True, **_POSITIVE),
    "dvl.velocity_scale_correction": Key("number", "", low=-0.5, high=0.5),
    "dvl.max_speed_mps": Key("number", "m/s", high=100.0, **_POSITIVE),
    "dvl.max_vertical_mps": Key("number", "m/s", high=100.0, **_POSITIVE),
    "dvl.max_accel_mps2": Key("number", "m/s^2", high=100.0, **_POSITIVE),
    "dvl.jump_tolerance_mps": Key("number", "m/s", high=100.0, **_NON_NEGATIVE),
    "imu_rate_hz": Key("number", "Hz", high=100000.0, **_POSITIVE),
    "lat_rad": Key("number", "rad", low=-math.pi / 2, high=math.pi / 2),
    "gravity_mps2": Key("number", "m/s^2", low=9.7, high=9.9),
    "earth_rotation": Key("bool"),
    "gravity_variation": Key("bool"),
    "dvl_time_offset_s": Key("number", "s", low=-TIME_OFFSET_MAX_S, high=TIME_OFFSET_MAX_S, nullable=True),
    "gt_time_offset_s": Key("number", "s", low=-TIME_OFFSET_MAX_S, high=TIME_OFFSET_MAX_S, nullable=True),
    "reference_position_b": Key("vector", "m", low=-100.0, high=100.0, size=3, nullable=True),
    "imu_axis_signs": Key("signs", nullable=True),
    "depth_noise_std": Key("number", "m", high=100.0, **_POSITIVE),
    "depth_range_m": Key("vector", "m", low=-1000.0, high=12000.0, size=2),
    "depth_jump_tolerance_m": Key("number", "m", high=10000.0, **_POSITIVE),
    "water_density_kgpm3": Key("number", "kg/m^3", low=990.0, high=1100.0),
    "atmospheric_pressure_pa": Key("number", "Pa", low=0.0, high=200000.0),
    "csv_columns": Key("object"),
    "bag_topics": Key("object"),
}

#: The keys each stream of ``csv_columns`` accepts (:mod:`graphnav.io.generic_csv` reads them), and under ``""``
#: the map's own keys besides the streams. A key not listed is a ConfigError naming it, so that a misspelt unit or
#: frame key cannot fall back to a default; a new key is one more name here.
CSV_COLUMN_KEYS: dict[str, tuple[str, ...]] = {
    "": ("time_unit",),
    "imu": ("file", "t", "time_unit", "delimiter", "f_b", "omega_b", "accel_unit", "gyro_unit", "frame"),
    "dvl": ("file", "t", "time_unit", "delimiter", "beams", "valid", "v_b", "velocity_unit", "clock", "pd0",
            "frame", "euler", "angle_unit"),
    "depth": ("file", "t", "time_unit", "delimiter", "depth", "positive", "pressure", "pressure_unit"),
    "gt": ("file", "t", "time_unit", "delimiter", "p_n", "v_n", "euler", "angle_unit", "velocity_sigma"),
}


#: The keys each stream of ``bag_topics`` accepts (:mod:`graphnav.io.bags` reads them): what a bag's messages cannot
#: say, with the name and meaning of the same key of :data:`CSV_COLUMN_KEYS`; ``dvl`` names the fields of a vendor's
#: own DVL message (:mod:`graphnav.io.bag_fields`; ``velocity_valid`` is the velocity's flag, which a column map
#: does not have).
BAG_TOPIC_KEYS: dict[str, tuple[str, ...]] = {
    "depth": ("positive",),
    "dvl": ("topic", "v_b", "velocity_valid", "beams", "valid", "frame", "velocity_unit")}


def check_column_map(cmap: dict, source: str, section: str = "csv_columns") -> None:
    """ConfigError naming ``source`` and the key for a ``csv_columns`` key that :data:`CSV_COLUMN_KEYS` does not
    list (with the closest accepted name), or a stream entry that is not a JSON object; ``section`` ``bag_topics``:
    the same for :data:`BAG_TOPIC_KEYS`."""
    table = CSV_COLUMN_KEYS if section == "csv_columns" else BAG_TOPIC_KEYS
    streams, own = [k for k in table if k], table.get("", ())
    for name, spec in cmap.items():
        if name not in streams:
            _unknown_column_key(source, section, "", name, streams + list(own), own)
        elif not isinstance(spec, dict):
            example = '{"file": ..., "t": ...}' if section == "csv_columns" else f'{{"{table[name][0]}": ...}}'
            what = "column names" if section == "csv_columns" else "keys"
            raise ConfigError(f"{source}: key '{section}.{name}': expected a JSON object of {what} ({example}), got "
                              f"{_got(spec)}")
        else:
            for key in spec:
                _unknown_column_key(source, section, name, key, table[name], table[name])


def _unknown_column_key(source: str, section: str, stream: str, key: str, choices, accepted) -> None:
    if key in accepted:
        return
    where = section + (f".{stream}" if stream else "")
    close = difflib.get_close_matches(str(key), list(choices), n=1, cutoff=0.6)
    hint = f"; did you mean '{where}.{close[0]}'?" if close else f"; {where} accepts {', '.join(choices)}"
    raise ConfigError(f"{source}: unknown key '{where}.{key}'{hint}")


#: Keys the prepare step finds from the data unless a configuration gives them (``graphnav.calibration.preparation``):
#: null in a file, as a dump of the defaults writes them, is not given. A SensorConfig's default 0 s and (1, 1, 1)
#: were written as numbers and then read as given, which switched the estimates off for every later log.
FOUND_WHEN_PREPARED = ("imu_axis_signs", "gt_time_offset_s", "dvl_time_offset_s")
#: What a mission holds for each of them before it is prepared: nothing applied.
NOTHING_APPLIED = {"imu_axis_signs": lambda: np.ones(3), "gt_time_offset_s": float, "dvl_time_offset_s": float}

#: The sections of a configuration file and the dataclass each one fills.
SECTIONS: dict[str, type] = {"imu": ImuSpec, "dvl": DvlSpec}


def _is_rotation(m: np.ndarray) -> bool:
    return bool(np.allclose(m @ m.T, np.eye(3), atol=1e-6) and np.linalg.det(m) > 0)


def field_docs(cls: type) -> dict[str, str]:
    """The ``Attributes:`` entries of a dataclass docstring, field name -> text (a shared entry such as
    ``a, b: ...`` describes each of its names)."""
    doc = inspect.cleandoc(cls.__doc__ or "")
    body = doc.split("Attributes:", 1)[1] if "Attributes:" in doc else ""
    docs, names = {}, []
    for line in body.splitlines():
        head = re.match(r"^    (\w+(?:, \w+)*):\s*(.*)$", line)
        if head:
            names = head.group(1).split(", ")
            for n in names:
                docs[n] = head.group(2)
        elif line.startswith("        ") and names:
            for n in names:
                docs[n] += " " + line.strip()
        elif line.strip():
            names = []
    return docs


def describe() -> list[tuple[str, str, str]]:
    """(key, expected value, meaning) for every key of :data:`SCHEMA`, the meaning from the dataclass
    docstrings (what ``graphnav online --schema`` and the docs print)."""
    docs = {**{f"imu.{k}": v for k, v in field_docs(ImuSpec).items()},
            **{f"dvl.{k}": v for k, v in field_docs(DvlSpec).items()}, **field_docs(SensorConfig)}
    return [(key, spec.expected(), docs.get(key, "")) for key, spec in SCHEMA.items()]


def _suggest(name: str, prefix: str) -> str:
    """``; did you mean 'x'?`` for an unknown key, from the keys of its section and every key's full name."""
    here = [k[len(prefix):].split(".")[0] for k in SCHEMA if k.startswith(prefix)]
    full = list(SCHEMA) + list(SECTIONS)
    close = difflib.get_close_matches(name, sorted(set(here)), n=1, cutoff=0.6)
    if close:
        return f"; did you mean '{prefix}{close[0]}'?"
    leaf = [k for k in full if k.rsplit(".", 1)[-1] == name]       # a key in the wrong section
    close = leaf or difflib.get_close_matches(name, full, n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ""


def _got(value) -> str:
    text = json.dumps(value) if not isinstance(value, float) or math.isfinite(value) else str(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _check_value(key: str, spec: Key, value, source: str):
    """The value of one key as graphnav holds it (float, bool, str, ndarray, dict), or ConfigError."""
    def bad(why: str = ""):
        return ConfigError(f"{source}: key '{key}': expected {spec.expected()}, got {_got(value)}"
                           + (f" ({why})" if why else ""))

    def number(x) -> float:
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise bad()
        if not math.isfinite(x):
            raise bad("not finite")
        if spec.low is not None and (x < spec.low or (spec.low_open and x == spec.low)):
            raise bad()
        if spec.high is not None and x > spec.high:
            raise bad()
        return float(x)

    if value is None and spec.nullable:
        return None
    if spec.kind == "number":
        return number(value)
    if spec.kind == "bool":
        if not isinstance(value, bool):
            raise bad()
        return value
    if spec.kind == "text":
        if not isinstance(value, str):
            raise bad()
        return value
    if spec.kind == "object":
        if not isinstance(value, dict):
            raise bad()
        return dict(value)
    if spec.kind == "rotation":
        if not (isinstance(value, list) and len(value) == 3
                and all(isinstance(r, list) and len(r) == 3 for r in value)):
            raise bad()
        m = np.array([[number(x) for x in row] for row in value])
        if not _is_rotation(m):
            raise bad("rows not orthonormal with determinant +1")
        return m
    size = 3 if spec.kind == "signs" else spec.size
    if not isinstance(value, (list, tuple)) or len(value) != size:
        raise bad(f"{len(value)} elements" if isinstance(value, (list, tuple)) else "")
    v = np.array([number(x) for x in value])
    if spec.kind == "signs" and not np.all(np.isin(v, (-1.0, 1.0))):
        raise bad()
    return v


@dataclass(frozen=True)
class ConfigOverrides:
    """The keys a configuration file (or a stream's ``config`` line) sets, checked against :data:`SCHEMA`.

    Attributes:
        values: dotted key (``imu.gyro_noise_density``, ``lat_rad``) -> value as graphnav holds it
            (float, bool, str, ndarray, dict).
        source: where they come from (file path, ``"<stream>, line 1"``), for messages.
    """

    values: dict
    source: str = "<config>"

    @classmethod
    def parse(cls, data, source: str = "<config>") -> "ConfigOverrides":
        """Check a JSON value (the parsed file) key by key; :class:`ConfigError` names ``source``, the key,
        what it expects and what it got."""
        if isinstance(data, SensorConfig):
            data = data.to_dict()
        if not isinstance(data, dict):
            raise ConfigError(f"{source}: a configuration is a JSON object of keys ({{\"imu_rate_hz\": 100, ...}}), "
                              f"got {type(data).__name__ if not isinstance(data, list) else 'a list'} {_got(data)}")
        values = {}
        for name, value in data.items():
            if name in SECTIONS:
                if not isinstance(value, dict):
                    raise ConfigError(f"{source}: key '{name}': expected a JSON object of {name} keys "
                                      f"(e.g. {{\"{next(k for k in SCHEMA if k.startswith(name + '.'))[len(name) + 1:]}\": "
                                      f"...}}), got {_got(value)}")
                for sub, v in value.items():
                    key = f"{name}.{sub}"
                    if key not in SCHEMA:
                        raise ConfigError(f"{source}: unknown key '{key}'{_suggest(str(sub), name + '.')}")
                    values[key] = _check_value(key, SCHEMA[key], v, source)
            elif name in FOUND_WHEN_PREPARED and value is None:
                continue                # not given: found from the data
            elif name in SCHEMA:
                values[name] = _check_value(name, SCHEMA[name], value, source)
                if name in ("csv_columns", "bag_topics"):
                    check_column_map(values[name], source, name)
            else:
                raise ConfigError(f"{source}: unknown key '{name}'{_suggest(str(name), '')}")
        return cls(values, source)

    def sets(self, key: str) -> bool:
        """Whether the file sets ``key`` (dotted name)."""
        return key in self.values

    def __bool__(self) -> bool:
        return bool(self.values)

    def over(self, base: SensorConfig) -> SensorConfig:
        """A copy of ``base`` with every key set here replaced, the others kept (key by key)."""
        cfg = dataclasses.replace(base, imu=dataclasses.replace(base.imu), dvl=dataclasses.replace(base.dvl),
                                  csv_columns=dict(base.csv_columns), bag_topics=dict(base.bag_topics))
        for key, value in self.values.items():
            target, name = cfg, key
            if "." in key:
                section, name = key.split(".", 1)
                target = getattr(cfg, section)
            setattr(target, name, value.copy() if isinstance(value, (np.ndarray, dict)) else value)
        try:        # the dataclasses' own checks (a reversed range, a reflection) on the combined values
            return dataclasses.replace(cfg, imu=dataclasses.replace(cfg.imu), dvl=dataclasses.replace(cfg.dvl))
        except ConfigError as exc:
            raise ConfigError(f"{self.source}: {exc}") from None

    def differences(self, used: SensorConfig) -> list[tuple[str, object, object]]:
        """(key, value set here, value in ``used``) for every key whose value ``used`` does not hold (a
        loader replaced it from the data)."""
        out = []
        for key, value in self.values.items():
            target, name = used, key
            if "." in key:
                section, name = key.split(".", 1)
                target = getattr(used, section)
            held = getattr(target, name)
            same = (np.allclose(np.asarray(held, float), value, rtol=1e-9, atol=1e-12)
                    if isinstance(value, (np.ndarray, float)) else held == value)
            if not same:
                out.append((key, value, held))
        return out


def read_config(path: str | Path) -> ConfigOverrides:
    """The keys a SensorConfig JSON file sets, checked (:class:`ConfigError` naming the file on any problem)."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise ConfigError(f"{path}: configuration file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read configuration: {exc}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{path}: not JSON: {exc.msg} at line {exc.lineno}, column {exc.colno}") from None
    return ConfigOverrides.parse(data, str(path))
