"""A loaded mission screened (:func:`screen_mission`): the rules of :mod:`graphnav.core.screening` a reader did not
apply with its file's lines (bags, PD0, generic CSV), each once, and the advice when most of a DVL is refused."""
from __future__ import annotations

import copy
import dataclasses
import hashlib

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.dvl import implausible_pings, no_lock_pings, ping_velocity_b
from graphnav.core.imu_timing import shown_rate_hz
from graphnav.core.mission import Mission
from graphnav.core.screening import (
    MAX_REFUSED_FRACTION,
    NO_BOTTOM_LOCK,
    ZERO_RESOLUTION,
    beams_out_of_range,
    check_refused_fraction,
    depth_implausible,
    gt_implausible,
    imu_implausible,
    note_outages,
    over_refused_limit,
    refuse,
)
from graphnav.core.streams import count_read


def record_kept(meta: dict, stream: str, t: np.ndarray) -> None:
    """The span and rate of ``stream`` recorded from the stamps ``t`` (s) of the samples kept after some were
    refused (none kept: no span)."""
    from graphnav.core.streams import set_span
    if len(t):
        set_span(meta, stream, t, shown_rate_hz(stream, t))
    else:
        meta["streams"][stream]["span_s"] = None


def _kept(meta: dict, name: str, stream, bad: np.ndarray):
    """``stream`` without its samples ``bad`` (refused), its span and rate recorded from those kept."""
    if not bad.any():
        return stream
    stream = stream.take(np.flatnonzero(~bad))
    record_kept(meta, name, stream.t)
    return stream


def screen_mission(mission: Mission) -> Mission:
    """The screening of :mod:`graphnav.core.screening` applied to a loaded mission (bags, PD0, generic CSV; the
    A-KIT loader screens its files itself, the column-map loader its IMU and GT rows): IMU rows with a NaN value, beyond
    full scale or spiking (:func:`graphnav.core.screening.imu_implausible`; a knock the DVL saw is kept), depth rows
    outside the range or spiking and implausible GT rows are dropped; pings with a beam beyond the vehicle's speed (the
    whole ping: one beam the instrument got wrong makes the others suspect, as on the Navigator's stream), pings logged
    as exactly 0 without bottom lock (:func:`graphnav.core.screening.no_bottom_lock`) and pings outside its envelope
    are marked invalid; each counted with its reason in ``meta["streams"]`` and warned about; DVL outages are
    warned about; more than half of a stream refused is a DataError. The IMU is screened once: a reader that
    screened it (``meta["imu_screened"]``), or the rows holding no measurement (``meta["imu_unmeasured_screened"]``,
    a bag's), is not screened for it again. The mission passed in is left as it is (its meta copied before anything is
    counted: screened twice, each count was made twice in the meta both shared); the mission returned is marked
    screened (``meta["screened"]``: :func:`_streams_digest` of its streams), and screening it again returns it as it
    is, unless a stream was changed since (the meta is shared by ``dataclasses.replace``: a DVL or depth replaced after
    screening was returned unscreened, a 6 m/s beam or a 5000 m depth kept without a word)."""
    if "screened" in mission.meta and mission.meta["screened"] == _streams_digest(mission):
        return mission
    meta = copy.deepcopy(mission.meta)
    cfg = mission.config
    for name, stream in (("imu", mission.imu), ("dvl", mission.dvl), ("depth", mission.depth), ("gt", mission.gt)):
        if stream is not None and not meta.get("streams", {}).get(name, {}).get("read"):
            count_read(meta, name, stream.t, stream.source, shown_rate_hz(name, stream.t))
    imu, dvl, depth, gt = mission.imu, mission.dvl, mission.depth, mission.gt
    # a reader that refused the rows holding no measurement itself (a bag's, naming its messages) says so here only
    unmeasured = not meta.pop("imu_unmeasured_screened", False)
    screened = not meta.get("imu_screened")     # a loader that knows the file lines screened the IMU itself
    if screened:
        # the DVL as read tells a knock, which changed its velocity, from a burst of bad samples
        bad = refuse(meta, "imu", imu_implausible(imu.t, imu.f_b, imu.omega_b, cfg, meta=meta, source=imu.source,
                                                  dvl=(dvl.t, ping_velocity_b(dvl, cfg.dvl)), unmeasured=unmeasured),
                     imu.source, t=imu.t)
        imu = _kept(meta, "imu", imu, bad)
    beam_bad = beams_out_of_range(dvl.beams, dvl.valid, cfg.dvl)
    masks = {f"beam beyond {cfg.dvl.max_speed_mps:g} m/s": beam_bad.any(axis=1)}
    valid = dvl.valid & ~beam_bad
    from graphnav.core.dvl import DvlGeometry
    v = dvl.v_b if dvl.v_b is not None else DvlGeometry.from_spec(cfg.dvl).velocity_from_beams(
        np.where(valid, dvl.beams, np.nan), valid, allow_missing=True)
    if not meta.get("dvl_zeros_screened"):
        # the log's resolution as recorded (PD0: 1 mm/s in any frame, where the beams rotated back are off that grid)
        resolution = meta.get("dvl_resolution_mps")
        fine = None if resolution is None else resolution < ZERO_RESOLUTION
        masks[NO_BOTTOM_LOCK] = no_lock_pings(dvl.t, cfg.dvl, fine, beams=dvl.beams, valid=valid, v=v, v_d=dvl.v_d,
                                              v_d_valid=dvl.v_d_valid)
        v = np.where(masks[NO_BOTTOM_LOCK][:, None], np.nan, v)       # no neighbour of the envelope's spike test
    masks.update({f"outside the envelope ({k})": m for k, m in implausible_pings(dvl.t, v, cfg.dvl).items()})
    # where the reader's file holds each ping (a PD0 ensemble, a bag message), for this warning only
    bad = refuse(meta, "dvl", masks, dvl.source, unit="ping", where=meta.pop("dvl_ping_where", None), t=dvl.t)
    if bad.any():
        valid = valid & ~bad[:, None]
        dvl = dataclasses.replace(dvl, beams=np.where(valid, dvl.beams, np.nan), valid=valid,
                                  v_b=None if dvl.v_b is None else np.where(bad[:, None], np.nan, dvl.v_b),
                                  v_d_valid=None if dvl.v_d_valid is None else dvl.v_d_valid & ~bad)
    usable = dvl.valid.sum(axis=1) >= 3
    if dvl.v_d_valid is not None:
        usable |= dvl.v_d_valid
    if len(dvl.t) > 1:
        note_outages(meta, dvl.t, usable, 1.0 / float(np.median(np.diff(dvl.t))), dvl.source)
    if depth is not None:
        where = meta.pop("depth_where", None)       # a PD0 ensemble, a bag message, for this warning only
        bad = refuse(meta, "depth", depth_implausible(depth.t, depth.depth, cfg), depth.source,
                     where=where if where is not None and len(where) == len(depth.t) else None, t=depth.t)
        depth = _kept(meta, "depth", depth, bad)
    if gt is not None and not meta.get("gt_screened"):     # the column-map loader screened it with its lines
        bad = refuse(meta, "gt", gt_implausible(gt.t, gt.v_n, cfg.dvl), gt.source)
        gt = _kept(meta, "gt", gt, bad)
    speed_reasons = [r for r in masks if r != NO_BOTTOM_LOCK]      # what a velocity unit changes
    check_refused_fraction(meta, advice=_declared_unit_advice(meta, imu, dvl.t, v, cfg, speed_reasons))
    out = dataclasses.replace(mission, imu=imu, dvl=dvl, depth=depth, gt=gt, meta={**meta, "imu_screened": True})
    out.meta["screened"] = _streams_digest(out)
    return out


