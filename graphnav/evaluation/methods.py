"""The method registry: the one table that maps a method name to its estimator, flags and completer, and
:func:`run_method`, which runs a method on a mission.

Method names (used in results, reports and on the command line); each is a :class:`Method` record of
:data:`METHODS`:

=================  =========  ==========================================================
method             estimator  completer
=================  =========  ==========================================================
LC, TC             EKF        none (fewer than 3 beams: LC coasts on the IMU)
LC-12, TC-12       EKF        none; the paper's 12-state filter (see below)
Average-LC/-TC     EKF        :class:`graphnav.nets.AverageCompleter`
HNLC, HNTC         EKF        the network completer for the scenario
Graph-TC           graph      none (measured beams only, ISAM2 filtered output)
Graph-HN           graph      :data:`HYBRID_COMPLETER`: the average estimator (ISAM2 filtered output)
Graph-HN-batch     graph      :data:`HYBRID_COMPLETER` (batch smoothed; the completions of an outage the
                              measured beams end are left out: :data:`RETIRE_COMPLETIONS`)
Graph-HN-net,      graph      the network completer (ISAM2 filtered output / batch smoothed); experimental
Graph-HN-net-batch
Graph-TC-batch     graph      none (batch smoothed): what smoothing alone gives, without completions
Graph-MP           graph      none; model-aided motion prior (body-velocity random walk, small
                              heave) at keyframes with fewer than 3 measured beams
HNTC-IMU           EKF        the IMU-aware completer fused with the beam-only one (beam-only where
                              it cannot serve)
Graph-HNI          graph      the same completer (ISAM2 filtered output); with a beam measured a run of
                              regressed beams screened until one is kept, its errors correlated over
                              10 s with 2 or 3 beams measured, 3 s with 1; in a total outage each
                              completion screened; its completions taken out when the measured beams
                              return (:data:`RETIRE_COMPLETIONS`)
Graph-HNI-batch    graph      the same completer and runs (batch smoothed; the completions of an outage
                              the measured beams end are left out)
Graph-HNP          graph      the pivot completer (:mod:`graphnav.nets.pivot`): the average estimator with
                              the hull's sideslip in turns from the gyro, its pivot length fitted online
                              over the mission's measured pings; with a beam measured a run of regressed
                              beams screened until one is kept, its errors correlated over 10 s with 1
                              or 2 measured; in a total outage each completion screened
Average-LC-12,     EKF        as without ``-12``, in the paper's 12-state filter
Average-TC-12,
HNLC-12, HNTC-12
=================  =========  ==========================================================

The EKF methods run the standard 15-state error-state filter (velocity, attitude, both biases and the position
error; :mod:`graphnav.estimators.ekf`), updated with the DVL, the depth sensor and position fixes. The ``-12``
methods are the paper's 12-state filter (no position error state, no depth; a position fix resets the
position), ``EkfOptions(position_states=False, dvl_error_states=False)`` in their :attr:`Method.defaults`: they
reproduce the paper's numbers, are runnable by name and are left out of the default method list of ``graphnav bench``
(:attr:`Method.reproduction`). A ``-12`` method is compared with the ``-12`` baseline and average estimator.

The estimators themselves take objects and flags, not names (:func:`graphnav.estimators.runs.run_ekf`:
``tight``, ``completer``; :func:`graphnav.estimators.runs.run_graph`: ``completer``, ``batch``); a record says
which call a name is.

The average estimator uses the past ``n_past=3`` pings for ``2-missing`` and 5 for the other scenarios
(:data:`AVERAGE_N_PAST`, defined beside the estimator in :mod:`graphnav.nets.average`).
``0-beams`` (total DVL outage) and ``markov`` (random dropouts) use ``load_completer("auto")``: the networks
for the patterns they were trained on, the average estimator for the others -- with no beam measured the
networks do not apply, so in a total outage the hybrid's completion is the average estimator's constant-beam
extrapolation, screened (:data:`GRAPH_HN_OPTIONS`; ``GraphOptions.motion_prior`` can add or substitute the
motion prior there).
The network completer is ``graphnav.nets.load_completer(missing=2|3)`` (``none`` uses
``load_completer("auto")``, the networks where trained and the average estimator for other patterns, only
consulted if beams drop out); when its weights or module are missing the
average estimator stands in, with a warning, and the solution's ``info["completer"]`` says so.

The IMU-aware completer (kind ``"imu-network"``) is ``graphnav.nets.load_imu_auto_completer()`` in every
scenario: the IMU-aware networks (2 and 3 missing beams) at pings with their pattern and a usable IMU window
(the last 20 s at 100 Hz, kept by the keyframer), each completion fused with the beam-only one by their sigmas
(neither fading through an outage, ``graphnav.nets.imu_auto.FUSED_RUN_DECAY``), and the beam-only
``load_completer("auto")`` alone, fading as its cards say, at the others (the first 20 s, after an IMU gap, no beam
measured, other dropout patterns). ``info["completer_usage"]`` counts
the routes (``imu`` / ``no_imu`` / ``pattern``), ``info["imu_window_missing"]`` why a window was missing.
When its weights cannot be loaded the scenario's beam-only network stands in, with a warning.
"""
from __future__ import annotations

