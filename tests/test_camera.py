import math

import numpy as np
import pytest

from coverplan import PRESETS, Camera, ParameterError, get_camera
from coverplan.geometry.orientation import angle_between_deg, camera_axes, heading_change_deg, heading_pitch, view_direction


def test_phantom4pro_derived_values():
    cam = get_camera("phantom4pro")
    assert cam.pixel_pitch_mm == pytest.approx(13.2 / 5472)
    assert cam.hfov_deg == pytest.approx(2 * math.degrees(math.atan(6.6 / 8.8)))
    assert cam.vfov_deg == pytest.approx(2 * math.degrees(math.atan(4.4 / 8.8)))
    # 10 m away one pixel covers 10 m * 2.412 um / 8.8 mm = 2.74 mm
    assert float(cam.gsd_at(10.0)) == pytest.approx(10 * (13.2 / 5472) / 8.8)
    assert cam.optimal_distance(0.005) == pytest.approx(0.005 * 8.8 / (13.2 / 5472))
    assert float(cam.gsd_at(cam.optimal_distance(0.005))) == pytest.approx(0.005)
    w, h = cam.footprint(10.0)
    assert (w, h) == pytest.approx((15.0, 10.0))


def test_thesis80_has_an_80_degree_horizontal_fov():
    assert get_camera("thesis80").hfov_deg == pytest.approx(80.0)


@pytest.mark.parametrize("name", ["phantom4pro", "mavic3e", "zenmuse-p1-35", "thesis80"])
def test_presets_exist_and_are_landscape(name):
    cam = PRESETS[name]
    assert cam.sensor_width_mm >= cam.sensor_height_mm
    assert cam.image_width_px >= cam.image_height_px


@pytest.mark.parametrize("args", [(0, 8.8, 8.8, 5472, 3648), (13.2, -1, 8.8, 5472, 3648),
                                  (13.2, 8.8, 0, 5472, 3648), (13.2, 8.8, 8.8, 0, 3648),
                                  (13.2, 8.8, float("nan"), 5472, 3648), (8.8, 13.2, 8.8, 5472, 3648)])
def test_bad_cameras_are_refused(args):
    with pytest.raises(ParameterError):
        Camera(*args)


def test_unknown_preset_lists_the_presets():
    with pytest.raises(ParameterError, match="phantom4pro"):
        get_camera("hasselblad")


def test_heading_and_pitch_conventions():
    np.testing.assert_allclose(view_direction(0, 0), [0, 1, 0], atol=1e-12)  # north
    np.testing.assert_allclose(view_direction(90, 0), [1, 0, 0], atol=1e-12)  # east
    np.testing.assert_allclose(view_direction(180, -90), [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(view_direction(270, 45), [-np.sqrt(.5), 0, np.sqrt(.5)], atol=1e-12)
    rng = np.random.default_rng(1)
    h, p = rng.uniform(0, 360, 200), rng.uniform(-89, 89, 200)
    h2, p2 = heading_pitch(view_direction(h, p))
    np.testing.assert_allclose(p2, p, atol=1e-9)
    assert (angle_between_deg(view_direction(h2, p2), view_direction(h, p)) < 1e-6).all()
    right, up, forward = camera_axes(h, p)
    np.testing.assert_allclose(np.einsum("ij,ij->i", right, forward), 0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(up, axis=1), 1, atol=1e-12)
    assert (up[:, 2] >= -1e-12).all()  # image up never points below the horizon for |pitch| < 90


def test_heading_change_is_the_short_way_across_north():
    np.testing.assert_allclose(heading_change_deg([350, 10, 0, 90, 720], [10, 350, 180, 45, 1]), [20, -20, -180, -45, 1])
    rng = np.random.default_rng(2)
    a, b = rng.uniform(-720, 720, 500), rng.uniform(-720, 720, 500)
    turn = heading_change_deg(a, b)
    assert ((turn >= -180) & (turn < 180)).all()
    # turning a by the change lands on b's direction: the same unit vector
    level = np.zeros_like(a)
    np.testing.assert_allclose(view_direction(a + turn, level), view_direction(b, level), atol=1e-9)
    # never more than the angle between the two directions
    np.testing.assert_allclose(np.abs(turn), angle_between_deg(view_direction(a, level), view_direction(b, level)),
                               atol=1e-5)
