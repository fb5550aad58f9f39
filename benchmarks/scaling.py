"""Planning time and peak memory as the resolution grows (thesis Figure 4.7).

The thesis's square scene (50 m, d_opt 7 m, security 3 m, 80 deg FOV) at grid sides
M = 25, 50, 75, 100 (cell = 50 / M m) for the voxel baseline, and the same physical scene for
the mesh planner with its sample spacing set to the cell size, for M up to 400. Each run is a
fresh child process (so peak memory is its own maximum resident set); times are the median
of three runs. Prints the voxel / mesh time ratio measured in the same run, writes JSON and
a log-log PNG. ``--quick``: M = 25 and 50, one run each.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

from common import RESULTS, ROOT, table, write_json

CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, {src!r}); sys.path.insert(0, {meshes!r})
import trimesh
from make_meshes import shapes_2d
from coverplan import get_camera, plan
from coverplan.world.scene import scene_from_meshes
from coverplan.voxel import grid_from_polygons, plan_2d
planner, m = sys.argv[1], int(sys.argv[2])
camera = get_camera("thesis80")
gsd = float(camera.gsd_at(7.0))
square = shapes_2d()["square"]
cell = 50.0 / m
if planner == "voxel":
    grid = grid_from_polygons([square], size=m, cell=cell)
    t = time.perf_counter()
    result = plan_2d(grid, camera, gsd, 3.0, (cell / 2, 50 - cell / 2), z=0.5)
    seconds = time.perf_counter() - t
    shots = result.route.shot.sum() if result.route is not None else 0
else:
    scene = scene_from_meshes([trimesh.creation.extrude_polygon(square, 1.0)], ground=0.0)
    t = time.perf_counter()
    route = plan(scene, camera, gsd=gsd, security=3.0, start=[cell / 2, 50 - cell / 2, 0.5], min_altitude=0.0,
                 surface_classes=("facade",), spacing=cell)
    seconds = time.perf_counter() - t
    shots = route.shot.sum()
print(json.dumps({{"seconds": seconds, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                   "shots": int(shots)}}))
"""


def measure(planner: str, m: int, repeats: int) -> dict:
    code = CHILD.format(src=str(ROOT / "src"), meshes=str(ROOT / "meshes"))
    runs = []
    for _ in range(repeats):
        out = subprocess.run([sys.executable, "-c", code, planner, str(m)], capture_output=True, text=True, check=True)
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    return {"planner": planner, "M": m, "cell_m": 50.0 / m, "seconds": statistics.median(r["seconds"] for r in runs),
            "peak_mb": max(r["peak_mb"] for r in runs), "shots": runs[-1]["shots"], "runs": [r["seconds"] for r in runs]}


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for planner, colour in (("voxel", "#c53030"), ("mesh", "#2b6cb0")):
        mine = [r for r in rows if r["planner"] == planner]
        a.loglog([r["M"] for r in mine], [r["seconds"] for r in mine], "o-", color=colour, label=planner)
        b.loglog([r["M"] for r in mine], [r["peak_mb"] for r in mine], "o-", color=colour, label=planner)
    sides = sorted({r["M"] for r in rows})
    for ax in (a, b):
        ax.set_xticks(sides, [str(m) for m in sides], minor=False)
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    a.set_xlabel("grid side M (cell = 50 m / M)")
    a.set_ylabel("planning time s (median of 3)")
    b.set_xlabel("grid side M")
    b.set_ylabel("peak memory MB (whole process)")
    for ax in (a, b):
        ax.legend()
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("the thesis's square scene at growing resolution")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else 3
    sides = [25, 50] if args.quick else [25, 50, 75, 100]
    mesh_only = [] if args.quick else [150, 200, 300, 400]
    rows = []
    for m in sides:
        vox, mesh = measure("voxel", m, repeats), measure("mesh", m, repeats)
        mesh["voxel_over_mesh_time"] = vox["seconds"] / mesh["seconds"]
        rows += [vox, mesh]
        print(f"  M={m} done", flush=True)
    for m in mesh_only:
        rows.append(measure("mesh", m, repeats))
        print(f"  M={m} done (mesh planner only)", flush=True)
    print(table(rows, [("M", "M", "d"), ("cell_m", "cell m", ".3f"), ("planner", "planner", ""),
                       ("seconds", "time s", ".2f"), ("peak_mb", "peak MB", ".0f"), ("shots", "shots", "d"),
                       ("voxel_over_mesh_time", "voxel/mesh time", ".2f")]))
    RESULTS.mkdir(exist_ok=True)
    png = RESULTS / ("scaling_quick.png" if args.quick else "scaling.png")
    plot(rows, png)
    out = write_json("scaling", args.quick, {"repeats": repeats, "rows": rows, "png": png.name})
    print(f"written {out} and {png}")


if __name__ == "__main__":
    main()
