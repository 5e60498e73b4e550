"""The shared trajectories through ``graphnav online`` without ground truth, next to the GT-initialised runs.

For every A-KIT trajectory folder under ``--data``:

1. ``no GT``: a copy of the folder with only ``IMU_*.csv`` and ``DVL_*.csv`` (symbolic links) goes through
   ``graphnav online --data COPY`` (the default: fixed-lag graph, Graph-TC). The Navigator aligns from the
   sensors; there is no depth sensor (the A-KIT depth stream is derived from the GT) and the DVL time offset
   is the loader's no-GT default.
2. ``GT init``: ``graphnav online --data FOLDER --init gt`` (the initial state from the GT, depth from the GT,
   offsets estimated against the GT: what the benchmark does).
3. ``sensor init, full folder``: ``--init sensors`` on the full folder, to separate the initialisation from the
   other differences of (1).

Each run is scored afterwards against the GT of the full folder (``graphnav.evaluation.metrics.vrmse``): mission VRMSE
after the first 60 s of the mission, and over the common span (from the end of the alignment).

Usage: ``.venv/bin/python experiments/no_gt_runs.py [--data ../shared/data/snapir-2022-akit] [--out out/no_gt]``
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import tempfile
import warnings
from pathlib import Path

import numpy as np

from graphnav.cli import main as graphnav
from graphnav.evaluation.metrics import vrmse
from graphnav.io.outputs import read_trajectory_csv
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit


def run_online(folder: Path, out: Path, *extra: str) -> tuple:
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = graphnav(["online", "--data", str(folder), "--out", str(out), "--no-plots", "--no-progress", *extra])
    if code != 0:
        raise SystemExit(f"graphnav online failed on {folder} ({code})")
    return read_trajectory_csv(out / "online.csv"), json.loads((out / "summary.json").read_text())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default=None, help="folder of A-KIT trajectories (default: the shared data)")
    parser.add_argument("--out", default="out/no_gt", help="output folder")
    args = parser.parse_args(argv)
    folders = akit_trajectories(args.data)
    out = Path(args.out)
    rows = []
    for folder in folders:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            gt = load_akit(folder).gt
        with tempfile.TemporaryDirectory() as tmp:
            bare = Path(tmp) / folder.name
            bare.mkdir()
            for f in folder.iterdir():
                if f.name.startswith(("IMU_", "DVL_")):
                    (bare / f.name).symlink_to(f.resolve())
            no_gt, s_no_gt = run_online(bare, out / folder.name / "no_gt")
        gt_init, _ = run_online(folder, out / folder.name / "gt_init", "--init", "gt")
        sensors, s_sensors = run_online(folder, out / folder.name / "sensor_init", "--init", "sensors")
        t_align = s_no_gt["initialisation"]["completed_t"]
        t_end = float(gt.t[-1])
        row = {"trajectory": folder.name, "t_align_s": t_align,
               "heading_source": s_no_gt["initialisation"]["heading_source"]}
        for name, sol in (("no_gt", no_gt), ("gt_init", gt_init), ("sensor_init", sensors)):
            row[f"{name}_after60"] = float(vrmse(sol, gt, gt.t[0] + 60.0, t_end))
            row[f"{name}_common"] = float(vrmse(sol, gt, max(t_align, s_sensors["initialisation"]["completed_t"]), t_end))
        rows.append(row)
        print(json.dumps(row), flush=True)
    print("\n| trajectory | alignment done at s | no GT: VRMSE after 60 s | GT init: after 60 s | GT init: from alignment "
          "| sensor init (full folder): after the alignment |")
    print("| --- | --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['trajectory']} | {r['t_align_s']:.0f} | {r['no_gt_after60']:.3f} | {r['gt_init_after60']:.3f} | "
              f"{r['gt_init_common']:.3f} | {r['sensor_init_common']:.3f} |")
    means = {k: float(np.mean([r[k] for r in rows])) for k in rows[0] if k.endswith(("after60", "common"))}
    print(f"| mean | | {means['no_gt_after60']:.3f} | {means['gt_init_after60']:.3f} | {means['gt_init_common']:.3f} | "
          f"{means['sensor_init_common']:.3f} |")
    (out / "no_gt_runs.json").write_text(json.dumps({"rows": rows, "means": means}, indent=2))


if __name__ == "__main__":
    main()
