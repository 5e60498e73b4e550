"""Missing-beam completers (installed as ``graphnav.nets``).

``AverageCompleter`` is the paper's average estimator; ``BeamRegressor`` is the paper's missing-beam
network with a calibrated sigma head, ``BeamEnsemble`` several of them averaged (the shipped beam-only
networks are five). ``load_completer(missing=2|3)`` loads the shipped weights as a completer,
``load_completer("auto")`` serves every missing pattern (network where trained, average otherwise). ``train``
trains a network on the BeamsNet data (``graphnav train-beams``).

``load_imu_completer(2|3)`` loads the IMU-aware network (``ImuBeamRegressor``, trained on A-KIT IMU + DVL with
``train_imu`` / ``graphnav train-beams --imu``); it needs the IMU window:
``complete(past, measured, imu=(f_b, omega_b))`` (see :mod:`graphnav.nets.imu_network`).
``load_imu_auto_completer()`` serves every pattern: the IMU-aware networks where trained and given an IMU
window, each completion fused with ``load_completer("auto")``'s by their sigmas (both members fading as
``FUSED_RUN_DECAY`` says: not at all), and ``load_completer("auto")`` alone otherwise, fading as its cards say
(:mod:`graphnav.nets.imu_auto`).

``FusedCompleter(first, second, rho, growth)`` combines two completers' regressed beams by their sigmas, their
error correlation and each one's sigma growth through an outage (:mod:`graphnav.nets.fused`; a study, not a
default); :mod:`graphnav.nets.outage_calibration` fits those numbers from held-out errors.

``graphnav.nets.crossval`` cross-validates training recipes of the beam-only network against the average estimator
with whole trajectories held out (``graphnav eval-beams --folds``); the hybrid graph methods complete with the
average estimator because no recipe helps the estimators in every held-out fold (``docs/decisions/completers.md``).

The torch-based names are imported on first use, so ``from graphnav.nets import AverageCompleter`` does
not load torch.
"""
from importlib import import_module

from .average import AverageCompleter
from .completer import BeamCompleter, check_inputs

_LAZY = {
    "BeamRegressor": "model", "BeamEnsemble": "model",
    "AutoCompleter": "network", "NetworkCompleter": "network", "load_completer": "network",
    "load_model": "network",
    "TrainOptions": "training", "TrainResult": "training", "fit": "training", "save": "training",
    "train": "training",
    "ImuBeamRegressor": "imu_model", "ImuNetworkCompleter": "imu_network", "load_imu_completer": "imu_network",
    "load_imu_model": "imu_network", "ImuTrainOptions": "imu_recipes", "train_imu": "imu_training",
    "ImuAutoCompleter": "imu_auto", "load_imu_auto_completer": "imu_auto", "load_fused_beam_only": "imu_auto",
    "FusedCompleter": "fused",
}

__all__ = ["AverageCompleter", "BeamCompleter", "check_inputs", *_LAZY]


def __getattr__(name):
    if name in _LAZY:
        value = getattr(import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
