"""Bad input gets one line naming the problem and exit status 2, never a traceback."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from conftest import MESHES, box

from coverplan.cli import main

L = str(MESHES / "l_prism.obj")


def run(capsys, *args) -> tuple[int, str, str]:
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:  # argparse
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_one_line_error(code, err, *words):
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])


def good_route(tmp_path, **change):
    d = {"format": "coverplan-route", "version": 1, "units": "m",
         "frame": {"crs": None, "origin": [0, 0, 0]},
         "camera": {"sensor_width_mm": 13.2, "sensor_height_mm": 8.8, "focal_length_mm": 8.8,
                    "image_width_px": 5472, "image_height_px": 3648},
         "params": {"gsd_m": 0.004, "security_m": 3.0},
         "waypoints": [{"position": [0, 0, 5], "shot": True, "heading_deg": 0, "gimbal_pitch_deg": 0,
                        "leg": "coverage"}]}
    d.update(change)
    path = tmp_path / "route.json"
    path.write_text(json.dumps(d) if not isinstance(change.get("raw"), str) else change["raw"])
    return path


def test_missing_route_file(capsys, tmp_path):
    code, _, err = run(capsys, "evaluate", tmp_path / "nope.json", "--target", L)
    assert_one_line_error(code, err, "nope.json", "no such file")


def test_missing_mesh_file(capsys, tmp_path):
    code, _, err = run(capsys, "evaluate", good_route(tmp_path), "--target", tmp_path / "gone.obj")
    assert_one_line_error(code, err, "gone.obj", "no such file")


def test_empty_mesh_file(capsys, tmp_path):
    empty = tmp_path / "empty.stl"
    empty.write_bytes(b"")
    code, _, err = run(capsys, "evaluate", good_route(tmp_path), "--target", empty)
    assert_one_line_error(code, err, "empty.stl", "empty")


@pytest.mark.parametrize("name, content", [("junk.stl", b"\x00\x01garbage" * 40),
                                           ("junk.obj", b"this is not an obj file\n"),
                                           ("junk.ply", b"ply\nformat nonsense\n")])
def test_unreadable_mesh_file(capsys, tmp_path, name, content):
    bad = tmp_path / name
    bad.write_bytes(content)
    code, _, err = run(capsys, "evaluate", good_route(tmp_path), "--target", bad)
    assert_one_line_error(code, err, name)


def test_unsupported_format(capsys, tmp_path):
    odd = tmp_path / "model.xyz"
    odd.write_text("1 2 3\n")
    code, _, err = run(capsys, "evaluate", good_route(tmp_path), "--target", odd)
    assert_one_line_error(code, err, "model.xyz", "unsupported format")


def test_mesh_without_faces(capsys, tmp_path):
    pts = tmp_path / "points.obj"
    pts.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    code, _, err = run(capsys, "evaluate", good_route(tmp_path), "--target", pts)
    assert_one_line_error(code, err, "points.obj")


@pytest.mark.parametrize("change, words", [
    ({"format": "something-else"}, ["route.json", "format"]),
    ({"waypoints": []}, ["route.json", "no waypoints"]),
    ({"raw": "{not json"}, ["route.json", "json"]),
    ({"params": {"gsd_m": -1, "security_m": 3}}, ["route.json", "gsd_m"]),
    ({"params": {"gsd_m": 0, "security_m": 3}}, ["route.json", "gsd_m"]),
])
def test_route_that_is_not_a_route(capsys, tmp_path, change, words):
    code, _, err = run(capsys, "evaluate", good_route(tmp_path, **change), "--target", L)
    assert_one_line_error(code, err, *words)


def test_route_with_nan_coordinates(capsys, tmp_path):
    path = good_route(tmp_path)
    path.write_text(path.read_text().replace("[0, 0, 5]", "[0, NaN, 5]"))
    code, _, err = run(capsys, "evaluate", path, "--target", L)
    assert_one_line_error(code, err, "route.json", "waypoint 0 position")


def test_route_missing_waypoints_key(capsys, tmp_path):
    path = good_route(tmp_path)
    d = json.loads(path.read_text())
    del d["waypoints"]
    path.write_text(json.dumps(d))
    code, _, err = run(capsys, "evaluate", path, "--target", L)
    assert_one_line_error(code, err, "route.json", "waypoints")


@pytest.mark.parametrize("spacing", ["0", "-2"])
def test_non_positive_spacing(capsys, tmp_path, spacing):
    code, _, err = run(capsys, "evaluate", good_route(tmp_path), "--target", L, "--spacing", spacing)
    assert_one_line_error(code, err, "spacing")


@pytest.mark.parametrize("camera_args, words", [
    (["--sensor-mm", "0", "8.8", "--focal-mm", "8.8", "--image-px", "5472", "3648"], ["sensor_width"]),
    (["--sensor-mm", "13.2", "8.8", "--focal-mm", "-8.8", "--image-px", "5472", "3648"], ["focal"]),
    (["--camera", "nosuchcam"], ["unknown camera preset", "phantom4pro"]),
    (["--sensor-mm", "13.2", "8.8"], ["camera"]),
])
def test_bad_camera_on_plan(capsys, tmp_path, camera_args, words):
    code, _, err = run(capsys, "plan", L, *camera_args, "--gsd", "0.004", "--security", "3",
                       "-o", tmp_path / "r.json")
    assert_one_line_error(code, err, *words)


@pytest.mark.parametrize("gsd", ["0", "-0.01"])
def test_non_positive_gsd_on_plan(capsys, tmp_path, gsd):
    code, _, err = run(capsys, "plan", L, "--camera", "phantom4pro", "--gsd", gsd, "--security", "3",
                       "-o", tmp_path / "r.json")
    assert_one_line_error(code, err, "gsd")


def test_argparse_errors_are_one_line_too(capsys, tmp_path):
    code, _, err = run(capsys, "plan", L, "--camera", "phantom4pro", "--security", "3", "-o", tmp_path / "r.json")
    assert_one_line_error(code, err, "--gsd")


def test_real_process_prints_no_traceback(tmp_path):
    """Through the installed console entry point, as a user runs it."""
    bad = tmp_path / "broken.obj"
    bad.write_text("f 1 2 3\n")
    proc = subprocess.run([sys.executable, "-m", "coverplan.cli", "evaluate", str(tmp_path / "x.json"),
                           "--target", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_nan_vertices_are_refused(capsys, tmp_path):
    mesh = box(0, 0, 0, 10, 10, 10)
    path = tmp_path / "nan.obj"
    text = mesh.export(file_type="obj")
    lines = text.splitlines()
    for k, line in enumerate(lines):
        if line.startswith("v "):
            lines[k] = "v nan 0 0"
            break
    path.write_text("\n".join(lines))
    code, _, err = run(capsys, "evaluate", good_route(tmp_path), "--target", path)
    assert_one_line_error(code, err, "nan")
