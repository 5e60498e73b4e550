"""The IMU spike test (graphnav.core.screening.imu_spikes, the loaders; ImuSpikeTest, the Navigator's stream) on
clean data, and what it catches.

Part 1, per clean A-KIT trajectory and simulated mission (navigation, tactical, MEMS grades; seeds 0-3, 400 s):
rows the loaders' test and the stream's test refuse (both should be 0), and the margin, the largest departure
from the running median over its limit max(floor, 30 x local noise), per sensor (below 1: nothing fires), with
the largest departure itself.

Part 2, detection on the ten trajectories: spikes added to one axis of every 500th row (cycling the axes, the
sign alternating), one row or a run of five rows, of each size; the fraction of them the loaders' test and the
stream's test refuse, and how many other rows they refuse (skipped with --no-detection: a few minutes).

Part 3, the spans in seconds: a still IMU at 10-400 Hz with a turn onset (yaw rate 0 -> 0.3 rad/s in 1 s), wave roll
starting (0.3 or 0.6 rad/s, period 2 or 5 s), a 1.2 s heading correction (0.2 rad/s) and a 12 m/s^2 half-sine shock
of 80 ms: rows the loaders' test and the stream's refuse (off: the rate is under IMU_SPIKE_MIN_RATE_HZ).

Part 4 (--shocks), a shock against a spike of its size: half-sine shocks of 5-30 m/s^2 lasting 30-100 ms on the
still IMU at 50-400 Hz, on f_x alone and on three axes (1, 0.6, -0.5 of it), each at 8 sampling phases: rows refused
by the loaders / the stream (mean over the phases; a shock is kept when it rises over rows, each within the limit of
the row before); then bursts of 1-3 rows every 0.5 s on one axis, of the same size on every row, of random sizes (1-3x,
random signs) or ramping up and down (RAMPS, a shock's shape): the fraction of bursts not refused whole (loaders,
stream) and other rows refused.

    GRAPHNAV_DATA=/work/shared/data .venv/bin/python experiments/imu_spike_report.py
    .venv/bin/python experiments/imu_spike_report.py --shocks-only
"""
from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np
from scipy.ndimage import median_filter

from graphnav.core.config import SensorConfig
from graphnav.core.imu_timing import imu_rate_hz
from graphnav.core.screening import (
    IMU_SPIKE_NOISE_FACTOR,
    ImuSpikeTest,
    imu_noise_scale,
    imu_spike_floors,
    imu_spike_rows,
    imu_spikes,
)
from graphnav.io.loaders import read_akit
from graphnav.io.paths import akit_trajectories
from graphnav.sim.simulate import simulate_mission

CONFIG = SensorConfig()
ACCEL_SIZES = (2.0, 3.0, 5.0, 6.0, 8.0, 10.0, 100.0)        # m/s^2
GYRO_SIZES = (0.05, 0.08, 0.1, 0.12, 0.15, 0.2, 0.5, 5.0)    # rad/s
SPACING = 500
RAMPS = {1: [1.0], 2: [0.6, 1.0], 3: [0.5, 1.0, 0.5]}        # part 4's bursts that rise and fall over rows


