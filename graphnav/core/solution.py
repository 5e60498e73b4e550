"""The output every estimator returns: a navigation solution at its output epochs."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: ``info["alignment"]["position_source"]`` of a solution started from the sensors without a fix or an initial
#: latitude and longitude: its position is dead-reckoned from an origin placed at the start. Its ``cov_p_n``
#: counts from that start; where the start is on Earth (``AlignOptions.local_origin_sigma_m``) is the frame's
#: ``origin_sigma_m`` (``info["alignment"]``, :func:`position_frame`).
LOCAL_ORIGIN = "local origin at start"

#: ``info["position_frame"]["set_by"]``: how the NED frame of a solution's positions was placed (see
#: :func:`position_frame`).
FRAME_INITIAL_STATE = "initial state"        # the initial state's frame (the ground truth's, with --init gt)
FRAME_INITIAL_LLA = "initial_lla"            # the alignment's given latitude and longitude
FRAME_FIX_AT_START = "fix at start"          # a position fix during the alignment
FRAME_FIRST_FIX = "first fix"                # the first fix after a start without position, at its offset
FRAME_UNKNOWN_START = "unknown start"        # dead-reckoned from a start whose place on Earth is unknown
_ALIGNMENT_FRAMES = {LOCAL_ORIGIN: FRAME_UNKNOWN_START, "initial_lla": FRAME_INITIAL_LLA,
                     "fix": FRAME_FIX_AT_START}


def position_frame(info: dict, origin_lla=None, offset_ne_m=(0.0, 0.0), first_fix_t: float | None = None) -> dict:
    """Where a solution's NED positions are on Earth, as ``info["position_frame"]`` and summary.json hold it.

    ``set_by`` (one of the ``FRAME_*`` values) says how the frame was placed; ``origin_lat_deg`` and
    ``origin_lon_deg`` (None when unknown) are the tangent point ``origin_lla`` (rad, rad, m) of the NED frame,
    and ``offset_ne_m`` the north and east (m) that point has in the positions: the latitude and longitude of a
    position ``p_n`` are ``graphnav.core.earth.ned_to_lla(p_n - [offset_n, offset_e, 0], origin)``. A start without
    its position that a fix places later (``first_fix_t_s``) keeps its dead-reckoned positions: the fix's point
    is put where the estimate was at that fix, so the offset is the dead-reckoned position there. An unknown
    start's ``origin_sigma_m`` is the horizontal 1-sigma per axis of where the frame is on Earth (None otherwise).
    ``info`` is the run's (its ``alignment`` when aligned from the sensors)."""
    source = (info.get("alignment") or {}).get("position_source")
    set_by = FRAME_FIRST_FIX if first_fix_t is not None else _ALIGNMENT_FRAMES.get(source, FRAME_INITIAL_STATE)
    known = origin_lla is not None
    sigma = (info.get("alignment") or {}).get("origin_sigma_m") if set_by == FRAME_UNKNOWN_START else None
    return {"set_by": set_by, "origin_lat_deg": float(np.degrees(origin_lla[0])) if known else None,
            "origin_lon_deg": float(np.degrees(origin_lla[1])) if known else None,
            "offset_ne_m": [float(x) for x in offset_ne_m], "first_fix_t_s": first_fix_t,
            "origin_sigma_m": sigma}


