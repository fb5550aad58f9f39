"""Property tests on random scenes: every route is safe and every coverage claim re-checks.

Random box or star-prism targets, up to three random obstacles (standing, floating, or
touching the target), random camera preset, security distance and GSD. The planner must
either refuse with a documented error or return a route the evaluator finds safe, covering
at least 99.5 % of the reachable surface checked every 0.25 m on samples it never saw (99.9 %
on average; at most one scene in a hundred below, and only one the planner itself reports
short with its reasons), never claiming more than 0.1 pp above that (issue 12's bar), and
whose every check sample not listed as uncovered is covered.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, Phase, given, seed, settings
from hypothesis import strategies as st
from shapely.geometry import Polygon

from coverplan import PRESETS, ParameterError, PlanningError, evaluate, plan
from coverplan.shots.check_samples import planner_check_samples
from coverplan.world.scene import scene_from_meshes
from tests.helpers import box
from tests.independent import polyline_min_distance

EXAMPLES = 34  # two halves of 17; test_random_scene_route_is_safe_many (--slow) draws 1,000
CLAIM_TOLERANCE_PP = 0.1  # how far the planner's coverage figure may exceed the evaluator's


@st.composite
def targets(draw):
    """("box", width, depth, height) or ("star", radii, height): plain numbers, so that a
    failing example printed in a CI log rebuilds the scene exactly (``target_mesh``)."""
    if draw(st.booleans()):
        return ("box",) + tuple(draw(st.floats(3, 12)) for _ in range(3))
    n = draw(st.integers(5, 8))
    radii = tuple(draw(st.floats(2.5, 8)) for _ in range(n))
    return ("star", radii, draw(st.floats(3, 12)))


@st.composite
def obstacles(draw):
    """Boxes as (x0, y0, z0, x1, y1, z1), standing on the ground or floating."""
    out = []
    for _ in range(draw(st.integers(0, 3))):
        x, y = draw(st.floats(-16, 16)), draw(st.floats(-16, 16))
        sx, sy, sz = draw(st.floats(0.3, 4)), draw(st.floats(0.3, 4)), draw(st.floats(0.5, 14))
        z0 = draw(st.sampled_from([0.0, draw(st.floats(0.5, 8))]))
        out.append((x, y, z0, x + sx, y + sy, z0 + sz))
    return out


def target_mesh(spec) -> trimesh.Trimesh:
    if spec[0] == "box":
        w, d, h = spec[1:]
        return box(-w / 2, -d / 2, 0, w / 2, d / 2, h)
    radii, height = np.asarray(spec[1]), spec[2]
    angles = np.linspace(0, 2 * np.pi, len(radii), endpoint=False)
    return trimesh.creation.extrude_polygon(Polygon(np.column_stack([np.cos(angles) * radii,
                                                                     np.sin(angles) * radii])), height)


@st.composite
def settings_(draw):
    camera = PRESETS[draw(st.sampled_from(sorted(PRESETS)))]
    security = draw(st.floats(1.0, 4.0))
    d_opt = max(security * draw(st.floats(1.6, 4.0)), 3.0)
    return {"camera": camera, "security": security, "gsd": float(camera.gsd_at(d_opt)),
            "min_altitude": draw(st.floats(0.5, security)), "d_opt": d_opt}


def plan_or_refusal(scene, opts):
    """The plan for ``opts`` (camera, gsd, security, min_altitude, and a selection if given),
    or None where the planner refuses with a documented one-line error."""
    try:
        return plan(scene, opts["camera"], gsd=opts["gsd"], security=opts["security"],
                    min_altitude=opts["min_altitude"], lp_time_limit=5, selection=opts.get("selection", "shots"))
    except (PlanningError, ParameterError) as exc:
        assert str(exc) and "\n" not in str(exc)
        return None


def check_random_scene(target_spec, obstacle_boxes, opts, results: dict, short: dict) -> None:
    """Plan one random scene and re-check every claim; its coverage goes into ``results``
    (and into ``short`` when below 99.5 %)."""
    target = target_mesh(target_spec)
    obs = [box(*b) for b in obstacle_boxes]
    scene = scene_from_meshes([target], obs)
    route = plan_or_refusal(scene, opts)
    if route is None:
        return
    ev = evaluate(route, scene)  # every 0.25 m, on samples the planner never saw
    key = (tuple(np.round(target.bounds.ravel(), 6)), tuple(tuple(np.round(o.bounds.ravel(), 6)) for o in obs),
           opts["camera"].name, round(opts["security"], 9), round(opts["gsd"], 12))
    m = ev.metrics
    assert m["safe"], m["unsafe_segments"]
    assert m["min_clearance_m"] >= opts["security"]
    assert m["altitude_violations"] == 0 and m["orientation_mismatches"] == 0
    assert polyline_min_distance(route.positions, scene.meshes, opts["security"] / 5) >= opts["security"]
    assert not (ev.covered & ~ev.reachable).any()  # what the route images is reachable, evidently
    # Issue 12's bar: 99.5 % per scene. A scene may fall short only where the planner reports
    # it short itself (its own figure below 99.5 % too, the samples it misses listed with
    # reasons), and only one in a hundred (checked below). The one seen: three obstacles round
    # a box, Mavic 3E, 3.86 m security, 99.33 % (test_plan's walls seen only between
    # obstacles). A wall facing an obstacle nearer than the security distance gave 99.43 %
    # in other draws. Before the check's ball (cover.CHECK_BALL) a 3 m box claimed 100 %
    # against the evaluator's 99.70 %.
    if m["coverage_pct"] < 99.5:
        assert route.metrics["planned_coverage_pct"] < 99.5, (m["coverage_pct"], route.metrics["planned_coverage_pct"])
        assert route.uncovered
        short[key] = m["coverage_pct"]
    # The two figures come from different samples, so they may differ a little either way.
    assert route.metrics["planned_coverage_pct"] <= m["coverage_pct"] + CLAIM_TOLERANCE_PP, (
        route.metrics["planned_coverage_pct"], m["coverage_pct"])
    results[key] = m["coverage_pct"]
    # The planner's claims on its own check samples: what it does not list is covered, and
    # what it lists as unreachable the evaluator finds unreachable too.
    mine = evaluate(route, scene, samples=planner_check_samples(scene, route))
    listed = {tuple(p): u["reachable"] for u in route.uncovered for p in [np.round(u["position"], 6).tolist()]}
    keys = [tuple(p) for p in np.round(mine.samples.points, 6).tolist()]
    claimed = np.array([k not in listed for k in keys])
    assert mine.covered[claimed].all()
    said_unreachable = np.array([listed.get(k) is False for k in keys])
    np.testing.assert_array_equal(said_unreachable, ~mine.reachable)


def _random_scenes(seed_value: int, examples: int = EXAMPLES // 2, selection: str = "shots", least: int = 14):
    """A test of EXAMPLES / 2 random scenes drawn from ``seed_value`` (two halves, so that two
    test workers share the scenes), then of their mean: coverage at 0.25 m averages at
    least 99.9 %, and at most one scene in a hundred stays below 99.5 %. A fixed seed, not
    derandomize: derandomize seeds from the test's source, so every edit of this file drew
    other scenes. No shrinking: a failing example is reported as found (shrinking one takes
    many minutes), in numbers that rebuild it.

    The draws come from the seed alone (``seed_only_draws``)."""

    def test(seed_only_draws):
        # Evaluator's coverage per planned scene (hypothesis may draw one twice), and of those below 99.5 %.
        results: dict[tuple, float] = {}
        short: dict[tuple, float] = {}

        @seed(seed_value)
        @settings(max_examples=examples, deadline=None, database=None,
                  phases=[Phase.explicit, Phase.generate], suppress_health_check=[HealthCheck.too_slow])
        @given(target=targets(), obs=obstacles(), opts=settings_())
        def run(target, obs, opts):
            check_random_scene(target, obs, dict(opts, selection=selection), results, short)

        run()
        # Most draws are plannable (the rest refused with a documented error): the mean means something.
        assert len(results) >= least, len(results)
        coverage = list(results.values())
        assert np.mean(coverage) >= 99.9, (np.mean(coverage), min(coverage))
        assert len(short) <= max(1, round(0.01 * len(results))), list(short.values())

    return test


test_random_scenes_first_half = pytest.mark.xdist_group("random_scenes_1")(_random_scenes(20261124))
test_random_scenes_second_half = pytest.mark.xdist_group("random_scenes_2")(_random_scenes(20261125))
# The lane selection (shots/lanes.py) under the same checks, on fewer scenes.
test_random_scenes_lanes = pytest.mark.xdist_group("random_scenes_lanes")(
    _random_scenes(20261205, examples=10, selection="lanes", least=8))


@pytest.mark.slow
@settings(max_examples=1000, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(target=targets(), obs=obstacles(), opts=settings_())
def test_random_scene_route_is_safe_many(target, obs, opts):
    check_random_scene(target, obs, opts, {}, {})
