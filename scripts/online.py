#!/usr/bin/env python
"""Thin wrapper: `python scripts/online.py ARGS` is `graphnav online ARGS` (see `graphnav online --help`)."""
import sys

from graphnav.cli import main

if __name__ == "__main__":
    sys.exit(main(["online", *sys.argv[1:]]))
