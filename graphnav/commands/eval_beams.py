"""``graphnav eval-beams``: the missing-beam network against the average estimator, as a table."""
from __future__ import annotations

import json


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "eval-beams", help="evaluate the missing-beam networks against the average estimator",
        description="Beam RMSE and velocity RMSE (least squares on the measured plus regressed beams vs the true DVL "
                    "velocity), and sigma calibration (fraction of errors within 1 and 2 sigma), of the "
                    "network and the average estimator, for 2 and 3 missing beams, on the validation split "
                    "of V.npy, on V_test.npy and on the A-KIT DVL velocities. 'per ping' regresses the "
                    "missing beams of every ping from the true past; 'outage 30 s' regresses 30-ping outages "
                    "recursively, as the estimators do. '4-beam vel RMSE' is least squares on all four beams "
                    "(the floor). It first prints what each network was trained on (its model card): rows on "
                    "those data are fitted data (the shipped networks were trained on all of V.npy and the ten "
                    "A-KIT trajectories; V_test.npy never). --folds "
                    "cross-validates training recipes instead, holding out whole trajectories: the numbers that "
                    "predict unseen motion.",
)
    p.add_argument("--weights", default=None, help="folder with <scenario>.pt/.json (default: shipped); scored on "
                   "beams made for the DVL each model card records")
    p.add_argument("--beamsnet", default=None, help="snapir-2021-beamsnet folder (default: GRAPHNAV_DATA)")
    p.add_argument("--akit", default=None, help="snapir-2022-akit folder (default: GRAPHNAV_DATA)")
    p.add_argument("--beam-seed", type=int, default=1000,
                   help="seed of the beam noise (default 1000, not the training draw's 0)")
    p.add_argument("--scenario", action="append", choices=["2-missing", "3-missing"],
                   help="scenario to evaluate (repeat; default both)")
    p.add_argument("--no-outage", action="store_true", help="skip the recursive 30 s outage rows")
    p.add_argument("--json", default=None, help="also write the rows to this JSON file")
    p.add_argument("--imu", action="store_true",
                   help="evaluate the IMU-aware networks instead: IMU-aware network vs average estimator "
                        "(N=3 for 2 missing beams, 5 for 3) vs the shipped beam-only network (when it was trained for "
                        "the same DVL) on A-KIT trajectories (default 3, 5, 6), with beams made for the DVL the "
                        "IMU-aware card records, per ping and recursive 30 s outages, with the reduction against the "
                        "average in %%; the shipped networks were trained on all ten (the out-of-fold numbers: "
                        "experiments/imu_completer_folds.py)")
    p.add_argument("--trajectories", type=str, default=None,
                   help="with --imu: comma-separated A-KIT trajectory numbers (default 3,5,6)")
    p.add_argument("--per-trajectory", action="store_true",
                   help="with --imu: also evaluate each trajectory alone and print the network-vs-average "
                        "summary per trajectory and pooled")
    p.add_argument("--folds", action="store_true",
                   help="leave-trajectories-out cross-validation instead: in each of 5 fixed folds (two A-KIT "
                        "trajectories and one block of BeamsNet missions held out) train a network with "
                        "--variant on the rest and score it against the average estimator on the held-out "
                        "recordings and V_test.npy; prints per-fold rows and the pooled / worst-fold table")
    p.add_argument("--variant", action="append", default=None,
                   help="with --folds: training recipe to cross-validate (repeat; one of "
                        "graphnav.nets.crossval.VARIANTS; default: paper-recipe, akit, akit-residual, "
                        "akit-residual-aug; the ensembles akit-residual-aug-ens5 and the shipped "
                        "akit-residual-aug-ens5-fade train five networks per fold, so they run only when named)")
    p.add_argument("--threads", type=int, default=1, help="with --folds: torch threads (default 1)")
    p.add_argument("--seed", type=int, default=0,
                   help="with --folds: training seed (default 0; fold k trains with seed + k, an ensemble's member j "
                        "with seed + k + 1000 j): another seed measures how much a table owes to one training draw")
    p.add_argument("--save-nets", default=None, metavar="DIR",
                   help="with --folds: also save each fold's network to DIR/<variant>/fold<k> (weights and card), "
                        "for studies that run it on that fold's held-out trajectories")
    p.add_argument("--config", metavar="JSON", default=None,
                   help="with --folds: the DVL of this sensor configuration (its beam directions and errors): the "
                        "recordings' beams are made for it, each fold's networks trained for it and scored with it "
                        "(default: the Snapir's DVL), as `graphnav train-beams --recipe NAME --config JSON` trains")
    p.set_defaults(func=run)


