"""Terrain: a DTM (GeoTIFF written here) or a city model's relief under the flight. The
minimum altitude must hold above the real ground along every segment, checked against
heights the test computes itself (the plane or hill it wrote), not the planner's grid."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import RegularGridInterpolator

from coverplan import get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.flight.route import Route
from coverplan.world.terrain import Terrain
from tests.helpers import UTM_EAST, UTM_NORTH, box

rasterio = pytest.importorskip("rasterio")
from rasterio.transform import from_origin  # noqa: E402

GRADE = 0.15
SECURITY = 3.0
CELL = 0.5
HALF = 60.0  # the DTM covers +-60 m around the house


def write_dtm(path, height, crs=None, west=-HALF, north=HALF, cell=CELL, n=int(2 * HALF / CELL)):
    """A GeoTIFF of ``height(x, y)`` at its pixel centres."""
    x = west + cell / 2 + np.arange(n) * cell
    y = north - cell / 2 - np.arange(n) * cell
    gx, gy = np.meshgrid(x, y)
    with rasterio.open(path, "w", driver="GTiff", height=n, width=n, count=1, dtype="float64",
                       transform=from_origin(west, north, cell, cell), crs=crs) as f:
        f.write(height(gx, gy), 1)
    return path


def house_on(tmp_path, ground, name="house.obj"):
    """A 12 x 8 m house, eaves 6 m above its highest ground, walls down below its lowest."""
    corners = np.array([[-6, -4], [6, -4], [6, 4], [-6, 4]], float)
    z = ground(corners[:, 0], corners[:, 1])
    mesh = box(-6, -4, z.min() - 0.5, 6, 4, z.max() + 6.0)
    mesh.export(tmp_path / name)
    return tmp_path / name


def points_along(positions, step=0.05):
    out = [positions[:1]]
    for a, b in zip(positions[:-1], positions[1:]):
        t = np.linspace(0, 1, max(int(np.ceil(np.linalg.norm(b - a) / step)), 1) + 1)[1:, None]
        out.append(a * (1 - t) + b * t)
    return np.vstack(out)


ARGS = ["--camera", "phantom4pro", "--gsd", "0.004", "--security", str(SECURITY), "--quiet"]


def plan_site(tmp_path, ground, over_terrain: bool = True):
    """A DTM of ``ground`` and a house standing on it, planned through the CLI with the DTM
    (or on flat ground): (dtm, house, route file, route)."""
    dtm = write_dtm(tmp_path / "dtm.tif", ground)
    house = house_on(tmp_path, ground)
    out = tmp_path / "r.json"
    assert main(["plan", str(house), *(["--terrain", str(dtm)] if over_terrain else []), *ARGS, "-o", str(out)]) == 0
    return dtm, house, out, Route.load(out)


def evaluate_json(capsys, route_file, house, dtm) -> dict:
    """``coverplan evaluate --json`` of the route against the house and the DTM."""
    capsys.readouterr()
    assert main(["evaluate", str(route_file), "--target", str(house), "--terrain", str(dtm), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def slope(x, y):
    return GRADE * x


def test_slope_plan_keeps_the_minimum_altitude_above_the_dtm_everywhere(tmp_path, capsys):
    dtm, house, out, route = plan_site(tmp_path, slope)
    along = points_along(route.positions)
    above = along[:, 2] - slope(along[:, 0], along[:, 1])
    assert above.min() >= SECURITY - 1e-3  # min altitude = security by default
    # Uphill the flight is higher than downhill: it follows the ground, not a flat floor.
    east, west = route.positions[:, 0] > 8, route.positions[:, 0] < -8
    assert route.positions[east, 2].min() > route.positions[west, 2].min() + 1.5
    # Heights relative to take-off count from the ground under the start.
    np.testing.assert_allclose(route.ground_z, slope(route.positions[:, 0], 0), atol=1e-3)
    assert route.takeoff_z == pytest.approx(slope(route.positions[0, 0], 0), abs=1e-3)
    # The evaluator, given the DTM, agrees; every sample above the ground is covered.
    m = evaluate_json(capsys, out, house, dtm)
    assert m["safe"] and m["terrain"] == "dtm.tif"
    assert m["lowest_above_ground_m"] >= SECURITY - 1e-3 and m["segments_below_min_altitude_count"] == 0
    assert m["coverage_pct"] >= 99.5
    # Wall below the ground is left out, and its area is what the slope buries: the walls reach
    # 0.5 m below the lowest ground (-0.9 m); the long walls lose that strip and a triangle
    # 12 m by 1.8 m, the short walls 0.5 m (downhill) and 2.3 m (uphill) over 8 m.
    buried = 2 * (12 * 0.5 + 0.5 * 12 * 1.8) + 8 * 0.5 + 8 * (0.5 + 1.8)
    assert m["left_out_area_m2"]["below_ground"] == pytest.approx(buried, rel=0.05)


def test_flat_plan_flies_too_low_over_the_slope_and_the_evaluator_says_so(tmp_path, capsys):
    dtm, house, out, route = plan_site(tmp_path, slope, over_terrain=False)  # flat at the lowest point
    m = evaluate_json(capsys, out, house, dtm)
    along = points_along(route.positions)
    truth = (along[:, 2] - slope(along[:, 0], along[:, 1])).min()
    assert truth < SECURITY - 0.5 and not m["safe"]
    assert m["lowest_above_ground_m"] == pytest.approx(truth, abs=0.01)


def test_flat_dtm_plans_exactly_as_flat_ground(tmp_path):
    dtm = write_dtm(tmp_path / "flat.tif", lambda x, y: np.zeros_like(x))
    house = tmp_path / "box.obj"
    box(-6, -4, 0, 6, 4, 7).export(house)
    cam = get_camera("phantom4pro")
    flat = plan(load_scene(house), cam, gsd=0.004, security=SECURITY)
    over = plan(load_scene(house, terrain=dtm), cam, gsd=0.004, security=SECURITY)
    np.testing.assert_allclose(over.positions, flat.positions, atol=1e-9)
    np.testing.assert_array_equal(over.shot, flat.shot)


def hill(x, y):
    """Ground rising 10 m to a round hill 22 m east of the house, on a gentle tilt."""
    return 0.03 * y + 10.0 * np.exp(-((x - 22.0) ** 2 + y ** 2) / (2 * 7.0 ** 2))


def test_hill_beside_the_house_is_flown_over_or_around_at_the_minimum_altitude(tmp_path, capsys):
    dtm, house, out, route = plan_site(tmp_path, hill)
    # Independent ground: a linear interpolation of the raster's own pixel centres.
    with rasterio.open(dtm) as f:
        grid = f.read(1)[::-1]
        x = f.transform.c + CELL / 2 + np.arange(f.width) * CELL
        y = f.transform.f - f.height * CELL + CELL / 2 + np.arange(f.height) * CELL
    ground = RegularGridInterpolator((y, x), grid)
    along = points_along(route.positions)
    above = along[:, 2] - ground(np.column_stack([along[:, 1], along[:, 0]]))
    # Bilinear and triangle-wise interpolation differ inside a cell by at most a hair here.
    assert above.min() >= SECURITY - 0.02
    scene = load_scene(house, terrain=dtm)
    d = trimesh.proximity.closest_point(scene.targets[0].mesh, along)[1]
    assert d.min() >= SECURITY - 1e-6
    # The hill hides part of the east wall's foot from low viewpoints, not all of it.
    m = evaluate_json(capsys, out, house, dtm)
    assert m["safe"] and m["coverage_pct"] >= 99.5


def test_dtm_heights_are_taken_as_they_are_at_its_pixel_centres(tmp_path):
    """A bank 3 m high and a sharp hilltop: read in its own frame, the planner's ground passes
    through every pixel centre's height (no averaging that lowers the top of the bank)."""
    def bank(x, y):
        return np.where(x > 4.1, 3.0, 0.0) + 2.0 * np.exp(-((x + 9.0) ** 2 + (y - 3.0) ** 2) / 2.0)

    dtm = write_dtm(tmp_path / "bank.tif", bank)
    house = tmp_path / "box.obj"
    box(-3, -3, 0, 3, 3, 6).export(house)
    scene = load_scene(house, terrain=dtm)
    centres = -HALF + CELL / 2 + np.arange(int(2 * HALF / CELL)) * CELL
    near = centres[np.abs(centres) < 30]
    gx, gy = (g.ravel() for g in np.meshgrid(near, near))
    np.testing.assert_allclose(scene.terrain.height(np.column_stack([gx, gy])), bank(gx, gy), atol=1e-9)