def batch(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(N,) rows the loaders' test refuses (stamps t s, rows x)."""
    return np.any(list(imu_spikes(t, x[:, :3], x[:, 3:], CONFIG).values()), axis=0)


def stream(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(N,) rows the stream's test refuses."""
    test = ImuSpikeTest(imu_spike_floors(CONFIG))
    return np.array([test.check(s, row) is not None for s, row in zip(t.tolist(), x.tolist())])


def margins(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(accel, gyro) largest departure over its limit, and the largest departure (m/s^2, rad/s)."""
    half, block = imu_spike_rows(imu_rate_hz(t))
    median = median_filter(x, size=(2 * half + 1, 1), mode="mirror")
    dev = np.abs(x - median)
    ratio = dev / np.maximum(imu_spike_floors(CONFIG), IMU_SPIKE_NOISE_FACTOR * imu_noise_scale(x, block))
    return (np.array([ratio[:, :3].max(), ratio[:, 3:].max()]), np.array([dev[:, :3].max(), dev[:, 3:].max()]))


def clean_row(name: str, t: np.ndarray, x: np.ndarray) -> None:
    ratio, dev = margins(t, x)
    print(f"{name:22s} {int(batch(t, x).sum()):6d} {int(stream(t, x).sum()):6d}   {ratio[0]:6.3f} {ratio[1]:6.3f}   "
          f"{dev[0]:6.3f} {dev[1]:7.4f}")


def clean_tables(folders) -> dict:
    print("data                   loader stream   margin accel gyro   largest departure m/s^2 rad/s")
    imus = {}
    for folder in folders:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            raw = read_akit(folder)
        imus[folder.name] = raw.imu[:, 0].copy(), raw.imu[:, 1:7].copy()
        clean_row(folder.name, *imus[folder.name])
    for grade in ("navigation", "tactical", "mems"):
        for seed in range(4):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                m = simulate_mission(400.0, imu_grade=grade, seed=seed)
            clean_row(f"sim {grade} seed {seed}", m.imu.t, np.hstack([m.imu.f_b, m.imu.omega_b]))
    return imus


def detection_table(imus: dict) -> None:
    print(f"\nspikes on every {SPACING}th row of the ten (axes cycled): size | rows | fraction refused loaders, "
          "stream | other rows refused loaders, stream")
    for sensor, sizes in (("accel", ACCEL_SIZES), ("gyro", GYRO_SIZES)):
        for size in sizes:
            for run in (1, 5):
                hit_b = hit_s = total = other_b = other_s = 0
                for t, x in imus.values():
                    y = x.copy()
                    at = np.arange(1000, len(y) - 1000, SPACING)
                    axes = (np.arange(at.size) % 3) + (0 if sensor == "accel" else 3)
                    sign = np.where(np.arange(at.size) % 2, -1.0, 1.0)
                    rows = (at[:, None] + np.arange(run)).ravel()
                    y[rows, np.repeat(axes, run)] += np.repeat(sign * size, run)
                    injected = np.zeros(len(y), bool)
                    injected[rows] = True
                    b, s = batch(t, y), stream(t, y)
                    hit_b += int(b[injected].sum())
                    hit_s += int(s[injected].sum())
                    other_b += int(b[~injected].sum())
                    other_s += int(s[~injected].sum())
                    total += int(injected.sum())
                unit = "m/s^2" if sensor == "accel" else "rad/s"
                print(f"{sensor} {size:g} {unit} | {run} | {hit_b / total:.3f} {hit_s / total:.3f} | "
                      f"{other_b} {other_s}")


def motion_cases(rate_hz: float) -> dict:
    """{name: (stamps s, rows)} of part 3 at ``rate_hz``: 120 s of a still IMU with one motion from t = 60 s."""
    t, x = still_imu(rate_hz, 120.0)
    cases = {}
    for name, axis, add in (
            ("turn onset 0.3 rad/s in 1 s", 5, np.clip(t - 60.0, 0.0, 1.0) * 0.3),
            ("wave roll 0.3 rad/s, 5 s", 3, np.where(t > 60, 0.3 * np.sin(2 * np.pi * (t - 60) / 5.0), 0.0)),
            ("wave roll 0.6 rad/s, 5 s", 3, np.where(t > 60, 0.6 * np.sin(2 * np.pi * (t - 60) / 5.0), 0.0)),
            ("wave roll 0.6 rad/s, 2 s", 3, np.where(t > 60, 0.6 * np.sin(2 * np.pi * (t - 60) / 2.0), 0.0)),
            ("heading 0.2 rad/s 1.2 s", 5, np.interp(t, [60, 60.2, 61.0, 61.2], [0, 0.2, 0.2, 0], left=0, right=0)),
            ("shock 12 m/s^2 80 ms", 0, np.where((t >= 60) & (t < 60.08), -12 * np.sin(np.pi * (t - 60) / 0.08), 0))):
        y = x.copy()
        y[:, axis] += add
        cases[name] = (t, y)
    return cases


def rates_table() -> None:
    print("\nmotion at other rates: case | rate Hz | rows refused loaders, stream (both on the same rows?)")
    for rate in (10.0, 20.0, 40.0, 50.0, 100.0, 200.0, 400.0):
        for name, (t, y) in motion_cases(rate).items():
            if imu_spike_rows(rate) is None:
                print(f"{name:28s} | {rate:5g} | off")
                continue
            b, s = batch(t, y), stream(t, y)
            print(f"{name:28s} | {rate:5g} | {int(b.sum())} {int(s.sum())} ({bool(np.array_equal(b, s))})")


def still_imu(rate_hz: float, duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(stamps s, rows) of a still IMU at ``rate_hz`` (white noise 0.01 m/s^2, 2e-4 rad/s), as part 3's."""
    rng = np.random.default_rng(0)
    t = np.arange(int(rate_hz * duration_s)) / rate_hz
    return t, np.hstack([[0.0, 0.0, -9.81] + rng.normal(0, 0.01, (t.size, 3)), rng.normal(0, 2e-4, (t.size, 3))])


def shocks_table(phases: int = 8) -> None:
    print("\nshocks: amplitude m/s^2 | duration ms | rate Hz | rows in it | rows refused loaders / stream, f_x alone; "
          "three axes")
    for rate in (50.0, 100.0, 200.0, 400.0):
        t, x = still_imu(rate, 20.0)
        for dur in (0.03, 0.05, 0.08, 0.1):
            for amp in (5.0, 8.0, 12.0, 20.0, 30.0):
                cells = []
                for axes in ((1.0, 0.0, 0.0), (1.0, 0.6, -0.5)):
                    refused = np.zeros(2)
                    for p in range(phases):
                        t0 = 10.0 + p / (phases * rate)
                        pulse = np.where((t >= t0) & (t < t0 + dur), amp * np.sin(np.pi * (t - t0) / dur), 0.0)
                        y = x - np.outer(pulse, axes + (0.0,) * 3)
                        refused += [batch(t, y).sum(), stream(t, y).sum()]
                    cells.append(f"{refused[0] / phases:4.1f} / {refused[1] / phases:4.1f}")
                print(f"{amp:4g} | {dur * 1e3:3.0f} | {rate:3.0f} | {dur * rate:4.1f} | {cells[0]}; {cells[1]}")


def bursts_table() -> None:
    print("\nbursts: rate Hz | kind | rows | size on axis | not refused whole loaders, stream | other rows refused")
    rng = np.random.default_rng(1)
    for rate in (50.0, 100.0, 200.0, 400.0):
        t, x = still_imu(rate, 60.0)
        at = np.arange(int(2 * rate), len(t) - int(2 * rate), int(0.5 * rate))
        for kind in ("same", "random", "ramp"):
            for rows in (1, 2, 3):
                for size, axis in ((5.5, 0), (6.0, 0), (10.0, 1), (100.0, 2), (0.12, 3), (0.5, 5), (5.0, 4)):
                    y, hit = x.copy(), np.zeros(len(t), bool)
                    for k, a in enumerate(at):
                        sizes = {"same": np.full(rows, size), "random": size * rng.uniform(1.0, 3.0, rows),
                                 "ramp": size * np.array(RAMPS[rows])}[kind]
                        y[a:a + rows, axis] += sizes * (rng.choice([-1.0, 1.0], rows) if kind == "random" else
                                                        (-1.0) ** k)
                        hit[a:a + rows] = True
                    b, s = batch(t, y), stream(t, y)
                    whole = [np.mean([not m[a:a + rows].all() for a in at]) for m in (b, s)]
                    print(f"{rate:3.0f} | {kind} | {rows} | {size:g} on {axis} | {whole[0]:.3f} {whole[1]:.3f} | "
                          f"{int(b[~hit].sum())} {int(s[~hit].sum())}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--no-detection", action="store_true", help="skip part 2 (the detection table)")
    p.add_argument("--shocks", action="store_true", help="add part 4 (shocks against spikes and bursts)")
    p.add_argument("--shocks-only", action="store_true", help="part 4 alone (no data needed)")
    args = p.parse_args(argv)
    if not args.shocks_only:
        imus = clean_tables(akit_trajectories(args.data))
        if not args.no_detection:
            detection_table(imus)
        rates_table()
    if args.shocks or args.shocks_only:
        shocks_table()
        bursts_table()
    return 0


if __name__ == "__main__":
    sys.exit(main())
