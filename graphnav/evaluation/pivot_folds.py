"""The pivot completer's lengths fitted leave-folds-out: per fold of whole trajectories, the hull's pivot length(s)
fitted on the other folds' recorded beams (:func:`graphnav.nets.pivot.fit_pivot_length`,
:func:`graphnav.nets.pivot.fit_pivot_lengths`). The completer studies share it."""
from __future__ import annotations


def fold_pivot_lengths(sources: dict, folds, axes: tuple[str, ...] = ("yaw",)) -> list:
    """Per fold, the pivot length (m) fitted on the other folds' trajectories (``sources``: trajectory name ->
    :class:`graphnav.evaluation.bench.TrajectorySource`; ``folds``: tuples of trajectory numbers); with ``axes``
    ``("yaw", "pitch")`` the pair ``(L, L_q)``."""
    from graphnav.evaluation.bench.cases import load_source
    from graphnav.nets.pivot import fit_pivot_length, fit_pivot_lengths
    missions = {k: load_source(sources[f"Trajectory{k}"]) for pair in folds for k in pair}
    fit = fit_pivot_length if tuple(axes) == ("yaw",) else lambda ms: list(fit_pivot_lengths(ms, axes=axes))
    return [fit([missions[k] for other in folds if other != pair for k in other]) for pair in folds]
