"""Regressed beams that earn their place, and the model-based motion prior used where no beam is measured.

A regressed beam (one the DVL did not measure, regressed by a completer) is a prediction made from past
pings, not a measurement. Before it becomes a factor it is compared with the graph's own prediction of the same beam (:func:`screen_regressed`):

- predicted beam ``y_p = b^T (R^T v_pred + (omega - b_g) x l)`` from the IMU-propagated state, with variance
  ``a = b^T R^T P_v R b``, ``P_v`` = the marginal velocity covariance of the previous keyframe plus the
  preintegrated velocity noise up to this one;
- completion ``y_c`` with the completer's variance ``s_c^2``.

Options (``GraphOptions.screening``, ``EkfOptions.screening``:
:class:`graphnav.estimators.options.RegressedScreeningOptions`):

- ``correlation`` (rho): the completion is made from pings that are already factors, so its error
  is correlated with the graph's prediction error. With covariance ``c = rho sqrt(a s_c^2)`` the best
  linear fusion of the two gives gain ``K = (a - c) / (a + s_c^2 - 2c)``; the equivalent independent factor
  at ``y_c`` has variance ``a (s_c^2 - c) / (a - c)`` (= ``s_c^2`` for rho = 0), floored at
  ``s_c^2 (1 - rho^2)``. When ``c >= a`` (the graph's prediction is sharper than rho times the completion)
  the completion carries nothing the graph does not already know and is dropped.
- ``adaptive``: the variance is raised to the innovation's excess, ``max(s^2, (y_c - y_p)^2 - a)``
  (one-sample covariance matching): a completion that disagrees with the IMU gets the sigma the
  disagreement shows.
- ``completion_var_scale``: the variance the correlation rule leaves is multiplied by it (1 by default). A
  completer's errors stay off for many pings together (integrated autocorrelation time 18-24 pings for the
  beam-only ensemble through 60-120 s outages), which per-ping factors treat as independent.
- ``gate_k``: joint-covariance gate, ``|y_c - y_p| / sqrt(a + s^2) > k`` -> dropped.

A beam regressed at consecutive keyframes (a run) is screened at every ping by default. With
``GraphOptions.regressed_runs="screen-first"`` only until one of its completions is kept: after that the graph's
prediction has been pulled by the run itself (:func:`graphnav.estimators.graph.builder.continue_regressed_runs`;
with ``regressed_error_tau_s`` the run's errors are modelled as Gauss-Markov).

Measured on the A-KIT data (``experiments/regressed_correlation.py``, Trajectory1 and 5, 60 s windows, plain
hybrid): the completion's error correlates with the graph's prediction error (rho 0.27-0.68 over tactical /
MEMS IMU and 2 / 3 / 0 measured beams), and it is 1.7-3.7x larger (RMS 0.13 m/s vs 0.035-0.075 m/s), so in
those regimes the completions carry nothing the IMU and the measured beams do not already give better. With
``correlation=0.5`` they are dropped there (on Trajectory1 all of them with the tactical IMU, 81 % in the
MEMS total outage, where the kept ones lower the window VRMSE by 8 % on Trajectory1, 5 and 8). The gate alone
fires on almost nothing (the completions are wrong by a steady 0.13 m/s, not by outliers), and the adaptive
sigma alone cuts Graph-HN's excess over Graph-TC by 18-82 % but still leaves it 1.02-1.96x Graph-TC
(``experiments/regressed_candidates.py``; docs/decisions/regressed-beams.md). The graph's predicted beam variance is
over-confident on these data (mean e_p^2 / a = 2.7-8.7); scaling it (``prediction_var_scale``) by 4
keeps more completions: tactical total outage 0.82x Graph-TC instead of 1.00x, but MEMS total outage 0.96x
instead of 0.88x and MEMS 2-missing 1.02x (x8: 1.10x / 1.21x), so the default stays 1.
``prediction_var_table`` (experimental, None by default) scales it by the number of measured beams and the time
into the run of regressed pings, as fitted out of fold (docs/decisions/completers.md, "The graph's claimed variance
calibrated out of fold": the claim's error differs more between trajectories than between those, and the rule
keeps it off).

When no beam at all is measured, the network completers do not apply as trained (they need at least one
measured beam); :func:`motion_prior_factors` give the physics-based alternative (body-frame velocity random
walk plus small heave, :mod:`graphnav.factors.motion`), used by ``Graph-MP`` (``motion_prior="partial"``)
and, with ``motion_prior="total"``, by the hybrid methods during total outages.

Which of the two is better in a total outage depends on the IMU (trajectories 2, 6, 10): the prior
was 1-17 % better than the screened completion with a tactical or MEMS IMU in 60-120 s outages and up to 29 %
worse with the navigation-grade recorded IMU. ``motion_prior="total-if-uncertain"`` lets the graph choose from
its own uncertainty, without a grade name (:class:`OutagePriorSwitch`): at a keyframe without any measured
beam the prior goes in once the graph's predicted body-frame sway/heave velocity std (the IMU-propagated
marginal, :func:`predict_state`) exceeds ``motion_prior_switch_std`` (0.2 m/s); the screened completions stay
next to it. Keeping them matters: the average estimator's completion holds the beams at their pre-outage
values, an absolute anchor the random walk does not give, and with the MEMS IMU in 120 s outages dropping them
for the prior cost 0.56-0.65x Graph-TC instead of 0.44x (docs/decisions/regressed-beams.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import V, X

from graphnav.core.beam_model import BeamModel
from graphnav.estimators.history import SmoothedSquare
from graphnav.estimators.regressed_screening import screen_against_prediction
from graphnav.factors import body_velocity_change_factor, nonholonomic_factor


@dataclass
class VelocityPrediction:
    """The graph's prediction at a keyframe: NED velocity (m/s), its covariance ((m/s)^2), gyro bias (rad/s)."""

    v_n: np.ndarray
    cov_v_n: np.ndarray
    gyro_bias: np.ndarray


