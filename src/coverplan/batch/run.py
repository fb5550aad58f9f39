"""``coverplan batch``: one route per building of a city file, planned on dask.distributed.

The city file is parsed once, here; each task receives only its building's neighbourhood (the
target's triangles and those of the city objects within the context radius), plans it on a
worker exactly as ``coverplan plan --building`` would, evaluates it, and sends back the bytes of
its outputs. This process writes each building's folder atomically (a temporary folder renamed
into place, ``result.json`` last), so an interrupted batch leaves whole folders or none, and a
re-run skips every building whose folder is complete and was made with the same settings and
geometry. A building that fails (bad geometry, nothing reachable, a worker killed) becomes a
row with its error; the others go on.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
import time
from dataclasses import asdict, dataclass, field, is_dataclass
from pathlib import Path
from typing import Callable

from coverplan import __version__
from coverplan.batch.outputs import completed_row, write_building
from coverplan.batch.selecting import folder_names, select_buildings
from coverplan.batch.summary import write_summary
from coverplan.equipment.camera import Camera
from coverplan.errors import CoverplanError, ParameterError
from coverplan.io import GEOGRAPHIC_FORMATS, read_city_model
from coverplan.io.city import CityModel, CityObject, Neighbourhood
from coverplan.io.load import load_scene
from coverplan.job import run_job
from coverplan.world.merge import merge_into_target

ALLOWED_FAILURES = 1  # a task that kills two workers is not retried a third time


@dataclass
class BatchSettings:
    """What every building of the batch is planned with (the flags ``plan`` takes).

    Parameters
    ----------
    camera : Camera
        The camera flown over every building.
    plan_options : dict
        ``plan``'s keyword arguments (PlanSettings fields).
    exports : list of str
        Export formats written per building.
    export_options : dict
        Keyword arguments of the writers.
    report : bool
        Write each building's HTML report.
    merge_obstacles_within : float, optional
        Merge neighbours closer than this many metres into one obstacle.
    context_radius : float, optional
        Metres around the building whose neighbours are obstacles.
    lod : int, optional
        The city model's level of detail to read.
    terrain : str, optional
        A DTM raster read as the ground.
    """

    camera: Camera
    plan_options: dict  # planner.plan's keyword arguments
    exports: list[str] = field(default_factory=list)
    export_options: dict = field(default_factory=dict)  # firmware, speed, drone, wpml_heights
    report: bool = True
    merge_obstacles_within: float | None = None
    context_radius: float | None = None
    lod: int | None = None
    terrain: str | None = None  # a DTM raster every worker reads its building's window of

    def __post_init__(self):
        if self.terrain is not None:
            path = Path(self.terrain).expanduser()
            if not path.is_file():
                raise ParameterError(f"{self.terrain}: no such DTM file")
            self.terrain = str(path.resolve())  # workers may start in another folder

    def fingerprint(self) -> str:
        """Changes with any setting that changes a building's outputs.

        Returns
        -------
        str
            A hex digest of the settings.
        """
        def plain(value):
            if is_dataclass(value):
                return asdict(value)
            if isinstance(value, Camera):
                return value.to_dict()
            return value
        data = {k: plain(v) for k, v in asdict(self).items() if k != "camera"}
        data["plan_options"] = {k: plain(v) for k, v in self.plan_options.items()}
        data["camera"] = self.camera.to_dict()
        data["coverplan"] = __version__
        if self.terrain is not None:  # a DTM replaced under the same name plans again
            stat = Path(self.terrain).stat()
            data["terrain_file"] = [stat.st_size, stat.st_mtime_ns]
        return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


@dataclass
class BuildingJob:
    """One task: a building's neighbourhood and the settings to plan it with.

    Parameters
    ----------
    id : str
        The building's id in the city model.
    folder : str
        Its folder name under ``OUT/buildings``.
    neighbourhood : Neighbourhood
        The building and the obstacles around it.
    settings : BatchSettings
        What it is planned with.
    key : str
        The fingerprint its outputs are recorded under.
    """

    id: str
    folder: str
    neighbourhood: Neighbourhood
    settings: BatchSettings
    key: str  # settings fingerprint + geometry digest; a complete folder with this key is skipped


# -- choosing buildings -----------------------------------------------------------------------


# -- one building, on a worker ----------------------------------------------------------------

def plan_building(job: BuildingJob) -> dict:
    """Plan, evaluate and render one building; returns its summary row and output files.

    Runs on a Dask worker. Errors become a 'failed' row rather than a raised exception, so the
    row carries the message a user can act on.

    Parameters
    ----------
    job : BuildingJob
        The building and its settings.

    Returns
    -------
    dict
        ``row``: the summary row (status, photos, coverage, message); ``files``: name to bytes.
    """
    started = time.perf_counter()
    row = {"id": job.id, "folder": job.folder, "key": job.key}
    try:
        row_update, files = _plan_and_render(job)
        row.update(row_update)
    except CoverplanError as exc:
        row.update(status="failed", error=str(exc))
        files = {}
    except MemoryError:
        row.update(status="failed", error="out of memory")
        files = {}
    except Exception as exc:  # a bug or a geometry the libraries choke on: keep the batch going
        row.update(status="failed", error=f"{type(exc).__name__}: {exc}")
        files = {}
    row["planning_time_s"] = round(time.perf_counter() - started, 3)
    return {"row": row, "files": files}


def _plan_and_render(job: BuildingJob) -> tuple[dict, dict]:
    s = job.settings
    scene = load_scene(job.neighbourhood.source(), terrain=s.terrain)
    if s.merge_obstacles_within is not None:
        scene = merge_into_target(scene, s.merge_obstacles_within)
    options = dict(s.plan_options)
    if options.get("max_memory") is None:
        options["max_memory"] = _worker_memory_budget()
    with tempfile.TemporaryDirectory(prefix="coverplan-batch-") as tmp:
        tmp = Path(tmp)
        done = run_job(scene, s.camera, tmp / "route.json", formats=s.exports, export_options=s.export_options,
                       report=tmp / "report.html" if s.report else None, title=f"coverplan: {job.id}", **options)
        files = {path.name: path.read_bytes() for path in sorted(tmp.iterdir())}
    route, ev = done.route, done.evaluation
    m = ev.metrics
    status = "planned" if ev.safe else "unsafe"
    reasons: dict[str, float] = {}
    for group in m["unreachable"]:
        reasons[group["reason"]] = reasons.get(group["reason"], 0.0) + group["area_m2"]
    if m["uncovered_reachable_area_m2"] > 0:
        reasons["reachable but not covered"] = m["uncovered_reachable_area_m2"]
    main_reason = max(reasons, key=reasons.get) if reasons else ""
    row = {"status": status, "error": "" if ev.safe else f"evaluator: {m['unsafe_segment_count']} unsafe segments",
           "shots": int(route.shot.sum()), "path_length_m": round(route.path_length, 2),
           "flight_time_min": round(sum(f["minutes"] for f in route.metrics["flights"]), 2),
           "flights": route.n_flights,
           "coverage_pct": round(m["coverage_pct"], 3),
           "planned_coverage_pct": round(route.metrics["planned_coverage_pct"], 3),
           "uncovered_area_m2": round(m["unreachable_area_m2"] + m["uncovered_reachable_area_m2"], 2),
           "main_uncovered_reason": main_reason, "min_clearance_m": round(m["min_clearance_m"], 3),
           "security_m": route.security, "obstacles": len(scene.obstacles)}
    return row, files


def _worker_memory_budget() -> float | None:
    """80 % of this Dask worker's memory limit (the planner refuses plans that need more)."""
    try:
        from distributed import get_worker
        limit = get_worker().memory_manager.memory_limit
    except (ImportError, ValueError, AttributeError):
        return None
    return 0.8 * limit if limit else None


