"""Missing-beam completers (installed as ``graphnav.nets``).

``AverageCompleter`` is the paper's average estimator; the network completer is loaded with
``load_completer(missing=2|3)`` once its weights ship.
"""
from .average import AverageCompleter
from .completer import BeamCompleter, check_inputs

__all__ = ["AverageCompleter", "BeamCompleter", "check_inputs"]