import dataclasses
import functools
import time
import types
import warnings
from typing import Mapping

from graphnav.core.errors import ConfigError
from graphnav.core.mission import Mission
from graphnav.core.scenarios import SCENARIOS
from graphnav.core.solution import NavSolution
from graphnav.nets.average import AVERAGE_N_PAST
from graphnav.nets.pivot import DEFAULT_N_PAST, DEFAULT_PRIOR_TURN

#: Names of the methods other modules refer to (every name is a record of :data:`METHODS`; library code takes
#: names from here, not from literals).
TC, LC, HNTC, HNTC_IMU = "TC", "LC", "HNTC", "HNTC-IMU"
GRAPH_TC, GRAPH_TC_BATCH, GRAPH_MP = "Graph-TC", "Graph-TC-batch", "Graph-MP"
GRAPH_HN, GRAPH_HN_BATCH = "Graph-HN", "Graph-HN-batch"
GRAPH_HNI, GRAPH_HNI_BATCH = "Graph-HNI", "Graph-HNI-batch"
GRAPH_HNP = "Graph-HNP"

#: Which network (number of missing beams it was trained for) serves each scenario.
NETWORK_FOR_SCENARIO: dict[str, int | str] = {"2-missing": 2, "3-missing": 3, "none": "auto", "0-beams": "auto",
                                              "markov": "auto"}
#: Screening of regressed beams against the estimator's own prediction (graph: graphnav.estimators.graph.regressed;
#: EKF: ErrorStateEkf.screen_regressed): their error is taken as correlated with the prediction's (rho = 0.5: both
#: come from the same past pings) and their sigma is raised to what the innovation shows. Measured with
#: experiments/regressed_candidates.py; numbers in docs/decisions/regressed-beams.md.
REGRESSED_SCREENING: Mapping = types.MappingProxyType({"screening.correlation": 0.5, "screening.adaptive": True})
#: The motion prior's settings (Graph-MP; the hybrid's GraphOptions.motion_prior="total" / "total-if-uncertain").
#: The densities are 4x the median 1-s body-velocity changes of the A-KIT ground truth and the heave sigma
#: 0.2 m/s (5x its spread): tighter values
#: (1x, heave 0.05 m/s) made Graph-MP 1.35x Graph-TC on the real data (the vehicle manoeuvres: 99th percentile
#: of the 1-s sway change 0.47 m/s, and a heave prior treated as white pulls the pitch, whose error the gravity
#: projection turns into horizontal velocity drift).
MOTION_PRIOR_SETTINGS: Mapping = types.MappingProxyType({"motion_prior_rw": (0.2, 0.32, 0.12),
                                                         "motion_prior_heave_sigma": 0.2})
