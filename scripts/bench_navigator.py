"""Speed and memory of the streaming Navigator (printed tables; nothing is asserted).

1. Sample-by-sample replay of the simulated 400 s mission through each backend: wall and CPU time, real-time
   factor, keyframe update median / p99 (targets: fixed-lag >= 500x real time, update p99 < 10 ms; EKF >=
   1000x).
2. ``state_at`` at the IMU rate (a controller reading the state after every IMU sample; target < 50 us).
3. Long missions with the fixed-lag backend (default 1 h and 21 h, simulated): keyframe update median / p99
   per hour and the process's resident memory as the mission goes on (targets: flat).

Usage: ``.venv/bin/python scripts/bench_navigator.py [--hours 1 21] [--skip-long]``
"""
from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np

from graphnav.estimators.graph import InitialState
from graphnav.estimators.navigator import Navigator
from graphnav.estimators.replay import first_ping_time, replay
from graphnav.sim.simulate import simulate_mission


def rss_mb() -> float:
    with open(f"/proc/{os.getpid()}/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def navigator(mission, backend: str) -> Navigator:
    return Navigator(mission.config, backend, initial=InitialState.from_ground_truth(mission, first_ping_time(mission)))


def replay_speed(mission, backend: str, state_at: bool = False) -> dict:
    events = list(replay(mission))
    nav = navigator(mission, backend)
    adders = {"imu": nav.add_imu, "dvl": nav.add_dvl, "depth": nav.add_depth}
    calls = []
    wall, cpu = time.perf_counter(), time.process_time()
    for kind, t, sample in events:
        adders[kind](t, *sample)
        if state_at and kind == "imu" and nav.n_estimates:
            c0 = time.perf_counter()
            nav.state_at(t)
            calls.append(time.perf_counter() - c0)
    nav.finish()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    upd = 1e3 * np.asarray(nav.info["update_s"])
    out = {"wall_s": wall, "cpu_s": cpu, "rt_wall": mission.duration / wall, "rt_cpu": mission.duration / cpu,
           "median_ms": float(np.median(upd)), "p99_ms": float(np.percentile(upd, 99)),
           "keyframes": len(upd), "samples": len(events)}
    if calls:
        us = 1e6 * np.asarray(calls)
        out.update(state_at_mean_us=float(us.mean()), state_at_p99_us=float(np.percentile(us, 99)))
    return out


def long_mission(hours: float) -> list[dict]:
    t0 = time.perf_counter()
    mission = simulate_mission(hours * 3600.0, seed=0)
    sim_s = time.perf_counter() - t0
    nav = navigator(mission, "fixed-lag")
    adders = {"imu": nav.add_imu, "dvl": nav.add_dvl, "depth": nav.add_depth}
    rows, hour = [], 1
    rss0 = rss_mb()
    start = time.perf_counter()

    def report(t):
        upd = nav.backend.estimator.update_times
        if not upd:
            return
        chunk = 1e3 * np.asarray(upd)
        rows.append({"hour": hour, "median_ms": float(np.median(chunk)), "p99_ms": float(np.percentile(chunk, 99)),
                     "rss_mb": rss_mb(), "rss_growth_mb": rss_mb() - rss0,
                     "rt": (t - mission.t0) / (time.perf_counter() - start)})
        del upd[:]          # the estimator keeps only its lag; this list of timings would grow

    t = mission.t0
    for kind, t, sample in replay(mission):
        adders[kind](t, *sample)
        if t >= hour * 3600.0:
            report(t)
            hour += 1
    report(t)
    nav.finish()
    print(f"  ({hours:g} h mission simulated in {sim_s:.0f} s)")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, nargs="*", default=[1.0, 21.0], help="long-mission lengths, h")
    parser.add_argument("--skip-long", action="store_true", help="only the 400 s replay and state_at")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    mission = simulate_mission(400.0, seed=0)
    print("1. Sample-by-sample replay, simulated 400 s mission (navigation IMU, 40 000 IMU samples)")
    print("| backend | wall s | CPU s | real-time (wall) | real-time (CPU) | update median ms | update p99 ms |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for backend in ("fixed-lag", "isam2", "ekf"):
        r = replay_speed(mission, backend)
        print(f"| {backend} | {r['wall_s']:.2f} | {r['cpu_s']:.2f} | {r['rt_wall']:.0f}x | {r['rt_cpu']:.0f}x | "
              f"{r['median_ms']:.2f} | {r['p99_ms']:.2f} |")
    print("\n2. state_at after every IMU sample (100 Hz controller), fixed-lag backend")
    r = replay_speed(mission, "fixed-lag", state_at=True)
    print(f"state_at: mean {r['state_at_mean_us']:.1f} us, p99 {r['state_at_p99_us']:.1f} us per call")
    if args.skip_long:
        return
    print("\n3. Long missions, fixed-lag backend: per hour of mission")
    print("| mission | hour | update median ms | update p99 ms | RSS MB | RSS growth since start MB | real-time |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for hours in args.hours:
        for row in long_mission(hours):
            print(f"| {hours:g} h | {row['hour']} | {row['median_ms']:.2f} | {row['p99_ms']:.2f} | {row['rss_mb']:.0f} | "
                  f"{row['rss_growth_mb']:+.0f} | {row['rt']:.0f}x |", flush=True)


if __name__ == "__main__":
    main()