def test_dtm_in_another_crs_is_reprojected_to_the_models(tmp_path):
    from pyproj import Transformer
    to_utm = Transformer.from_crs("EPSG:4326", "EPSG:25832", always_xy=True)
    to_geo = Transformer.from_crs("EPSG:25832", "EPSG:4326", always_xy=True)

    def utm_plane(e, n):
        return 250.0 + GRADE * (e - UTM_EAST) + 0.05 * (n - UTM_NORTH)

    lon0, lat0 = to_geo.transform(UTM_EAST - 80, UTM_NORTH + 80)
    cell = 0.5 / 111_000  # about half a metre

    def in_degrees(lon, lat):
        return utm_plane(*to_utm.transform(lon, lat))

    dtm = write_dtm(tmp_path / "geo.tif", in_degrees, crs="EPSG:4326", west=lon0, north=lat0, cell=cell, n=330)
    mesh = box(0, 0, -2, 10, 8, 8)
    mesh.apply_translation([UTM_EAST, UTM_NORTH, 250.0])
    mesh.export(tmp_path / "house.obj")
    scene = load_scene(tmp_path / "house.obj", crs="EPSG:25832", terrain=dtm)
    rng = np.random.default_rng(3)
    # Square degrees: the raster reaches about 108 m east and 165 m south of its corner.
    source = np.column_stack([UTM_EAST + rng.uniform(-30, 20, 200), UTM_NORTH + rng.uniform(-30, 40, 200)])
    local = scene.to_local(np.column_stack([source, np.zeros(len(source))]))[:, :2]
    got = scene.terrain.height(local) + scene.origin[2]
    np.testing.assert_allclose(got, utm_plane(source[:, 0], source[:, 1]), atol=0.05)


