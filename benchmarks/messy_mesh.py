"""A 2-million-triangle messy scan: time and peak memory of plan + evaluate, and what mesh
preparation reported.

The mesh is generated: the benchmark building subdivided to ~2M triangles, vertices jittered
by 1 cm, 40 holes cut, 10 % of the faces flipped, 5,000 faces duplicated. It is written as
PLY and planned through the command line in a child process (Phantom 4 Pro, 5 mm/px, 5 m
security), so peak memory is the child's maximum resident set. ``--quick`` uses ~20k
triangles.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

from common import big_building, table, write_json


def messy_building(n_faces: int, seed: int = 0) -> trimesh.Trimesh:
    mesh = big_building(max(n_faces // 64, 2000))
    while len(mesh.faces) < n_faces * 0.9:
        mesh = mesh.subdivide()
    rng = np.random.default_rng(seed)
    vertices = mesh.vertices + rng.normal(scale=0.01, size=mesh.vertices.shape)
    centres = mesh.triangles_center
    keep = np.ones(len(mesh.faces), dtype=bool)
    for c in rng.choice(len(mesh.faces), 40, replace=False):  # holes ~0.8 m across
        keep &= np.linalg.norm(centres - centres[c], axis=1) > 0.4
    faces = mesh.faces[keep].copy()
    flip = rng.random(len(faces)) < 0.1
    faces[flip] = faces[flip][:, ::-1]
    faces = np.vstack([faces, faces[rng.choice(len(faces), 5000, replace=False)]])
    return trimesh.Trimesh(vertices, faces, process=False)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    n = 20_000 if args.quick else 2_000_000
    t = time.perf_counter()
    mesh = messy_building(n)
    made_s = time.perf_counter() - t
    with tempfile.TemporaryDirectory() as tmp:
        ply = Path(tmp) / "messy.ply"
        mesh.export(ply)
        out = Path(tmp) / "messy.json"
        cmd = [sys.executable, "-m", "coverplan.cli", "plan", str(ply), "--camera", "phantom4pro", "--gsd", "0.005",
               "--security", "5", "-o", str(out), "-q", "-v"]
        t = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t
        peak_kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
        if proc.returncode != 0:
            print(proc.stderr[-2000:])
            raise SystemExit(f"plan failed with exit status {proc.returncode}")
        route = json.loads(out.read_text())
    stages = {}
    for line in proc.stderr.splitlines():
        if line.startswith("[coverplan] ") and line.endswith(" s"):
            name, seconds = line[len("[coverplan] "):].rsplit(": ", 1)
            stages[name] = float(seconds[:-2])
    ev = route["metrics"]["evaluation"]
    row = {"faces": int(len(mesh.faces)), "vertices": int(len(mesh.vertices)), "wall_s": wall,
           "peak_gb": peak_kb / 1e6, "shots": ev["shots"], "coverage_pct": ev["coverage_pct"],
           "unreachable_m2": ev["unreachable_area_m2"], "min_clearance_m": ev["min_clearance_m"], "safe": ev["safe"],
           "generate_s": made_s}
    print(table([row], [("faces", "faces", ","), ("wall_s", "plan+evaluate s", ".1f"), ("peak_gb", "peak GB", ".2f"),
                        ("shots", "shots", "d"), ("coverage_pct", "cover %", ".2f"),
                        ("unreachable_m2", "unreachable m2", ".1f"), ("min_clearance_m", "min clr m", ".2f")]))
    print("stages: " + ", ".join(f"{k} {v:.1f} s" for k, v in stages.items()))
    notes = route["planner"]["notes"]
    print("preparation: " + "; ".join(n for n in notes if "messy" in n))
    path = write_json("messy_mesh", args.quick, {"rows": [row], "stages_s": stages, "notes": notes})
    print(f"written {path}")


if __name__ == "__main__":
    main()