# -- outputs ----------------------------------------------------------------------------------


# -- the batch --------------------------------------------------------------------------------

@dataclass
class BatchResult:
    """What a batch did: a row per building, the folder, and how many were planned now or kept.

    Parameters
    ----------
    rows : list of dict
        One summary row per chosen building.
    out_dir : Path
        The batch's output folder.
    planned_now : int
        Buildings planned in this run.
    skipped : int
        Buildings kept from an earlier run with the same settings.
    seconds : float
        The run's wall time.
    written : list of Path
        The summary files written.
    """
    rows: list[dict]  # one per selected building, in selection order
    out_dir: Path
    planned_now: int
    skipped: int
    seconds: float
    written: list[Path] = field(default_factory=list)

    @property
    def failed(self) -> list[dict]:
        """The rows of the buildings that were not planned."""
        return [r for r in self.rows if r.get("status") != "planned"]


def run_batch(city: str | Path | CityModel, out_dir: str | Path, settings: BatchSettings, *,
              buildings: list[str] | None = None, everything: bool = False, bbox: list[float] | None = None,
              where: list[tuple[str, str]] | None = None, workers: int | None = None,
              scheduler: str | None = None, progress=None, log_lines: bool = False,
              task: Callable[[BuildingJob], dict] = plan_building) -> BatchResult:
    """Plan every chosen building of ``city`` on Dask and write OUT_DIR (see the module doc).

    ``workers``: size of the local cluster (default: one per core); ``scheduler``: the address
    of a running Dask scheduler to use instead. ``progress`` (a progress.Progress) draws the
    bar; ``log_lines`` prints a line per building instead. ``task`` is what each worker runs
    (for custom pipelines and fault tests).

    Parameters
    ----------
    city : str, Path or CityModel
        A CityGML or CityJSON file, or a model already read.
    out_dir : str or Path
        The output folder.
    settings : BatchSettings
        What every building is planned with.
    buildings : list of str, optional
        Building ids to plan.
    everything : bool
        Plan every building.
    bbox : list of float, optional
        ``xmin ymin xmax ymax`` in the file's coordinates.
    where : list of (str, str), optional
        Attribute values every chosen building has.
    workers : int, optional
        Size of the local cluster.
    scheduler : str, optional
        Address of a running Dask scheduler.
    progress : Progress, optional
        Draws the bar.
    log_lines : bool
        Print a line per building.
    task : callable
        Runs one ``BuildingJob`` and returns its row and files.

    Returns
    -------
    BatchResult
        The rows and counts.
    """

    started = time.perf_counter()
    model = city if isinstance(city, CityModel) else read_city_model(city)
    chosen = select_buildings(model, buildings, everything, bbox, where)
    if set(settings.exports) & GEOGRAPHIC_FORMATS and not model.crs[0]:
        raise ParameterError(f"{', '.join(sorted(set(settings.exports) & GEOGRAPHIC_FORMATS))} export needs a "
                             f"georeference and {model.path.name} names no CRS")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ParameterError(f"{out_dir} exists and is not a folder")
    if not out_dir.parent.exists():
        raise ParameterError(f"{out_dir.parent} does not exist (the parent of the output folder)")
    out_dir.mkdir(exist_ok=True)
    folders = folder_names(chosen)
    fingerprint = settings.fingerprint()
    rows: dict[str, dict] = {}
    pending: list[tuple[CityObject, str, str]] = []
    for obj, folder in zip(chosen, folders):
        key = f"{fingerprint}-{model.neighbourhood(obj.id, settings.context_radius, settings.lod).digest()}"
        done = completed_row(out_dir, folder, key)
        if done is not None:
            rows[obj.id] = dict(done, resumed=True)
        else:
            pending.append((obj, folder, key))
    skipped = len(rows)

    def job(obj: CityObject, folder: str, key: str) -> BuildingJob:
        # made again when submitted, not kept from above: the client holds few neighbourhoods at once
        return BuildingJob(obj.id, folder, model.neighbourhood(obj.id, settings.context_radius, settings.lod),
                           settings, key)

    counter = _Counter(len(pending), progress, log_lines)
    try:
        if pending:
            for row, files in _run_on_dask(pending, job, task, workers, scheduler):
                write_building(out_dir, row, files)
                rows[row["id"]] = row
                counter.update(row)
    finally:
        counter.close()
        ordered = [rows.get(o.id) or {"id": o.id, "folder": f, "status": "not run", "error": "the batch stopped before planning it"}
                   for o, f in zip(chosen, folders)]
        written = write_summary(model, chosen, ordered, out_dir, settings)
    return BatchResult(ordered, out_dir, len(pending), skipped, time.perf_counter() - started, written)


