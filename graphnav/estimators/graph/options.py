"""Settings of the factor-graph estimators (one dataclass, defaults chosen and measured here).

Chosen defaults and why:

- One DVL factor per epoch holding all its measured beams (``beam_factor_mode="epoch"``): each
  ``gtsam.CustomFactor`` call costs a Python round trip plus a copy of the whole ``Values``, so fewer,
  larger factors are faster (``benchmarks/navigator_speed.py`` measures epoch vs beam). Regressed beams go in
  a second factor of the same epoch. A Huber kernel still acts per beam: GTSAM's per-row (``Scalar``)
  reweighting linearises one factor over a ping's beams to exactly the rows of one factor per beam
  (``docs/decisions/speed.md``).
- Regressed beams: noise = the completer's sigma (floored at the measured-beam sigma) with a Huber kernel
  (k = 1.5 sigma) so one bad regression cannot pull the solution.
- Measured beams: Huber kernel at k = 3 sigma (per beam, so a bad beam does not down-weight the
  good ones of its ping). Measured with ``tests/test_faults.py``'s spike fault (1 m/s on one beam in 10 % of
  the pings, simulated 200 s, seeds 1-2, navigation and tactical IMU), Graph-TC VRMSE m/s:
  Gaussian 0.086/0.130/0.116/0.153 -> k=3: 0.036/0.047/0.027/0.046 (k=1.5: 0.037/0.045/0.026/0.047), while on
  the clean missions k=3 changes VRMSE by <= 0.0001 (k=1.5: up to +10 %). Cost: none since the kernel
  reweights each row of the ping's one factor (it used to take four factors per ping, ~30 % more update time).
- ISAM2 and the fixed-lag smoother: QR factorisation (``factorization``). Cholesky was the first choice, but
  with an initial yaw sigma of degrees (a start aligned from the sensors, :mod:`graphnav.estimators.align`) it reported
  ``IndeterminantLinearSystem`` at the first IMU factor, and the restart from marginals (below) then held the
  yaw near its initial error (a 3 deg error still 1.1 deg after 100 s of 0.5 deg heading fixes; QR: 0.05 deg
  after 5 s, as the batch smoother and the EKF). Measured on the simulated 400 s mission, Graph-TC: QR costs
  the same (1.4-1.6 s CPU either way, update median 1.0-2.3 ms for both on a loaded machine) and agrees with
  Cholesky to 3e-11 m/s. The batch smoother keeps Cholesky (``batch_factorization``) and retries with QR.
  The integration covariance of 1e-4 (m^2/s): Cholesky saw indeterminant systems at 1e-8 (horizontal
  position is unobservable while attitude and biases are very well known). Should the solver still hit an
  indeterminant system, it restarts from the last estimate with its marginals as priors and continues (warning).
  The extra 1e-4 m^2/s of position uncertainty per second loosens what the depth says of the vertical velocity:
  on 16 simulated missions the velocity NEES along the body's down axis is 0.50 (Graph-TC) and 0.52 (batch), the
  EKF's 0.94; 0.92 and 0.89 with 1e-3 (``experiments/velocity_band_coverage.py --graph integration_sigma=1e-3``,
  docs/decisions/position-consistency.md). On the ten shared trajectories it
  changes nothing measurable (leave-trajectories-out, ``crossval`` parameter ``integration_sigma``: NEES within
  0.08, 3-missing window VRMSE 0.8 % higher at 1e-3), so it stays (docs/decisions/fitted-defaults.md).
- Relinearisation: per-variable-type thresholds (pose rot 2e-3 rad / pos 1 m, velocity 0.01 m/s,
  bias 1e-3 m/s^2 / 1e-5 rad/s) checked every ``relinearize_skip`` = 10 updates, and only for keyframes
  of the last ``relin_window_s`` = 5 s (older ones are ``noRelinKeys``). Relinearising an old keyframe
  re-eliminates the chain from it to the newest one: with tight thresholds and no window, updates took
  up to 250 ms at 400 s. Measured on simulated 200 s missions (navigation, tactical, MEMS IMU, 3-missing
  outage): VRMSE identical to 4 digits with relinearisation at every update, with this window, and with
  none at all -- predictions from the preintegrated IMU are already close to the optimum.
- Back-substitution: wildfire threshold 0.01 (the newest state is always updated exactly).
- Keyframes (where they go is the stream's business: :class:`graphnav.estimators.keyframes.KeyframeOptions`) at every
  DVL stamp; when no DVL stamp arrives for more than 2 s, IMU-only keyframes every 1 s keep each
  preintegration short.
- DVL error states (``dvl_error_states``): a Vector7 ``D(k)`` per keyframe, [scale per DVL axis (3),
  bias per beam (4) m/s] in the beam model ``y = T_d[(1 + s) v_d] + b`` (the EKF's ``dvl_error_states``),
  prior at the first keyframe (sigmas ``PriorOptions.dvl_scale_sigma`` / ``dvl_bias_sigma``, shared with the
  EKF) and a random walk between keyframes: ``BetweenFactorVector`` with sigma ``rw * sqrt(dt)``. The synthetic beam errors are constant and
  the recorded DVL's own errors drift slowly (sound speed, bottom type), so the walk is small:
  ``dvl_scale_rw`` = 2e-5 /sqrt(s) (2e-4 over 100 s) and ``dvl_bias_rw`` = 2e-4 m/s/sqrt(s) (0.002 m/s over
  100 s); ``experiments/identify_noise.py`` bounds the recorded DVL's drift against the IMU-carried GT from above
  at 1.8e-4..1.2e-3 m/s/sqrt(s) (median 5.9e-4; the GT's slow error is in it too). Leave-trajectories-out
  (``experiments/leave_trajectories_out.py``, docs/decisions/fitted-defaults.md): with the A-KIT IMU densities
  as identified the folds chose a bias walk of 5e-4, but with the densities chosen out of fold (1.4x) they
  choose 1e-4, which scores as 2e-4 does (NEES within 0.05, VRMSE within 0.3 %), so both walks stay.
  **On by default**
  (docs/decisions/consistency.md): on the ten shared trajectories they lower the window VRMSE of Graph-TC, Graph-HN and Graph-HN-batch in
  every scenario and bring their velocity NEES to 1.2-5.3; measured both ways with ``graphnav consistency``.
- Marginals (``marginals="full"``): every output keyframe carries its velocity, position (NED), attitude and
  bias covariances. Full marginals cost 0.15 ms per keyframe over velocity-only ones in the fixed-lag
  smoother and 0.7 ms in ISAM2 (the newest keyframe sits in the Bayes tree's root clique), 0.07 s per 400 s in
  the batch; the estimates are bit-equal at every level (``docs/decisions/covariance-out.md``,
  ``benchmarks/marginals_speed.py``).
- Priors on the first keyframe come from the ground truth of the mission at that time (or an explicit
  initial state), with sigmas ``priors`` below; bias priors are the IMU spec's turn-on sigmas.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from graphnav.core.errors import ConfigError
from graphnav.estimators.coasting import MAX_PURE_INERTIAL_S
from graphnav.estimators.health import HealthOptions
from graphnav.estimators.options import DVL_ERROR_STATES, PriorOptions, RegressedScreeningOptions

BEAM_FACTOR_MODES = ("epoch", "beam")
FACTORIZATIONS = ("CHOLESKY", "QR")
BATCH_SOLVERS = ("vectorized", "lm")
#: Where the batch smoother's factors and initial values come from (GraphOptions.batch_first_pass).
BATCH_FIRST_PASSES = ("incremental", "dead-reckoning")
#: What ``GraphOptions.marginals`` may ask for at every output keyframe (see its docstring).
MARGINAL_LEVELS = ("none", "velocity", "full")
MOTION_PRIOR_MODES = ("off", "partial", "total", "total-if-uncertain")
#: How a run of regressed beams meets the screening (GraphOptions.regressed_runs).
REGRESSED_RUNS = ("screen-each", "screen-first")
#: The graph's side of rehearsed outages (GraphOptions.rehearsal_graph) and how a kept completion enters
#: (GraphOptions.rehearsal_fusion).
REHEARSAL_GRAPHS = ("imu", "twin")
REHEARSAL_FUSIONS = ("independent", "correlated")


def checked_by_count(value, name: str, check):
    """A setting that is one value or a mapping from a number of measured beams (an int >= 0, or its digits, as a
    configuration file's keys come) to a value, each value passed through ``check(value, where)``; a mapping is
    returned as a new dict with int keys (a plain dict: options travel to worker processes by pickle). Raises
    :class:`ConfigError` naming the setting ``name`` and the bad entry."""
    if not isinstance(value, Mapping):
        return check(value, "")
    by_count = {}
    for key, entry in value.items():
        count = int(key) if isinstance(key, str) and key.isdecimal() and key.isascii() else key
        if not isinstance(count, int) or isinstance(count, bool) or count < 0:
            raise ConfigError(f"{name} keys are numbers of measured beams (0, 1, 2, ...), got {key!r}")
        if count in by_count:
            raise ConfigError(f"{name} names {count} measured beams twice ({key!r})")
        by_count[count] = check(entry, f"[{count}]")
    return by_count


def checked_error_tau(tau):
    """``GraphOptions.regressed_error_tau_s`` checked (:func:`checked_by_count`): None or a time > 0 s, or a
    mapping of them by number of measured beams."""
    def time_or_none(value, where):
        if value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)
                             and 0 < value < float("inf")):
            return value
        raise ConfigError(f"regressed_error_tau_s{where} must be a time > 0 s or None, got {value!r}")
    return checked_by_count(tau, "regressed_error_tau_s", time_or_none)


def checked_regressed_runs(runs):
    """``GraphOptions.regressed_runs`` checked (:func:`checked_by_count`): one of :data:`REGRESSED_RUNS`, or a
    mapping of them by number of measured beams."""
    def one_of(value, where):
        if value in REGRESSED_RUNS:
            return value
        raise ConfigError(f"regressed_runs{where} must be one of {REGRESSED_RUNS}, got {value!r}")
    return checked_by_count(runs, "regressed_runs", one_of)


@dataclass
class GraphOptions:
    """Settings of the graph estimators. Units SI (m, s, rad, m/s).

    Attributes:
        beam_sigma: noise of one measured beam, m/s; None = ``config.dvl.beam_noise_std``.
        beam_factor_mode: ``"epoch"`` (one factor per epoch, all beams) or ``"beam"`` (one per beam).
        huber_measured_k: Huber threshold (in sigmas) for measured beams; None = Gaussian.
        huber_regressed_k: Huber threshold (in sigmas) for regressed beams; None = Gaussian.
        regressed_sigma_floor: lowest noise a regressed beam may get, m/s; None = beam_sigma.
        use_depth: add depth factors when the mission has a depth sensor.
        depth_sigma: depth noise, m; None = ``config.depth_noise_std``.
        earth_rate_in_lever_arm: remove the Earth rate (with the predicted attitude) from the gyro sample
            used for the lever-arm velocity, so the DVL sees ``omega_nb_b x l_b``.
        integration_sigma: preintegration integration noise (continuous-time std, m/sqrt(s)); its square is
            GTSAM's integration covariance.
        factorization: ``"QR"`` or ``"CHOLESKY"``, ISAM2 and the fixed-lag smoother.
        batch_factorization: ``"CHOLESKY"`` (retried with QR on an indeterminant system) or ``"QR"``, batch.
        relinearize_skip: ISAM2 relinearisation check interval (updates).
        relin_rot, relin_pos, relin_vel, relin_bias_acc, relin_bias_gyro: per-variable-type thresholds.
        relin_window_s: online ISAM2 holds keyframes older than this at their linearisation point
            (``noRelinKeys``); None = any keyframe may be relinearised.
        wildfire_threshold: ISAM2 Gauss-Newton back-substitution stops where the update is smaller.
        priors: :class:`graphnav.estimators.options.PriorOptions`, the first-keyframe prior sigmas (position,
            velocity, attitude -- None = 0.05 deg --, biases -- None = the IMU spec's turn-on sigmas --, DVL
            error states), named as the EKF's.
        lag_s: fixed-lag smoother lag, s; used by the ``"fixed-lag"`` backend.
        reanchor_interval_s: the fixed-lag smoother is restarted from the last estimate (priors: its marginal
            covariances, block-diagonal) every this many seconds; None = never. GTSAM's smoother slows down
            over hours (update p99 5 ms in hour 1, 18 ms in hour 21 without it:
            ``benchmarks/navigator_speed.py --long-hours 1 21 --no-reanchor``).
        batch_solver: ``"vectorized"`` (Gauss-Newton with numpy-linearised DVL factors, O(N) per
            iteration) or ``"lm"`` (GTSAM LM on the CustomFactor graph, O(N^2)); see :mod:`.batch`.
        batch_max_iterations: iteration cap of the batch solver.
        batch_first_pass: where the batch's factors and initial values come from: ``"incremental"`` (the
            ``mode`` smoother of :func:`~graphnav.estimators.runs.run_graph`, fixed-lag or ISAM2) or
            ``"dead-reckoning"`` (the same factors, states from a DVL-aided dead reckoning without a solver:
            :mod:`.first_pass`; the incremental smoother is used anyway where the factors need its velocity
            covariance, and when a callback asks for the filtered estimates). See docs/decisions/speed.md.
        marginals: the marginal covariances computed at every output keyframe: ``"none"``; ``"velocity"``
            (``cov_v_n``, which the health monitor's innovation test and the regressed-beam screening use);
            ``"full"`` (also position ``cov_p_n`` in NED, attitude ``cov_rot_b`` and biases ``cov_bias``, what the
            outputs print). The estimates do not depend on it; only the cost does
            (``docs/decisions/covariance-out.md``). ``True`` / ``False`` are read as ``"velocity"`` / ``"none"``.
        max_pure_inertial_s: warn when no DVL factor with a measured beam enters for longer than this, s
            (:func:`graphnav.estimators.coasting.check_pure_inertial`).
        screening: :class:`graphnav.estimators.options.RegressedScreeningOptions`, the screening of regressed
            beams against the graph's predicted beam (see :mod:`.regressed`); off by default.
        health: :class:`graphnav.estimators.health.HealthOptions` of the graph's NIS monitor.
        motion_prior: ``"off"``; ``"partial"`` = model-aided motion prior (body-velocity random walk + small
            heave, :func:`.regressed.motion_prior_factors`) at keyframes with fewer than 3 measured beams;
            ``"total"`` = only at keyframes without any measured beam. With a completer, pings without any
            measured beam then get no regressed beams (the prior replaces them);
            ``"total-if-uncertain"`` = at keyframes without any measured beam, the prior once the graph's
            predicted sway/heave velocity std exceeds ``motion_prior_switch_std`` (then until a beam is
            measured again), next to the (screened) completions, which stay
            (:class:`.regressed.OutagePriorSwitch`).
        motion_prior_switch_std: predicted body-velocity std (m/s) above which ``"total-if-uncertain"``
            switches the motion prior on; 0.2 m/s = the sigma of Graph-MP's heave prior, the spread the
            vehicle model allows its small body velocities (0.1 m/s and always-on were worse: docs/decisions/regressed-beams.md).
        motion_prior_rw: body-velocity random-walk densities (surge, sway, heave), m/s/sqrt(s); None = none.
        motion_prior_heave_sigma: heave velocity ~ 0 with this sigma, m/s; None = no heave prior.
        regressed_runs: how a run of regressed beams (a beam regressed at consecutive keyframes; a keyframe
            where it is measured, dropped or absent, such as a position fix between pings, ends the run) meets the
            screening: ``"screen-each"`` = every completion is screened against the graph's prediction
            (:mod:`.regressed`); ``"screen-first"`` = until one completion of the run is kept, then the rest of the
            run enters without the screening, at the completer's sigma (the screening compares a completion with a
            prediction the run's earlier completions have already pulled, and would drop most of them as redundant
            with themselves). A mapping gives one per number of beams measured at the ping (:meth:`runs_for`; a
            count it does not name screens each ping). ``Graph-HNI`` uses ``"screen-first"`` with a beam or more
            measured, with ``regressed_error_tau_s`` by the number of measured beams, 3 s / 10 s / 10 s for 1 / 2
            / 3, and screens each ping in a total outage
            (:data:`graphnav.evaluation.methods.GRAPH_HNI_OPTIONS`, chosen over the folds of five training
            draws, the total outage again with its completions taken out when the beams return); with the
            average estimator it made some folds worse than Graph-TC, so ``Graph-HN`` screens
            each ping; ``Graph-HNP`` screens each ping in a total outage and a run once with a beam or more measured
            (:data:`graphnav.evaluation.methods.GRAPH_HNP_OPTIONS`; docs/decisions/completers.md).
        regressed_error_tau_s: with ``regressed_runs="screen-first"``, the correlation time (s) of a completer's
            errors, modelled as a first-order Gauss-Markov process per beam: the run's later completions enter as
            the whitened difference with the previous one (:func:`graphnav.factors.beam_difference_factor`,
            ``phi = exp(-dt / tau)``, variance ``max(s_k^2 - phi^2 s_(k-1)^2, (1 - phi^2) s_k^2)`` from the
            completer's sigmas); None = independent from ping to ping. A mapping gives one per number of beams
            measured at the ping (``{0: 3.0, 1: 3.0, 2: 10.0, 3: 10.0}``: the completions of a total outage, of
            3, 2 and 1 missing beams come from different completers; :meth:`error_tau_for`), a count it does not
            name taking independent errors. A run whose count changes keeps its chain, at the current ping's time
            (out of fold, with a beam dropping in and out of a 2-missing outage, pooled better than ending the run
            there; docs/decisions/completers.md, "Runs whose number of measured beams changes").
        retire_completions: the incremental smoothers take the factors of the regressed beams (their groups and
            run links, :meth:`.builder.KeyframeFactors.completion_positions`) out of the graph at the first ping
            whose measured beams alone give the velocity (3 or more), so that the returning beams re-estimate the
            outage's states from the IMU and the measured beams only, as without a completer. The filtered
            estimates made during the outage keep the completions. The fixed-lag smoother keeps every keyframe
            since a run's first completion from being marginalised until then, each for at most
            ``retire_hold_s`` (completions older than that plus its lag go into its marginal and stay; so do those
            before a re-anchoring). A failed update's restart keeps them in its prior. The batch smoother leaves
            out those before the mission's last such ping (an outage it ends in keeps its completions). Off by
            default (on in the registry's hybrids); see docs/decisions/completers.md, "Completions
            taken out when the beams return".
        retire_hold_s: with ``retire_completions``, how long the fixed-lag smoother keeps a keyframe of a run of
            completions beyond its lag, s. It relinearises what it keeps: with 2 beams lost for good, the update
            took p99 106 ms with 120 s, 428 ms with 300 s, 14 ms without retiring (simulated 600 s;
            docs/decisions/completers.md).
            120 s covers outages up to 150 s with the default 30 s lag; 0 takes out only what the lag still holds.
        rehearsed_outages: experimental, for the incremental smoothers (ISAM2, fixed-lag) with a completer that can
            rehearse (``rehearse``: the pivot completer, the average estimator, an IMU-aware completer of one
            pattern, its network fed its own completions and both sides scored on its missing beams): the margin
            ``m`` of rehearsed outages (:mod:`graphnav.estimators.rehearsal`): the mission's measured past scores the
            completer's recursion and the graph's IMU-only prediction per horizon into an outage, and a
            completion at horizon ``h`` is kept, at sigma ``e_comp(h)`` and unscreened, only when
            ``e_comp(h) < m e_graph(h)``; None (the default) = off. A graph without a completer, one whose
            completer cannot rehearse and the batch smoother (not studied with it) are refused (ConfigError). See
            docs/decisions/completers.md, "Rehearsed outages".
        rehearsal_graph: with ``rehearsed_outages`` (refused without it), the graph's side of the rehearsals: ``"imu"``
            (the IMU alone) or ``"twin"`` (the IMU-carried velocity fused with the beams the outage's pattern still
            measures, each pattern rehearsed; the completer then scored on the pattern's missing beams).
        rehearsal_fusion: with ``rehearsed_outages`` (refused without it), ``"independent"`` (a completion kept at
            ``e_comp(h)`` when it beats the margin) or ``"correlated"`` (the two rehearsed errors' covariance decides:
            the completion kept at the equivalent independent sigma of their best linear fusion, dropped where it adds
            nothing; the margin is not used). Both experimental; see completers.md, "Rehearsed outages: the graph's
            twin".
        measured_both_margin: experimental, with a completer whose ``run_sigma`` is ``"measured-change"`` (refused
            otherwise): the margin ``m`` by which a completion's recent error must beat the graph's own, both read on
            the beams still measured in the outage (:class:`graphnav.estimators.graph.regressed.GraphPredictionError`):
            a regressed beam of sigma ``s`` is kept only when ``s^2 < m s_graph^2``; None (the default) = off. See
            docs/decisions/completers.md, "Both errors read on the beams still measured".
        dvl_error_states: estimate the DVL scale factor (per DVL axis) and beam biases as graph variables
            ``D(k)`` (random walk between keyframes); see :mod:`graphnav.estimators.graph.dvl_errors`.
        dvl_errors_on_regressed: the DVL error states act on regressed beams too (the completer predicts beams
            as the DVL measures them, bias and scale included); False = regressed beams enter without them.
        dvl_scale_rw: random walk of each scale state, 1/sqrt(s).
        dvl_bias_rw: random walk of each beam bias state, m/s/sqrt(s).
        relin_dvl_scale, relin_dvl_bias: ISAM2 relinearisation thresholds of the DVL error states.
    """

    beam_sigma: float | None = None
    beam_factor_mode: str = "epoch"
    huber_measured_k: float | None = 3.0
    huber_regressed_k: float | None = 1.5
    regressed_sigma_floor: float | None = None
    use_depth: bool = True
    depth_sigma: float | None = None
    earth_rate_in_lever_arm: bool = True
    integration_sigma: float = 1e-2
    factorization: str = "QR"
    batch_factorization: str = "CHOLESKY"
    relinearize_skip: int = 10
    relin_rot: float = 2e-3
    relin_pos: float = 1.0
    relin_vel: float = 1e-2
    relin_bias_acc: float = 1e-3
    relin_bias_gyro: float = 1e-5
    relin_window_s: float | None = 5.0
    wildfire_threshold: float = 1e-2
    priors: PriorOptions = field(default_factory=PriorOptions)
    lag_s: float = 30.0
    reanchor_interval_s: float | None = 600.0
    batch_solver: str = "vectorized"
    batch_max_iterations: int = 20
    batch_first_pass: str = "incremental"
    marginals: str = "full"
    max_pure_inertial_s: float = MAX_PURE_INERTIAL_S
    screening: RegressedScreeningOptions = field(default_factory=RegressedScreeningOptions)
    health: HealthOptions = field(default_factory=HealthOptions)
    motion_prior: str = "off"
    motion_prior_rw: tuple[float, float, float] | None = (0.05, 0.08, 0.03)
    motion_prior_heave_sigma: float | None = 0.05
    motion_prior_switch_std: float = 0.2
    regressed_runs: str | Mapping[int, str] = "screen-each"
    regressed_error_tau_s: float | None | Mapping[int, float | None] = None
    retire_completions: bool = False
    retire_hold_s: float = 120.0
    rehearsed_outages: float | None = None
    rehearsal_graph: str = "imu"
    rehearsal_fusion: str = "independent"
    measured_both_margin: float | None = None
    dvl_error_states: bool = DVL_ERROR_STATES
    dvl_errors_on_regressed: bool = True
    dvl_scale_rw: float = 2e-5
    dvl_bias_rw: float = 2e-4
    relin_dvl_scale: float = 1e-3
    relin_dvl_bias: float = 1e-3

    def __post_init__(self):
        if isinstance(self.marginals, (bool, np.bool_)):
            self.marginals = "velocity" if self.marginals else "none"
        if self.marginals not in MARGINAL_LEVELS:
            raise ConfigError(f"marginals must be one of {MARGINAL_LEVELS}, got {self.marginals!r}")
        if self.beam_factor_mode not in BEAM_FACTOR_MODES:
            raise ConfigError(f"beam_factor_mode must be one of {BEAM_FACTOR_MODES}, got '{self.beam_factor_mode}'")
        self.factorization = self.factorization.upper()
        self.batch_factorization = self.batch_factorization.upper()
        for name in ("factorization", "batch_factorization"):
            if getattr(self, name) not in FACTORIZATIONS:
                raise ConfigError(f"{name} must be one of {FACTORIZATIONS}, got '{getattr(self, name)}'")
        if self.lag_s <= 0:
            raise ConfigError(f"lag_s must be > 0 s, got {self.lag_s}")
        if self.rehearsed_outages is not None and not self.rehearsed_outages > 0:
            raise ConfigError(f"rehearsed_outages must be a margin > 0 (or None: off), got {self.rehearsed_outages}")
        if self.measured_both_margin is not None and not 0 < self.measured_both_margin < float("inf"):
            raise ConfigError(f"measured_both_margin must be a margin > 0 (or None: off), got "
                              f"{self.measured_both_margin}")
        for name, allowed in (("rehearsal_graph", REHEARSAL_GRAPHS), ("rehearsal_fusion", REHEARSAL_FUSIONS)):
            value = getattr(self, name)
            if value not in allowed:
                raise ConfigError(f"{name} must be one of {allowed}, got {value!r}")
            if value != allowed[0] and self.rehearsed_outages is None:
                raise ConfigError(f"{name}={value!r} is a variant of the rehearsed outages: it needs "
                                  "rehearsed_outages (a margin > 0), without which nothing is rehearsed")
        if not self.retire_hold_s >= 0:
            raise ConfigError(f"retire_hold_s must be >= 0 s, got {self.retire_hold_s}")
        if self.motion_prior not in MOTION_PRIOR_MODES:
            raise ConfigError(f"motion_prior must be one of {MOTION_PRIOR_MODES}, got '{self.motion_prior}'")
        self.regressed_error_tau_s = checked_error_tau(self.regressed_error_tau_s)
        self.regressed_runs = checked_regressed_runs(self.regressed_runs)
        # the counts either mapping names, then (-1) the counts neither names
        named = sorted({c for v in (self.regressed_runs, self.regressed_error_tau_s) if isinstance(v, Mapping)
                        for c in v}) + [-1]
        for count in named:
            if self.error_tau_for(count) is not None and self.runs_for(count) != "screen-first":
                where = f" with {count} measured beams" if count >= 0 else \
                    ("" if not named[:-1] else " at the numbers of measured beams that regressed_runs does not name")
                raise ConfigError(f"regressed_error_tau_s models the errors of a run of regressed beams kept without "
                                  f"the screening: it needs regressed_runs='screen-first'{where}")
        if not self.motion_prior_switch_std > 0:
            raise ConfigError(f"motion_prior_switch_std must be > 0 m/s, got {self.motion_prior_switch_std}")
        if self.dvl_scale_rw < 0 or self.dvl_bias_rw < 0:
            raise ConfigError("dvl_scale_rw and dvl_bias_rw must be >= 0")
        if self.batch_solver not in BATCH_SOLVERS:
            raise ConfigError(f"batch_solver must be 'vectorized' or 'lm', got '{self.batch_solver}'")
        if self.batch_first_pass not in BATCH_FIRST_PASSES:
            raise ConfigError(f"batch_first_pass must be one of {BATCH_FIRST_PASSES}, got '{self.batch_first_pass}'")

    @property
    def models_run_errors(self) -> bool:
        """Whether some run of regressed beams enters with a correlation time (``regressed_error_tau_s``)."""
        tau = self.regressed_error_tau_s
        return any(t is not None for t in tau.values()) if isinstance(tau, Mapping) else tau is not None

    def runs_for(self, n_measured: int) -> str:
        """How a run of completions at a ping with ``n_measured`` measured beams meets the screening
        (``regressed_runs``; a count a mapping does not name: ``"screen-each"``)."""
        runs = self.regressed_runs
        return runs.get(n_measured, "screen-each") if isinstance(runs, Mapping) else runs

    def error_tau_for(self, n_measured: int) -> float | None:
        """The correlation time (s) of the completions at a ping with ``n_measured`` measured beams; None =
        independent errors."""
        tau = self.regressed_error_tau_s
        return tau.get(n_measured) if isinstance(tau, Mapping) else tau
