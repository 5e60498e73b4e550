"""Two ``graphnav bench`` runs compared record by record: what changed, and by how much.

A change that must not alter behaviour (a refactoring, a speed-up) is checked by running the same bench
before and after and comparing the two ``results.json``: records are matched by their key
(:data:`RECORD_KEY`: trajectory, scenario, IMU grade, window length, method, window start); for the records
both hold, every numeric field is compared (``runtime_s`` excepted: wall time differs from run to run) and
every other field (flags, reasons, errors) must be equal. :func:`compare_runs` returns a
:class:`Comparison`; :func:`format_comparison` prints it; ``graphnav compare`` (``graphnav/commands/
compare.py``) is the command.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from graphnav.core.errors import DataError

#: The fields that name one record of ``results.json`` (one window of one method on one case).
RECORD_KEY: tuple[str, ...] = ("trajectory", "scenario", "imu_grade", "window_s", "method", "window_start_s")
#: Fields never compared: wall time differs from run to run by nature.
IGNORED_FIELDS: frozenset[str] = frozenset({"runtime_s"})
#: The accuracy fields whose largest change is reported on its own (m/s).
VRMSE_FIELDS: tuple[str, ...] = ("vrmse_window", "vrmse_mission")


@dataclass
class RecordDiff:
    """The differences of one record present in both runs: ``numeric`` field -> (a, b), ``other`` field ->
    (a, b) for non-numeric fields that differ (or a field only one side has)."""

    key: tuple
    numeric: dict[str, tuple[float, float]] = field(default_factory=dict)
    other: dict[str, tuple[object, object]] = field(default_factory=dict)

    def delta(self, name: str) -> float:
        """|b - a| of a numeric field (0 when it did not differ)."""
        if name not in self.numeric:
            return 0.0
        a, b = self.numeric[name]
        d = abs(b - a)
        return math.inf if math.isnan(d) else d


@dataclass
class Comparison:
    """Result of :func:`compare_runs`."""

    n_a: int
    n_b: int
    only_a: list[tuple]
    only_b: list[tuple]
    identical: int
    diffs: list[RecordDiff]

    @property
    def n_common(self) -> int:
        return self.identical + len(self.diffs)

    def max_delta(self, name: str) -> tuple[float, tuple | None]:
        """(largest |b - a| of ``name`` over the common records, the key where it is); (0, None) if none."""
        best = max(self.diffs, key=lambda d: d.delta(name), default=None)
        if best is None or best.delta(name) == 0.0:
            return 0.0, None
        return best.delta(name), best.key

    def field_maxima(self) -> dict[str, tuple[float, float]]:
        """field -> (largest |b - a|, that difference relative to |a|) over the common records."""
        out: dict[str, tuple[float, float]] = {}
        for d in self.diffs:
            for name, (a, b) in d.numeric.items():
                delta = d.delta(name)
                if delta > out.get(name, (-1.0, 0.0))[0]:
                    out[name] = (delta, delta / max(abs(a), 1e-12) if math.isfinite(delta) else math.inf)
        return out

    def same(self, tol: float = 0.0) -> bool:
        """Both runs hold the same records and no field differs by more than ``tol`` (non-numeric: at all)."""
        if self.only_a or self.only_b:
            return False
        return all(not d.other and all(d.delta(n) <= tol for n in d.numeric) for d in self.diffs)


def record_key(record: dict) -> tuple:
    """The key of one record (:data:`RECORD_KEY`; a record that failed has no window start: None)."""
    return tuple(float(record[k]) if k in ("window_s", "window_start_s") and record.get(k) is not None
                 else record.get(k) for k in RECORD_KEY)


def index_records(records: list[dict], source: str | Path) -> dict[tuple, dict]:
    """Records by key. Raises DataError naming ``source`` and both indices when two records share a key."""
    out: dict[tuple, dict] = {}
    first: dict[tuple, int] = {}
    for i, r in enumerate(records):
        key = record_key(r)
        if key in out:
            raise DataError(f"{source}: records {first[key]} and {i} have the same key "
                            f"{dict(zip(RECORD_KEY, key))}; is it two runs concatenated?")
        out[key], first[key] = r, i
    return out


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _numbers(x) -> bool:
    """A list of numbers; None stands for NaN (``results.json`` writes NaN as null)."""
    return isinstance(x, (list, tuple)) and all(v is None or _is_number(v) for v in x)


def diff_record(key: tuple, a: dict, b: dict) -> RecordDiff:
    """The fields in which records ``a`` and ``b`` (same key) differ; NaN equals NaN. A list of numbers (e.g. the
    velocity NEES per body axis) is compared element by element, as ``name[i]``, within the same tolerance."""
    d = RecordDiff(key)
    for name in sorted(a.keys() | b.keys()):
        if name in IGNORED_FIELDS:
            continue
        va, vb = a.get(name), b.get(name)
        if _numbers(va) and _numbers(vb) and len(va) == len(vb):
            pairs = [(f"{name}[{i}]", math.nan if x is None else x, math.nan if y is None else y)
                     for i, (x, y) in enumerate(zip(va, vb))]
        else:
            pairs = [(name, va, vb)]
        for field_name, x, y in pairs:
            if _is_number(x) and _is_number(y):
                fx, fy = float(x), float(y)
                if fx != fy and not (math.isnan(fx) and math.isnan(fy)):
                    d.numeric[field_name] = (fx, fy)
            elif x != y:
                d.other[field_name] = (x, y)
    return d


def compare_runs(a: list[dict], b: list[dict], source_a: str | Path = "A", source_b: str | Path = "B") -> Comparison:
    """Compare the records of two bench runs (``a`` before, ``b`` after), matched by :data:`RECORD_KEY`."""
    ia, ib = index_records(a, source_a), index_records(b, source_b)
    diffs, identical = [], 0
    for key in sorted(ia.keys() & ib.keys(), key=repr):
        d = diff_record(key, ia[key], ib[key])
        if d.numeric or d.other:
            diffs.append(d)
        else:
            identical += 1
    return Comparison(len(a), len(b), sorted(ia.keys() - ib.keys(), key=repr),
                      sorted(ib.keys() - ia.keys(), key=repr), identical, diffs)


def _key_text(key: tuple | None) -> str:
    if key is None:
        return "-"
    traj, sc, grade, win, method, start = key
    where = f"window {start:g} s" if start is not None else "no window (failed run)"
    return f"{traj} {sc} {grade} {method} {where} ({win:g} s)" if win is not None else f"{traj} {sc} {grade} {method}"


def format_comparison(c: Comparison, name_a: str, name_b: str, show: int = 10) -> str:
    """A plain-text report: record counts, identical count, largest VRMSE changes, the per-field maxima, the
    non-numeric differences and the ``show`` records with the largest window-VRMSE change."""
    lines = [f"A: {name_a} ({c.n_a} records)", f"B: {name_b} ({c.n_b} records)",
             f"{c.n_common} records in both, {c.identical} identical (every field but runtime_s), "
             f"{len(c.diffs)} differ; {len(c.only_a)} only in A, {len(c.only_b)} only in B"]
    for name in VRMSE_FIELDS:
        delta, key = c.max_delta(name)
        lines.append(f"max |delta {name}| = {delta:.3g} m/s" + (f" at {_key_text(key)}" if key else ""))
    maxima = c.field_maxima()
    if maxima:
        lines += ["", "| field | max abs difference | relative to A |", "| --- | --- | --- |"]
        lines += [f"| {n} | {d:.3g} | {r:.3g} |" for n, (d, r) in sorted(maxima.items())]
    other = [(d.key, n, va, vb) for d in c.diffs for n, (va, vb) in d.other.items()]
    if other:
        lines += ["", f"{len(other)} non-numeric differences (first {min(show, len(other))}):"]
        lines += [f"  {_key_text(k)}: {n}: {va!r} -> {vb!r}" for k, n, va, vb in other[:show]]
    changed = sorted((d for d in c.diffs if "vrmse_window" in d.numeric), key=lambda d: -d.delta("vrmse_window"))
    if changed and show > 0:
        lines += ["", f"largest window-VRMSE changes (first {min(show, len(changed))} of {len(changed)}):",
                  "| record | A m/s | B m/s | B - A |", "| --- | --- | --- | --- |"]
        for d in changed[:show]:
            a, b = d.numeric["vrmse_window"]
            lines.append(f"| {_key_text(d.key)} | {a:.4f} | {b:.4f} | {b - a:+.3g} |")
    for label, keys in (("only in A", c.only_a), ("only in B", c.only_b)):
        if keys:
            lines += ["", f"{label} (first {min(show, len(keys))} of {len(keys)}):"]
            lines += [f"  {_key_text(k)}" for k in keys[:show]]
    return "\n".join(lines)
