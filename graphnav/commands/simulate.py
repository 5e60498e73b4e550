"""``graphnav simulate``: make the embedded default mission, print a summary, optionally write it as CSVs."""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

from graphnav.core.config import DVL_ERROR_SOURCES, IMU_GRADES
from graphnav.core.errors import ConfigError
from graphnav.core.earth import EarthModel


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "simulate", help="simulate an AUV survey mission (IMU, DVL beams, depth, exact ground truth)",
        description="Simulate a realistic AUV survey (descent, lawnmower legs with turns, depth and speed "
                    "changes) with a 100 Hz IMU of the chosen grade, a 1 Hz four-beam DVL with lever arm "
                    "and error model, a 10 Hz depth sensor and exact ground truth. Prints a summary; with "
                    "--out writes the mission in the published A-KIT CSV layout (OUT/TrajectoryN/"
                    "{IMU,DVL,GT}_trajectoryN.csv, IMU in FRD, with the mission's configuration and beams "
                    "beside them, which graphnav smooth/online --data read it back with) plus a PNG of track, "
                    "depth and speed.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--duration", type=float, default=400.0, help="mission length, s (up to 86400)")
    parser.add_argument("--imu-grade", choices=sorted(IMU_GRADES), default="navigation",
                        help="IMU error model (navigation: FOG INS like the Phins)")
    parser.add_argument("--seed", type=int, default=0, help="seed of trajectory and sensor errors")
    parser.add_argument("--dropout", action="store_true", help="random per-beam bottom-lock dropouts")
    parser.add_argument("--noiseless", action="store_true", help="exact sensors (no IMU/DVL/depth errors)")
    parser.add_argument("--gt-rate", type=float, default=10.0, help="ground-truth rate, Hz")
    parser.add_argument("--start-ne", type=float, nargs=2, default=(0.0, 0.0), metavar=("NORTH", "EAST"),
                        help="start this far from the NED origin, m (gravity tilts 1.5e-6 m/s^2 per metre)")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder to write the CSVs and the PNG into (appears only once complete)")
    parser.add_argument("--force", action="store_true",
                        help="replace an --out folder that already holds files, or an existing --stream file")
    parser.add_argument("--number", type=int, default=1, help="N of the written TrajectoryN folder")
    parser.add_argument("--stream", metavar="FILE", default=None,
                        help="write the measurements (no ground truth) as time-ordered JSON lines to FILE ('-' = "
                             "standard output; the summary then goes to standard error), the input of "
                             "`graphnav online --stream`")
    parser.add_argument("--dvl-output", choices=("beams", "velocity"), default="beams",
                        help="what the simulated DVL reports: its four beams, or (velocity) only its own DVL-frame "
                             "velocity, as a velocity-only DVL does (with --stream: dvl_velocity records)")
    parser.add_argument("--surface-every", type=float, default=None, metavar="SECONDS",
                        help="surface every SECONDS for GNSS fixes (1 Hz, sigma 2-3 m; with --stream: fix "
                             "records); default: never")
    parser.add_argument("--surface-stay", type=float, default=30.0, metavar="SECONDS",
                        help="time at the surface of each --surface-every surfacing, s")
    parser.add_argument("--pivot", type=float, default=0.0, metavar="M",
                        help="the hull's pivot point ahead of the IMU, m: in turns the vehicle slides sideways at "
                             "the IMU by -M times the turn's yaw rate, as a real hull does (the A-KIT Snapir: about 3.6; "
                             "0: no sideslip in turns)")
    parser.add_argument("--pitch-pivot", type=float, default=0.0, metavar="M",
                        help="the hull's pitch pivot ahead of the IMU, m: the vehicle heaves at the IMU by M times "
                             "its pitch rate, as a real hull does (the A-KIT Snapir: about 3; 0: no heave in pitch)")
    parser.add_argument("--dvl-errors", choices=DVL_ERROR_SOURCES, default="spec",
                        help="the beams' bias and scale factor: the configuration's (spec: the paper's 0.01 m/s "
                             "on every beam and 0.7 %% on every axis, the same in every seed), or drawn per seed "
                             "from zero-mean normals with those sigmas, the estimators' priors (drawn: for Monte "
                             "Carlo consistency checks); the written configuration keeps the given values")
    parser.set_defaults(func=run)


