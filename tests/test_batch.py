"""coverplan batch: buildings of the shipped CityJSON sample on a real 2-worker Dask cluster,
one worker killed on purpose, one building with broken geometry; then a resumed run."""

from __future__ import annotations

import csv
import functools
import json
import os
import sys

import numpy as np
import pytest

from tests.helpers import MESHES
from tests.independent import polyline_min_distance

pytest.importorskip("distributed")
import cloudpickle  # noqa: E402  (installed with distributed)

from coverplan import get_camera, load_scene, plan  # noqa: E402
from coverplan.batch.outputs import completed_row
from coverplan.batch.run import BatchSettings, plan_building, run_batch
from coverplan.batch.selecting import folder_names, select_buildings
from coverplan.errors import ParameterError  # noqa: E402
from coverplan.flight.route import Route  # noqa: E402
from coverplan.io import read_city_model  # noqa: E402

CITY = MESHES / "citygml" / "lod2_buildings_v2.json.gz"
CORNER = "FZK_GUID_1F3E679D-E226-4535-926C-7390977FB25A"  # 6 x 8 m house at (0, 0)
RADIUS = 12.0  # neighbours within 12 m: a few houses each, to keep the test quick
KILLED, BROKEN = 1, 2  # which of the three chosen buildings fails, and how

# Workers unpickle the fault-injecting task; they need this module's code, not its import path.
cloudpickle.register_pickle_by_value(sys.modules[__name__])


def settings(**changes) -> BatchSettings:
    options = dict(gsd=0.005, security=3.0, lp_time_limit=5.0)
    return BatchSettings(camera=get_camera("phantom4pro"), plan_options=options, exports=["qgc"],
                         export_options={"speed": 5.0}, report=False, context_radius=RADIUS, **changes)


@pytest.fixture(scope="module")
def model():
    return read_city_model(CITY)


@pytest.fixture(scope="module")
def three(model):
    return [b.id for b in model.buildings[:3]]


def faulty(job, kill: str, broken: str):
    """The real task, except one building kills its worker and one has broken geometry."""
    if job.id == kill:
        os._exit(13)  # as if the OOM killer took the worker
    if job.id == broken:
        target_id, tri = job.neighbourhood.parts[0]
        job.neighbourhood.parts[0] = (target_id, np.full_like(tri, np.nan))
    return plan_building(job)


@pytest.fixture(scope="module")
def first_run(tmp_path_factory, three):
    out = tmp_path_factory.mktemp("batch")
    task = functools.partial(faulty, kill=three[KILLED], broken=three[BROKEN])
    result = run_batch(CITY, out, settings(), buildings=three, workers=2, task=task)
    return out, result


def test_failures_are_rows_and_the_rest_is_planned(first_run, three):
    out, result = first_run
    rows = {r["id"]: r for r in csv.DictReader(open(out / "summary.csv", encoding="utf-8"))}
    assert list(rows) == three
    assert rows[three[0]]["status"] == "planned"
    assert rows[three[KILLED]]["status"] == "failed" and "worker" in rows[three[KILLED]]["error"]
    assert rows[three[BROKEN]]["status"] == "failed" and "nan" in rows[three[BROKEN]]["error"].lower()
    assert [r["status"] for r in result.rows] == ["planned", "failed", "failed"]
    # failed buildings leave no route; no temporary folders are left behind
    assert not (out / "buildings" / rows[three[KILLED]]["folder"] / "route.json").exists()
    assert not [p for p in (out / "buildings").iterdir() if p.name.startswith(".")]
    features = json.loads((out / "summary.geojson").read_text())["features"]
    assert [f["properties"]["status"] for f in features] == ["planned", "failed", "failed"]
    lon, lat = np.array(features[0]["geometry"]["coordinates"][0]).T
    assert 13.0 < lon.min() < lon.max() < 13.1 and 52.3 < lat.min() < lat.max() < 52.4  # EPSG:3068 is Berlin
    index = (out / "index.html").read_text()
    assert index.count("<polygon") == 3 and "failed" in index


def test_planned_route_is_what_plan_building_makes_and_is_safe(first_run, three):
    out, _ = first_run
    folder = out / "buildings" / folder_names(read_city_model(CITY).buildings[:1])[0]
    route = Route.load(folder / "route.json")
    assert (folder / "route.plan").stat().st_size > 0
    scene = load_scene(CITY, building=three[0], context_radius=RADIUS)
    alone = plan(scene, get_camera("phantom4pro"), gsd=0.005, security=3.0, lp_time_limit=5.0)
    np.testing.assert_allclose(route.positions, alone.positions, atol=1e-3)  # the file keeps 0.1 mm
    # independent of FCL: trimesh distances along the flight to the house and its neighbours
    assert polyline_min_distance(route.positions, scene.meshes, step=0.3) >= 3.0 - 1e-3
    assert len(scene.obstacles) >= 1


