"""How smooth could any order of the default plan's photos fly? (issue 33's lanes bar)

For each sample scene, the default plan for a Mavic 3 Enterprise (4 mm/px, 3 m security, one
flight: the settings of ``flights.py`` part 3): photos, distinct headings and gimbal pitches
(to the degree), the groups the photos form through smooth steps (heading within 10 deg,
pitch within 5 deg, chained), the photos alone in their group, the ceiling on smooth steps
that no order can pass (``lanes.smooth_ceiling``: n - groups of the n - 1 steps), and the
smooth steps of the planned order. A ceiling under 75 % means the bar cannot be met by
ordering these photos: it needs other photos.
``--quick``: the square prism.
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from common import MESHES, table, write_json
from coverplan import load_scene, plan
from coverplan.equipment.drones import get_drone
from coverplan.flight.lanes import route_step_shape, smooth_ceiling, smooth_step
from plan_scenes import SCENES

LANES_BAR_PCT = 75.0


def row(name: str, route) -> dict:
    heading, pitch = route.heading_deg[route.shot], route.pitch_deg[route.shot]
    joined = smooth_step(heading[:, None], pitch[:, None], heading[None], pitch[None])
    _groups, label = connected_components(sp.csr_matrix(joined), directed=False)
    sizes = np.bincount(label)
    smooth, reversals = route_step_shape(route)
    return {"scene": name, "photos": int(route.shot.sum()), "headings": len(np.unique(np.round(heading) % 360)),
            "pitches": len(np.unique(np.round(pitch))), "groups": len(sizes), "alone": int((sizes == 1).sum()),
            "ceiling_pct": smooth_ceiling(heading, pitch), "smooth_pct": smooth, "reversals_per_100": reversals}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    names = ["square"] if args.quick else list(SCENES)
    drone = get_drone("m3e")
    rows = []
    for name in names:
        target, obstacles = SCENES[name]
        scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
        route = plan(scene, drone.camera, gsd=0.004, security=3.0, drone=drone, max_flight_min=1e6)
        rows.append(row(name, route))
        print(f"  planned {name}", flush=True)
    print(table(rows, [("scene", "scene", ""), ("photos", "photos", "d"), ("headings", "headings", "d"),
                       ("pitches", "pitches", "d"), ("groups", "groups", "d"), ("alone", "alone", "d"),
                       ("ceiling_pct", "ceiling %", ".0f"), ("smooth_pct", "planned %", ".0f"),
                       ("reversals_per_100", "reversals/100", ".1f")]))
    under = [r["scene"] for r in rows if r["ceiling_pct"] < LANES_BAR_PCT]
    print(f"ceiling under {LANES_BAR_PCT:g} %: {len(under)} of {len(rows)} ({', '.join(under) or 'none'})")
    print(f"written {write_json('smooth_ceiling', args.quick, {'drone': 'm3e', 'gsd_m': 0.004, 'security_m': 3.0, 'rows': rows})}")


if __name__ == "__main__":
    main()
