"""The ``graphnav`` command line.

Every module in :mod:`graphnav.commands` that defines ``register(subparsers)`` adds one subcommand;
``register`` creates its parser (with ``--help``) and sets ``func`` to a callable taking the parsed args
and returning an exit code.
"""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from graphnav import __version__, commands
from graphnav.core.errors import GraphnavError


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="graphnav",
        description="Factor-graph INS/DVL navigation for AUVs through partial DVL beam outages.")
    parser.add_argument("--version", action="version", version=f"graphnav {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        if hasattr(module, "register"):
            module.register(sub)
    parser.subcommands = sub.choices     # name -> its parser: an unknown option is reported with its usage
    return parser


def parse(parser: argparse.ArgumentParser, argv: list[str] | None) -> argparse.Namespace:
    """``parser.parse_args(argv)``, but an unknown option after a subcommand is the subcommand's error: its usage,
    and the option it may be a typo of (argparse's own reports it with the top-level usage)."""
    args, extras = parser.parse_known_args(argv)
    if extras:
        import difflib
        sub = getattr(parser, "subcommands", {}).get(getattr(args, "command", None), parser)
        known = [o for action in sub._actions for o in action.option_strings]
        hints = [f"{e} (did you mean {close[0]}?)"
                 if e.startswith("-") and (close := difflib.get_close_matches(e.split("=")[0], known, 1)) else e
                 for e in extras]
        sub.error(f"unrecognized arguments: {' '.join(hints)}")
    return args


def _warning_line(message, category, filename, lineno, line=None) -> str:
    """A warning as a command prints it: its message, without the source file and line Python adds (they name
    graphnav's code, not the user's input; the message names the input)."""
    return f"warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    import warnings
    parser = build_parser()
    args = parse(parser, argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    shown, warnings.formatwarning = warnings.formatwarning, _warning_line
    try:
        return int(args.func(args) or 0)
    except GraphnavError as exc:
        print(f"graphnav {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"graphnav {args.command}: interrupted; results written so far are kept", file=sys.stderr)
        return 130
    finally:
        warnings.formatwarning = shown


if __name__ == "__main__":
    sys.exit(main())
