"""A route remembers its scene: `evaluate`, `report` and `export` run on the route file alone,
with the same scene (city building, obstacles, merge) the plan was made in, and a clear line
when a recorded file moved or changed."""

from __future__ import annotations

import json
import shutil

from coverplan.cli import main
from tests.helpers import MESHES
from tests.test_bad_input import PLAN, assert_one_line_error, run

CITY = MESHES / "citygml" / "lod2_buildings_v2.json.gz"
HOUSE = "FZK_GUID_1F3E679D-E226-4535-926C-7390977FB25A"


def _project(tmp_path, capsys, *extra, meshes=("gabled_house.obj",)):
    folder = tmp_path / "project"
    folder.mkdir()
    for name in meshes:
        shutil.copy(MESHES / name, folder / name)
    code, _, err = run(capsys, "plan", folder / meshes[0], *extra, *PLAN, "-o", folder / "house.json", "-q")
    assert code == 0, err
    return folder


def _metrics(capsys, *args):
    code, out, err = run(capsys, "evaluate", *args, "--json")
    assert code == 0, err
    return json.loads(out)


def test_evaluate_and_report_from_the_route_alone_after_the_folder_moved(tmp_path, capsys):
    folder = _project(tmp_path, capsys)
    record = json.loads((folder / "house.json").read_text())["params"]["scene"]
    assert record["files"]["targets"][0]["path"] == "gabled_house.obj"  # relative: the folder moves whole
    given = _metrics(capsys, folder / "house.json", "--target", folder / "gabled_house.obj")
    moved = folder.rename(tmp_path / "moved")
    alone = _metrics(capsys, moved / "house.json")
    assert alone["coverage_pct"] == given["coverage_pct"] and alone["safe"]
    assert alone["min_clearance_m"] == given["min_clearance_m"]
    code, out, err = run(capsys, "report", moved / "house.json", "-o", tmp_path / "r.html", "-q")
    assert code == 0, err
    assert (tmp_path / "r.html").stat().st_size > 10_000


def test_a_moved_or_changed_scene_file_is_named(tmp_path, capsys):
    folder = _project(tmp_path, capsys)
    (folder / "gabled_house.obj").rename(tmp_path / "elsewhere.obj")
    code, _, err = run(capsys, "evaluate", folder / "house.json")
    assert_one_line_error(code, err, "gabled_house.obj", "not there", "--target")
    shutil.copy(MESHES / "square_prism.obj", folder / "gabled_house.obj")  # same name, another building
    code, _, err = run(capsys, "report", folder / "house.json", "-o", tmp_path / "r.html")
    assert_one_line_error(code, err, "has changed", "--target")
    # the scene given again is judged as it is
    code, _, err = run(capsys, "evaluate", folder / "house.json", "--target", tmp_path / "elsewhere.obj")
    assert code == 0, err


def test_scene_options_alone_are_refused(tmp_path, capsys):
    folder = _project(tmp_path, capsys)
    code, _, err = run(capsys, "evaluate", folder / "house.json", "--units", "cm")
    assert_one_line_error(code, err, "--units needs --target")


def test_city_building_obstacles_and_merge_are_recorded(tmp_path, capsys):
    folder = tmp_path / "city"
    folder.mkdir()
    shutil.copy(CITY, folder / CITY.name)
    code, _, err = run(capsys, "plan", folder / CITY.name, "--building", HOUSE, *PLAN, "--merge-obstacles-within", "0.5",
                       "-o", folder / "house.json", "-q")
    assert code == 0, err
    record = json.loads((folder / "house.json").read_text())["params"]["scene"]
    assert record["options"]["building"] == HOUSE and record["options"]["merge_obstacles_within"] == 0.5
    given = _metrics(capsys, folder / "house.json", "--target", folder / CITY.name, "--building", HOUSE)
    alone = _metrics(capsys, folder / "house.json")
    # the same building with the same neighbours: the same clearance to them
    assert alone["min_clearance_m"] == given["min_clearance_m"]
    assert alone["coverage_pct"] == given["coverage_pct"]


GEO = ("--geo-origin", "49.01", "8.42", "115")


def test_export_needs_no_scene(tmp_path, capsys):
    folder = _project(tmp_path, capsys, *GEO)
    code, out, err = run(capsys, "export", folder / "house.json", "--format", "csv,wpl")
    assert code == 0, err
    assert (folder / "house.csv").exists() and (folder / "house.waypoints").exists()


def test_a_mission_from_another_app_needs_the_scene(tmp_path, capsys):
    folder = _project(tmp_path, capsys, *GEO)
    assert main(["export", str(folder / "house.json"), "--format", "wpl"]) == 0
    capsys.readouterr()
    code, _, err = run(capsys, "evaluate", folder / "house.waypoints", *PLAN)
    assert_one_line_error(code, err, "mission from another app", "--target")


def test_export_writes_every_format_that_fits_and_names_the_others(tmp_path, capsys, monkeypatch):
    import coverplan.io.qgc as qgc

    folder = _project(tmp_path, capsys, *GEO)
    monkeypatch.setattr(qgc, "PX4_MISSION_ITEMS", 10)  # the house's flight no longer fits PX4
    code, out, err = run(capsys, "export", folder / "house.json", "--format", "qgc,litchi,kml")
    assert code == 0, err
    assert "not written as qgc" in err and "PX4 keeps at most 10" in err
    assert (folder / "house.litchi.csv").exists() and (folder / "house.kml").exists()
    assert not (folder / "house.plan").exists()
    code, _, err = run(capsys, "export", folder / "house.json", "--format", "qgc", "-o", tmp_path / "only")
    assert code == 2 and "no format could be written" in err and "Traceback" not in err


def test_the_own_csv_export_reads_back_in_evaluate(tmp_path, capsys):
    folder = _project(tmp_path, capsys, *GEO)
    assert main(["export", str(folder / "house.json"), "--format", "csv"]) == 0
    capsys.readouterr()
    route = _metrics(capsys, folder / "house.json")
    mission = _metrics(capsys, folder / "house.csv", "--target", folder / "gabled_house.obj", *GEO, *PLAN)
    assert mission["shots"] == route["shots"]
    # the same photos, rounded to the file's decimals: the same coverage within a sample or two
    assert abs(mission["coverage_pct"] - route["coverage_pct"]) < 0.5
    assert mission["safe"]
