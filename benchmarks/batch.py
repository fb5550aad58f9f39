"""coverplan batch on 1 and 2 Dask workers: buildings per minute, speed-up, memory per worker.

N buildings of the shipped CityJSON sample (or of any city file given with --city), planned
with a Phantom 4 Pro at 5 mm/px, 3 m security, the default 150 m context radius, a QGC export
and the HTML report per building, as ``coverplan batch`` does. Each configuration runs on a
fresh local cluster (its start-up timed apart) into an empty folder; the batch time is the
median of ``--repeats`` runs. Memory: the peak resident size of each worker process (its
``ru_maxrss``) and of this process, which parses the city file. The projection for 10,000
buildings scales the measured per-building time of the fastest configuration.
``--quick`` plans 4 buildings once.
"""

from __future__ import annotations

import argparse
import logging
import resource
import statistics
import tempfile
import time
from pathlib import Path

from common import MESHES, table, write_json
from coverplan import get_camera
from coverplan.batch.run import BatchSettings, run_batch
from coverplan.io import read_city_model


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB


def run(model, ids, settings, workers: int) -> dict:
    from distributed import Client, LocalCluster

    t = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.ERROR)
    startup = time.perf_counter() - t
    try:
        with tempfile.TemporaryDirectory() as out:
            t = time.perf_counter()
            result = run_batch(model, Path(out) / "batch", settings, buildings=ids, scheduler=cluster.scheduler_address)
            seconds = time.perf_counter() - t
        with Client(cluster) as client:
            worker_mb = sorted(client.run(peak_rss_mb).values())
    finally:
        cluster.close()
    planned = sum(r["status"] == "planned" for r in result.rows)
    return {"seconds": seconds, "startup_s": startup, "planned": planned, "failed": len(result.rows) - planned,
            "worker_peak_mb": worker_mb, "cpu_s": sum(float(r.get("planning_time_s") or 0) for r in result.rows)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--city", default=str(MESHES / "citygml" / "lod2_buildings_v2.json.gz"))
    parser.add_argument("-n", "--buildings", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    n, repeats = (4, 1) if args.quick else (args.buildings, args.repeats)

    t = time.perf_counter()
    model = read_city_model(args.city)
    parse_s = time.perf_counter() - t
    ids = [b.id for b in model.buildings[:n]]
    settings = BatchSettings(camera=get_camera("phantom4pro"), plan_options={"gsd": 0.005, "security": 3.0},
                             exports=["qgc"], export_options={"speed": 5.0}, report=True)
    rows, runs = [], {}
    for workers in (1, 2):
        results = [run(model, ids, settings, workers) for _ in range(repeats)]
        runs[workers] = results
        seconds = statistics.median(r["seconds"] for r in results)
        rows.append({"workers": workers, "buildings": len(ids), "seconds": seconds,
                     "per_min": 60.0 * len(ids) / seconds, "per_building_s": seconds / len(ids),
                     "startup_s": statistics.median(r["startup_s"] for r in results),
                     "failed": max(r["failed"] for r in results),
                     "worker_mb": max(max(r["worker_peak_mb"]) for r in results),
                     "runs": [round(r["seconds"], 2) for r in results]})
    speedup = rows[0]["seconds"] / rows[1]["seconds"]
    for row in rows:
        row["speedup"] = rows[0]["seconds"] / row["seconds"]
    best = min(rows, key=lambda r: r["per_building_s"])
    projected_h = 10_000 * best["per_building_s"] / 3600.0
    print(f"{Path(args.city).name}: {len(model.buildings)} buildings parsed once in {parse_s:.2f} s; "
          f"{len(ids)} planned per run, median of {repeats}")
    print(table(rows, [("workers", "workers", "d"), ("buildings", "buildings", "d"), ("seconds", "batch s", ".1f"),
                       ("per_min", "bldg/min", ".1f"), ("speedup", "speed-up", ".2f"),
                       ("startup_s", "cluster start s", ".1f"), ("worker_mb", "peak MB/worker", ".0f"),
                       ("failed", "failed", "d")]))
    print(f"1 -> 2 workers: {speedup:.2f}x; client process peak {peak_rss_mb():.0f} MB; "
          f"10,000 such buildings: {projected_h:.1f} h with {best['workers']} workers on this machine "
          f"(a cluster of W such workers: about {projected_h * best['workers']:.1f} h / W)")
    path = write_json("batch", args.quick, {"city": Path(args.city).name, "parse_s": parse_s, "rows": rows,
                                            "speedup": speedup, "client_peak_mb": peak_rss_mb(),
                                            "projected_10k_hours": projected_h,
                                            "runs": {str(k): v for k, v in runs.items()}})
    print(f"written {path}")


if __name__ == "__main__":
    main()
