"""What the screening refuses on the shared A-KIT trajectories (it should refuse nothing on clean data), and
what it does with each damaged input of the screening brief (Trajectory1 copies in a temporary folder).

Part 1, per clean trajectory: samples refused by the loader (per stream and reason), by the Navigator's
per-sample stream rules (:class:`graphnav.core.screening.StreamScreen`, IMU spike test included, run over the
replay without an estimator) and pings rejected by the aligner's fit (300 s gyrocompassing alignment from the
first sample).

Part 2, with ``--damage``: ``graphnav smooth`` (Graph-HN-batch, GT initial state as the default) on Trajectory1
clean and with each damage, its exit status, health state, refusals and VRMSE against the clean file's GT.

    GRAPHNAV_DATA=/work/shared/data .venv/bin/python experiments/screening_report.py            # part 1
    GRAPHNAV_DATA=/work/shared/data .venv/bin/python experiments/screening_report.py --damage   # and part 2
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


def damage_table(root: Path) -> None:
    from graphnav.evaluation.metrics import vrmse
    from graphnav.io.outputs import read_trajectory_csv
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        truth = load_akit(root / "Trajectory1").gt
    exe = Path(sys.executable).parent / "graphnav"
    print("damage | exit | health | refused at load | VRMSE m/s | first warning")
    with tempfile.TemporaryDirectory() as tmp:
        for name, damage in DAMAGES.items():
            folder = Path(tmp) / name.replace(" ", "_") / "Trajectory1"
            shutil.copytree(root / "Trajectory1", folder)
            if damage is not None:
                kind, edit = damage
                _edit(folder / f"{kind}_trajectory1.csv", edit)
            out = folder.parent / "out"
            run = subprocess.run([str(exe), "smooth", "--data", str(folder), "--out", str(out), "--no-plots"],
                                 capture_output=True, text=True)
            summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
            refused = {k: v["refused"] for k, v in summary.get("input_streams", {}).items() if v["refused"]}
            error = "" if not (out / "trajectory.csv").exists() else \
                f"{vrmse(read_trajectory_csv(out / 'trajectory.csv'), truth):.4f}"
            first = next((ln.strip() for ln in run.stderr.splitlines()
                          if ("refused" in ln or "outage" in ln or "missing from" in ln or "Error" in ln)), "")
            print(f"{name} | {run.returncode} | {(summary.get('health') or {}).get('state')} | {refused} | {error} | "
                  f"{first[:200]}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--damage", action="store_true", help="also run graphnav smooth on damaged Trajectory1 copies")
    p.add_argument("--no-clean", action="store_true", help="skip part 1")
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    args = p.parse_args(argv)
    root = akit_trajectories(args.data)[0].parent
    if not args.no_clean:
        clean_table(root)
    if args.damage:
        damage_table(root)
    return 0


if __name__ == "__main__":
    sys.exit(main())
