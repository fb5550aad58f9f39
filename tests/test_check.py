"""`coverplan check` (issue 32): a flight's own photos, tagged as a DJI drone tags them,
reconstructed and judged; the side the flight left out is named."""

from __future__ import annotations

import base64
import json
import os
from pathlib import Path

import numpy as np
import pytest
import trimesh

from coverplan import get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.sfm.cameras import LENS_MODEL, LENS_MODELS
from coverplan.sfm.photos import PhotoTags, read_photo, write_flight_photos, write_photo
from tests.helpers import MESHES, strict_json

ORIGIN = ["48.77", "9.18", "250"]  # the gabled house's frame on Earth (--geo-origin)


def test_photo_tags_round_trip(tmp_path):
    tags = PhotoTags("a.jpg", 64, 48, 48.7712345, -9.1812345, gps_altitude_m=271.25, absolute_altitude_m=271.25,
                     relative_altitude_m=21.25, heading_deg=312.5, pitch_deg=-35.0, focal_mm=8.8, pixels_per_mm=4.85)
    back = read_photo(write_photo(tmp_path / "a.jpg", np.zeros((48, 64, 3), np.uint8), tags))
    assert (back.width, back.height) == (64, 48) and back.has_position
    assert back.lat == pytest.approx(tags.lat, abs=1e-9) and back.lon == pytest.approx(tags.lon, abs=1e-9)
    for name in ("gps_altitude_m", "absolute_altitude_m", "relative_altitude_m", "heading_deg", "pitch_deg"):
        assert getattr(back, name) == pytest.approx(getattr(tags, name), abs=1e-3), name
    assert back.focal_px == pytest.approx(8.8 * 4.85, rel=1e-3)
    # Without the sensor's pixel size, the 35 mm equivalent over the image diagonal.
    plain = read_photo(write_photo(tmp_path / "b.jpg", np.zeros((48, 64, 3), np.uint8),
                                   PhotoTags("b.jpg", 64, 48, 1.0, 2.0, relative_altitude_m=5.0, focal_35mm=24.0)))
    assert plain.focal_px == pytest.approx(24.0 * 80.0 / np.hypot(36.0, 24.0), rel=1e-3)


@pytest.mark.xdist_group("photos_check")
def test_check_finds_one_model_and_names_the_side_left_out(tmp_path, capsys):
    scene = load_scene(MESHES / "gabled_house.obj", geodetic_origin=[float(v) for v in ORIGIN])
    # Without edge views: a corner's edge view sees the north façade and the side beside it
    # alike, so leaving out every photo north of the house would take part of a side too.
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, edge_views=False)
    north = scene.bounds("target")[1][1]
    keep = np.flatnonzero(route.positions[route.shots][:, 1] <= north)  # no photo from north of the house
    folder = tmp_path / "photos"
    write_flight_photos(route, scene, folder, width=480, shots=keep)
    from PIL import Image
    Image.open(folder / "DJI_0001.JPG").save(folder / "NO_GPS.JPG")  # pixels without the tags
    sky = read_photo(folder / "DJI_0002.JPG")  # taken at the same place, of a grey sky
    sky.name = "DJI_SKY.JPG"
    write_photo(folder / sky.name, np.full((sky.height, sky.width, 3), 180, np.uint8), sky)
    out = tmp_path / "check"
    report = tmp_path / "check.html"
    code = main(["check", str(folder), "--target", str(MESHES / "gabled_house.obj"), "--geo-origin", *ORIGIN,
                 "-o", str(out), "--json", "-q", "--report", str(report)])
    assert code == 0
    captured = capsys.readouterr()
    result = strict_json(captured.out)
    assert "NO_GPS.JPG left out" in captured.err
    assert result["photos"] == len(keep) + 1 and result["models"] == 1
    assert result["registered"] >= 0.98 * len(keep)
    lost = {r["photo"]: r["why"] for r in result["not_registered"]}
    assert "DJI_SKY.JPG" in lost and "features" in lost["DJI_SKY.JPG"]
    by = result["surface"]["by_radius"]["0.2"]["by_class_pct"]
    assert by["facade north"] < 30.0  # the side nobody photographed
    assert min(by["facade south"], by["facade east"], by["facade west"]) >= 85.0
    assert max(result["missing_m2"], key=result["missing_m2"].get) == "facade north"
    missing = json.loads((out / "missing.geojson").read_text())["features"]
    classes = [f["properties"]["class"] for f in missing]
    assert classes.count("facade north") > 0.4 * len(classes)
    lon, lat = np.array([f["geometry"]["coordinates"][:2] for f in missing]).T
    assert np.all(np.abs(lat - 48.77) < 0.001) and np.all(np.abs(lon - 9.18) < 0.001)
    check_report_in_a_browser(report, result)


