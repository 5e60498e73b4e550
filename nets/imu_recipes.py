"""The IMU-aware network's training options and the recipes chosen out of fold, without torch: the command
line's help reads their defaults, and importing torch for it would cost every ``graphnav`` call about 2 s."""
from __future__ import annotations

from dataclasses import dataclass, replace

from .completer import check_run_decay
from .imu_window import IMU_WINDOW_S


@dataclass
class ImuTrainOptions:
    """Hyper-parameters of the IMU-aware network."""

    n_past: int | None = None           # None: DEFAULT_IMU_N_PAST for the number of missing beams
    hidden: int = 32
    sigma_hidden: int = 16
    imu_window_s: float = IMU_WINDOW_S
    epochs: int = 60
    batch_size: int = 64
    lr: float = 2e-3
    lr_step_epochs: int = 20
    lr_gamma: float = 0.3
    patience: int | None = 15
    sigma_epochs: int = 20
    sigma_batch_size: int = 128
    sigma_lr: float = 3e-3
    blend: bool = True                  # learned blend of the IMU-propagated and the held prior
    relative: bool = True               # the heads see beams relative to the prior, not their values
    correction_sees_imu: bool = False   # the correction sees the angular rates and gravity direction
    rollout_epochs: int = 20            # recursive stage (0: one step ahead only)
    rollout_window: int = 30            # pings per rollout (the benchmark's 30 s outages)
    rollout_stride: int = 3             # pings between rollout starts
    rollout_batch_size: int = 64
    rollout_lr: float = 1e-3
    draws: int = 6                      # beam-noise draws of the training trajectories
    select_fraction: float = 0.2        # last part of each training trajectory: epoch and sigma-gain selection
    seed: int = 0
    beam_seed: int = 0
    threads: int = 1
    imu_grades: tuple[str, ...] = ()    # extra training copies with these IMU grades' errors added (out-of-fold study)
    imu_seed: int = 0                   # seed of those errors: imu_seed + 100 * copy + trajectory number
    run_decay: float = 1.0              # the completer's fading to the average through an outage (model card);
    #                                     changes no training (ImuNetworkCompleter run_decay)

    def __post_init__(self):
        check_run_decay(self.run_decay, "ImuTrainOptions")


#: Recipes of the IMU-aware network chosen by leave-trajectories-out cross-validation
#: (``experiments/imu_completer_folds.py``, ``docs/decisions/completers.md``), trained on every A-KIT trajectory by
#: ``graphnav train-beams --imu --recipe NAME``. ``graded``: the schedule the five folds were trained and scored
#: with, and one copy of every trajectory with tactical and one with MEMS IMU errors (out of fold, the copies made
#: the worst folds' outages much less bad than the recorded IMU alone).
#: ``graded-fade``: the same networks, completing an outage with a fade to the average estimator (``run_decay``
#: 0.95 for 2 and 3 missing beams, chosen out of fold by ``experiments/completer_fade_folds.py --imu``): the
#: shipped recipe.
_GRADED = ImuTrainOptions(epochs=15, rollout_epochs=3, rollout_stride=6, draws=2, sigma_epochs=10,
                          imu_grades=("tactical", "mems"))
IMU_RECIPES = {
    "graded": _GRADED,
    "graded-fade": replace(_GRADED, run_decay=0.95),
}