class _Counter:
    """Buildings done / failed / remaining: a bar on a terminal, a line per building otherwise."""

    def __init__(self, total: int, progress, lines: bool):
        import sys
        self.total, self.done, self.failed = total, 0, 0
        self.bar = None
        if progress is not None and progress.bars and total:
            from tqdm import tqdm
            self.bar = tqdm(total=total, desc="buildings", unit="bldg", file=progress.stream, dynamic_ncols=True)
        self.lines = lines and self.bar is None
        self.stream = progress.stream if progress is not None else sys.stderr

    def update(self, row: dict) -> None:
        ok = row.get("status") == "planned"
        self.done += ok
        self.failed += not ok
        if self.bar is not None:
            self.bar.set_postfix(done=self.done, failed=self.failed, remaining=self.total - self.done - self.failed)
            self.bar.update(1)
        elif self.lines:
            what = (f"{row['shots']} shots, {row['coverage_pct']:.2f} %" if ok
                    else f"{row.get('status')}: {row.get('error', '')}")
            print(f"[{self.done + self.failed}/{self.total}] {row['id']}: {what}", file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _run_on_dask(pending, make_job, task, workers, scheduler):
    """Yield (row, files) per building as tasks finish; at most a few tasks per worker are in
    flight, so the client never holds every building's geometry at once."""
    try:
        import dask
        from distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise ParameterError("coverplan batch needs Dask: pip install 'coverplan[batch]'") from None
    with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES}):
        if scheduler:
            try:
                client = Client(scheduler, timeout="20s")
            except (OSError, TimeoutError) as exc:
                raise ParameterError(f"cannot reach the Dask scheduler at {scheduler} ({exc})") from None
            cluster = None
        else:
            n = workers or os.cpu_count() or 1
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.ERROR)
            client = Client(cluster)
        try:
            slots = 3 * (len(client.scheduler_info().get("workers", {})) or workers or 1)
            queue = list(pending)
            futures = {}

            def submit():
                obj, folder, key = queue.pop(0)
                future = client.submit(task, make_job(obj, folder, key), pure=False,
                                       key=f"coverplan-{folder}-{time.time_ns()}")
                futures[future.key] = (obj, folder)
                return future

            running = as_completed([submit() for _ in range(min(slots, len(queue)))])
            for future in running:
                obj, folder = futures.pop(future.key)
                if future.status == "finished":
                    result = future.result()
                    yield result["row"], result["files"]
                else:
                    exc = future.exception()
                    yield {"id": obj.id, "folder": folder, "status": "failed", "error": _task_error(exc)}, {}
                future.release()
                if queue:
                    running.add(submit())
        finally:
            client.close()
            if cluster is not None:
                cluster.close()


def _task_error(exc) -> str:
    name = type(exc).__name__
    if name == "KilledWorker":
        return "the worker planning it died (killed, or out of memory)"
    return f"{name}: {exc}"