#: The hybrids' completions leave the graph when the measured beams return (GraphOptions.retire_completions), so
#: that the returning beams re-estimate the outage's states as without a completer; the estimates made during the
#: outage keep them. Chosen by the regime rule scored on the velocity through the outage and the position 20-40 s
#: after it (experiments/outage_position_drift.py --retired; docs/decisions/completers.md, "Completions taken out
#: when the beams return"), on all folds and with each fold left out: with Graph-HN fold cells over 1.02x Graph-TC
#: 2 instead of 8 of 120, all in the position after the outage. The batch smoother (Graph-HN-batch) leaves out the
#: completions of every outage the measured beams end: kept, they put 5 of 60 fold cells over 1.02x
#: Graph-TC-batch in velocity and 7 in the position after, and change nothing pooled (0.96-1.03x); left out, it
#: is within 0.98-1.014x of Graph-TC-batch in every fold cell (the same study, --methods Graph-TC Graph-TC-batch
#: Graph-HN-batch --retired).
RETIRE_COMPLETIONS: Mapping = types.MappingProxyType({"retire_completions": True})
#: Graph settings of the hybrid graph methods (Graph-HN, Graph-HN-batch, Graph-HN-net) on top of the GraphOptions
#: defaults: the screening and RETIRE_COMPLETIONS. In total outages the screened completion (the average estimator's
#: held beams) carries the keyframes alone: neither the motion prior in its place nor
#: motion_prior="total-if-uncertain" beside it is better-or-equal in every regime of the ten shared trajectories
#: (docs/decisions/regressed-beams.md, measured with experiments/regressed_candidates.py).
GRAPH_HN_OPTIONS: Mapping = types.MappingProxyType({**REGRESSED_SCREENING, **RETIRE_COMPLETIONS})
#: Graph settings of Graph-HNI and Graph-HNI-batch: the screening, and with a beam measured a run of regressed beams
#: screened only until one of its completions is kept, its later ones entering as whitened differences with a
#: Gauss-Markov correlation time that depends on how many beams the ping measured (GraphOptions.regressed_runs,
#: regressed_error_tau_s): 3 s with one, 10 s with two (and with three, which no regime cell measures: the joint
#: choice's value); in a total outage each completion screened (below). Chosen
#: by the regime rule (fewest fold cells over 1.02x Graph-TC, then the lowest mean ratio), each fold with its own
#: networks, with the cells of five training draws of those networks counted together. Over the 2-missing, 3-missing
#: and total-outage cells together the rule picked 10 s: 3 s and 5 s put fold 1 over 1.02x with 2 missing beams and
#: MEMS over 60 s in two draws. Each number of measured beams is a different completer, and chosen each alone: with
#: one beam measured 3 s (no fold cell over 1.02x in five draws; 0.66-0.69x with MEMS over 120 s against 10 s's
#: 0.72-0.74x; independent errors, chosen on the first three draws, put fold 1 at 1.06x in the fifth), in a total
#: outage (no network, the same in every draw) 3 s with the completions kept (0.44x with MEMS over 120 s), with two
#: beams measured 10 s (no
#: fold cell over 1.02x in five draws; 3 s 1.03x and independent errors 1.09x in fold 1). With the average estimator
#: (Graph-HN) the rule keeps screening each ping: there every screen-first setting is worse than 1.02x Graph-TC in
#: some fold (docs/decisions/completers.md, experiments/oracle_completions.py). A position-fix keyframe between pings
#: ends a run. Its completions leave the graph when the measured beams return (RETIRE_COMPLETIONS), as Graph-HN's:
#: chosen by the same rule on both readings (the velocity through the outage and the position 20-40 s after it),
#: each trajectory with its own fold's networks, on all folds and with each fold left out, over two training draws
#: (fold cells over 1.02x Graph-TC 1 / 6 of 100 against 0 / 14 kept; the batch, which leaves out the completions of
#: every outage the measured beams end, 0 of 60 fold cells over 1.02x Graph-TC-batch against 8 kept). With them
#: taken out, the total outage's setting was chosen again as Graph-HNP's was: each completion screened, 0 / 0 of 20
#: fold cells over (3 s: 1 / 1, the velocity cell 1.029x), on all folds and with each fold left out, at a cost
#: with MEMS over 120 s (0.48x Graph-TC against 0.44x) (experiments/outage_position_drift.py --fold-nets
#: --hni-runs; docs/decisions/completers.md, "Graph-HNI's completions taken out when the beams return").
GRAPH_HNI_OPTIONS: Mapping = types.MappingProxyType({
    **REGRESSED_SCREENING,
    "regressed_runs": types.MappingProxyType({0: "screen-each", 1: "screen-first", 2: "screen-first",
                                              3: "screen-first"}),
    "regressed_error_tau_s": types.MappingProxyType({0: None, 1: 3.0, 2: 10.0, 3: 10.0}), **RETIRE_COMPLETIONS})
#: Graph settings of Graph-HNP (the pivot completer): the screening; in a total outage every completion screened
#: against the graph's prediction (as Graph-HN's), and with a beam or more measured a run of regressed beams screened
#: only until one of its completions is kept, its later ones entering with errors correlated over 10 s (one or two
#: measured)
#: (GraphOptions.regressed_runs, regressed_error_tau_s, by the number of measured beams); its completions leave the
#: graph when the measured beams return (RETIRE_COMPLETIONS). Chosen by the regime rule on both readings (fold cells
#: over 1.02x Graph-TC in the velocity through the outage and the position 20-40 s after it, then the mean pooled
#: ratio) per number of measured beams, with the completions taken out, on all folds: in a total outage screening each
#: ping puts 0 / 1 of 20 fold cells over (3 s, chosen before the completions were taken out, 1 / 4: the velocity cell
#: 1.031x), the same for every fold left out; with one beam measured 10 s 0 / 1 (independent errors 0 / 4), the same
#: for every fold left out; with two 10 s 0 / 0 (independent 0 / 1), fold 3 left out getting independent errors
#: (experiments/outage_position_drift.py --pivot-runs; docs/decisions/completers.md, "The pivot completer's runs
#: chosen again with the completions taken out"). With three measured, which no regime cell measures, independent
#: errors as before: the completions are taken out at every ping that measures three, and a difference factor would
#: be left without the completion it differs from.
GRAPH_HNP_OPTIONS: Mapping = types.MappingProxyType({
    **REGRESSED_SCREENING,
    "regressed_runs": types.MappingProxyType({0: "screen-each", 1: "screen-first", 2: "screen-first",
                                              3: "screen-first"}),
    "regressed_error_tau_s": types.MappingProxyType({0: None, 1: 10.0, 2: 10.0, 3: None}), **RETIRE_COMPLETIONS})
