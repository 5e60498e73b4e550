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
