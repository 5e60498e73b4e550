"""The average estimator with the hull's turn: a completer that models the vehicle's motion.

A vehicle that turns does not move along its nose at every point: it turns about a pivot point ahead of its middle,
and the points behind the pivot slide outward. In the body frame (FRD) the sway velocity at the IMU is then
``v_y = v_y0 - L r`` with ``r`` the yaw rate (rad/s, ``omega_b[2]``) and ``L`` (m) the pivot point's distance ahead
of the IMU, a property of the hull. A hull that pitches heaves the same way about a point ahead of it:
``v_z = v_z0 + L_q q`` with ``q`` the pitch rate (``omega_b[1]``). The average estimator holds the past beams, so it
holds the sway and heave of the past pings through a turn that starts or ends in the outage. :class:`PivotCompleter`
holds the past body velocity with the turn's sway and heave taken out and puts the ping's own back in, from the gyro:
per missing beam::

    b = mean_j(past_j) + T_b (d_v + d_omega x l),
    d_v = (0, -L (r - mean_j r_j), L_q (q - mean_j q_j)),    d_omega = omega - mean_j omega_j

with ``T_b`` the beams' unit vectors in the body frame, ``l`` the DVL lever arm and the rates per ping the mean gyro
over the ping's DVL period. With ``L = L_q = 0`` and no lever arm it is the average estimator exactly. Its sigma is
the average estimator's with the spread of the past beams taken after their turn terms are removed.

The rates tell what the graph does not know: the hull's hydrodynamics, not more inertial information (the graph
integrates the same gyro). ``L`` and ``L_q`` are fitted by least squares from pings with every beam measured: over
whole logs (:func:`fit_pivot_lengths`) or online over the mission's own (:class:`PivotFit`,
:meth:`PivotCompleter.observe`). On the Snapir AUV the A-KIT trajectories give ``L`` 3.59-3.63 m and ``L_q``
2.60-3.38 m in the leave-two-out folds; the reference trajectory (another system's) gives the same within 0.4 m on
trajectories 1 and 4. The completer models both by default (:data:`DEFAULT_AXES`); ``Graph-HNP`` runs it with the yaw
alone (:data:`graphnav.evaluation.methods.PIVOT_AXES`) (``docs/decisions/completers.md``, "A completer that models
the turn", "The hull's heave in pitch")."""
from __future__ import annotations

import numpy as np

from graphnav.core.errors import ConfigError

from .average import AVERAGE_N_PAST, AverageCompleter
from .completer import check_inputs

#: Outage pings after the hold that :class:`PivotFit` (and :func:`fit_pivot_lengths`) fits the lengths over (the
#: studies' 30 s outages).
FIT_HORIZON_PINGS = 30

#: How much turning, (rad/s)^2, shrinks the online fit of ``L`` toward 0 (the average estimator): ``L = num / (den +
#: prior_turn)`` of :class:`PivotFit`, so ``L`` is half the fit's where the turns seen give ``den = prior_turn``.
#: Early in a mission, or on a straight run with gyro noise, the unshrunk fit can be tens of metres (with none, 36 of
#: 180 held-out fold cells of the completer study were worse than the average). The study's rule picks 0.01; 0.1 is
#: shipped by judgement, further from that cliff (experiments/pivot_completer_folds.py; docs/decisions/completers.md,
#: "A completer that models the turn"). In the estimator 0.01 to 1 are alike (the same fold cells over 1.02x
#: Graph-TC, mean ratios within 0.002: "The pivot completer's prior_turn in the estimator"). With the pitch modelled
#: too it is added to both diagonal terms of the fit's normal equations, ``(den + prior_turn I) (L, L_q) = num``; the
#: beams' vertical components being larger than their lateral ones (sum of squares 3.5 against 0.23 on the Snapir's
#: head), the same turn statistic is reached with a pitch-rate change about four times smaller, and ``L_q`` is shrunk
#: less for it. For the two lengths the rule picks 0.01 again, by 0.2 point ("The hull's heave in pitch").
DEFAULT_PRIOR_TURN = 0.1

