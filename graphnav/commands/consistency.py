"""``graphnav consistency``: velocity, position and heading NEES, window VRMSE and % DT per method (graph methods
with the DVL error states off and on); the check of the reference the NEES is scored against; the check of how
much of the window % DT a stamp offset explains.

The study is :mod:`graphnav.evaluation.consistency_study`; this module reads the arguments, writes
``OUT/consistency.json`` (rows, rewritten as trajectories finish) and ``OUT/table.md``, and prints the table.
"""
from __future__ import annotations

import sys

from graphnav.commands.common import HelpFormatter, add_out_arguments, add_parallel_arguments, methods_help
from graphnav.core.scenarios import SCENARIOS
from graphnav.evaluation.consistency_study import SETTINGS
from graphnav.evaluation.methods import GRAPH_HN, GRAPH_HN_BATCH, GRAPH_TC, METHODS, TC

ROWS_FILE = "consistency.json"
TABLE_FILE = "table.md"


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "consistency", help="velocity / position / heading NEES, window VRMSE and %% DT per method, DVL error "
                            "states off/on; reference and drift checks",
        description="Run each method on every trajectory (the simulated default, or each under --data) with the "
                    "bench's windows and scenarios and print per method: the window VRMSE per scenario and the "
                    "mean velocity NEES over the mission after 60 s with all beams (3 for a consistent "
                    "estimator; the 95 % band of one trajectory beside it), scored against the ground truth "
                    "carried to each epoch by the IMU, also with the GT's own velocity error (--gt-sigma) added, "
                    "and split along the body axes (forward, starboard, down: 1 each when consistent); "
                    "the horizontal position NEES (2 dof) and heading NEES (1 dof) over the mission with their "
                    "bands; the drift in % of the distance travelled (% DT) over the windows (summed drift / "
                    "summed distance) per scenario and at the mission's end. The graph methods run with the DVL "
                    "error states off and on (--settings). Writes OUT/consistency.json and OUT/table.md. "
                    "--reference-check instead compares the recorded DVL with the linearly interpolated and the "
                    "IMU-carried ground truth, deep and at the surface; --drift-check fits the estimate's stamp "
                    "offset against the GT and prints the window % DT with and without that offset. "
                    "Example: graphnav consistency --data ../shared/data/snapir-2022-akit --jobs 2",
        formatter_class=HelpFormatter)
    p.add_argument("--data", metavar="DIR",
                   help="a folder of trajectories in the A-KIT layout or one trajectory folder (or ROS 2 bags "
                        "with ground truth), as `bench --data`; default: the simulated mission")
    p.add_argument("--config", metavar="JSON", help="sensor configuration for every trajectory")
    p.add_argument("--sim-seeds", type=int, default=1, metavar="N",
                   help="without --data: simulated missions (seeds 0..N-1)")
    p.add_argument("--sim-duration", type=float, default=400.0, metavar="S",
                   help="without --data: simulated mission length, s")
    p.add_argument("--methods", nargs="+", default=[GRAPH_TC, GRAPH_HN, GRAPH_HN_BATCH, TC], choices=METHODS, metavar="METHOD",
                   help=f"methods to score ({methods_help()})")
    p.add_argument("--scenario", nargs="+", default=["none", "2-missing", "3-missing"], choices=sorted(SCENARIOS),
                   help="beam-outage scenarios (the mission NEES needs none)")
    p.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS),
                   help="DVL error states off and/or on for the graph methods")
    p.add_argument("--gt-sigma", type=float, nargs=3, default=[0.0, 0.0, 0.0], metavar=("N", "E", "D"),
                   help="the ground truth's velocity error std, m/s NED, added to P for the NEES+GT column")
    p.add_argument("--window-s", type=float, default=30.0, metavar="S", help="outage window length, s")
    p.add_argument("--per-trajectory", action="store_true", help="print the per-trajectory NEES table too")
    p.add_argument("--reference-check", action="store_true",
                   help="only print, per trajectory, the recorded DVL against the GT interpolated linearly and "
                        "carried by the IMU, deeper and shallower than --surface-m (body x / y / z RMS, m/s)")
    p.add_argument("--surface-m", type=float, default=1.0, metavar="M", help="--reference-check: surface depth")
    p.add_argument("--drift-check", action="store_true",
                   help="only print, per trajectory and method (all beams), the stamp offset of the estimate that "
                        "best explains its horizontal position error (error = offset + trend - v_gt * delta, "
                        "least squares) and the window %% DT as scored and with the stamps moved back by delta")
    add_parallel_arguments(p, "trajectories", ", one trajectory each")
    add_out_arguments(p, "out/consistency", "output folder (one that already holds files needs --force)")
    p.set_defaults(func=run)


def check_args(args) -> None:
    from graphnav.core.errors import ConfigError
    if not args.window_s > 0:
        raise ConfigError(f"--window-s {args.window_s}: must be > 0 s")
    if any(s < 0 for s in args.gt_sigma):
        raise ConfigError(f"--gt-sigma {args.gt_sigma}: standard deviations must be >= 0 m/s")
    if args.jobs < 1:
        raise ConfigError(f"--jobs {args.jobs}: give 1 or more")


def run(args) -> int:
    from graphnav.commands.common import StagedOut
    from graphnav.evaluation.bench import find_trajectories
    from graphnav.evaluation.consistency_study import (
        drift_check_table,
        per_trajectory_table,
        reference_check_table,
        run_drift_check,
        run_study,
        study_table,
    )
    from graphnav.io.outputs import write_json
    check_args(args)
    sources = find_trajectories(args.data, sim_seeds=args.sim_seeds, sim_duration_s=args.sim_duration,
                                config_path=args.config)
    if args.reference_check:
        print(reference_check_table(sources, args.surface_m))
        return 0
    if args.drift_check:
        rows = run_drift_check(sources, args.methods, args.window_s, jobs=args.jobs, scheduler=args.scheduler)
        print(drift_check_table(rows))
        return 0
    with StagedOut(args.out, args.force) as staged:
        rows: list[dict] = []

        def finished(new: list[dict]) -> None:
            rows.extend(new)
            write_json(staged.path / ROWS_FILE, rows)
            print(f"{new[0]['trajectory'] if new else '?'} done ({len(rows)} rows)", file=sys.stderr, flush=True)
        run_study(sources, args.methods, args.scenario, args.settings, args.gt_sigma, args.window_s,
                  jobs=args.jobs, scheduler=args.scheduler, finished=finished)
        text = study_table(rows, args.methods, args.scenario, args.settings, args.gt_sigma)
        if args.per_trajectory:
            text += "\n\n" + per_trajectory_table(rows, args.methods, args.settings)
        (staged.path / TABLE_FILE).write_text(text + "\n", encoding="utf-8")
        where = staged.final(staged.path / TABLE_FILE)
    print(text)
    print(f"rows and table: {where}", file=sys.stderr)
    return 0
