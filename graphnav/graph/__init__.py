"""The factor-graph estimators: IMU preintegration + per-beam DVL factors, solved by ISAM2 (online),
GTSAM's fixed-lag smoother, or a batch smoother over the whole mission.

Entry point: :func:`run_graph` (methods ``Graph-TC``, ``Graph-HN``, ``Graph-HN-batch``; ``mode`` online or
fixed-lag). Building blocks: :class:`GraphOptions`, :class:`KeyframeBuilder`, :class:`OnlineGraph`,
:class:`FixedLagGraph`, :func:`batch_smooth`.
"""
from .batch import StackedBeams, batch_smooth
from .builder import (BeamGroup, DvlMeasurement, Keyframe, KeyframeBuilder, KeyframeFactors, keyframe_factors,
                      preintegration_params)
from .incremental import EpochEstimate, FixedLagGraph, InitialState, OnlineGraph
from .options import GraphOptions
from .run import GRAPH_METHODS, MODES, iterate_graph, run_graph, solution_from_estimates

__all__ = ["GRAPH_METHODS", "MODES", "DvlMeasurement", "EpochEstimate", "FixedLagGraph", "GraphOptions",
           "InitialState", "Keyframe", "KeyframeBuilder", "OnlineGraph", "batch_smooth", "BeamGroup",
           "KeyframeFactors", "StackedBeams",
           "iterate_graph", "keyframe_factors", "preintegration_params", "run_graph",
           "solution_from_estimates"]
