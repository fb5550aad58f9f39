"""The README and the option reference say what the code does now: their examples and tables are
regenerated from real runs and the parser, and must match."""

from __future__ import annotations

import re
import subprocess
import sys

from tests.helpers import ROOT


def script(name: str, *args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "scripts" / name), *args], capture_output=True, text=True,
                          cwd=ROOT)


def test_readme_examples_match_a_fresh_run():
    """The planning, evaluation and export examples, run again: the README prints what they print."""
    done = script("readme_examples.py", "--check", "--only", "first-plan", "plan", "evaluate", "export")
    assert done.returncode == 0, done.stdout + done.stderr


def test_options_page_matches_the_parser():
    done = script("options_doc.py", "--check")
    assert done.returncode == 0, done.stdout + done.stderr


def test_readme_is_a_manual():
    """At most 300 lines, every example block filled, no dated progress notes."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 300
    blocks = re.findall(r"<!-- example ([\w-]+) -->\n(.*?)<!-- /example -->", text, re.S)
    assert len(blocks) >= 5 and all(body.startswith("```console\n$ coverplan ") for _, body in blocks)
    assert not re.search(r"\b(January|February|March|April|May|June|July|August|September|October|November|"
                         r"December) \d{1,2}\b(?!, 20\d\d)", text)
