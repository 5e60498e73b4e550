"""``graphnav online``: run a mission through the incremental graph as it would run on a vehicle.

Every keyframe estimate (the filtered state and its marginal velocity covariance) is appended to
``OUT/online.csv`` and flushed as soon as it is produced, so a crash or Ctrl-C keeps everything computed
so far. ``--resume`` continues an interrupted run: the estimator is deterministic, so it replays the
epochs already in the file without writing them (fast, no pacing) and appends from the first new epoch.
"""
from __future__ import annotations

import time
from pathlib import Path

from .smooth import HelpFormatter, accuracy_summary, add_mission_arguments, make_plots, mission_from_args


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "online", help="stream a mission through ISAM2 (or a fixed-lag smoother); per-epoch CSV flushed live",
        description="Stream a mission through the incremental factor graph (ISAM2, or gtsam's fixed-lag "
                    "smoother with --lag) one keyframe at a time, as on a vehicle. Each estimate is "
                    "appended to OUT/online.csv and flushed at once; Ctrl-C keeps the file; --resume "
                    "continues from its last epoch. A final summary goes to OUT/summary.json.",
        formatter_class=HelpFormatter)
    add_mission_arguments(p)
    p.add_argument("--out", default="out/online", metavar="DIR", help="output folder")
    p.add_argument("--method", default="Graph-HN", choices=("Graph-HN", "Graph-TC"),
                   help="Graph-HN adds the completer's regressed beams as weak factors; Graph-TC uses "
                        "measured beams only")
    p.add_argument("--lag", type=float, default=None, metavar="S",
                   help="use a fixed-lag smoother keeping S seconds (bounded memory) instead of ISAM2 "
                        "over the whole mission")
    p.add_argument("--realtime", action="store_true",
                   help="pace the run to the mission clock (sleep until each epoch's time has come)")
    p.add_argument("--speed", type=float, default=1.0, metavar="X",
                   help="with --realtime: play X times faster than real time")
    p.add_argument("--resume", action="store_true",
                   help="continue from the last epoch in OUT/online.csv instead of starting anew")
    p.add_argument("--fsync", action="store_true",
                   help="also force each epoch to disk (survives power loss; slower)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots at the end")
    p.set_defaults(func=run)


def epoch_fields(est) -> dict:
    """The CSV fields of one :class:`graphnav.graph.EpochEstimate`: t, p_n, v_n, C_b_n, cov_v_n and the
    accelerometer and gyro biases."""
    bias = est.bias
    return {"t": est.t, "p_n": est.p_n, "v_n": est.v_n, "C_b_n": est.C_b_n, "cov_v_n": est.cov_v_n,
            "bias_acc": None if bias is None else bias.accelerometer(),
            "bias_gyro": None if bias is None else bias.gyroscope()}


class EpochSink:
    """Callback for the online estimator: skip replayed epochs, pace, write+flush, advance the progress bar."""

    def __init__(self, writer, bar, skip_until: float | None, realtime: bool, speed: float):
        self.writer, self.bar = writer, bar
        self.skip_until = skip_until
        self.realtime, self.speed = realtime, speed
        self.first_t: float | None = None
        self.wall0: float | None = None
        self.n_new = 0
        self.n_replayed = 0

    def __call__(self, est) -> None:
        f = epoch_fields(est)
        t = float(f["t"])
        self.bar.update(1)
        if self.skip_until is not None and t <= self.skip_until + 1e-9:
            self.n_replayed += 1
            return
        if self.realtime:
            if self.first_t is None:
                self.first_t, self.wall0 = t, time.perf_counter()
            ahead = (t - self.first_t) / self.speed - (time.perf_counter() - self.wall0)
            if ahead > 0:
                time.sleep(ahead)
        self.writer.write(**f)
        self.n_new += 1


def update_timing(update_s) -> dict:
    """Median, p99 and max of the per-keyframe solver times, ms."""
    import numpy as np
    if not update_s:
        return {}
    ms = 1e3 * np.asarray(update_s, float)
    return {"keyframes": int(ms.size), "median_ms": float(np.median(ms)),
            "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max())}


def run(args) -> int:
    from tqdm import tqdm

    from graphnav.methods import run_method
    from graphnav.outputs import EpochCsvWriter, read_trajectory_csv, write_json

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    mission, outages = mission_from_args(args)
    csv_path = out / "online.csv"
    options = None if args.lag is None else {"lag_s": args.lag}
    with EpochCsvWriter(csv_path, resume=args.resume, fsync=args.fsync) as writer:
        resumed_from = writer.last_t
        if resumed_from is not None:
            print(f"resuming after t = {resumed_from:.3f} s ({writer.n_written} epochs already in {csv_path}); "
                  "replaying the earlier epochs without writing them")
        bar = tqdm(total=len(mission.dvl.t), desc=f"{args.method}{'' if args.lag is None else ' lag'}",
                   unit="epoch", disable=args.no_progress, dynamic_ncols=True)
        sink = EpochSink(writer, bar, resumed_from, args.realtime, args.speed)
        start = time.perf_counter()
        try:
            sol = run_method(mission, args.method, args.scenario, options=options, callback=sink,
                             mode="online" if args.lag is None else "fixed-lag")
        finally:
            bar.close()
        wall = time.perf_counter() - start
        n_total = writer.n_written
    # The summary covers the whole file (earlier runs included), read back from what was written.
    written = read_trajectory_csv(csv_path, method=args.method)
    summary = {
        "method": args.method, "mode": "ISAM2" if args.lag is None else f"fixed-lag {args.lag:g} s",
        "mission": mission.name, "scenario": args.scenario, "imu_grade": args.imu_grade,
        "completer": sol.info.get("completer"), "epochs": int(n_total), "epochs_this_run": sink.n_new,
        "epochs_replayed": sink.n_replayed, "resumed_after_s": resumed_from,
        "duration_s": mission.duration, "runtime_s": wall,
        "realtime_factor": mission.duration / wall if wall > 0 else float("nan"),
        "update_timing": update_timing(sol.info.get("update_s")),
        "health": sol.info.get("health"),
        "accuracy": accuracy_summary(written, mission, outages) if len(written.t) else {},
        "files": {"online_csv": str(csv_path)},
    }
    if not args.no_plots and len(written.t):
        plots = make_plots(out, mission, [written], outages, f"online {summary['mode']}, {args.scenario}")
        summary["files"].update({Path(p).stem: p for p in plots})
    summary["files"]["summary_json"] = str(out / "summary.json")
    write_json(out / "summary.json", summary)
    from .smooth import print_summary
    print_summary(summary)
    return 0
