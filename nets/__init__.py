"""Missing-beam completers (installed as ``graphnav.nets``).

``AverageCompleter`` is the paper's average estimator; ``BeamRegressor`` is the paper's missing-beam
network with a calibrated sigma head. ``load_completer(missing=2|3)`` loads the shipped weights as a
completer, ``load_completer("auto")`` serves every missing pattern (network where trained, average
otherwise). ``train`` trains a network on the BeamsNet data (``graphnav train-beams``).

The torch-based names are imported on first use, so ``from graphnav.nets import AverageCompleter`` does
not load torch.
"""
from importlib import import_module

from .average import AverageCompleter
from .completer import BeamCompleter, check_inputs

_LAZY = {
    "BeamRegressor": "model",
    "AutoCompleter": "network", "NetworkCompleter": "network", "load_completer": "network",
    "load_model": "network",
    "TrainOptions": "training", "TrainResult": "training", "fit": "training", "save": "training",
    "train": "training",
}

__all__ = ["AverageCompleter", "BeamCompleter", "check_inputs", *_LAZY]


def __getattr__(name):
    if name in _LAZY:
        value = getattr(import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
