"""Error-state EKF for INS/DVL: the LC and TC baselines and their hybrid (beam-completer) variants, as the standard
15-state filter (default) or the paper's 12-state filter (``EkfOptions(position_states=False, dvl_error_states=False)``; the registry's
``-12`` methods, :mod:`graphnav.evaluation.methods`).

State and conventions
---------------------
Nominal state: attitude ``C_b_n``, velocity ``v_n``, position ``p_n``, accelerometer and gyro biases ``b_a``,
``b_g``. Error state ``dx = [dv_n, eps_n, db_a, db_g, dp_n]`` (15; the paper's 12 are the first four blocks, in
its order, and the paper's filter integrates the position without an error state) with *every* error defined as
estimate minus truth: ``v = v_hat - dv``, ``p = p_hat - dp``, ``b = b_hat - db`` and
``C_b_n = Exp(-eps_n) C_hat_b_n`` (eps is the misalignment of the estimated frame about NED axes; in GTSAM's
right-perturbation form ``C = C_hat Exp(-C_hat^T eps)``). The optional DVL error states (7) follow the
navigation states (indices ``n_nav`` = 12 or 15 onwards: :attr:`ErrorStateEkf.i_scale`, ``i_bias``).

Error model (the local-navigation-frame strapdown error equations of Groves, *Principles of GNSS, Inertial
and Multisensor Integrated Navigation Systems*, 2nd ed., ch. 14, and Savage; derived here for the convention
above and checked against a numerical linearisation of the strapdown in ``tests/test_ekf.py``). The frame is
the Earth model's fixed tangent frame (:mod:`graphnav.core.earth`): no transport rate. The nominal state
uses the gravity of its position, so a position error ``dp`` is a gravity error ``Gamma dp`` with
``Gamma = d g_n / d p_n`` (:meth:`graphnav.core.earth.EarthModel.gravity_gradient_n`, about
``diag(-g/R_M, -g/R_N, +2g/R)``: -1.5e-6 s^-2 horizontally, the Schuler coupling, +3.1e-6 s^-2 vertically, the
unstable vertical channel that depth aiding holds)::

    d(dv)/dt  = -2 [w_ie]x dv - [f_n]x eps - C_b_n db_a + Gamma dp + C_b_n n_a
    d(eps)/dt =               - [w_ie]x eps - C_b_n db_g + C_b_n n_g
    d(db_a)/dt = n_ab,  d(db_g)/dt = n_gb,  d(dp)/dt = dv

so, with ``w = [n_a, n_g, n_ab, n_gb]``::

    F = [[F_vv, F_ve, -C, 0, Gamma], [F_ev=0, F_ee, 0, -C, 0], [0]*5, [0]*5, [I, 0, 0, 0, 0]]
    G = [[C, 0, 0, 0], [0, C, 0, 0], [0, 0, I, 0], [0, 0, 0, I], [0]*4]

The 12-state filter drops the last row and column (``Gamma dp`` has no place without a position error: it is
``Gamma`` times the position error, 1.5e-5 m/s^2 for 10 m).

**Block placement against the paper.** ``../shared/docs/method.md`` prints the velocity row as
``[F_vv, F_ve, 0, C_b^n]`` and the attitude row as ``[F_ev, F_ee, C_b^n, 0]`` (and G with the velocity driven
by the second noise, the attitude by the first) for the state order ``[dv, eps, db_a, db_g]``. That would let
the *gyro* bias drive the velocity error and the *accelerometer* bias the misalignment, which is physically
wrong; it is the textbook matrix with the two bias columns (and noise columns) swapped, i.e. what one gets
with the state order ``[dv, eps, db_g, db_a]``. We use the textbook placement (accelerometer bias into
velocity, gyro bias into attitude). The signs of the bias blocks (-C) follow from "true = estimate -
error" for the biases; the paper's +C corresponds to the opposite bias-error sign and changes nothing else.

Discretisation (the paper's): per IMU segment ``Phi = sum_{r<=order} (F dt)^r / r!`` and
``Q = 0.5 (Phi G Qc G^T + G Qc G^T Phi^T) dt``. With isotropic IMU noise ``G Qc G^T`` is the constant
diagonal ``diag(sa^2 I, sg^2 I, sab^2 I, sgb^2 I)`` (C C^T = I), which the code uses; the 15-state filter adds
the position block ``sa^2 dt^3 / 3`` of integrated white acceleration, without which the paper's ``Q`` is
indefinite in the position rows. The per-segment pairs
are composed between two DVL pings by a pairwise tree, ``(Phi_b, Q_b) o (Phi_a, Q_a) = (Phi_b Phi_a,
Phi_b Q_a Phi_b^T + Q_b)``, which equals propagating P segment by segment.

Measurements (DVL head velocity ``v_d_b = C_b_n^T v_n + (omega_b - b_g) x l_b``, lever arm l_b optional,
``omega_b`` the IMU rate interpolated at the ping stamp), with ``dz = h(x_hat) - y = H dx + noise``:

- LC (>= 3 beams; weighted least-squares velocity): ``H = [C^T, C^T [v_n]x, 0, [l_b]x]``.
  The paper prints ``-C^T [v_n x]``, which is the same row for the opposite misalignment sign.
- TC (one row per beam): ``y_i = b_i^T v_d_b``, ``H_i = b_i^T H_LC`` (b_i the beam unit vector in body).
- DVL-frame velocity measured by the instrument (:meth:`ErrorStateEkf.update_velocity`, both LC and TC): the
  beam model with ``T_d`` = identity, ``y = C_d_b^T v_d_b`` (times ``1 + s`` with the DVL error states, no beam
  bias), ``H = C_d_b^T H_LC``; noise per DVL axis from the ping or ``DvlSpec.velocity_noise_std``, plus the
  beam bias and scale inflation carried through the geometry as for beams.

Position aiding (15-state filter only; :class:`graphnav.estimators.backends.EkfBackend` feeds it):

- depth: ``z = p_D + n``, ``H = e_D`` on ``dp`` (:meth:`ErrorStateEkf.update_depth`; the pressure depth turned into
  the tangent frame's down as the graph's depth factor does, sigma ``config.depth_noise_std``);
- horizontal position fix: ``z = p_NE + n``, ``H = [I_2 0]`` on ``dp`` at the fix's sigma
  (:meth:`ErrorStateEkf.update_position_ne`). The 12-state filter resets its horizontal position to the fix and
  never uses depth (the paper's filter).

Both are gated at ``gate_prob`` outside the DVL's health monitor; after ``EkfOptions.aiding_lockout`` gated in a
row the component is re-initialised from the measurement, with a warning.

The model is linear in the beams, so with four beams (and no DVL error states) an LC update with the WLS
velocity and its covariance is identical to the TC update; LC and TC differ only when beams are missing.

Beam noise: the beams carry a bias (0.01 m/s) and scale factor (0.7 %) besides white noise. The paper's
12-state filter treats them as white noise of variance ``noise^2 + bias^2 + (scale * |beam|)^2`` (each term
from the configuration by default, see :class:`EkfOptions`); it then averages many pings and becomes
overconfident (velocity NEES ~8 on the simulated default mission). ``EkfOptions.dvl_error_states`` adds the
scale factor per DVL axis and the bias per beam as 7 random-constant states (beam model
``y = T_d [(1 + s) C_d_b^T v_d_b] + b``, rows ``H_s = T_d diag(v_d)``, ``H_b = I``). Regressed beams add
their completer sigma^2.

Update: ``K = P H^T S^-1``, Joseph form ``P = (I-KH) P (I-KH)^T + K R K^T``, optional chi-square gating on the
normalised innovation squared, closed-loop correction of the nominal state (v -= dv, C = Exp(-eps) C,
b -= db, p -= dp) and reset of dx to zero (reset Jacobian taken as identity, first order).

Health: every update's NIS (gated or not) goes to a :class:`graphnav.estimators.health.NisMonitor` (``info["health"]``:
chi-square band per block of pings, divergence flag, warnings). Gating cannot lock the filter out: after
``HealthOptions.lockout_rejections`` rejected pings in a row it re-acquires (:meth:`ErrorStateEkf.reacquire`:
velocity from a >= 3-beam least-squares fix, or covariance inflation with fewer beams; attitude variance
inflated) and says so (``experiments/lockout_demo.py``).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.dvl import DvlGeometry
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.rotations import skew, so3_exp_batch
from graphnav.estimators.coasting import MAX_PURE_INERTIAL_S
from graphnav.estimators.health import HealthOptions, NisMonitor
from graphnav.estimators.ins import Strapdown, StrapdownState
from graphnav.estimators.options import DVL_ERROR_STATES, PriorOptions, RegressedScreeningOptions
from graphnav.estimators.regressed_screening import screen_against_prediction

#: the paper's error state [dv_n, eps_n, db_a, db_g]
N_STATES = 12
#: the standard form: the paper's states plus the position error dp_n
N_STATES_15 = 15
N_DVL_STATES = 7
IV, IE, IA, IG = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
#: position error dp_n (15-state filter); the optional DVL error states follow the navigation states
IP = slice(12, 15)


@dataclass
class EkfOptions:
    """Tuning of :class:`ErrorStateEkf`. None means "from the mission's :class:`SensorConfig`".

    Attributes:
        position_states: the standard 15-state filter (True, the default): the position error ``dp_n`` is
            a state, coupled through ``d(dp)/dt = dv`` and the gravity gradient, so depth readings and
            position fixes are measurement updates. False: the paper's 12-state filter (position integrated
            from velocity; a fix resets the horizontal position; no depth), kept to reproduce its numbers
            (the registry's ``-12`` methods).
        priors: :class:`graphnav.estimators.options.PriorOptions`, the initial sigmas, named as the graph's
            first-keyframe priors: position per NED axis (15-state only), velocity (the filter starts on the
            ground truth; it covers GT error and the time offsets of real data), attitude per NED axis (None =
            0.1 deg), biases (None = the IMU spec's turn-on sigmas), DVL error states (None =
            ``max(|config value|, 0.005)``).
        use_depth: update with the depth sensor (15-state only; the paper's filter never uses depth).
        depth_sigma: depth noise, m (None: ``config.depth_noise_std``, as the graph's depth factor).
        aiding_lockout: a depth reading or a position fix is gated like a DVL ping (``gate_prob``, its own
            dof); after this many gated in a row of one kind, that position component is re-initialised
            from the measurement (with a warning): a long dead-reckoned stretch can leave the filter more
            confident than its real error, and the gate must not then refuse every later fix.
        lever_arm: model the DVL lever arm (None: on when ``config.dvl.lever_arm_b`` is non-zero).
        gating: reject updates whose normalised innovation squared exceeds ``chi2.ppf(gate_prob, dof)``.
            On by default (not in the paper): on the simulated 300 s missions (seeds 1-3, navigation/tactical/
            MEMS IMU, 3-missing and 2-missing 30 s windows, a 120 s total outage; TC, LC, HNTC) and on A-KIT
            trajectories 1-3 (3-missing windows) it rejected no update and changed nothing, while it rejects
            every 1 m/s beam spike of ``tests/test_faults.py`` (TC VRMSE 0.086 -> 0.037 m/s).
        gate_prob: gating probability.
        beam_noise_std: white beam noise, m/s (None: ``config.dvl.beam_noise_std``).
        beam_bias_std: inflation for the unmodelled beam bias, m/s (None: max |config.dvl.beam_bias|).
        beam_scale_std: inflation for the unmodelled scale factor, unitless, multiplies |beam| (None: max
            |config.dvl.scale_factor|).
        phi_order: order of the truncated series for Phi.
        imu_noise_scale: factor on the IMU white-noise densities of ``config.imu`` in Q. 1 for simulated
            data; on the recorded A-KIT data the INS disagrees with the ground truth far more than the
            recorded noise densities say (1-s free-inertial velocity error ~0.06 m/s), and all-beam runs
            need about 10-20 for a velocity NEES near 3 (``experiments/ekf_paper_protocol.py`` reports its choice).
        dvl_error_states: add 7 DVL error states (not in the paper): the scale factor per DVL axis ``s``
            (3) and the bias per beam ``b`` (4) of the beam model ``y = T_d [(1 + s) v_d] + b + n``, random
            constants. They are observable through accelerations and turns (the IMU senses velocity
            changes exactly); with them the white-noise inflation for bias/scale defaults to 0. On by default
            (as in the graph): treated as white noise, a constant beam bias and scale average out of the
            velocity but not out of the position; on the ten shared trajectories (TC, all beams) the error
            states take the window VRMSE from 0.0508 to 0.0468 m/s (better on 9 of 10 trajectories, so on
            every leave-two-out fold), the velocity NEES from 3.02 to 2.02 and the horizontal position NEES
            from 6.58 to 1.97 (docs/decisions/ekf-position-states.md). The paper's 12-state filter (the
            ``-12`` methods) keeps them off.
        health: :class:`graphnav.estimators.health.HealthOptions` of the NIS monitor; its ``lockout_rejections``
            consecutive gated pings trigger a re-acquisition.
        reacquire: after a lockout, re-acquire (see :meth:`ErrorStateEkf.reacquire`) instead of staying
            pure inertial. Without it the filter can reject every ping of a mission (seen on a real
            trajectory that starts inside a fast turn: 400 of 400 pings gated, 262 m/s VRMSE).
        sigma_att_reacq_rad: misalignment sigma per NED axis added at a re-acquisition, rad; doubled at each
            further re-acquisition within ``reacq_escalate_s`` of the previous one (the first did not
            cover the error), up to ``sigma_att_reacq_max_rad``.
        reacq_escalate_s: see ``sigma_att_reacq_rad``, s.
        sigma_att_reacq_max_rad: cap of the escalated misalignment sigma, rad.
        sigma_v_reacq: floor of the velocity sigma set at a re-acquisition without a >= 3-beam fix, m/s.
        relevel: at a re-acquisition with a >= 3-measured-beam fix, re-level roll and pitch from the fixes and
            the accelerometers over the rejection run (:meth:`ErrorStateEkf.relevel`).
        screening: :class:`graphnav.estimators.options.RegressedScreeningOptions`, the
            screening of regressed beams against the filter's own predicted beam with their joint
            covariance, as the graph's (:mod:`graphnav.estimators.graph.regressed`; same meaning):
            :meth:`ErrorStateEkf.screen_regressed`. Off by default (the paper's hybrid filter takes the
            completions at the completer's sigma); ``graphnav.evaluation.methods`` switches it on for the
            hybrid methods.
        max_pure_inertial_s: warn when no DVL update with a measured beam enters for longer than this, s
            (:func:`graphnav.estimators.coasting.check_pure_inertial`).
        catch_up_heading_sigma_factor: the heading sigma of the filter that goes on after a sensor alignment's
            catch-up (:class:`graphnav.estimators.navigator.NavigatorOptions` ``align_catch_up``), which runs
            through the alignment's data again: the gyrocompassed heading's sigma times this, at most
            ``AlignOptions.unaligned_heading_sigma_rad`` (30 deg). None: that 30 deg. From 30 deg the first
            pings' noise moves the heading tens of degrees, and linearised there the filter settles degrees off
            claiming tenths (simulated, drawn DVL errors, seeds 14-21: heading NEES 11 after the window, 2.8
            with 10). The prior counts 1 / factor^2 of the alignment's heading information a second time (1 %:
            its sigma 0.5 % too small). A finite factor of 1 or more (under 1 the prior claims more than the
            aligner knows), else a ConfigError. Measured and chosen in docs/decisions/alignment.md.
    """

    position_states: bool = True
    priors: PriorOptions = field(default_factory=PriorOptions)
    use_depth: bool = True
    depth_sigma: float | None = None
    aiding_lockout: int = 3
    lever_arm: bool | None = None
    gating: bool = True
    gate_prob: float = 0.9999
    beam_noise_std: float | None = None
    beam_bias_std: float | None = None
    beam_scale_std: float | None = None
    phi_order: int = 2
    imu_noise_scale: float = 1.0
    dvl_error_states: bool = DVL_ERROR_STATES
    health: HealthOptions = field(default_factory=HealthOptions)
    reacquire: bool = True
    sigma_att_reacq_rad: float = float(np.deg2rad(2.0))
    reacq_escalate_s: float = 30.0
    sigma_att_reacq_max_rad: float = float(np.deg2rad(30.0))
    sigma_v_reacq: float = 0.5
    relevel: bool = True
    screening: RegressedScreeningOptions = field(default_factory=RegressedScreeningOptions)
    max_pure_inertial_s: float = MAX_PURE_INERTIAL_S
    catch_up_heading_sigma_factor: float | None = 10.0

    def __post_init__(self):
        factor = self.catch_up_heading_sigma_factor
        # under 1 the prior claims more than the aligner knows of the heading; inf is no prior (None says that)
        if factor is not None and not (factor >= 1.0 and math.isfinite(factor)):
            raise ConfigError("EkfOptions.catch_up_heading_sigma_factor must be a finite number >= 1 (times the "
                              f"aligned heading's sigma) or None (the 30 deg prior), got {factor}")
        if self.screening.prediction_var_table is not None:
            # the filter does not track the runs of regressed pings the table is indexed by
            raise ConfigError("EkfOptions.screening.prediction_var_table is a factor-graph option (experimental); "
                              "the EKF would ignore it")


def compose_transitions(Phi: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Compose per-segment (Phi_j, Q_j) (n,k,k) in time order into one (Phi, Q) by a pairwise tree."""
    while len(Phi) > 1:
        even = len(Phi) // 2 * 2
        Pa, Pb, Qa, Qb = Phi[0:even:2], Phi[1:even:2], Q[0:even:2], Q[1:even:2]
        Phi_new = Pb @ Pa
        Q_new = Pb @ Qa @ np.swapaxes(Pb, 1, 2) + Qb
        if len(Phi) > even:
            Phi_new = np.concatenate([Phi_new, Phi[-1:]])
            Q_new = np.concatenate([Q_new, Q[-1:]])
        Phi, Q = Phi_new, Q_new
    return Phi[0], Q[0]


def joseph_update(P: np.ndarray, K: np.ndarray, H: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Joseph-form covariance update ``(I - K H) P (I - K H)^T + K R K^T``, symmetrised, for P (n,n), gain K
    (n,m), rows H (m,n), noise R (m,m). With m <= 4 rows per update it is evaluated as two rank-m corrections,
    ``A = P - K (H P)`` and ``A - (A H^T) K^T``, instead of two n x n products (22 states: ~10x fewer
    multiplications); the same matrix to rounding."""
    A = P - K @ (H @ P)
    out = A - (A @ H.T) @ K.T + K @ R @ K.T
    out += out.T
    out *= 0.5
    return out


def so3_exp(phi: np.ndarray) -> np.ndarray:
    """``Exp(phi)`` (3,3) of one rotation vector (3,) rad: :func:`graphnav.core.rotations.so3_exp_batch`'s
    Rodrigues formula and small-angle series, without the batch machinery (one correction per update)."""
    x, y, z = float(phi[0]), float(phi[1]), float(phi[2])
    theta2 = x * x + y * y + z * z
    if theta2 < 1e-8:
        a, b = 1.0 - theta2 / 6.0, 0.5 - theta2 / 24.0
    else:
        theta = math.sqrt(theta2)
        a, b = math.sin(theta) / theta, (1.0 - math.cos(theta)) / theta2
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + a * K + b * (K @ K)


class ErrorStateEkf:
    """Error-state EKF on a strapdown INS, aided by DVL velocity (LC) or beams (TC), and (15-state) by depth and
    position fixes.

    Args:
        config: sensor configuration (noise model, gravity, Earth rate, DVL geometry).
        state: initial nominal state.
        options: tuning; default :class:`EkfOptions`.
        bias_acc, bias_gyro: initial bias estimates, m/s^2 and rad/s (default zero).
        name: estimator name in health warnings (e.g. ``"EKF TC"``).

    Attributes:
        health: the :class:`graphnav.estimators.health.NisMonitor` fed with the NIS of every update (gated or not).
    """

    #: the gravity gradient is re-evaluated when the position has moved this far, m (it changes by ~1e-9 s^-2
    #: per km: g / R^2 horizontally; each evaluation is six ECEF round trips)
    GAMMA_REUSE_M = 100.0

    def __init__(self, config: SensorConfig, state: StrapdownState, options: EkfOptions | None = None,
                 bias_acc: np.ndarray | None = None, bias_gyro: np.ndarray | None = None, name: str = "EKF"):
        self.config = config
        self.name = name
        self.options = opts = options or EkfOptions()
        self.strapdown = Strapdown.from_config(config)
        self.state = state.copy()
        self.bias_acc = np.zeros(3) if bias_acc is None else np.asarray(bias_acc, float).copy()
        self.bias_gyro = np.zeros(3) if bias_gyro is None else np.asarray(bias_gyro, float).copy()
        imu = config.imu
        priors = opts.priors
        sba0, sbg0 = priors.bias_sigmas(imu)
        variances = [np.full(3, priors.velocity_sigma ** 2),
                     np.broadcast_to(np.asarray(priors.attitude_sigma_for("ekf")) ** 2, (3,)),
                     np.full(3, sba0 ** 2), np.full(3, sbg0 ** 2)]
        #: whether the position error is a state (15-state filter) and the number of navigation states, where
        #: the optional DVL error states start
        self.position_states = bool(opts.position_states)
        self.n_nav = N_STATES_15 if self.position_states else N_STATES
        if self.position_states:
            variances.append(np.broadcast_to(np.asarray(priors.position_sigma, float) ** 2, (3,)))
        self.i_scale = slice(self.n_nav, self.n_nav + 3)
        self.i_bias = slice(self.n_nav + 3, self.n_nav + N_DVL_STATES)
        dvl = config.dvl
        self.n_states = self.n_nav + (N_DVL_STATES if opts.dvl_error_states else 0)
        if opts.dvl_error_states:
            ss0, sb0 = priors.dvl_error_sigmas(dvl)
            variances += [np.full(3, ss0 ** 2), np.full(4, sb0 ** 2)]
        self.P = np.diag(np.concatenate(variances))
        #: DVL scale factor per DVL axis (3,) and beam biases (4,) m/s; stay zero without dvl_error_states
        self.dvl_scale = np.zeros(3)
        self.beam_bias = np.zeros(4)
        # G Qc G^T: constant because the IMU noise is isotropic (C C^T = I)
        k = opts.imu_noise_scale
        self.qd = np.repeat([(k * imu.accel_noise_density) ** 2, (k * imu.gyro_noise_density) ** 2,
                             imu.accel_bias_rw ** 2, imu.gyro_bias_rw ** 2], 3)
        if self.position_states:      # no noise drives the position directly: it integrates the velocity
            self.qd = np.r_[self.qd, np.zeros(3)]
        geometry = DvlGeometry.from_spec(config.dvl)
        self.T_b = geometry.T_b
        self.beam_model = geometry.beam_model(dvl_errors=opts.dvl_error_states)
        self.velocity_model = geometry.velocity_model(dvl_errors=opts.dvl_error_states)
        self.C_d_b = geometry.C_d_b
        #: per-axis factor from a beam sigma to the four-beam least-squares velocity sigma (DVL frame)
        self._velocity_gain = geometry.velocity_sigma_d(1.0)
        use_lever = (np.any(config.dvl.lever_arm_b != 0) if opts.lever_arm is None else opts.lever_arm)
        self.lever_arm_b = geometry.lever_arm_b if use_lever else np.zeros(3)
        self.beam_noise_std = config.dvl.beam_noise_std if opts.beam_noise_std is None else opts.beam_noise_std
        modelled = opts.dvl_error_states       # bias and scale are states: no white-noise inflation
        self.beam_bias_std = ((0.0 if modelled else float(np.max(np.abs(dvl.beam_bias))))
                              if opts.beam_bias_std is None else opts.beam_bias_std)
        self.beam_scale_std = ((0.0 if modelled else float(np.max(np.abs(dvl.scale_factor))))
                               if opts.beam_scale_std is None else opts.beam_scale_std)
        #: (3,) white-noise sigma per DVL axis of a DVL-frame velocity without its own, m/s
        self.velocity_noise_std = (dvl.velocity_noise_std if dvl.velocity_noise_std is not None
                                   else self._velocity_gain * self.beam_noise_std)
        self.n_velocity_updates = 0
        from scipy.stats import chi2    # here, not at import: scipy.stats takes ~1 s to import (CLI start-up)
        self._gate = {m: chi2.ppf(opts.gate_prob, m) for m in range(1, 5)}
        self._skew_wie = skew(self.strapdown.omega_ie_n)
        # constant blocks of F and index helpers of the hot paths (no per-call allocation)
        self._F_vv = -2.0 * self._skew_wie
        self._F_ee = -self._skew_wie
        self._eye3 = np.eye(3)
        self._diag_nav = np.arange(self.n_nav)
        self.n_updates = 0
        self.n_gated = 0
        self.health = NisMonitor(name, opts.health)
        self._reacq_level = 0
        self._reacq_t = -np.inf
        # (t, r_n) at the first gated ping of the current rejection run with >= 3 measured beams:
        # r_n = C_hat v_b(fix) - v_hat, the NED velocity residual (see reacquire: re-levelling)
        self._run_start: tuple[float, np.ndarray] | None = None
        self._gamma: tuple[np.ndarray, np.ndarray] | None = None     # (where, Gamma) of gravity_gradient
        # velocity corrections made by depth/fix updates since _run_start (relevel removes them from the residual)
        self._run_aiding_dv = np.zeros(3)
        #: regressed beams screened against the prediction (:meth:`screen_regressed`): counters
        #: regressed beams offered to the screening, dropped (gated, decorrelated out), given a larger variance, and
        #: passed to the update (``entered``; the update's innovation gate can still reject the whole ping)
        self.regressed_screening = {"offered": 0, "gated": 0, "decorrelated_out": 0, "inflated": 0, "entered": 0}
        #: depth and position-fix updates (15-state): used, gated, re-initialised after ``aiding_lockout``
        self.aiding = {kind: {"used": 0, "gated": 0, "reset": 0} for kind in ("depth", "fix")}
        self._aiding_run = {"depth": 0, "fix": 0}
        self.depth_sigma = config.depth_noise_std if opts.depth_sigma is None else float(opts.depth_sigma)

    def set_joint_prior(self, cov_joint: np.ndarray, dvl_errors: np.ndarray | None = None) -> None:
        """Start from a joint covariance (16,16) of the errors (truth - estimate) of [attitude (GTSAM right
        perturbation, body, rad), v_n (m/s), accelerometer bias (m/s^2), DVL scale (3) and beam biases (4, m/s)],
        cross-terms included (an alignment's, :attr:`graphnav.estimators.types.InitialState.cov_joint`), and the
        DVL error states at ``dvl_errors`` (7,); the DVL blocks only with :attr:`EkfOptions.dvl_error_states`."""
        with_dvl = self.n_states > self.n_nav
        idx = np.r_[np.arange(IE.start, IE.stop), np.arange(IV.start, IV.stop), np.arange(IA.start, IA.stop)]
        if with_dvl:
            idx = np.r_[idx, np.arange(self.n_nav, self.n_states)]
        # this filter's errors are estimate - truth, its attitude error eps = -C delta about NED axes
        T = -np.eye(len(idx))
        T[0:3, 0:3] = -self.state.C_b_n
        self.P[np.ix_(idx, idx)] = T @ np.asarray(cov_joint, float)[:len(idx), :len(idx)] @ T.T
        if with_dvl and dvl_errors is not None:
            self.dvl_scale, self.beam_bias = np.array(dvl_errors[:3], float), np.array(dvl_errors[3:], float)

    # --- propagation ------------------------------------------------------------------------------
    def transition(self, path) -> tuple[np.ndarray, np.ndarray]:
        """Per-segment (Phi (n,k,k), Q (n,k,k)), k = 12 or 15 navigation states, along a
        :class:`~graphnav.estimators.ins.PropagationPath`. The 15-state rows: ``d(dp)/dt = dv`` and the gravity
        gradient ``Gamma dp`` in the velocity row, ``Gamma`` taken at the path's start (it changes by
        ~1e-9 s^-2 per km)."""
        n, dt, C, k = len(path.dt), path.dt, path.C_b_n, self.n_nav
        # A = F dt filled block by block (the bias rows stay zero): the same numbers as F * dt
        dt3 = dt[:, None, None]
        A = np.zeros((n, k, k))
        A[:, IV, IV] = self._F_vv * dt3
        A[:, IV, IE] = -skew(path.f_n) * dt3
        minus_C_dt = -C * dt3
        A[:, IV, IA] = minus_C_dt
        A[:, IE, IE] = self._F_ee * dt3
        A[:, IE, IG] = minus_C_dt
        if self.position_states and n:
            A[:, IV, IP] = self.gravity_gradient(path.p_n[0]) * dt3
            A[:, IP, IV] = self._eye3 * dt3
        Phi = A.copy()
        Phi[:, self._diag_nav, self._diag_nav] += 1.0
        term = A
        for r in range(2, self.options.phi_order + 1):
            term = term @ A / r
            Phi += term
        M = Phi * self.qd
        Q = M + np.swapaxes(M, 1, 2)
        Q *= 0.5 * dt3                  # scaling by 0.5 is exact: the same numbers as 0.5 (M + M^T) dt
        if self.position_states:
            # the paper's Q leaves the position block at zero, which with its velocity cross terms
            # (q_a dt^2 / 2) is indefinite; the integrated white acceleration's own term q_a dt^3 / 3 fixes it
            diag_p = self._diag_nav[IP]
            Q[:, diag_p, diag_p] += (self.qd[0] * dt ** 3 / 3.0)[:, None]
        return Phi, Q

    def predict(self, f_b: np.ndarray, omega_b: np.ndarray, dt: np.ndarray) -> None:
        """Propagate nominal state and covariance over zero-order-hold IMU segments.

        Args:
            f_b: (n,3) specific force, m/s^2; omega_b: (n,3) rate, rad/s (body, raw: biases are removed
                here); dt: (n,) segment lengths, s.
        """
        if len(dt) == 0:
            return
        self.state, path = self.strapdown.propagate(self.state, f_b, omega_b, dt, self.bias_acc, self.bias_gyro)
        Phi, Q = compose_transitions(*self.transition(path))
        P, n = self.P, self.n_nav
        if self.n_states == n:
            self.P = Phi @ P @ Phi.T + Q
        else:   # the DVL error states are random constants: Phi = blockdiag(Phi_nav, I), Q = blockdiag(Q_nav, 0)
            cross = Phi @ P[:n, n:]
            P[:n, :n] = Phi @ P[:n, :n] @ Phi.T + Q
            P[:n, n:] = cross
            P[n:, :n] = cross.T

    def nav_covariances(self) -> dict:
        """The filter's marginal covariances in :class:`graphnav.core.solution.NavSolution`'s conventions:
        ``cov_v_n`` (NED, (m/s)^2), ``cov_rot_b`` (GTSAM right perturbation, body axes, rad^2: with
        ``C = Exp(-eps) C_hat = C_hat Exp(-C_hat^T eps)`` it is ``C^T P_eps C``), ``cov_bias`` ([acc, gyro]) and
        ``cov_p_n`` (NED, m^2; None without position error states)."""
        P, C = self.P, self.state.C_b_n
        bias = P[IA.start:IG.stop, IA.start:IG.stop].copy()      # [acc, gyro]: adjacent blocks of P
        cov_p_n = P[IP, IP].copy() if self.position_states else None
        return {"cov_v_n": P[IV, IV].copy(), "cov_rot_b": C.T @ P[IE, IE] @ C, "cov_bias": bias,
                "cov_p_n": cov_p_n}

    def gravity_gradient(self, p_n: np.ndarray) -> np.ndarray:
        """``Gamma = d g_n / d p_n`` (3,3), s^-2, of the Earth model at ``p_n`` (m, navigation frame): about
        ``diag(-g/R_M, -g/R_N, +2g/R)`` (:meth:`graphnav.core.earth.EarthModel.gravity_gradient_n`; zero for a
        flat Earth). With "true = estimate - error" the velocity error gains ``g(p_hat) - g(p) = Gamma dp``."""
        p_n = np.asarray(p_n, float)
        if self._gamma is None or np.max(np.abs(p_n - self._gamma[0])) > self.GAMMA_REUSE_M:
            self._gamma = (p_n.copy(), self.strapdown.earth.gravity_gradient_n(p_n))
        return self._gamma[1]

    def inflate(self, var_v: float, var_att: float) -> None:
        """Add variance per axis to the velocity ((m/s)^2) and misalignment (rad^2) errors, e.g. over an IMU
        gap bridged by interpolation (:meth:`graphnav.core.mission.ImuData.bridge_gaps`)."""
        self.P[IV, IV] += var_v * np.eye(3)
        self.P[IE, IE] += var_att * np.eye(3)

    # --- measurement model -----------------------------------------------------------------------
    def predicted_beams(self, omega_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(h (4,) predicted beams, m/s; H (4, n_states)) at the current state.

        ``h`` is the beam model of :mod:`graphnav.core.beam_model` (``h = T_d [(1 + s) C_d_b^T v_d_b] + b``,
        ``v_d_b = C_b_n^T v_n + (omega_b - b_g) x l_b``, ``omega_b`` the raw IMU rate at the ping, rad/s; s and
        b zero unless :attr:`EkfOptions.dvl_error_states`); ``H`` its Jacobians mapped to this filter's error
        state: with "true = estimate - error" (``v = v_hat - dv``, ``b = b_hat - db``, ``C = C_hat Exp(-C_hat^T
        eps)``) and ``dz = h(x_hat) - y``, every block is the model's derivative, the attitude one taken from
        GTSAM's right perturbation to NED axes: ``H_eps = (dh/dtheta) C_hat^T``.
        """
        return self._predicted(self.beam_model, omega_b)

    def predicted_velocity(self, omega_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(h (3,) predicted DVL-frame velocity of the DVL head, m/s; H (3, n_states)): the beam model with
        ``T_d`` = identity (:meth:`graphnav.core.beam_model.BeamModel.dvl_velocity`), Jacobians mapped as in
        :meth:`predicted_beams`."""
        return self._predicted(self.velocity_model, omega_b)

    def _predicted(self, model, omega_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        C = self.state.C_b_n
        dvl = np.concatenate((self.dvl_scale, self.beam_bias)) if self.n_states > self.n_nav else None
        p = model.predict(C, self.state.v_n, omega_b, self.bias_gyro, self.lever_arm_b, dvl)
        H = np.zeros((len(p.h), self.n_states))
        H[:, IV] = p.d_v()
        H[:, IE] = p.d_rot() @ C.T
        H[:, IG] = p.d_gyro_bias()
        if dvl is not None:
            H[:, self.n_nav:] = p.d_dvl_errors()
        return p.h, H

    def beam_variance(self, beams: np.ndarray) -> np.ndarray:
        """Assumed variance (m/s)^2 of beam measurements of magnitude |beams| (white + bias + scale)."""
        return (self.beam_noise_std ** 2 + self.beam_bias_std ** 2
                + (self.beam_scale_std * np.asarray(beams)) ** 2)

    def velocity_variance(self, v_d: np.ndarray, sigma: np.ndarray | None = None) -> np.ndarray:
        """Assumed variance (m/s)^2 per DVL axis of a measured DVL-frame velocity ``v_d`` (3,) m/s: its white
        noise (``sigma`` (3,) m/s, NaN or None = :attr:`velocity_noise_std`), the beam bias inflation through the
        geometry and the scale inflation on each axis (zero with the DVL error states, as for beams)."""
        white = self.velocity_noise_std if sigma is None else np.where(np.isfinite(sigma), sigma,
                                                                        self.velocity_noise_std)
        return (np.asarray(white, float) ** 2 + (self._velocity_gain * self.beam_bias_std) ** 2
                + (self.beam_scale_std * np.asarray(v_d, float)) ** 2)

    def update_ping(self, ping, tight: bool = True) -> bool:
        """Update with one :class:`~graphnav.estimators.types.Ping` at the gyro rate ``ping.omega_b``: a velocity
        ping with its DVL-frame velocity (:meth:`update_velocity`, the same for TC and LC: a velocity is loosely
        coupled by nature), a beam ping one row per beam (``tight``, :meth:`update_tc`) or as a least-squares
        velocity (:meth:`update_lc_beams`), regressed beams with the completer's sigma added. Returns whether
        the update entered (not gated; LC: >= 3 beams)."""
        if ping.is_velocity:
            return self.update_velocity(ping.v_d, ping.omega_b, ping.v_d_sigma)
        sigma = ping.sigma_regressed if ping.n_regressed else None
        if tight:
            return self.update_tc(ping.beams, ping.omega_b, sigma)
        return self.update_lc_beams(ping.beams, ping.omega_b, sigma)

    def update_velocity(self, v_d: np.ndarray, omega_b: np.ndarray, sigma: np.ndarray | None = None) -> bool:
        """Update with a DVL-frame velocity of the DVL head measured by the instrument, ``v_d`` (3,) m/s, with
        one-sigma ``sigma`` (3,) m/s per DVL axis (None/NaN: the configured one). A lockout re-acquires from the
        velocity itself. Returns whether the update entered (not gated)."""
        v_d = np.asarray(v_d, float).reshape(3)
        var = self.velocity_variance(v_d, sigma)
        C_d_b = self.C_d_b
        fix = (C_d_b @ v_d, C_d_b @ np.diag(var) @ C_d_b.T, "the instrument's DVL-frame velocity")

        def innovation():
            h, H = self.predicted_velocity(omega_b)
            return h - v_d, H, np.diag(var)
        ok = self._update_or_reacquire(innovation, np.full(4, np.nan), omega_b, None, fix=fix)
        self.n_velocity_updates += int(ok)
        return ok

    def _update(self, dz: np.ndarray, H: np.ndarray, R: np.ndarray) -> bool:
        PHt = self.P @ H.T
        S = H @ PHt + R
        S_inv_dz = np.linalg.solve(S, dz)
        nis = float(dz @ S_inv_dz)
        gated = self.options.gating and not nis <= self._gate[min(len(dz), 4)]
        self.health.record(self.state.t, nis, len(dz), accepted=not gated)
        if gated:
            self.n_gated += 1
            return False
        self._run_start = None                     # the nominal state is updated: a new run starts afresh
        self._apply(PHt, S, S_inv_dz, H, R)
        self.n_updates += 1
        return True

    def _apply(self, PHt: np.ndarray, S: np.ndarray, S_inv_dz: np.ndarray, H: np.ndarray, R: np.ndarray,
               ) -> np.ndarray:
        """Joseph-form covariance update and closed-loop correction of the nominal state; returns dx."""
        K = np.linalg.solve(S, PHt.T).T           # S symmetric: K = P H^T S^-1
        dx = PHt @ S_inv_dz
        self.P = joseph_update(self.P, K, H, R)
        # closed-loop correction, then the error state is reset to zero
        self.state.v_n = self.state.v_n - dx[IV]
        self.state.C_b_n = so3_exp(-dx[IE]) @ self.state.C_b_n
        self.bias_acc = self.bias_acc - dx[IA]
        self.bias_gyro = self.bias_gyro - dx[IG]
        if self.position_states:
            self.state.p_n = self.state.p_n - dx[IP]
        if self.n_states > self.n_nav:
            self.dvl_scale = self.dvl_scale - dx[self.i_scale]
            self.beam_bias = self.beam_bias - dx[self.i_bias]
        return dx

    # --- position aiding (15-state filter) ------------------------------------------------------------
    def update_depth(self, down_m: float, sigma_m: float | None = None) -> bool:
        """Update with a depth reading: ``z = p_D + n``, ``down_m`` the navigation frame's down of the reading
        (m; :func:`graphnav.estimators.graph.builder.tangent_down` turns a pressure depth into it), noise
        ``sigma_m`` (None: :attr:`depth_sigma`). ``dz = p_hat_D - z``, ``H = e_D`` on ``dp_n``. Returns whether
        it entered (not gated). Only the 15-state filter has a position error to update."""
        sigma = self.depth_sigma if sigma_m is None else float(sigma_m)
        return self._update_position("depth", np.array([2]), np.array([float(down_m)]), sigma)

    def update_position_ne(self, p_ne: np.ndarray, sigma_m: float) -> bool:
        """Update with a horizontal position fix ``p_ne`` (2,) m (north, east in the navigation frame), one-sigma
        ``sigma_m`` per axis: ``dz = p_hat_NE - p_ne``, ``H = [I_2 0]`` on ``dp_n``. Returns whether it entered
        (not gated). Only the 15-state filter; the paper's 12-state filter resets the position instead."""
        return self._update_position("fix", np.array([0, 1]), np.asarray(p_ne, float).reshape(2), float(sigma_m))

    def _update_position(self, kind: str, axes: np.ndarray, z: np.ndarray, sigma: float) -> bool:
        """Position components ``axes`` (NED indices) measured as ``z`` (m) with white noise ``sigma`` (m).

        Gated with ``gate_prob`` but kept out of the DVL's health monitor and lockout logic (a depth reading
        accepted at every ping must not hide a run of rejected pings); after ``aiding_lockout`` gated in a row
        the components are re-initialised from the measurement (:meth:`_reset_position`)."""
        if not self.position_states:
            raise ConfigError(f"{self.name}: the paper's 12-state filter has no position error state for a {kind} "
                              "update (EkfOptions.position_states=True)")
        if not (np.all(np.isfinite(z)) and np.isfinite(sigma) and sigma > 0):
            raise DataError(f"{self.name}: {kind} update at t={self.state.t:.3f} s needs a finite value and a "
                            f"positive sigma, got {z} m, sigma {sigma} m")
        rows = IP.start + axes
        H = np.zeros((len(axes), self.n_states))
        H[np.arange(len(axes)), rows] = 1.0
        R = np.eye(len(axes)) * sigma ** 2
        dz = self.state.p_n[axes] - z
        PHt = self.P[:, rows]                      # P H^T and H P H^T of a selection H: its columns
        S = PHt[rows] + R
        S_inv_dz = np.linalg.solve(S, dz)
        nis = float(dz @ S_inv_dz)
        counts = self.aiding[kind]
        if self.options.gating and not nis <= self._gate[len(dz)]:
            counts["gated"] += 1
            self._aiding_run[kind] += 1
            if self._aiding_run[kind] >= self.options.aiding_lockout:
                self._reset_position(kind, axes, z, sigma)
            return False
        self._aiding_run[kind] = 0
        dx = self._apply(PHt, S, S_inv_dz, H, R)
        if self._run_start is not None:
            self._run_aiding_dv = self._run_aiding_dv - dx[IV]
        counts["used"] += 1
        return True

    def _reset_position(self, kind: str, axes: np.ndarray, z: np.ndarray, sigma: float) -> None:
        """Re-initialise position components ``axes`` from a measurement ``z`` the gate keeps rejecting: the
        new error is the measurement's own, independent of the other states (its rows of P are cleared)."""
        moved = float(np.linalg.norm(self.state.p_n[axes] - z))
        self.state.p_n[axes] = z
        rows = IP.start + axes
        self.P[rows, :] = 0.0
        self.P[:, rows] = 0.0
        self.P[rows, rows] = sigma ** 2
        self.aiding[kind]["reset"] += 1
        self._aiding_run[kind] = 0
        warnings.warn(f"{self.name}: {self.options.aiding_lockout} {kind} measurements in a row rejected by the gate "
                      f"at t={self.state.t:.3f} s; position re-initialised from the {kind} (moved by {moved:.3g} m)",
                      RuntimeWarning, stacklevel=4)

    def update_lc_beams(self, beams: np.ndarray, omega_b: np.ndarray, sigma_extra: np.ndarray | None = None,
                        ) -> bool:
        """LC update from >= 3 beams (4,) m/s (NaN = missing) by weighted least squares.

        ``v = G y``, ``G = (A^T W A)^-1 A^T W`` over the used beams (A their body-frame unit vectors, W the
        inverse beam variances), ``R_v = (A^T W A)^-1`` and the prediction ``G h(x)``. ``sigma_extra`` (4,)
        m/s is added in quadrature to the beam noise (regressed beams). With fewer than three beams there
        is no update (pure inertial) and False is returned.
        """
        beams, sigma_extra = self.screen_regressed(beams, omega_b, sigma_extra)
        used = np.isfinite(beams)
        if used.sum() < 3:
            return False
        var = self.beam_variance(beams[used])
        if sigma_extra is not None:
            var = var + sigma_extra[used] ** 2
        A = self.T_b[used]
        R_v = np.linalg.inv(A.T @ (A / var[:, None]))
        G = R_v @ (A.T / var)

        def innovation():
            h, H = self.predicted_beams(omega_b)
            return G @ (h[used] - beams[used]), G @ H[used], R_v
        return self._update_or_reacquire(innovation, beams, omega_b, sigma_extra)

    def update_tc(self, beams: np.ndarray, omega_b: np.ndarray, sigma_extra: np.ndarray | None = None) -> bool:
        """Tightly coupled update, one row per finite beam of ``beams`` (4,) m/s (NaN = missing).

        ``sigma_extra`` (4,) m/s is added in quadrature to the beam noise (regressed beams).
        """
        beams, sigma_extra = self.screen_regressed(beams, omega_b, sigma_extra)
        used = np.isfinite(beams)
        if not used.any():
            return False
        y = beams[used]
        var = self.beam_variance(y)
        if sigma_extra is not None:
            var = var + sigma_extra[used] ** 2

        def innovation():
            h, H = self.predicted_beams(omega_b)
            return h[used] - y, H[used], np.diag(var)
        return self._update_or_reacquire(innovation, beams, omega_b, sigma_extra)

    def screen_regressed(self, beams: np.ndarray, omega_b: np.ndarray, sigma_extra: np.ndarray | None,
                         ) -> tuple[np.ndarray, np.ndarray | None]:
        """Regressed beams (``sigma_extra`` > 0) checked against the filter's own predicted beams before an
        update: :func:`graphnav.estimators.regressed_screening.screen_against_prediction` with the predicted
        beam's variance ``a = H_i P H_i^T`` (velocity, attitude and gyro-bias uncertainty) and the completion's
        ``beam variance + sigma_extra^2``. A completion is made from past pings the filter has already used, so
        its error is correlated with the prediction's: where the filter's prediction is sharper than rho times
        the completion, the completion adds nothing and is dropped (NaN); a kept one gets the variance of the
        equivalent independent measurement, raised to what its innovation shows (adaptive). Without it a
        completion that is wrong by more than its sigma (a 30 s outage inside a manoeuvre) pulls the filter
        off and the gate, set for the sum of all rows, does not see it. Returns (beams, sigma_extra)."""
        opts = self.options
        if sigma_extra is None:
            return beams, sigma_extra
        regressed = np.isfinite(beams) & (np.nan_to_num(sigma_extra, nan=0.0) > 0)
        if not regressed.any() or not opts.screening.active:
            self.regressed_screening["entered"] += int(regressed.sum())
            return beams, sigma_extra
        h, H = self.predicted_beams(omega_b)
        Hr = H[regressed]
        a = np.einsum("mi,ij,mj->m", Hr, self.P, Hr)
        var_beam = self.beam_variance(beams[regressed])
        keep, s2, stats = screen_against_prediction(beams[regressed], h[regressed], a,
                                                    var_beam + sigma_extra[regressed] ** 2, opts.screening)
        self.regressed_screening["offered"] += int(regressed.sum())
        for k, n in {**stats, "entered": int(keep.sum())}.items():
            self.regressed_screening[k] += n
        beams, sigma_extra = beams.copy(), np.asarray(sigma_extra, float).copy()
        idx = np.flatnonzero(regressed)
        beams[idx[~keep]] = np.nan
        sigma_extra[idx[~keep]] = np.nan
        sigma_extra[idx[keep]] = np.sqrt(np.maximum(s2[keep] - var_beam[keep], 1e-12))
        return beams, sigma_extra

    def _update_or_reacquire(self, innovation, beams: np.ndarray, omega_b: np.ndarray,
                             sigma_extra: np.ndarray | None, fix: tuple | None = None) -> bool:
        """Update with ``innovation() -> (dz, H, R)`` at the current state; when the gate has now rejected a
        run of pings (lockout), re-acquire and, unless the ping itself made the velocity fix, update again.
        ``fix``: the ping's own velocity fix (see :meth:`reacquire`) instead of one from its beams."""
        if self._update(*innovation()):
            return True
        if self._run_start is None:
            run_fix = fix if fix is not None else self._velocity_fix(beams, sigma_extra)
            if run_fix is not None:
                self._run_start = (self.state.t, self._residual_n(run_fix[0], omega_b))
                self._run_aiding_dv = np.zeros(3)
        if not self._locked_out():
            return False
        if self.reacquire(beams, omega_b, sigma_extra, fix=fix).startswith("velocity re-initialised"):
            return True                            # this ping made the velocity fix
        return self._update(*innovation())

    # --- re-acquisition ------------------------------------------------------------------------------
    def _locked_out(self) -> bool:
        return (self.options.reacquire and self.options.gating
                and self.health.rejection_run >= self.options.health.lockout_rejections)

    def _velocity_fix(self, beams: np.ndarray, sigma_extra: np.ndarray | None):
        """Weighted least-squares DVL-head velocity (3,) m/s, body axes, and its covariance from the *measured*
        beams of a ping (regressed beams never make a fix: the gate may have been right to reject them); None
        with fewer than three."""
        used = np.isfinite(beams)
        if sigma_extra is not None:
            used = used & (np.nan_to_num(sigma_extra, nan=np.inf) == 0)
        if used.sum() < 3:
            return None
        var = self.beam_variance(beams[used])
        A = self.T_b[used]
        R_v = np.linalg.inv(A.T @ (A / var[:, None]))
        return R_v @ (A.T @ (beams[used] / var)), R_v, int(used.sum())

    def _fix_n(self, v_d_b: np.ndarray, omega_b: np.ndarray) -> np.ndarray:
        """NED velocity (3,) m/s of the vehicle from a DVL-head velocity fix ``v_d_b`` (body axes): the beam
        model's ``v_d_b = C_b_n^T v_n + (omega_b - b_g) x l_b`` solved for v_n at the estimated attitude."""
        return self.state.C_b_n @ (v_d_b - np.cross(omega_b - self.bias_gyro, self.lever_arm_b))

    def _residual_n(self, v_d_b: np.ndarray, omega_b: np.ndarray) -> np.ndarray:
        """NED velocity of a fix rotated with the estimated attitude, minus the estimated velocity, m/s."""
        return self._fix_n(v_d_b, omega_b) - self.state.v_n

    def relevel(self, r_n: np.ndarray) -> float | None:
        """Roll/pitch from the DVL and the accelerometers over the rejection run; returns the correction, rad.

        ``r_n`` is the current fix's residual (:meth:`_residual_n`). During a rejection run the nominal state is
        only propagated: with a misalignment eps constant over the run (``C = Exp(-eps) C_hat``, the gyros carry
        both alike) the INS velocity changes by ``Int C_hat f dt + g T`` and the true one by
        ``Exp(-eps) Int C_hat f dt + g T``, while the fixes rotated with the estimated attitude are
        ``w = Exp(eps) v_true``. So the change of the residual ``r = w - v_hat`` over the run, plus ``g T``,
        is ``U = Exp(eps) g T``: the direction of U against gravity gives the tilt part of eps exactly (not
        its first-order image, which the filter's error model holds and which misses ``g (1 - cos eps) T``
        along gravity: 0.3 m/s per second at 14 deg, enough for the gate to reject every ping), whatever the
        vehicle did meanwhile. The rotation about gravity (heading) is not observable this way. Errors: the
        fixes' noise over ``g T`` (0.02 m/s over 5 s: 0.02 deg), an accelerometer bias b (b/g, as in any
        levelling) and Coriolis terms of order ``2 omega_ie eps v T``. Applied when the run spans >= 1 s.
        """
        if self._run_start is None:
            return None
        t0, r0 = self._run_start
        T = self.state.t - t0
        if T < 1.0:
            return None
        g_n = self.strapdown.gravity_at(self.state.p_n)
        # depth/fix updates during the run moved v_hat by _run_aiding_dv: the residual without them
        U = r_n + self._run_aiding_dv - r0 + g_n * T
        axis = np.cross(g_n, U)
        angle = float(np.arctan2(np.linalg.norm(axis), g_n @ U))
        if angle == 0.0:
            return 0.0
        eps = axis / np.linalg.norm(axis) * angle
        self.state.C_b_n = so3_exp_batch(-eps[None])[0] @ self.state.C_b_n
        return angle

    def reacquire(self, beams: np.ndarray, omega_b: np.ndarray, sigma_extra: np.ndarray | None = None,
                  fix: tuple | None = None) -> str:
        """Recover from a gating lockout with the current ping ``beams`` (4,) m/s (NaN = missing).

        A lockout means the state has left the region its covariance describes, so that the gate rejects
        the very measurements that could correct it. As robust (fault-tolerant) INS/DVL filters do, the
        filter falls back on the measurements: with >= 3 beams the velocity is re-initialised from their
        weighted least-squares fix (``v_n = C_b_n (v_d_b - (omega_b - b_g) x l_b)``; its error
        ``-[v_n]x eps + C n_v`` sets the velocity rows of P: ``C R_v C^T`` plus the misalignment's share,
        correlated with eps; the ping is then used up); with
        fewer, the velocity variance is inflated so that the rejected innovation lies inside the gate
        (at least ``sigma_v_reacq``). In both cases the misalignment variance grows by
        ``sigma_att_reacq_rad^2`` per axis (escalating on repeated re-acquisitions), since an attitude error
        (e.g. a start inside a fast turn) is
        the usual cause and must be observable again through the velocity updates. Before the fix, with
        ``EkfOptions.relevel``, roll and pitch are re-levelled from the fixes and the accelerometers over the
        rejection run (:meth:`relevel`): a tilt error of more than a few degrees is otherwise not covered by the
        filter's first-order error model and the gate keeps rejecting. Regressed beams never
        enter the fix.
        ``fix`` = ``(v_d_b (3,) m/s body axes, R_v (3,3), description)``: a velocity the ping measured itself (a
        DVL-frame velocity), used as the fix instead of one from ``beams``.
        The re-acquisition is reported to the health monitor (warning and counter); returns what was done.
        """
        opts = self.options
        used = np.isfinite(beams)
        if sigma_extra is not None:
            # regressed beams never make the fix: the gate may have been right to reject them
            used = used & (np.nan_to_num(sigma_extra, nan=np.inf) == 0)
        if fix is None:
            fix = self._velocity_fix(beams, sigma_extra)
            source = None if fix is None else f"a {int(used.sum())}-measured-beam least-squares fix"
        else:
            source = fix[2]
        levelled = None
        if fix is not None and opts.relevel:
            levelled = self.relevel(self._residual_n(fix[0], omega_b))
        self._run_start = None
        P = self.P
        t = self.state.t
        self._reacq_level = self._reacq_level + 1 if t - self._reacq_t < opts.reacq_escalate_s else 0
        self._reacq_t = t
        sigma_att = min(opts.sigma_att_reacq_rad * 2.0 ** self._reacq_level, opts.sigma_att_reacq_max_rad)
        att_var = sigma_att ** 2
        P[IE, IE] += att_var * np.eye(3)
        C = self.state.C_b_n
        if fix is not None:
            v_d_b, R_v, _ = fix
            v_old = self.state.v_n
            self.state.v_n = self._fix_n(v_d_b, omega_b)
            # v_hat = C_hat v_b: its error is the fix's noise plus the misalignment's share,
            # dv = -[v_hat]x eps + C n_v, so it stays correlated with eps (and through it with the rest)
            J = -skew(self.state.v_n)
            P[IV, :] = J @ P[IE, :]
            P[:, IV] = P[IV, :].T
            P[IV, IV] = J @ P[IE, IE] @ J.T + C @ R_v @ C.T
            how = (f"velocity re-initialised from {source} (changed by "
                   f"{np.linalg.norm(self.state.v_n - v_old):.3g} m/s), "
                   + (f"roll/pitch re-levelled by {np.rad2deg(levelled):.3g} deg, " if levelled is not None else "")
                   + f"attitude sigma +{np.rad2deg(sigma_att):.3g} deg")
        else:
            h, _ = self.predicted_beams(omega_b)
            worst = float(np.max(np.abs(h[used] - beams[used]))) if used.any() else 0.0
            sigma = max(2.0 * worst, opts.sigma_v_reacq)
            P[IV, IV] += sigma ** 2 * np.eye(3)
            how = (f"velocity sigma +{sigma:.3g} m/s ({int(used.sum())} measured beam(s): no velocity fix), attitude "
                   f"sigma +{np.rad2deg(sigma_att):.3g} deg")
        self.P = 0.5 * (P + P.T)
        self.health.reacquired(self.state.t, how)
        return how
