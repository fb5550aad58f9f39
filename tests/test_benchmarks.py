"""Every benchmark script runs in --quick mode, prints its table and writes its JSON."""

import json
import runpy
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(p.stem for p in BENCH.glob("*.py") if p.stem not in ("common", "structure_scan"))  # helpers
REAL_PHOTOS = BENCH.parents[1] / "shared" / "data" / "real-photos"  # what check_real reads


@pytest.mark.parametrize("name", [pytest.param(s, marks=pytest.mark.xdist_group("benchmark_reconstruction"))
                                  if s == "reconstruction" else s for s in SCRIPTS])
def test_benchmark_quick(name, capsys, monkeypatch):
    if name == "check_real" and not REAL_PHOTOS.is_dir():
        pytest.skip("the real photo sets are not beside this checkout (../shared/data/real-photos)")
    monkeypatch.syspath_prepend(str(BENCH))
    monkeypatch.setattr(sys, "argv", [name, "--quick"])
    runpy.run_path(str(BENCH / f"{name}.py"), run_name="__main__")
    out = capsys.readouterr().out
    assert "written" in out
    result = BENCH / "results" / f"{name}_quick.json"
    data = json.loads(result.read_text())
    assert data["machine"] and data["rows"]
