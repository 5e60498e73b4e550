"""Rehearsed outages: the mission's own measured past tells, per horizon, whether a completion or the graph's own
prediction of a missing beam is the better one (``GraphOptions.rehearsed_outages``; experimental, off by default).

Every :attr:`OutageRehearsal.stride` fully measured pings a rehearsal starts at that ping ``t0`` and runs two
predictors forward through the next fully measured pings, as if the beams had been lost after ``t0``:

- the completer's recursion: ``completer.rehearse(past, imu)`` (the four beams completed from the held past,
  without side effects on the completer), fed its own completions ping after ping, as in an outage. A completer of
  one missing pattern (:class:`graphnav.nets.imu_auto.ImuAutoCompleter` with one IMU-aware network:
  ``rehearsal_measured``) is handed the ping's beams, ``rehearse(past, imu, beams)``, completes the pattern's
  missing ones with the measured ones given, and both sides are then scored on the missing beams only
  (:attr:`OutageRehearsal.scored`);
- the graph's prediction with the IMU alone: the filtered state at ``t0`` (attitude, NED velocity, biases) carried
  keyframe by keyframe through the recorded IMU (the keyframes' preintegrations), its vertical velocity the measured
  beams' (the depth sensor holds the graph's through an outage; the IMU alone does not, and on steep beams its
  vertical drift would decide), its beams predicted with the one beam model. It knows nothing of the measured beams
  after ``t0``, so with beams still measured in a real outage it is an upper bound on the graph's error.

Both are scored against the beams measured ``h`` pings after ``t0``: per horizon ``h`` (1 .. ``horizon`` pings), the
mean square error over the four beams of each of the last ``recent`` rehearsals, ``e_comp(h)`` and ``e_graph(h)``
their RMS (m/s). A ping with a beam missing ends every running rehearsal (it cannot be scored).

In a real outage, a beam regressed for the ``h``-th ping of its run is kept when ``e_comp(h) < margin e_graph(h)``
(``margin`` = ``GraphOptions.rehearsed_outages``), at sigma ``e_comp(h)`` and without the graph's screening
(:func:`graphnav.estimators.graph.builder.keyframe_factors`); otherwise it is dropped (the graph keeps its own
prediction). Beyond the horizons rehearsed (fewer than ``min_rehearsals`` each side) the largest horizon below
``h`` that was is read; with none, the completion is left to the screening as without rehearsals. The decisions
are counted (:attr:`OutageRehearsal.counts`: ``completer`` kept, ``graph`` dropped, ``unrehearsed`` screened) and
logged with their stamps and horizons (:attr:`OutageRehearsal.decisions`).

On the ten A-KIT trajectories (``Graph-HNP`` with it, experiments/outage_position_drift.py ``--rehearsed``) it
leaves 81-83 % of the missing beams to the graph with the tactical IMU and about half with MEMS, and gains velocity
pooled, but puts 8-9 fold cells over 1.02x Graph-TC (docs/decisions/completers.md, "Rehearsed outages"): not shipped.
With ``Graph-HNI``'s IMU-aware fold networks (``--hni-rehearsed``) folds 1 and 3 alone put 6-9 fold cells over
1.02x (section "Rehearsed outages with the IMU-aware network"): not shipped either.

Two variants (``GraphOptions.rehearsal_graph`` / ``rehearsal_fusion``; section "Rehearsed outages: the graph's
twin"), both scored per measured-beam pattern of a partial outage (every pattern rehearsed, the ping's read):

- ``graph="twin"``: the IMU-carried velocity (its horizontal variance per horizon the rehearsals' own spread
  against the four beams' velocity; its vertical held at ``beam_sigma``) fused by weighted least squares with the
  beams the pattern still measures (at ``beam_sigma``), the missing beams predicted from that: a twin of the
  graph's prediction without a smoother. The completer is scored on the same missing beams.
- ``fusion="correlated"``: the two errors' covariance measured in the same rehearsals (per horizon and pattern)
  decides: with the graph's variance ``a``, the completion's ``s^2`` and their covariance ``c``, the completion is
  kept at the equivalent independent variance of the two's best linear fusion, ``a (s^2 - c) / (a - c)`` floored
  at ``s^2 (1 - rho^2)`` (:mod:`graphnav.estimators.graph.regressed`'s rule), and dropped when ``c >= a``.
"""
from __future__ import annotations

from collections import deque

import gtsam
import numpy as np

from graphnav.core.beam_model import BeamModel

