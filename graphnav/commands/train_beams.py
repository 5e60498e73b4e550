"""``graphnav train-beams``: train the missing-beam regressor and write its weights and model card."""
from __future__ import annotations

import json
from pathlib import Path

from graphnav.core.errors import ConfigError


def register(subparsers) -> None:
    from graphnav.nets.imu_recipes import ImuTrainOptions

    p = subparsers.add_parser(
        "train-beams", help="train the missing-beam regressor (2 and/or 3 missing beams)",
        description="Train the paper's missing-beam regressor on beams made from the BeamsNet V.npy DVL "
                    "velocities (first 75 % train, last 25 % validation), then its sigma head (Gaussian "
                    "NLL). Writes <scenario>.pt and <scenario>.json (model card) to --out; only --install-weights "
                    "also copies them over the shipped weights that every later run uses. Defaults are the "
                    "paper's: MSE, RMSprop, batch 4, lr 1e-3 x0.1 every 35 epochs, 100 epochs (with early "
                    "stopping on validation).",
    )
    p.add_argument("--scenario", action="append", choices=["2-missing", "3-missing"],
                   help="scenario to train (repeat for both; default: both)")
    p.add_argument("--missing", type=str, default=None,
                   help="custom 0-based missing beams, e.g. '0,3' (instead of --scenario)")
    p.add_argument("--n-past", type=int, default=None, help="past window N (default 3, or 5 for 3 missing)")
    p.add_argument("--epochs", type=int, default=100, help="maximum epochs (default 100)")
    p.add_argument("--batch-size", type=int, default=4, help="batch size (default 4)")
    p.add_argument("--lr", type=float, default=1e-3, help="RMSprop learning rate (default 1e-3)")
    p.add_argument("--lr-step", type=int, default=35, help="epochs between x0.1 learning-rate steps (default 35)")
    p.add_argument("--patience", type=int, default=30,
                   help="stop after this many epochs without validation improvement (default 30; 0: never; "
                        "the best validation epoch is kept either way)")
    p.add_argument("--sigma-epochs", type=int, default=30, help="epochs of the sigma head, Gaussian NLL (default 30)")
    p.add_argument("--seed", type=int, default=0, help="seed of weight init and shuffling (default 0)")
    p.add_argument("--beam-seed", type=int, default=0, help="seed of the beam noise (default 0)")
    p.add_argument("--align-yaw", type=float, default=45.0,
                   help="yaw (deg) turning the BeamsNet velocities into the body frame (default 45; 0: as "
                        "published, as the paper did)")
    p.add_argument("--threads", type=int, default=1, help="torch threads (default 1, fastest for this tiny net)")
    p.add_argument("--data", default=None, help="snapir-2021-beamsnet folder (default: found via GRAPHNAV_DATA)")
    p.add_argument("--out", default="out/train-beams", metavar="DIR",
                   help="output folder of the weights and model cards (appears only once training completes)")
    p.add_argument("--force", action="store_true", help="replace an --out folder that already holds files")
    p.add_argument("--install-weights", action="store_true",
                   help="after training, also copy the weights and model cards over the shipped ones in the "
                        "package's nets/weights (what every later run loads); without it they are left as they are")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.add_argument("--imu", action="store_true",
                   help="train the IMU-aware networks instead (imu-<scenario>.pt/.json): A-KIT trajectories "
                        "(IMU + DVL), split by trajectory (train 1 2 4 8 10 11 13, validation 3 5 6), Adam, "
                        "early stopping on the last 20 %% of each training trajectory; prints the validation "
                        "table. Uses --scenario, --seed, --beam-seed, --threads, --out; --data is the "
                        "snapir-2022-akit folder; --imu-epochs, --imu-draws set its schedule; --recipe graded-fade "
                        "trains the shipped recipe, chosen out of fold, on all ten trajectories instead")
    p.add_argument("--imu-epochs", type=int, default=None,
                   help=f"maximum epochs of the IMU-aware network (default {ImuTrainOptions.epochs})")
    p.add_argument("--imu-draws", type=int, default=None, help="beam-noise draws of the training trajectories for the "
                   f"IMU-aware network (default {ImuTrainOptions.draws})")
    p.add_argument("--recipe", default=None, metavar="NAME",
                   help="train a cross-validated recipe of graphnav.nets.crossval.VARIANTS (akit-residual-aug-ens5-fade "
                        "is the shipped one) "
                        "on all ten A-KIT trajectories and all of V.npy instead of the paper's BeamsNet split; "
                        "--data is then the folder holding snapir-2022-akit and snapir-2021-beamsnet (default: "
                        "GRAPHNAV_DATA); uses --scenario, --seed, --beam-seed, --threads, --out. With --imu: a "
                        "recipe of graphnav.nets.imu_recipes.IMU_RECIPES (graded: the schedule and IMU-grade "
                        "copies of the leave-trajectories-out study; graded-fade, the shipped one: the same "
                        "networks fading to the average through an outage) trained on all ten A-KIT trajectories")
    p.add_argument("--config", metavar="JSON", default=None,
                   help="train the beam-only networks for the DVL of this sensor configuration (its dvl.theta_rad, "
                        "dvl.psi_rad, dvl.C_d_b and beam errors; e.g. from `graphnav calibrate`): their beams are made "
                        "from the recorded velocities with it, one a ping 1 s apart whatever its dvl.rate_hz (a rate "
                        "the estimators would refuse is warned about), the model card records it, and the estimators "
                        "bind the networks to it (default: the Snapir's DVL, DvlSpec's default). With "
                        "--install-weights they replace the shipped Snapir networks. With --imu: the IMU-aware "
                        "networks, the same way")
    p.add_argument("--out-of-fold", nargs="+", default=None, metavar="JSON",
                   help="with --recipe: the rows of 'graphnav eval-beams --folds --json' that chose it; their pooled "
                        "and worst-fold numbers of this recipe go into the model card ('out_of_fold')")
    p.set_defaults(func=run)


