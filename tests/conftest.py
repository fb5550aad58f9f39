from __future__ import annotations

import numpy as np
import pytest


def pytest_addoption(parser):
    parser.addoption("--slow", action="store_true", default=False, help="also run tests marked slow")


# The longest groups of the suite (minutes each), started first so that the two workers of
# ``-n auto --dist loadgroup`` share them instead of one ending the run with a long tail.
LONG_GROUPS = ("field", "random_scenes_1", "random_scenes_2", "photos_check", "benchmark_reconstruction",
               "random_scenes_lanes", "real_photos")


def _group(item) -> str | None:
    mark = item.get_closest_marker("xdist_group")
    return (mark.args[0] if mark.args else mark.kwargs.get("name")) if mark else None


# The fast tier (``pytest -m "not slow_sim"``) leaves out the long groups, every test that
# renders photos and runs COLMAP or runs the benchmark scripts, and the tests that took 3 s or
# more on 2 cores (node ids, or their prefix for every parametrisation), so that it answers in
# under 2 minutes with one test of each concern kept.
SLOW_SIM_MODULES = ("test_simulate", "test_check", "test_benchmarks")
SLOW_SIM_TESTS = (
    "test_airspace.py::test_a_tower_taller_than_the_ceiling_is_flown_below_it",
    "test_api_docs.py::test_the_api_reference_builds_without_a_warning",
    "test_batch.py::test_an_incomplete_folder_is_not_taken_for_done",
    "test_batch.py::test_failures_are_rows_and_the_rest_is_planned",
    "test_batch.py::test_planned_route_is_what_plan_building_makes_and_is_safe",
    "test_batch.py::test_rerun_completes_only_the_missing_buildings",
    "test_city.py::test_lod3_building_with_openings_plans_and_is_covered",
    "test_existing.py::test_an_exported_mission_and_tagged_photos_count_as_the_route_does",
    "test_export.py::test_qgc_plan",
    "test_flights.py::test_a_gimbal_that_cannot_look_up_never_points_up",
    "test_flights.py::test_flights_split_to_fit_a_mission_item_limit",
    "test_flights.py::test_one_flight_when_it_fits_the_battery",
    "test_flights.py::test_plan_exporting_for_px4_keeps_each_flight_within_500_items",
    "test_framing.py::test_narrow_tower_faces_get_framed_views_from_closer_in",
    "test_lanes.py::test_the_tour_trades_a_little_path_for_fewer_reversals",
    "test_passing.py::test_every_flight_reaches_a_mavsdk_autopilot",
    "test_plan.py::test_coverage_rechecked_by_brute_force[fig411]",
    "test_plan.py::test_sample_scene_is_covered_and_safe[courtyard]",
    "test_plan.py::test_sample_scene_is_covered_and_safe[fig411]",
    "test_plan.py::test_sample_scene_is_covered_and_safe[ring]",
    "test_readme.py::test_readme_examples_match_a_fresh_run",
    "test_reconstructability.py::test_braced_ring_has_no_cut_photo",
    "test_reconstructability.py::test_faces_links_are_links_sample_by_sample",
    "test_reconstructability.py::test_links_hold_on_the_evaluators_samples",
    "test_reconstructability.py::test_overhang_undersides_are_seen_as_squarely_as_the_gimbal_allows",
    "test_report_flights.py::test_flight_files_are_judged_together",
    "test_report_flights.py::test_report_reads_missions_and_colours_each_flight",
    "test_route_scene.py::test_city_building_obstacles_and_merge_are_recorded",
    "test_safety.py::test_segment_queries_see_thin_obstacles_between_endpoints[fcl]",
    "test_safety.py::test_segment_queries_see_thin_obstacles_between_endpoints[near]",
    "test_sites.py::test_random_site_flies_safe_over_its_ground_and_clear_of_its_trees",
    "test_terrain.py::test_hillside_house_keeps_the_security_distance_from_the_slope_in_3d",
    "test_terrain.py::test_report_draws_the_ground_under_its_frame",
    "test_terrain.py::test_segment_check_is_exact_on_random_ground",
    "test_voxel.py::test_small_obstacle_between_slices_is_not_seen",
    "test_zones.py::test_segment_test_agrees_with_dense_sampling",
    "test_zones.py::test_the_geofence_reaches_the_autopilot",
    "test_zones.py::test_the_street_is_never_entered",
)


def _slow_sim(item) -> bool:
    if _group(item) in LONG_GROUPS or item.module.__name__.rpartition(".")[2] in SLOW_SIM_MODULES:
        return True
    node = item.nodeid.rpartition("tests/")[2]
    return any(node == t or (node.startswith(t + "[") and "[" not in t) for t in SLOW_SIM_TESTS)


def pytest_collection_modifyitems(config, items):
    for item in items:
        if _slow_sim(item):
            item.add_marker(pytest.mark.slow_sim)
    items.sort(key=lambda item: LONG_GROUPS.index(_group(item)) if _group(item) in LONG_GROUPS else len(LONG_GROUPS))
    if config.getoption("--slow"):
        return
    skip = pytest.mark.skip(reason="slow; run with --slow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def thesis_camera():
    from coverplan import get_camera
    return get_camera("thesis80")


@pytest.fixture
def write_mesh(tmp_path):
    def write(mesh, name):
        path = tmp_path / name
        mesh.export(path)
        return path
    return write


np.set_printoptions(precision=4, suppress=True)


@pytest.fixture(scope="module")
def seed_only_draws():
    """Hypothesis draws from the test's seed alone: it also draws constants it finds in the
    source of loaded modules outside the test folders, which made the drawn scenes depend on
    the install (editable or not) and on which tests had run before in the worker."""
    from hypothesis.internal.conjecture import providers
    with pytest.MonkeyPatch.context() as patch:
        if hasattr(providers, "_get_local_constants"):  # hypothesis >= 6.131: internals, hence the guard
            patch.setattr(providers, "_get_local_constants", providers.Constants)
            patch.setattr(providers, "CONSTANTS_CACHE", type(providers.CONSTANTS_CACHE)(1024))
        yield


# The jobs several test files plan, planned once per test process.

@pytest.fixture(scope="session")
def house_job():
    """The gabled house for a Phantom 4 Pro at 4 mm/px, 3 m security (the simulate sample)."""
    from coverplan import get_camera, load_scene, plan
    from tests.helpers import MESHES
    scene = load_scene(MESHES / "gabled_house.obj")
    return scene, plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)


@pytest.fixture(scope="session")
def ring_job():
    """The README's sample job: the ring prism for a Phantom 4 Pro at 4 mm/px, 3 m security."""
    from coverplan import get_camera, load_scene, plan
    from tests.helpers import MESHES
    scene = load_scene(MESHES / "ring_prism.obj")
    return scene, plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)
