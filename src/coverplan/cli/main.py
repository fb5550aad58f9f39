"""Command line: the parser of every subcommand and error reporting; each subcommand is a module."""

from __future__ import annotations

import argparse
import glob
import sys
from pathlib import Path

from coverplan import __version__
from coverplan.cli import batching, checking, evaluating, exporting, listing, planning, reporting, simulating
from coverplan.cli.args import Parser
from coverplan.errors import CoverplanError


def build_parser() -> argparse.ArgumentParser:
    """The ``coverplan`` parser: one subcommand per module of this package.

    Returns
    -------
    argparse.ArgumentParser
        The parser.
    """
    parser = Parser(prog="coverplan", description="Plan safe drone photo flights that cover a building.")
    parser.add_argument("--version", action="version", version=f"coverplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    listing.register(sub)
    evaluating.register(sub)
    planning.register(sub)
    batching.register(sub)
    simulating.register(sub)
    checking.register(sub)
    reporting.register(sub)
    exporting.register(sub)
    return parser


# The positional input each subcommand reads: named before any option is found missing.
INPUTS = {"plan": "targets", "evaluate": "route", "simulate": "route", "check": "photos", "report": "route",
          "plot": "route", "export": "route", "batch": "city"}


class _Unparsed(Exception):
    pass


def missing_input(parser: argparse.ArgumentParser, argv: list[str]) -> str | None:
    """The one-line error for an input file that is not there, found with the options' own
    checks relaxed (a missing file is the first thing to tell, not a missing ``--gsd``).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser.
    argv : list of str
        The command line.

    Returns
    -------
    str or None
        The error.
    """
    if not argv or argv[0] not in INPUTS or {"-h", "--help"} & set(argv):
        return None
    sub = parser._subparsers._group_actions[0].choices[argv[0]]
    saved = [(a, a.required) for a in sub._actions if a.option_strings]
    for a, _ in saved:
        a.required = False

    def stop(message):
        raise _Unparsed(message)

    parser_error, sub_error = parser.error, sub.error
    parser.error = sub.error = stop
    try:
        ns, _ = parser.parse_known_args(argv)
    except (_Unparsed, SystemExit):
        return None
    finally:
        parser.error, sub.error = parser_error, sub_error
        for a, required in saved:
            a.required = required
    given = getattr(ns, INPUTS[argv[0]], None)
    paths = given if isinstance(given, list) else [given]
    for path in paths:
        if isinstance(path, str) and path and not Path(path).exists() and not glob.has_magic(path):
            return f"{path}: no such file or folder"
    return None


def main(argv=None) -> int:
    """The ``coverplan`` command.

    Parameters
    ----------
    argv : list of str, optional
        The arguments; ``sys.argv[1:]`` when None.

    Returns
    -------
    int
        The exit status: 0 done, 1 a rule failed under ``--strict``, 2 bad input or an error.
    """
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    missing = missing_input(parser, argv)
    if missing:
        print(f"coverplan: error: {missing}", file=sys.stderr)
        return 2
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except CoverplanError as exc:
        print(f"coverplan: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("coverplan: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into a reader that stopped early (| head)
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
