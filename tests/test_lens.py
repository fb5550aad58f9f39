"""Lens distortion (issue 61): the model against COLMAP's own cameras, DJI's DewarpData read back,
and photos grouped by camera as COLMAP is given them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coverplan.equipment.drones import get_drone
from coverplan.equipment.lens import Lens, parse_dewarp_data
from coverplan.errors import ParameterError
from coverplan.sfm.cameras import LENS_MODEL, LENS_MODELS, CameraGroup, photo_groups
from coverplan.sfm.photos import PhotoTags, read_photo, write_photo
from coverplan.sfm.render import PhotoCamera

P4P = get_drone("phantom4pro").lens


@settings(max_examples=60, deadline=None)
@given(st.floats(-0.3, 0.05), st.floats(-0.05, 0.15), st.floats(-0.05, 0.0), st.floats(-1e-3, 1e-3),
       st.floats(-1e-3, 1e-3), st.floats(0.0, 0.75), st.floats(0.0, 2 * np.pi))
def test_undistort_inverts_distort_within_the_field_of_view(k1, k2, k3, p1, p2, radius, angle):
    lens = Lens(k1, k2, p1, p2, k3)
    xy = np.array([[radius * np.cos(angle), radius * np.sin(angle)]])
    back = lens.undistort(lens.distort(xy))
    assert np.abs(back - xy).max() < 1e-5


def test_rendered_rays_land_where_colmaps_camera_projects_them():
    """Each pixel of a photo drawn through the Phantom 4 Pro's lens looks along the ray that
    COLMAP's FULL_OPENCV camera (its own implementation, the same parameters) images at that
    pixel's centre: the photos and the camera given to COLMAP agree."""
    pycolmap = pytest.importorskip("pycolmap")
    photo = PhotoCamera(96, 64, 70.0, 70.0, P4P)
    group = CameraGroup.known(photo, ["a"])
    camera = pycolmap.Camera(model=group.model, width=photo.width, height=photo.height,
                             params=np.array(group.params, dtype=float))
    rays = photo.rays(0.0, 0.0)  # heading north, level: right = +x, up = +z, forward = +y
    cam = np.column_stack([rays[:, 0], -rays[:, 2], rays[:, 1]])  # COLMAP's x right, y down, z forward
    pixels = np.asarray(camera.img_from_cam(cam))[:, :2]
    u, v = np.meshgrid(np.arange(photo.width) + 0.5, np.arange(photo.height) + 0.5)
    expected = np.column_stack([u.ravel(), v.ravel()])
    assert np.abs(pixels - expected).max() < 1e-3
    # The corners see well beyond the pinhole's field of view: a strong barrel.
    corner = np.degrees(np.arccos(rays[0] @ np.array([0.0, 1.0, 0.0])))
    pinhole = np.degrees(np.arctan(np.hypot(48, 32) / 70.0))
    assert corner > pinhole + 5.0


def test_dewarp_data_is_read_back_and_scaled_to_the_photo_size(tmp_path):
    text = P4P.dewarp_data(3659.78, 3653.17, -7.71, 45.9, date="2018-03-13")
    dewarp = parse_dewarp_data(text)
    assert (dewarp.fx, dewarp.fy, dewarp.dx, dewarp.dy) == pytest.approx((3659.78, 3653.17, -7.71, 45.9))
    assert dewarp.lens.opencv == pytest.approx(P4P.opencv)
    assert parse_dewarp_data("2018-03-13;1,2,3") is None and parse_dewarp_data("not;a,b") is None
    # A photo calibrated at 5472 px wide, written at 547 px: the calibration scales with it.
    tags = PhotoTags("a.jpg", 547, 365, 48.77, 9.18, relative_altitude_m=20.0, focal_mm=8.8, pixels_per_mm=45.6,
                     camera_model="FC6310", dewarp_data=text)
    path = write_photo(tmp_path / "a.jpg", np.zeros((365, 547, 3), np.uint8), tags)
    back = read_photo(path)
    assert back.dewarp_data == text and back.camera_model == "FC6310"
    back.optical_centre_x = 2736.0  # as the full-size photo's CalibratedOpticalCenterX says
    (group,) = photo_groups([back], tmp_path)
    scale = 547 / 5472
    assert group.model == "OPENCV" and group.refine
    assert group.params[:4] == pytest.approx((3659.78 * scale, 3653.17 * scale, 273.5 - 7.71 * scale,
                                              182.5 + 45.9 * scale))
    assert group.params[4:] == pytest.approx(P4P.opencv[:4])


def test_photos_are_grouped_by_camera_and_an_unknown_lens_is_estimated(tmp_path):
    def tags(name, width, model, focal_mm):
        return PhotoTags(name, width, width * 3 // 4, 48.77, 9.18, relative_altitude_m=20.0, focal_mm=focal_mm,
                         pixels_per_mm=width / 13.2, camera_model=model)

    groups = photo_groups([tags("a", 400, "FC6310", 8.8), tags("b", 400, "FC6310", 8.8),
                           tags("c", 640, "L1D-20c", 10.3), tags("d", 400, "FC6310", 12.0)], tmp_path)
    assert [g.names for g in groups] == [["a", "b"], ["c"], ["d"]]
    model, terms = LENS_MODELS[LENS_MODEL]
    assert all(g.model == model and g.refine and g.params[-terms:] == (0.0,) * terms for g in groups)
    assert groups[0].params[0] == pytest.approx(8.8 * 400 / 13.2)
    for name, (model, terms) in LENS_MODELS.items():  # each named lens model, its terms at zero
        (group, *_) = photo_groups([tags("a", 400, "FC6310", 8.8)], tmp_path, name)
        assert group.model == model and len(group.params) == (4 if model == "OPENCV" else 3) + terms
        assert group.params[-terms:] == (0.0,) * terms
    with pytest.raises(ParameterError, match="lens model"):
        photo_groups([tags("a", 400, "FC6310", 8.8)], tmp_path, "fisheye")


def test_a_lens_out_of_range_is_refused():
    with pytest.raises(ParameterError, match="k1"):
        Lens(k1=float("nan"))


def test_simulate_draws_through_the_drone_profiles_lens_or_says_why_not():
    from coverplan import get_camera, load_scene, plan
    from coverplan.sfm.simulate import photo_lens
    from tests.helpers import MESHES

    scene = load_scene(MESHES / "gabled_house.obj")
    with_drone = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, drone=get_drone("phantom4pro"))
    assert photo_lens("drone", with_drone) == P4P and photo_lens("pinhole", with_drone).is_pinhole
    with pytest.raises(ParameterError, match="names no drone profile.*--drone phantom4pro"):
        photo_lens("drone", plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0))
    with pytest.raises(ParameterError, match="unknown lens"):
        photo_lens("fisheye", with_drone)