def _streams_digest(mission: Mission) -> str:
    """A digest of the values of a mission's IMU, DVL, depth and GT (every numeric array of each): the same for the
    streams :func:`screen_mission` returned, another once one is replaced or changed in place."""
    h = hashlib.sha1()
    for stream in (mission.imu, mission.dvl, mission.depth, mission.gt):
        h.update(b"|")
        for f in dataclasses.fields(stream) if stream is not None else ():
            value = getattr(stream, f.name)
            if isinstance(value, np.ndarray) and value.dtype != object:
                h.update(f"{f.name}{value.shape}{value.dtype}".encode())
                h.update(np.ascontiguousarray(value).tobytes())
    return h.hexdigest()


def _declared_unit_advice(meta: dict, imu, t: np.ndarray, v: np.ndarray, cfg: SensorConfig,
                          speed_reasons: list[str]) -> dict:
    """``{"dvl": why}`` when over half the pings of a DVL in a declared velocity unit (``meta["prepare"]["dvl_unit"]``;
    a column map's without one: the unit its loader took, :func:`graphnav.io.units.taken_velocity_unit`) are refused
    and a smaller unit explains them (:func:`graphnav.io.dvl_frame.smaller_unit_advice`, the body-frame velocity ``v``
    (M,3, m/s) at ``t`` (s) against ``imu``): a unit 10x too large, or knots read as m/s, puts a vehicle beyond its
    envelope, where the refusal's "check the units" does not say which; else ``{}``. Where the pings refused for
    something a unit does not change (no valid beam, bottom lock lost) are over half the stream by themselves, the
    refusal says so (:func:`_refused_for_what_no_unit_changes`; ``speed_reasons``: the refusals a unit changes), and a
    unit is advised beside it only where the pings refused for their speed are at least
    :data:`UNIT_ADVICE_MIN_SPEED_SHARE` of the rest (not a few spikes). Beside
    any such pings a unit is advised only where the IMU's accelerations explain it clearly better
    (:data:`UNIT_ADVICE_CLEARLY`); where none is, the refusal names both kinds of pings and what to check for each."""
    from graphnav.io.units import judged_velocity_unit
    declared = judged_velocity_unit(meta)
    if not declared or not over_refused_limit(meta, "dvl"):
        return {}
    refused = _refused_for_what_no_unit_changes(meta, speed_reasons)
    advice = None
    if refused.alone is None or refused.speed_share >= UNIT_ADVICE_MIN_SPEED_SHARE:
        from graphnav.io.dvl_frame import smaller_unit_advice
        # beside pings refused whatever the unit, the speed alone cannot tell spikes from a unit: the IMU must, where
        # it sees the pings, on those the declared unit keeps (the spikes spoil every unit's fit alike)
        advice = smaller_unit_advice(t, v, declared, imu.t, imu.f_b, imu.omega_b, cfg.dvl,
                                     clearly=1.0 if not refused.with_speed else UNIT_ADVICE_CLEARLY,
                                     speed_alone=refused.alone is None)
    not_the_unit = refused.alone or (refused.with_speed if not advice else None)
    said = "; besides, ".join(s for s in (not_the_unit, advice) if s)
    return {"dvl": said} if said else {}