#: Graph settings of Graph-MP: the motion prior at keyframes with fewer than 3 measured beams.
GRAPH_MP_OPTIONS: Mapping = types.MappingProxyType({"motion_prior": "partial", **MOTION_PRIOR_SETTINGS})

#: EKF settings of the hybrid EKF methods (Average-LC/-TC, HNLC, HNTC): the same screening of regressed beams
#: against the filter's own prediction (graphnav.estimators.ekf.ErrorStateEkf.screen_regressed). Without it a
#: 30 s outage inside a manoeuvre made the completions wrong by 2.3-3.7x their sigma (RMS 0.31-0.46 m/s) and
#: pulled the filter to 0.53-0.78 m/s window VRMSE (graphnav start-sweep).
EKF_HYBRID_OPTIONS: Mapping = REGRESSED_SCREENING
#: The paper's 12-state EKF (the ``-12`` methods): no position error state, no depth, a fix resets the position.
EKF_PAPER_OPTIONS: Mapping = types.MappingProxyType({"position_states": False, "dvl_error_states": False})
#: Name suffix of the paper's 12-state EKF methods.
PAPER_SUFFIX = "-12"

#: The completer of the hybrid graph methods (Graph-HN, Graph-HN-batch): the average estimator. Chosen by the
#: leave-trajectories-out cross-validation of the completers (graphnav.nets.crossval, ``graphnav eval-beams
#: --folds``; docs/decisions/completers.md): no beam-only network recipe was at least as good as the average
#: estimator in every held-out fold of the ten A-KIT trajectories; the networks stay runnable as Graph-HN-net,
#: Graph-HN-net-batch (and HNLC / HNTC, the paper's EKF hybrids).
HYBRID_COMPLETER = "average"

#: The pivot completer's shrinkage of its online fit toward the average estimator, (rad/s)^2: the completer's own
#: default, chosen (by judgement, the study's rule picks 0.01) in experiments/pivot_completer_folds.py.
PIVOT_PRIOR_TURN = DEFAULT_PRIOR_TURN

#: The turn axes Graph-HNP's pivot completer models: the yaw alone. The completer's own default also models the heave
#: from the pitch rate, which its study's rule picks (per-ping beam gain 14.5 % instead of 6.1 % with 2 missing
#: beams); in the estimator, whose depth sensor already gives the heave, the two are alike (the same fold cells over
#: 1.02x Graph-TC, mean ratios within 0.001) and the regime rule keeps the yaw alone, its worst fold in a 120 s MEMS
#: total outage 0.72x against 0.81x (experiments/outage_position_drift.py --pivot-axes; docs/decisions/completers.md,
#: "The hull's heave in pitch").
PIVOT_AXES: tuple[str, ...] = ("yaw",)
#: Past pings Graph-HNP's pivot completer holds per scenario: the completer's own (graphnav.nets.pivot.DEFAULT_N_PAST:
#: 4 with 2 missing beams, where the average holds 3; the average's N otherwise). With 2 missing beams the regime rule
#: picks 4 over 3 with the yaw alone, on all folds and for four of the five folds left out, though by 0.001 of the mean
#: ratio: every hold and turn model there gives the same fold cells, none over 1.02x Graph-TC
#: (experiments/outage_position_drift.py --pivot-holds; docs/decisions/completers.md, "The hull's heave in pitch").
PIVOT_N_PAST: Mapping = types.MappingProxyType(dict(DEFAULT_N_PAST))

#: The completer kinds a method can have.
COMPLETER_KINDS = ("none", "average", "network", "imu-network", "pivot")


