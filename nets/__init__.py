"""Missing-beam completers (installed as ``graphnav.nets``).

``AverageCompleter`` is the paper's average estimator; ``BeamRegressor`` is the paper's missing-beam
network with a calibrated sigma head. ``load_completer(missing=2|3)`` loads the shipped weights as a
completer, ``load_completer("auto")`` serves every missing pattern (network where trained, average
otherwise). ``train`` trains a network on the BeamsNet data (``graphnav train-beams``).
"""
from .average import AverageCompleter
from .completer import BeamCompleter, check_inputs
from .model import BeamRegressor
from .network import AutoCompleter, NetworkCompleter, load_completer, load_model
from .train import TrainOptions, TrainResult, fit, save, train

__all__ = ["AverageCompleter", "AutoCompleter", "BeamCompleter", "BeamRegressor", "NetworkCompleter",
           "TrainOptions", "TrainResult", "check_inputs", "fit", "load_completer", "load_model", "save",
           "train"]
