"""Compare two ``graphnav bench`` results.json files record by record: the largest absolute and relative
difference of every numeric field over the records both hold, and any flag or warning that differs.

A refactoring that must not change behaviour is checked this way (run the same bench before and after):

    .venv/bin/python scripts/compare_results.py before/results.json after/results.json
"""
from __future__ import annotations

import argparse
import json
import math

KEY = ("trajectory", "scenario", "imu_grade", "window_s", "method", "window_start_s")
#: wall time differs from run to run by nature
IGNORED = {"runtime_s"}


def compare(before: list[dict], after: list[dict]) -> tuple[dict, dict, set, set]:
    """(field -> (max abs diff, its relative diff)), (field -> first differing non-numeric pair), keys only
    in before, keys only in after."""
    a = {tuple(r[k] for k in KEY): r for r in before}
    b = {tuple(r[k] for k in KEY): r for r in after}
    numeric, other = {}, {}
    for key in a.keys() & b.keys():
        for field, va in a[key].items():
            vb = b[key].get(field)
            if field in IGNORED:
                continue
            if isinstance(va, float) and isinstance(vb, (int, float)) and not isinstance(vb, bool):
                if math.isnan(va) and math.isnan(vb):
                    continue
                d = abs(va - vb)
                if d > numeric.get(field, (-1.0, 0.0))[0] or math.isnan(d):
                    numeric[field] = (d, d / max(abs(va), 1e-12))
            elif va != vb:
                other.setdefault(field, (key, va, vb))
    return numeric, other, a.keys() - b.keys(), b.keys() - a.keys()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("before")
    ap.add_argument("after")
    args = ap.parse_args()
    with open(args.before) as f, open(args.after) as g:
        before, after = json.load(f), json.load(g)
    numeric, other, only_a, only_b = compare(before, after)
    print(f"records: {len(before)} before, {len(after)} after; {len(only_a)} only before, {len(only_b)} only after")
    print("| field | max abs difference | relative |\n| --- | --- | --- |")
    for field, (d, rel) in sorted(numeric.items()):
        print(f"| {field} | {d:.3g} | {rel:.3g} |")
    for field, (key, va, vb) in sorted(other.items()):
        print(f"differs: {field} at {key}: {va!r} -> {vb!r}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
