"""A surveyor's first hour, through the command line: unit slips refused with a line that names
them (and planned under --force), garbage meshes named as such, inputs checked before outputs."""

from __future__ import annotations

import json

import pytest

from coverplan import load_scene
from coverplan.equipment.drones import DRONES
from coverplan.errors import ParameterError
from coverplan.planning.guards import BATTERIES, check_endurance
from coverplan.planning.settings import PlanSettings
from tests.helpers import MESHES
from tests.test_bad_input import assert_one_line_error, run

HOUSE = str(MESHES / "gabled_house.obj")
CAMERA = ["--camera", "phantom4pro"]


@pytest.mark.parametrize("args, words", [
    (["--gsd", "4", "--security", "3"], ["--gsd 4", "unit slip", "--gsd 0.004", "--force"]),
    (["--gsd", "0.4", "--security", "3"], ["--gsd 0.4", "unit slip", "--gsd 0.004"]),
    (["--gsd", "0.05", "--security", "3"], ["182 m from the surface", "unit slip"]),
    (["--gsd", "0.004", "--security", "300"], ["--security 300", "unit slip"]),
    (["--gsd", "0.004", "--security", "3", "--min-altitude", "400", "--max-altitude", "none"],
     ["--min-altitude 400", "unit slip"]),
])
def test_unit_slips_are_refused_with_the_value_named(tmp_path, capsys, args, words):
    code, _, err = run(capsys, "plan", HOUSE, *CAMERA, *args, "-o", tmp_path / "r.json")
    assert_one_line_error(code, err, *words)
    assert not (tmp_path / "r.json").exists()


def test_force_plans_what_looks_like_a_slip(tmp_path, capsys):
    code, _, err = run(capsys, "plan", HOUSE, *CAMERA, "--gsd", "0.4", "--security", "3", "--max-altitude", "none",
                       "--force", "-o", tmp_path / "r.json", "-q")
    assert code == 0, err
    route = json.loads((tmp_path / "r.json").read_text())
    assert route["params"]["gsd_m"] == 0.4
    # the photos are taken from as far as that GSD asks: over a kilometre away
    z = [w["position"][2] for w in route["waypoints"] if w["shot"]]
    assert max(z) > 500


def test_a_single_flight_beyond_every_battery_is_refused_unless_split():
    longest = BATTERIES * max(d.usable_flight_min for d in DRONES.values())
    settings = PlanSettings(gsd=0.004, security=3)
    with pytest.raises(ParameterError, match="as long as any drone flies"):
        check_endurance(longest + 1, settings, None)
    check_endurance(longest + 1, settings, 20.0)  # --max-flight-min splits it
    check_endurance(longest + 1, PlanSettings(gsd=0.004, security=3, force=True), None)
    check_endurance(longest - 1, settings, None)


@pytest.mark.parametrize("ext, words", [("stl", ["not a valid STL"]), ("obj", ["not a valid OBJ"])])
def test_random_bytes_are_not_a_mesh(tmp_path, capsys, ext, words):
    path = tmp_path / f"junk.{ext}"
    path.write_bytes(bytes(range(256)) * 20)
    code, _, err = run(capsys, "plan", path, *CAMERA, "--gsd", "0.004", "--security", "3", "-o", tmp_path / "r.json")
    assert_one_line_error(code, err, *words)


def test_real_stl_files_still_read(tmp_path, capsys):
    import trimesh
    mesh = load_scene(HOUSE).targets[0].mesh
    mesh.export(tmp_path / "b.stl")
    (tmp_path / "a.stl").write_text(trimesh.exchange.stl.export_stl_ascii(mesh))
    for name in ("a.stl", "b.stl"):
        assert sum(len(p.mesh.faces) for p in load_scene(tmp_path / name).targets) == len(mesh.faces)


def test_a_bad_building_id_is_told_before_an_existing_output(tmp_path, capsys):
    (tmp_path / "r.json").write_text("{}")
    code, _, err = run(capsys, "plan", MESHES / "citygml" / "lod2_buildings_v2.json.gz", "--building", "NOPE", *CAMERA,
                       "--gsd", "0.004", "--security", "3", "-o", tmp_path / "r.json")
    assert_one_line_error(code, err, "no city object with id")
    code, _, err = run(capsys, "plan", HOUSE, *CAMERA, "--gsd", "0.004", "--security", "3", "-o", tmp_path / "r.json")
    assert_one_line_error(code, err, "exists", "--force")


def test_every_option_of_every_subcommand_has_help():
    from coverplan.cli.main import build_parser

    parser = build_parser()
    lacking = [f"{name} {a.option_strings or a.dest}"
               for name, sub in parser._subparsers._group_actions[0].choices.items()
               for a in sub._actions if a.dest != "help" and not a.help]
    assert not lacking, lacking


def test_the_old_name_of_an_option_still_plans_and_says_the_new_one(tmp_path, capsys):
    code, _, err = run(capsys, "plan", HOUSE, *CAMERA, "--gsd", "0.004", "--security", "3", "--margin", "none",
                       "-o", tmp_path / "old.json", "-q")
    assert code == 0 and err.count("--margin is now --pose-margin") == 1
    code, _, err = run(capsys, "plan", HOUSE, *CAMERA, "--gsd", "0.004", "--security", "3", "--pose-margin", "none",
                       "-o", tmp_path / "new.json", "-q")
    assert code == 0 and not err.strip()
    old, new = (json.loads((tmp_path / n).read_text()) for n in ("old.json", "new.json"))
    assert old["waypoints"] == new["waypoints"] and new["params"]["pose_margin"]["kind"] == "none"


def test_evaluate_refuses_an_unknown_rule_as_the_rest_does():
    from trimesh.creation import box

    from coverplan import evaluate, get_camera, plan
    from coverplan.world.scene import scene_from_meshes

    scene = scene_from_meshes([box((6, 6, 4))])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, lp_time_limit=0)
    with pytest.raises(ParameterError, match="rule must be one of"):
        evaluate(route, scene, rule="strictest")