def test_rerun_completes_only_the_missing_buildings(first_run, three):
    out, _ = first_run
    kept = out / "buildings" / folder_names(read_city_model(CITY).buildings[:1])[0] / "result.json"
    stamp = kept.stat().st_mtime_ns
    result = run_batch(CITY, out, settings(), buildings=three, workers=2)
    assert (result.skipped, result.planned_now) == (1, 2)
    assert [r["status"] for r in result.rows] == ["planned"] * 3
    assert kept.stat().st_mtime_ns == stamp  # not rewritten
    for row in result.rows:
        assert Route.load(out / "buildings" / row["folder"] / "route.json").metrics["evaluation"]["safe"]
    # other settings make other routes: nothing is skipped then
    again = run_batch(CITY, out, settings(), buildings=three[:1], workers=1)
    assert again.skipped == 1
    changed = settings(lod=1)
    assert completed_row(out, result.rows[0]["folder"], changed.fingerprint()) is None


def test_an_incomplete_folder_is_not_taken_for_done(tmp_path, model, three):
    result = run_batch(model, tmp_path, settings(), buildings=three[:1], workers=1)
    row = result.rows[0]
    folder = tmp_path / "buildings" / row["folder"]
    assert completed_row(tmp_path, row["folder"], row["key"]) is not None
    with open(folder / "route.plan", "ab") as handle:  # a truncated or edited file
        handle.write(b" ")
    assert completed_row(tmp_path, row["folder"], row["key"]) is None


def test_choosing_buildings(model):
    everything = model.buildings
    assert len(select_buildings(model, everything=True)) == 100
    west = select_buildings(model, bbox=[-1, -1, 20, 20])  # centres of the first two rows and columns
    assert {b.id for b in west} >= {CORNER} and len(west) == 4
    assert len(select_buildings(model, where=[("roofType", "1030"), ("storeysAboveGround", "5")])) >= 1
    assert len(select_buildings(model, where=[("measuredHeight", "11")])) \
        == sum(b.attributes.get("measuredHeight") == 11.0 for b in everything)
    with pytest.raises(ParameterError, match="no building"):
        select_buildings(model, bbox=[500, 500, 600, 600])
    with pytest.raises(ParameterError, match="no city object with id"):
        select_buildings(model, ids=["NOPE"])
    with pytest.raises(ParameterError, match="choose the buildings"):
        select_buildings(model)


def test_folder_names_are_safe_and_unique():
    class Obj:
        def __init__(self, i):
            self.id = i
    names = folder_names([Obj("a/b"), Obj("a:b"), Obj(".."), Obj("A_B")])
    assert len(set(n.lower() for n in names)) == 4
    assert all("/" not in n and not n.startswith(".") for n in names)


def test_every_building_flies_over_the_dtm_given(tmp_path, model):
    """--terrain reaches the workers: each building's route follows the DTM (not the flat
    ground of a city model without relief), and the settings' fingerprint changes with it."""
    rasterio = pytest.importorskip("rasterio")
    from rasterio.transform import from_origin

    from coverplan.batch.run import BuildingJob

    def ground(x, y):
        return 0.1 * x - 0.5 + 0.02 * y  # 1.1 m across the house; 6 m across the 60 m site

    cell, n = 0.5, 240
    centres = -60 + cell / 2 + np.arange(n) * cell
    gx, gy = np.meshgrid(centres, centres[::-1])
    dtm = tmp_path / "dtm.tif"
    with rasterio.open(dtm, "w", driver="GTiff", height=n, width=n, count=1, dtype="float64",
                       transform=from_origin(-60, 60, cell, cell), crs="EPSG:3068") as f:
        f.write(ground(gx, gy), 1)
    with_dtm = settings(terrain=str(dtm))
    assert with_dtm.fingerprint() != settings().fingerprint()
    job = BuildingJob(CORNER, "corner", model.neighbourhood(CORNER, RADIUS, None), with_dtm, "key")
    out = plan_building(job)
    assert out["row"]["status"] == "planned", out["row"]
    (tmp_path / "route.json").write_bytes(out["files"]["route.json"])
    route = Route.load(tmp_path / "route.json")
    p = route.positions
    np.testing.assert_allclose(route.ground_z, ground(p[:, 0], p[:, 1]), atol=0.02)
    t = np.linspace(0, 1, 40)[None, :, None]
    along = (p[:-1, None] * (1 - t) + p[1:, None] * t).reshape(-1, 3)
    assert (along[:, 2] - ground(along[:, 0], along[:, 1])).min() >= 3.0 - 0.02  # min altitude = security
    with pytest.raises(ParameterError, match="no such DTM"):
        settings(terrain=str(tmp_path / "missing.tif"))