def position_frame_line(frame: dict | None) -> str:
    """One line of a summary's ``position_frame`` (:func:`graphnav.core.solution.position_frame`): where the
    positions are on Earth; empty for the initial state's own frame (the ground truth's, nothing to say)."""
    if not frame or frame.get("set_by") == FRAME_INITIAL_STATE:
        return ""
    if frame["set_by"] == FRAME_UNKNOWN_START:
        sigma = frame.get("origin_sigma_m")
        where = "" if sigma is None else f", {sigma:.0f} m per axis"
        return ("positions: NED from the start, whose place on Earth is unknown (no fix, no initial position"
                f"{where}): their covariance and scores count from the start")
    n, e = frame["offset_ne_m"]
    line = (f"positions: NED tangent at lat {frame['origin_lat_deg']:.7f} deg, lon {frame['origin_lon_deg']:.7f} deg"
            f" ({frame['set_by']}")
    if frame["set_by"] == FRAME_FIRST_FIX:
        line += (f" at t = {frame['first_fix_t_s']:.1f} s, which sits at north {n:.2f} m, east {e:.2f} m: "
                 "latitude/longitude of p_n are those of p_n less that offset")
    return line + ")"


@dataclass
class NavSolution:
    """Estimated trajectory of the IMU.

    Attributes:
        method: method name (``LC``, ``TC``, ``Average-LC``, ``Average-TC``, ``HNLC``, ``HNTC``,
            ``Graph-TC``, ``Graph-HN``, ``Graph-HN-batch``, ...).
        t: (K,) output stamps, s (IMU clock).
        p_n: (K,3) NED position, m.
        v_n: (K,3) NED velocity, m/s.
        C_b_n: (K,3,3) body-to-NED rotation.
        cov_v_n: optional (K,3,3) velocity covariance in NED, (m/s)^2.
        cov_p_n: optional (K,3,3) position covariance in NED, m^2 (None: the estimator has no position
            uncertainty, e.g. the paper's 12-state EKF, which integrates position without an error state).
        cov_rot_b: optional (K,3,3) attitude covariance, rad^2, of the right perturbation ``C_b_n = C_hat
            Exp(theta)`` (GTSAM's Rot3 tangent, body axes); :func:`graphnav.core.rotations.heading_variance`
            turns it into a heading variance.
        cov_bias: optional (K,6,6) covariance of the IMU biases ``[acc (m/s^2), gyro (rad/s)]`` (GTSAM's
            ConstantBias order), their units squared.

    Each covariance is the estimator's own marginal of that quantity (GTSAM marginals for the graph, blocks of
    P for the EKF); the cross-covariances between position, attitude, velocity and biases are not carried.
        bias_acc: optional (K,3) accelerometer bias estimate, m/s^2.
        bias_gyro: optional (K,3) gyro bias estimate, rad/s.
        runtime_s: wall time of the whole run, s.
        info: free-form diagnostics (e.g. update timings).
    """

    method: str
    t: np.ndarray
    p_n: np.ndarray
    v_n: np.ndarray
    C_b_n: np.ndarray
    cov_v_n: np.ndarray | None = None
    bias_acc: np.ndarray | None = None
    bias_gyro: np.ndarray | None = None
    cov_p_n: np.ndarray | None = None
    cov_rot_b: np.ndarray | None = None
    cov_bias: np.ndarray | None = None
    runtime_s: float = float("nan")
    info: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.t)

    @property
    def origin_unknown(self) -> bool:
        """True when the solution's horizontal positions are relative to a start whose place on Earth is unknown:
        started without its position (:data:`LOCAL_ORIGIN`) and not placed by a fix later
        (``info["position_frame"]``, :func:`position_frame`)."""
        frame = self.info.get("position_frame")
        if frame is not None:
            return frame.get("set_by") == FRAME_UNKNOWN_START
        return (self.info.get("alignment") or {}).get("position_source") == LOCAL_ORIGIN

    @property
    def origin_sigma_m(self) -> float | None:
        """Horizontal 1-sigma per axis (m) of where an unknown start is on Earth (:attr:`origin_unknown`), which
        ``cov_p_n`` does not hold; None for other starts, or when the run did not record it."""
        if not self.origin_unknown:
            return None
        sigma = (self.info.get("position_frame") or {}).get("origin_sigma_m")
        if sigma is None:
            sigma = (self.info.get("alignment") or {}).get("origin_sigma_m")
        return None if sigma is None else float(sigma)
