"""Field conditions of simulate (where a real drone takes the photos, in what light, on which
materials) and the planner's pose margin: checked against their own definitions, without SfM."""

from __future__ import annotations

import math

import numpy as np
import pytest

from coverplan import get_camera, load_scene
from coverplan.cli import main
from coverplan.equipment.drones import DRONES, POSITION_MARGIN_M, TYPICAL_GNSS, get_drone, security_shortfall
from coverplan.equipment.margin import NO_MARGIN, margin_for, tightened
from coverplan.flight.route import Route
from coverplan.sfm import field_render, materials, render
from coverplan.sfm.conditions import BIAS_CORRELATION_S, CONDITIONS, fly, get_conditions, photo_times
from coverplan.shots.reconstructability import MatchRule
from tests.helpers import MESHES


def line_route(n=400, drone=None, spacing=2.0):
    """n photos along a wall, 2 m apart, one flight."""
    x = np.arange(n) * spacing
    pos = np.column_stack([x, np.full(n, -10.0), np.full(n, 5.0)])
    params = {"gsd_m": 0.004, "security_m": 3.0}
    if drone:
        params["drone"] = drone
    return Route(pos, np.ones(n, bool), np.zeros(n), np.zeros(n), ["coverage"] * n, get_camera("phantom4pro"), params)


def test_ideal_flies_the_plan_exactly():
    route = line_route(50)
    flown = fly(route, CONDITIONS["ideal"], seed=3)
    assert np.array_equal(flown.positions, route.positions[route.shots])
    assert np.array_equal(flown.heading_deg, route.heading_deg) and np.array_equal(flown.pitch_deg, route.pitch_deg)
    assert (flown.exposure == 1).all() and (flown.velocity == 0).all()


def test_field_error_has_the_profiles_statistics():
    """Per-photo wander between neighbours and a bias common to nearby photos, as the profile says."""
    route = line_route(400, drone="phantom4pro")
    (bias_h, bias_v), (jit_h, jit_v) = get_drone("phantom4pro").position.bias_sigma, \
        get_drone("phantom4pro").position.jitter_sigma
    # Between neighbours the bias drifts a little: 2 sigma^2 (1 - exp(-dt / tau)) of variance.
    dt = np.diff(photo_times(route, get_drone("phantom4pro").flight_model()))
    drift = 2.0 * (1.0 - np.exp(-dt / BIAS_CORRELATION_S)).mean()
    offsets = []
    for seed in range(20):
        flown = fly(route, CONDITIONS["field"], seed=seed)
        d = flown.positions - flown.planned
        offsets.append(d)
        # Neighbouring photos share the slowly drifting bias: their difference is mostly the wander.
        step = np.diff(d, axis=0)
        assert np.std(step[:, 0]) == pytest.approx(math.sqrt(2 * jit_h ** 2 + drift * bias_h ** 2), rel=0.15)
        assert np.std(step[:, 2]) == pytest.approx(math.sqrt(2 * jit_v ** 2 + drift * bias_v ** 2), rel=0.15)
        assert np.std((flown.heading_deg + 180.0) % 360.0 - 180.0) == pytest.approx(1.5, rel=0.2)
        assert np.std(flown.pitch_deg) == pytest.approx(0.5, rel=0.2)
    # Across draws the first photo's error is the bias plus the wander.
    first = np.array([o[0, 0] for o in offsets])
    assert 0.4 * bias_h < np.std(first) < 1.8 * math.hypot(bias_h, jit_h)
    # Different seeds draw different flights; one seed always the same one.
    assert not np.allclose(offsets[0], offsets[1])
    again = fly(route, CONDITIONS["field"], seed=0)
    assert np.array_equal(again.positions - again.planned, offsets[0])


def test_rtk_flies_closer_than_gnss():
    gnss = fly(line_route(200, "phantom4pro"), CONDITIONS["field"], seed=1).offset_m
    rtk = fly(line_route(200, "m350-p1"), CONDITIONS["field"], seed=1).offset_m
    assert np.median(rtk) < 0.15 < np.median(gnss)