@dataclasses.dataclass(frozen=True)
class Method:
    """One method of the registry.

    Attributes:
        name: the name in results, reports and on the command line.
        family: ``"ekf"`` (:func:`graphnav.estimators.runs.run_ekf`) or ``"graph"``
            (:func:`graphnav.estimators.runs.run_graph`).
        tight: beams as individual measurements (TC) or a 3-beam velocity fix (LC; EKF only).
        completer: ``"none"`` (measured beams only), ``"average"`` (the average estimator), ``"network"``
            (the scenario's network, :data:`NETWORK_FOR_SCENARIO`) or ``"imu-network"`` (the IMU-aware
            completer, module docstring).
        batch: graph only: the batch smoother over the whole mission after the filtered pass.
        defaults: the fields of the estimator's options (:class:`~graphnav.estimators.ekf.EkfOptions` or
            :class:`~graphnav.estimators.graph.GraphOptions`) that differ from their defaults
            (:data:`EKF_HYBRID_OPTIONS`, :data:`GRAPH_HN_OPTIONS`, :data:`GRAPH_HNI_OPTIONS`,
            :data:`GRAPH_MP_OPTIONS`); options given to :func:`run_method` as a dict go on top.
        description: one line for tables and ``--help``.
        experimental: runnable by name, but left out of the default method list of ``graphnav bench`` and
            the start sweep (:data:`BENCH_METHODS`) because a measurement says it should not be used as is.
        reproduction: the paper's 12-state EKF (``-12``), kept to reproduce its numbers: runnable by name, left
            out of :data:`BENCH_METHODS`.
    """

    name: str
    family: str
    tight: bool
    completer: str
    batch: bool = False
    defaults: Mapping = dataclasses.field(default_factory=lambda: types.MappingProxyType({}), hash=False)
    description: str = ""
    experimental: bool = False
    reproduction: bool = False

    def __post_init__(self):
        if self.family not in ("ekf", "graph") or self.completer not in COMPLETER_KINDS:
            raise ConfigError(f"method {self.name}: family must be 'ekf' or 'graph' and completer one of "
                              f"{COMPLETER_KINDS}, got {self.family!r}, {self.completer!r}")

    @property
    def _suffix(self) -> str:
        return PAPER_SUFFIX if self.reproduction else ""

    @property
    def baseline(self) -> str:
        """The classical baseline the method is compared with: LC for the loosely coupled family, else TC
        (LC-12 / TC-12 for the paper's 12-state methods)."""
        return ("TC" if self.tight else "LC") + self._suffix

    @property
    def average(self) -> str:
        """The average-estimator method the method is compared with (Average-LC or Average-TC, with ``-12`` for
        the paper's 12-state methods)."""
        return ("Average-TC" if self.tight else "Average-LC") + self._suffix


_EKF_RECORDS = (
    Method(LC, "ekf", tight=False, completer="none",
           description="loosely coupled 15-state EKF: a velocity fix from 3+ measured beams (else it coasts), depth"),
    Method(TC, "ekf", tight=True, completer="none",
           description="tightly coupled 15-state EKF: every measured beam is a measurement, depth"),
    Method("Average-LC", "ekf", tight=False, completer="average", defaults=EKF_HYBRID_OPTIONS,
           description="LC with the missing beams regressed by the average estimator, screened against the filter"),
    Method("Average-TC", "ekf", tight=True, completer="average", defaults=EKF_HYBRID_OPTIONS,
           description="TC with the missing beams regressed by the average estimator, screened against the filter"),
    Method("HNLC", "ekf", tight=False, completer="network", defaults=EKF_HYBRID_OPTIONS,
           description="LC with the network's regressed beams (the paper's hybrid), screened against the filter"),
    Method(HNTC, "ekf", tight=True, completer="network", defaults=EKF_HYBRID_OPTIONS,
           description="TC with the network's regressed beams (the paper's hybrid), screened against the filter"),
)


def _paper_filter(m: Method) -> Method:
    """The record of EKF method ``m`` in the paper's 12-state filter (name ``m.name + PAPER_SUFFIX``)."""
    return Method(m.name + PAPER_SUFFIX, "ekf", tight=m.tight, completer=m.completer, reproduction=True,
                  defaults=types.MappingProxyType({**m.defaults, **EKF_PAPER_OPTIONS}),
                  description=f"{m.name} in the paper's 12-state EKF (no position error state, no depth)")


_RECORDS = (
    *_EKF_RECORDS,
    Method(GRAPH_TC, "graph", tight=True, completer="none",
           description="factor graph (ISAM2, filtered output), measured beams only"),
    Method(GRAPH_HN, "graph", tight=True, completer=HYBRID_COMPLETER, defaults=GRAPH_HN_OPTIONS,
           description="factor graph (ISAM2, filtered output) plus screened regressed beams (average estimator)"),
    Method(GRAPH_HN_BATCH, "graph", tight=True, completer=HYBRID_COMPLETER, batch=True, defaults=GRAPH_HN_OPTIONS,
           description="Graph-HN, then the batch smoother over the whole mission (the completions of an outage "
                       "the measured beams end left out)"),
    Method(GRAPH_TC_BATCH, "graph", tight=True, completer="none", batch=True,
           description="Graph-TC, then the batch smoother over the whole mission (no completions)"),
    Method(GRAPH_MP, "graph", tight=True, completer="none", defaults=GRAPH_MP_OPTIONS,
           description="Graph-TC with a motion prior at keyframes with fewer than 3 measured beams"),
    Method("Graph-HN-net", "graph", tight=True, completer="network", defaults=GRAPH_HN_OPTIONS,
           description="Graph-HN with the beam-only network's regressed beams; experimental (worse than the "
                       "average estimator in some held-out folds)", experimental=True),
    Method("Graph-HN-net-batch", "graph", tight=True, completer="network", batch=True, defaults=GRAPH_HN_OPTIONS,
           description="Graph-HN-net, then the batch smoother over the whole mission; experimental",
           experimental=True),
    Method(HNTC_IMU, "ekf", tight=True, completer="imu-network", defaults=EKF_HYBRID_OPTIONS,
           description="HNTC with the IMU-aware completer fused with the beam-only one (beam-only alone "
                       "without a 20 s IMU window); experimental",
           experimental=True),
    Method(GRAPH_HNI, "graph", tight=True, completer="imu-network", defaults=GRAPH_HNI_OPTIONS,
           description="Graph-HN with the IMU-aware completer fused with the beam-only one (beam-only alone "
                       "without a 20 s IMU window); with a beam measured a run of regressed beams screened until "
                       "one is kept, its errors correlated over 10 s with 2 or 3 measured, 3 s with 1; in a total "
                       "outage each completion screened; taken out when the measured beams return; experimental",
           experimental=True),
    Method(GRAPH_HNI_BATCH, "graph", tight=True, completer="imu-network", batch=True, defaults=GRAPH_HNI_OPTIONS,
           description="Graph-HNI, then the batch smoother over the whole mission (the completions of an outage "
                       "the measured beams end left out); experimental", experimental=True),
    Method(GRAPH_HNP, "graph", tight=True, completer="pivot", defaults=GRAPH_HNP_OPTIONS,
           description="Graph-HN with the pivot completer: the past beams held with the hull's sideslip in turns "
                       "(pivot length fitted online from the mission's measured pings); with a beam measured a run "
                       "of regressed beams screened until one is kept, in a total outage each completion screened"),
    *(_paper_filter(m) for m in _EKF_RECORDS),
)

