"""DVL beam geometry and measurement model (``../shared/docs/method.md``).

Beam velocities are the projections of the DVL velocity on the beam unit vectors:
``y = T @ v_d`` with ``T`` (4,3) holding the beam vectors of the DVL frame as rows and
``v_d = C_d_b^T (v_b + omega_b x l_b)`` the velocity of the DVL head in the DVL frame.
Beam indices are 0-based here (index 0 is the paper's beam 1).

The one DVL frame and beam convention (``docs/decisions/dvl-frame.md``):

* **DVL frame d**: right-handed, fixed to the head; ``z_d`` along the instrument's axis on the side the beams
  point to (down for a down-looking DVL), ``x_d`` and ``y_d`` across it. ``v_b = C_d_b v_d`` with ``C_d_b`` a
  rotation (det +1; :class:`~graphnav.core.config.DvlSpec` refuses a reflection).
* **Beams**: outward unit vectors ``[cos psi sin theta, sin psi sin theta, cos theta]`` in ``d`` (along +z,
  inclination theta, azimuth psi from ``x_d`` toward ``y_d``). A **beam velocity** is the head's velocity over
  the seabed along its outward beam, ``y_i = u_i . v_d``: positive when the head moves toward the spot the
  beam sees. That is also what a Teledyne RDI DVL records as a bottom-track beam velocity (the seabed's
  velocity "toward the transducer"), so RDI beams are used as recorded.
* **RDI instrument frame to d** (:data:`graphnav.io.pd0.C_D_RDI`): RDI's ``X, Y, Z`` (beam 1 -> -X, beam 2 -> +X,
  beam 3 -> +Y, beam 4 -> -Y for a convex head, beams along **-Z**: the ``w = +b (B1+B2+B3+B4)`` row of the
  beam-to-instrument matrix RDI stores in block 0x3200 and dolfyn uses) map to ``x_d = +Y`` (beam 3, the
  instrument's heading reference: forward), ``y_d = +X`` (beam 2: right), ``z_d = -Z`` (the beams: down). A
  convex RDI head has azimuths 270, 90, 0, 180 deg in ``d``; mounted with beam 3 forward and looking down,
  ``C_d_b = I``. The head's velocity in ``d`` is ``-C_D_RDI`` times dolfyn's instrument-frame bottom-track
  velocity (the seabed's velocity relative to the head).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from graphnav.core.beam_model import BeamModel
from graphnav.core.config import DvlSpec
from graphnav.core.errors import GeometryError
from graphnav.core.screening import (  # noqa: F401
    SPIKE_NEIGHBOURS, describe_implausible, implausible_pings, no_bottom_lock)


def ping_speed(beams: np.ndarray, valid: np.ndarray, spec: DvlSpec) -> np.ndarray:
    """(M,) speed, m/s, of the least-squares velocity of each ping's valid beams (M,4) m/s; NaN under three."""
    v = DvlGeometry.from_spec(spec).velocity_from_beams(np.where(valid, beams, np.nan), valid, allow_missing=True)
    return np.linalg.norm(v, axis=1)


def beam_velocity_b(dvl, spec: DvlSpec) -> np.ndarray:
    """(M,3) each ping's velocity of the DVL head in the body frame, m/s (:class:`~graphnav.core.mission.DvlData`):
    its ``v_b`` where the reader gives one, else the least-squares velocity of >= 3 valid beams; NaN: none."""
    if dvl.v_b is not None:
        return dvl.v_b
    return DvlGeometry.from_spec(spec).velocity_from_beams(np.where(dvl.valid, dvl.beams, np.nan), dvl.valid,
                                                           allow_missing=True)


def ping_velocity_b(dvl, spec: DvlSpec) -> np.ndarray:
    """(M,3) :func:`beam_velocity_b`, and where it has none the instrument's own ``v_d`` turned by ``spec.C_d_b``
    (m/s, body frame; NaN: none)."""
    v = beam_velocity_b(dvl, spec)
    if dvl.v_d is not None:
        own = dvl.v_d_valid & ~np.all(np.isfinite(v), axis=1)
        v = np.where(own[:, None], dvl.v_d @ np.asarray(spec.C_d_b, float).T, v)
    return v


