"""The factor-graph estimators: IMU preintegration + per-beam DVL factors, solved by ISAM2 (online),
GTSAM's fixed-lag smoother, or a batch smoother over the whole mission.

Entry point: :func:`run_graph` (methods ``Graph-TC``, ``Graph-HN``, ``Graph-HN-batch``; ``mode`` online or
fixed-lag), a replay through :class:`graphnav.navigator.Navigator`. Building blocks: :class:`GraphOptions`,
:class:`GraphContext`, :class:`OnlineGraph`, :class:`FixedLagGraph`, :func:`batch_smooth`.
"""
from .batch import batch_smooth
from .builder import GraphContext, mission_keyframes, preintegration_params
from .incremental import EpochEstimate, FixedLagGraph, InitialState, OnlineGraph
from .options import GraphOptions
from .run import GRAPH_METHODS, MODES, iterate_graph, run_graph, solution_from_estimates

__all__ = ["GRAPH_METHODS", "MODES", "EpochEstimate", "FixedLagGraph", "GraphContext", "GraphOptions",
           "InitialState", "OnlineGraph", "batch_smooth", "iterate_graph", "mission_keyframes",
           "preintegration_params", "run_graph", "solution_from_estimates"]