#: Where most of a DVL's pings are refused for what no unit changes, a smaller unit is still advised when the pings
#: refused for their speed are at least this share of the others: knots read as m/s with 55 % of the pings without
#: bottom lock have 98 of 268 (0.37) beyond the envelope; a DVL with 61 % of its pings blank and 1 in 50 at 3x speed,
#: which a unit does not explain, 6 of 234 (0.03).
UNIT_ADVICE_MIN_SPEED_SHARE = 0.1
#: ... and when the unit leaves under this share of what the declared one leaves unexplained by the IMU on the pings
#: the declared unit keeps (:func:`graphnav.io.dvl_frame.smaller_unit_advice`'s ``clearly``; on all of them spikes
#: spoil every unit's fit alike: m/s data with 70 % of the pings blank and 30 % of the rest at 3x speed left 0.993
#: against 0.994, knots with 1 in 50 at 3x 0.98-1.00 against 1.00-1.04). 600 s simulated logs, seeds 1-3, 0.005-0.045
#: m/s beams: knots read as m/s with 20-55 % blank, some with 1 in 50 at 3x, leave 0.07-0.83 of what m/s leaves on those
#: pings; m/s with 40-70 % blank and 30 % of the rest at 3x leave 1.45-38x less than knots.
UNIT_ADVICE_CLEARLY = 0.9


@dataclasses.dataclass(frozen=True)
class _NoUnitRefusal:
    """What the DVL pings refused for reasons a velocity unit does not change say
    (:func:`_refused_for_what_no_unit_changes`).

    Attributes:
        alone: what to check, naming those pings and the few a unit could, when they are over
            :data:`~graphnav.core.screening.MAX_REFUSED_FRACTION` of the stream by themselves; else None.
        speed_share: the pings refused for their speed over those not refused for the other reasons.
        with_speed: where there are pings of both kinds, both named and what to check for each, for a refusal no unit
            explains; else None.
    """

    alone: str | None
    speed_share: float
    with_speed: str | None


def _refused_for_what_no_unit_changes(meta: dict, speed_reasons: list[str]) -> _NoUnitRefusal:
    """The DVL pings refused (``meta["streams"]["dvl"]``) for reasons a velocity unit does not change: all but
    ``speed_reasons`` (the screen's vehicle envelope and a beam beyond its speed). A DVL with over half its pings
    without a valid beam and a few speed spikes was advised knots, in which as many are refused."""
    entry = meta["streams"]["dvl"]
    by_speed = {r: n for r, n in entry["refused"].items() if r in speed_reasons}
    others = {r: n for r, n in entry["refused"].items() if r not in by_speed}
    share = sum(by_speed.values()) / max(entry["read"] - sum(others.values()), 1)
    if not others:
        return _NoUnitRefusal(None, share, None)
    most = max(others, key=others.get)
    said = (f"{sum(others.values())} of the {entry['read']} pings are refused for what no velocity unit changes "
            f"({', '.join(r.split(' (')[0] for r in sorted(others, key=others.get, reverse=True))})")
    what = ("that the DVL kept bottom lock (altitude within its range) and that its velocity is read from the right "
            "columns"
            if most.startswith("no valid beam") or most == NO_BOTTOM_LOCK else
            "the column map and the configuration's sensor ranges")
    both = None if not by_speed else (
        f"{said}, and {sum(by_speed.values())} are beyond the vehicle's envelope, which no smaller velocity unit "
        f"explains (spikes, or a vehicle faster than its configured envelope): check {what}; and check the DVL's "
        "velocity for spikes and the configuration's sensor ranges")
    if not sum(others.values()) > MAX_REFUSED_FRACTION * entry["read"]:
        return _NoUnitRefusal(None, share, both)
    if by_speed:
        said += f", over {MAX_REFUSED_FRACTION:.0%} without the {sum(by_speed.values())} beyond the vehicle's envelope"
    return _NoUnitRefusal(f"{said}: check {what}", share, both)
