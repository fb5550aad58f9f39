"""coverplan simulate: photos rendered along a flight, reconstructed by COLMAP, judged from
COLMAP's own output (registered images, 3D points), never from the planner's numbers."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
from conftest import MESHES

from coverplan import get_camera, load_scene, plan
from coverplan.errors import ParameterError

pycolmap = pytest.importorskip("pycolmap", reason="simulate needs the sfm extra")

from coverplan.simulate import Simulation, simulate  # noqa: E402

# px: below the default 1024 to keep the 43-photo flight near a minute on 2 cores; the verdict
# is the same (768 px: 99.2 % rebuilt, 1024 px: 99.3 %, every class within 0.1 pp).
WIDTH = 768


@pytest.fixture(scope="module")
def house():
    scene = load_scene(MESHES / "gabled_house.obj")
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)
    return scene, route


@pytest.fixture(scope="module")
def simulated(house, tmp_path_factory):
    scene, route = house
    out = tmp_path_factory.mktemp("sim")
    return simulate(route, scene, out, conditions="ideal", width=WIDTH), out


def test_default_plan_reconstructs_as_one_model(simulated, house):
    sim, out = simulated
    _scene, route = house
    assert sim.photos == len(route.shots)
    assert sim.models == 1 and sim.registered >= 0.98 * sim.photos, sim.table()
    # The alignment is a similarity fitted to the true centres: a correct reconstruction puts
    # every registered camera within centimetres of where the route flies it.
    assert sim.centre_error_m["median"] < 0.05 and sim.centre_error_m["max"] < 0.25, sim.table()
    # DESIGN.md's bar, from COLMAP's points: >= 95 % of the surface within 0.2 m of one, and
    # >= 90 % of every class (measured 99.2 %, the least class 96.0 %).
    by = sim.surface["by_radius"]["0.2"]
    assert by["pct"] >= 95.0, sim.table()
    assert min(by["by_class_pct"].values()) >= 90.0, sim.table()
    assert sim.reconstructable
    assert sim.surface["by_radius"]["0.1"]["pct"] <= by["pct"]


# Under field conditions: the drone's GNSS, heading and gimbal error, the moving sun with cast
# shadows, clouds, auto exposure, sensor noise, textures at the materials' own scales. At the
# default 1024 px (at 640 px this draw rebuilds 92.6 %: too coarse for the bar). Matched as a
# large flight is, by COLMAP's spatial matcher on the photos' GNSS tags, with 16 neighbours
# each instead of 50 to keep the test near 2 minutes.
FIELD_SEED = 0


@pytest.fixture(scope="module")
def field(house, tmp_path_factory):
    scene, route = house
    out = tmp_path_factory.mktemp("field")
    return simulate(route, scene, out, conditions="field", draws=1, seed=FIELD_SEED, exhaustive_limit=0,
                    spatial_neighbours=16), out


def _colmap_verdict(out, scene, sim):
    """Registered photos and rebuilt surface (0.2 m) read back from COLMAP's own files, its
    points brought into the scene by simulate's alignment (checked to be the same cloud)."""
    from coverplan.sfm.judge import judge_samples, reconstructed_surface
    models = sorted((out / "colmap" / "sparse").iterdir())
    recs = [pycolmap.Reconstruction(m) for m in models]
    best = max(recs, key=lambda r: r.num_reg_images())
    assert best.num_points3D() == len(sim.model_points)
    by = reconstructed_surface(judge_samples(scene, 0.1), sim.model_points)["by_radius"]["0.2"]
    return best.num_reg_images(), len(recs), by


@pytest.mark.xdist_group("field")
def test_field_flight_of_the_default_plan_reconstructs(field, house):
    """The default plan (with its pose margin), flown as a GNSS drone would fly it."""
    sim, out = field
    scene, route = house
    assert sim.conditions == "field" and sim.texture == "noise"
    # The photos really were taken off the plan: a flight-wide bias of about a metre.
    assert sim.flown_offset_m["median"] > 0.3, sim.flown_offset_m
    registered, n_models, by = _colmap_verdict(out, scene, sim)
    # Measured: 38 of 38 in one model, 97.3 % rebuilt, the east face (in shadow) 92.3 %.
    assert n_models == 1 and registered >= 0.98 * len(route.shots), sim.table()
    assert by["pct"] >= 95.0 and min(by["by_class_pct"].values()) >= 90.0, sim.table()
    assert sim.reconstructable


@pytest.mark.xdist_group("field")
def test_without_the_pose_margin_the_field_flight_loses_more(field, house, tmp_path):
    """The same house planned with the rules as given (no pose margin), flown in the same field
    draw: the face that suffers most (the east gable, in shadow all flight) loses more.
    Measured: 36 photos, 95.0 % rebuilt, east 84.5 %, against 38 photos, 97.3 %, east 92.3 %."""
    sim, out = field
    scene, _route = house
    bare = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, pose_margin="none")
    assert len(bare.shots) < len(_route.shots)
    lost = simulate(bare, scene, tmp_path / "bare", conditions="field", draws=1, seed=FIELD_SEED, exhaustive_limit=0,
                    spatial_neighbours=16)
    _registered, _n, by_margin = _colmap_verdict(out, scene, sim)
    _registered, _n, by_bare = _colmap_verdict(tmp_path / "bare", scene, lost)
    assert min(by_bare["by_class_pct"].values()) < min(by_margin["by_class_pct"].values()) - 2.0, (
        lost.table(), sim.table())
    assert by_bare["pct"] < by_margin["pct"], (lost.table(), sim.table())


