"""A DVL log on its own: what :func:`graphnav.io.read_dvl` returns for any DVL file (PD0, VmDAS, a bag's DVL
topic, a CSV of DVL velocities), before it meets an IMU.

Frames: ``v_d`` is the velocity of the DVL head (over the seabed) in graphnav's DVL frame ``d`` (see
:mod:`graphnav.core.dvl`), whatever frame the instrument recorded in (``frame``); beams are the head's velocity along each outward beam
unit vector, as :mod:`graphnav.core.dvl` defines them.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


#: Keys of :attr:`DvlLog.counts` that describe pings without refusing them (the rest are refusal reasons).
COUNT_NOTES = ("read", "valid", "beams recovered", "ensembles in file", "bad pressure word", "depth out of range",
               "flagged beams", "3-beam solution", "bad checksum (ensemble left out)",
               "ensemble written twice (copy left out)", "ensemble stored out of time order (sorted)",
               "cut ensemble at the end of the file (left out)",
               "byte(s) before the first ensemble (skipped)", "byte(s) between ensembles (skipped)",
               "ensemble cut short by the next one (left out)", "byte(s) after the last ensemble (skipped)",
               "recording joined behind another (numbers start again)")


@dataclass
class DvlLog:
    """One DVL log.

    Attributes:
        t: (M,) ping stamps, s (Unix seconds when the file has a real-time clock, else the log's own clock).
        v_d: (M,3) velocity of the DVL head in the DVL frame ``d``, m/s; NaN where not measured.
        v_d_valid: (M,) bool, True where ``v_d`` is a measurement.
        frame: the frame the instrument recorded its velocities in: "beam", "instrument", "ship" or "earth"
            (RDI's EX bits), or "dvl" for a velocity-only instrument.
        beams: (M,4) along-beam velocities, m/s, where the file holds or allows recovering them, else None.
        beam_valid: (M,4) bool or None.
        attitude_deg: (M,3) heading, pitch, roll the instrument stored (deg, RDI convention), or None.
        depth_m: (M,) depth of the instrument, m, positive down, NaN where unknown, or None.
        v_n: (M,3) velocity of the head over the seabed in NED, m/s, from the instrument's own attitude (what an
            earth-coordinate log holds, or ``v_d`` turned with ``attitude_deg``), NaN where not measured, or None.
        three_beam: (M,) bool or None: the instrument's velocity is a 3-beam solution.
        instrument: metadata (model, frequency, beam angle deg, beam pattern, orientation, serial, ...).
        counts: per reason, pings read / valid / refused (e.g. ``{"read": 400, "valid": 380, "no bottom
            lock": 20}``).
        source: the file (or file:topic) it came from.
        where: per ping, where the file holds it, for messages (PD0: ``ensemble N (byte B)``), or None.
    """

    t: np.ndarray
    v_d: np.ndarray
    v_d_valid: np.ndarray
    frame: str
    beams: np.ndarray | None = None
    beam_valid: np.ndarray | None = None
    attitude_deg: np.ndarray | None = None
    depth_m: np.ndarray | None = None
    v_n: np.ndarray | None = None
    three_beam: np.ndarray | None = None
    instrument: dict = field(default_factory=dict)
    counts: dict = field(default_factory=dict)
    source: str = "dvl"
    where: list | None = None

    def __len__(self) -> int:
        return len(self.t)

    def refused(self) -> dict[str, int]:
        """Pings refused, by reason (the non-zero :attr:`counts` that are not :data:`COUNT_NOTES`)."""
        return {k: int(n) for k, n in self.counts.items() if k not in COUNT_NOTES and n}
