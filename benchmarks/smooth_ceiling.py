"""How smooth could any order of the default plan's photos fly? (issue 33's lanes bar)

For each sample scene, the default plan for a Mavic 3 Enterprise (4 mm/px, 3 m security, one
flight: the settings of ``flights.py`` part 3): photos, distinct headings and gimbal pitches
(to the degree), the groups the photos form through smooth steps (heading within 10 deg,
pitch within 5 deg, chained), the photos alone in their group, the ceiling on smooth steps
that no order can pass (``lanes.smooth_ceiling``: n - groups of the n - 1 steps), and the
smooth steps of the planned order. A ceiling under 75 % means the bar cannot be met by
ordering these photos: it needs other photos.

The other way to the bar, priced: keep the plan and its order, and bridge the camera's turns
between consecutive photos with extra photos taken in passing on the leg, each step turning at
most 10 deg of heading and 5 deg of pitch, so a turn of T deg needs ceil(T / 10) - 1 of them
(``bridging_photos``). Two prices: bridging every turn of at most 40 / 50 / 60 deg (the
smooth steps then, and the photos added per planned photo), and the fewest photos that bring
the planned order to 75 % (the smallest turns bridged first).
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
from coverplan.flight.lanes import SMOOTH_HEADING_DEG, SMOOTH_PITCH_DEG, route_step_shape, smooth_ceiling, smooth_step
from coverplan.geometry.orientation import heading_change_deg
from plan_scenes import SCENES

LANES_BAR_PCT = 75.0
BRIDGED_TURNS_DEG = (40, 50, 60)


def bridging_photos(heading, pitch) -> np.ndarray:
    """Per step of photos in this order: the photos in passing that would make it smooth steps
    only (0 for a smooth step)."""
    turn = np.abs(heading_change_deg(heading[:-1], heading[1:])) / SMOOTH_HEADING_DEG
    tilt = np.abs(np.diff(pitch)) / SMOOTH_PITCH_DEG
    return np.maximum(np.ceil(np.maximum(turn, tilt) - 1e-9) - 1, 0).astype(int)


def bridged(extra: np.ndarray, mask: np.ndarray) -> tuple[float, int]:
    """Smooth steps % and photos added when the steps in ``mask`` are bridged."""
    mask = mask & (extra > 0)
    added = int(extra[mask].sum())
    smooth = int((extra == 0).sum() + (extra[mask] + 1).sum())
    return 100.0 * smooth / (len(extra) + added), added


def to_bar(extra: np.ndarray) -> int:
    """The fewest bridging photos that bring the order to LANES_BAR_PCT (smallest turns first)."""
    if (extra == 0).sum() >= LANES_BAR_PCT / 100 * len(extra):
        return 0
    need = np.sort(extra[extra > 0])
    steps, smooth = len(extra) + np.cumsum(need), (extra == 0).sum() + np.cumsum(need + 1)
    return int(need[:int(np.argmax(smooth >= LANES_BAR_PCT / 100 * steps)) + 1].sum())


def row(name: str, route) -> dict:
    heading, pitch = route.heading_deg[route.shot], route.pitch_deg[route.shot]
    joined = smooth_step(heading[:, None], pitch[:, None], heading[None], pitch[None])
    _groups, label = connected_components(sp.csr_matrix(joined), directed=False)
    sizes = np.bincount(label)
    smooth, reversals = route_step_shape(route)
    extra = bridging_photos(heading, pitch)
    n = len(heading)
    bridges = {}
    for limit in BRIDGED_TURNS_DEG:
        pct, added = bridged(extra, extra <= limit // SMOOTH_HEADING_DEG - 1)
        bridges[f"bridged_{limit}_smooth_pct"], bridges[f"bridged_{limit}_photos_x"] = pct, added / n
    bridges["to_bar_photos_x"] = to_bar(extra) / n
    return {**bridges, "scene": name, "photos": int(route.shot.sum()),
            "headings": len(np.unique(np.round(heading) % 360)), "pitches": len(np.unique(np.round(pitch))),
            "groups": len(sizes), "alone": int((sizes == 1).sum()),
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
                       ("reversals_per_100", "reversals/100", ".1f"),
                       *[(f"bridged_{t}_{k}", f"{t} deg {h}", f) for t in BRIDGED_TURNS_DEG
                         for k, h, f in (("smooth_pct", "smooth %", ".0f"), ("photos_x", "+photos x", ".2f"))],
                       ("to_bar_photos_x", "+photos x to 75 %", ".2f")]))
    under = [r["scene"] for r in rows if r["ceiling_pct"] < LANES_BAR_PCT]
    print(f"ceiling under {LANES_BAR_PCT:g} %: {len(under)} of {len(rows)} ({', '.join(under) or 'none'})")
    payload = {"drone": "m3e", "gsd_m": 0.004, "security_m": 3.0, "rows": rows}
    print(f"written {write_json('smooth_ceiling', args.quick, payload)}")


if __name__ == "__main__":
    main()
