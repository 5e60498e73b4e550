#!/usr/bin/env python
"""Thin wrapper: `python scripts/smooth.py ARGS` is `graphnav smooth ARGS` (see `graphnav smooth --help`)."""
import sys

from graphnav.cli import main

if __name__ == "__main__":
    sys.exit(main(["smooth", *sys.argv[1:]]))
