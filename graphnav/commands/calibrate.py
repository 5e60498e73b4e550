"""``graphnav calibrate``: estimate DVL lever arm, time offsets, DVL mounting and check the IMU axes."""
from __future__ import annotations

import argparse
from pathlib import Path


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
                    "calibrated configuration, which every command accepts as --config.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--data", metavar="FOLDER", default=None,
                   help="A-KIT trajectory folder (IMU_*.csv, DVL_*.csv, GT_*.csv); default: simulated mission")
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
                   help="where to write the calibrated SensorConfig (an existing file is kept unless --force)")
    p.add_argument("--report", metavar="JSON", default=None,
                   help="also write every estimate with its sigma and the axis check as JSON")
    p.add_argument("--force", action="store_true", help="replace an existing --out / --report file")
    p.set_defaults(func=run)


def run(args) -> int:
    from graphnav.calibration.calibrate import calibrate
    from graphnav.commands.common import check_out_file, recorded_mission
    from graphnav.io.outputs import write_json
    check_out_file(args.out, force=args.force)
    check_out_file(args.report, force=args.force, option="--report")
    mission = recorded_mission(args)
    kwargs = {"min_depth_m": args.min_depth} if args.mode != "graph" and mission.gt is not None else {}
    if not args.no_noise:   # the noise run is Graph-HN-batch on the data as recorded: the registry's completer
        from graphnav.evaluation.methods import network_completer
        kwargs["completer"] = network_completer("none", mission.config.dvl.beam_noise_std)[0]
    result = calibrate(mission, args.mode, identify_noise=not args.no_noise, **kwargs)
    print(f"mission: {mission.name} ({mission.duration:.0f} s)")
    print(result.report())
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    result.config.save(args.out)
    print(f"calibrated configuration written to {args.out} (use it with --config)")
    if args.report:
        write_json(args.report, result.to_dict())
        print(f"report written to {args.report}")
    return 0 if result.axis_check.ok else 3