def check_report_in_a_browser(report: Path, result: dict) -> None:
    """The check's HTML report in headless Chromium: drawn without a script error, every photo
    not in the model listed with why, and the scene coloured by what COLMAP rebuilt."""
    from tests.test_report import chromium, open_report

    browser = chromium()
    try:
        open_report(browser, report)
        assert not [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
        rows = browser.execute_script(
            "return [...document.querySelectorAll('#photos-lost tr')].slice(1).map(r => r.innerText)")
        named = {row.split("\t")[0]: row for row in rows}
        assert set(named) == {"NO_GPS.JPG"} | {r["photo"] for r in result["not_registered"]}
        assert "no position" in named["NO_GPS.JPG"].lower() or "gps" in named["NO_GPS.JPG"].lower()
        assert "features" in named["DJI_SKY.JPG"]
        text = browser.execute_script("return document.getElementById('reconstruction').innerText")
        assert "facade north" in text and "not in the model" in text
        # The scene's samples, coloured by whether COLMAP put a point within 0.2 m: as many as the verdict.
        data = json.loads(browser.execute_script("return document.getElementById('report-data').textContent"))
        rebuilt = np.frombuffer(base64.b64decode(data["simulation"]["reconstructed"]), np.uint8)
        assert abs(100.0 * rebuilt.mean() - result["surface"]["by_radius"]["0.2"]["pct"]) < 5.0
        browser.execute_script("document.querySelector('input[data-layer=uncovered]').click()")
        before = browser.find_element("css selector", "#view canvas").screenshot_as_png
        browser.execute_script("document.querySelector('input[value=sfm]').click()")
        after = browser.find_element("css selector", "#view canvas").screenshot_as_png
        assert before != after  # the surface recoloured by what was rebuilt
        assert not [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    finally:
        browser.quit()


@pytest.mark.xdist_group("photos_check")
def test_check_of_a_real_size_flight_goes_through_spatial_matching(tmp_path, capsys):
    """Over the exhaustive-matching limit (80 photos) COLMAP's feature extraction has stored a
    pose prior from each photo's EXIF GPS before the spatial matching writes its own: one prior
    per image must remain, in the scene's frame, and the whole flight must rebuild in one model."""
    pycolmap = pytest.importorskip("pycolmap")
    scene = load_scene(MESHES / "gabled_house.obj", geodetic_origin=[float(v) for v in ORIGIN])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.002, security=3.0, edge_views=False)
    assert len(route.shots) >= 100
    folder = tmp_path / "photos"
    write_flight_photos(route, scene, folder, width=240)
    out = tmp_path / "check"
    code = main(["check", str(folder), "--target", str(MESHES / "gabled_house.obj"), "--geo-origin", *ORIGIN,
                 "-o", str(out), "--json", "-q"])
    assert code == 0
    result = strict_json(capsys.readouterr().out)
    assert strict_json((out / "check.json").read_text()) == result
    db = pycolmap.Database.open(out / "colmap" / "database.db")
    try:
        images = {im.data_id.id: im.name for im in db.read_all_images()}
        priors = db.read_all_pose_priors()
    finally:
        db.close()
    assert len(images) == len(route.shots)
    assert sorted(p.corr_data_id.id for p in priors) == sorted(images)  # one prior per image, no second one
    assert all(p.coordinate_system == pycolmap.PosePriorCoordinateSystem.CARTESIAN for p in priors)
    planned = {f"DJI_{k + 1:04d}.JPG": route.positions[s] for k, s in enumerate(route.shots)}
    for p in priors:  # the prior is the photo's tag in the scene's frame (local metres)
        assert np.linalg.norm(np.asarray(p.position) - planned[images[p.corr_data_id.id]]) < 0.05
    rec = pycolmap.Reconstruction(out / "colmap" / "sparse" / "0")  # COLMAP's own model on disk
    assert rec.num_reg_images() == result["registered"] >= 0.98 * len(route.shots)
    (camera,) = rec.cameras.values()  # pinhole photos: the radial terms refined stay near nought
    assert camera.model == getattr(pycolmap.CameraModelId, LENS_MODELS[LENS_MODEL][0])
    assert np.abs(camera.params[camera.extra_params_idxs()]).max() < 0.02
    assert result["models"] == 1
    assert result["gnss_residual_m"]["median"] < 0.5
    assert result["surface"]["by_radius"]["0.2"]["pct"] >= 85.0


def test_a_colmap_failure_names_its_stage_and_a_rerun_resumes(tmp_path, capsys, monkeypatch):
    pytest.importorskip("pycolmap")
    from coverplan.sfm import colmap, database

    scene = load_scene(MESHES / "gabled_house.obj", geodetic_origin=[float(v) for v in ORIGIN])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, edge_views=False)
    folder = tmp_path / "photos"
    write_flight_photos(route, scene, folder, width=160, shots=np.arange(6))

    def broken(*args, **kwargs):  # as pycolmap raises its C++ errors
        raise RuntimeError("[incremental_mapper.cc:1] Check failed: something inside COLMAP")

    monkeypatch.setattr(colmap, "map_models", broken)
    out = tmp_path / "check"
    code = main(["check", str(folder), "--target", str(MESHES / "gabled_house.obj"), "--geo-origin", *ORIGIN,
                 "-o", str(out), "-q"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "COLMAP failed in" in err[0] and "mapping" in err[0] and "Traceback" not in err[0]
    db_file = out / "colmap" / "database.db"
    assert str(db_file) in err[0] and db_file.exists()

    # The rerun starts after the stages that finished: features and matches are not made again.
    monkeypatch.undo()
    made = []

    def counted(real):
        def call(*args, **kwargs):
            made.append(real.__name__)
            return real(*args, **kwargs)
        return call

    for module, name in ((colmap, "extract_features"), (colmap, "polled"), (database, "polled")):  # polled matches
        monkeypatch.setattr(module, name, counted(getattr(module, name)))
    command = ["check", str(folder), "--target", str(MESHES / "gabled_house.obj"), "--geo-origin", *ORIGIN,
               "-o", str(out), "--json", "-v"]
    assert main(command) == 0
    assert made == [] and "kept from the earlier run" in capsys.readouterr().err
    assert (out / "colmap" / "sparse").is_dir()
    # A photo written again is a different photo: everything runs anew.
    first = sorted(folder.iterdir())[0]
    first.write_bytes(first.read_bytes())
    os.utime(first, ns=(first.stat().st_atime_ns, first.stat().st_mtime_ns + 10 ** 9))
    assert main(command) == 0
    assert "extract_features" in made and "polled" in made


REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real-photos"


def flat_target(tmp_path, half: float = 80.0) -> Path:
    mesh = trimesh.Trimesh([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]],
                           [[0, 1, 2], [0, 2, 3]])
    path = tmp_path / "flat.ply"
    mesh.export(path)
    return path


@pytest.mark.xdist_group("real_photos")
def test_check_reads_and_rebuilds_a_real_dji_flight(tmp_path, capsys):
    """18 photos of a DJI FC300S as the camera wrote them (EXIF GPS, DJI XMP), features found at
    480 px: one model of every photo, camera centres within a GNSS error of their tags, the
    model fitted onto a flat target at take-off height (GPS altitude less the relative altitude)
    with the move reported, and no figure the user cannot read."""
    folder = REAL / "brighton-beach"
    if not folder.is_dir():
        pytest.skip("the real photo sets are not beside this checkout (../shared/data/real-photos)")
    tags = [read_photo(f) for f in sorted(folder.glob("*.JPG"))]
    lat, lon = np.mean([t.lat for t in tags]), np.mean([t.lon for t in tags])
    takeoff = float(np.median([t.gps_altitude_m - t.relative_altitude_m for t in tags]))
    out = tmp_path / "check"
    code = main(["check", str(folder), "--target", str(flat_target(tmp_path)), "--geo-origin", str(lat), str(lon),
                 str(takeoff), "--working-px", "480", "-o", str(out)])
    captured = capsys.readouterr()
    assert code == 0
    assert "nan" not in captured.out and "DESIGN" not in captured.out
    result = json.loads((out / "check.json").read_text())
    assert result["photos"] == 18 and result["registered"] >= 16 and result["models"] == 1
    assert result["gnss_residual_m"]["median"] < 1.5  # a consumer GNSS's error
    assert result["fitted"] and 0.5 < result["icp_shift_m"] <= 10.0  # its heights were off; the fit says by how much
    assert "fitted to the surfaces (moved" in captured.out
    import pycolmap

    rec = pycolmap.Reconstruction(out / "colmap" / "sparse" / "0")
    assert rec.num_reg_images() == result["registered"]
    cams = {c.model.name for c in rec.cameras.values()}
    assert cams  # COLMAP's own model on disk, read back
    # A few thousand sparse points over 25,600 m2 cannot put a point within 0.2 m of most of it:
    # the verdict is what the registered photos see twice, and it matches the photos' own
    # footprints on the target, drawn here from their tags alone.
    assert result["judged_by"] == "photo views" and result["point_ceiling_pct"] < 95.0
    assert "too thin to judge at 0.2 m" in captured.out and "seen by 2+ registered photos" in captured.out
    twice = footprints_seen_twice(tags, lat, lon, half=80.0)
    assert abs(result["photo_cover_pct"] - twice) < 15.0, (result["photo_cover_pct"], twice)


def footprints_seen_twice(tags, lat0: float, lon0: float, half: float) -> float:
    """% of a flat square target (side 2 * half m, centred on lat0, lon0, at take-off height) inside
    two or more nadir photos' footprints: each photo's rectangle from its GPS position, its height
    above take-off, its heading and its focal length in pixels, on a 1 m grid."""
    from pyproj import Geod

    x = np.arange(-half + 0.5, half, 1.0)
    gx, gy = np.meshgrid(x, x)
    count = np.zeros_like(gx)
    for t in tags:
        azimuth, _, distance = Geod(ellps="WGS84").inv(lon0, lat0, t.lon, t.lat)
        east, north = distance * np.sin(np.radians(azimuth)), distance * np.cos(np.radians(azimuth))
        h = np.radians(t.heading_deg)
        along = (gx - east) * np.sin(h) + (gy - north) * np.cos(h)
        across = (gx - east) * np.cos(h) - (gy - north) * np.sin(h)
        reach = t.relative_altitude_m / t.focal_px
        count += (np.abs(across) <= reach * t.width / 2) & (np.abs(along) <= reach * t.height / 2)
    return float(100.0 * (count >= 2).mean())


@pytest.mark.xdist_group("real_photos")
def test_check_of_a_real_gps_only_flight_says_why_it_gives_no_verdict(tmp_path, capsys):
    """14 Canon photos with EXIF GPS only (no XMP; the GPS altitude drifts 15 m through the
    flight) against a flat target at a height the photos do not give: every photo registers in
    one model, and where the model does not sit on the target the report says why instead of a
    0 % verdict."""
    folder = REAL / "caliterra"
    if not folder.is_dir():
        pytest.skip("the real photo sets are not beside this checkout (../shared/data/real-photos)")
    tags = [read_photo(f) for f in sorted(folder.glob("*.jpg"))]
    assert all(t.has_position for t in tags) and not any(np.isfinite(t.pitch_deg) for t in tags)
    lat, lon = np.mean([t.lat for t in tags]), np.mean([t.lon for t in tags])
    out = tmp_path / "check"
    code = main(["check", str(folder), "--target", str(flat_target(tmp_path)), "--geo-origin", str(lat), str(lon),
                 "300", "--working-px", "480", "-o", str(out)])
    captured = capsys.readouterr()
    assert code == 0 and "nan" not in captured.out
    result = json.loads((out / "check.json").read_text())
    assert result["photos"] == 14 and result["registered"] >= 12 and result["models"] == 1
    assert not result["judged"] and "median" in result["why_not_judged"]
    assert "not judged:" in captured.out and "surface reconstructed" not in captured.out


@pytest.mark.xdist_group("photos_check")
def test_a_card_of_two_battery_flights_through_a_real_lens(tmp_path, capsys):
    """A folder as a card holds it after a real-size flight: one subfolder per battery flight
    whose photos restart at DJI_0001, a DNG beside one JPEG, a JPEG cut short in the copy. The
    photos are drawn through the Phantom 4 Pro's raw lens (barrel, k1 -0.27) and carry only EXIF
    (no DewarpData), so COLMAP must find the distortion itself: both flights go into one model
    under their own paths, the lens is recovered in bundle adjustment, and every other file is
    named with why it was left out."""
    import shutil

    import pycolmap

    from coverplan.equipment.drones import get_drone

    scene = load_scene(MESHES / "gabled_house.obj", geodetic_origin=[float(v) for v in ORIGIN])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.002, security=3.0)
    lens = get_drone("phantom4pro").lens
    assert len(route.shots) >= 100 and lens.k1 < -0.2
    flat = tmp_path / "rendered"
    written = write_flight_photos(route, scene, flat, width=240, lens=lens, dewarp_data=False)
    card = tmp_path / "card"
    half = len(written) // 2
    for k, path in enumerate(written):
        flight, number = ("100MEDIA", k + 1) if k < half else ("101MEDIA", k - half + 1)
        (card / flight).mkdir(parents=True, exist_ok=True)
        shutil.copy(path, card / flight / f"DJI_{number:04d}.JPG")
    (card / "100MEDIA" / "DJI_0003.DNG").write_bytes(b"II*\x00" + bytes(4096))  # the raw twin of a JPEG
    whole = (card / "101MEDIA" / "DJI_0002.JPG").read_bytes()
    (card / "101MEDIA" / "DJI_0999.JPG").write_bytes(whole[: len(whole) // 2])  # cut short in the copy
    out = tmp_path / "check"
    code = main(["check", str(card), "--target", str(MESHES / "gabled_house.obj"), "--geo-origin", *ORIGIN,
                 "-o", str(out), "--json", "-q"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    result = strict_json(captured.out)
    used = result["photos_used"]
    assert len(used) == len(written) and "100MEDIA/DJI_0001.JPG" in used and "101MEDIA/DJI_0001.JPG" in used
    err = captured.err
    assert "100MEDIA/DJI_0003.DNG left out: a raw file; the JPEG beside it is used" in err
    assert "101MEDIA/DJI_0999.JPG left out: not a whole image" in err
    assert len(result["cameras"]) == 1 and "lens distortion estimated" in result["cameras"][0]
    models = sorted((out / "colmap" / "sparse").iterdir())
    recs = [pycolmap.Reconstruction(m) for m in models]
    rec = max(recs, key=lambda r: r.num_reg_images())  # COLMAP's own model on disk
    assert len(recs) == result["models"] == 1
    assert rec.num_reg_images() == result["registered"] >= 0.98 * len(written)
    names = {im.name for im in rec.images.values()}
    assert {"100MEDIA/DJI_0001.JPG", "101MEDIA/DJI_0001.JPG"} <= names  # COLMAP's own names, both flights
    (camera,) = rec.cameras.values()
    assert camera.model == getattr(pycolmap.CameraModelId, LENS_MODELS[LENS_MODEL][0])
    assert camera.params[camera.extra_params_idxs()[0]] < -0.1  # the barrel found
    assert result["surface"]["by_radius"]["0.2"]["pct"] >= 85.0


@pytest.mark.parametrize("make, words", [
    ("empty", ["holds no photos"]),
    ("raw only", ["holds no photos"]),
    ("a file", ["is not a folder of photos"]),
    ("no gps", ["with a GPS position", "at least 2"]),
])
def test_a_bad_photo_folder_is_one_line(tmp_path, capsys, make, words):
    from tests.test_bad_input import assert_one_line_error, run

    folder = tmp_path / "photos"
    folder.mkdir()
    image = np.zeros((48, 64, 3), np.uint8)
    if make == "raw only":
        (folder / "DJI_0001.DNG").write_bytes(b"II*\x00" + bytes(64))
    elif make == "a file":
        folder.rmdir()
        folder.write_text("not a folder")
    elif make == "no gps":
        write_photo(folder / "a.jpg", image, PhotoTags("a.jpg", 64, 48, focal_mm=8.8, pixels_per_mm=4.85))
    code, _, err = run(capsys, "check", folder, "--target", MESHES / "gabled_house.obj", "--geo-origin", *ORIGIN,
                       "-o", tmp_path / "out")
    assert_one_line_error(code, err, *words)


def test_no_neighbours_to_match_is_one_line(tmp_path, capsys):
    from tests.test_bad_input import assert_one_line_error, run

    (tmp_path / "photos").mkdir()
    code, _, err = run(capsys, "check", tmp_path / "photos", "--target", MESHES / "gabled_house.obj",
                       "-o", tmp_path / "out", "--neighbours", "0")
    assert_one_line_error(code, err, "--neighbours")
