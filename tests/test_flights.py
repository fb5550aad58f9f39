"""Drone profiles, the flight-time model and battery-sized flights."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import trimesh

from coverplan import evaluate, load_scene, plan
from coverplan.cli import main
from coverplan.equipment.drones import DRONES, get_drone, with_gimbal
from coverplan.equipment.flighttime import FlightModel
from coverplan.errors import ParameterError
from coverplan.flight.route import Route
from coverplan.io import export_route
from coverplan.world.scene import scene_from_meshes
from tests.helpers import MESHES, box
from tests.independent import polyline_min_distance

LIMIT_MIN = 3.0


def test_segment_times_follow_the_speed_profile():
    m = FlightModel(cruise_speed=5.0, acceleration=2.0, ascent_speed=3.0, descent_speed=2.0)
    a = np.zeros((5, 3))
    b = np.array([[100, 0, 0], [1, 0, 0], [0, 0, 30], [40, 0, 30], [0, 0, -10]], dtype=float)
    # cruise 100 m at 5 m/s plus 2 x 1.25 s lost accelerating and braking; 1 m never reaches
    # 5 m/s (triangle: 2 sqrt(1/2)); 30 m up at 3 m/s; 50 m slope capped by the climb rate
    # (vertical 3 of the 5 m/s along it); 10 m down at 2 m/s.
    expected = [100 / 5 + 5 / 2, 2 * math.sqrt(0.5), 30 / 3 + 3 / 2, 50 / 5 + 5 / 2, 10 / 2 + 2 / 2]
    np.testing.assert_allclose(m.segment_seconds(a, b), expected, rtol=1e-12)


def test_rotations_take_the_short_way_and_can_outlast_the_leg():
    m = FlightModel(yaw_rate_deg=60.0, gimbal_rate_deg=30.0)
    np.testing.assert_allclose(m.rotation_seconds([350, 10, 190], [0, -60, -60]), [2.0, 3.0])
    parts = m.flight_seconds([[0, 0, 10], [0.5, 0, 10]], [False, True], [0, 180], [0, 0], height_m=10)
    assert parts["rotation_wait_s"] == pytest.approx(3.0 - 2 * math.sqrt(0.5 / 2.0))
    assert parts["total_s"] == pytest.approx(sum(v for k, v in parts.items() if k != "total_s"))
    assert parts["takeoff_landing_s"] == pytest.approx(2 * 10 + 10 / 3 + 10 / 1.5)


def test_profiles_hold_together():
    for name, d in DRONES.items():
        assert get_drone(name.upper()) is d
        lo, hi = d.gimbal_pitch_deg
        assert -90 <= lo < 0 < hi <= 90
        assert 0 < d.usable_flight_min < d.rated_flight_min and d.cruise_speed <= d.max_speed
        assert d.sources, name
    assert get_drone("m3e").wpml == (77, 0, 66) and get_drone("m350-p1").wpml[0] == 89
    with pytest.raises(ParameterError, match="unknown drone 'x'.*m3e"):
        get_drone("x")
    with pytest.raises(ParameterError, match="outside what"):
        get_drone("phantom4pro").flight_model(20.0)


@pytest.fixture(scope="module")
def ring():
    scene = load_scene(MESHES / "ring_prism.obj", crs="EPSG:25832")
    drone = get_drone("m3e")
    single = plan(scene, drone.camera, gsd=0.004, security=3.0, drone=drone)
    split = plan(scene, drone.camera, gsd=0.004, security=3.0, drone=drone, max_flight_min=LIMIT_MIN)
    return scene, drone, single, split


def assert_the_same_photos_safely(split, single, scene):
    """Exactly the one-flight plan's photos, each once, and a path that keeps the security
    distance by an independent distance check."""
    mine = np.round(np.column_stack([split.positions, split.heading_deg])[split.shot], 6)
    theirs = np.round(np.column_stack([single.positions, single.heading_deg])[single.shot], 6)
    assert len(np.unique(mine, axis=0)) == len(mine)
    np.testing.assert_array_equal(np.unique(mine, axis=0), np.unique(theirs, axis=0))
    meshes = [p.mesh for p in scene.parts]
    assert polyline_min_distance(split.positions, meshes, step=0.5) >= split.security - 1e-6


def test_one_flight_when_it_fits_the_battery(ring):
    _scene, drone, single, _split = ring
    assert single.n_flights == 1 and single.params["max_flight_min"] == drone.usable_flight_min
    assert single.metrics["flights"][0]["minutes"] <= drone.usable_flight_min


def test_battery_flights_fit_return_home_and_share_the_shots(ring):
    scene, drone, single, split = ring
    assert split.n_flights >= 2
    model = drone.flight_model()
    start = split.positions[0]
    ground = split.params["ground_z_m"]
    corner = ~split.straight_points()  # the turn points between photos are flown straight through
    for rows in split.flight_rows():
        p = split.positions[rows]
        stops = rows[corner[rows]]
        seconds = model.flight_seconds(split.positions[stops], split.shot[stops], split.heading_deg[stops],
                                       split.pitch_deg[stops], p[0, 2] - ground)["total_s"]
        assert seconds <= LIMIT_MIN * 60 + 1e-6
        np.testing.assert_allclose(p[0], start)
        np.testing.assert_allclose(p[-1], start)
        assert split.shot[rows].any()
    assert_the_same_photos_safely(split, single, scene)
    assert evaluate(split, scene).safe
    assert split.path_length > single.path_length  # each extra flight flies out and back


def test_flights_survive_the_route_file_and_export_one_file_each(ring, tmp_path):
    _scene, _drone, _single, split = ring
    split.save(tmp_path / "r.json")
    back = Route.load(tmp_path / "r.json")
    np.testing.assert_array_equal(back.flight, split.flight)
    written = export_route(back, tmp_path / "r", ["qgc", "wpml"], speed=5.0)
    names = sorted(p.name for p in written)
    n = split.n_flights
    assert names == sorted([f"r.f{k}.plan" for k in range(1, n + 1)] + [f"r.f{k}.kmz" for k in range(1, n + 1)])
    for k in range(1, n + 1):
        assert back.flight_route(k).shot.sum() == split.metrics["flights"][k - 1]["shots"]


def test_flights_split_to_fit_a_mission_item_limit(ring, tmp_path):
    """With a limit of a third of the one-flight plan's mission items (PX4 keeps 500), the
    flights come apart so that each exported .plan holds at most that many, read back from the
    files; together they take the one-flight plan's photos, each once, safely."""
    scene, drone, single, _split = ring
    one = export_route(single, tmp_path / "one", ["qgc"], firmware="ardupilot")[0]
    single_items = len(json.loads(one.read_text())["mission"]["items"])
    limit = single_items // 3
    split = plan(scene, drone.camera, gsd=0.004, security=3.0, drone=drone, max_flight_min=1e6,
                 max_mission_items=limit)
    assert split.params["max_mission_items"] == limit
    assert split.n_flights >= 3
    files = export_route(split, tmp_path / "split", ["qgc"])
    counts = [len(json.loads(f.read_text())["mission"]["items"]) for f in files]
    assert len(counts) == split.n_flights and max(counts) <= limit
    assert_the_same_photos_safely(split, single, scene)


