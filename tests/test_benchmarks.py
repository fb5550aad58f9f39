"""Every benchmark script runs in --quick mode, prints its table and writes its JSON."""

import json
import runpy
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(p.stem for p in BENCH.glob("*.py") if p.stem not in ("common", "structure_scan"))  # helpers


@pytest.mark.parametrize("name", [pytest.param(s, marks=pytest.mark.xdist_group("benchmark_reconstruction"))
                                  if s == "reconstruction" else s for s in SCRIPTS])
def test_benchmark_quick(name, capsys, monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))
    monkeypatch.setattr(sys, "argv", [name, "--quick"])
    runpy.run_path(str(BENCH / f"{name}.py"), run_name="__main__")
    out = capsys.readouterr().out
    assert "written" in out
    result = BENCH / "results" / f"{name}_quick.json"
    data = json.loads(result.read_text())
    assert data["machine"] and data["rows"]


def test_triangle_groups_follow_links_that_share_a_triangle_side(monkeypatch):
    import numpy as np

    monkeypatch.syspath_prepend(str(BENCH))
    from link_truth import triangle_groups

    def graph(n, edges):
        a = np.zeros((n, n), dtype=bool)
        for x, y in edges:
            a[x, y] = a[y, x] = True
        return a

    # two triangles meeting in one photo: the mapper cannot carry one into the other
    assert triangle_groups(graph(5, [(0, 1), (1, 2), (0, 2), (2, 3), (3, 4), (2, 4)])) == [[0, 1, 2], [2, 3, 4]]
    # a strip of triangles, each sharing a side with the next, and a dangling chain
    strip = [(0, 1), (1, 2), (0, 2), (2, 3), (1, 3), (3, 4), (2, 4), (4, 5), (5, 6)]
    assert triangle_groups(graph(7, strip)) == [[0, 1, 2, 3, 4]]
    # a ring of photos linked to their neighbours only has no triangle at all
    assert triangle_groups(graph(6, [(k, (k + 1) % 6) for k in range(6)])) == []