def test_city_model_relief_becomes_the_terrain_not_an_obstacle(tmp_path):
    """A CityJSON with a house and a TINRelief sloping at 15 %."""
    xs = np.arange(-60, 61, 10.0)
    gx, gy = np.meshgrid(xs, xs)
    verts = np.column_stack([gx.ravel(), gy.ravel(), GRADE * gx.ravel()])
    n = len(xs)
    idx = np.arange(n * n).reshape(n, n)
    tri = []
    for j in range(n - 1):
        for i in range(n - 1):
            a, b, c, d = idx[j, i], idx[j, i + 1], idx[j + 1, i], idx[j + 1, i + 1]
            tri += [[[int(a), int(b), int(d)]], [[int(a), int(d), int(c)]]]
    house = box(-6, -4, GRADE * -6 - 0.5, 6, 4, GRADE * 6 + 6)
    hv = len(verts)
    verts = np.vstack([verts, house.vertices])
    shell = [[[int(v + hv) for v in f]] for f in house.faces]
    doc = {"type": "CityJSON", "version": "2.0", "transform": {"scale": [0.001] * 3, "translate": [0, 0, 0]},
           "CityObjects": {
               "house": {"type": "Building", "geometry": [{"type": "Solid", "lod": "2", "boundaries": [shell]}]},
               "relief": {"type": "TINRelief", "geometry": [{"type": "CompositeSurface", "lod": "2",
                                                             "boundaries": tri}]}},
           "vertices": np.round(verts * 1000).astype(int).tolist()}
    path = tmp_path / "site.city.json"
    path.write_text(json.dumps(doc))
    scene = load_scene(path)
    assert scene.terrain is not None and len(scene.parts) == 1  # the relief is no obstacle
    probe = np.array([[-40.0, 5.0], [0.0, 20.0], [35.0, -12.0]])
    np.testing.assert_allclose(scene.terrain.height(probe), GRADE * probe[:, 0], atol=1e-3)
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=SECURITY)
    along = points_along(route.positions)
    assert (along[:, 2] - GRADE * along[:, 0]).min() >= SECURITY - 1e-3