def test_photo_times_follow_the_flight_model_and_the_sun_moves():
    route = line_route(100, "phantom4pro")
    t = photo_times(route, get_drone("phantom4pro").flight_model())
    assert (np.diff(t) > 0).all()
    flown = fly(route, CONDITIONS["field"], seed=2)
    az = np.degrees(np.arctan2(flown.sun[:, 0], flown.sun[:, 1]))
    moved = (az[-1] - az[0] + 180) % 360 - 180
    assert moved == pytest.approx(15.0 / 3600.0 * (t[-1] - t[0]), rel=1e-6)
    assert 0.15 <= flown.direct.min() and flown.direct.max() <= 1.0 and flown.direct.std() > 0


def test_unknown_conditions_are_refused():
    with pytest.raises(Exception, match="unknown conditions"):
        get_conditions("sunny")


def test_textures_fade_where_pixels_are_too_coarse_to_show_them():
    """Physical scale: a brick wall shows its 7.1 cm courses up close and is plain from afar."""
    up = np.linspace(0.0, 3.0, 3001)
    along = np.full_like(up, 0.31)  # inside a brick in every course: only the bed joints repeat
    near = materials.brick(along, up, np.full_like(up, 0.005), salt=3)
    far = materials.brick(along, up, np.full_like(up, 0.3), salt=3)
    spectrum = np.abs(np.fft.rfft(near - near.mean()))
    freq = np.fft.rfftfreq(len(up), d=up[1] - up[0])
    assert 1.0 / freq[np.argmax(spectrum[1:]) + 1] == pytest.approx(0.071, rel=0.05)
    assert far.std() < 0.1 * near.std()
    rng = np.random.default_rng(0)
    pts = rng.random((20000, 3)) * 5.0
    lattice = render.noise_lattice(0)
    fine = materials.physical_noise(pts, np.full(len(pts), 0.003, np.float32), lattice)
    coarse = materials.physical_noise(pts, np.full(len(pts), 0.5, np.float32), lattice)
    assert coarse.std() < 0.75 * fine.std()


def test_the_two_texture_families_differ():
    """Cells are flat tones with joints; value noise is smooth: not one texture under two names."""
    x = np.linspace(0.0, 2.0, 4000)
    pts = np.column_stack([x, np.full_like(x, 0.3), np.full_like(x, 1.1)])
    fp = np.full(len(pts), 0.002, np.float32)
    cells = materials.physical_cells(pts, fp)
    noise = materials.physical_noise(pts, fp, render.noise_lattice(0))
    assert abs(np.corrcoef(cells, noise)[0, 1]) < 0.3
    # Inside a stone the tone is nearly constant, with jumps at joints: heavy-tailed steps.
    def kurtosis(v):
        d = np.diff(v)
        return float(np.mean((d - d.mean()) ** 4) / np.var(d) ** 2)
    assert kurtosis(cells) > 2.0 * kurtosis(noise)


def test_windows_are_a_regular_grid():
    along, up = np.meshgrid(np.linspace(0, 26.0, 521), np.linspace(0, 9.0, 181))
    glass, frame = materials.windows(along.ravel(), up.ravel())
    share = glass.mean() + frame.mean()
    assert share == pytest.approx(materials.WINDOW_W * materials.WINDOW_H / (materials.WINDOW_BAY_M * materials.STOREY_M), rel=0.1)
    shifted, _ = materials.windows(along.ravel() + materials.WINDOW_BAY_M, up.ravel())
    assert (shifted == glass).mean() > 0.99  # identical windows, bay after bay


def test_field_photo_differs_from_the_ideal_one_but_shows_the_same_building():
    scene = load_scene(MESHES / "gabled_house.obj")
    cam = render.PhotoCamera.of(get_camera("phantom4pro"), 320)
    pos, heading, pitch = np.array([5.0, -12.0, 4.0]), 0.0, -10.0
    ideal = render.PhotoRenderer(scene, cam, 0.05, 40.0).render(pos, heading, pitch)
    field = field_render.FieldRenderer(scene, cam, 40.0, facades=True, seed=1)
    sun = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    img, seen = field.render_flown(pos, heading, pitch, sun, 1.0, 1.0, np.zeros(3), 1 / 500, np.random.default_rng(0))
    assert img.shape == ideal.shape and img.dtype == np.uint8 and len(seen)
    assert 60 < img.mean() < 200  # auto exposure
    # Sensor noise: two renders of the same pose differ a little, everywhere.
    img2, _ = field.render_flown(pos, heading, pitch, sun, 1.0, 1.0, np.zeros(3), 1 / 500, np.random.default_rng(1))
    diff = img.astype(int) - img2.astype(int)
    assert 0.7 < diff.std() < 3.0  # about 1 DN per photo at mid grey, sqrt(2) of that between two


