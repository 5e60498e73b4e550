"""``graphnav calibrate``: estimate DVL lever arm, time offsets, DVL mounting and check the IMU axes."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from graphnav.core.errors import DataError, GraphnavError


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate", help="estimate DVL lever arm, time offsets, DVL yaw/scale and check the IMU axes",
        description="Calibrate the sensors of a mission (a real A-KIT trajectory folder, or the simulated "
                    "default). With ground truth: the IMU axes are checked against the GT attitude and "
                    "roll/pitch, the IMU-to-GT offset is found from attitude increments, and the DVL "
                    "velocity is regressed on the GT body velocity (lever arm, DVL time offset, mounting "
                    "yaw, scale factor, bias). Without ground truth (--mode graph): the lever arm is a "
                    "Point3 variable of a factor graph and the DVL offset minimises the graph's negative "
                    "log-likelihood. Prints the estimates with 1-sigma uncertainties and writes the "
                    "calibrated configuration, which every command accepts as --config. A mission's sigmas say how "
                    "well its data fix its own values; some quantities differ more between missions (on the Snapir "
                    "AUV the DVL mounting yaw, its scale factor and the accelerometer's position, by 2.1-4.3 times). "
                    "Give several missions of one vehicle to calibrate each and combine them (random effects): the "
                    "written configuration holds the combined values, and the report where the next mission's "
                    "value is expected.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--data", metavar="FOLDER", nargs="+", default=None,
                   help="recorded mission(s) (A-KIT trajectory folder, bag, PD0 log, ...) or folder(s) of missions; "
                        "several missions: one vehicle's, calibrated each and combined; default: simulated mission")
    p.add_argument("--config", metavar="JSON", default=None,
                   help="configuration to start from (its offsets, lever arm and axis signs are applied "
                        "when loading)")
    p.add_argument("--seed", type=int, default=0, help="simulator seed when --data is not given")
    p.add_argument("--duration", type=float, default=400.0, metavar="S",
                   help="simulated mission length when --data is not given, s")
    p.add_argument("--mode", choices=["auto", "gt", "graph"], default="auto",
                   help="gt: regression against ground truth; graph: factor graph without GT; auto: gt when "
                        "the mission has GT")
    p.add_argument("--min-depth", type=float, default=2.0, metavar="M",
                   help="gt mode: leave out DVL pings shallower than this (surface waves), m")
    p.add_argument("--no-noise", action="store_true",
                   help="skip the noise identification (graphnav.calibration.noise): the IMU's white densities from "
                        "its 1-s increments against the GT (without GT: by the Allan deviation), written times the "
                        "factor the estimators needed on the shared Snapir data (ESTIMATOR_DENSITY_FACTOR); the beam "
                        "noise from the all-beam batch smoother's residuals; the GT's velocity error (printed only)")
    p.add_argument("--out", metavar="JSON", default="calibrated_config.json",
                   help="where to write the calibrated SensorConfig (an existing file is kept unless --force); of "
                        "several missions: the combined one, without each mission's own time offsets, latitude, "
                        "gravity and surface pressure")
    p.add_argument("--report", metavar="JSON", default=None,
                   help="also write every estimate with its sigma and the axis check as JSON")
    p.add_argument("--force", action="store_true", help="replace an existing --out / --report file")
    p.set_defaults(func=run)


def run(args) -> int:
    from graphnav.commands.common import check_out_file
    from graphnav.io.outputs import write_json
    check_out_file(args.out, force=args.force)
    check_out_file(args.report, force=args.force, option="--report")
    folders = mission_folders(args.data, args.config)
    if len(folders) == 1:
        _, result = calibrate_one(args, folders[0])
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        result.config.save(args.out)
        print(f"calibrated configuration written to {args.out} (use it with --config)")
        if args.report:
            write_json(args.report, result.to_dict())
            print(f"report written to {args.report}")
        return 0 if result.axis_check.ok else 3
    return run_several(args, folders)


def run_several(args, folders: list[str]) -> int:
    """Calibrate each of several missions and combine them; a mission that cannot be read, calibrated or combined
    with the first one is named and left out (exit 1), the others kept."""
    from graphnav.calibration.combine import combine, incompatibility
    from graphnav.io.outputs import write_json
    done, failed = [], []
    for folder in folders:
        try:
            name, result = calibrate_one(args, folder)
            problem = incompatibility(done[0][2], result) if done else None
            if problem is not None:
                raise DataError(f"cannot be combined with {done[0][1]}: {problem}", folder)
        except GraphnavError as exc:
            print(f"mission {folder}: not calibrated: {exc}", file=sys.stderr)
            failed.append(folder)
            continue
        done.append((folder, name, result))
    if not done:
        raise DataError(f"none of the {len(folders)} missions could be calibrated", ", ".join(map(str, failed)))
    # a mission is named by its name, or by its path where two share one (TrajectoryN of different folders)
    names = [name if [n for _, n, _ in done].count(name) == 1 else str(folder) for folder, name, _ in done]
    combined = combine([result for *_, result in done], names)
    if len(done) == 1:
        print(f"only {names[0]} could be calibrated: nothing to combine")
    else:
        print(combined.report())
    write_json(args.out, combined.config_dict())
    print(f"combined configuration of {len(done)} missions written to {args.out} (use it with --config; without "
          "each mission's own clocks and place)")
    if args.report:
        write_json(args.report, {**combined.to_dict(), "not_calibrated": [str(f) for f in failed]})
        print(f"report written to {args.report}")
    if failed:
        print(f"{len(failed)} of {len(folders)} missions not calibrated: {', '.join(map(str, failed))}",
              file=sys.stderr)
        return 1
    return 0 if all(r.axis_check.ok for *_, r in done) else 3


def mission_folders(data: list[str] | None, config: str | None) -> list[str | None]:
    """The missions of ``--data``: each item one mission, or a folder of missions (as ``graphnav smooth`` and
    ``bench`` find them) standing for each of them, each mission once; ``[None]`` (the simulated mission) without
    ``--data``."""
    if not data:
        return [None]
    from graphnav.evaluation.bench import mission_collection
    folders, seen = [], set()
    for item in data:
        sources = mission_collection(item, config)
        for folder in [item] if sources is None else [str(source.folder) for source in sources]:
            if Path(folder).resolve() in seen:      # counted twice, it would weigh twice and hide the spread
                print(f"mission {folder}: given twice, counted once", file=sys.stderr)
                continue
            seen.add(Path(folder).resolve())
            folders.append(folder)
    return folders


def calibrate_one(args, folder):
    """(mission name, CalibrationResult) of one ``--data`` folder (None: the simulated mission), printed."""
    from graphnav.calibration.calibrate import calibrate
    from graphnav.commands.common import recorded_mission
    mission = recorded_mission(argparse.Namespace(**{**vars(args), "data": folder}))
    kwargs = {"min_depth_m": args.min_depth} if args.mode != "graph" and mission.gt is not None else {}
    if not args.no_noise:   # the noise run is Graph-HN-batch on the data as recorded: the registry's completer
        from graphnav.evaluation.methods import network_completer
        kwargs["completer"] = network_completer("none", mission.config.dvl.beam_noise_std)[0]
    result = calibrate(mission, args.mode, identify_noise=not args.no_noise, **kwargs)
    print(f"mission: {mission.name} ({mission.duration:.0f} s)")
    print(result.report())
    return mission.name, result