CITYGML_RELIEF = """<?xml version="1.0" encoding="UTF-8"?>
<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml"
 xmlns:dem="http://www.opengis.net/citygml/relief/2.0" xmlns:bldg="http://www.opengis.net/citygml/building/2.0">
 <core:cityObjectMember><bldg:Building gml:id="b1"><bldg:lod1Solid><gml:Solid><gml:exterior><gml:CompositeSurface>
 {walls}
 </gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod1Solid></bldg:Building></core:cityObjectMember>
 <core:cityObjectMember><dem:ReliefFeature gml:id="r1"><dem:lod>1</dem:lod><dem:reliefComponent>
  <dem:TINRelief gml:id="t1"><dem:lod>1</dem:lod><dem:tin><gml:TriangulatedSurface><gml:trianglePatches>
  {triangles}
  </gml:trianglePatches></gml:TriangulatedSurface></dem:tin></dem:TINRelief></dem:reliefComponent>
 </dem:ReliefFeature></core:cityObjectMember>
</core:CityModel>"""


def _poly(points, tag="gml:Polygon", ring="gml:exterior"):
    text = " ".join(f"{v:g}" for p in list(points) + [points[0]] for v in p)
    inner = f"<{ring}><gml:LinearRing><gml:posList>{text}</gml:posList></gml:LinearRing></{ring}>"
    return f"<gml:surfaceMember><{tag}>{inner}</{tag}></gml:surfaceMember>" if tag == "gml:Polygon" \
        else f"<{tag}>{inner}</{tag}>"


def test_citygml_relief_feature_is_read_as_terrain(tmp_path):
    house = box(-6, -4, -2, 6, 4, 8)
    walls = "".join(_poly(t) for t in house.triangles)
    corners = [(-50, -50), (50, -50), (50, 50), (-50, 50)]
    z = {c: 0.1 * c[1] for c in corners}
    tri = [[(*corners[0], z[corners[0]]), (*corners[1], z[corners[1]]), (*corners[2], z[corners[2]])],
           [(*corners[0], z[corners[0]]), (*corners[2], z[corners[2]]), (*corners[3], z[corners[3]])]]
    triangles = "".join(_poly(t, tag="gml:Triangle") for t in tri)
    path = tmp_path / "site.gml"
    path.write_text(CITYGML_RELIEF.format(walls=walls, triangles=triangles))
    scene = load_scene(path)
    assert scene.terrain is not None and len(scene.parts) == 1
    np.testing.assert_allclose(scene.terrain.height([[0, 30], [20, -20]]), [3.0, -2.0], atol=1e-3)


def test_footprints_stand_on_the_terrain(tmp_path):
    from shapely.geometry import box as rect
    from shapely.geometry import mapping
    doc = {"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "EPSG:25832"}},
           "features": [{"type": "Feature", "id": "h", "properties": {"h": 6.0},
                         "geometry": mapping(rect(UTM_EAST - 6, UTM_NORTH - 4, UTM_EAST + 6, UTM_NORTH + 4))}]}
    (tmp_path / "fp.geojson").write_text(json.dumps(doc))
    dtm = write_dtm(tmp_path / "dtm.tif", lambda e, n: 250.0 + GRADE * (e - UTM_EAST), crs="EPSG:25832",
                    west=UTM_EAST - HALF, north=UTM_NORTH + HALF)
    scene = load_scene(tmp_path / "fp.geojson", height_attribute="h", terrain=dtm)
    lo, hi = scene.to_source(scene.bounds("target"))
    assert lo[2] == pytest.approx(250.0 - GRADE * 6, abs=0.02)  # from the lowest ground along the outline
    assert hi[2] == pytest.approx(250.0 - GRADE * 6 + 6.0, abs=0.02)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), nx=st.integers(2, 9), ny=st.integers(2, 9),
       dx=st.floats(0.3, 3.0), dy=st.floats(0.3, 3.0), altitude=st.floats(0.0, 4.0))
