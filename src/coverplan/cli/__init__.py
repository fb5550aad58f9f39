"""The ``coverplan`` command line: one sub-command per job (plan, evaluate, simulate, ...)."""

from coverplan.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
