"""A start point is given in the input models' coordinates and moves with them; a start far
from the target is refused instead of planning a 10,000 km flight."""

from __future__ import annotations

import json

import numpy as np

from coverplan.cli import main
from tests.helpers import UTM_EAST, UTM_NORTH, utm_house

EAST, NORTH, BASE = UTM_EAST, UTM_NORTH, 513.0
ARGS = ["--camera", "phantom4pro", "--gsd", "0.004", "--security", "3", "--crs", "EPSG:25832",
        "--quiet", "--no-evaluate"]


def _house(tmp_path):
    return utm_house(tmp_path, base=BASE)


def test_start_in_model_coordinates_moves_with_the_scene(tmp_path):
    start = [EAST - 15.0, NORTH - 15.0, BASE + 4.0]
    out = tmp_path / "r.json"
    assert main(["plan", str(_house(tmp_path)), *ARGS, "--start", *map(str, start), "-o", str(out)]) == 0
    route = json.loads(out.read_text())
    origin = np.array(route["frame"]["origin"])
    assert np.abs(origin).max() > 1e5  # the scene was moved to a local origin ...
    first = np.array(route["waypoints"][0]["position"]) + origin  # ... and the start with it
    np.testing.assert_allclose(first, start, atol=1e-3)
    assert route["metrics"]["path_length_m"] < 2_000


def test_start_far_from_the_target_is_refused(tmp_path, capsys):
    # The mix-up of the issue: local metres given beside a mesh in UTM coordinates.
    code = main(["plan", str(_house(tmp_path)), *ARGS, "--start", "-15", "-15", "4", "-o", str(tmp_path / "r.json")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "km from the target" in err and "same coordinates as the input" in err
