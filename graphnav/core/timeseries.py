"""Small helpers for time series sampled at increasing stamps."""
from __future__ import annotations

import numpy as np


def interp_rows(t_query, t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Linear interpolation of each column of x (N,k) at t_query: a scalar gives (k,), (M,) gives (M,k).

    Outside [t[0], t[-1]] the end values are held (np.interp). Pass a Fortran-ordered x
    (``np.asfortranarray``) when calling often: np.interp copies strided columns.
    """
    return np.stack([np.interp(t_query, t, x[:, i]) for i in range(x.shape[1])], axis=-1)


def cumulative_integral(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Running integral of IMU samples x (N,...) at stamps t (N,), starting at 0.

    Sample j is held over ``[t_j, t_j+1)`` (zero-order hold, GTSAM's preintegration convention and the
    simulator's increment convention), so offsets found with it are the ones the estimators need.
    """
    dt = np.diff(t).reshape((-1,) + (1,) * (x.ndim - 1))
    steps = x[:-1] * dt
    return np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(steps, axis=0)])


def finite_rows(x: np.ndarray) -> np.ndarray:
    """(K,) True where every value of row k of ``x`` (K, ...) is finite: an epoch of an estimate or of its
    covariance that is all there."""
    x = np.asarray(x)
    return np.all(np.isfinite(x.reshape(len(x), -1)), axis=1)


#: A stream whose span overlaps the IMU's over less than this fraction of the shorter of the two spans is on a
#: clock of its own (:func:`on_the_imu_clock`).
MIN_CLOCK_OVERLAP = 0.5


def span_overlap_fraction(t: np.ndarray, t_imu: np.ndarray) -> float:
    """The overlap (s) of the spans of stamps ``t`` and ``t_imu`` (s, increasing) over the shorter of the two
    spans, 0..1. Against the shorter span, not as the share of ``t`` inside the IMU span: a log that runs longer
    than the other (either side) still overlaps it fully. A span of one stamp: 1 inside the other span, else 0."""
    t, t_imu = np.asarray(t, float), np.asarray(t_imu, float)
    if len(t) == 0 or len(t_imu) == 0:
        return 0.0
    overlap = min(t[-1], t_imu[-1]) - max(t[0], t_imu[0])
    shorter = min(t[-1] - t[0], t_imu[-1] - t_imu[0])
    if shorter <= 0:
        return 1.0 if overlap >= 0 else 0.0
    return float(np.clip(overlap / shorter, 0.0, 1.0))


def overlap_text(t: np.ndarray, t_imu: np.ndarray) -> str:
    """'N % of the shorter span': how much the spans of stamps ``t`` and ``t_imu`` (s) share, for a message
    (:func:`span_overlap_fraction`)."""
    return f"{100 * span_overlap_fraction(t, t_imu):.0f} % of the shorter span"


def on_the_imu_clock(t: np.ndarray, t_imu: np.ndarray) -> bool:
    """Stamps ``t`` (s) share the IMU's clock as far as their spans tell: they overlap the IMU span ``t_imu`` (s)
    over at least :data:`MIN_CLOCK_OVERLAP` of the shorter span (:func:`span_overlap_fraction`). A log that merely
    outlasts the IMU is on its clock (its samples outside the span are refused, and counted, later); one seconds or
    days away is not."""
    return span_overlap_fraction(t, t_imu) >= MIN_CLOCK_OVERLAP
