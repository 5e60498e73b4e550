"""Model-aided motion priors for an AUV: the vehicle's body-frame velocity is small or slowly varying.

The classic model-aided AUV INS (a flight-style vehicle flies along its nose: sway and heave velocity are
small, surge changes slowly under constant thrust) as GTSAM factors on Pose3 ``x`` (attitude ``R`` =
``C_b_n``) and the NED velocity ``v`` (Vector3), body velocity ``v_b = R^T v_n``:

- :func:`nonholonomic_factor` (unary): ``S v_b - m`` with ``S`` the selected body axes (default sway and
  heave, rows 1 and 2) and ``m`` their expected values (default 0). Over ground, ocean current and crab angle
  make the sway non-zero (the A-KIT DVL sees 0.2-0.3 m/s body-frame sway on long legs), so a zero-sway prior
  needs a sigma that covers it.
- :func:`body_velocity_change_factor` (binary): ``S (v_b,j - v_b,i)`` -- the body-frame velocity is a random
  walk between two keyframes (constant velocity in the body frame), which holds whatever the current is as
  long as it changes slowly. This is the body-frame form of the constant-velocity factors of model-aided
  graph navigators (e.g. CoUG-FGO's constant-velocity factor).

Jacobians (GTSAM's right perturbation ``R Exp(dtheta)``, Pose3 tangent ``[rot, trans]``):
``d(R^T v)/dtheta = [R^T v]x``, ``d(R^T v)/dv = R^T``, nothing on the translation. Checked against numerical
derivatives in ``tests/test_factors.py``.
"""
from __future__ import annotations

import gtsam
import numpy as np

from graphnav.core.beam_model import skew3

#: Body axes 1 (sway, starboard) and 2 (heave, down): the components a flight-style AUV keeps small.
SWAY_HEAVE: tuple[int, ...] = (1, 2)


def _select(axes) -> np.ndarray:
    axes = tuple(int(a) for a in axes)
    if not axes or any(a not in (0, 1, 2) for a in axes):
        raise ValueError(f"axes must be body axes 0..2, got {axes}")
    return np.eye(3)[list(axes)]


def _noise(sigmas, n: int) -> gtsam.noiseModel.Base:
    if isinstance(sigmas, gtsam.noiseModel.Base):
        return sigmas
    s = np.broadcast_to(np.asarray(sigmas, dtype=float), (n,))
    if np.any(~np.isfinite(s)) or np.any(s <= 0):
        raise ValueError(f"motion prior sigmas must be finite and > 0 m/s, got {s}")
    return gtsam.noiseModel.Diagonal.Sigmas(s.copy())


def nonholonomic_factor(x_key: int, v_key: int, sigmas, axes=SWAY_HEAVE, mean=None) -> gtsam.CustomFactor:
    """Unary prior on body-frame velocity components: ``S R^T v_n - mean`` ~ N(0, diag(sigmas^2)).

    Args:
        x_key, v_key: keys of the Pose3 and the NED velocity (Vector3, m/s).
        sigmas: (len(axes),) or scalar std, m/s, or a gtsam noise model.
        axes: body axes constrained (0 surge, 1 sway, 2 heave); default sway and heave.
        mean: expected body velocity on those axes, m/s (default 0).
    """
    S = _select(axes)
    m = np.zeros(len(S)) if mean is None else np.asarray(mean, dtype=float).reshape(len(S))
    noise = _noise(sigmas, len(S))
    zeros = np.zeros((len(S), 3))

    def error(_factor, values, H):
        R = values.atPose3(x_key).rotation().matrix()
        v_b = R.T @ values.atVector(v_key)
        if H is not None:
            H[0] = np.hstack([S @ skew3(v_b), zeros])
            H[1] = S @ R.T
        return S @ v_b - m

    return gtsam.CustomFactor(noise, [x_key, v_key], error)


def body_velocity_change_factor(xi_key: int, vi_key: int, xj_key: int, vj_key: int, sigmas,
                                axes=(0, 1, 2)) -> gtsam.CustomFactor:
    """Between keyframes i and j: ``S (R_j^T v_j - R_i^T v_i)`` ~ N(0, diag(sigmas^2)).

    ``sigmas`` (m/s) is the random-walk std over the interval, i.e. ``q * sqrt(t_j - t_i)`` for a body
    velocity random walk of density ``q`` (m/s/sqrt(s)).
    """
    S = _select(axes)
    noise = _noise(sigmas, len(S))
    zeros = np.zeros((len(S), 3))

    def error(_factor, values, H):
        Ri = values.atPose3(xi_key).rotation().matrix()
        Rj = values.atPose3(xj_key).rotation().matrix()
        vbi = Ri.T @ values.atVector(vi_key)
        vbj = Rj.T @ values.atVector(vj_key)
        if H is not None:
            H[0] = np.hstack([-S @ skew3(vbi), zeros])
            H[1] = -S @ Ri.T
            H[2] = np.hstack([S @ skew3(vbj), zeros])
            H[3] = S @ Rj.T
        return S @ (vbj - vbi)

    return gtsam.CustomFactor(noise, [xi_key, vi_key, xj_key, vj_key], error)
