"""What the screening refuses on the shared A-KIT trajectories (it should refuse nothing on clean data), and
what it does with each damaged input of the screening brief (Trajectory1 copies in a temporary folder).

Part 1, per clean trajectory: samples refused by the loader (per stream and reason), by the Navigator's
per-sample stream rules (:class:`graphnav.core.screening.StreamScreen`, IMU spike test included, run over the
replay without an estimator) and pings rejected by the aligner's fit (300 s gyrocompassing alignment from the
first sample).

Part 2, with ``--damage``: ``graphnav smooth`` (Graph-HN-batch, GT initial state as the default) on Trajectory1
clean and with each damage, its exit status, health state, refusals and VRMSE against the clean file's GT.
``--first S`` crops the copies to their first S s first. The damages named like ``gt_days`` are those of a new
user's trial of the commands (docs/decisions: units-clocks-axes.md, screening.md, akit-loader.md), which read
Trajectory1's first 150 s (``--damage --first 150 --no-clean``).

    GRAPHNAV_DATA=/work/shared/data .venv/bin/python experiments/screening_report.py            # part 1
    GRAPHNAV_DATA=/work/shared/data .venv/bin/python experiments/screening_report.py --damage   # and part 2

``--gt-positions``: per clean trajectory, the largest departure of the GT position less its velocity's integral
from its neighbours (the reference position spike test's statistic, as the A-KIT reader computes it, published
stamps) against the test's limit.
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

from graphnav.core.errors import DataError
from graphnav.core.screening import StreamScreen
from graphnav.estimators.align import align_mission
from graphnav.estimators.replay import replay
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit


def clean_table(root: Path | None) -> None:
    print("trajectory  loader_refused  stream_refused  aligner_fit_rejected  heading_deg")
    for folder in akit_trajectories(root):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = load_akit(folder)
            al = align_mission(m)
        loader = {k: sum(v["refused"].values()) for k, v in m.meta["streams"].items()}
        screen = StreamScreen(m.config)
        stream = {}
        for kind, t, payload in replay(m):
            why = screen.stamp_problem(kind, t)
            if why is None and kind == "imu":
                why = screen.imu_problem(*payload)
                spike = screen.imu_spike(t, *payload) if why is None else None
                why = why if spike is None else spike[0]
            elif why is None and kind == "dvl":
                problems = screen.dvl_problems(t, np.asarray(payload[0]), np.asarray(payload[1]))
                why = next(iter(problems.values()), None)
            elif why is None and kind == "depth":
                why = screen.depth_problem(t, payload[0])
            if why is not None:
                stream[why] = stream.get(why, 0) + 1
        print(f"{folder.name:12s} {json.dumps(loader):40s} {json.dumps(stream):30s} "
              f"{al.info['n_dvl_rejected_fit']:3d}  {np.degrees(al.euler[2]):8.2f}")


def _edit(path: Path, edit) -> None:
    lines = path.read_text().splitlines()
    path.write_text("\n".join(edit(lines)) + "\n")


def _set(lines, row, col, value):
    parts = lines[row + 1].split(",")
    parts[col] = value
    return lines[:row + 1] + [",".join(parts)] + lines[row + 2:]


DAMAGES = {
    "clean": None,
    "IMU f_x = 1e6 at row 10000": ("IMU", lambda ls: _set(ls, 10000, 1, "1000000.0")),
    "DVL x = 1e6 at row 100": ("DVL", lambda ls: _set(ls, 100, 1, "1000000.0")),
    "GT v_north = 1e6 at row 200": ("GT", lambda ls: _set(ls, 200, 4, "1000000.0")),
    "IMU last stamp 1e300": ("IMU", lambda ls: ls[:-1] + ["1e300," + ls[-1].split(",", 1)[1]]),
    "60 s of DVL rows deleted": ("DVL", lambda ls: ls[:101] + ls[161:]),
    "60 s of DVL NaN rows": ("DVL", lambda ls: ls[:101] + [x.split(",")[0] + ",nan,nan,nan" for x in ls[101:161]]
                              + ls[161:]),
}


def _column(col, fn):
    """Every data line's column ``col`` mapped through ``fn`` (a float to a float)."""
    def edit(lines):
        rows = [x.split(",") for x in lines[1:]]
        for r in rows:
            r[col] = repr(fn(float(r[col])))
        return lines[:1] + [",".join(r) for r in rows]
    return edit


