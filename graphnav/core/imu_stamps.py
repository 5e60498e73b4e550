"""IMU sample conventions: what a sample's stamp means, and conversions to graphnav's.

graphnav's convention (:class:`graphnav.core.mission.ImuData`, the JSON-lines stream, the simulator): the sample
stamped ``t_k`` is the **increment over** ``[t_k, t_{k+1}]`` **divided by its length**, with the body axes frozen
at ``t_k``: ``omega_b[k] = theta_k / dt_k`` where ``Exp(theta_k)`` is the body rotation over the interval, and
``f_b[k] = dv_k / dt_k`` with ``dv_k`` the velocity increment in the axes of ``t_k`` (coning and sculling
included). Held constant over ``[t_k, t_{k+1})`` (zero-order hold, as GTSAM's preintegration does) such samples
reproduce the motion exactly. The stamp is the **start** of the interval a sample covers.

What users bring:

* **Increments ending at the stamp** (navigation-grade INS/IMU logs, e.g. Phins or RDI-style binary logs, and
  pyins' ``sensor_type='increment'``): raw gyro angle and velocity increments over ``(t_{k-1}, t_k]``, in the
  body axes of each instant. :func:`increments_to_samples` applies the two-sample coning and sculling
  corrections and the rotation compensation, and stamps each result at its interval's start.
* **Instant rates** (ROS ``sensor_msgs/Imu``: angular velocity and linear acceleration at the stamp):
  :func:`rates_to_samples` assumes the rates vary linearly between stamps and integrates them over each
  interval (the same formulas, with the linear model's exact coning/sculling terms).

Using increments or rates as if they were graphnav samples is a real error: stamping the increments of a
2 m/s, four-turn run at their interval's end instead of its start costs 1.2 m/s and 240 m in 400 s
(pure inertial); feeding instant rates without integration gives first-order errors in turns.
"""
from __future__ import annotations

import numpy as np

from graphnav.core.errors import DataError
from graphnav.core.mission import ImuData

#: the one sentence every reader and writer quotes for graphnav's convention
SAMPLE_CONVENTION = ("increment over [t_k, t_k+1] divided by its length, body axes frozen at t_k "
                     "(the stamp is the start of the interval)")


def _check(t: np.ndarray, a: np.ndarray, b: np.ndarray, source: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.asarray(t, dtype=float)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if t.ndim != 1 or a.shape != (len(t), 3) or b.shape != (len(t), 3):
        raise DataError(f"{source}: expected stamps (N,) and two (N,3) arrays, got {t.shape}, {a.shape}, "
                        f"{b.shape}")
    if len(t) < 2:
        raise DataError(f"{source}: at least two samples are needed to know an interval")
    bad = np.flatnonzero(~(np.diff(t) > 0))
    if bad.size:
        raise DataError(f"{source}: stamps must increase; index {bad[0] + 1} (t={t[bad[0] + 1]!r}) does not")
    return t, a, b


def increments_to_samples(t_end: np.ndarray, dtheta_b: np.ndarray, dv_b: np.ndarray,
                          source: str = "imu") -> ImuData:
    """graphnav samples from increments that end at their stamps.

    Args:
        t_end: (N,) stamps, s; row k holds the increments over ``(t_end[k-1], t_end[k]]`` (row 0 only
            serves as the previous increment of row 1: its own interval is unknown).
        dtheta_b: (N,3) raw integrated angular rate over each interval, rad (body axes of each instant).
        dv_b: (N,3) raw integrated specific force over each interval, m/s.
        source: name used in error messages and kept in ``ImuData.source``.

    Returns:
        N-1 samples stamped ``t_end[:-1]`` (each interval's start), rates = corrected increments / dt.
        Two-sample coning ``dtheta_{k-1} x dtheta_k / 12`` and sculling
        ``(dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k) / 12``, and the rotation compensation
        ``dtheta_k x dv_k / 2`` that puts the velocity increment in the interval's starting axes.
    """
    t, th, dv = _check(t_end, dtheta_b, dv_b, source)
    dt = np.diff(t)[:, None]
    coning = np.cross(th[:-1], th[1:]) / 12.0
    sculling = (np.cross(th[:-1], dv[1:]) + np.cross(dv[:-1], th[1:])) / 12.0
    theta = th[1:] + coning
    dvel = dv[1:] + sculling + 0.5 * np.cross(th[1:], dv[1:])
    return ImuData(t[:-1].copy(), dvel / dt, theta / dt, source)


def rates_to_samples(t: np.ndarray, omega_b: np.ndarray, f_b: np.ndarray, source: str = "imu") -> ImuData:
    """graphnav samples from instant rates (ROS ``sensor_msgs/Imu``: angular velocity, linear acceleration).

    Args:
        t: (N,) stamps of the instant values, s.
        omega_b: (N,3) angular rate at each stamp, rad/s; f_b: (N,3) specific force at each stamp, m/s^2.
        source: name used in error messages.

    Returns:
        N-1 samples stamped ``t[:-1]``, each the linear model's increment over ``[t_k, t_{k+1}]`` (trapezoid
        plus the exact coning ``dt^2 a x b / 12`` and sculling terms of a linear rate), divided by dt.
    """
    t, w, f = _check(t, omega_b, f_b, source)
    dt = np.diff(t)[:, None]
    a_w, b_w = w[:-1], np.diff(w, axis=0)
    a_f, b_f = f[:-1], np.diff(f, axis=0)
    theta_raw = (a_w + 0.5 * b_w) * dt
    dv_raw = (a_f + 0.5 * b_f) * dt
    coning = np.cross(a_w, b_w) * dt ** 2 / 12.0
    sculling = (np.cross(a_w, b_f) + np.cross(a_f, b_w)) * dt ** 2 / 12.0
    theta = theta_raw + coning
    dvel = dv_raw + sculling + 0.5 * np.cross(theta_raw, dv_raw)
    return ImuData(t[:-1].copy(), dvel / dt, theta / dt, source)