def predict_state(last_cov_v_n: np.ndarray, C_b_n_last: np.ndarray, pim, v_n_pred: np.ndarray,
                  gyro_bias: np.ndarray) -> VelocityPrediction:
    """Prediction of keyframe k from k-1: ``P_v = P_v,k-1 + R_k-1 Cov(dv) R_k-1^T`` (preintegrated velocity
    noise is in the body frame of k-1; GTSAM's combined covariance order is [rot, pos, vel, b_a, b_g])."""
    cov_dv = np.asarray(pim.preintMeasCov())[6:9, 6:9]
    cov = np.asarray(last_cov_v_n) + C_b_n_last @ cov_dv @ C_b_n_last.T
    return VelocityPrediction(np.asarray(v_n_pred, float), cov, np.asarray(gyro_bias, float))


def screen_regressed(rows_b: np.ndarray, y: np.ndarray, sigma: np.ndarray, C_b_n: np.ndarray,
                     omega_b: np.ndarray, lever_arm_b: np.ndarray, prediction: VelocityPrediction | None,
                     options, table_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, dict]:
    """Sigmas for regressed beams after the checks in the module docstring.

    Args:
        rows_b (m,3), y (m,), sigma (m,): the regressed beams (body-frame unit vectors, m/s, m/s).
        C_b_n: predicted attitude; omega_b: body rate for the lever-arm term (rad/s); lever_arm_b: m.
        prediction: the graph's prediction, or None (first keyframe: nothing to compare with).
        options: :class:`~graphnav.estimators.graph.GraphOptions` (its ``screening``).
        table_scale: the factor of ``screening.prediction_var_table`` at this ping (1: none).

    Returns:
        (keep (m,) bool, sigma (m,) m/s, counters {"gated", "decorrelated_out", "inflated"}).
    """
    sigma = np.asarray(sigma, float).copy()
    if prediction is None:
        return np.ones(len(y), dtype=bool), sigma, {"gated": 0, "decorrelated_out": 0, "inflated": 0}
    y_p, a = predicted_beams(rows_b, C_b_n, omega_b, lever_arm_b, prediction)
    keep, s2, stats = screen_against_prediction(y, y_p, a, sigma ** 2, options.screening, table_scale)
    return keep, np.sqrt(s2), stats


