"""Which DVL a network was trained for, and whether a mission's DVL is that one.

A network completer learns how the missing beams of one DVL follow from its other beams (and, IMU-aware, from the
vehicle's motion): the directions of that DVL's beams in the body frame are built into its weights. The shipped
networks were trained for the Snapir's DVL as :class:`~graphnav.core.config.DvlSpec` describes it by default: beams
20 deg from the vertical at azimuths 45, 135, 225 and 315 deg, the DVL along the body axes. On a DVL whose beams point
elsewhere a network completes beams that this DVL does not have, and little in its inputs says so. On the A-KIT
trajectories' motion with the beams of a convex RDI head (azimuths 270, 90, 0, 180 deg) the shipped networks' beam
and velocity errors were 1.3-2.8x the average estimator's, per ping and through 30-ping outages, and their training
envelope caught 57-95 % of the pings; with the Snapir's head turned 45 deg about the vertical the beam-only networks'
envelope caught none, and through 3-missing outages they were 2.1x the average's in velocity
(``experiments/network_on_other_dvl.py``; ``docs/decisions/completers.md``, "A network on a DVL it was not trained
for").

So a network completer is bound to the mission's DVL before it completes any of its pings (the estimators' keyframer
calls ``bind_dvl`` with the mission's beam directions): when a beam's direction differs from the one the network was
trained for by more than :data:`BEAM_DIRECTION_TOLERANCE_DEG`, the average estimator completes every ping the
network would have, counted in ``fallbacks["dvl"]``, and the keyframer warns, naming the beams. The binding is the
completer object's (the registry's network completers are one object per process, bound again by each run's
keyframer, as their counters are shared: one run at a time). Completers without a network (the average estimator,
the pivot completer, which is built from the mission's own geometry) have nothing to bind. A completer that wraps a
network must hand ``bind_dvl`` on to it (as :func:`bind_members` does), or it is never bound.

A network was also trained for one ping period: the past beams it reads are one DVL period apart (1 s for every
shipped network: the A-KIT and BeamsNet DVLs ping at 1 Hz). On simulated missions whose DVL pings faster the
beam-only networks lose their gain per ping: beam / velocity RMSE over the average estimator's, 0.91-0.93 / 0.97-1.00
at 1 Hz, 0.99-1.02 / 1.01-1.03 at 2 Hz, 1.04-1.15 / 1.01-1.09 at 4 and 5 Hz. Past pings further apart cost far less:
on real motion with every 2nd to 5th ping kept (a slower DVL, or missed pings) the networks still complete better
than the average pooled (single recordings up to 1.03x in velocity, as at 1 s), and at 10 s apart no longer in every
case (``experiments/network_on_other_dvl.py --ping-rates``; docs/decisions/completers.md, "A network on a DVL pinging
at another rate"). So a network completer checks each ping's past (:meth:`TrainedForOneDvl.period_mismatch`,
``past_dt_s`` from the history's stamps): an interval shorter than ``1 - PING_PERIOD_TOLERANCE`` of the trained period
(:data:`graphnav.core.dvl.PING_PERIOD_TOLERANCE`) or longer than :data:`LONGEST_PAST_INTERVAL_PERIODS` periods leaves
that ping to the average estimator, counted in ``fallbacks["period"]``. Where the stamps are not known (``past_dt_s``
None: a past made without them) nothing is checked. The IMU-aware networks propagate each past ping over exactly one
period, so theirs may be no longer than ``1 + PING_PERIOD_TOLERANCE`` periods.
"""
from __future__ import annotations

import itertools
from dataclasses import asdict, fields

import numpy as np

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import off_period

#: Largest angle (deg) between a beam's direction in the body frame on the DVL a network was trained for and on the
#: mission's DVL for which the network still completes the mission's beams. A head turned about the vertical by D moves
#: each 20 deg beam by about D sin(20 deg), so up to about 6 deg of turn passes. Measured with the shipped beam-only
#: networks (the study above): at 5 deg of turn they are unchanged, at 10 deg still better than the average, at 20 deg
#: (6.8 deg a beam) 6 % worse in velocity through 3-missing outages. Beams inclined 30 deg instead of 20 (10 deg a
#: beam) still complete 2-23 % better than the average, yet in the paper's hybrid EKF through 120 s MEMS outages they
#: put HNTC at 0.96-0.99x TC where the average gives 0.85-0.90x (6-8 of 20 windows over 1.02x Average-TC).
BEAM_DIRECTION_TOLERANCE_DEG = 2.0

#: Longest interval, in trained ping periods, between a beam-only network's past pings (and from the newest to the ping
#: it completes) for which it still completes the ping. Chosen on real motion per ping, the networks fed every k-th
#: ping (the study above): at 2, 3 and 5 periods every pooled cell (A-KIT, in sample; ``V_test.npy``, never trained
#: on) still beats the average, 0.50-0.93 in beam and 0.77-0.93 in velocity RMSE, and no recording is worse than the
#: worst at the trained period (1.03x); at 10 periods A-KIT with 3 missing beams is 1.07 / 1.02x the average (one
#: trajectory 1.13x).
LONGEST_PAST_INTERVAL_PERIODS = 5.0

