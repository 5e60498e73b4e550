"""The factor-graph engines: IMU preintegration + per-beam DVL factors, solved by ISAM2 (online), GTSAM's
fixed-lag smoother, or a batch smoother over the whole mission.

A mission is run through them by :func:`graphnav.estimators.runs.run_graph` (a replay through the
:class:`~graphnav.estimators.navigator.Navigator`). The API: :class:`GraphOptions` (every setting),
:class:`InitialState` (where a run starts), :class:`EpochEstimate` (what each keyframe update returns; both
defined in :mod:`graphnav.estimators.types` and re-exported here),
:class:`OnlineGraph`, :class:`FixedLagGraph` and :func:`batch_smooth` (the engines).
"""
from graphnav.estimators.graph.batch import batch_smooth
from graphnav.estimators.graph.incremental import FixedLagGraph, OnlineGraph
from graphnav.estimators.graph.options import GraphOptions
from graphnav.estimators.types import EpochEstimate, InitialState

__all__ = ["EpochEstimate", "FixedLagGraph", "GraphOptions", "InitialState", "OnlineGraph", "batch_smooth"]