def test_motion_blur_smears_along_the_motion():
    img = np.zeros((41, 41))
    img[20, 20] = 1.0
    right_motion = np.array([5.0, 0.0, 0.0])  # heading 0: image right is +x
    out = field_render._motion_blur(img, right_motion, 0.01, 0.0, 0.0, np.array([10.0]), 1000.0)
    rows, cols = np.nonzero(out > 1e-6)
    assert np.ptp(cols) >= 4 and np.ptp(rows) == 0 and out.sum() == pytest.approx(1.0)
    still = field_render._motion_blur(img, np.zeros(3), 0.01, 0.0, 0.0, np.array([10.0]), 1000.0)
    assert np.array_equal(still, img)


# -- security against position error -----------------------------------------------------------

def test_security_below_the_position_error_is_named():
    p4 = get_drone("phantom4pro")
    msg = security_shortfall(2.0, p4)
    assert msg and "+-1.5 m" in msg and p4.label in msg and "2.5 m" in msg
    assert security_shortfall(1.5 + POSITION_MARGIN_M, p4) is None
    assert security_shortfall(1.2, get_drone("m350-p1")) is None  # RTK
    assert "no --drone" in security_shortfall(1.0, None)
    assert all(d.position.horizontal_m > 0 for d in DRONES.values())
    assert TYPICAL_GNSS.horizontal_m == p4.position.horizontal_m


