"""DVL error states of the graph: scale factor per DVL axis and bias per beam, as slowly varying variables.

Each keyframe k carries a Vector7 ``D(k) = [s_x, s_y, s_z, b_1..b_4]`` (unitless, m/s) used by its DVL
factors (:func:`graphnav.factors.beam_factor_dvl_errors`, beam model ``y = T_d[(1 + s) v_d] + b`` as the
EKF's ``dvl_error_states``). Between keyframes it follows a random walk,
``D(k) - D(k-1) ~ N(0, diag(rw^2) dt)`` (a ``BetweenFactorVector``); the first keyframe has a zero-mean prior.

Why per keyframe rather than one constant: the recorded DVL's own errors (sound speed, bottom type) drift
over a mission, and a fixed-lag smoother must be able to marginalise old values like any other state; the
random walk keeps the chain well conditioned and the variables local in time.
"""
from __future__ import annotations

import gtsam
import numpy as np
from gtsam.symbol_shorthand import D

from graphnav.core.config import SensorConfig
from graphnav.estimators.graph.options import GraphOptions
from graphnav.factors import N_DVL_ERRORS

#: Smallest random-walk sigma between two keyframes (keeps the BetweenFactor finite when rw = 0).
MIN_STEP_SIGMA = 1e-9


def prior_sigmas(config: SensorConfig, options: GraphOptions) -> np.ndarray:
    """(7,) first-keyframe sigmas: scale (unitless) then beam bias (m/s), ``options.priors`` (as the EKF's)."""
    s0, b0 = options.priors.dvl_error_sigmas(config.dvl)
    return np.r_[np.full(3, s0), np.full(4, b0)]


def prior_factor(k: int, mean: np.ndarray, sigmas_or_cov: np.ndarray) -> gtsam.PriorFactorVector:
    """Prior on D(k): (7,) sigmas or a (7,7) covariance."""
    arr = np.asarray(sigmas_or_cov, dtype=float)
    noise = (gtsam.noiseModel.Gaussian.Covariance(arr) if arr.ndim == 2
             else gtsam.noiseModel.Diagonal.Sigmas(arr))
    return gtsam.PriorFactorVector(D(k), np.asarray(mean, dtype=float), noise)


def random_walk_factor(k: int, dt: float, options: GraphOptions) -> gtsam.BetweenFactorVector:
    """Random walk D(k-1) -> D(k) over dt seconds."""
    step = np.sqrt(max(dt, 0.0))
    sigmas = np.maximum(np.r_[np.full(3, options.dvl_scale_rw), np.full(4, options.dvl_bias_rw)] * step,
                        MIN_STEP_SIGMA)
    return gtsam.BetweenFactorVector(D(k - 1), D(k), np.zeros(N_DVL_ERRORS),
                                     gtsam.noiseModel.Diagonal.Sigmas(sigmas))


def beam_index(rows_b: np.ndarray, T_b: np.ndarray) -> np.ndarray:
    """(m,) beam number 0..3 of each body-frame beam row (the row of ``T_b`` it equals)."""
    dist = np.linalg.norm(np.asarray(rows_b)[:, None, :] - T_b[None, :, :], axis=2)
    index = np.argmin(dist, axis=1)
    if np.any(dist[np.arange(len(index)), index] > 1e-9):
        raise ValueError("a beam row is not one of the DVL's beam vectors")
    return index
