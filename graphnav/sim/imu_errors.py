"""IMU error injection: white noise, constant turn-on bias and bias random walk.

Used by the simulator (to turn exact IMU samples into a sensor of a chosen grade) and by the benchmark (to
degrade a recorded IMU to a lower grade by adding that grade's errors on top of the recorded samples).

The error model of one axis, for samples at stamps ``t_k`` (s):

    measured_k = true_k + b0 + w_k + n_k
    b0  ~ N(0, bias_sigma^2)                             (turn-on bias, constant over the run)
    w_0 = 0,  w_k = w_{k-1} + bias_rw * sqrt(t_k - t_{k-1}) * N(0, 1)   (bias random walk)
    n_k ~ N(0, (noise_density * sqrt(rate_hz))^2)          (white noise of a sample at rate_hz)

The total bias ``b0 + w_k`` is returned per sample so that tests and benchmarks know the truth.
Units: specific force m/s^2, angular rate rad/s, densities as in :class:`~graphnav.core.config.ImuSpec`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from graphnav.core.config import ImuSpec
from graphnav.core.errors import DataError
from graphnav.core.mission import ImuData
from graphnav.core.timeseries import interp_rows


@dataclass
class ImuErrorTruth:
    """The errors that :func:`corrupt_imu` added.

    Attributes:
        t: (N,) IMU stamps, s.
        bias_acc: (N,3) total accelerometer bias (turn-on + random walk) at each stamp, m/s^2.
        bias_gyro: (N,3) total gyro bias at each stamp, rad/s.
        spec: the error model used.
        seed: the seed the errors were drawn with.
    """

    t: np.ndarray
    bias_acc: np.ndarray
    bias_gyro: np.ndarray
    spec: ImuSpec
    seed: int | None

    def at(self, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(bias_acc, bias_gyro) linearly interpolated at time(s) t (s)."""
        t = np.asarray(t, dtype=float)
        acc = interp_rows(t, self.t, self.bias_acc)
        gyro = interp_rows(t, self.t, self.bias_gyro)
        return acc, gyro


def _random_walk(rng: np.random.Generator, dt: np.ndarray, sigma_rw: float) -> np.ndarray:
    """(N,3) random walk starting at 0 with increments ``sigma_rw * sqrt(dt) * N(0,1)``."""
    steps = rng.standard_normal((len(dt), 3)) * (sigma_rw * np.sqrt(dt))[:, None]
    return np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])


def corrupt_imu(imu: ImuData, spec: ImuSpec, seed: int | np.random.Generator | None = 0,
                rate_hz: float | None = None) -> tuple[ImuData, ImuErrorTruth]:
    """Add the errors of ``spec`` to the IMU samples ``imu``.

    Args:
        imu: IMU samples (stamps s, f_b m/s^2, omega_b rad/s). Not modified.
        spec: error model (noise densities, bias random walks, turn-on bias sigmas).
        seed: int seed or a numpy Generator; same seed, same errors.
        rate_hz: sample rate used to scale the white-noise densities; default ``1 / median(diff(t))``.

    Returns:
        (corrupted copy of ``imu``, :class:`ImuErrorTruth` with the bias trajectories).
    """
    t = np.asarray(imu.t, dtype=float)
    if len(t) < 2:
        raise DataError("need at least 2 IMU samples to add errors", imu.source, field="t")
    if rate_hz is None:
        rate_hz = 1.0 / float(np.median(np.diff(t)))
    if not rate_hz > 0:
        raise DataError(f"IMU rate must be > 0 Hz, got {rate_hz}", imu.source, field="t")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    n = len(t)
    dt = np.diff(t)
    # Draw order is fixed (turn-on, random walk, white noise; accelerometer before gyro) so that a seed
    # always gives the same errors.
    b0_acc = rng.normal(0.0, spec.accel_bias_sigma, 3)
    b0_gyro = rng.normal(0.0, spec.gyro_bias_sigma, 3)
    bias_acc = b0_acc + _random_walk(rng, dt, spec.accel_bias_rw)
    bias_gyro = b0_gyro + _random_walk(rng, dt, spec.gyro_bias_rw)
    noise_acc = rng.standard_normal((n, 3)) * spec.accel_noise_density * np.sqrt(rate_hz)
    noise_gyro = rng.standard_normal((n, 3)) * spec.gyro_noise_density * np.sqrt(rate_hz)
    out = ImuData(t.copy(), imu.f_b + bias_acc + noise_acc, imu.omega_b + bias_gyro + noise_gyro, imu.source)
    truth = ImuErrorTruth(t.copy(), bias_acc, bias_gyro, spec,
                          None if isinstance(seed, np.random.Generator) else seed)
    return out, truth