def test_plan_warns_and_strict_refuses(tmp_path, capsys):
    target = str(MESHES / "gabled_house.obj")
    out = tmp_path / "r.json"
    code = main(["plan", target, "--drone", "phantom4pro", "--gsd", "0.004", "--security", "2", "-o", str(out),
                 "--strict", "-q"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "position error" in err and not out.exists()
    assert main(["plan", target, "--drone", "phantom4pro", "--gsd", "0.004", "--security", "2", "-o", str(out),
                 "--no-evaluate"]) == 0
    assert "WARNING security 2 m is less than" in capsys.readouterr().out


# -- the planner's pose margin -----------------------------------------------------------------

def test_margin_narrows_the_frame_but_keeps_the_gsd():
    cam = get_camera("phantom4pro")
    m = margin_for("field", get_drone("phantom4pro"), 12.0)
    narrow = m.camera(cam)
    assert narrow.pixel_pitch_mm == pytest.approx(cam.pixel_pitch_mm, rel=1e-3)
    assert narrow.optimal_distance(0.004) == pytest.approx(cam.optimal_distance(0.004), rel=1e-3)
    assert cam.hfov_deg / 2 - narrow.hfov_deg / 2 == pytest.approx(m.frame_h_deg, abs=0.05)
    assert cam.vfov_deg / 2 - narrow.vfov_deg / 2 == pytest.approx(m.frame_v_deg, abs=0.05)
    # 1.5 deg heading + the 0.3 m wander at 12 m; pairs: sqrt(2) * 0.3 m at 12 m.
    assert m.frame_h_deg == pytest.approx(1.5 + math.degrees(math.atan(0.3 / 12.0)), rel=1e-6)
    assert m.pair_deg == pytest.approx(math.degrees(math.atan(math.sqrt(2) * 0.3 / 12.0)), rel=1e-6)
    rule, tri = tightened(MatchRule(), 5.0, m)
    assert rule.max_pair_deg == pytest.approx(35.0 - m.pair_deg) and tri == pytest.approx(5.0 + m.pair_deg)
    assert margin_for("none", None, 12.0) == NO_MARGIN
    rtk = margin_for("field", get_drone("m350-p1"), 12.0)
    assert rtk.pair_deg < m.pair_deg and rtk.frame_h_deg < m.frame_h_deg
    with pytest.raises(Exception, match="margin must be"):
        margin_for("wide", None, 12.0)


def test_flights_of_one_scene_drawn_with_one_seed_fly_under_the_same_sun():
    """A paired comparison: the sun of a draw does not depend on how many photos the flight takes."""
    from coverplan import get_camera, load_scene, plan
    from coverplan.shots.reconstructability import MatchRule
    from tests.helpers import MESHES
    scene = load_scene(MESHES / "gabled_house.obj")
    camera = get_camera("phantom4pro")
    few = plan(scene, camera, gsd=0.004, security=3.0, match=MatchRule(framed_views=0, braced=False))
    many = plan(scene, camera, gsd=0.004, security=3.0)
    assert len(few.shots) != len(many.shots)
    for seed in (0, 1):
        a, b = (fly(r, get_conditions("field"), seed=seed) for r in (few, many))
        assert np.allclose(a.sun[0], b.sun[0], atol=0.01)  # the same sun at take-off (it moves 0.004 deg/s)
    assert not np.allclose(fly(few, get_conditions("field"), seed=0).sun[0],
                           fly(few, get_conditions("field"), seed=1).sun[0])


def test_centre_weighted_metering_exposes_a_narrow_face_against_the_sky():
    """The chapel's tower seen from the west fills a narrow column of the frame, between sky and
    sunlit ground; its face is in shade. Metered centre-weighted (as DJI's cameras meter by
    default) the face comes out brighter than metered on the whole frame, and near mid grey."""
    scene = load_scene(MESHES / "chapel.obj")
    cam = render.PhotoCamera.of(get_camera("phantom4pro"), 240)
    pos, heading, pitch = np.array([25.0 - 11.5 - 14.0, 25.0, 17.0]), 90.0, 0.0  # facing east, at the tower
    sun = np.array([0.8, 0.0, 0.6])  # from the east: the west face is in shade
    grey = {}
    for metering in field_render.METERING:
        r = field_render.FieldRenderer(scene, cam, 40.0, seed=1, metering=metering)
        img, _ = r.render_flown(pos, heading, pitch, sun, 1.0, 1.0, np.zeros(3), 1 / 500, None)
        dirs = cam.rays(heading, pitch)
        _d, mesh, face = r.rays.first_hit(np.broadcast_to(pos, dirs.shape), dirs)
        normal = r.normals[0][np.clip(face, 0, None)]
        on_face = (mesh == 0) & (normal[:, 0] < -0.9)  # the tower's west face
        assert 0.05 < on_face.mean() < 0.5  # a narrow part of the frame
        grey[metering] = float(img.ravel()[on_face].mean())
    assert grey["center"] > grey["average"] + 15
    mid = 255 * field_render.MID_GREY ** (1 / field_render.GAMMA)
    assert abs(grey["center"] - mid) < abs(grey["average"] - mid)
    w = field_render.metering_weights(cam.height, cam.width)
    assert w.sum() == pytest.approx(1.0) and w.reshape(cam.height, cam.width)[cam.height // 2, cam.width // 2] == w.max()
    with pytest.raises(Exception, match="unknown metering"):
        field_render.metering_weights(4, 6, "spot")


def test_the_draws_table_names_the_worst_draws_class_and_gives_the_median(tmp_path):
    """Three saved draws: the worst row is the draw with the least surface, with its class
    named; the median row gives the median of the draws' least classes, without a name."""
    import json

    from coverplan.sfm.simulation import Simulation
    draws = [{"photos": 10, "registered": r, "models": 1, "surface_0.2_pct": s, "least_class": c,
              "least_class_pct": p, "reconstructable": s >= 95.0, "seed": k}
             for k, (r, s, c, p) in enumerate([(10, 99.4, "roof", 98.1), (10, 98.9, "facade north", 94.7),
                                               (9, 99.0, "facade west", 96.0)])]
    saved = {"photos": 10, "registered": 10, "registered_any": 10, "models": 1, "points": 100,
             "reprojection_error_px": 0.5, "centre_error_m": {"median": 0.1, "max": 0.2}, "surface": {},
             "photo_width_px": 640, "seconds": {}, "shot_registered": [True] * 10, "draws": draws, "worst_draw": 1}
    (tmp_path / "simulation.json").write_text(json.dumps(saved))
    lines = Simulation.load(tmp_path / "simulation.json").draws_table().splitlines()
    cells = [[c.strip() for c in line.split("  ") if c.strip()] for line in lines]
    assert cells[1] == ["worst", "10/10", "1", "98.9 %", "facade north 94.7 %", "yes"]
    assert cells[2] == ["median", "10/10", "1", "99.0 %", "96.0 %", "yes"]
    assert [c[0] for c in cells[3:]] == ["seed 0", "seed 1", "seed 2"]
    # the column lines up under its heading in every row
    column = lines[0].index("least class")
    assert lines[1].index("facade north") == lines[2].index("96.0 %") == column