#: The turns the completer models by default: the sway from the yaw rate and the heave from the pitch rate. Out of fold
#: the pitch term doubles the per-ping beam gain against the average (+14.5 % against +6.1 % with 2 missing beams,
#: +18.3 % against +9.4 % with 3), no fold worse (experiments/pivot_completer_folds.py --pitch;
#: docs/decisions/completers.md, "The hull's heave in pitch").
DEFAULT_AXES: tuple[str, ...] = ("yaw", "pitch")

#: Past pings the completer holds per beam-outage scenario, with :data:`DEFAULT_AXES`: the average estimator's N
#: (:data:`graphnav.nets.average.AVERAGE_N_PAST`) but 4 with 2 missing beams (the average's 3 gives +14.5 % per-ping
#: beam gain). Chosen by its study's rule over 3-6 per scenario, on all folds and for every fold left out but one
#: (fold 4, which then gets 5 or 6 and is still better than the average in every cell) (experiments/
#: pivot_completer_folds.py --choose-n-past; docs/decisions/completers.md, "The hull's heave in pitch").
DEFAULT_N_PAST: dict[str, int] = {**AVERAGE_N_PAST, "2-missing": 4}


def ping_rates(omega_b: np.ndarray, n_pings: int, samples_per_ping: int) -> np.ndarray:
    """Mean angular rate (n_pings, 3), rad/s, over each of the last ``n_pings`` DVL periods of an IMU window
    ``omega_b`` (M, 3) whose last sample is at the newest ping, oldest first."""
    tail = np.asarray(omega_b, float)[len(omega_b) - n_pings * samples_per_ping:]
    return tail.reshape(n_pings, samples_per_ping, 3).mean(axis=1)


def turn_terms(T_b: np.ndarray, lever_arm_b: np.ndarray, pivot_m: float, omega_b: np.ndarray,
               pitch_pivot_m: float = 0.0) -> np.ndarray:
    """The beams' turn terms (..., 4), m/s, at rates ``omega_b`` (..., 3): ``T_b (-L r e_y + L_q q e_z + omega x l)``,
    the part of the beam velocities that the model ties to the rotation (module docstring); ``L_q`` is
    ``pitch_pivot_m``."""
    omega_b = np.asarray(omega_b, float)
    v = np.cross(omega_b, lever_arm_b)
    v[..., 1] -= pivot_m * omega_b[..., 2]
    v[..., 2] += pitch_pivot_m * omega_b[..., 1]
    return v @ np.asarray(T_b, float).T


def check_axes(axes) -> tuple[str, ...]:
    """The turn axes a pivot fit models, checked: ``("yaw",)`` or ``("yaw", "pitch")``."""
    axes = tuple(axes)
    if axes not in (("yaw",), ("yaw", "pitch")):
        raise ConfigError(f"pivot completer: axes {axes!r} must be ('yaw',) or ('yaw', 'pitch')")
    return axes


