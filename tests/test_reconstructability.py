"""The SfM rule: matchable view pairs, linked photos, one connected set (hand-worked cases)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import box

from coverplan import evaluate, get_camera, plan
from coverplan.reconstructability import MatchRule, connect_shots, graph_summary, shot_links
from coverplan.scene import scene_from_meshes
from coverplan.visibility import has_pair_between, widest_pair_angle


def _rays(*angles_deg):
    a = np.radians(angles_deg)
    return np.column_stack([np.sin(a), np.zeros_like(a), np.cos(a)])


def test_pair_window_needs_a_pair_inside_it():
    # point 0: rays 0/3 deg (too narrow); point 1: 0/20 (inside); point 2: 0/60 (too wide);
    # point 3: 0/3/60 (no pair in [5, 35], though widest is 60); point 4: one ray.
    rays = np.vstack([_rays(0, 3), _rays(0, 20), _rays(0, 60), _rays(0, 3, 60), _rays(0)])
    pts = np.array([0, 0, 1, 1, 2, 2, 3, 3, 3, 4])
    assert has_pair_between(pts, rays, 5, 5.0, 35.0).tolist() == [False, True, False, False, False]
    # Without an upper bound it is the thesis's rule: the widest pair is wide enough.
    assert has_pair_between(pts, rays, 5, 5.0, None).tolist() == (widest_pair_angle(pts, rays, 5) >= 5).tolist()
    assert has_pair_between(pts, rays, 5, 5.0, None).tolist() == [False, True, True, True, False]


def _wall_samples(n=41):
    """Samples on the wall x=0, y in [0, 40], z in [0, 4]."""
    y, z = np.meshgrid(np.linspace(0, 40, n), np.linspace(0, 4, 5))
    return np.column_stack([np.zeros(y.size), y.ravel(), z.ravel()])


def _sees(points, centre, half_width):
    return np.abs(points[:, 1] - centre) <= half_width


def test_links_need_overlap_and_a_narrow_angle():
    pts = _wall_samples()
    # Cameras 10 m from the wall: 0 and 1 two metres apart (same footprint nearly, ~11 deg),
    # 2 far along the wall (no shared surface), 3 at the same spot as 0 seen from a 70 deg angle.
    positions = np.array([[10.0, 10.0, 2.0], [10.0, 12.0, 2.0], [10.0, 35.0, 2.0],
                          [3.4, 10.0 + 9.4, 2.0]])
    vis = sp.csr_matrix(np.array([_sees(pts, 10, 5), _sees(pts, 12, 5), _sees(pts, 35, 5),
                                  _sees(pts, 10, 5)], dtype=float))
    links = shot_links(vis, positions, pts, MatchRule(max_pair_deg=35, min_overlap=0.3))
    assert links[0, 1] and links[1, 0]
    assert not links[0, 2] and not links[1, 2]
    assert not links[0, 3]  # same surface, but 70 deg apart: SfM would not match them
    s = graph_summary(links, MatchRule(min_neighbours=1))
    assert s["components"] == 3 and s["largest_component"] == 2 and s["shots_short_of_neighbours"] == 2


def test_connect_adds_the_bridging_shot_and_nothing_useless():
    pts = _wall_samples()
    centres = [4, 6, 8, 32, 34, 36, 20, 14, 26, 20.5]
    positions = np.array([[10.0, c, 2.0] for c in centres])
    vis = sp.csr_matrix(np.array([_sees(pts, c, 5) for c in centres], dtype=float))
    rule = MatchRule(min_neighbours=2)
    chosen = np.array([0, 1, 2, 3, 4, 5])  # two groups 24 m apart: no shared surface
    assert graph_summary(shot_links(vis[chosen], positions[chosen], pts, rule))["components"] == 2
    out = connect_shots(vis, positions, pts, chosen, rule)
    links = shot_links(vis[out], positions[out], pts, rule)
    summary = graph_summary(links, rule)
    assert summary["components"] == 1 and summary["shots_short_of_neighbours"] == 0
    assert out[:6].tolist() == chosen.tolist()
    assert set(out[6:]) <= {6, 7, 8, 9} and len(out) <= 9  # a chain 14 - 20 - 26 bridges 8 m steps


def test_default_plan_links_every_photo_and_thesis_rule_does_not_have_to():
    scene = scene_from_meshes([box(0, 0, 0, 12, 8, 6)])
    camera = get_camera("phantom4pro")
    route = plan(scene, camera, gsd=0.004, security=3.0)
    assert route.params["rule"] == "sfm" and route.params["min_views"] == 3
    ev = evaluate(route, scene, spacing=0.5)  # finer than the planner's samples
    g = ev.metrics["shot_graph"]
    assert ev.safe and g["components"] == 1, g
    assert g["shots_short_of_neighbours"] <= 0.05 * g["shots"], g
    thesis = plan(scene, camera, gsd=0.004, security=3.0, rule="thesis")
    assert thesis.params["min_views"] == 2 and "max_pair_deg" not in thesis.params
    assert len(thesis.shots) < len(route.shots)


def test_bad_rule_settings_are_one_line_errors(capsys, tmp_path):
    from conftest import MESHES

    from coverplan.cli import main
    base = ["plan", str(MESHES / "square_prism.obj"), "--camera", "thesis80", "--gsd", "0.005",
            "--security", "3", "-o", str(tmp_path / "r.json")]
    for extra, text in ((["--max-pair-deg", "120"], "--max-pair-deg must be in (0, 90)"),
                        (["--min-overlap", "0"], "--min-overlap must be in (0, 1]"),
                        (["--rule", "thesis", "--max-pair-deg", "30"], "--max-pair-deg belongs to --rule sfm"),
                        (["--min-triangulation-deg", "40"], "must be below the widest matchable pair")):
        assert main(base + extra) == 2
        err = capsys.readouterr().err.strip()
        assert text in err and len(err.splitlines()) == 1, err


@pytest.mark.parametrize("rule", ["sfm", "thesis"])
def test_route_file_keeps_the_rule_and_evaluate_applies_it(tmp_path, rule):
    from coverplan import Route
    scene = scene_from_meshes([box(0, 0, 0, 10, 10, 5)])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, rule=rule)
    path = route.save(tmp_path / "r.json")
    back = Route.load(path)
    assert back.params["rule"] == rule
    assert back.params.get("max_pair_deg") == (35.0 if rule == "sfm" else None)
    assert evaluate(back, scene).coverage_pct == pytest.approx(evaluate(route, scene).coverage_pct)
