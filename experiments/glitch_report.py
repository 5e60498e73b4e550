"""Glitch-injection table: implausible DVL samples in a simulated mission and in shared A-KIT trajectories,
and what the hybrid methods (network completer) make of them.

10 % of the pings (default) are replaced by :func:`graphnav.evaluation.faults.glitch_velocities` glitches: two of three
no-bottom-lock samples (|v_z| 1-2 m/s, horizontal velocity scaled by 0.2-1), one of three a 2.5-3.5 m/s
one-ping spike. Three runs of each method on each scenario (missing beams in 30 s windows, as the bench):

- ``clean``: the mission as loaded;
- ``screened``: glitches injected and screened the way the loaders do (``DvlSpec`` envelope,
  :func:`graphnav.core.dvl.implausible_pings`; for A-KIT the glitched CSV goes through ``load_akit``);
- ``unscreened``: glitches injected with the envelope off: only the completer's own envelope check
  (fallback to the average estimator, counted in ``info["completer_fallbacks"]["envelope"]``) protects it.

- ``dropped``: the clean mission with the screened pings simply missing (valid mask cleared): the best any
  screening can do, since a glitched ping carries no usable velocity.

VRMSE is the mean window VRMSE (m/s) over the outage windows; ``ratio`` = screened / clean (the bound is
1.2), ``vs dropped`` = screened / dropped. ``check``: PASS within 1.2x of clean; LOST-PINGS above it but within
2 % of ``dropped`` (the glitches left no trace; what is lost is the pings' information); FAIL otherwise
(the exit status counts FAILs only). Run:

    .venv/bin/python experiments/glitch_report.py                          # simulated + Trajectory5
    .venv/bin/python experiments/glitch_report.py --trajectories Trajectory5 Trajectory11 --fraction 0.1
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from graphnav.core.dvl import screen_implausible
from graphnav.core.scenarios import scenario_outage, window_starts
from graphnav.evaluation.faults import dvl_glitches, glitch_csv
from graphnav.evaluation.methods import run_method
from graphnav.evaluation.metrics import vrmse
from graphnav.io.loaders import akit_files
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit
from graphnav.sim.simulate import simulate_mission

BOUND = 1.2
#: screened within this factor of the same pings simply missing: the glitches themselves left no trace
TRACE = 1.02
NO_ENVELOPE = dict(max_speed_mps=np.inf, max_vertical_mps=np.inf, max_accel_mps2=np.inf)


def simulated_variants(duration: float, grade: str, seed: int, fraction: float):
    clean = simulate_mission(duration, grade, seed=seed, dvl_stamp_offset_s=0.37)
    glitched = dvl_glitches(clean, fraction, seed)
    screened = dataclasses.replace(glitched, dvl=screen_implausible(glitched.dvl, clean.config.dvl))
    return f"sim-{grade}-{duration:g}s", clean, screened, glitched, glitched.meta["glitch_rows"].size


def akit_variants(folder: Path, workdir: Path, fraction: float, seed: int):
    clean = load_akit(folder)
    files = akit_files(folder)
    copy = workdir / folder.name
    copy.mkdir()
    for kind in ("IMU", "GT"):
        os.symlink(files[kind], copy / files[kind].name)
    dvl = copy / files["DVL"].name
    dvl.write_bytes(files["DVL"].read_bytes())
    rows = glitch_csv(dvl, fraction, seed)
    fixed = dict(imu_axis_signs=tuple(clean.config.imu_axis_signs), gt_time_offset_s=clean.config.gt_time_offset_s,
                 dvl_time_offset_s=clean.config.dvl_time_offset_s)
    screened = load_akit(copy, **fixed)
    cfg = dataclasses.replace(clean.config, dvl=dataclasses.replace(clean.config.dvl, **NO_ENVELOPE))
    unscreened = load_akit(copy, config=cfg, **fixed)
    return folder.name, clean, screened, unscreened, rows.size


def window_vrmse(mission, method: str, scenario: str, starts, window_s: float):
    run = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
    sol = run_method(run, method, scenario)
    return (float(np.mean([vrmse(sol, mission.gt, s, s + window_s) for s in starts])),
            sol.info.get("completer_fallbacks", {}).get("envelope", 0))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--duration", type=float, default=400.0, help="simulated mission length, s")
    parser.add_argument("--grade", default="navigation", help="IMU grade of the simulated mission")
    parser.add_argument("--seed", type=int, default=1, help="simulator and glitch seed")
    parser.add_argument("--trajectories", nargs="*", default=["Trajectory5"],
                        help="shared A-KIT trajectories (none: simulation only)")
    parser.add_argument("--fraction", type=float, default=0.1, help="fraction of pings glitched")
    parser.add_argument("--scenarios", nargs="+", default=["2-missing", "3-missing"])
    parser.add_argument("--methods", nargs="+", default=["HNTC", "Graph-HN", "Graph-HN-batch"])
    parser.add_argument("--window", type=float, default=30.0, help="outage window, s")
    parser.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    args = parser.parse_args(argv)
    folders = akit_trajectories(args.data, names=args.trajectories) if args.trajectories else []
    warnings.simplefilter("ignore")   # the loaders' and completers' warnings are counted in the table instead
    n_fail = n_lost = 0
    with tempfile.TemporaryDirectory() as tmp:
        sources = [simulated_variants(args.duration, args.grade, args.seed, args.fraction)]
        for folder in folders:
            sources.append(akit_variants(folder, Path(tmp), args.fraction, args.seed))
        print(f"{'mission':16} {'glitched':>8} {'screened':>8} {'scenario':9} {'method':15} {'clean':>7} "
              f"{'screened':>8} {'ratio':>6} {'dropped':>8} {'vs dropped':>10} {'unscreened':>10} {'fallbacks':>9}  "
              "check")
        for name, clean, screened, unscreened, n_glitched in sources:
            lost = clean.dvl.valid.any(axis=1) & ~screened.dvl.valid.any(axis=1)
            n_screened = int(lost.sum())
            dropped = dataclasses.replace(clean, dvl=dataclasses.replace(
                clean.dvl, valid=clean.dvl.valid & ~lost[:, None]))
            starts = window_starts(clean.t0, clean.t1, args.window)
            for scenario in args.scenarios:
                for method in args.methods:
                    t = time.perf_counter()
                    v_clean, _ = window_vrmse(clean, method, scenario, starts, args.window)
                    v_scr, fb_scr = window_vrmse(screened, method, scenario, starts, args.window)
                    v_raw, fb_raw = window_vrmse(unscreened, method, scenario, starts, args.window)
                    v_drop, _ = window_vrmse(dropped, method, scenario, starts, args.window)
                    ratio, vs_drop = v_scr / v_clean, v_scr / v_drop
                    check = "PASS" if ratio <= BOUND else ("LOST-PINGS" if vs_drop <= TRACE else "FAIL")
                    n_fail += check == "FAIL"
                    n_lost += check == "LOST-PINGS"
                    print(f"{name:16} {n_glitched:8d} {n_screened:8d} {scenario:9} {method:15} {v_clean:7.4f} "
                          f"{v_scr:8.4f} {ratio:6.2f} {v_drop:8.4f} {vs_drop:10.2f} {v_raw:10.4f} "
                          f"{fb_scr:4d}/{fb_raw:<4d}  {check} ({time.perf_counter() - t:.0f} s)", flush=True)
    print(f"\nfallbacks: pings the network completer left to the average estimator (screened/unscreened); "
          f"{n_fail} FAIL, {n_lost} above {BOUND}x of clean only by the pings' lost information")
    return 1 if n_fail else 0


if __name__ == "__main__":
    raise SystemExit(main())