def test_segment_check_is_exact_on_random_ground(seed, nx, ny, dx, dy, altitude):
    """The crossing-based test agrees with dense sampling of the same surface, inside and
    beyond the grid (where the edge heights stand in)."""
    rng = np.random.default_rng(seed)
    terrain = Terrain(-1.0, 2.0, dx, dy, rng.normal(0, 2, (ny, nx)))
    a = rng.uniform(-8, 8 + nx * dx, (300, 3))
    b = a + rng.normal(0, 5, (300, 3))
    a[:, 2], b[:, 2] = rng.uniform(-4, 8, 300), rng.uniform(-4, 8, 300)
    t = np.linspace(0, 1, 3001)[:, None]
    dense = np.array([(a[k] + t * (b[k] - a[k]))[:, 2] - terrain.height((a[k] + t * (b[k] - a[k]))[:, :2])
                      for k in range(len(a))]).min(axis=1)
    lowest = terrain.lowest_above(a, b)
    assert (lowest <= dense + 1e-9).all()  # never above any sampled point
    assert np.abs(lowest - dense).max() < 0.02 * max(dx, dy) * 10  # and the sampling comes close to it
    ok = terrain.segments_above(a, b, altitude)
    np.testing.assert_array_equal(ok, lowest >= altitude - 1e-6)
    # Sampled points are real points: one below the altitude fails the segment. Clear by
    # sampling means clear by more than the most the height can fall between two samples.
    rate = np.abs(b[:, 2] - a[:, 2]) + terrain.max_slope * np.linalg.norm(b[:, :2] - a[:, :2], axis=1)
    clear = dense - rate / (len(t) - 1) > altitude + 1e-9
    assert ok[clear].all() and not ok[dense < altitude - 1e-3].any()


def test_exports_count_heights_from_the_ground_under_the_start(tmp_path):
    """On a slope the take-off point is not at the ground's lowest point: QGC and Litchi heights
    relative to take-off must start from the ground under the start, and the mission read back
    lands where the route is."""
    def ground(e, n):
        return 250.0 + GRADE * (e - UTM_EAST)

    dtm = write_dtm(tmp_path / "dtm.tif", ground, crs="EPSG:25832", west=UTM_EAST - HALF, north=UTM_NORTH + HALF)
    mesh = box(-6, -4, -1.5, 6, 4, 7.5)
    mesh.apply_translation([UTM_EAST, UTM_NORTH, 250.0])
    mesh.export(tmp_path / "house.obj")
    start = [UTM_EAST + 25.0, UTM_NORTH, 0.0]  # uphill: raised to 3 m clear of the slope (ground 253.75 m)
    out = tmp_path / "r.json"
    assert main(["plan", str(tmp_path / "house.obj"), "--crs", "EPSG:25832", "--terrain", str(dtm), *ARGS,
                 "--start", *map(str, start), "--export", "qgc", "--no-evaluate", "-o", str(out)]) == 0
    route = Route.load(out)
    origin = np.array(route.frame["origin"])
    source = route.positions + origin
    takeoff = ground(start[0], start[1])
    assert route.takeoff_z + origin[2] == pytest.approx(takeoff, abs=1e-3)
    # 3 m from the 15 % slope in 3D is 3.03 m above it; the planner's envelope of the ground
    # stays above the true one by up to about a cell's rise.
    clear = SECURITY * np.hypot(1.0, GRADE)
    assert takeoff + clear - 1e-3 <= source[0, 2] <= takeoff + clear + 3 * GRADE * CELL
    items = json.loads((tmp_path / "r.plan").read_text())["mission"]["items"]
    alt = np.array([i["params"][6] for i in items if i["command"] == 16])
    np.testing.assert_allclose(alt, source[1:, 2] - takeoff, atol=0.01)
    # Downhill of the start the relative heights go below zero while staying 3 m above the ground.
    assert alt.min() < 0 and (source[:, 2] - ground(source[:, 0], source[:, 1])).min() >= SECURITY - 1e-3