def test_plan_exporting_for_px4_keeps_each_flight_within_500_items(tmp_path, capsys):
    """The ring's one flight for a Mavic 3 Enterprise comes to over 900 mission items, which
    PX4 refuses; ``plan --export qgc`` (PX4 by default) splits it into flights that fit."""
    out = tmp_path / "ring.json"
    code = main(["plan", str(MESHES / "ring_prism.obj"), "--drone", "m3e", "--gsd", "0.004", "--security", "3",
                 "--crs", "EPSG:25832", "--export", "qgc", "-o", str(out), "--no-evaluate"])
    assert code == 0
    assert "min and 500 mission items per flight" in capsys.readouterr().out
    route = Route.load(out)
    assert route.params["max_mission_items"] == 500 and route.n_flights >= 2
    counts = [len(json.loads((tmp_path / f"ring.f{k}.plan").read_text())["mission"]["items"])
              for k in range(1, route.n_flights + 1)]
    assert max(counts) <= 500 and sum(counts) > 500


def test_a_gimbal_that_cannot_look_up_never_points_up():
    """Under the overhang, photos must look up (max incidence 45 deg); a gimbal that stops at
    level leaves the underside unreachable, saying so, and plans the rest."""
    tower, block = box(0, 0, 0, 6, 6, 8), box(-3, -3, 8, 9, 9, 11)
    scene = scene_from_meshes([trimesh.boolean.union([tower, block])])
    underside = 12 * 12 - 6 * 6
    m3e = get_drone("m3e")
    free = plan(scene, m3e.camera, gsd=0.002, security=1.5, drone=m3e, max_incidence_deg=45)
    assert free.pitch_deg[free.shot].max() > 0 and not free.uncovered
    level = with_gimbal(m3e, -90, 0)
    route = plan(scene, level.camera, gsd=0.002, security=1.5, drone=level, max_incidence_deg=45)
    assert route.pitch_deg[route.shot].max() <= 1e-9
    blocked = [u for u in route.uncovered if u["reason"] == "visible only at a gimbal pitch outside its range"]
    assert sum(u["area_m2"] for u in blocked) == pytest.approx(underside, rel=0.03)
    assert all(abs(u["position"][2] - 8.0) < 1e-6 for u in blocked)
    ev = evaluate(route, scene)
    assert ev.safe and ev.coverage_pct >= 99.5


def test_gimbal_range_beyond_the_drone_is_refused():
    scene = scene_from_meshes([box(0, 0, 0, 6, 6, 6)])
    p4 = get_drone("phantom4pro")
    with pytest.raises(ParameterError, match="beyond the DJI Phantom 4 Pro"):
        plan(scene, p4.camera, gsd=0.004, security=2.0, drone=p4, gimbal_pitch_range_deg=(-90, 45))