#: Every method by name, in the order tables and plots show them (iterating gives the names).
METHODS: Mapping[str, Method] = types.MappingProxyType({m.name: m for m in _RECORDS})
#: The default method list of ``graphnav bench`` and the start sweep: every method but the experimental ones
#: (the IMU-aware completer's: fused with the beam-only one and with its runs screened once, each fold with its own
#: networks, no fold worse than 1.02x Graph-TC in five training draws and better than Graph-HN with MEMS over
#: 120 s, 0.66-0.69x against Graph-HN's 0.80x with 3 missing beams; but chosen leave-one-fold-out fold 1 is over
#: 1.02x (1.08-1.09x with 2 missing beams in two of five draws, 1.06x with 3 in one), the completer itself is still
#: worse than the average through outages in one fold, and it helps in 2 of the 10 regime cells that ask for it;
#: docs/decisions/completers.md, regressed-beams.md).
BENCH_METHODS: tuple[str, ...] = tuple(n for n, m in METHODS.items() if not (m.experimental or m.reproduction))
#: The EKF methods and the graph methods, in table order.
EKF_METHODS: tuple[str, ...] = tuple(n for n, m in METHODS.items() if m.family == "ekf")
GRAPH_METHODS: tuple[str, ...] = tuple(n for n, m in METHODS.items() if m.family == "graph")


def get_method(name: str) -> Method:
    """The :class:`Method` record of ``name``, or :class:`ConfigError` listing the valid names."""
    try:
        return METHODS[name]
    except KeyError:
        raise ConfigError(f"unknown method '{name}'; choose from {', '.join(METHODS)}") from None


def check_method(name: str) -> str:
    """Return ``name`` or raise :class:`ConfigError` listing the valid names."""
    return get_method(name).name


def check_scenario(scenario: str) -> str:
    if scenario not in SCENARIOS:
        raise ConfigError(f"unknown scenario '{scenario}'; choose from {', '.join(SCENARIOS)}")
    return scenario


def baseline_of(name: str) -> str:
    """The classical baseline a method is compared with: LC for the loosely coupled family, TC otherwise."""
    return get_method(name).baseline


def average_of(name: str) -> str:
    """The average-estimator method a method is compared with (Average-LC or Average-TC)."""
    return get_method(name).average


def uses_network(name: str) -> bool:
    return get_method(name).completer in ("network", "imu-network")


def average_completer(scenario: str, noise_std: float = 0.042):
    """The paper's average estimator with the scenario's ``n_past``."""
    from graphnav.nets.average import AverageCompleter
    return AverageCompleter(n_past=AVERAGE_N_PAST[check_scenario(scenario)], noise_std=noise_std)


@functools.lru_cache(maxsize=None)
def _network(missing):
    """Load a network once per process (loading torch weights costs far more than a completion)."""
    from graphnav import nets
    return nets.load_completer(missing=missing)


def network_completer(scenario: str, noise_std: float = 0.042):
    """(completer, description): the scenario's network, or the average estimator when it cannot be loaded."""
    missing = NETWORK_FOR_SCENARIO[check_scenario(scenario)]
    try:
        return _network(missing), f"network(missing={missing})"
    except (ImportError, AttributeError, OSError, ValueError, RuntimeError, KeyError) as exc:
        warnings.warn(f"network completer for {missing} missing beams unavailable ({exc}); "
                      f"using the average estimator instead", RuntimeWarning, stacklevel=2)
        return average_completer(scenario, noise_std), f"average(n_past={AVERAGE_N_PAST[scenario]}) fallback"