class PivotCompleter:
    """Fill missing beams with the past beams held, turned with the hull (module docstring).

    Args:
        T_b: (4, 3) beam unit vectors in the body frame (:attr:`graphnav.core.dvl.DvlGeometry.T_b`).
        lever_arm_b: (3,) DVL position relative to the IMU, body frame, m.
        pivot_m: ``L``, the yaw pivot's distance ahead of the IMU along the body x axis, m; None: ``L`` and, with
            ``"pitch"`` in ``axes``, ``L_q`` fitted online over the mission's measured pings (:meth:`observe`,
            :class:`PivotFit`).
        pitch_pivot_m: ``L_q``, the pitch pivot's distance ahead of the IMU, m, used with a given ``pivot_m``.
        axes: the turns the online fit models: ``("yaw", "pitch")`` (:data:`DEFAULT_AXES`) or ``("yaw",)`` (the
            pitch term left out: ``L_q = 0``).
        n_past: past pings held (the average estimator's N; the completer's chosen hold per beam-outage scenario is
            :data:`DEFAULT_N_PAST`).
        noise_std: beam noise, m/s (the average estimator's sigma formula).
        imu_rate_hz: the IMU rate the window is cut at, Hz.
        ping_dt: the DVL period, s (the past pings must be this far apart; the keyframer checks it).
        prior_turn: with ``pivot_m`` None, the shrinkage of the online fit toward 0 (:attr:`lengths_m`,
            :data:`DEFAULT_PRIOR_TURN`), (rad/s)^2; 0: none (the fit alone, wild while it has seen few turns).

    Without an IMU window (``imu=None``: the first seconds of a mission, after an IMU gap, a DVL period that
    changed) a ping is completed by the average estimator, counted in ``usage["no_imu"]``; so is a window with a
    non-finite rate, counted in ``usage["imu_not_finite"]``. A fully measured ping shown to :meth:`observe` with a
    non-finite beam or rate is left out of the fit and counted in :attr:`observations_refused`. The online fit
    lasts as long as the object: a completer run over several missions fits over all of them (one hull).
    """

    needs_imu = True
    #: a ping without an IMU window is the average estimator's (a completer wrapping this one may hand it None)
    completes_without_imu = True

    def __init__(self, T_b: np.ndarray, lever_arm_b: np.ndarray, pivot_m: float | None = None, n_past: int = 5,
                 noise_std: float = 0.042, imu_rate_hz: float = 100.0, ping_dt: float = 1.0,
                 prior_turn: float = DEFAULT_PRIOR_TURN, pitch_pivot_m: float = 0.0,
                 axes: tuple[str, ...] = DEFAULT_AXES):
        for name, value in (("pivot_m", pivot_m), ("pitch_pivot_m", pitch_pivot_m)):
            if value is not None and not np.isfinite(value):
                raise ConfigError(f"PivotCompleter: {name} = {value!r} is not a distance in m")
        if not np.isfinite(prior_turn) or prior_turn < 0:
            raise ConfigError(f"PivotCompleter: prior_turn = {prior_turn!r} must be >= 0 ((rad/s)^2)")
        samples = imu_rate_hz * ping_dt
        if not np.isfinite(samples) or samples < 0.5:
            raise ConfigError(f"PivotCompleter: the DVL period ({ping_dt} s) must hold an IMU sample at "
                              f"{imu_rate_hz} Hz")
        self.T_b = np.asarray(T_b, float)
        self.lever_arm_b = np.asarray(lever_arm_b, float)
        if self.T_b.shape != (4, 3) or self.lever_arm_b.shape != (3,):
            raise ConfigError(f"PivotCompleter: T_b must be (4, 3) and lever_arm_b (3,), got {self.T_b.shape} and "
                              f"{self.lever_arm_b.shape}")
        self.axes = check_axes(axes)
        self.pivot_m = None if pivot_m is None else float(pivot_m)
        self.pitch_pivot_m = float(pitch_pivot_m)
        self.prior_turn = float(prior_turn)
        self.average = AverageCompleter(n_past=n_past, noise_std=noise_std)
        #: the completer of the pings without an IMU window (the keyframer asks for one)
        self.beam_only = self.average
        self.n_past = n_past
        self.noise_std = noise_std
        self.imu_rate_hz = float(imu_rate_hz)
        self.ping_dt = float(ping_dt)
        # the rate of a ping: the mean over the samples of its DVL period (rounded to whole samples)
        self.samples_per_ping = max(1, int(round(samples)))
        self.imu_samples = (n_past + 1) * self.samples_per_ping
        self.usage = {"imu": 0, "no_imu": 0, "imu_not_finite": 0}
        #: fully measured pings :meth:`observe` left out of the fit: a non-finite beam or rate
        self.observations_refused = 0
        #: the online fit over the mission's measured pings (used when pivot_m is None)
        self.fit = PivotFit(self.T_b, self.lever_arm_b, n_past, FIT_HORIZON_PINGS, ping_dt, self.axes)

    @property
    def lengths_m(self) -> tuple[float, float]:
        """``(L, L_q)`` (m) the completions use now: the given ones, or the online fit shrunk toward 0 (the average
        estimator) by ``prior_turn`` (:meth:`PivotFit.lengths`)."""
        if self.pivot_m is not None:
            return self.pivot_m, self.pitch_pivot_m
        yaw, pitch = self.fit.lengths(self.prior_turn)
        return float(yaw), float(pitch)

    @property
    def length_m(self) -> float:
        """``L`` (m), the yaw pivot's distance ahead of the IMU that completions use now (:attr:`lengths_m`)."""
        return self.lengths_m[0]

    def observe(self, t: float, beams: np.ndarray, imu=None) -> None:
        """A ping at ``t`` (s) whose four ``beams`` (m/s) were all measured, with its IMU window (or None), for the
        online fit: the estimators' keyframer calls it on every such ping."""
        beams = np.asarray(beams, float)
        if beams.shape != (4,):
            raise ConfigError(f"PivotCompleter.observe: beams of shape {beams.shape}, expected (4,)")
        if imu is None:
            self.fit.break_run()
            return
        rate = ping_rates(self._checked(imu), 1, self.samples_per_ping)[0]
        if not (np.all(np.isfinite(beams)) and np.all(np.isfinite(rate))):
            self.observations_refused += 1
            self.fit.break_run()
            return
        self.fit.add(t, beams, rate)

    def _checked(self, imu) -> np.ndarray:
        """The angular rates (imu_samples, 3) of an IMU window: its last ``imu_samples`` samples (a longer window,
        as the IMU-aware networks it is fused with take, ends at the same ping), or a :class:`ConfigError` naming
        its shape."""
        omega = np.asarray(imu[1], float)
        if omega.ndim != 2 or omega.shape[1] != 3 or len(omega) < self.imu_samples:
            raise ConfigError(f"PivotCompleter: IMU window of shape {omega.shape}, expected at least "
                              f"({self.imu_samples}, 3)")
        return omega[len(omega) - self.imu_samples:]

    def complete(self, past: np.ndarray, measured: np.ndarray, imu=None) -> tuple[np.ndarray, np.ndarray]:
        """(beams (4,), sigma (4,)) m/s from ``past`` (n_past, 4), oldest first, ``measured`` (4,) with NaN where
        missing, and ``imu`` = (f_b, omega_b), the last ``imu_samples`` (or more) IMU samples up to the ping (or None)."""
        past, measured = check_inputs(past, measured, self.n_past)
        missing = ~np.isfinite(measured)
        if not missing.any():
            return measured.copy(), np.zeros(4)
        self.fit.break_run()
        if imu is None:
            self.usage["no_imu"] += 1
            return self.average.complete(past, measured)
        rates = ping_rates(self._checked(imu), self.n_past + 1, self.samples_per_ping)
        if not np.all(np.isfinite(rates)):
            self.usage["imu_not_finite"] += 1
            return self.average.complete(past, measured)
        self.usage["imu"] += 1
        beams, straight = self._turned(past, rates)
        spread = np.sqrt(self.noise_std ** 2 * (1.0 + 1.0 / self.n_past) + straight.var(axis=0))
        return np.where(missing, beams, measured), np.where(missing, spread, 0.0)

    def _turned(self, past: np.ndarray, rates: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(the four beams held with the turn, (4,); the past beams with their turn terms taken out, (n_past, 4)),
        m/s, from ``past`` (n_past, 4) and the per-ping ``rates`` (n_past + 1, 3), rad/s."""
        yaw, pitch = self.lengths_m
        turn = turn_terms(self.T_b, self.lever_arm_b, yaw, rates, pitch)
        straight = past - turn[:-1]
        return straight.mean(axis=0) + turn[-1], straight

    def rehearse(self, past: np.ndarray, imu=None) -> np.ndarray:
        """The four beams (m/s) :meth:`complete` would give a ping whose beams are all missing, from ``past``
        (n_past, 4) and ``imu`` (or None: the average's), without counting the ping or ending the online fit's run
        (:mod:`graphnav.estimators.rehearsal`)."""
        past = np.asarray(past, float)
        rates = None if imu is None else ping_rates(self._checked(imu), self.n_past + 1, self.samples_per_ping)
        if rates is None or not np.all(np.isfinite(rates)):
            return past.mean(axis=0)
        return self._turned(past, rates)[0]


class PivotFit:
    """Least-squares fit of the pivot lengths ``L`` and ``L_q`` (m) from pings with every beam measured, one ping at
    a time.

    For every new ping ``k`` and every lag ``h`` in 1..``horizon`` whose ``n_past + h`` pings up to ``k`` are all
    measured and one DVL period apart, the ping is predicted from the mean of the ``n_past`` measured pings before
    ``k - h + 1`` with the turn model, and the lengths minimise the squared error of those predictions summed over
    every such pair (they enter linearly: ``d b / d L = -(r - mean r_j) T_b[:, 1]``, ``d b / d L_q = (q - mean q_j)
    T_b[:, 2]``; the lever-arm term is known). ``axes`` ``("yaw",)`` fits ``L`` alone (``L_q = 0``). At ``h = 1``
    that is :class:`PivotCompleter`'s prediction exactly; further into an outage the completer holds its own
    completions too (a weighted mean of the measured pings), which the fit does not follow: it fits the model, not
    the recursion. :func:`fit_pivot_lengths` runs it over whole logs; :class:`PivotCompleter` runs it online over
    the mission's own measured pings. ``num`` (n_axes,) and ``den`` (n_axes, n_axes) are the normal equations' sums.
    """

    def __init__(self, T_b: np.ndarray, lever_arm_b: np.ndarray, n_past: int = 5, horizon: int = FIT_HORIZON_PINGS,
                 ping_dt: float = 1.0, axes: tuple[str, ...] = DEFAULT_AXES):
        self.T_b = np.asarray(T_b, float)
        self.lever_arm_b = np.asarray(lever_arm_b, float)
        self.n_past, self.horizon, self.ping_dt = int(n_past), int(horizon), float(ping_dt)
        self.axes = check_axes(axes)
        n = len(self.axes)
        self.num = np.zeros(n)
        self.den = np.zeros((n, n))
        self.pairs = 0
        # the beams' change per metre of each length, per unit change of its rate (yaw: -r T_y; pitch: +q T_z)
        self._per_length = np.stack([-self.T_b[:, 1], self.T_b[:, 2]], axis=1)[:, :n]       # (4, n)
        self._recent: list[tuple[float, np.ndarray, np.ndarray]] = []   # (t, beams - lever terms, (r, q))

    def add(self, t: float, beams: np.ndarray, omega_b: np.ndarray) -> None:
        """A ping at ``t`` (s) with all four ``beams`` (m/s) measured and ``omega_b`` (rad/s), the mean rate over
        its DVL period."""
        omega_b = np.asarray(omega_b, float)
        straight = np.asarray(beams, float) - turn_terms(self.T_b, self.lever_arm_b, 0.0, omega_b)
        if self._recent and abs(t - self._recent[-1][0] - self.ping_dt) > 0.25 * self.ping_dt:
            self._recent.clear()        # not one DVL period after the last: a new run of measured pings
        rates = np.array([omega_b[2], omega_b[1]])[:len(self.axes)]
        self._recent.append((float(t), straight, rates))
        del self._recent[:-(self.n_past + self.horizon)]
        n_lags = min(self.horizon, len(self._recent) - self.n_past)
        if n_lags < 1:
            return
        # every lag at once (the keyframer calls this on every measured ping): the held pings of lag h are
        # recent[m - h - n_past : m - h], their means from running sums
        n = len(self.axes)
        held = np.array([np.append(b, r) for _, b, r in self._recent[:-1]])     # (m - 1, 4 + n): beams, rates
        sums = np.vstack([np.zeros(4 + n), np.cumsum(held, axis=0)])
        ends = len(held) + 1 - np.arange(1, n_lags + 1)                      # m - h
        means = (sums[ends] - sums[ends - self.n_past]) / self.n_past
        resid = straight - means[:, :4]                                       # (lags, 4)
        grad = (rates - means[:, 4:])[:, None, :] * self._per_length           # (lags, 4, n)
        # summed per axis as the yaw-only fit always summed, so that fit is unchanged to the bit
        self.num += [np.sum(grad[:, :, i] * resid) for i in range(n)]
        self.den += [[np.sum(grad[:, :, i] * grad[:, :, j]) for j in range(n)] for i in range(n)]
        self.pairs += int(n_lags)

    def break_run(self) -> None:
        """The next ping does not follow the last one added (a ping with a missing beam came between)."""
        self._recent.clear()

    def lengths(self, prior_turn: float = 0.0) -> np.ndarray:
        """``(L, L_q)`` (m) solving the normal equations with ``den`` shrunk toward 0 by ``prior_turn`` ((rad/s)^2
        on its diagonal); a length whose rate has not changed in the pings seen is 0 (the least-norm solution:
        zeros while nothing is seen), and ``L_q = 0`` when only the yaw is fitted."""
        return solve_lengths(self.num, self.den, prior_turn)

    def length(self, min_turn: float = 0.0) -> float | None:
        """The fitted ``L`` (m), or None while the yaw turns seen give ``den[0, 0]`` (sum over the pairs of the
        squared change of yaw rate times ``|T_b[:, 1]|^2``, (rad/s)^2) of ``min_turn`` or less."""
        return float(self.lengths()[0]) if self.den[0, 0] > max(min_turn, 1e-12) else None


def solve_lengths(num: np.ndarray, den: np.ndarray, prior_turn: float = 0.0) -> np.ndarray:
    """``(L, L_q)`` (m) from the normal equations' sums ``num`` (n,) and ``den`` (n, n) of :class:`PivotFit` (n = 1:
    the yaw alone, ``L_q = 0``), ``den`` shrunk toward 0 by ``prior_turn`` on its diagonal; the least-norm solution,
    so a length whose rate never changed is 0."""
    out = np.zeros(2)
    a = den + prior_turn * np.eye(len(num))
    if len(num) == 1:
        out[0] = num[0] / a[0, 0] if a[0, 0] > 0 else 0.0      # the yaw-only fit's division, to the bit
    else:
        out[:len(num)] = np.linalg.pinv(a, rcond=1e-9, hermitian=True) @ num
    return out


def _ping_period(t: np.ndarray) -> float:
    """A log's DVL period, s: the median step of its ping stamps ``t`` (1 s for a single ping)."""
    return float(np.median(np.diff(t))) if len(t) > 1 else 1.0


def measured_series(mission) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(beams (M, 4) m/s, rates (M, 3) rad/s, usable (M,) bool) of a mission's pings: the rates are the mean gyro over
    the DVL period before each ping (over the samples there are); usable where every beam is valid, the period
    starts after the IMU's first sample and holds at least one."""
    t, beams = mission.dvl.t, mission.dvl.beams
    dt = _ping_period(t)
    imu_t, omega = mission.imu.t, mission.imu.omega_b
    lo = np.searchsorted(imu_t, t - dt, side="right")
    hi = np.searchsorted(imu_t, t, side="right")
    csum = np.vstack([np.zeros(3), np.cumsum(omega, axis=0)])
    count = hi - lo
    rates = (csum[hi] - csum[lo]) / np.maximum(count, 1)[:, None]
    usable = mission.dvl.valid.all(axis=1) & (count > 0) & (t - dt >= imu_t[0])
    return beams, rates, usable


def fit_pivot_lengths(missions, n_past: int = 5, horizon: int = FIT_HORIZON_PINGS,
                      axes: tuple[str, ...] = DEFAULT_AXES) -> tuple[float, float]:
    """``(L, L_q)`` (m) fitted by :class:`PivotFit` over the pings with every beam measured in logs of one vehicle
    (:class:`graphnav.core.mission.Mission` objects; their DVL geometry is used); ``L_q = 0`` with ``axes``
    ``("yaw",)``. A :class:`ConfigError` when the logs hold no run of ``n_past + 1`` measured pings or no turn."""
    from graphnav.core.dvl import DvlGeometry
    n = len(check_axes(axes))
    num, den, pairs = np.zeros(n), np.zeros((n, n)), 0
    for mission in missions:
        geometry = DvlGeometry.from_spec(mission.config.dvl)
        t = mission.dvl.t
        fit = PivotFit(geometry.T_b, geometry.lever_arm_b, n_past, horizon, _ping_period(t), axes)
        beams, rates, usable = measured_series(mission)
        for k in range(len(t)):
            if usable[k]:
                fit.add(t[k], beams[k], rates[k])
            else:
                fit.break_run()
        num, den, pairs = num + fit.num, den + fit.den, pairs + fit.pairs
    if pairs == 0:
        raise ConfigError(f"fit_pivot_lengths: no run of {n_past + 1} pings one DVL period apart with every beam "
                          "measured in the logs")
    if den[0, 0] <= 1e-12:
        raise ConfigError("fit_pivot_lengths: the logs hold no turn (the yaw rate never changes), so L is not "
                          "observable")
    yaw, pitch = solve_lengths(num, den)
    return float(yaw), float(pitch)


def fit_pivot_length(missions, n_past: int = 5, horizon: int = FIT_HORIZON_PINGS) -> float:
    """``L`` (m) alone (the yaw turns, ``L_q = 0``): :func:`fit_pivot_lengths` with ``axes`` ``("yaw",)``."""
    return fit_pivot_lengths(missions, n_past, horizon, ("yaw",))[0]