def test_report_draws_the_ground_under_its_frame(tmp_path):
    """The HTML report's 3D view shows the terrain: the DTM's heights, cut to the picture's
    frame (not the whole raster), thinned to at most MAX_TERRAIN_CELLS cells, with a layer
    switch; the page renders without errors."""
    import base64

    from coverplan import evaluate
    from coverplan.report import write_html_report
    from coverplan.report.frame import focus_bounds
    from coverplan.report.html import MAX_TERRAIN_CELLS, report_data
    from tests.test_report import chromium, open_report

    dtm, house, _out, route = plan_site(tmp_path, slope)
    scene = load_scene(house, terrain=dtm)
    ev = evaluate(route, scene)
    grounds = [m for m in report_data(route, scene, ev)["meshes"] if m["role"] == "terrain"]
    assert len(grounds) == 1
    v = np.frombuffer(base64.b64decode(grounds[0]["positions"]), dtype=np.float32).reshape(-1, 3)
    faces = np.frombuffer(base64.b64decode(grounds[0]["indices"]), dtype=np.uint32).reshape(-1, 3)
    np.testing.assert_allclose(v[:, 2], slope(v[:, 0], v[:, 1]), atol=1e-3)
    lo, hi = focus_bounds(route, scene)
    assert (v[:, :2].min(axis=0) <= lo[:2]).all() and (v[:, :2].max(axis=0) >= hi[:2]).all()
    assert np.ptp(v[:, 0]) < 2 * HALF - 10  # cut to the frame, not the 120 m raster
    assert 0 < len(faces) <= 2.2 * MAX_TERRAIN_CELLS and faces.max() < len(v)

    page = write_html_report(route, scene, tmp_path / "site.html", evaluation=ev)
    assert "data-layer=terrain" in page.read_text()
    browser = chromium()
    try:
        open_report(browser, page)
        browser.execute_script("document.querySelector('input[data-layer=terrain]').click();")
        assert not [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    finally:
        browser.quit()


# -- the security distance from the ground in 3D (issue 34) --------------------------------

def test_clearance_envelope_keeps_the_distance_in_3d_and_is_exact_over_flat_ground():
    """Points on the envelope are at least the distance from the ground's own triangle mesh
    (trimesh's closest points, not the planner's grid); over flat ground it is the height."""
    rng = np.random.default_rng(4)
    heights = np.cumsum(rng.normal(0, 0.4, (40, 50)), axis=1) + 3.0 * np.sin(np.arange(40) / 5.0)[:, None]
    ground = Terrain(-10.0, -8.0, 0.5, 0.5, heights)
    env = ground.clearance_envelope(4.0)
    xy = rng.uniform([-9, -7], [13, 10], (3000, 2))
    pts = np.column_stack([xy, env.height(xy)])
    _closest, dist, _tri = trimesh.proximity.closest_point(ground.mesh, pts)
    assert dist.min() >= 4.0 - 1e-6
    assert np.median(dist) < 4.6  # and not far more than asked: within about a cell's rise
    flat = Terrain(0.0, 0.0, 1.0, 1.0, np.full((20, 20), 7.0)).clearance_envelope(3.0)
    np.testing.assert_allclose(flat.heights, 10.0)


STEEP = 0.35  # 35 % (19 deg): 4 m straight up is 3.78 m from the slope


def steep(x, y):
    return STEEP * y


def test_hillside_house_keeps_the_security_distance_from_the_slope_in_3d(tmp_path):
    """A house dug into a 35 % hillside with a tree uphill, planned with the DTM and 4 m
    security: every 5 cm of the flight is >= 4 m from the ground as a surface (trimesh's
    distance to the DTM's own triangles, built here) and from the house and the tree."""
    dtm = write_dtm(tmp_path / "hill.tif", steep)
    house = house_on(tmp_path, steep)
    tree = trimesh.creation.cylinder(radius=2.5, height=9.0, sections=16)
    tree.apply_translation([3.0, 13.0, steep(3.0, 13.0) + 4.0])
    tree.export(tmp_path / "tree.obj")
    out = tmp_path / "r.json"
    assert main(["plan", str(house), "--obstacles", str(tmp_path / "tree.obj"), "--terrain", str(dtm),
                 "--camera", "phantom4pro", "--gsd", "0.005", "--security", "4", "--quiet", "-o", str(out)]) == 0
    route = Route.load(out)
    along = points_along(route.positions)
    # The DTM's heights at its pixel centres, as a triangle mesh of this test's own.
    n, cell = int(2 * HALF / CELL), CELL
    xs = -HALF + cell / 2 + np.arange(n) * cell
    gx, gy = np.meshgrid(xs, xs)
    verts = np.column_stack([gx.ravel(), gy.ravel(), steep(gx, gy).ravel()])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    ground = trimesh.Trimesh(verts, np.vstack([np.column_stack([a, b, c]), np.column_stack([b, d, c])]),
                             process=False)
    _closest, to_ground, _tri = trimesh.proximity.closest_point(ground, along)
    assert to_ground.min() >= 4.0 - 1e-3, to_ground.min()
    # The minimum altitude alone would have allowed 4 m straight above the slope: 3.78 m from it.
    assert (along[:, 2] - steep(along[:, 0], along[:, 1])).min() >= 4.0 / np.cos(np.arctan(STEEP)) - 0.05
    for obstacle in (trimesh.load(house), tree):
        _c, dist, _t = trimesh.proximity.closest_point(obstacle, along[::4])
        assert dist.min() >= 4.0 - 1e-3
