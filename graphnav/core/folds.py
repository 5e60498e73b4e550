"""Cross-validation folds of whole recordings (trajectories, missions): the one rule both the defaults' study
(:mod:`graphnav.evaluation.crossval`) and the completers' (:mod:`graphnav.nets.crossval`) hold their folds to."""
from __future__ import annotations

from typing import Hashable, Sequence

from graphnav.core.errors import ConfigError


def check_folds(folds: Sequence[Sequence[Hashable]], names: Sequence[Hashable] | None = None) -> None:
    """Raise :class:`ConfigError` when a recording is in two folds, a fold is empty, or (with ``names``) a
    recording of ``names`` is in no fold or a fold names one that is not in ``names``: a fold holds out whole
    recordings, each exactly once."""
    seen: dict = {}
    for i, fold in enumerate(folds):
        if not fold:
            raise ConfigError(f"fold {i} holds no trajectory (fold {i} is empty)")
        for n in fold:
            if n in seen:
                raise ConfigError(f"trajectory {n} is in folds {seen[n]} and {i}; a trajectory is held out once")
            seen[n] = i
    if names is not None:
        missing, extra = sorted(set(names) - set(seen)), sorted(set(seen) - set(names))
        if missing or extra:
            raise ConfigError(f"folds do not match the trajectories: not in any fold {missing}, "
                              f"not a trajectory {extra}")