def no_lock_pings(t: np.ndarray, spec: DvlSpec, fine: bool | None = None, *, beams: np.ndarray | None = None,
                  valid: np.ndarray | None = None, v: np.ndarray | None = None, v_d: np.ndarray | None = None,
                  v_d_valid: np.ndarray | None = None) -> np.ndarray:
    """(M,) DVL pings at ``t`` (M,) s logged as exactly 0 that are no bottom lock
    (:func:`~graphnav.core.screening.no_bottom_lock`), on the same inputs for every reader: a ping's valid beams
    (``beams`` (M,4) m/s where ``valid``), or its instrument velocity (``v_d`` (M,3) m/s where ``v_d_valid``) when
    it has fewer than three; without beams, the velocity ``v`` (M,3) m/s as logged. Its speed is that of ``v``
    (default: solved from the valid beams, :func:`ping_speed`; NaN: that of ``v_d``). ``fine``: the log's
    resolution is finer than :data:`~graphnav.core.screening.ZERO_RESOLUTION` (None: judged from the values)."""
    if beams is None:
        return no_bottom_lock(t, v, np.linalg.norm(v, axis=1), spec, fine)
    values = np.where(valid, beams, np.nan)
    speed = ping_speed(beams, valid, spec) if v is None else np.linalg.norm(v, axis=1)
    if v_d is not None:
        v_d = np.where(v_d_valid[:, None], v_d, np.nan)
        own = (valid.sum(axis=1) < 3) & v_d_valid
        values = np.where(own[:, None], np.column_stack([v_d, np.full(len(v_d), np.nan)]), values)
        speed = np.where(np.isfinite(speed), speed, np.linalg.norm(v_d, axis=1))
    return no_bottom_lock(t, values, speed, spec, fine)


#: Largest relative difference between the interval of two consecutive DVL pings and the ping period a completer
#: network was trained for, on the short side (and, by default, the long side) (:func:`off_period`): past pings
#: closer together are not the past the network learned from. A safety bound, not a fitted one: a quarter of a period
#: is far outside a DVL's stamp jitter, and DVLs pinging more than 4/3 times the trained rate are refused
#: (docs/decisions/completers.md, "A network on a DVL pinging at another rate").
PING_PERIOD_TOLERANCE = 0.25


def off_period(intervals_s, period_s: float, longest: float = 1.0 + PING_PERIOD_TOLERANCE) -> bool:
    """Whether any of the ping intervals ``intervals_s`` (s) is shorter than ``1 - PING_PERIOD_TOLERANCE`` periods
    ``period_s`` (s) or longer than ``longest`` periods.

    Raises:
        ValueError: an interval that is not a finite number (stamps that are not known have no intervals to check).
    """
    x = np.asarray(intervals_s, float) / period_s
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise ValueError(f"ping intervals must be finite numbers (s), got {intervals_s!r}")
    return bool(np.any((x < 1.0 - PING_PERIOD_TOLERANCE) | (x > longest)))


def beam_matrix(theta_rad: float, psi_rad: np.ndarray) -> np.ndarray:
    """The (4,3) matrix T of beam unit vectors in the DVL frame."""
    psi = np.asarray(psi_rad, dtype=float)
    return np.stack([np.cos(psi) * np.sin(theta_rad), np.sin(psi) * np.sin(theta_rad),
                     np.full_like(psi, np.cos(theta_rad))], axis=-1)