def run_imu(args, out: Path, spec=None) -> list[Path]:
    """``--imu``: train the IMU-aware networks into ``out`` for the DVL ``spec`` (``--config``; None: the Snapir's)
    and print their validation table; returns the files written."""
    from dataclasses import replace

    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.dvl_match import chosen_for_note
    from graphnav.nets.imu_evaluate import format_imu_table
    from graphnav.nets.imu_recipes import IMU_RECIPES, ImuTrainOptions
    from graphnav.nets.imu_training import train_imu
    from graphnav.nets.training import save

    if args.missing is not None:
        raise ConfigError("--imu trains the 2-missing and 3-missing scenarios; use --scenario, not --missing")
    if args.recipe is not None and args.recipe not in IMU_RECIPES:
        raise ConfigError(f"--imu --recipe {args.recipe!r} unknown; choose from {list(IMU_RECIPES)}")
    schedule = {k: v for k, v in (("epochs", args.imu_epochs), ("draws", args.imu_draws)) if v is not None}
    if args.recipe is not None and schedule:
        raise ConfigError("--imu --recipe sets its own schedule; drop --imu-epochs / --imu-draws")
    written = []
    if args.recipe:     # chosen out of fold: trained on every trajectory, nothing left to validate on
        opt = replace(IMU_RECIPES[args.recipe], seed=args.seed, beam_seed=args.beam_seed, threads=args.threads)
        trajectories = sorted(t for pair in AKIT_FOLDS for t in pair)
    else:
        opt = ImuTrainOptions(**schedule, seed=args.seed, beam_seed=args.beam_seed, threads=args.threads)
        trajectories = None
    for scenario in args.scenario or ["2-missing", "3-missing"]:
        result = train_imu(scenario, opt, args.data, progress=not args.no_progress, evaluate=not args.recipe,
                           trajectories=trajectories, spec=spec)
        card = result.card
        if args.recipe:
            card["selected_by"] = ("leave-trajectories-out cross-validation, experiments/imu_completer_folds.py: "
                                   f"A-KIT folds {[list(f) for f in AKIT_FOLDS]}, recipe {args.recipe!r}"
                                   + ("; run_decay chosen on the same folds' networks by "
                                      "experiments/completer_fade_folds.py --imu" if opt.run_decay < 1.0 else "")
                                   + chosen_for_note(spec, "experiments/imu_completer_folds.py --config"))
        pt, js = save(result, out)
        written += [pt, js]
        print(f"{card['name']}: N={card['n_past']} IMU window {card['imu_samples']} samples, "
              f"{card['n_parameters']} parameters, epochs={card['training']['epochs_run']} "
              f"(best {card['training']['best_epoch']}) time={card['training']['time_s']:.1f} s; "
              + (f"validation trajectories {card['split']['val_trajectories']}" if not args.recipe
                 else f"trained on trajectories {card['split']['train_trajectories']}, chosen by "
                      f"{card['selected_by']}"))
        if "metrics_val" in card:
            print(format_imu_table(card["metrics_val"]))
    return written


