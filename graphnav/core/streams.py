"""What each input stream read, used and refused, and why: the one record every loader and the Navigator keep.

It lives in ``Mission.meta["streams"]`` (and from there in ``summary.json`` and ``graphnav info``)::

    {"dvl": {"source": "log.pd0", "read": 400, "used": 380, "refused": {"no bottom lock": 20},
             "rate_hz": 1.0, "span_s": [t0, t1], "notes": ["stamps: header stamps were zero; receive time used"]},
     "imu": {..., "doubted": {"gyro rates read as they are, though they look 57.3x too small": 15000}}}

Nothing a loader drops leaves without a count and a reason here, and nothing it reads despite a doubt either
(``doubted``, present only when a sample was: used, yet a user should look at them before trusting a result).
"""
from __future__ import annotations

import warnings

import numpy as np


def stream_entry(meta: dict, stream: str) -> dict:
    """The (created on first use) record of ``stream`` in a mission's ``meta``."""
    return meta.setdefault("streams", {}).setdefault(
        stream, {"source": "", "read": 0, "used": 0, "refused": {}, "rate_hz": None, "span_s": None, "notes": []})


def count_read(meta: dict, stream: str, t: np.ndarray, source: str = "", rate_hz: float | None = None) -> dict:
    """Record ``len(t)`` samples read (and the stream's rate and span, :func:`set_span`) for ``stream``."""
    entry = stream_entry(meta, stream)
    t = np.asarray(t, float)
    entry["read"] += int(t.size)
    entry["used"] += int(t.size)
    if source:
        entry["source"] = source
    return set_span(meta, stream, t, rate_hz)


def set_span(meta: dict, stream: str, t: np.ndarray, rate_hz: float | None = None) -> dict:
    """Record the span and rate of ``stream`` from its stamps ``t`` (s) as the mission holds them (after
    a loader's rescaling or clock offsets), without counting samples. ``rate_hz``: the rate (Hz) its reader read
    from them (the IMU's, :func:`graphnav.core.imu_timing.shown_rate_hz`); None: their median step."""
    entry = stream_entry(meta, stream)
    t = np.asarray(t, float)
    finite = t[np.isfinite(t)]
    if finite.size:
        entry["span_s"] = [float(finite.min()), float(finite.max())]
    if finite.size > 1:
        if rate_hz is None:
            step = np.median(np.diff(np.sort(finite)))
            rate_hz = 1.0 / step if step > 0 else np.nan
        entry["rate_hz"] = float(rate_hz) if np.isfinite(rate_hz) else None
    return entry


def count_refused(meta: dict, stream: str, reason: str, n: int) -> dict:
    """Record ``n`` samples of ``stream`` refused for ``reason`` (they are no longer counted as used)."""
    entry = stream_entry(meta, stream)
    if n:
        entry["refused"][reason] = entry["refused"].get(reason, 0) + int(n)
        entry["used"] = max(0, entry["used"] - int(n))
    return entry


def count_doubted(meta: dict, stream: str, reason: str, n: int) -> dict:
    """Record ``n`` samples of ``stream`` read and used despite a doubt ``reason`` (a unit the evidence cannot settle,
    taken with a warning); they stay counted as used."""
    entry = stream_entry(meta, stream)
    if n:
        doubted = entry.setdefault("doubted", {})
        doubted[reason] = doubted.get(reason, 0) + int(n)
    return entry


def say_doubted(meta: dict, stream: str, source: str, text: str, reason: str, n: int, stacklevel: int = 2) -> None:
    """A suspect input kept: ``{source}: {text}`` warned about (``stacklevel`` as the caller's own warning would
    have it), ``text`` noted on ``stream`` and its ``n`` samples counted as doubted for ``reason``."""
    warnings.warn(f"{source}: {text}", RuntimeWarning, stacklevel=stacklevel + 1)
    add_note(meta, stream, text)
    count_doubted(meta, stream, reason, n)


def add_note(meta: dict, stream: str, note: str) -> dict:
    """A sentence about ``stream`` a user must see (which stamps were used, a unit converted, an offset)."""
    entry = stream_entry(meta, stream)
    entry["notes"].append(note)
    return entry


#: ``meta`` key of the files rescaled about their own first stamp (on a clock of their own), by stream:
#: ``{"origin": s, "factor": the rescale, "folder_origin": s}`` (``folder_origin``: the stamp the IMU's stamps are
#: rescaled about, the folder's origin unless the IMU is on a clock of its own too), which a time offset on their
#: stamps as written needs
#: (:func:`offset_on_rescaled_stamps`, :func:`offset_on_written_stamps`), set by
#: :func:`graphnav.io.loaders.read_akit`; a time offset a user sees or gives is on the stamps as written.
OWN_CLOCK_RESCALE = "own_clock_rescale"


def offset_on_rescaled_stamps(meta: dict, stream: str, offset_s: float) -> float:
    """The offset (s) to add to the rescaled stamps of ``stream`` that puts them where ``offset_s``, added to its
    stamps as written, does: the stamps plus the offset rescaled as the folder's files are, about its origin
    (:data:`OWN_CLOCK_RESCALE`). A file on a clock of its own is rescaled about its own first stamp ``T0``; an offset
    added after that would land ``(1 - factor) (T0 + offset - origin)`` s late (0.0025 ``t0`` s for a piece cut ``t0``
    s into a published grid a day away). ``offset_s`` itself for a file rescaled about the folder's origin or not
    at all."""
    own = meta.get(OWN_CLOCK_RESCALE, {}).get(stream)
    if own is None:
        return offset_s
    factor = own["factor"]
    return offset_s * factor + (1.0 - factor) * (own["folder_origin"] - own["origin"])


def offset_on_written_stamps(meta: dict, stream: str, offset_s: float) -> float:
    """The inverse of :func:`offset_on_rescaled_stamps`: the offset (s) on the stamps of ``stream`` as written that
    puts them where ``offset_s`` added to its rescaled stamps does."""
    own = meta.get(OWN_CLOCK_RESCALE, {}).get(stream)
    if own is None:
        return offset_s
    factor = own["factor"]
    return (offset_s - (1.0 - factor) * (own["folder_origin"] - own["origin"])) / factor


def clock_offsets_on_written_stamps(meta: dict, stream: str, kept: dict | None) -> dict | None:
    """``kept`` (a clock or time offset estimate as a dict: ``offset_s``, ``coarse_offset_s``, ``repeated_at_s``, s,
    on the rescaled stamps of ``stream``) with those offsets on its stamps as written (:func:`offset_on_written_stamps`;
    the same dict where there is nothing to convert)."""
    own = meta.get(OWN_CLOCK_RESCALE, {}).get(stream)
    if kept is None or own is None:
        return kept
    return {k: offset_on_written_stamps(meta, stream, float(v)) if k in OFFSET_KEYS else v for k, v in kept.items()}


#: The keys of a clock or time offset estimate (dict) that hold offsets (s) on a stream's stamps.
OFFSET_KEYS = ("offset_s", "coarse_offset_s", "repeated_at_s")