@dataclass
class DvlGeometry:
    """Beam geometry of one DVL installation.

    Attributes:
        T_d: (4,3) beam unit vectors in the DVL frame (rows).
        C_d_b: (3,3) DVL-to-body rotation.
        lever_arm_b: (3,) DVL position relative to the IMU, body frame, m.
    """

    T_d: np.ndarray
    C_d_b: np.ndarray
    lever_arm_b: np.ndarray

    @classmethod
    def from_spec(cls, spec: DvlSpec) -> "DvlGeometry":
        return cls(beam_matrix(spec.theta_rad, spec.psi_rad), spec.C_d_b.copy(), spec.lever_arm_b.copy())

    @property
    def T_b(self) -> np.ndarray:
        """(4,3) beam unit vectors in the body frame: ``y = T_b @ v_dvl_b``."""
        return self.T_d @ self.C_d_b.T

    def beam_model(self, dvl_errors: bool = False) -> BeamModel:
        """The :class:`~graphnav.core.beam_model.BeamModel` of the four beams (rows of :attr:`T_b`), with the
        DVL error states (scale per DVL axis, bias per beam) when ``dvl_errors``."""
        return BeamModel(self.T_b, np.arange(4), self.C_d_b) if dvl_errors else BeamModel(self.T_b)

    def velocity_model(self, dvl_errors: bool = False) -> BeamModel:
        """The :class:`~graphnav.core.beam_model.BeamModel` of a DVL-frame velocity ``v_d`` measured by the
        instrument (``T_d`` = identity; with ``dvl_errors`` the scale per DVL axis, no beam bias)."""
        return BeamModel.dvl_velocity(self.C_d_b, dvl_errors)

    def velocity_sigma_d(self, beam_noise_std: float) -> np.ndarray:
        """(3,) one-sigma per DVL axis, m/s, of the four-beam least-squares velocity when each beam has white
        noise ``beam_noise_std`` (m/s): ``sqrt(diag(sigma^2 (T_d^T T_d)^-1))``. For the Janus geometry at 20 deg
        it is ``sigma / (sqrt(2) sin 20 deg)`` = 2.07 sigma horizontally and ``sigma / (2 cos 20 deg)`` = 0.53
        sigma vertically."""
        T = self.T_d
        return float(beam_noise_std) * np.sqrt(np.diag(np.linalg.inv(T.T @ T)))

    def dvl_velocity_b(self, v_b: np.ndarray, omega_b: np.ndarray | None = None) -> np.ndarray:
        """Velocity of the DVL head in the body frame, ``v_b + omega_b x l_b``, m/s (…,3)."""
        v_b = np.asarray(v_b, dtype=float)
        if omega_b is None:
            return v_b
        return v_b + np.cross(omega_b, self.lever_arm_b)

    def beams_from_velocity(self, v_b: np.ndarray, omega_b: np.ndarray | None = None) -> np.ndarray:
        """Error-free beam velocities (…,4), m/s, from body velocity v_b (…,3) of the IMU and body rate.

        With ``omega_b`` (rad/s) given, the lever-arm velocity is included (the beam model of
        :mod:`graphnav.core.beam_model` at attitude I, zero gyro bias).
        """
        v_b = np.asarray(v_b, dtype=float)
        rate = np.zeros(3) if omega_b is None else np.asarray(omega_b, dtype=float)
        lever = np.zeros(3) if omega_b is None else self.lever_arm_b
        per_ping = v_b.ndim > 1 or rate.ndim > 1       # broadcast the pings over the four beam rows
        v, w = (v_b[..., None, :], rate[..., None, :]) if per_ping else (v_b, rate)
        return self.beam_model().predict(np.eye(3), v, w, np.zeros(3), lever).h

    def velocity_from_beams(self, beams: np.ndarray, valid: np.ndarray | None = None,
                            allow_missing: bool = False) -> np.ndarray:
        """Least-squares DVL velocity in the body frame from >= 3 valid beams, m/s.

        ``v_b = C_d_b (T^T T)^-1 T^T y`` over the valid rows. Works on one epoch (4,) or many (N,4).
        This is the velocity of the DVL head; subtract ``omega_b x l_b`` for the IMU's velocity.

        Raises:
            GeometryError: an epoch has fewer than 3 valid beams (unless ``allow_missing``, which gives NaN).
        """
        beams = np.asarray(beams, dtype=float)
        single = beams.ndim == 1
        beams = np.atleast_2d(beams)
        if valid is None:
            valid = np.isfinite(beams)
        valid = np.atleast_2d(np.asarray(valid, dtype=bool)) & np.isfinite(beams)
        out = np.full((beams.shape[0], 3), np.nan)
        T_b = self.T_b
        for pattern in np.unique(valid, axis=0):
            rows = np.all(valid == pattern, axis=1)
            if pattern.sum() < 3:
                if not allow_missing:
                    first = int(np.flatnonzero(rows)[0])
                    raise GeometryError(
                        f"epoch {first}: {int(pattern.sum())} valid beams, a least-squares velocity needs >= 3")
                continue
            out[rows] = np.linalg.lstsq(T_b[pattern], beams[rows][:, pattern].T, rcond=None)[0].T
        return out[0] if single else out