def training_data_notes(directory, names: list[str]) -> list[str]:
    """One line per model card ``<name>.json`` in ``directory`` (default: the shipped weights) saying what the
    network was trained on, so that a row on those data is read as fitted data, not unseen motion, and for which DVL
    (the beams its rows are scored on)."""
    from pathlib import Path

    from graphnav.nets.dvl_match import dvl_name, trained_dvl_spec
    from graphnav.nets.storage import weights_dir

    lines = []
    for name in names:
        path = Path(directory or weights_dir()) / f"{name}.json"
        if not path.exists():
            continue
        card = json.loads(path.read_text())
        split = card.get("split", {})
        if "train_trajectories" in split:
            trained = f"A-KIT trajectories {split['train_trajectories']}"
        elif "train_fraction" in split:     # the paper's recipe: the first part of V.npy
            trained = f"the first {split['train_fraction']:.0%} of BeamsNet V.npy"
        else:
            trained = card.get("data", {}).get("source", "unknown data")
        beams = dvl_name(trained_dvl_spec(card))
        lines.append(f"{name}: trained on {trained}, for a DVL with beams {beams} (scored on its beams); chosen by "
                     f"{card.get('selected_by', 'its validation split')}")
    return lines


def run_imu(args) -> int:
    from graphnav.core.errors import ConfigError
    from graphnav.nets.imu_data import AKIT_SPLIT
    from graphnav.nets.imu_evaluate import (
        evaluate_imu,
        evaluate_imu_per_trajectory,
        format_imu_summary,
        format_imu_table,
    )

    trajectories = AKIT_SPLIT["val"]
    if args.trajectories:
        try:
            trajectories = tuple(int(t) for t in args.trajectories.split(","))
        except ValueError:
            raise ConfigError(f"--trajectories must be comma-separated numbers, got '{args.trajectories}'") from None
    scenarios = tuple(args.scenario or ("2-missing", "3-missing"))
    if args.per_trajectory:
        rows = evaluate_imu_per_trajectory(scenarios, trajectories, directory=args.weights, akit_dir=args.akit,
                                           beam_seed=args.beam_seed, outage=not args.no_outage)
        tables = [format_imu_table([r for r in rows if r["trajectories"] == rows[-1]["trajectories"]]),
                  format_imu_summary(rows)]
    else:
        rows = evaluate_imu(scenarios, trajectories, args.weights, args.akit, args.beam_seed,
                            outage=not args.no_outage)
        tables = [format_imu_table(rows)]
    print(f"A-KIT trajectories {list(trajectories)}, beam seed {args.beam_seed}")
    # the beam-only network of the table is the shipped one, there only when it was trained for the same DVL
    beam_only = [s for s in scenarios if any(r["scenario"] == s and r["method"] == "network" for r in rows)]
    for line in training_data_notes(args.weights, [f"imu-{s}" for s in scenarios]) + training_data_notes(
            None, beam_only):
        print(line)
    print("\n".join(tables))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


def run_folds(args) -> int:
    """``--folds``: the out-of-fold table of each training recipe."""
    import sys

    import torch

    from graphnav.core.errors import ConfigError
    from graphnav.nets import crossval

    names = args.variant or list(crossval.DEFAULT_VARIANTS)
    unknown = [v for v in names if v not in crossval.VARIANTS]
    if unknown:
        raise ConfigError(f"--variant {unknown[0]!r} unknown; choose from {list(crossval.VARIANTS)}")
    torch.set_num_threads(args.threads)
    from graphnav.commands.common import config_dvl
    data = crossval.load_fold_data(args.akit, args.beamsnet, args.beam_seed, spec=config_dvl(args.config))
    print(crossval.fold_table(data))
    if args.config:
        from graphnav.nets.dvl_match import dvl_name
        print(f"DVL of {args.config}: beams {dvl_name(data.spec)}")
    rows = []
    for name in names:
        for scen in args.scenario or ("2-missing", "3-missing"):
            rows += crossval.crossval(data, scen, name, seed=args.seed, outage=not args.no_outage,
                                      log=lambda msg: print(msg, file=sys.stderr, flush=True),
                                      save_dir=f"{args.save_nets}/{name}" if args.save_nets else None)
            if args.json:
                with open(args.json, "w") as fh:
                    json.dump(rows, fh, indent=1)
    print(crossval.format_fold_rows(rows))
    print("\nGain of the network against the average per held-out A-KIT fold (beam / velocity RMSE):")
    print(crossval.format_fold_gains(rows))
    print("\nPooled over the folds, and the worst fold:")
    print(crossval.format_summary(crossval.summarise(rows)))
    return 0


def run(args) -> int:
    from graphnav.commands.common import check_out_file
    from graphnav.nets.evaluate import evaluate_all, format_table

    check_out_file(args.json, force=True, option="--json")
    if args.config and not args.folds:
        from graphnav.core.errors import ConfigError
        raise ConfigError("--config goes with --folds (the other tables score the shipped networks on the DVL they "
                          "were trained for)")
    if args.folds:
        return run_folds(args)
    if args.imu:
        return run_imu(args)
    scenarios = tuple(args.scenario or ("2-missing", "3-missing"))
    rows = evaluate_all(args.weights, args.beamsnet, args.akit, args.beam_seed, scenarios, outage=not args.no_outage)
    for line in training_data_notes(args.weights, list(scenarios)):
        print(line)
    print("Rows on data a network was trained on score fitted data; --folds gives the out-of-fold numbers.")
    print(format_table(rows))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0
