"""Rehearsed outages: the mission's own measured past tells, per horizon, whether a completion or the graph's own
prediction of a missing beam is the better one (``GraphOptions.rehearsed_outages``; experimental, off by default).

Every :attr:`OutageRehearsal.stride` fully measured pings a rehearsal starts at that ping ``t0`` and runs two
predictors forward through the next fully measured pings, as if the beams had been lost after ``t0``:

- the completer's recursion: ``completer.rehearse(past, imu)`` (the four beams completed from the held past,
  without side effects on the completer), fed its own completions ping after ping, as in an outage;
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
"""
from __future__ import annotations

from collections import deque

import gtsam
import numpy as np

from graphnav.core.beam_model import BeamModel


class _Scores:
    """Per horizon 1..``horizon``: the mean square errors of the last ``recent`` rehearsals, (m/s)^2."""

    def __init__(self, horizon: int, recent: int):
        self.by_h = [deque(maxlen=recent) for _ in range(horizon + 1)]

    def add(self, h: int, err: np.ndarray) -> None:
        if 1 <= h < len(self.by_h) and np.all(np.isfinite(err)):
            self.by_h[h].append(float(np.mean(np.square(err))))


class OutageRehearsal:
    """The rehearsals of one mission, the completer's side fed by the keyframer and the graph's by the incremental
    graph (module docstring). ``T_b`` (4, 3) beam unit vectors and ``lever_arm_b`` (3,) m, body frame."""

    def __init__(self, T_b: np.ndarray, lever_arm_b: np.ndarray, margin: float = 1.0, horizon: int = 120,
                 stride: int = 5, recent: int = 20, min_rehearsals: int = 5):
        self.beams = BeamModel(np.asarray(T_b, float))
        self.lever_arm_b = np.asarray(lever_arm_b, float)
        self.margin, self.horizon, self.stride, self.min_rehearsals = float(margin), horizon, stride, min_rehearsals
        self.comp, self.graph = _Scores(horizon, recent), _Scores(horizon, recent)
        self._n_measured = 0
        self._started: set[float] = set()        # stamps the completer's side started a rehearsal at
        self._comp_runs: list[list] = []         # [h, past (n_past, 4)]
        self._graph_runs: list[list] = []        # [h, NavState, bias]
        self.counts = {"completer": 0, "graph": 0, "unrehearsed": 0}
        #: (stamp s, horizon pings, "completer" / "graph" / "unrehearsed") of each regressed beam decided
        self.decisions: list[tuple[float, int, str]] = []

    # --- the completer's side (the keyframer) ------------------------------------------------------
    def completer_ping(self, completer, t: float, beams: np.ndarray, imu, history) -> None:
        """A ping at ``t`` (s) whose four ``beams`` (m/s) were measured, after it entered ``history`` (the
        completer's :class:`~graphnav.estimators.history.BeamHistory`); ``imu`` the completer's window or None."""
        for run in self._comp_runs:
            run[0] += 1
            completion = np.asarray(completer.rehearse(run[1], imu), float)
            self.comp.add(run[0], completion - beams)
            run[1] = np.vstack([run[1][1:], completion])
        self._comp_runs = [r for r in self._comp_runs if r[0] < self.horizon]
        self._n_measured += 1
        if history.ready and self._n_measured % self.stride == 0:
            self._comp_runs.append([0, history.past()[-completer.n_past:]])
            self._started.add(float(t))

    def interrupt(self) -> None:
        """A ping with a beam missing: the running rehearsals cannot be scored on."""
        self._comp_runs, self._graph_runs = [], []

    # --- the graph's side --------------------------------------------------------------------------
    def graph_keyframe(self, kf, estimate) -> None:
        """After the update of keyframe ``kf`` (a :class:`~graphnav.estimators.graph.builder.GraphKeyframe`) whose
        filtered state is ``estimate``: carry the running rehearsals through its IMU, score them on its ping."""
        ping = kf.ping
        if ping is not None and not ping.is_velocity and not ping.measured.all():
            self._graph_runs = []
            return
        scored = ping is not None and not ping.is_velocity
        for run in self._graph_runs:
            run[1] = kf.pim.predict(run[1], run[2])
            if scored:
                run[0] += 1
                C = run[1].pose().rotation().matrix()
                v_n = self._depth_held(run[1].velocity(), C, ping.beams, ping.omega_b - run[2].gyroscope())
                h = self.beams.predict(C, v_n, ping.omega_b, run[2].gyroscope(), self.lever_arm_b).h
                self.graph.add(run[0], h - ping.beams)
        self._graph_runs = [r for r in self._graph_runs if r[0] < self.horizon]
        if scored and float(ping.t) in self._started:
            self._started.discard(float(ping.t))
            self._graph_runs.append([0, gtsam.NavState(estimate.pose, estimate.v_n), estimate.bias])

    def _depth_held(self, v_n: np.ndarray, C_b_n: np.ndarray, beams: np.ndarray, omega_b: np.ndarray) -> np.ndarray:
        """``v_n`` (NED, m/s) with its down component the measured ``beams``' (the depth sensor holds the graph's
        vertical velocity through an outage; the IMU alone does not), ``omega_b`` the bias-corrected rate (rad/s)."""
        v_b = np.linalg.lstsq(self.beams.rows_b, beams, rcond=None)[0] - np.cross(omega_b, self.lever_arm_b)
        return np.r_[np.asarray(v_n, float)[:2], (C_b_n @ v_b)[2]]

    # --- the decision ------------------------------------------------------------------------------
    def errors(self, h: int) -> tuple[float, float] | None:
        """``(e_comp, e_graph)`` (m/s) at horizon ``h`` pings, or at the largest horizon below it that both sides
        rehearsed ``min_rehearsals`` times; None when none did."""
        for j in range(min(h, self.horizon), 0, -1):
            c, g = self.comp.by_h[j], self.graph.by_h[j]
            if len(c) >= self.min_rehearsals and len(g) >= self.min_rehearsals:
                return float(np.sqrt(np.mean(c))), float(np.sqrt(np.mean(g)))
        return None

    def decide(self, t: float, beams: np.ndarray, sigma: np.ndarray, regressed: np.ndarray, steps: np.ndarray):
        """(beams, sigma, rehearsed (4,) bool) of a ping at ``t`` whose ``regressed`` beams are at the ``steps``-th
        ping of their run: kept at ``e_comp`` where the completer rehearsed better, NaN where the graph did."""
        beams, sigma = np.array(beams, float), np.array(sigma, float)
        rehearsed = np.zeros(4, dtype=bool)
        for i in np.flatnonzero(regressed):
            e = self.errors(int(steps[i]))
            verdict = "unrehearsed" if e is None else "completer" if e[0] < self.margin * e[1] else "graph"
            if verdict == "completer":
                sigma[i], rehearsed[i] = e[0], True
            elif verdict == "graph":
                beams[i], sigma[i] = np.nan, 0.0
            self.counts[verdict] += 1
            self.decisions.append((float(t), int(steps[i]), verdict))
        return beams, sigma, rehearsed
