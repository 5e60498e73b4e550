"""Subcommands of the graphnav CLI, one module each (see graphnav.cli)."""
