"""Photos in passing (issue 33): where the drone flies through, how fast, and what the exports
ask of the autopilot.

The pass plan's promises are re-derived here from their definitions, not from its code:
blur from the speed, the range and the pixel angle; the photo interval from the leg times;
braking from the speed changes; the cut corner's distance from the planned point; the flown
path's clearance by trimesh's closest points; the exports read back by lxml, pymavlink's own
waypoint loader and MAVSDK's QGroundControl importer with an upload to a MAVSDK autopilot.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coverplan import evaluate, load_scene, plan
from coverplan.cli import main
from coverplan.equipment.drones import get_drone
from coverplan.equipment.flighttime import FlightModel
from coverplan.errors import ParameterError
from coverplan.flight.corners import flown_path, turn_angles
from coverplan.flight.passing import PassRules, pass_plan
from coverplan.flight.route import Route
from tests.helpers import MESHES, mavsdk_upload
from tests.independent import polyline_min_distance

PIXEL = 3.3e-3 / 12.29  # rad per pixel, a Mavic 3 Enterprise's
SHUTTER, INTERVAL = 1.0 / 500.0, 0.7


def _plan(p, shot, heading=None, pitch=None, near=30.0, model=FlightModel(), rules=PassRules()):
    n = len(p)
    heading = np.zeros(n) if heading is None else heading
    pitch = np.zeros(n) if pitch is None else pitch
    return pass_plan(model, p, shot, heading, pitch, np.full(n, near), pixel_angle=PIXEL, shutter_s=SHUTTER,
                     photo_interval_s=INTERVAL, rules=rules)


def _photo_gaps(plan, shot) -> np.ndarray:
    """Seconds from each photo to the next: the legs between them and the hovers after the first."""
    t = np.concatenate([[0.0], np.cumsum(plan.leg_seconds)]) + np.cumsum(plan.hover_seconds) - plan.hover_seconds
    return np.diff(t[shot])


def test_a_straight_facade_run_is_flown_through_within_a_pixel_of_blur():
    x = np.arange(0.0, 81.0, 4.0)  # 4 m apart: the photo interval allows 5.7 m/s, blur binds
    p = np.column_stack([x, np.zeros_like(x), np.full_like(x, 10.0)])
    shot = np.ones(len(p), bool)
    shot[[0, -1]] = False
    plan = _plan(p, shot, heading=np.full(len(p), 90.0))
    assert plan.passing[1:-1].all() and not plan.passing[[0, -1]].any()
    blur_px = plan.speed * SHUTTER / (30.0 * PIXEL)
    assert blur_px[shot].max() <= 1.0 + 1e-9 and blur_px[shot].max() > 0.9  # the bound, and it binds
    assert np.allclose(np.linalg.norm(plan.offset, axis=1), 0.0)  # no turn: taken on the point
    assert _photo_gaps(plan, shot).min() >= INTERVAL - 1e-9
    stopping = FlightModel().flight_seconds(p, shot, np.full(len(p), 90.0), np.zeros(len(p)), 10.0)
    assert plan.leg_seconds.sum() + plan.hover_seconds.sum() < 0.5 * (stopping["total_s"] - stopping["takeoff_landing_s"])


def test_reversals_stop_and_square_corners_pass_slowly_near_the_point():
    p = np.array([[0, 0, 10], [10, 0, 10], [10, 10, 10], [20, 10.5, 10], [0, 11, 10], [0, 0, 10.0]])
    shot = np.array([0, 1, 1, 1, 1, 0], bool)
    plan = _plan(p, shot)
    theta = turn_angles(p)
    assert theta[3] > 170 and not plan.passing[3]  # turning back: a stop
    assert plan.passing[1] and plan.passing[2]  # square corners
    rules = PassRules()
    offset = np.linalg.norm(plan.offset, axis=1)
    assert offset[plan.passing].max() <= rules.max_photo_offset_m + 1e-9
    # on the arc tangent at the damping distance d: radius d / tan(theta/2), sideways acceleration a
    d = plan.damping_m[1]
    assert plan.speed[1] <= np.sqrt(FlightModel().acceleration * d / np.tan(np.radians(theta[1]) / 2)) + 1e-9
    assert offset[1] == pytest.approx(d * np.tan(np.radians(theta[1]) / 4))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-30, 30), st.floats(-30, 30), st.floats(3, 40)), min_size=3, max_size=14),
       st.lists(st.booleans(), min_size=14, max_size=14), st.lists(st.floats(0, 359), min_size=14, max_size=14),
       st.floats(2.0, 40.0))
def test_every_pass_plan_keeps_its_rules(points, shots, headings, near):
    p = np.array(points, dtype=float)
    n = len(p)
    shot = np.array(shots[:n])
    shot[[0, -1]] = False
    heading = np.array(headings[:n])
    model, rules = FlightModel(), PassRules()
    plan = _plan(p, shot, heading=heading, near=near, model=model, rules=rules)
    length = np.linalg.norm(np.diff(p, axis=0), axis=1)
    v = plan.speed
    assert v[0] == 0 and v[-1] == 0
    # no faster change of speed than the acceleration allows
    assert (np.abs(np.diff(v ** 2)) <= 2 * model.acceleration * length + 1e-6).all()
    # blur at photos from translation alone within the bound
    assert (v[shot] * SHUTTER / (near * PIXEL) <= rules.max_blur_px + 1e-9).all()
    assert _photo_gaps(plan, shot).min(initial=np.inf) >= INTERVAL - 1e-6
    assert (plan.leg_seconds >= model.rotation_seconds(heading, np.zeros(n)) - 1e-9).all()
    offset = np.linalg.norm(plan.offset, axis=1)
    assert (offset[shot] <= rules.max_photo_offset_m + 1e-9).all()
    assert (turn_angles(p)[plan.passing] <= rules.max_turn_deg + 1e-9).all()
    # the flown path leaves each leg no farther than the largest cut corner
    path = flown_path(p, plan.damping_m)
    far = offset.max(initial=0.0)
    seg_a, seg_b = p[:-1], p[1:]
    ab = seg_b - seg_a
    t = np.clip(np.einsum("mkj,kj->mk", path[:, None, :] - seg_a[None], ab) / np.maximum((ab ** 2).sum(1), 1e-12),
                0, 1)
    nearest = np.linalg.norm(path[:, None, :] - (seg_a[None] + t[..., None] * ab[None]), axis=2).min(axis=1)
    assert nearest.max() <= far + 1e-6


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    """The gabled house for a Mavic 3 Enterprise, split into battery flights of 2 minutes, exported."""
    out = tmp_path_factory.mktemp("passing") / "house.json"
    code = main(["plan", str(MESHES / "gabled_house.obj"), "--drone", "m3e", "--gsd", "0.004", "--security", "3",
                 "--geo-origin", "48.1", "11.5", "500", "--max-flight-min", "2", "--export", "qgc,wpl,wpml",
                 "-o", str(out), "--no-evaluate"])
    assert code == 0
    return out, Route.load(out)


def test_the_plan_flies_through_safely_and_covers_from_where_photos_are_taken(flown):
    out, route = flown
    assert route.n_flights >= 2 and route.flies_through
    through = route.metrics["fly_through"]
    assert through["photos_in_passing"] >= 0.3 * route.shot.sum()
    assert sum(through["flight_minutes"]) < sum(f["minutes"] for f in route.metrics["flights"])
    scene = load_scene(MESHES / "gabled_house.obj")
    path = flown_path(route.positions, np.where(route.passing(), route.turn_damping, 0.0))
    assert polyline_min_distance(path, scene.meshes, step=0.05) >= route.security  # trimesh, not FCL
    offsets = np.linalg.norm(route.flown_positions() - route.positions, axis=1)
    assert offsets[route.shot].max() <= PassRules().max_photo_offset_m + 1e-9
    ev = evaluate(route, scene, spacing=0.25, seed=11)
    assert ev.safe and ev.metrics["flown_through"]["safe"]
    assert ev.coverage_pct >= 99.0


def test_stopping_plans_take_the_same_photos(flown):
    _out, route = flown
    scene = load_scene(MESHES / "gabled_house.obj")
    drone = get_drone("m3e")
    stop = plan(scene, drone.camera, gsd=0.004, security=3, drone=drone, max_flight_min=2, fly="stop")
    assert not stop.flies_through and stop.pass_speed is None
    # The same waypoints but for the turn points the through plan adds between photos.
    corner = ~route.straight_points()
    assert not stop.straight_points().any()
    assert np.allclose(stop.positions, route.positions[corner], atol=1e-4)
    assert np.array_equal(stop.shot, route.shot[corner])
    # Its stopping minutes are the stop plan's: no stop where the path runs straight on.
    assert [round(f["minutes"], 6) for f in stop.metrics["flights"]] == \
        [round(f["minutes"], 6) for f in route.metrics["flights"]]
    from coverplan.io.litchi import litchi_waypoints
    stop.frame = route.frame  # the fixture's --geo-origin
    assert len(litchi_waypoints(route)) == len(litchi_waypoints(stop))  # Litchi stops at each: none added


def test_the_camera_turns_between_photos_and_holds_still_at_them(flown):
    _out, route = flown
    p, h, g = route.positions, route.heading_deg, route.pitch_deg
    turns = np.flatnonzero(route.straight_points())
    assert len(turns) >= route.shot.sum()  # most legs between photos turn the camera
    for rows in route.flight_rows():
        shots = rows[route.shot[rows]]
        for a, b in zip(shots[:-1], shots[1:]):
            between = np.arange(a + 1, b)
            if not np.isin(between, turns).all() or not len(between):
                continue
            assert len(between) == 2
            t1, t2 = between
            # on the straight leg from a to b, at a quarter and three quarters of it
            ab = p[b] - p[a]
            for k, share in ((t1, 0.25), (t2, 0.75)):
                assert np.allclose(p[k], p[a] + share * ab, atol=1e-3)  # the route file keeps 0.1 mm
            # holding a's orientation, then already b's: the camera turns between t1 and t2 only
            assert h[t1] == pytest.approx(h[a]) and g[t1] == pytest.approx(g[a])
            assert h[t2] == pytest.approx(h[b]) and g[t2] == pytest.approx(g[b])
            assert abs((h[b] - h[a] + 180) % 360 - 180) >= 1.0 or abs(g[b] - g[a]) >= 1.0


def test_turning_between_photos_flies_the_same_photos_sooner():
    scene = load_scene(MESHES / "gabled_house.obj")
    drone = get_drone("m3e")
    # The tour without a re-aim cost, so that most legs turn the camera (the default flies
    # more photos that look the same way one after another and gains less from turn points).
    held = plan(scene, drone.camera, gsd=0.004, security=3, drone=drone, max_flight_min=1e6, reaim_steps=0.0)
    even = plan(scene, drone.camera, gsd=0.004, security=3, drone=drone, max_flight_min=1e6, reaim_steps=0.0,
                pass_rules=PassRules(turn_share=1.0))
    assert not even.straight_points().any() and held.straight_points().any()
    assert np.allclose(held.positions[held.shot], even.positions[even.shot])
    assert held.path_length == pytest.approx(even.path_length)
    fast, slow = held.metrics["fly_through"], even.metrics["fly_through"]
    assert fast["photos_in_passing"] > slow["photos_in_passing"]
    assert fast["minutes"] < 0.95 * slow["minutes"]
    assert held.metrics["flights"][0]["minutes"] == pytest.approx(even.metrics["flights"][0]["minutes"])
    with pytest.raises(ParameterError, match="turn share"):
        PassRules(turn_share=1.5)


def test_wpml_flies_through_as_the_reference_describes(flown):
    import zipfile

    from lxml import etree

    out, route = flown
    ns = {"k": "http://www.opengis.net/kml/2.2", "wpml": "http://www.dji.com/wpmz/1.0.2"}
    for k in range(1, route.n_flights + 1):
        rows = route.flight_rows()[k - 1]
        with zipfile.ZipFile(out.with_suffix(f".f{k}.kmz")) as z:
            doc = etree.fromstring(z.read("wpmz/waylines.wpml"))
        marks = doc.findall(".//k:Placemark", ns)
        assert len(marks) == len(rows)
        p = route.positions[rows]
        legs = np.linalg.norm(np.diff(p, axis=0), axis=1)
        damping = []
        for j, mark in enumerate(marks):
            mode = mark.findtext("wpml:waypointTurnParam/wpml:waypointTurnMode", namespaces=ns)
            dist = float(mark.findtext("wpml:waypointTurnParam/wpml:waypointTurnDampingDist", namespaces=ns))
            funcs = mark.xpath(".//wpml:actionGroup[wpml:actionTrigger/wpml:actionTriggerType='reachPoint']"
                               "//wpml:actionActuatorFunc/text()", namespaces=ns)
            if route.passing()[rows[j]]:
                # "Turns before waypoint. Flies through.": the pass mode with useStraightLine 1 and a
                # damping distance in (0, segment length]
                assert mode == "toPointAndPassWithContinuityCurvature"
                assert mark.findtext("wpml:useStraightLine", namespaces=ns) == "1"
                assert 0 < dist <= min(legs[j - 1], legs[j])
                assert "rotateYaw" not in funcs and "gimbalRotate" not in funcs
                assert mark.findtext("wpml:waypointHeadingParam/wpml:waypointHeadingMode",
                                     namespaces=ns) == "smoothTransition"
            else:
                assert mode == "toPointAndStopWithDiscontinuityCurvature"
            assert (funcs.count("takePhoto") == 1) == bool(route.shot[rows[j]])
            damping.append(dist)
        # the two turns of a leg fit in it (the reference's note on turn intercepts)
        both = np.array(damping[:-1]) + np.array(damping[1:])
        assert ((both < legs) | (both == 0)).all()
        # the gimbal turns evenly along the legs that arrive at a pitch change flown through (or at
        # a stop without a photo, from which a photo is flown through at that pitch)
        for group in doc.xpath(".//wpml:actionGroup[wpml:action/wpml:actionActuatorFunc='gimbalEvenlyRotate']",
                               namespaces=ns):
            assert group.findtext("wpml:actionTrigger/wpml:actionTriggerType", namespaces=ns) == \
                "betweenAdjacentPoints"
            start = int(group.findtext("wpml:actionGroupStartIndex", namespaces=ns))
            assert int(group.findtext("wpml:actionGroupEndIndex", namespaces=ns)) == start + 1
            assert route.passing()[rows[start + 1]] or not route.shot[rows[start + 1]]
        speeds = [float(m.findtext("wpml:waypointSpeed", namespaces=ns)) for m in marks]
        passing = route.passing()[rows]
        for j in np.flatnonzero(passing):  # no leg at a pass faster than the pass speed
            assert speeds[j] <= route.pass_speed[rows[j]] + 1e-3 and speeds[j - 1] <= route.pass_speed[rows[j]] + 1e-3


def test_pymavlink_loads_every_waypoints_file(flown):
    from pymavlink import mavutil, mavwp

    out, route = flown
    photos_passed = 0
    for k in range(1, route.n_flights + 1):
        rows = route.flight_rows()[k - 1]
        loader = mavwp.MAVWPLoader()
        count = loader.load(str(out.with_suffix(f".f{k}.waypoints")))
        items = [loader.wp(i) for i in range(count)]
        nav = [w for w in items[1:] if w.command in (mavutil.mavlink.MAV_CMD_NAV_WAYPOINT,
                                                     mavutil.mavlink.MAV_CMD_NAV_TAKEOFF)]
        assert len(nav) == len(rows)  # take-off at the first waypoint, then one per waypoint
        photos = [w for w in items if w.command == mavutil.mavlink.MAV_CMD_IMAGE_START_CAPTURE]
        assert len(photos) == int(route.shot[rows].sum())
        passing = route.passing()[rows][1:]
        waypoints = [w for w in nav if w.command == mavutil.mavlink.MAV_CMD_NAV_WAYPOINT]
        hold = np.array([w.param1 for w in waypoints])
        accept = np.array([w.param2 for w in waypoints])
        assert (hold == 0).all()
        assert (accept[passing] > 0).all() and (accept[~passing] == 0).all()
        in_passing = passing & route.shot[rows][1:]
        assert (accept[in_passing] <= PassRules().max_photo_offset_m + 1e-6).all()
        photos_passed += int(in_passing.sum())
        if passing.any():  # slower legs where it flies through
            assert any(w.command == mavutil.mavlink.MAV_CMD_DO_CHANGE_SPEED for w in items)
    assert photos_passed >= 0.3 * route.shot.sum()


def test_every_flight_reaches_a_mavsdk_autopilot(flown):
    out, route = flown
    for k in range(1, route.n_flights + 1):
        data, _mission, arrived = mavsdk_upload(out.with_suffix(f".f{k}.plan"))
        rows = route.flight_rows()[k - 1]
        assert arrived == len(data.mission_items)
        nav = [i for i in data.mission_items if i.command in (16, 22)]
        assert len(nav) == len(rows)
        assert sum(i.command == 2000 for i in data.mission_items) == int(route.shot[rows].sum())
