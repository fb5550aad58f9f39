"""Command line: the parser of every subcommand and error reporting; each subcommand is a module."""

from __future__ import annotations

import argparse
import sys

from coverplan import __version__
from coverplan.cli import batching, checking, evaluating, exporting, listing, planning, reporting, simulating
from coverplan.cli.args import Parser
from coverplan.errors import CoverplanError


def build_parser() -> argparse.ArgumentParser:
    """The ``coverplan`` parser: one subcommand per module of this package."""
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


def main(argv=None) -> int:
    parser = build_parser()
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


if __name__ == "__main__":
    sys.exit(main())