def predicted_beams(rows_b: np.ndarray, C_b_n: np.ndarray, omega_b: np.ndarray, lever_arm_b: np.ndarray,
                    prediction: VelocityPrediction) -> tuple[np.ndarray, np.ndarray]:
    """The graph's predicted beams ``y_p`` (m,) m/s along ``rows_b`` (m,3) (body-frame unit vectors) and their
    claimed variance ``a`` (m,) (m/s)^2, from the IMU-propagated state (module docstring)."""
    predicted = BeamModel(rows_b).predict(C_b_n, prediction.v_n, omega_b, prediction.gyro_bias, lever_arm_b)
    H = predicted.d_v()
    return predicted.h, np.einsum("mi,ij,mj->m", H, prediction.cov_v_n, H)


class GraphPredictionError:
    """``GraphOptions.measured_both_margin`` (experimental): a completion is kept only where the completer's recent
    error is smaller than the graph's own, both read on the beams still measured in the same outage.

    The completer's side is the sigma its history hands on with ``run_sigma="measured-change"``
    (:mod:`graphnav.estimators.history`: the measured beams' change from the completer's own completion of them).
    The graph's side is its innovation on the measured beams at each ping with regressed beams, ``e_j = y_j - y_p,j``
    (the IMU-propagated prediction before the ping's beams update it), its mean square over the measured beams
    smoothed as the completer's (:class:`graphnav.estimators.history.SmoothedSquare`) less the beam noise's variance:
    ``s_graph^2``. A regressed beam of sigma ``s`` is kept (and screened as without the option) when
    ``s^2 < margin s_graph^2``, dropped otherwise. A ping without a measured beam, or without a prediction, keeps
    its completions; a ping without a regressed beam ends the run and its smoothing. Counters (``counts``):
    completions kept and dropped. See docs/decisions/completers.md, "Both errors read on the beams still measured".
    """

    def __init__(self, margin: float, beam_sigma: float):
        self.margin, self.beam_sigma = float(margin), float(beam_sigma)
        self.innovation2 = SmoothedSquare()
        self.counts = {"kept": 0, "dropped": 0}

    def end_run(self) -> None:
        self.innovation2 = SmoothedSquare()

    def keep(self, rows_b: np.ndarray, y: np.ndarray, sigma: np.ndarray, regressed: np.ndarray, C_b_n: np.ndarray,
             omega_b: np.ndarray, lever_arm_b: np.ndarray, prediction: VelocityPrediction | None) -> np.ndarray:
        """(number of regressed rows,) bool: which of a ping's regressed rows (``regressed`` (m,) of the ping's rows
        ``rows_b`` (m,3), beams ``y`` (m,) m/s, sigmas ``sigma`` (m,) m/s) are kept, the graph's innovation on its
        measured rows read first (class docstring)."""
        measured = ~np.asarray(regressed, bool)
        keep = np.ones(int((~measured).sum()), dtype=bool)
        if prediction is not None and measured.any():
            y_p, _ = predicted_beams(rows_b[measured], C_b_n, omega_b, lever_arm_b, prediction)
            self.innovation2.add(float(np.mean((y[measured] - y_p) ** 2)))
            keep = sigma[~measured] ** 2 < self.margin * self.innovation2.less_noise(self.beam_sigma)
        self.counts["kept"] += int(keep.sum())
        self.counts["dropped"] += int((~keep).sum())
        return keep