def _columns(cols, fn):
    def edit(lines):
        for c in cols:
            lines = _column(c, fn)(lines)
        return lines
    return edit


DEG = 180.0 / np.pi
DAY_S = 86400.0
#: A new user's damaged inputs (rows of the data lines, 0-based; IMU row 5000 is t = 50 s): each is
#: {file kind: edit, or None to delete the file}.
DAMAGES.update({
    "imu_nan: an IMU cell nan": {"IMU": lambda ls: _set(ls, 5000, 1, "nan")},
    "imu_empty: an IMU cell empty": {"IMU": lambda ls: _set(ls, 5000, 1, "")},
    "dvl_empty: a DVL cell empty": {"DVL": lambda ls: _set(ls, 50, 2, "")},
    "gt_nan: a GT cell nan": {"GT": lambda ls: _set(ls, 50, 3, "nan")},
    "gyro_spike5: gyro z = 5 rad/s on one row": {"IMU": lambda ls: _set(ls, 5000, 6, "5")},
    "imu_spike100: f_x = 100 m/s^2 on one row": {"IMU": lambda ls: _set(ls, 5000, 1, "100")},
    "imu_spike150_5rows: f_x = 150 m/s^2 on five rows": {"IMU": lambda ls: _set(_set(_set(_set(_set(
        ls, 5000, 1, "150"), 5001, 1, "150"), 5002, 1, "150"), 5003, 1, "150"), 5004, 1, "150")},
    "gt_latlon_deg: GT latitude/longitude in degrees": {"GT": _columns((1, 2), lambda x: x * DEG)},
    "gt_att_deg: GT roll/pitch/yaw in degrees": {"GT": _columns((7, 8, 9), lambda x: x * DEG)},
    "gt_alt_pos: GT altitude sign flipped": {"GT": _column(3, lambda x: -x)},
    "gt_days: GT clock 3 days later": {"GT": _column(0, lambda x: x + 3 * DAY_S)},
    "dvl_days: DVL clock 3 days later": {"DVL": _column(0, lambda x: x + 3 * DAY_S)},
    "imu_unix: every file on a Unix clock": {k: _column(0, lambda x: x + 1.65e9) for k in ("IMU", "DVL", "GT")},
    "all_ms: every file's stamps in ms": {k: _column(0, lambda x: x * 1000.0) for k in ("IMU", "DVL", "GT")},
    "no_dvl: the DVL file missing": {"DVL": None},
})


def _damaged_copy(root: Path, name: str, damage, first_s: float | None, tmp: Path) -> Path:
    """Trajectory1 copied to ``tmp`` (its first ``first_s`` s when given) with ``damage`` applied."""
    folder = tmp / name.split(":")[0].replace(" ", "_") / "Trajectory1"
    shutil.copytree(root / "Trajectory1", folder)
    if first_s is not None:
        for f in folder.glob("*_trajectory1.csv"):
            _edit(f, lambda ls: ls[:1] + [x for x in ls[1:] if float(x.split(",")[0]) <= first_s])
    edits = {} if damage is None else damage if isinstance(damage, dict) else dict([damage])
    for kind, edit in edits.items():
        path = folder / f"{kind}_trajectory1.csv"
        if edit is None:
            path.unlink()
        else:
            _edit(path, edit)
    return folder


