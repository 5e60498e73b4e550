"""``graphnav evaluate``: APE/RPE (through evo) beside VRMSE and NEES of a written trajectory."""
from __future__ import annotations

from pathlib import Path

from graphnav.commands.common import HelpFormatter


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "evaluate", help="score a trajectory CSV/TUM against a reference: APE, RPE (evo), VRMSE, NEES, %% DT",
        description="Score a trajectory written by `graphnav smooth`/`online` (trajectory.csv, or a TUM file) "
                    "against a reference: a TUM file, a trajectory CSV, or a mission path as --data takes it "
                    "(A-KIT folder, ROS 2 bag with a reference nav_msgs/Odometry topic, CSV log with a gt "
                    "column map) whose ground truth is used. APE and RPE come from evo's library, VRMSE "
                    "from graphnav.evaluation.metrics; the velocity NEES is the benchmark's (after 60 s, against "
                    "the reference carried to the estimate's epochs by the mission's IMU), also split along the body "
                    "axes (forward, starboard, down: 1 each when consistent); epochs with an empty sigma are "
                    "left out and counted, and an epoch without a finite estimate (lost track) leaves that NEES "
                    "not finite, never a number from part of the run (APE and RPE are then not computed, with the "
                    "count); horizontal position NEES (2 "
                    "dof) and heading NEES (1 dof) when the estimate carries those sigmas; drift in % of the "
                    "distance travelled (horizontal error at the end / distance the reference travelled). "
                    "Positions on both sides: NED from the sea surface "
                    "above the first fix, down = absolute depth. Needs graphnav[eval].",
        formatter_class=HelpFormatter)
    p.add_argument("trajectory", help="trajectory.csv (or .tum) to score")
    p.add_argument("--ref", required=True, metavar="PATH", help="reference: TUM/CSV file or mission data path")
    p.add_argument("--config", metavar="JSON", help="sensor configuration for a mission reference")
    p.add_argument("--topic", action="append", metavar="STREAM=TOPIC",
                   help="bag reference: read STREAM from TOPIC (e.g. gt=/nav/odometry)")
    p.add_argument("--align", action="store_true",
                   help="Umeyama SE(3) alignment before APE (as evo_ape --align), for a reference in another frame")
    p.add_argument("--rpe-delta", type=float, default=10.0, metavar="D", help="RPE pose distance")
    p.add_argument("--rpe-unit", choices=("m", "frames"), default="m", help="unit of --rpe-delta")
    p.add_argument("--json", metavar="FILE", help="also write the results as JSON")
    p.add_argument("--plots", metavar="DIR",
                   help="also write DIR/position_error.png: north, east and horizontal position error against the "
                        "reference with the estimate's +-2 sigma (when it carries position sigmas)")
    p.set_defaults(func=run)


def run(args) -> int:
    from graphnav.commands.common import check_out_file
    from graphnav.evaluation.score import (
        evaluate,
        format_report,
        load_reference_mission,
        load_trajectory,
    )
    from graphnav.io.bags import parse_topics
    check_out_file(args.json, force=True, option="--json")
    if args.plots:
        check_out_file(Path(args.plots) / "position_error.png", force=True, option="--plots")
    est = load_trajectory(args.trajectory)
    ref, mission = load_reference_mission(args.ref, args.config, parse_topics(args.topic) or None)
    result = evaluate(est, ref, mission=mission, align=args.align, rpe_delta=args.rpe_delta,
                      rpe_unit=args.rpe_unit)
    result.update({"trajectory": str(args.trajectory), "reference": str(args.ref)})
    from graphnav.calibration.preparation import reference_notes
    if mission is not None:     # said beside the score: it is taken where or when the reference may not be
        result.update(reference_notes(mission))
    print(format_report(result, Path(args.trajectory).name, str(args.ref)))
    if args.json:
        from graphnav.io.outputs import write_json
        write_json(args.json, result)
    if args.plots:
        from graphnav.evaluation.plots import plot_position_error
        path = plot_position_error(ref, [est], [], Path(args.plots) / "position_error.png",
                                   f"{Path(args.trajectory).name} vs {Path(args.ref).name}: position error")
        print(f"  plot: {path}")
    return 0