#: The fields of :class:`DvlSpec`, as a model card records them.
_SPEC_FIELDS = tuple(f.name for f in fields(DvlSpec))


def beam_model_record(spec: DvlSpec | None = None) -> dict:
    """The DVL a network is trained for, as a model card stores it (``card["data"]["beam_model"]``): the fields of
    ``spec`` (default :class:`DvlSpec`), arrays as lists."""
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in asdict(spec or DvlSpec()).items()}


def dvl_name(spec: DvlSpec | None = None) -> str:
    """How rows and messages name a DVL: its beams (:func:`describe_beams`); None: the default :class:`DvlSpec`'s."""
    from graphnav.core.dvl import DvlGeometry
    return describe_beams(DvlGeometry.from_spec(spec or DvlSpec()).T_b)


def rows_dvls(rows) -> set[str]:
    """The DVLs result rows were made for, as :func:`dvl_name` names them (each row's ``dvl``; a row without one was
    made for the default :class:`DvlSpec`, as every row was before rows named their DVL)."""
    default = dvl_name()
    return {r.get("dvl", default) for r in rows}


def default_dvl_mismatch(T_b: np.ndarray) -> str | None:
    """:func:`beam_direction_mismatch` of beams ``T_b`` ((4, 3) unit vectors, body frame) against the default
    :class:`DvlSpec`'s (the Snapir's, the DVL every recipe was chosen on): None when they are those beams."""
    from graphnav.core.dvl import DvlGeometry
    return beam_direction_mismatch(DvlGeometry.from_spec(DvlSpec()).T_b, T_b)


def chosen_for_note(spec: DvlSpec | None, check: str) -> str:
    """What a model card's ``selected_by`` adds for a recipe trained for the DVL ``spec``: nothing for the default
    :class:`DvlSpec` (the Snapir's, the DVL every recipe was chosen on), else that the choice was made on the Snapir's
    beams and ``check``, the command that gives the recipe's out-of-fold numbers for this DVL."""
    from graphnav.core.dvl import DvlGeometry
    if spec is None or default_dvl_mismatch(DvlGeometry.from_spec(spec).T_b) is None:
        return ""
    return (f"; the recipe was chosen on the default DVL's beams ({dvl_name()}), not on this DVL's "
            f"({dvl_name(spec)}): its out-of-fold numbers for this DVL come from {check}")


def trained_dvl_spec(card: dict) -> DvlSpec:
    """The DVL a model card's network was trained for, beams and errors: its ``data["beam_model"]``
    (:func:`beam_model_record`), the default :class:`DvlSpec` for a card without one (every beam-only card written
    before the cards recorded it: :mod:`graphnav.nets.data` makes the training beams with that spec) and for a field
    the record lacks."""
    record = (card.get("data") or {}).get("beam_model") or {}
    return DvlSpec(**{k: record[k] for k in _SPEC_FIELDS if k in record})


def trained_beams_b(card: dict) -> np.ndarray:
    """(4, 3) unit vectors of the beams, body frame, of the DVL a model card's network was trained for
    (:func:`trained_dvl_spec`)."""
    from graphnav.core.dvl import DvlGeometry
    return DvlGeometry.from_spec(trained_dvl_spec(card)).T_b


def trained_ping_period_s(card: dict) -> float:
    """The DVL ping period (s) a model card's network was trained for: ``1 / rate_hz`` of its ``data["beam_model"]``,
    or of the default :class:`DvlSpec` (1 Hz, the A-KIT and BeamsNet DVLs) for a card without one."""
    return 1.0 / float(trained_dvl_spec(card).rate_hz)


def _angles_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (deg) between the rows of ``a`` and ``b``."""
    cos = np.sum(a * b, axis=1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def describe_beams(T_b: np.ndarray) -> str:
    """Beams (rows of ``T_b``, body frame) as their angle from the body's z axis and their azimuths, deg."""
    T_b = np.asarray(T_b, float)
    tilt = np.degrees(np.arccos(np.clip(np.abs(T_b[:, 2]) / np.linalg.norm(T_b, axis=1), -1.0, 1.0)))
    azimuth = np.degrees(np.arctan2(T_b[:, 1], T_b[:, 0])) % 360.0
    tilts = f"{tilt[0]:.0f} deg" if np.ptp(tilt) < 0.5 else ", ".join(f"{x:.0f}" for x in tilt) + " deg"
    return f"{tilts} from the vertical at azimuths {', '.join(f'{x:.0f}' for x in azimuth)} deg"


