"""graphnav: factor-graph INS/DVL navigation for AUVs.

``graphnav.Navigator`` is the streaming backend a vehicle runs (:mod:`graphnav.estimators.navigator`); it is loaded
on first use, so that ``import graphnav`` stays light.
"""
__version__ = "0.1.0"

_LAZY = {"Navigator": "graphnav.estimators.navigator", "NavigatorOptions": "graphnav.estimators.navigator"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'graphnav' has no attribute '{name}'")