@dataclass
class DvlErrorModel:
    """The beam error model ``y = T [v_d * (1 + s)] + b + n`` (scale s per DVL axis, bias b per beam, noise n).

    Attributes:
        scale_factor: (3,) unitless.
        beam_bias: (4,) m/s.
        noise_std: white noise std of each beam, m/s.
    """

    scale_factor: np.ndarray
    beam_bias: np.ndarray
    noise_std: float

    @classmethod
    def from_spec(cls, spec: DvlSpec) -> "DvlErrorModel":
        return cls(spec.scale_factor.copy(), spec.beam_bias.copy(), spec.beam_noise_std)

    def beams(self, geometry: DvlGeometry, v_dvl_b: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Noisy beams (N,4), m/s, from the DVL-head velocity in the body frame v_dvl_b (N,3) (the beam model
        of :mod:`graphnav.core.beam_model` with this scale and bias, plus white noise)."""
        v = np.atleast_2d(np.asarray(v_dvl_b, dtype=float))[:, None, :]
        clean = geometry.beam_model(dvl_errors=True).predict(
            np.eye(3), v, np.zeros(3), np.zeros(3), np.zeros(3), np.r_[self.scale_factor, self.beam_bias]).h
        return clean + rng.normal(0.0, self.noise_std, clean.shape)


def make_beams(v_dvl_b: np.ndarray, spec: DvlSpec, seed: int | np.random.Generator = 0) -> np.ndarray:
    """Beams (N,4) made from recorded or simulated DVL-head body velocities with the spec's error model.

    This is how beams are made from the recorded DVL velocities of the real data sets (as in the paper).
    """
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    return DvlErrorModel.from_spec(spec).beams(DvlGeometry.from_spec(spec), v_dvl_b, rng)


# The envelope rules live with every other sample rule in graphnav.core.screening; re-exported here.
JUMP_NEIGHBOURS = SPIKE_NEIGHBOURS


def screen_implausible(dvl, spec: DvlSpec):
    """``dvl`` (:class:`~graphnav.core.mission.DvlData`) with the pings of :func:`implausible_pings` marked invalid
    (beams NaN), with a warning naming the first index and the counts; what the loaders do to a file, for
    in-memory data. The ping velocity is ``dvl.v_b`` where given, else the least-squares velocity of pings
    with >= 3 valid beams."""
    import warnings

    from graphnav.core.mission import DvlData
    masks = implausible_pings(dvl.t, beam_velocity_b(dvl, spec), spec)
    bad = np.any(list(masks.values()), axis=0)
    if not bad.any():
        return dvl
    rows = np.flatnonzero(bad)
    warnings.warn(f"{dvl.source}: {rows.size} ping(s) outside the vehicle's envelope marked invalid "
                  f"({describe_implausible(masks, spec)}; DvlSpec.max_*), first at index {int(rows[0])}",
                  RuntimeWarning, stacklevel=2)
    valid = dvl.valid & ~bad[:, None]
    return DvlData(dvl.t, np.where(valid, dvl.beams, np.nan), valid,
                   None if dvl.v_b is None else np.where(bad[:, None], np.nan, dvl.v_b), dvl.source)


def as_velocity_only(dvl, spec: DvlSpec):
    """``dvl`` (:class:`~graphnav.core.mission.DvlData`) as a velocity-only DVL reports it: on every ping with >= 3
    valid beams the instrument's own least-squares solution of those beams in the DVL frame (``v_d``, m/s,
    ``v_d_valid``; no per-ping sigma) and no beams (all invalid). For studies and tests: the same pings with the
    information of their beams, through :meth:`graphnav.estimators.navigator.Navigator.add_dvl_velocity`'s path."""
    from graphnav.core.mission import DvlData, no_beams
    geometry = DvlGeometry.from_spec(spec)
    v_b = geometry.velocity_from_beams(dvl.beams, dvl.valid, allow_missing=True)
    v_d_valid = np.all(np.isfinite(v_b), axis=1)
    v_d = np.where(v_d_valid[:, None], v_b @ geometry.C_d_b, np.nan)             # row form of C_d_b^T v_b
    return DvlData(dvl.t, *no_beams(len(dvl.t)), source=dvl.source, v_d=v_d, v_d_valid=v_d_valid)
