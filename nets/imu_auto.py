"""An IMU-aware completer for every missing pattern, with a beam-only completer where the IMU one cannot serve.

The IMU-aware networks (:func:`graphnav.nets.load_imu_completer`) serve one pattern each and need the last
``imu_samples`` IMU samples at ``imu_rate_hz``. An estimator has no such window during the first 20 s of a
mission, after a bridged IMU gap or with an IMU at another rate; the keyframer
(:class:`graphnav.estimators.keyframes.Keyframer`) then passes ``imu=None``, or the beam-only completer's own
shorter window when it needs one (the pivot completer: ``member_imu_samples``). Patterns without an IMU-aware
network (no beam measured, the random dropouts' other patterns) are not what it was trained for either.
:class:`ImuAutoCompleter` sends those pings to a beam-only completer (``load_completer("auto")``: the
beam-only networks where trained, the average estimator otherwise) and counts each route in ``usage``.

With ``beam_correlation`` the IMU-aware completion is fused with the beam-only one of the same ping
(:func:`graphnav.nets.fused.fuse`): inverse-variance weights, and the sigma of that combination with the two errors
correlated as measured out of fold (:data:`IMU_BEAM_ERROR_CORRELATION`). The two see different things (the IMU's
turn, the past beams' trend) and fail on different trajectories; out of fold the fusion is better than either
alone (``docs/decisions/completers.md``, "The IMU-aware completer fused with the beam-only one"). Each network's
card fades it to the average through a run of regressed pings, a fading chosen for that network alone; fused, the
members fade as :data:`FUSED_RUN_DECAY` says (not at all: over every placement of the outages and two training
draws, the fusion without fading is better than the average in every fold and by more than with the cards'
fadings), the fused member being a second beam-only completer (``fused_beam_only``).

``drift_std`` (m/s per ping) is the growth :class:`graphnav.estimators.history.BeamHistory` gives its sigma through a
run of pings with regressed beams (None: the history's 0.03). The shipped completer keeps the history's growth on
purpose. In 60-120 s outages inside the graph, out of fold, that sigma is about twice the fused completion's error
(0.93-0.95 of the errors within 1 sigma with the members not fading) and the screening drops most of the completions.
A calibrated growth (0.01: 0.71-0.76 within 1 sigma) lets them in and helps the graph pooled over the trajectories,
but makes the steadiest held-out fold (trajectories 6 and 13) up to 1.37x worse than Graph-TC, trajectory 6 alone
up to 2.4x, and chosen leave-one-fold-out the rule gives that fold a smaller growth than 0.03, which harms it
(``experiments/oracle_completions.py``; ``docs/decisions/completers.md``, "How good a completion
would have to be" and "The sigma growth checked again for the completer without fading").
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from graphnav.core.errors import ConfigError
from graphnav.estimators.history import complete_with

from .completer import check_drift_std, check_inputs, new_fallbacks, summed_fallbacks
from .dvl_match import bind_members
from .fused import fuse
from .model import scenario_name

#: Correlation of the IMU-aware and the beam-only fading completers' per-ping errors (each over its own sigma):
#: every A-KIT fold's two networks on the fold's held-out pair, recorded IMU
#: (``experiments/imu_beam_fused_folds.py``); the sigma of the fused completion uses it.
IMU_BEAM_ERROR_CORRELATION = {"2-missing": 0.80, "3-missing": 0.71}

#: ``run_decay`` of the two members when fused, 1 = no fading (their cards' values were chosen for each alone):
#: the fadings' rule (fewest fold cells worse than the average, then the largest smallest pooled gain) applied to
#: the fused completer over every placement of 30-ping outages in two training draws, also leave-one-fold-out
#: (``experiments/outage_placement.py --choose-decays``; ``docs/decisions/completers.md``, "The fadings chosen
#: again for the fused completer").
FUSED_RUN_DECAY = {"2-missing": {"IMU-aware": 1.0, "beam-only": 1.0},
                   "3-missing": {"IMU-aware": 1.0, "beam-only": 1.0}}


class ImuAutoCompleter:
    """IMU-aware networks where they apply, a beam-only completer elsewhere (module docstring).

    Args:
        imu_networks: IMU-aware completers (``needs_imu``), one per missing pattern (``missing``), all with the
            same ``imu_samples`` and ``imu_rate_hz``.
        beam_only: completer for the other pings (``complete(past, measured)``, ``n_past``), e.g.
            ``load_completer("auto")``.
        beam_correlation: scenario name ("2-missing", ...) -> correlation of the IMU-aware network's and
            ``fused_beam_only``'s errors; the IMU-aware completion of those patterns is fused with
            ``fused_beam_only``'s (module docstring). None (default): the IMU-aware network alone.
        drift_std: sigma growth per ping through a run of regressed pings, m/s (module docstring); None
            (default): the history's.
        fused_beam_only: the completer whose completion is fused with the IMU-aware one (e.g. the beam-only
            networks fading as :data:`FUSED_RUN_DECAY` says, or the pivot completer); None (default): ``beam_only``.
            ``beam_only`` and ``fused_beam_only`` may need the IMU themselves (the pivot completer, with a window no
            longer than the networks'): they are handed the networks' window, and where the networks have none
            (the first 20 s of a mission, an IMU gap) the keyframer hands ``beam_only`` its own shorter window
            (``member_imu_samples``), or None.

    With a member that learns from fully measured pings (the pivot completer), the completer has ``observe``, which
    the keyframer calls on each such ping with the window the learners read (``observe_imu_samples``) and which hands
    it on: they learn from the pings they would learn from alone, not only from those with the networks' 20 s.

    ``usage`` counts the pings with missing beams by route: ``"imu"`` (an IMU-aware network), ``"no_imu"``
    (its pattern has one but no IMU window was passed, or only ``beam_only``'s shorter one, or past pings not spaced as
    the network propagates them: ``past_dt_s``) and ``"pattern"`` (no
    IMU-aware network for the pattern, or one bound to a DVL it was not trained for: :meth:`bind_dvl`).
    ``fallbacks`` count the pings the networks left to the average estimator: ``"envelope"`` (inputs outside a
    network's training envelope, IMU-aware or beam-only), ``"pattern"`` (the beam-only completers', ``beam_only``
    and ``fused_beam_only`` both counted when they are two), ``"dvl"`` (networks bound to a DVL they were not
    trained for: :mod:`graphnav.nets.dvl_match`) and ``"period"`` (past pings not spaced as a network was trained
    for).
    """

    needs_imu = True

    def __init__(self, imu_networks, beam_only, beam_correlation: dict[str, float] | None = None,
                 drift_std: float | None = None, fused_beam_only=None):
        imu_networks = list(imu_networks)
        if not imu_networks:
            raise ConfigError("ImuAutoCompleter needs at least one IMU-aware network")
        fused_beam_only = beam_only if fused_beam_only is None else fused_beam_only
        if any(not getattr(n, "needs_imu", False) for n in imu_networks):
            raise ConfigError("ImuAutoCompleter: imu_networks must need the IMU")
        windows = {(n.imu_samples, n.imu_rate_hz, n.ping_dt) for n in imu_networks}
        if len(windows) != 1:
            raise ConfigError(f"ImuAutoCompleter: the IMU-aware networks want different IMU windows {sorted(windows)}")
        (samples, rate_hz, ping_dt), = windows
        # a member that needs the IMU too (the pivot completer) is handed the networks' window and reads its tail
        # and completes a ping without a window itself (``completes_without_imu``)
        for name, c in (("beam_only", beam_only), ("fused_beam_only", fused_beam_only)):
            if not getattr(c, "needs_imu", False):
                continue
            if not getattr(c, "completes_without_imu", False):
                raise ConfigError(f"ImuAutoCompleter: {name} needs the IMU and cannot complete a ping without a "
                                  "window (it serves the pings the networks cannot)")
            if (c.imu_samples > samples or c.imu_rate_hz != rate_hz
                    or round(c.imu_rate_hz * c.ping_dt) != round(rate_hz * ping_dt)):
                raise ConfigError(f"ImuAutoCompleter: {name} wants {c.imu_samples} IMU samples at {c.imu_rate_hz} "
                                  f"Hz, {c.ping_dt} s apart, the networks' window is {samples} at {rate_hz} Hz, "
                                  f"{ping_dt} s apart")
        self.networks = {tuple(n.missing): n for n in imu_networks}
        self.beam_only = beam_only
        self.fused_beam_only = fused_beam_only
        self.beam_correlation = dict(beam_correlation or {})
        unknown = set(self.beam_correlation) - {scenario_name(m) for m in self.networks}
        if unknown:
            raise ConfigError(f"ImuAutoCompleter: beam_correlation for {sorted(unknown)}, which has no IMU-aware "
                              "network")
        for name, rho in self.beam_correlation.items():
            if isinstance(rho, bool) or not isinstance(rho, (int, float)) or not -1.0 < rho < 1.0:
                raise ConfigError(f"ImuAutoCompleter: beam_correlation[{name!r}] = {rho!r} is not in (-1, 1)")
        #: read by BeamHistory (None: the history's own growth)
        self.drift_std = check_drift_std("ImuAutoCompleter", drift_std)
        # per missing pattern, so that a ping looks its correlation up by the pattern it already has
        self._fuse_rho = {m: self.beam_correlation.get(scenario_name(m)) for m in self.networks}
        (self.imu_samples, self.imu_rate_hz, self.ping_dt), = windows
        self.n_past = max([n.n_past for n in imu_networks] + [beam_only.n_past, fused_beam_only.n_past])
        # a fading completer needs the run steps that BeamHistory hands to completers taking them
        self.takes_run_steps = any(getattr(c, "takes_run_steps", False)
                                   for c in (*imu_networks, beam_only, fused_beam_only))
        self.takes_past_dt = any(getattr(c, "takes_past_dt", False)
                                 for c in (*imu_networks, beam_only, fused_beam_only))
        self.usage = {"imu": 0, "no_imu": 0, "pattern": 0}
        # the window ``beam_only`` reads alone, which the keyframer hands on where the networks have none (None:
        # it needs no IMU; the fused member only ever completes with the networks, on their window)
        self.member_imu_samples = beam_only.imu_samples if getattr(beam_only, "needs_imu", False) else None
        # the keyframer shows a completer with ``observe`` every fully measured ping with its IMU window: only when a
        # member learns from them, so that the others cost no window per ping
        learners = [c for c in {id(c): c for c in (beam_only, fused_beam_only)}.values()
                    if callable(getattr(c, "observe", None))]
        self._learners = [c.observe for c in learners]
        if learners:
            self.observe = self._hand_on
            # the longest window a learner that needs the IMU reads (None: the networks' window, as before)
            self.observe_imu_samples = max((c.imu_samples for c in learners if getattr(c, "needs_imu", False)),
                                           default=None)
        if len(self.networks) == 1:
            # one pattern: its outages can be rehearsed (graphnav.estimators.rehearsal), the network fed its own
            # completions; with several the rehearsals could not know which pattern to rehearse
            missing, = self.networks
            #: (4,) bool, the beams the rehearsed outages keep measured (the network's pattern's)
            self.rehearsal_measured = ~np.isin(np.arange(4), missing)
            self.rehearse = self._rehearse
            self._counts = None       # the count dicts _rehearse restores, found on its first call

    def _hand_on(self, t: float, beams: np.ndarray, imu=None) -> None:
        """``observe``: a ping whose four beams were all measured, with its IMU window (or None), handed on to the
        members that learn from such pings (the pivot completer's online fit of its pivot length)."""
        for observe in self._learners:
            observe(t, beams, imu)

    def _rehearse(self, past: np.ndarray, imu=None, beams: np.ndarray | None = None) -> np.ndarray:
        """``rehearse`` (with one IMU-aware network): the four beams (m/s) :meth:`complete` gives a ping whose
        ``beams`` (4,) m/s are measured where :attr:`rehearsal_measured` says (None: a ping without beams), from the
        held ``past`` (n_past, 4) and the IMU window ``imu``; its counters (``usage``, the members' ``fallbacks``)
        are left as they were, so that a run counts only the completions it used."""
        measured = (np.full(4, np.nan) if beams is None
                    else np.where(self.rehearsal_measured, np.asarray(beams, float), np.nan))
        if self._counts is None:
            self._counts = _counters(self)
        saved = [(d, dict(d)) for d in self._counts]
        try:
            return self.complete(past, measured, imu=imu)[0]
        finally:
            for counts, before in saved:
                counts.clear()
                counts.update(before)

    @property
    def fallbacks(self) -> dict[str, int]:
        return new_fallbacks() | summed_fallbacks([self.beam_only, self.fused_beam_only, *self.networks.values()])

    def bind_dvl(self, T_b: np.ndarray) -> list[str]:
        """Bind every member to a mission's DVL (``T_b``: (4, 3) beam unit vectors, body frame;
        :mod:`graphnav.nets.dvl_match`): an IMU-aware network trained for another DVL serves none of its pattern's
        pings, ``beam_only`` does (counted in ``usage["pattern"]``)."""
        return bind_members(T_b, [*self.networks.values(), self.beam_only, self.fused_beam_only])

    def complete(self, past: np.ndarray, measured: np.ndarray, imu=None, run_steps=None, past_dt_s=None
                 ) -> tuple[np.ndarray, np.ndarray]:
        """Complete one ping: ``past`` (n_past, 4) and ``measured`` (4,) m/s as every completer, ``imu`` the
        ``(f_b, omega_b)`` window of :mod:`graphnav.nets.imu_network` or None (no usable window), ``run_steps`` and
        ``past_dt_s`` (the past pings' intervals, s) passed on to the completer that serves the ping (its
        ``run_decay``, its ping period)."""
        past, measured = check_inputs(past, measured, self.n_past)
        missing = ~np.isfinite(measured)
        if not missing.any():
            return measured.copy(), np.zeros(4)
        pattern = tuple(int(b) for b in np.flatnonzero(missing))
        net = self.networks.get(pattern)
        if net is not None and getattr(net, "dvl_mismatch", None) is not None:
            net = None          # trained for another DVL: the pattern is beam_only's, as one without a network
        # a window shorter than the networks' is the members' own (the keyframer's, where the networks have none); a
        # past not spaced as the network propagates it is beam_only's too (the keyframer sends none such with a window)
        if (net is not None and imu is not None and len(imu[1]) >= self.imu_samples
                and not net.period_mismatch(past_dt_s)):
            self.usage["imu"] += 1
            b_imu, s_imu = complete_with(net, past, measured, imu=imu, run_steps=run_steps, past_dt_s=past_dt_s)
            rho = self._fuse_rho[pattern]
            if rho is None:
                return b_imu, s_imu
            b_beam, s_beam = complete_with(self.fused_beam_only, past, measured, imu=imu, run_steps=run_steps,
                                           past_dt_s=past_dt_s)
            return fuse(b_imu, s_imu, b_beam, s_beam, 0.0, rho)
        self.usage["no_imu" if net is not None else "pattern"] += 1
        return complete_with(self.beam_only, past, measured, imu=imu, run_steps=run_steps, past_dt_s=past_dt_s)


def _counters(completer, seen: set | None = None) -> list[dict]:
    """The count dicts (``usage``, ``fallbacks``) of ``completer`` and of its members, each once."""
    seen = set() if seen is None else seen
    if id(completer) in seen:
        return []
    seen.add(id(completer))
    found = []
    for name, value in vars(completer).items():
        if name in ("usage", "fallbacks") and isinstance(value, dict):
            found.append(value)
        for member in value.values() if isinstance(value, dict) else (value,):
            if callable(getattr(member, "complete", None)):
                found += _counters(member, seen)
    return found


def load_fused_beam_only(directory=None):
    """The beam-only member :func:`load_imu_auto_completer` fuses with: ``load_completer("auto")`` (``directory``:
    its weights, default the shipped ones) fading as :data:`FUSED_RUN_DECAY` says."""
    from .network import load_completer
    return load_completer("auto", directory=directory,
                          run_decay={name: d["beam-only"] for name, d in FUSED_RUN_DECAY.items()})


def load_imu_auto_completer(directory=None, beam_only=None, fused: bool = True,
                            fused_beam_only=None, patterns=("2-missing", "3-missing")) -> ImuAutoCompleter:
    """IMU-aware networks, by default the shipped ones (2 and 3 missing beams), with ``beam_only`` (default
    ``load_completer("auto")``, fading as its cards say) for the other pings. ``directory`` holds the IMU-aware
    weights (default: the shipped ones), or maps each of ``patterns`` to the folder of its network (out-of-fold
    networks live one pattern to a folder). ``patterns``: the missing patterns the IMU-aware networks serve (scenario
    names). ``fused`` (default): each IMU-aware completion fused with ``fused_beam_only``'s
    (:data:`IMU_BEAM_ERROR_CORRELATION`; default :func:`load_fused_beam_only`), both members fading as
    :data:`FUSED_RUN_DECAY` says. Not fused: the IMU-aware networks fade with their cards' ``run_decay``.

    Raises:
        ConfigError: fused with a ``beam_only`` of the caller's but no ``fused_beam_only`` (which networks the
            IMU-aware ones are fused with must be said, not taken from the shipped weights behind the caller's back);
            fused for a pattern without a chosen fusion (:data:`FUSED_RUN_DECAY`); a ``directory`` mapping whose
            patterns are not ``patterns``.
    """
    from .imu_network import load_imu_completer
    from .network import load_completer
    if fused and beam_only is not None and fused_beam_only is None:
        raise ConfigError("load_imu_auto_completer: with a beam_only of your own, give fused_beam_only too (e.g. "
                          "load_fused_beam_only(directory)): the fused member fades as FUSED_RUN_DECAY says")
    patterns = list(patterns)
    unchosen = [p for p in patterns if p not in FUSED_RUN_DECAY]
    if fused and unchosen:
        raise ConfigError(f"load_imu_auto_completer: no fusion was chosen for {unchosen} (FUSED_RUN_DECAY has "
                          f"{sorted(FUSED_RUN_DECAY)}); load it with fused=False")
    folders = dict(directory) if isinstance(directory, Mapping) else dict.fromkeys(patterns, directory)
    if sorted(folders) != sorted(patterns):
        raise ConfigError(f"load_imu_auto_completer: directory names folders for {sorted(folders)}, the patterns "
                          f"are {sorted(patterns)}")
    beam_only = beam_only if beam_only is not None else load_completer("auto")
    if not fused:
        return ImuAutoCompleter([load_imu_completer(p, folders[p]) for p in patterns], beam_only)
    nets = [load_imu_completer(p, folders[p], run_decay=FUSED_RUN_DECAY[p]["IMU-aware"]) for p in patterns]
    fused_beam_only = fused_beam_only if fused_beam_only is not None else load_fused_beam_only()
    return ImuAutoCompleter(nets, beam_only, {p: IMU_BEAM_ERROR_CORRELATION[p] for p in patterns},
                            fused_beam_only=fused_beam_only)
