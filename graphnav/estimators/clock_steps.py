"""A gap in every stream of a live stream at once: a step of the clock they share, or a loss of every sensor?

A JSON-lines stream has one clock. When it steps forward by ``tau`` s (the logging computer's clock set), every
stream's stamps jump by ``tau`` and no time passed for the vehicle; when every sensor is lost for ``tau`` s, the
stamps jump the same way and the vehicle moved on. Bridged as a loss, a step invents ``tau`` s of turn (the rates
either side interpolated over it); joined as a step, a loss drops a turn. The stamps cannot tell them apart; the
IMU readings either side can, where the vehicle's motion changes over ``tau``: each channel (``f_b``, ``omega_b``)
is fitted on either side (a quadratic over :data:`JUDGE_WINDOW_S`) and the level after the gap compared with

- a step: the level before it carried one IMU period on (no time passed: the readings join up), and
- a loss: the level before it carried ``tau`` s on with the mean of the slopes either side (the trapezoid the
  bridge's linear interpolation integrates), its unmodelled curvature (the slopes' difference over ``tau``) as
  part of its sigma.

:func:`judge_gap` says which one the readings fit (chi-square over the six channels, each residual over the fits'
own standard errors): the one whose chi-square is :data:`RATIO` times smaller (and :data:`MARGIN_CHI2` below), else
undecided (a steady turn or a straight leg reads the same either way; the Navigator then bridges it
as a loss and says the doubt).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the IMU readings fitted on either side of a gap, s (the Navigator holds this long after it before deciding), and
#: at least :data:`MIN_SAMPLES` of them (an IMU slower than 40 Hz is fitted over that many: 1 s at 20 Hz)
JUDGE_WINDOW_S = 0.5
#: gaps in every stream shorter than this are bridged as before, unjudged (s): the two readings of a shorter gap
#: differ by too little turn to matter and to tell
JUDGED_GAP_MIN_S = 1.0
#: a gap of the IMU is one in every stream when the other streams' samples since the IMU sample before it are
#: stamped at most this long (s) before the IMU sample after it (they came after the gap, as the clock stepped)
AFTER_GAP_S = 0.1
#: one hypothesis is chosen when the other's chi-square over the six channels is this many times larger: the
#: readings' motion within a window, which the quadratic leaves, makes the right one's chi-square tens to hundreds.
#: Steps and losses of 5, 2 and 1 s put every 20 s into the ten A-KIT IMU records (180 of each per length): no loss
#: taken for a step, 1 step for a loss (as before: bridged), of the steps 39 told and 140 undecided (a steady
#: vehicle's readings fit both); at 5 s 174 losses told, 6 undecided (RATIO 5: 59 steps told, 2 undecided losses;
#: a window of 1 s: 30 and 24). Simulated 200 s streams (seeds 1-6, eight places): all 96 told.
RATIO = 10.0
#: and by at least this much (chi-square)
MARGIN_CHI2 = 50.0
#: samples needed on either side to judge
MIN_SAMPLES = 20


def side_full(samples) -> bool:
    """Whether the IMU samples ``samples`` ((t s, ...) each, in stamp order) on one side of a gap are enough to fit:
    :data:`JUDGE_WINDOW_S` of them and at least :data:`MIN_SAMPLES`."""
    return len(samples) >= MIN_SAMPLES and samples[-1][0] - samples[0][0] >= JUDGE_WINDOW_S


@dataclass
class GapVerdict:
    """What the IMU readings either side of a gap say: ``kind`` ``"step"``, ``"loss"`` or ``"undecided"``,
    ``chi2_step`` / ``chi2_loss`` (the six channels' chi-square of each hypothesis) and ``why`` (a sentence)."""

    kind: str
    chi2_step: float
    chi2_loss: float
    why: str


def _side_fit(t: np.ndarray, x: np.ndarray, at: float):
    """Quadratic fit of the readings ``x`` (N, 6) at stamps ``t`` (s), about the stamp ``at``: (level (6,), slope
    (6,), standard error of the level (6,), of the slope (6,))."""
    dt = t - at
    A = np.stack([np.ones_like(dt), dt, dt * dt], axis=1)
    coef, *_ = np.linalg.lstsq(A, x, rcond=None)
    resid = x - A @ coef
    s2 = np.sum(resid * resid, axis=0) / max(len(t) - 3, 1)
    inv = np.linalg.inv(A.T @ A)
    return coef[0], coef[1], np.sqrt(s2 * inv[0, 0]), np.sqrt(s2 * inv[1, 1])


def judge_gap(before: list, after: list, period_s: float) -> GapVerdict | None:
    """Judge the gap between the IMU samples ``before`` it and ``after`` it ((t s, f_b m/s^2, omega_b rad/s) each,
    in stamp order, the last of ``before`` and the first of ``after`` bounding the gap; ``period_s`` the IMU's
    period, s). None when either side has under :data:`MIN_SAMPLES` samples (nothing to judge by)."""
    if len(before) < MIN_SAMPLES or len(after) < MIN_SAMPLES:
        return None
    tb = np.array([s[0] for s in before])
    ta = np.array([s[0] for s in after])
    xb = np.array([tuple(s[1]) + tuple(s[2]) for s in before], float)
    xa = np.array([tuple(s[1]) + tuple(s[2]) for s in after], float)
    t0, t1 = tb[-1], ta[0]
    tau = t1 - t0
    lb, sb, elb, esb = _side_fit(tb, xb, t0)
    la, sa, ela, esa = _side_fit(ta, xa, t1)
    # a step: one period passed (the vehicle's readings join up); a loss: tau passed, on the mean slope
    r_step = la - (lb + sb * period_s)
    var_step = ela ** 2 + elb ** 2 + (esb * period_s) ** 2
    r_loss = la - (lb + 0.5 * (sb + sa) * tau)
    var_loss = ela ** 2 + elb ** 2 + (0.5 * tau) ** 2 * (esa ** 2 + esb ** 2) + (0.5 * (sa - sb) * tau) ** 2
    # a channel reading exactly one value on both sides (a quantised gyro at rest, a dead axis) has no spread to
    # weigh its residuals by (0/0: every chi-square NaN, every gap undecided): it tells nothing, and is left out
    told = (var_step > 0.0) & (var_loss > 0.0)
    if not told.any():
        return GapVerdict("undecided", float("nan"), float("nan"), "every IMU channel reads one value on both sides "
                          "of it (nothing to judge by)")
    chi2_step = float(np.sum(r_step[told] ** 2 / var_step[told]))
    chi2_loss = float(np.sum(r_loss[told] ** 2 / var_loss[told]))
    channels = "six" if told.all() else f"{int(told.sum())} (the others read one value either side)"
    numbers = f"chi-square over the {channels} IMU channels: step {chi2_step:.3g}, loss {chi2_loss:.3g}"
    if chi2_loss > max(RATIO * chi2_step, chi2_step + MARGIN_CHI2):
        return GapVerdict("step", chi2_step, chi2_loss, "the IMU readings join up across it as if no time passed "
                          f"and do not fit {tau:.3f} s of the vehicle's motion ({numbers})")
    if chi2_step > max(RATIO * chi2_loss, chi2_loss + MARGIN_CHI2):
        return GapVerdict("loss", chi2_step, chi2_loss, "the IMU readings changed across it as the vehicle's "
                          f"motion does in {tau:.3f} s and do not join up ({numbers})")
    return GapVerdict("undecided", chi2_step, chi2_loss, "the IMU readings fit both (a steady motion reads the same "
                      f"either side; {numbers})")