def motion_prior_factors(k: int, dt: float, options) -> gtsam.NonlinearFactorGraph:
    """Motion prior of keyframe k (k >= 1) linking it to k-1, ``dt`` s apart: the body velocity is a random
    walk of density ``options.motion_prior_rw`` (surge, sway, heave; m/s/sqrt(s)) and, if
    ``options.motion_prior_heave_sigma`` is set, the heave velocity is ~ 0 with that sigma (m/s)."""
    graph = gtsam.NonlinearFactorGraph()
    if k < 1:
        return graph
    if options.motion_prior_rw is not None:
        rw = np.asarray(options.motion_prior_rw, float) * np.sqrt(max(dt, 1e-3))
        graph.add(body_velocity_change_factor(X(k - 1), V(k - 1), X(k), V(k), rw))
    if options.motion_prior_heave_sigma is not None:
        graph.add(nonholonomic_factor(X(k), V(k), [options.motion_prior_heave_sigma], axes=(2,)))
    return graph


def body_velocity_std(prediction: VelocityPrediction, C_b_n: np.ndarray) -> np.ndarray:
    """Predicted body-frame velocity std (surge, sway, heave), m/s: ``sqrt(diag(C_b_n^T P_v C_b_n))`` with
    ``P_v`` the predicted NED velocity covariance and ``C_b_n`` the predicted attitude (body-to-NED)."""
    C_b_n = np.asarray(C_b_n, float)
    return np.sqrt(np.maximum(np.diag(C_b_n.T @ prediction.cov_v_n @ C_b_n), 0.0))


class OutagePriorSwitch:
    """The choice of ``motion_prior="total-if-uncertain"`` at keyframes without any measured beam.

    The motion prior goes in where the graph's predicted body-frame velocity std on the axes the prior
    constrains best (sway and heave, ``MOTION_PRIOR_AXES``) exceeds ``options.motion_prior_switch_std`` (m/s):
    there the IMU alone no longer holds the velocity better than the vehicle model. In 120 s total outages
    on six A-KIT trajectories (1, 2, 4, 6, 8, 10), with 0.2 m/s: the recorded navigation-grade IMU's predicted
    sway std reaches 0.16-0.18 m/s at the end, so the prior never goes in; the tactical IMU passes 0.2 m/s
    after ~53-68 s, the MEMS IMU after ~30 s (the heave std stays below 0.02 m/s: the depth sensor holds it). Once on, the prior stays on until a beam is measured
    again: with the prior in the graph the marginal shrinks below the threshold, and switching it off again
    would make the prior flicker on and off through the outage.

    Counters (``counts``): keyframes of total outages with the prior (``prior``), without it (``no_prior``),
    outages in which it was switched on (``switched_on``); ``max_std`` is the largest predicted std seen on the
    switch axes (m/s), for the report.
    """

    #: body axes (0 surge, 1 sway, 2 heave) whose predicted std decides: the prior's absolute information
    #: (heave ~ 0) and its tightest random-walk axes (small sway and heave velocity of a torpedo AUV)
    MOTION_PRIOR_AXES = (1, 2)

    def __init__(self, options):
        self.threshold = options.motion_prior_switch_std
        self.on = False
        self.counts = {"prior": 0, "no_prior": 0, "switched_on": 0, "max_std": 0.0}

    def decide(self, n_measured: int, prediction: VelocityPrediction | None, C_b_n_pred: np.ndarray) -> bool:
        """Whether a keyframe with ``n_measured`` measured beams gets the motion prior. ``prediction`` is the
        graph's prediction at it (None at the first keyframe: no prior); ``C_b_n_pred`` its predicted attitude."""
        if n_measured > 0:
            self.on = False
            return False
        if prediction is None:
            return False
        std = float(np.max(body_velocity_std(prediction, C_b_n_pred)[list(self.MOTION_PRIOR_AXES)]))
        self.counts["max_std"] = max(self.counts["max_std"], std)
        if not self.on and std > self.threshold:
            self.on = True
            self.counts["switched_on"] += 1
        self.counts["prior" if self.on else "no_prior"] += 1
        return self.on