def test_verdict_comes_from_colmap_output(simulated, house):
    """Re-read what COLMAP wrote and judge it independently of simulate's own bookkeeping."""
    sim, out = simulated
    scene, route = house
    models = sorted((out / "colmap" / "sparse").iterdir())
    assert models, "COLMAP wrote no model"
    sizes = []
    for m in models:
        rec = pycolmap.Reconstruction(m)
        sizes.append(rec.num_reg_images())
    assert max(sizes) == sim.registered
    # Points of the saved cloud lie on the target: most within 0.1 m of the mesh surface.
    import trimesh
    pts = np.array([p.xyz for p in pycolmap.Reconstruction(models[0]).points3D.values()])
    # COLMAP's frame is arbitrary: bring its points over with simulate's alignment and check
    # they land on the mesh (a wrong alignment or wrong matches would scatter them).
    assert len(pts) == len(sim.model_points)
    pts = sim.model_points
    mesh = scene.targets[0].mesh
    _closest, dist, _tri = trimesh.proximity.closest_point(mesh, pts[np.random.default_rng(3).choice(len(pts), 2000)])
    near_ground = pts[:, 2] < scene.ground_z + 0.1
    assert np.median(dist) < 0.05
    assert len(pts) > 1000 and not near_ground.all()


def test_thesis_rule_falls_apart_where_the_default_holds(simulated, house, tmp_path):
    """The thesis's 'two views 5 deg apart' with the fewest photos: SfM cannot chain them."""
    sim, _out = simulated
    scene, route = house
    thesis = plan(scene, route.camera, gsd=0.004, security=3.0, rule="thesis")
    bad = simulate(thesis, scene, tmp_path / "thesis", conditions="ideal", width=WIDTH)
    assert not bad.reconstructable
    assert bad.registered < 0.9 * bad.photos, bad.table()
    assert bad.reconstructed_pct < sim.reconstructed_pct - 30.0, (bad.table(), sim.table())


def test_saved_simulation_loads_for_reports(simulated, tmp_path):
    sim, out = simulated
    path = sim.save(tmp_path / "simulation.json")
    back = Simulation.load(path)
    assert back.registered == sim.registered and back.shot_registered.tolist() == sim.shot_registered.tolist()
    assert len(back.model_points) == len(sim.model_points)
    data = json.loads(path.read_text())
    assert data["surface"]["by_radius"]["0.2"]["pct"] == pytest.approx(sim.reconstructed_pct)
    hit = back.reconstructed_at(sim.sample_points)
    assert hit.mean() == pytest.approx((sim.sample_distance <= 0.2).mean(), abs=0.02)


def test_cli_simulate_and_report(simulated, house, tmp_path, capsys):
    from coverplan.cli import main
    sim, out = simulated
    _scene, route = house
    route_path = route.save(tmp_path / "house.json")
    report = tmp_path / "house.html"
    assert main(["report", str(route_path), "--target", str(MESHES / "gabled_house.obj"), "-o", str(report),
                 "--simulation", str(sim.save(tmp_path / "simulation.json")), "-q"]) == 0
    html = report.read_text()
    assert "Reconstruction (simulated photos, COLMAP)" in html and "reconstructed (COLMAP, 0.2 m)" in html
    assert main(["report", str(route_path), "--target", str(MESHES / "gabled_house.obj"), "-o", str(report),
                 "--simulation", str(tmp_path / "nope.json"), "-q"]) == 2
    assert "no such file" in capsys.readouterr().err


def test_without_pycolmap_simulate_says_how_to_get_it(monkeypatch, house, tmp_path, capsys):
    from coverplan.cli import main
    _scene, route = house
    route_path = route.save(tmp_path / "house.json")
    monkeypatch.setitem(sys.modules, "pycolmap", None)
    with pytest.raises(ParameterError, match=r"pip install 'coverplan\[sfm\]'"):
        simulate(route, _scene, tmp_path / "x")
    assert main(["simulate", str(route_path), "--target", str(MESHES / "gabled_house.obj"), "-o",
                 str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("pip install 'coverplan[sfm]'") and len(err.splitlines()) == 1


def test_large_flights_match_photos_that_see_the_same_surface():
    """Pairs for large flights come from what the photos see, not where the cameras are."""
    from coverplan.sfm.colmap import covisible_pairs
    rng = np.random.default_rng(0)
    wall_a = rng.random((500, 3)) * [10, 0.1, 10]
    wall_b = rng.random((500, 3)) * [0.1, 10, 10] + [40, 0, 0]
    seen = [wall_a, wall_a[::2], wall_b, wall_b[1::2], np.zeros((0, 3))]
    pairs = covisible_pairs(seen, cell=1.0, k=3)
    assert (0, 1) in pairs and (2, 3) in pairs
    assert not any(i in (0, 1) and j in (2, 3) for i, j in pairs)
    assert not any(4 in p for p in pairs)