def beam_direction_mismatch(trained_T_b: np.ndarray, T_b: np.ndarray,
                            tolerance_deg: float = BEAM_DIRECTION_TOLERANCE_DEG) -> str | None:
    """None when every beam of the mission's DVL (``T_b``, (4, 3) unit vectors, body frame) points within
    ``tolerance_deg`` of the trained DVL's (``trained_T_b``); else what differs: the two layouts, the beams further
    off than that and their angles (1-based, as the paper numbers them), and whether the same beams are there numbered
    differently."""
    a, b = np.asarray(trained_T_b, float), np.asarray(T_b, float)
    angle = _angles_deg(a, b)
    if np.all(angle <= tolerance_deg):
        return None
    off = ", ".join(f"beam {i + 1} {angle[i]:.1f} deg" for i in np.flatnonzero(angle > tolerance_deg))
    text = (f"trained for beams {describe_beams(a)}, the mission's are {describe_beams(b)} ({off} away; "
            f"tolerance {tolerance_deg:g} deg)")
    for order in itertools.permutations(range(4)):
        if np.all(_angles_deg(a[list(order)], b) <= tolerance_deg):
            moved = [i for i, j in enumerate(order) if i != j]
            theirs, ours = (", ".join(str(k + 1) for k in ks) for ks in (moved, [order[i] for i in moved]))
            text += f": the same beams numbered differently (the mission's beams {theirs} are the trained DVL's {ours})"
            break
    return text


class TrainedForOneDvl:
    """What a network completer with a model card (``card``) shares: the DVL it was trained for (:attr:`trained_T_b`,
    :attr:`trained_ping_period_s`), ``dvl_mismatch``, why the DVL it is bound to is not that one (None: it is, or it
    was never bound), and the check of each ping's past against the trained ping period (:meth:`period_mismatch`)."""

    card: dict
    n_past: int
    dvl_mismatch: str | None = None
    #: the estimators' history hands it ``past_dt_s`` (:func:`graphnav.estimators.history.complete_with`)
    takes_past_dt = True
    #: longest interval of its past pings, in trained periods (:meth:`period_mismatch`)
    longest_past_interval = LONGEST_PAST_INTERVAL_PERIODS

    @property
    def trained_ping_period_s(self) -> float:
        """The DVL ping period (s) the network was trained for (:func:`trained_ping_period_s`)."""
        return trained_ping_period_s(self.card)

    @property
    def trained_dvl_spec(self) -> DvlSpec:
        """The DVL (beams and errors) the network was trained for: its card's (:func:`trained_dvl_spec`)."""
        return trained_dvl_spec(self.card)

    def period_mismatch(self, past_dt_s) -> bool:
        """Whether a ping's past (``past_dt_s``, (>= n_past,) s: the interval from each past ping to the next, the
        newest one's to this ping; its last ``n_past`` are the network's window) is not the past the network was
        trained on: an interval shorter than ``1 - PING_PERIOD_TOLERANCE`` trained periods or longer than
        :attr:`longest_past_interval` periods (None: stamps unknown, nothing to check).

        Raises:
            ValueError: an interval that is not a finite number."""
        return past_dt_s is not None and off_period(np.asarray(past_dt_s, float)[-self.n_past:],
                                                    self.trained_ping_period_s, self.longest_past_interval)

    def refusal(self, past: np.ndarray, measured: np.ndarray, past_dt_s=None) -> str | None:
        """Why the network leaves a ping of its own pattern to the average estimator, as its ``fallbacks`` key: bound
        to a DVL it was not trained for (``"dvl"``), past pings not spaced as in training (``"period"``), inputs
        outside its training envelope (``"envelope"``, when the completer has an ``envelope``); None: it completes
        the ping. ``past`` (n_past, 4) and ``measured`` (4,) m/s, ``past_dt_s`` as :meth:`period_mismatch` takes it."""
        if self.dvl_mismatch is not None:
            return "dvl"
        if self.period_mismatch(past_dt_s):
            return "period"
        envelope = getattr(self, "envelope", None)
        if envelope is not None and not envelope.contains(past, measured, self.model.kept):
            return "envelope"
        return None

    @property
    def trained_T_b(self) -> np.ndarray:
        """(4, 3) body-frame beam directions of the DVL the network was trained for (:func:`trained_beams_b`)."""
        return trained_beams_b(self.card)

    def bind_dvl(self, T_b: np.ndarray) -> list[str]:
        """Bind the network to a mission's DVL (``T_b``: (4, 3) beam unit vectors, body frame, the DVL's beam order):
        when its beams are not those the network was trained for, every ping it would complete goes to the average
        estimator. Returns what differs (empty: nothing)."""
        self.dvl_mismatch = beam_direction_mismatch(self.trained_T_b, T_b)
        return [] if self.dvl_mismatch is None else [self.dvl_mismatch]


def bind_members(T_b: np.ndarray, members) -> list[str]:
    """``bind_dvl(T_b)`` (``T_b``: (4, 3) beam unit vectors of the mission's DVL, body frame) on each distinct member
    that has it: how a completer made of others hands the mission's DVL on. What they report, each message once."""
    seen, messages = set(), []
    for member in members:
        bind = getattr(member, "bind_dvl", None)
        if bind is None or id(member) in seen:
            continue
        seen.add(id(member))
        messages += [m for m in bind(T_b) if m not in messages]
    return messages