#: The measured-beam patterns rehearsed for the twin (bit i: beam i measured), a total outage (0) included.
PATTERNS = np.array([[(p >> i) & 1 for i in range(4)] for p in range(15)], dtype=bool)


class _Scores:
    """Per horizon 1..``horizon``: the mean square errors of the last ``recent`` rehearsals, (m/s)^2."""

    def __init__(self, horizon: int, recent: int):
        self.by_h = [deque(maxlen=recent) for _ in range(horizon + 1)]

    def add(self, h: int, err: np.ndarray) -> None:
        if 1 <= h < len(self.by_h) and np.all(np.isfinite(err)):
            self.by_h[h].append(float(np.mean(np.square(err))))

    def mean(self, h: int, least: int) -> float | None:
        """The mean at horizon ``h`` of at least ``least`` rehearsals, else None."""
        return float(np.mean(self.by_h[h])) if len(self.by_h[h]) >= least else None


class _Pairs:
    """Per measured-beam pattern and horizon: (completer's, graph's mean square error, their mean product) over the
    pattern's missing beams, of the last ``recent`` rehearsals, (m/s)^2."""

    def __init__(self, horizon: int, recent: int):
        self.by_h = [[deque(maxlen=recent) for _ in range(horizon + 1)] for _ in PATTERNS]

    def add(self, h: int, e_comp: np.ndarray, e_graph: np.ndarray) -> None:
        """``e_comp`` (4,), ``e_graph`` (len(PATTERNS), 4): the errors of one rehearsal at horizon ``h``, m/s."""
        if 1 <= h < len(self.by_h[0]) and np.all(np.isfinite(e_comp)) and np.all(np.isfinite(e_graph)):
            for p, missing in enumerate(~PATTERNS):
                c, g = e_comp[missing], e_graph[p, missing]
                self.by_h[p][h].append((np.mean(c * c), np.mean(g * g), np.mean(c * g)))