def run_recipe(args, out: Path, spec=None) -> list[Path]:
    """``--recipe``: train a cross-validated recipe on every recording into ``out`` for the DVL ``spec`` (``--config``;
    None: the Snapir's); returns the files written."""
    import torch

    from graphnav.nets import crossval
    from graphnav.nets.training import save

    if args.recipe not in crossval.VARIANTS:
        raise ConfigError(f"--recipe {args.recipe!r} unknown; choose from {list(crossval.VARIANTS)}")
    if args.missing is not None:
        raise ConfigError("--recipe trains the 2-missing / 3-missing networks; drop --missing")
    akit = beamsnet = None
    if args.data:
        akit, beamsnet = Path(args.data) / "snapir-2022-akit", Path(args.data) / "snapir-2021-beamsnet"
    scenarios = args.scenario or ["2-missing", "3-missing"]
    summary = out_of_fold_summary(args.out_of_fold, args.recipe, scenarios, spec) if args.out_of_fold else None
    torch.set_num_threads(args.threads)
    written = []
    for scenario in scenarios:
        result = crossval.train_final(scenario, args.recipe, akit, beamsnet, args.beam_seed, args.seed,
                                      summary=summary, progress=not args.no_progress, spec=spec)
        written += list(save(result, out))
        print(f"{scenario}: recipe {args.recipe}, {result.card['training']['time_s']:.1f} s; "
              f"chosen by {result.card['selected_by']}")
    return written


def out_of_fold_summary(files: list[str], recipe: str, scenarios: list[str], spec=None) -> list[dict]:
    """Pooled and worst-fold rows (:func:`graphnav.nets.crossval.summarise`) of ``recipe`` from the fold rows in
    ``files`` (``eval-beams --folds --json``) made for the DVL ``spec`` (default: the Snapir's; rows that name no DVL
    are its); a file that is not such rows, rows missing a scenario, or rows made for another DVL is a
    ``ConfigError`` naming it."""
    from graphnav.nets import crossval

    from graphnav.nets.dvl_match import dvl_name, rows_dvls
    dvl = dvl_name(spec)
    rows = []
    for name in files:
        try:
            loaded = json.loads(Path(name).read_text())
        except (OSError, ValueError) as exc:
            raise ConfigError(f"--out-of-fold {name}: cannot read it as JSON ({exc})") from exc
        if not isinstance(loaded, list) or not all(isinstance(r, dict) and "fold" in r for r in loaded):
            raise ConfigError(f"--out-of-fold {name}: not the fold rows of 'graphnav eval-beams --folds --json'")
        ours = [r for r in loaded if r.get("variant") == recipe]
        other = rows_dvls(ours) - {dvl}
        if other:
            raise ConfigError(f"--out-of-fold {name}: rows made for another DVL ({sorted(other)[0]}); this training is "
                              f"for {dvl} (--config)")
        rows += ours
    missing = [s for s in scenarios if not any(r.get("scenario") == s for r in rows)]
    if missing:
        raise ConfigError(f"--out-of-fold {' '.join(files)}: no rows of recipe {recipe!r} for {', '.join(missing)}")
    keys = [(r.get("dataset"), r.get("scenario"), r.get("mode"), r.get("method"), r["fold"]) for r in rows]
    if len(set(keys)) < len(keys):
        raise ConfigError(f"--out-of-fold {' '.join(files)}: a fold's rows appear twice (the same file or fold given "
                          "twice)")
    folds: dict[tuple, set] = {}
    for dataset, scenario, mode, _, fold in keys:
        folds.setdefault((dataset, scenario, mode), set()).add(fold)
    if len({frozenset(f) for f in folds.values()}) > 1:
        raise ConfigError(f"--out-of-fold {' '.join(files)}: not every scenario and mode has the same folds (an "
                          "unfinished run?)")
    return crossval.summarise(rows)