def summarize(mission) -> dict:
    """Distance (m), depth range (m), speed range (m/s), max |yaw rate| (rad/s) of a mission's GT."""
    gt = mission.gt
    speed = np.linalg.norm(gt.v_n, axis=1)
    depth = EarthModel.from_config(mission.config).depth_of(gt.p_n)
    traj = mission.meta.get("trajectory")
    if traj is not None:
        yaw_rate = traj.state(gt.t).omega_nb_b
    else:
        yaw_rate = mission.imu.omega_b
    return {
        "duration_s": mission.duration,
        "distance_m": float(np.sum(np.linalg.norm(np.diff(gt.p_n, axis=0), axis=1))),
        # the pressure depth (the tangent plane's down is larger far from the origin: the Earth curves away)
        "depth_min_m": float(depth.min()), "depth_max_m": float(depth.max()),
        "speed_min_mps": float(speed.min()), "speed_max_mps": float(speed.max()),
        "max_yaw_rate_radps": float(np.abs(yaw_rate[:, 2]).max()),
        "dvl_pings": len(mission.dvl.t), "dvl_pings_lt3_beams": int(np.sum(mission.dvl.n_valid < 3)),
    }


def plot(mission, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gt = mission.gt
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    axes[0].plot(gt.p_n[:, 1], gt.p_n[:, 0])
    axes[0].plot(gt.p_n[0, 1], gt.p_n[0, 0], "go", label="start")
    axes[0].set(xlabel="East [m]", ylabel="North [m]", title="track", aspect="equal")
    axes[0].legend()
    axes[1].plot(gt.t, EarthModel.from_config(mission.config).depth_of(gt.p_n))
    axes[1].invert_yaxis()
    axes[1].set(xlabel="time [s]", ylabel="depth [m]", title="depth")
    axes[2].plot(gt.t, np.linalg.norm(gt.v_n, axis=1))
    axes[2].set(xlabel="time [s]", ylabel="speed [m/s]", title="speed")
    fig.suptitle(mission.name)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def run(args) -> int:
    from graphnav.commands.common import StagedOut, check_out, check_out_file
    from graphnav.io.export import write_akit
    from graphnav.sim.simulate import simulate_mission

    if args.dvl_output == "velocity" and args.out is not None:
        raise ConfigError("--dvl-output velocity goes with --stream only: the A-KIT CSV layout of --out has no "
                          "DVL-frame velocity")
    if args.surface_every is not None and args.out is not None:
        raise ConfigError("--surface-every goes with --stream only: the A-KIT CSV layout of --out has no "
                          "position fixes")
    surfacing = None
    if args.surface_every is not None:
        from graphnav.sim.simulate import SurfacingProfile
        surfacing = SurfacingProfile(interval_s=args.surface_every, stay_s=args.surface_stay)
    if args.out is not None:
        check_out(args.out, force=args.force)
    if args.stream not in (None, "-"):
        check_out_file(args.stream, force=args.force, option="--stream")
    mission = simulate_mission(args.duration, args.imu_grade, args.seed, dropout=args.dropout,
                               gt_rate_hz=args.gt_rate, noiseless=args.noiseless, dvl_output=args.dvl_output,
                               start_ne_m=args.start_ne, surfacing=surfacing, pivot_m=args.pivot,
                               pitch_pivot_m=args.pitch_pivot, dvl_errors=args.dvl_errors)
    log = sys.stderr if args.stream == "-" else sys.stdout
    if args.stream is not None:
        from graphnav.estimators.replay import mission_records
        from graphnav.io.streamio import write_records
        if args.stream == "-":
            write_records(mission_records(mission), sys.stdout)
        else:
            import os
            tmp = Path(args.stream).with_name(f".{Path(args.stream).name}.partial-{os.getpid()}")
            tmp.parent.mkdir(parents=True, exist_ok=True)      # checked creatable up front (check_out_file)
            with open(tmp, "w") as fh:
                n = write_records(mission_records(mission), fh)
            os.replace(tmp, args.stream)
            print(f"wrote {n} records to {args.stream}", file=log)
    s = summarize(mission)
    print(f"{mission.name}: {s['duration_s']:.0f} s, {s['distance_m']:.0f} m travelled, "
          f"depth {s['depth_min_m']:.1f}..{s['depth_max_m']:.1f} m, "
          f"speed {s['speed_min_mps']:.2f}..{s['speed_max_mps']:.2f} m/s, "
          f"max yaw rate {s['max_yaw_rate_radps']:.3f} rad/s, "
          f"{s['dvl_pings']} DVL pings ({s['dvl_pings_lt3_beams']} with < 3 beams"
          + (", velocity-only DVL" if args.dvl_output == "velocity" else "") + ")"
          + (f", {len(mission.meta['surface_windows'])} surfacing(s) with {len(mission.fixes.t)} GNSS fixes"
             if mission.fixes is not None else ""), file=log)
    if args.out is not None:
        with StagedOut(args.out, args.force) as staged:
            paths = write_akit(mission, staged.path, args.number)
            png = staged.path / f"trajectory{args.number}.png"
            plot(mission, png)
        print(f"wrote {staged.final(paths['IMU'].parent)} ({', '.join(p.name for p in paths.values())}) and "
              f"{staged.final(png)}; navigate it with: graphnav smooth --data "
              f"{shlex.quote(str(staged.final(paths['IMU'].parent)))}")
    return 0
