"""Planning time of this checkout against an earlier commit, scene by scene, in one run.

The issues ask that planning time stay within a factor of "today's" (the commit before the
work): #11 within 2x of fed8e4b (before planning for SfM), #12 within 1.5x of c396e02 (before
the 0.25 m repair loop). The old commit is checked out into a temporary git worktree; each
(commit, scene) plans in a fresh process, old and new alternating scene by scene so that a
slow spell of the machine hits both. Settings as ``plan_scenes.py``; median of ``--repeats``.

    python benchmarks/plan_time_vs.py            # against c396e02 and fed8e4b
    python benchmarks/plan_time_vs.py --quick    # two scenes, once, against c396e02
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from common import MESHES, ROOT, big_building, table, write_json
from plan_scenes import BIG_SETTINGS, SCENES, THESIS_SETTINGS

# The commits before the work of each issue ("today's" planning time).
BASELINES = {"c396e02": "issue 12, before the 0.25 m repair loop", "fed8e4b": "issue 11, before planning for SfM"}

CHILD = """
import json, sys, time
sys.path.insert(0, sys.argv[1])
from coverplan import get_camera, load_scene, plan
spec = json.loads(sys.argv[2])
scene = load_scene(spec["target"], spec["obstacles"])
camera = get_camera(spec["camera"])
gsd = spec["gsd"] if spec["gsd"] else float(camera.gsd_at(7.0))  # plan_scenes' THESIS_SETTINGS
times = []
for _ in range(spec["repeats"]):
    t = time.perf_counter()
    route = plan(scene, camera, gsd=gsd, security=spec["security"])
    times.append(time.perf_counter() - t)
print(json.dumps({"times": times, "shots": len(route.shots)}))
"""


def scene_specs(tmp: Path, repeats: int, quick: bool) -> dict[str, dict]:
    names = ["square", "gabled"] if quick else list(SCENES)

    def spec(target, obstacles, settings):
        camera, gsd, security = settings
        return {"target": str(target), "obstacles": [str(o) for o in obstacles], "camera": camera, "gsd": gsd,
                "security": security, "repeats": repeats}

    specs = {n: spec(MESHES / SCENES[n][0], [MESHES / o for o in SCENES[n][1]], THESIS_SETTINGS) for n in names}
    if not quick:
        path = tmp / "building50k.ply"
        big_building(50_000).export(path)
        specs["building50k"] = spec(path, [], BIG_SETTINGS)
    return specs


def plan_times(src: Path, spec: dict) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, str(src), json.dumps(spec)], capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("commits", nargs="*", default=list(BASELINES),
                        help="earlier commits to compare with (default: " + " ".join(BASELINES) + ")")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="two scenes, one run each, the first commit only")
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else args.repeats
    if args.quick:
        args.commits = args.commits[:1]
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        sources = {}
        for commit in args.commits:
            tree = tmp / commit
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree), commit],
                           check=True, capture_output=True)
            sources[commit] = tree / "src"
        sources["now"] = ROOT / "src"
        try:
            rows = []
            for name, spec in scene_specs(tmp, repeats, args.quick).items():
                row = {"scene": name}
                for label, src in sources.items():
                    result = plan_times(src, spec)
                    row[f"s_{label}"] = statistics.median(result["times"])
                    row[f"shots_{label}"] = result["shots"]
                for commit in args.commits:
                    row[f"ratio_{commit}"] = row["s_now"] / row[f"s_{commit}"]
                rows.append(row)
                print(f"  timed {name}", flush=True)
        finally:
            for commit in args.commits:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tmp / commit)],
                               check=False, capture_output=True)
    columns = [("scene", "scene", "")]
    for label in sources:
        columns += [(f"shots_{label}", f"shots {label}", "d"), (f"s_{label}", f"plan s {label}", ".2f")]
    columns += [(f"ratio_{c}", f"now/{c}", ".2f") for c in args.commits]
    print(table(rows, columns))
    for commit in args.commits:
        ratios = sorted(r[f"ratio_{commit}"] for r in rows)
        print(f"now / {commit}: median {statistics.median(ratios):.2f} ({ratios[0]:.2f}-{ratios[-1]:.2f})")
    path = write_json("plan_time_vs", args.quick, {"repeats": repeats, "commits": args.commits, "rows": rows})
    print(f"written {path}")


if __name__ == "__main__":
    main()
