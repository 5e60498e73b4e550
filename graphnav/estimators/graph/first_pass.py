"""The batch smoother's cheap first pass: every keyframe's factors, and initial values without a solver.

The batch (:mod:`graphnav.estimators.graph.batch`) needs the factors of every keyframe and a starting point
for its Gauss-Newton iterations. An incremental smoother (fixed-lag or ISAM2) gives both, at the price of one
solver update per keyframe (80-90 % of a 1 h Graph-TC-batch run). :class:`DeadReckoningGraph` builds the same
keyframes and factors (it is an :class:`~graphnav.estimators.graph.incremental._IncrementalGraph`) and takes as
the state of keyframe k:

- attitude and position: the IMU factor's prediction from keyframe k-1 (GTSAM's ``PreintegratedCombined
  Measurements.predict``, the gravity of :meth:`~.builder.GraphContext.set_gravity`), the down position from
  the keyframe's depth reading when it has one;
- velocity: the least-squares NED velocity of the keyframe's measured beams at that attitude (the one beam
  model, :class:`graphnav.core.beam_model.BeamModel`, with the DVL error states at zero), or the IMU
  prediction at a keyframe with fewer than three measured rows;
- biases and DVL error states: their initial values throughout.

That is a DVL-aided dead reckoning: its velocity is the DVL's, its attitude drifts with the gyro bias. The
batch starts from it and converges to the optimum of the same factors (``docs/decisions/speed.md``: the
differences to the batch after a fixed-lag first pass, and what they come from).

What the first pass does not have: marginal covariances (the batch computes its own), the innovation test of
the health monitor (no filter to test against: the estimates carry the coasting check only), and a predicted
velocity covariance, so it cannot be used where the factors depend on one (the screening of regressed beams,
``motion_prior="total-if-uncertain"``): :func:`needs_filter` says when.
"""
from __future__ import annotations

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, D, V, X

from graphnav.core.beam_model import BeamModel
from graphnav.core.errors import ConfigError
from graphnav.estimators.graph.builder import GraphContext, GraphKeyframe, tangent_down
from graphnav.estimators.graph.incremental import _IncrementalGraph
from graphnav.estimators.graph.options import GraphOptions
from graphnav.estimators.types import InitialState


def needs_filter(options: GraphOptions, completer) -> bool:
    """True when a keyframe's factors depend on the filter's predicted velocity covariance (screened regressed
    beams with a completer, or ``motion_prior="total-if-uncertain"``): the first pass must then be an
    incremental smoother."""
    return (completer is not None and options.screening.active) or options.motion_prior == "total-if-uncertain"


class DeadReckoningGraph(_IncrementalGraph):
    """Keyframe factors and DVL-aided dead-reckoned states, no solver (see the module docstring)."""

    reanchors = False

    def __init__(self, builder: GraphContext, initial: InitialState, keep_keyframe_graphs: bool = False):
        if needs_filter(builder.options, None):
            raise ConfigError("the dead-reckoning first pass cannot choose motion_prior='total-if-uncertain' "
                              "(it has no velocity covariance); use an incremental first pass")
        super().__init__(builder, initial, keep_keyframe_graphs)
        self._state: dict[int, object] = {}
        self._previous: dict[int, object] = {}
        self.n_dvl_velocity = 0       # keyframes whose velocity is the DVL's least-squares velocity

    def _prediction(self, kf, v_n_pred, bias):
        if kf.n_regressed and needs_filter(self.options, True):
            raise ConfigError("the dead-reckoning first pass cannot screen regressed beams (no velocity "
                              "covariance); use an incremental first pass")
        return None

    def _check_innovation(self, kf, local, pose, v_n, bias) -> None:
        """No filter, no innovation: the dead-reckoned velocity is the DVL's own."""

    def _solve(self, factors, values, kf: GraphKeyframe, first_key=None, remove=()):
        k = kf.index
        pose = values.atPose3(X(k))
        v_n = values.atVector(V(k))
        groups = self._pending_local.groups if self._pending_local is not None else []
        measured = self._dvl_velocity(pose.rotation().matrix(), values.atConstantBias(B(k)).gyroscope(), groups)
        if measured is not None:
            v_n = measured
            self.n_dvl_velocity += 1
        if kf.depth is not None:
            # the depth factor pins the down position: take it, rather than the integrated velocity's drift
            p_n = np.array(pose.translation(), float)
            p_n[2] = tangent_down(self.builder.earth, kf.depth, p_n)
            pose = gtsam.Pose3(pose.rotation(), p_n)
        self._previous = self._state
        self._state = {X(k): pose, V(k): v_n, B(k): values.atConstantBias(B(k))}
        if values.exists(D(k)):
            self._state[D(k)] = values.atVector(D(k))

    @staticmethod
    def _dvl_velocity(C_b_n: np.ndarray, gyro_bias: np.ndarray, groups) -> np.ndarray | None:
        """Least-squares NED velocity (m/s) from a keyframe's measured rows (beams, or a DVL-frame velocity) at
        the attitude ``C_b_n``; None with fewer than 3 independent rows."""
        H, r = [], []
        for g in groups:
            if g.regressed:
                continue
            model = BeamModel(g.rows_b)
            # h = H v_n + c, linear in v_n: c is the lever-arm term
            p = model.predict(C_b_n, np.zeros(3), g.omega_b, gyro_bias, g.lever_arm_b)
            H.append(p.d_v() / g.sigma[:, None])
            r.append((g.y - p.h) / g.sigma)
        if not H or sum(len(h) for h in H) < 3:
            return None
        H, r = np.vstack(H), np.concatenate(r)
        if np.linalg.matrix_rank(H) < 3:
            return None
        return np.linalg.lstsq(H, r, rcond=None)[0]

    def _value(self, key, kind):
        if key in self._state:
            return self._state[key]
        if key in self._previous:
            return self._previous[key]
        raise ConfigError(f"dead-reckoning first pass: no value for key {key} (only the last two keyframes are kept)")

    def _marginal(self, key):
        raise ConfigError("the dead-reckoning first pass has no marginal covariances")

    def _restart(self):
        return None

    def _graph(self):
        raise ConfigError("the dead-reckoning first pass keeps no graph")

    def _estimates(self):
        raise ConfigError("the dead-reckoning first pass keeps no estimates")
