"""``plan --existing`` (issue 32): photos already taken count toward the rules, and the new
flight takes only what they do not give.

The existing flight is the gabled house's own default plan without the photos of its south
side (a flight that missed one façade). Every claim is re-checked by the evaluator on fresh
samples with the old and new photos together, and on the old ones alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from coverplan import evaluate, load_scene, plan
from coverplan.cli import main
from coverplan.equipment.drones import get_drone
from coverplan.flight.route import Route
from coverplan.io.formats import export_route
from coverplan.sfm.photos import write_flight_photos
from tests.helpers import MESHES

HOUSE = MESHES / "gabled_house.obj"
GEO = ["--geo-origin", "48.1", "11.5", "500"]
PLAN = ["--drone", "phantom4pro", "--gsd", "0.004", "--security", "3"]


def _only(route: Route, keep: np.ndarray) -> Route:
    """The route's photos where ``keep`` (per shot), as a flight of their own."""
    rows = route.shots[keep]
    rows = np.concatenate([[0], rows, [len(route) - 1]])
    return Route(route.positions[rows], route.shot[rows], route.heading_deg[rows], route.pitch_deg[rows],
                 ["initial"] + ["coverage"] * (len(rows) - 2) + ["final"], route.camera, dict(route.params),
                 frame=route.frame)


@pytest.fixture(scope="module")
def missed_south(tmp_path_factory):
    out = tmp_path_factory.mktemp("existing")
    scene = load_scene(HOUSE, geodetic_origin=(48.1, 11.5, 500.0))
    drone = get_drone("phantom4pro")
    fresh = plan(scene, drone.camera, gsd=0.004, security=3, drone=drone)
    heading, pitch = fresh.heading_deg[fresh.shot], fresh.pitch_deg[fresh.shot]
    south = (np.abs((heading + 180.0) % 360.0 - 180.0) < 60.0) & (pitch > -60.0)  # facing north, at the south wall
    old = _only(fresh, ~south)
    old.save(out / "old.json")
    return out, scene, fresh, old


def test_the_new_flight_adds_what_the_old_one_missed_and_both_link(missed_south, capsys):
    out, scene, fresh, old = missed_south
    alone = evaluate(old, scene, spacing=0.25, seed=5)
    assert alone.coverage_pct < 95.0  # the south wall is missing
    assert main(["plan", str(HOUSE), *PLAN, *GEO, "--existing", str(out / "old.json"), "-o", str(out / "new.json")]) == 0
    text = capsys.readouterr().out
    assert "existing photos" in text and "this flight adds" in text
    new = Route.load(out / "new.json")
    assert new.shot.sum() <= 0.5 * fresh.shot.sum()
    assert new.params["existing_photos"]["count"] == int(old.shot.sum())
    # old and new together, judged on fresh samples by the evaluator: covered and one photo set
    both = evaluate(new, scene, spacing=0.25, seed=5)
    assert both.coverage_pct >= 99.0
    assert both.metrics["shot_graph"]["components"] == 1
    assert both.safe
    # the new flight alone does not cover the house: it counts on the old photos
    own = Route.from_dict({**new.to_dict(), "params": {k: v for k, v in new.params.items() if k != "existing_photos"}})
    assert evaluate(own, scene, spacing=0.25, seed=5).coverage_pct < 90.0


def test_an_exported_mission_and_tagged_photos_count_as_the_route_does(missed_south, tmp_path):
    out, scene, _fresh, old = missed_south
    [mission] = export_route(old, tmp_path / "old", ["qgc"])
    photos = tmp_path / "photos"
    write_flight_photos(old, scene, photos, width=160)
    counts = []
    for k, source in enumerate((out / "old.json", mission, photos)):
        target = tmp_path / f"new_{k}.json"
        assert main(["plan", str(HOUSE), *PLAN, *GEO, "--existing", str(source), "-o", str(target), "-q",
                     "--no-evaluate"]) == 0
        new = Route.load(target)
        assert new.params["existing_photos"]["count"] == int(old.shot.sum())
        positions = np.array(new.params["existing_photos"]["positions"])
        assert np.abs(positions - old.positions[old.shot]).max() < 0.05  # read back where they were taken
        counts.append(int(new.shot.sum()))
    assert max(counts) - min(counts) <= 2


def test_existing_photos_that_already_cover_everything_leave_nothing_to_fly(missed_south, tmp_path, capsys):
    out, _scene, fresh, _old = missed_south
    fresh.save(tmp_path / "all.json")
    # one-piece links: the braced rule may still brace a plan whose bracing ran out of budget
    code = main(["plan", str(HOUSE), *PLAN, *GEO, "--links", "one-piece", "--existing", str(tmp_path / "all.json"),
                 "-o", str(tmp_path / "none.json")])
    err = capsys.readouterr().err
    assert code == 2 and "nothing to fly" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_a_missing_existing_source_is_one_line(tmp_path, capsys):
    code = main(["plan", str(HOUSE), *PLAN, "--existing", str(tmp_path / "nope"), "-o", str(tmp_path / "r.json")])
    err = capsys.readouterr().err
    assert code == 2 and "no such file or folder" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "r.json").exists()
