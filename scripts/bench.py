#!/usr/bin/env python
"""Thin wrapper: `python scripts/bench.py ARGS` is `graphnav bench ARGS` (see `graphnav bench --help`)."""
import sys

from graphnav.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
