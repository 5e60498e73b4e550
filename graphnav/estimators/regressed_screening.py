"""Screening of regressed beams (beams the DVL did not measure, regressed by a completer) against an
estimator's own predicted beams, shared by the factor graph
(:func:`graphnav.estimators.graph.regressed.screen_regressed`) and the EKF
(:meth:`graphnav.estimators.ekf.ErrorStateEkf.screen_regressed`).

The rules (correlation with the prediction, adaptive variance, joint-covariance gate) and the measurements
behind their defaults are in :mod:`graphnav.estimators.graph.regressed`'s docstring.
"""
from __future__ import annotations

import numpy as np


def screen_against_prediction(y: np.ndarray, y_p: np.ndarray, a: np.ndarray, s2: np.ndarray, options,
                              table_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, dict]:
    """The checks of :mod:`graphnav.estimators.graph.regressed`'s docstring for completions ``y`` (m,) m/s of
    variance ``s2`` (m,) (m/s)^2 against the estimator's predicted beams ``y_p`` (m,) of variance ``a`` (m,).
    ``options`` is the estimator's :class:`graphnav.estimators.options.RegressedScreeningOptions`;
    ``table_scale`` the factor of its ``prediction_var_table`` at this ping (1: none). Returns
    (keep (m,) bool, variance (m,), counters)."""
    keep = np.ones(len(y), dtype=bool)
    stats = {"gated": 0, "decorrelated_out": 0, "inflated": 0}
    a = np.maximum(np.asarray(a, float), 1e-12) * options.prediction_var_scale * table_scale
    s2 = np.asarray(s2, float)
    rho = options.correlation
    if rho:
        c = rho * np.sqrt(a * s2)
        informative = c < a
        stats["decorrelated_out"] = int((~informative).sum())
        keep &= informative
        # K >= 1 (c >= s_c^2, a prediction far wider than the completion) has no equivalent factor at y_c;
        # the conditional variance of the completion's error given the prediction's, s_c^2 (1 - rho^2),
        # is the floor
        s2 = np.where(informative, np.maximum(a * (s2 - c) / np.maximum(a - c, 1e-12), s2 * (1 - rho ** 2)), s2)
    # the serial correlation of a completer's errors weakens what the prediction leaves of it. Scaling before the
    # rule above would make a wide variance look redundant with the prediction and drop the completion instead
    s2 = s2 * options.completion_var_scale
    innov2 = (np.asarray(y, float) - y_p) ** 2
    if options.adaptive:
        raised = innov2 - a > s2
        stats["inflated"] = int((raised & keep).sum())
        s2 = np.where(raised, innov2 - a, s2)
    if options.gate_k is not None:
        outside = innov2 > options.gate_k ** 2 * (a + s2)
        stats["gated"] = int((outside & keep).sum())
        keep &= ~outside
    return keep, s2, stats