def damage_table(root: Path, first_s: float | None = None) -> None:
    from graphnav.evaluation.metrics import vrmse
    from graphnav.io.outputs import read_trajectory_csv
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        truth = load_akit(root / "Trajectory1").gt
    exe = Path(sys.executable).parent / "graphnav"
    print("damage | exit | health | refused at load | VRMSE m/s against the clean GT (against the copy's own GT; "
          "final horizontal error) | first warning")
    with tempfile.TemporaryDirectory() as tmp:
        for name, damage in DAMAGES.items():
            try:
                folder = _damaged_copy(root, name, damage, first_s, Path(tmp))
            except IndexError:
                print(f"{name} | | | | | skipped: its row is beyond the first {first_s:g} s")
                continue
            out = folder.parent / "out"
            run = subprocess.run([str(exe), "smooth", "--data", str(folder), "--out", str(out), "--no-plots"],
                                 capture_output=True, text=True)
            summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
            refused = {k: v["refused"] for k, v in summary.get("streams", {}).items() if v.get("refused")}
            error = ""
            if (out / "trajectory.csv").exists():
                try:
                    error = f"{vrmse(read_trajectory_csv(out / 'trajectory.csv'), truth):.4f}"
                except DataError:           # the estimate on a clock of the copy's own (a Unix clock)
                    error = "other clock"
            own = (summary.get("accuracy") or {})
            if own.get("ground_truth"):
                error += f" ({own['vrmse_mission_mps']:.4f}; {own['final_horizontal_position_error_m']:.2f} m)"
            first = next((ln.strip() for ln in run.stderr.splitlines()
                          if any(w in ln for w in ("refused", "outage", "missing from", "rror", "converted",
                                                   "clock", "flipped", "not found"))), "")
            print(f"{name} | {run.returncode} | {(summary.get('health') or {}).get('state')} | {refused} | {error} | "
                  f"{first[:200]}")


def gt_position_table(root: Path) -> None:
    """The position spike and step tests' statistics on each clean trajectory's GT
    (:func:`graphnav.core.screening.with_position_spikes`): the position less the velocity's integral, its largest
    departure from the nearer of the medians of its neighbours on either side (a spike departs from both), and its
    largest change between consecutive rows (a step), each against its limit."""
    from graphnav.core.config import SensorConfig
    from graphnav.core.screening import GT_POSITION_TOLERANCE_M, _position_residual, _side_medians
    from graphnav.io.loaders import _local_ned, read_akit
    spec = SensorConfig().dvl
    print("trajectory  spike departure m  step m  limit m  largest share of the limit (spike, step)")
    for folder in akit_trajectories(str(root)):
        g = read_akit(folder, rescale_stamps=False).gt
        rows = np.ones(len(g), bool)
        r = _position_residual(g[:, 0], _local_ned(g, rows), g[:, 4:7], rows)
        before, after = _side_medians(r)
        gaps = np.diff(g[:, 0])
        limit = 1.5 * spec.jump_tolerance_mps * np.minimum(np.r_[np.inf, gaps], np.r_[gaps, np.inf]) + \
            GT_POSITION_TOLERANCE_M
        spike = np.fmin(np.linalg.norm(r - before, axis=1), np.linalg.norm(r - after, axis=1))
        step = np.linalg.norm(np.diff(r, axis=0), axis=1)
        step_limit = 1.5 * spec.jump_tolerance_mps * gaps + GT_POSITION_TOLERANCE_M
        print(f"{folder.name:12s} {spike.max():.2f} {step.max():.2f} {limit.min():.2f} "
              f"{np.max(spike / limit):.2f} {np.max(step / step_limit):.2f}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--damage", action="store_true", help="also run graphnav smooth on damaged Trajectory1 copies")
    p.add_argument("--no-clean", action="store_true", help="skip part 1")
    p.add_argument("--first", type=float, metavar="S", help="with --damage: crop the copies to their first S s")
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--gt-positions", action="store_true", help="only the GT position spike statistic per trajectory")
    args = p.parse_args(argv)
    root = akit_trajectories(args.data)[0].parent
    if args.gt_positions:
        gt_position_table(root)
        return 0
    if not args.no_clean:
        clean_table(root)
    if args.damage:
        damage_table(root, args.first)
    return 0


if __name__ == "__main__":
    sys.exit(main())