def warn_off_rate(spec, source: str) -> None:
    """Warn when the DVL ``spec`` of ``source`` pings at a rate whose pings the networks, trained on pings 1 s apart,
    would leave to the average estimator (:mod:`graphnav.nets.dvl_match`)."""
    import warnings

    from graphnav.core.dvl import off_period
    from graphnav.nets.data import RECORDED_PING_RATE_HZ
    from graphnav.nets.dvl_match import LONGEST_PAST_INTERVAL_PERIODS
    if off_period([1.0 / spec.rate_hz], 1.0 / RECORDED_PING_RATE_HZ, LONGEST_PAST_INTERVAL_PERIODS):
        warnings.warn(f"{source}: dvl.rate_hz = {spec.rate_hz:g} Hz; the networks are trained on the recordings' "
                      f"pings, {1.0 / RECORDED_PING_RATE_HZ:g} s apart, and on a DVL pinging at {spec.rate_hz:g} Hz "
                      "the estimators leave every ping to the average estimator (completer_fallbacks['period'])",
                      RuntimeWarning, stacklevel=2)


def run(args) -> int:
    from graphnav.commands.common import StagedOut, config_dvl

    spec = config_dvl(args.config)          # read once, and a bad file is said before any training
    if spec is not None:
        from graphnav.nets.dvl_match import dvl_name
        warn_off_rate(spec, args.config)
        print(f"training for the DVL of {args.config}: beams {dvl_name(spec)}")
    if args.out_of_fold and (not args.recipe or args.imu):
        raise ConfigError("--out-of-fold goes with a beam-only --recipe: it names the rows that chose the recipe")

    with StagedOut(args.out, args.force) as staged:
        if args.imu:
            written = run_imu(args, staged.path, spec)
        else:
            written = run_recipe(args, staged.path, spec) if args.recipe else run_beams(args, staged.path, spec)
    finals = [Path(staged.final(p)) for p in written]
    print("wrote " + ", ".join(str(p) for p in finals))
    if args.install_weights:
        install_weights(finals)
    return 0


def install_weights(files: list[Path]) -> None:
    """Copy trained weights and model cards over the shipped ones (``--install-weights``), each file whole."""
    import os
    import shutil

    from graphnav.nets.storage import weights_dir
    target = weights_dir()
    for f in files:
        tmp = target / f".{f.name}.partial-{os.getpid()}"
        shutil.copyfile(f, tmp)
        os.replace(tmp, target / f.name)
    print(f"installed {', '.join(f.name for f in files)} into {target} (the weights every later run uses)")


def run_beams(args, out: Path, spec=None) -> list[Path]:
    """Train the beam-only regressors into ``out`` for the DVL ``spec`` (``--config``; None: the Snapir's); returns
    the files written."""
    from graphnav.nets.training import TrainOptions, save, train

    written = []
    if args.missing is not None:
        try:
            targets = [tuple(int(b) for b in args.missing.split(","))]
        except ValueError:
            raise ConfigError(f"--missing must be comma-separated beam indices, got '{args.missing}'") from None
    else:
        targets = args.scenario or ["2-missing", "3-missing"]
    opt = TrainOptions(epochs=args.epochs, batch_size=args.batch_size, lr=args.lr, lr_step_epochs=args.lr_step,
                       patience=args.patience or None, sigma_epochs=args.sigma_epochs, seed=args.seed,
                       beam_seed=args.beam_seed, threads=args.threads,
                       align_yaw_deg=args.align_yaw)
    for missing in targets:
        result = train(missing, args.n_past, opt, args.data, progress=not args.no_progress, spec=spec)
        pt, js = save(result, out)
        written += [pt, js]
        card = result.card
        val, test = card["metrics"]["val"], card["metrics"]["test"]
        print(f"{card['scenario']}: N={card['n_past']} epochs={card['training']['epochs_run']} "
              f"(best {card['training']['best_epoch']}) time={card['training']['time_s']:.1f} s")
        for name, m in (("validation", val), ("V_test", test)):
            print(f"  {name:10s} beam RMSE {m['beam_rmse']:.4f} m/s  velocity RMSE {m['vel_rmse']:.4f} m/s  "
                  f"within 1/2 sigma {m['within_1sigma']:.3f}/{m['within_2sigma']:.3f}")
        print(json.dumps({"constant_sigma": card["constant_sigma"]}))
    return written
