"""``graphnav info PATH``: what a file or folder holds and whether graphnav will use it (:mod:`graphnav.io.inspect`)."""
from __future__ import annotations

import contextlib
import json
import sys

from graphnav.commands.common import HelpFormatter


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "info", help="describe a log: instruments, streams read/used/refused and why, rates, span, speed, depth",
        description="Describe what PATH holds and whether graphnav will use it: an A-KIT TrajectoryN folder, a CSV "
                    "log with the column map of --config, a ROS 1 or ROS 2 bag, a PD0 DVL file or a JSON-lines "
                    "stream file. "
                    "Shows the instrument(s), the DVL frame, each stream's samples read / used / refused with the "
                    "reasons, rates, time span, DVL speed and beams per ping, depth range, and the loaders' notes "
                    "and warnings. A file graphnav cannot use is described with the reason. Exit code 0 when "
                    "described, 2 when PATH is not something graphnav reads.",
        formatter_class=HelpFormatter)
    p.add_argument("path", metavar="PATH", help="file or folder to describe")
    p.add_argument("--config", metavar="JSON",
                   help="sensor configuration (the column map of a CSV log; the IMU that goes with a PD0 file; "
                        "a bag's bag_topics, e.g. the fields of a vendor's own DVL message)")
    p.add_argument("--topic", action="append", metavar="STREAM=TOPIC",
                   help="bags: read STREAM (imu, dvl, depth, heading, gt) from TOPIC (repeatable)")
    p.add_argument("--json", action="store_true", help="print the description as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    from graphnav.calibration.preparation import prepare
    from graphnav.io.bags import parse_topics
    from graphnav.io.inspect import describe, format_description
    # readers that print progress (dolfyn's "Reading file ...") must not mix into the description
    with contextlib.redirect_stdout(sys.stderr):
        desc = describe(args.path, args.config, parse_topics(args.topic), prepare=prepare)
    print(json.dumps(desc, indent=2) if args.json else format_description(desc))
    return 0 if desc["format"] is not None else 2
