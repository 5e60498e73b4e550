"""The beam history every hybrid estimator keeps for its completer.

The completer sees the N most recent *full* beam vectors. Epochs with all four beams valid push the
measurement; epochs with missing beams push the completed vector (measured beams plus regressed ones),
so during an outage earlier completions stand in for missing beams, as in the paper.
"""
from __future__ import annotations

from collections import deque

import numpy as np


class BeamHistory:
    """Ring buffer of the last ``n_past`` full beam vectors (m/s)."""

    def __init__(self, n_past: int):
        if n_past < 1:
            raise ValueError(f"n_past must be >= 1, got {n_past}")
        self.n_past = n_past
        self._buf: deque[np.ndarray] = deque(maxlen=n_past)

    def __len__(self) -> int:
        return len(self._buf)

    @property
    def ready(self) -> bool:
        """True once ``n_past`` full vectors have been pushed."""
        return len(self._buf) == self.n_past

    def push(self, beams: np.ndarray) -> None:
        """Append one full (4,) beam vector; it must be finite."""
        beams = np.asarray(beams, dtype=float).reshape(4)
        if not np.all(np.isfinite(beams)):
            raise ValueError("BeamHistory.push needs a full finite beam vector")
        self._buf.append(beams.copy())

    def past(self) -> np.ndarray:
        """(n_past, 4) oldest first."""
        return np.array(self._buf)

    def complete(self, completer, beams: np.ndarray, valid: np.ndarray):
        """Complete one ping and update the history.

        Args:
            completer: object with ``complete(past, measured) -> (beams, sigma)`` and ``n_past``.
            beams: (4,) measured beams, m/s.
            valid: (4,) bool validity.

        Returns:
            (beams (4,), sigma (4,)): the full vector and the per-beam sigma (0 for measured beams), or
            ``None`` when the ping cannot be completed yet (history not full) -- the caller then uses the
            measured beams alone. Full pings always go into the history.
        """
        valid = np.asarray(valid, dtype=bool)
        if valid.all():
            self.push(beams)
            return np.asarray(beams, dtype=float), np.zeros(4)
        if not self.ready:
            return None
        measured = np.where(valid, beams, np.nan)
        full, sigma = completer.complete(self.past(), measured)
        self.push(full)
        return full, sigma