@functools.lru_cache(maxsize=None)
def _imu_auto():
    """The IMU-aware completer, loaded once per process (its beam-only part is :func:`_network`'s "auto")."""
    from graphnav import nets
    return nets.load_imu_auto_completer(beam_only=_network("auto"), fused_beam_only=nets.load_fused_beam_only())


def imu_network_completer(scenario: str, noise_std: float = 0.042):
    """(completer, description): the IMU-aware completer, or the scenario's beam-only completer (with a
    warning) when it cannot be loaded."""
    check_scenario(scenario)
    try:
        return _imu_auto(), "imu-network(2, 3, fused with beam-only auto; beam-only auto without an IMU window)"
    except (ImportError, AttributeError, OSError, ValueError, RuntimeError, KeyError, ConfigError) as exc:
        warnings.warn(f"IMU-aware completer unavailable ({exc}); using the beam-only completer instead",
                      RuntimeWarning, stacklevel=2)
        completer, described = network_completer(scenario, noise_std)
        return completer, described + " (IMU-aware unavailable)"


def pivot_completer(scenario: str, config, pivot_m: float | None = None, prior_turn: float = PIVOT_PRIOR_TURN,
                    pitch_pivot_m: float = 0.0, axes: tuple[str, ...] = PIVOT_AXES, n_past: int | None = None):
    """The pivot completer (:class:`graphnav.nets.pivot.PivotCompleter`) for a mission's sensors ``config``
    (:class:`~graphnav.core.config.SensorConfig`: the DVL's beams, lever arm, noise and rate, the IMU rate), with the
    scenario's ``n_past``; its pivot lengths ``pivot_m`` and ``pitch_pivot_m`` (m), or by default those of the turn
    ``axes`` fitted online over the mission's measured pings, shrunk by ``prior_turn``; ``n_past``: the past pings
    held. The defaults are Graph-HNP's (:data:`PIVOT_AXES`, :data:`PIVOT_N_PAST`); the completer's own, chosen by
    its study, are ``axes=graphnav.nets.pivot.DEFAULT_AXES, n_past=graphnav.nets.pivot.DEFAULT_N_PAST[scenario]``."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.pivot import PivotCompleter
    geometry = DvlGeometry.from_spec(config.dvl)
    return PivotCompleter(geometry.T_b, geometry.lever_arm_b, pivot_m,
                          n_past=PIVOT_N_PAST[check_scenario(scenario)] if n_past is None else n_past,
                          noise_std=config.dvl.beam_noise_std,
                          imu_rate_hz=config.imu_rate_hz, ping_dt=1.0 / config.dvl.rate_hz, prior_turn=prior_turn,
                          pitch_pivot_m=pitch_pivot_m, axes=axes)


def completer_for(name: str, scenario: str, noise_std: float = 0.042, config=None):
    """(completer or None, description) for a method in a scenario (see the module table). ``config``: the mission's
    :class:`~graphnav.core.config.SensorConfig`, which the pivot completer is built for (the defaults without it)."""
    kind = get_method(name).completer
    check_scenario(scenario)
    if kind == "average":
        return average_completer(scenario, noise_std), f"average(n_past={AVERAGE_N_PAST[scenario]})"
    if kind == "pivot":
        from graphnav.core.config import SensorConfig
        config = config if config is not None else SensorConfig()
        return (pivot_completer(scenario, config),
                f"pivot(n_past={PIVOT_N_PAST[scenario]}, pivot length fitted online)")
    if kind == "network":
        return network_completer(scenario, noise_std)
    if kind == "imu-network":
        return imu_network_completer(scenario, noise_std)
    return None, "none"


def estimator_options(name: str, options=None):
    """The options object a method's estimator runs with: ``options`` as given when it is an options object,
    else :class:`~graphnav.estimators.ekf.EkfOptions` / :class:`~graphnav.estimators.graph.GraphOptions` from
    the method's ``defaults`` updated by the dict ``options`` (names as
    :func:`graphnav.estimators.options.build_options` reads them: ``"lag_s"``, ``"priors.velocity_sigma"``;
    a name of before the option groups is mapped with a DeprecationWarning)."""
    m = get_method(name)
    if options is not None and not isinstance(options, dict):
        return options
    from graphnav.estimators.ekf import EkfOptions
    from graphnav.estimators.graph import GraphOptions
    from graphnav.estimators.options import build_options, current_name
    given = {current_name(k, stacklevel=4): v for k, v in (options or {}).items()}
    return build_options(EkfOptions if m.family == "ekf" else GraphOptions, {**m.defaults, **given})


def completer_state(completer) -> dict:
    """What a completer learned during the mission, for run summaries: the pivot completer's pivot lengths at the
    end (``pivot_length_m`` for the yaw, m; ``pitch_pivot_length_m`` for the pitch where it models one), the number
    of ping pairs its online fit used since the completer was made (``pivot_fit_pairs``) and the fully measured pings
    it left out of the fit for a non-finite beam or rate (``pivot_observations_refused``, when any); empty for the
    others."""
    if not hasattr(completer, "length_m"):
        return {}
    fit = getattr(completer, "fit", None)
    yaw, pitch = getattr(completer, "lengths_m", (completer.length_m, 0.0))
    state = {"pivot_length_m": float(yaw)}
    fitted_pitch = getattr(completer, "pivot_m", None) is None and "pitch" in getattr(completer, "axes", ())
    if fitted_pitch or pitch != 0.0:
        state["pitch_pivot_length_m"] = float(pitch)
    if fit is not None and completer.pivot_m is None:
        state["pivot_fit_pairs"] = int(fit.pairs)
    if getattr(completer, "observations_refused", 0):
        state["pivot_observations_refused"] = int(completer.observations_refused)
    return state


#: What each kind of a network completer's fallback (``info["completer_fallbacks"]``) means.
FALLBACK_REASONS = {"envelope": "inputs outside its training envelope",
                    "pattern": "a missing-beam pattern it was not trained for",
                    "dvl": "a DVL it was not trained for",
                    "period": "past pings not spaced as it was trained for"}


def completer_fallbacks_line(counts: dict | None) -> str:
    """One line on the pings a network completer left to the average estimator, by reason (empty when none)."""
    counts = {k: n for k, n in (counts or {}).items() if n}
    if not counts:
        return ""
    reasons = "; ".join(f"{n} for {FALLBACK_REASONS.get(k, k)}" for k, n in counts.items())
    return f"network completer: {sum(counts.values())} ping(s) completed by the average estimator instead ({reasons})"


def run_method(mission: Mission, method: str, scenario: str = "none", *, completer=None,
               options=None, callback=None, backend: str = "isam2", init: str = "auto",
               align=None) -> NavSolution:
    """Run one method of :data:`METHODS` on a mission and return its :class:`NavSolution`.

    The scenario only chooses the completer (the outage itself is already in ``mission``'s valid mask,
    see :meth:`Mission.with_outage`). ``completer`` overrides the choice (a method without a completer,
    such as TC or Graph-TC, runs without one). ``options`` go to the estimator: its options object
    (:class:`graphnav.estimators.ekf.EkfOptions`, :class:`graphnav.estimators.graph.GraphOptions`) as is, or a
    dict of its fields on top of the method's defaults. Graph methods only: ``callback`` receives each filtered
    :class:`graphnav.estimators.types.EpochEstimate` as it is produced, and ``backend`` is ``"isam2"`` or
    ``"fixed-lag"`` (lag ``options.lag_s``). ``init``: the initial state from the ground truth (``"gt"``),
    from the sensors (``"sensors"``, with ``align``, an :class:`~graphnav.estimators.align.AlignOptions`, e.g. with
    ``initial_heading_rad``), or ``"auto"``
    (ground truth when the mission has it).
    ``runtime_s`` is the estimator's wall time; ``info["completer"]`` names the completer and, for a network
    completer, ``info["completer_fallbacks"]`` counts the pings it left to the average estimator
    (``{"envelope": inputs outside its training envelope, "pattern": a pattern it was not trained for, "dvl": a DVL
    whose beams are not those it was trained for, "period": past pings closer together than the DVL period it was
    trained for, or gaps of several periods}``);
    ``info["completer_state"]`` is what the completer learned during the run (:func:`completer_state`, when any).
    """
    from graphnav.estimators.runs import run_ekf, run_graph
    m = get_method(method)
    described = "given"
    if completer is None:
        completer, described = completer_for(m.name, scenario, mission.config.dvl.beam_noise_std, mission.config)
    elif m.completer == "none":
        completer, described = None, "none"
    usage_before = dict(getattr(completer, "usage", {}))
    options = estimator_options(m.name, options)
    start = time.perf_counter()
    if m.family == "ekf":
        sol = run_ekf(mission, tight=m.tight, completer=completer, options=options, init=init,
                      align=align, name=m.name)
    else:
        sol = run_graph(mission, completer=completer, batch=m.batch, options=options, callback=callback,
                        backend=backend, init=init, align=align, name=m.name)
    wall = time.perf_counter() - start
    if not sol.runtime_s == sol.runtime_s:  # NaN: the estimator did not time itself
        sol.runtime_s = wall
    sol.info = {**sol.info, "completer": described, "scenario": scenario}
    if usage_before:
        sol.info["completer_usage"] = {k: completer.usage[k] - n for k, n in usage_before.items()}
    state = completer_state(completer)
    if state:
        sol.info["completer_state"] = state
    counts = sol.info.get("completer_fallbacks")    # this run's, as the Navigator that ran it counted them
    if counts and any(counts.values()):
        warnings.warn(f"{m.name}: {completer_fallbacks_line(counts)}", RuntimeWarning, stacklevel=2)
    return sol