class OutageRehearsal:
    """The rehearsals of one mission, the completer's side fed by the keyframer and the graph's by the incremental
    graph (module docstring). ``T_b`` (4, 3) beam unit vectors and ``lever_arm_b`` (3,) m, body frame."""

    def __init__(self, T_b: np.ndarray, lever_arm_b: np.ndarray, margin: float = 1.0, horizon: int = 120,
                 stride: int = 5, recent: int = 20, min_rehearsals: int = 5, graph: str = "imu",
                 fusion: str = "independent", beam_sigma: float = 0.02):
        self.beams = BeamModel(np.asarray(T_b, float))
        self.twin, self.correlated, self.beam_sigma = graph == "twin", fusion == "correlated", float(beam_sigma)
        #: per pattern and horizon (the variants of the module docstring); None: the four beams' scores decide
        self.pairs = _Pairs(horizon, recent) if self.twin or self.correlated else None
        self.spread = _Scores(horizon, recent)   # the IMU-carried horizontal velocity's error, per axis
        self._comp_errors: dict[tuple[float, int], np.ndarray] = {}   # (start s, h) -> completion - beams
        self.lever_arm_b = np.asarray(lever_arm_b, float)
        self.margin, self.horizon, self.stride, self.min_rehearsals = float(margin), horizon, stride, min_rehearsals
        self.comp, self.graph = _Scores(horizon, recent), _Scores(horizon, recent)
        #: (4,) bool, the beams both sides are scored on: all four, or a one-pattern completer's missing ones
        self.scored = np.ones(4, dtype=bool)
        self._n_measured = 0
        self._started: set[float] = set()        # stamps the completer's side started a rehearsal at
        self._comp_runs: list[list] = []         # [h, past (n_past, 4)]
        self._graph_runs: list[list] = []        # [h, NavState, bias]
        self.counts = {"completer": 0, "graph": 0, "unrehearsed": 0}
        #: (stamp s, horizon pings, "completer" / "graph" / "unrehearsed", beam, e_comp, e_graph m/s (NaN
        #: unrehearsed), completion m/s) of each regressed beam decided
        self.decisions: list[tuple] = []

    # --- the completer's side (the keyframer) ------------------------------------------------------
    def completer_ping(self, completer, t: float, beams: np.ndarray, imu, history) -> None:
        """A ping at ``t`` (s) whose four ``beams`` (m/s) were measured, after it entered ``history`` (the
        completer's :class:`~graphnav.estimators.history.BeamHistory`); ``imu`` the completer's window or None."""
        pattern = getattr(completer, "rehearsal_measured", None)
        if pattern is not None:
            # a completer of one pattern (the IMU-aware network): its measured beams given, its missing ones scored
            self.scored = ~np.asarray(pattern, bool)
        for run in self._comp_runs:
            run[0] += 1
            completion = np.asarray(completer.rehearse(run[1], imu) if pattern is None
                                    else completer.rehearse(run[1], imu, beams), float)
            self.comp.add(run[0], (completion - beams)[self.scored])
            if self.pairs is not None:
                self._comp_errors[(run[2], run[0])] = completion - beams
            run[1] = np.vstack([run[1][1:], completion])
        self._comp_runs = [r for r in self._comp_runs if r[0] < self.horizon]
        self._n_measured += 1
        if history.ready and self._n_measured % self.stride == 0:
            self._comp_runs.append([0, history.past()[-completer.n_past:], float(t)])
            self._started.add(float(t))

    def interrupt(self) -> None:
        """A ping with a beam missing: the running rehearsals cannot be scored on."""
        self._comp_runs, self._graph_runs = [], []
        self._comp_errors.clear()

    # --- the graph's side --------------------------------------------------------------------------
    def graph_keyframe(self, kf, estimate) -> None:
        """After the update of keyframe ``kf`` (a :class:`~graphnav.estimators.graph.builder.GraphKeyframe`) whose
        filtered state is ``estimate``: carry the running rehearsals through its IMU, score them on its ping."""
        ping = kf.ping
        if ping is not None and not ping.is_velocity and not ping.measured.all():
            self._graph_runs = []
            self._comp_errors.clear()
            return
        scored = ping is not None and not ping.is_velocity
        for run in self._graph_runs:
            run[1] = kf.pim.predict(run[1], run[2])
            if scored:
                run[0] += 1
                C = run[1].pose().rotation().matrix()
                v_n = self._depth_held(run[1].velocity(), C, ping.beams, ping.omega_b - run[2].gyroscope())
                h = self.beams.predict(C, v_n, ping.omega_b, run[2].gyroscope(), self.lever_arm_b).h
                self.graph.add(run[0], (h - ping.beams)[self.scored])
                if self.pairs is not None:
                    self._score_patterns(run[0], run[3], C, v_n, ping.beams, ping.omega_b - run[2].gyroscope())
        self._graph_runs = [r for r in self._graph_runs if r[0] < self.horizon]
        if scored and float(ping.t) in self._started:
            self._started.discard(float(ping.t))
            self._graph_runs.append([0, gtsam.NavState(estimate.pose, estimate.v_n), estimate.bias, float(ping.t)])

    def _depth_held(self, v_n: np.ndarray, C_b_n: np.ndarray, beams: np.ndarray, omega_b: np.ndarray) -> np.ndarray:
        """``v_n`` (NED, m/s) with its down component the measured ``beams``' (the depth sensor holds the graph's
        vertical velocity through an outage; the IMU alone does not), ``omega_b`` the bias-corrected rate (rad/s)."""
        v_b = np.linalg.lstsq(self.beams.rows_b, beams, rcond=None)[0] - np.cross(omega_b, self.lever_arm_b)
        return np.r_[np.asarray(v_n, float)[:2], (C_b_n @ v_b)[2]]

    def _score_patterns(self, h: int, t0: float, C_b_n: np.ndarray, v_n: np.ndarray, beams: np.ndarray,
                        rate_b: np.ndarray) -> None:
        """Score the rehearsal started at ``t0`` (s) at horizon ``h`` per pattern (module docstring): the graph's
        prediction from the depth-held ``v_n`` (NED, m/s), alone or fused with the pattern's measured ``beams``."""
        e_comp = self._comp_errors.pop((t0, h), None)
        if e_comp is None:
            return
        rows = self.beams.rows_b
        lever = rows @ np.cross(rate_b, self.lever_arm_b)
        v_b = C_b_n.T @ v_n
        measured_v_b = np.linalg.lstsq(rows, beams - lever, rcond=None)[0]
        var = self.spread.mean(h, self.min_rehearsals)     # the earlier rehearsals' only
        self.spread.add(h, (C_b_n @ (v_b - measured_v_b))[:2])
        fused = np.broadcast_to(v_b, (len(PATTERNS), 3))
        if self.twin and var is not None:
            info_prior = np.linalg.inv(C_b_n.T @ np.diag([var, var, self.beam_sigma ** 2]) @ C_b_n)
            masked = rows[None] * PATTERNS[:, :, None]               # (patterns, 4, 3): the measured rows
            info = info_prior + np.einsum("pki,pkj->pij", masked, masked) / self.beam_sigma ** 2
            rhs = info_prior @ v_b + np.einsum("pki,k->pi", masked, beams - lever) / self.beam_sigma ** 2
            fused = np.linalg.solve(info, rhs[..., None])[..., 0]
        elif self.twin:
            return                                                   # no spread yet to weigh the IMU by
        self.pairs.add(h, e_comp, fused @ rows.T + lever - beams)

    def pattern_errors(self, measured: np.ndarray, h: int) -> tuple[float, float, float] | None:
        """(completer's, graph's mean square error, their mean product) ((m/s)^2) of the rehearsals of the pattern
        ``measured`` (4,) bool at horizon ``h`` pings or the largest below it with ``min_rehearsals``; None: none."""
        p = int(np.dot(np.asarray(measured, bool), 1 << np.arange(4)))
        for j in range(min(h, self.horizon), 0, -1):
            if len(self.pairs.by_h[p][j]) >= self.min_rehearsals:
                return tuple(float(x) for x in np.mean(self.pairs.by_h[p][j], axis=0))
        return None

    def _pattern_verdict(self, measured: np.ndarray, h: int) -> tuple[str, float, float, float]:
        """(verdict, sigma of a kept completion, e_comp, e_graph) (m/s) of a beam at horizon ``h`` of the pattern
        ``measured``, by the margin or, with ``fusion="correlated"``, by the two errors' covariance."""
        e = self.pattern_errors(measured, h)
        if e is None:
            return "unrehearsed", np.nan, np.nan, np.nan
        s2, a, c = e
        e_comp, e_graph = np.sqrt(s2), np.sqrt(a)
        if not self.correlated:
            return ("completer" if e_comp < self.margin * e_graph else "graph"), e_comp, e_comp, e_graph
        if c >= a:
            return "graph", np.nan, e_comp, e_graph
        rho2 = c * c / max(a * s2, 1e-30)
        return "completer", float(np.sqrt(max(a * (s2 - c) / (a - c), s2 * (1.0 - rho2)))), e_comp, e_graph

    # --- the decision ------------------------------------------------------------------------------
    def errors(self, h: int) -> tuple[float, float] | None:
        """``(e_comp, e_graph)`` (m/s) at horizon ``h`` pings, or at the largest horizon below it that both sides
        rehearsed ``min_rehearsals`` times; None when none did."""
        for j in range(min(h, self.horizon), 0, -1):
            c, g = self.comp.by_h[j], self.graph.by_h[j]
            if len(c) >= self.min_rehearsals and len(g) >= self.min_rehearsals:
                return float(np.sqrt(np.mean(c))), float(np.sqrt(np.mean(g)))
        return None

    def decide(self, t: float, beams: np.ndarray, sigma: np.ndarray, regressed: np.ndarray, steps: np.ndarray,
               measured: np.ndarray | None = None):
        """(beams, sigma, rehearsed (4,) bool) of a ping at ``t`` whose ``regressed`` beams are at the ``steps``-th
        ping of their run: kept at ``e_comp`` where the completer rehearsed better, NaN where the graph did; with
        the variants, by the rehearsals of the pattern ``measured`` (default: the beams not regressed)."""
        measured = ~np.asarray(regressed, bool) if measured is None else np.asarray(measured, bool)
        beams, sigma = np.array(beams, float), np.array(sigma, float)
        rehearsed = np.zeros(4, dtype=bool)
        for i in np.flatnonzero(regressed):
            completion = beams[i]
            if self.pairs is not None:
                verdict, kept_sigma, e_comp, e_graph = self._pattern_verdict(measured, int(steps[i]))
            else:
                e = self.errors(int(steps[i]))
                verdict = "unrehearsed" if e is None else "completer" if e[0] < self.margin * e[1] else "graph"
                e_comp, e_graph = e if e is not None else (np.nan, np.nan)
                kept_sigma = e_comp
            if verdict == "completer":
                sigma[i], rehearsed[i] = kept_sigma, True
            elif verdict == "graph":
                beams[i], sigma[i] = np.nan, 0.0
            self.counts[verdict] += 1
            self.decisions.append((float(t), int(steps[i]), verdict, int(i), float(e_comp), float(e_graph),
                                   float(completion)))
        return beams, sigma, rehearsed
