"""Subcommands of the graphnav CLI, one module each (see graphnav.cli); shared helpers in ``common``. No
Python API here: the entry point is :func:`graphnav.cli.main`."""
__all__: list[str] = []
