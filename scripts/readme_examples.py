"""Run the README's examples and write their output into it, so that it cannot go stale.

Each example is a block of README.md between ``<!-- example NAME -->`` and
``<!-- /example -->``: the command as typed, then what it printed. This script runs the
commands in a scratch folder beside copies of ``meshes/`` (one after the other: later
examples use the files earlier ones wrote) and rewrites the blocks.

    python3 scripts/readme_examples.py            # run every example and rewrite README.md
    python3 scripts/readme_examples.py --check    # exit 1 if README.md differs from a fresh run
    python3 scripts/readme_examples.py --only plan evaluate

Examples marked ``exact=False`` (COLMAP's results vary from run to run and machine to machine)
are compared by their row labels only under ``--check``; progress lines are left out.
"""

from __future__ import annotations

import argparse
import difflib
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


@dataclass(frozen=True)
class Example:
    name: str
    command: str
    exact: bool = True
    needs: tuple[str, ...] = ()  # earlier examples whose files this one reads


EXAMPLES = (
    Example("first-plan", "coverplan plan meshes/ring_prism.obj --camera phantom4pro --gsd 0.004 --security 3 "
                          "-o ring_route.json --report ring_report.html --force"),
    Example("plan", "coverplan plan meshes/gabled_house.obj --drone m3e --gsd 0.004 --security 3 "
                    "--geo-origin 48.7758 9.1829 250 --start-latlon 48.77572 9.18260 -o house.json "
                    "--export wpml,qgc,kml --report house.html --force"),
    Example("evaluate", "coverplan evaluate house.json", needs=("plan",)),
    Example("export", "coverplan export house.json --format qgc --firmware ardupilot -o house_ardupilot",
            needs=("plan",)),
    Example("simulate", "coverplan simulate house.json -o house_sim --quick", exact=False, needs=("plan",)),
)
NAMES = [e.name for e in EXAMPLES]
BLOCK = re.compile(r"(<!-- example (?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /example -->)", re.S)


def run(example: Example, cwd: Path) -> str:
    """The example's block: the command, then its output without progress lines."""
    done = subprocess.run(shlex.split(example.command), cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{example.name}: '{example.command}' exited {done.returncode}:\n{done.stderr}")
    return block(example.command, done)


def block(command: str, done: subprocess.CompletedProcess) -> str:
    """A command's block as the README shows it: the command, then what it printed without
    progress lines."""
    lines = [line for line in (done.stderr + done.stdout).splitlines()
             if line.strip() and not line.startswith("[coverplan]")]
    return f"```console\n$ {command}\n" + "\n".join(lines) + "\n```\n"


def labels(block: str) -> list[str]:
    """The row labels of an example's output (the words before two spaces)."""
    return [re.split(r"\s{2,}", line.strip())[0] for line in block.splitlines()[2:-1] if "  " in line.strip()]


def generate(names: list[str]) -> dict[str, str]:
    wanted = set(names)
    for e in EXAMPLES:
        if e.name in wanted:
            wanted |= set(e.needs)
    blocks = {}
    with tempfile.TemporaryDirectory(prefix="coverplan-readme-") as tmp:
        shutil.copytree(ROOT / "meshes", Path(tmp) / "meshes")
        for e in EXAMPLES:
            if e.name in wanted:
                print(f"running {e.name}: {e.command}", file=sys.stderr, flush=True)
                blocks[e.name] = run(e, Path(tmp))
    return {k: v for k, v in blocks.items() if k in names}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare with README.md instead of writing it")
    parser.add_argument("--only", nargs="+", choices=NAMES, default=NAMES, help="these examples only")
    args = parser.parse_args(argv)
    text = README.read_text(encoding="utf-8")
    present = {m.group("name"): m.group("body") for m in BLOCK.finditer(text)}
    missing = [n for n in args.only if n not in present]
    if missing:
        raise SystemExit(f"README.md has no block for {', '.join(missing)}")
    fresh = generate(args.only)
    if args.check:
        exact = {e.name: e.exact for e in EXAMPLES}
        stale = []
        for name, block in fresh.items():
            same = block == present[name] if exact[name] else labels(block) == labels(present[name])
            if not same:
                stale.append(name)
                sys.stdout.writelines(difflib.unified_diff(present[name].splitlines(True), block.splitlines(True),
                                                           f"README.md ({name})", "fresh run"))
        if stale:
            print(f"README.md is stale: {', '.join(stale)} (python3 scripts/readme_examples.py rewrites it)")
            return 1
        return 0
    text = BLOCK.sub(lambda m: m.group(1) + fresh.get(m.group("name"), m.group("body")) + m.group(4), text)
    README.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
