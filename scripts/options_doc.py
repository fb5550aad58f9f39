"""Write docs/options.md from the command line's own parser: every subcommand, its option
groups and every option with its values, unit and default, as ``--help`` gives them.

    python3 scripts/options_doc.py           # rewrite docs/options.md
    python3 scripts/options_doc.py --check   # exit 1 if docs/options.md differs from the parser
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "options.md"


def option_name(action, formatter) -> str:
    if not action.option_strings:
        return formatter._metavar_formatter(action, action.dest)(1)[0]
    values = "" if action.nargs == 0 else " " + formatter._format_args(action, action.dest.upper())
    return ", ".join(action.option_strings) + values


def render() -> str:
    from coverplan.cli.main import build_parser

    parser = build_parser()
    out = ["# Every option", "",
           "What `coverplan SUBCOMMAND --help` says, for every subcommand, generated from the parser by",
           "`python3 scripts/options_doc.py` (the test suite checks that this page matches it).", ""]
    for name, sub in parser._subparsers._group_actions[0].choices.items():
        formatter = sub._get_formatter()
        out += [f"## `coverplan {name}`", "", (sub.description or "").strip() or _help_of(parser, name), ""]
        for group in sub._action_groups:
            actions = [a for a in group._group_actions if a.dest != "help"]
            if not actions:
                continue
            title = {"options": "options", "positional arguments": "inputs"}.get(group.title, group.title)
            out += [f"**{title}**", "", "| option | what it sets |", "|---|---|"]
            for a in actions:
                text = (a.help or "").replace("%%", "%").replace("|", "\\|")
                out.append(f"| `{option_name(a, formatter).replace('|', chr(92) + '|')}` | {text} |")
            out.append("")
    return "\n".join(out).rstrip() + "\n"


def _help_of(parser, name: str) -> str:
    for a in parser._subparsers._group_actions[0]._choices_actions:
        if a.dest == name:
            return (a.help or "").capitalize() + "."
    return ""


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--check", action="store_true", help="compare with docs/options.md instead of writing it")
    args = p.parse_args(argv)
    text = render()
    if args.check:
        if PAGE.read_text(encoding="utf-8") != text:
            print("docs/options.md is stale: python3 scripts/options_doc.py rewrites it")
            return 1
        return 0
    PAGE.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
