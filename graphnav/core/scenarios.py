"""Beam outage scenarios: which beams are missing, when.

Beam numbers in names and presets follow the paper (beams 1..4); arrays use 0-based indices.
Presets: ``2-missing`` = beams 1 and 3 missing (2 and 4 measured); ``3-missing`` = only beam 2 measured;
``0-beams`` = total DVL outage (no beam measured); ``markov`` = random per-beam dropouts inside the window
(independent two-state Markov chains per beam, :data:`MARKOV_DROPOUT`, seeded by the window start so every
method sees the same pattern); ``none`` = all beams measured.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from graphnav.core.errors import ConfigError

#: Missing beam indices (0-based) of the named scenarios.
SCENARIOS: dict[str, tuple[int, ...]] = {
    "none": (),
    "2-missing": (0, 2),
    "3-missing": (0, 2, 3),
    "0-beams": (0, 1, 2, 3),
    "markov": (0, 1, 2, 3),     # beams that may drop; which ones and when: MARKOV_DROPOUT
}
#: Per-ping (p_drop, p_recover) of the random-dropout scenarios. 0.1 / 0.2: each beam is out a third of the
#: time in runs of 5 pings on average (1 s at the A-KIT DVL's 5 Hz), so 2+ beams are missing together in
#: ~26 % of the pings -- the bursty loss of a compact DVL over rough terrain or in bubbles.
MARKOV_DROPOUT: dict[str, tuple[float, float]] = {"markov": (0.1, 0.2)}


@dataclass(frozen=True)
class Outage:
    """A window ``start_s <= t < start_s + duration_s`` in which the beams ``missing`` (0-based) are invalid."""

    start_s: float
    duration_s: float
    missing: tuple[int, ...]
    #: (p_drop, p_recover) per ping: the ``missing`` beams drop at random (:func:`markov_dropout`) instead
    #: of all the time; None = fixed pattern.
    markov: tuple[float, float] | None = None

    def __post_init__(self):
        if self.duration_s < 0:
            raise ConfigError(f"outage duration must be >= 0 s, got {self.duration_s}")
        if any(b not in range(4) for b in self.missing):
            raise ConfigError(f"missing beams must be 0-based indices 0..3, got {self.missing}")
        if self.markov is not None and not all(0.0 < p <= 1.0 for p in self.markov):
            raise ConfigError(f"markov (p_drop, p_recover) must be in (0, 1], got {self.markov}")

    @property
    def end_s(self) -> float:
        return self.start_s + self.duration_s

    def mask(self, t: np.ndarray) -> np.ndarray:
        """(M,4) bool, True where a beam is removed at stamps t (s)."""
        inside = (t >= self.start_s) & (t < self.end_s)
        out = np.zeros((len(t), 4), dtype=bool)
        out[np.ix_(inside, list(self.missing))] = True
        if self.markov is not None:
            # seeded by the window start (ms): the same pattern for every method and run of this window
            drop = ~markov_dropout(int(inside.sum()), *self.markov, seed=int(round(self.start_s * 1e3)) % 2**32)
            out[inside] &= drop
        return out


def is_total_outage(name: str) -> bool:
    """True for scenarios in which no beam is measured (the name holds ``0-`` or ``outage``)."""
    return "0-" in name or "outage" in name


def scenario_outage(name: str, start_s: float, duration_s: float = 30.0) -> Outage:
    """The named scenario (a key of :data:`SCENARIOS`) as an :class:`Outage`."""
    try:
        return Outage(start_s, duration_s, SCENARIOS[name], MARKOV_DROPOUT.get(name))
    except KeyError:
        raise ConfigError(f"unknown scenario '{name}'; choose one of {sorted(SCENARIOS)}") from None


def window_starts(t0: float, t1: float, window_s: float = 30.0, settle_s: float = 60.0,
                  gap_s: float = 60.0, max_windows: int | None = None) -> list[float]:
    """Start times of outage windows spread over a mission [t0, t1] (s).

    The first window starts after ``settle_s`` (filter convergence); windows are separated by at least
    ``gap_s`` of full beams, and the last one ends before ``t1 - 5 s``. With ``max_windows`` the list is
    thinned evenly.
    """
    starts = list(np.arange(t0 + settle_s, t1 - window_s - 5.0 + 1e-9, window_s + gap_s))
    if max_windows is not None and len(starts) > max_windows:
        keep = np.linspace(0, len(starts) - 1, max_windows).round().astype(int)
        starts = [starts[i] for i in keep]
    return [float(s) for s in starts]


def markov_dropout(n_epochs: int, p_drop: float = 0.05, p_recover: float = 0.3,
                   seed: int | np.random.Generator = 0) -> np.ndarray:
    """Random per-beam on/off validity (n_epochs, 4) from independent two-state Markov chains.

    Each beam drops with probability ``p_drop`` per epoch while valid and recovers with ``p_recover``
    while invalid; chains start in their stationary distribution. Seeded and deterministic.
    """
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    p_on = p_recover / (p_drop + p_recover)
    valid = np.empty((n_epochs, 4), dtype=bool)
    state = rng.random(4) < p_on
    u = rng.random((n_epochs, 4))
    for k in range(n_epochs):
        valid[k] = state
        state = np.where(state, u[k] >= p_drop, u[k] < p_recover)
    return valid
