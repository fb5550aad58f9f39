"""Where the drone may fly: an altitude ceiling above the ground under it (issue 34). Checked
on the route file's own waypoints, not on the planner's bookkeeping."""

from __future__ import annotations

import json

import numpy as np
import pytest

from coverplan import ParameterError, PlanSettings, evaluate, get_camera, plan
from coverplan.cli import main
from coverplan.flight.route import Route
from coverplan.world.scene import scene_from_meshes
from tests.helpers import box

CEILING = 25.0


@pytest.fixture(scope="module")
def tower(tmp_path_factory):
    """An 8 x 8 x 45 m tower planned for a Phantom 4 Pro at 1 cm/px under a 25 m ceiling."""
    folder = tmp_path_factory.mktemp("tower")
    path = folder / "tower.obj"
    box(0, 0, 0, 8, 8, 45).export(path)
    out = folder / "tower.json"
    assert main(["plan", str(path), "--camera", "phantom4pro", "--gsd", "0.01", "--security", "4",
                 "--max-altitude", str(CEILING), "--quiet", "-o", str(out)]) == 0
    return path, out, Route.load(out)


def test_a_tower_taller_than_the_ceiling_is_flown_below_it(tower):
    _path, _out, route = tower
    assert route.params["max_altitude_m"] == CEILING
    assert route.positions[:, 2].max() <= CEILING + 1e-6  # flat ground at 0: heights are altitudes
    assert route.shot.sum() > 10


def test_the_top_it_cannot_reach_is_reported(tower, capsys):
    path, out, route = tower
    above = [u for u in route.uncovered if "ceiling" in u["reason"]]
    assert above, {u["reason"] for u in route.uncovered}
    # What the ceiling hides lies high up: the roof (45 m) and the top of the walls.
    assert min(np.asarray(u["position"])[2] for u in above) > CEILING
    capsys.readouterr()
    assert main(["evaluate", str(out), "--target", str(path), "--json"]) == 0
    m = json.loads(capsys.readouterr().out)
    assert m["safe"] and m["above_ceiling_count"] == 0 and m["max_altitude_m"] == CEILING
    assert m["highest_above_ground_m"] <= CEILING + 1e-6
    assert m["coverage_pct"] >= 99.5  # of what can be reached below the ceiling
    reasons = {g["reason"]: g["area_m2"] for g in m["unreachable"]}
    hidden = sum(a for r, a in reasons.items() if "ceiling" in r)
    assert hidden >= 0.95 * 64.0  # the 64 m2 roof, as the samples measure it


def test_the_evaluator_judges_a_route_against_the_ceiling_it_records():
    scene = scene_from_meshes([box(0, 0, 0, 10, 8, 6)])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)
    assert route.params["max_altitude_m"] == 120.0 and evaluate(route, scene).safe
    route.params["max_altitude_m"] = 5.0  # below the roof shots it flies
    m = evaluate(route, scene).metrics
    assert not m["safe"] and m["above_ceiling_count"] > 0


def test_evaluate_judges_any_route_against_a_ceiling_given(tower, capsys):
    path, out, _route = tower
    capsys.readouterr()
    assert main(["evaluate", str(out), "--target", str(path), "--max-altitude", "20", "--json"]) == 0
    m = json.loads(capsys.readouterr().out)
    assert not m["safe"] and m["above_ceiling_count"] > 0 and m["max_altitude_m"] == 20.0


def test_a_ceiling_below_the_minimum_altitude_is_refused(tmp_path, capsys):
    with pytest.raises(ParameterError, match="not above the minimum altitude"):
        PlanSettings(gsd=0.004, security=3.0, max_altitude=2.5)
    path = tmp_path / "b.obj"
    box(0, 0, 0, 10, 8, 6).export(path)
    capsys.readouterr()
    assert main(["plan", str(path), "--camera", "phantom4pro", "--gsd", "0.004", "--security", "3",
                 "--max-altitude", "2", "-o", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--max-altitude" in err
    with pytest.raises(SystemExit) as stop:  # argparse's own one-line error
        main(["plan", str(path), "--camera", "phantom4pro", "--gsd", "0.004", "--security", "3",
              "--max-altitude", "high", "-o", str(tmp_path / "r.json")])
    assert stop.value.code == 2 and "expected metres or 'none'" in capsys.readouterr().err
