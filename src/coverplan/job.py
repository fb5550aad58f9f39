"""One planning job, as ``coverplan plan`` and ``coverplan batch`` both run it: plan ->
evaluate -> save -> report and figures -> exports."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from coverplan.evaluation import evaluate
from coverplan.evaluation.result import Evaluation
from coverplan.flight.route import Route
from coverplan.io.formats import export_route
from coverplan.io.zones import read_zones
from coverplan.planning.planner import plan
from coverplan.progress import Progress
from coverplan.report import write_figures, write_html_report


@dataclass(frozen=True)
class JobResult:
    """The route, the evaluator's verdict (None when not evaluated) and the files written.

    Parameters
    ----------
    route : Route
        The planned route.
    evaluation : Evaluation or None
        The evaluator's verdict.
    written : list of Path
        Every file written, route file first.
    exports_withheld : bool
        True when the evaluator found the route unsafe and no mission was written.
    """

    route: Route
    evaluation: Evaluation | None
    written: list[Path] = field(default_factory=list)
    exports_withheld: bool = False  # the evaluator found the route unsafe: no mission written


def write_pictures(route: Route, scene, evaluation: Evaluation | None, report=None, plot=None,
                   progress: Progress | None = None, simulation=None, title: str | None = None,
                   check=None) -> list[Path]:
    """The HTML report (``report``: its path) and PNG figures (``plot``: their folder);
    ``simulation`` or ``check`` (a Check) adds what SfM made of the photos.

    Parameters
    ----------
    route : Route
        The route to draw.
    scene : Scene
        The scene it was planned for.
    evaluation : Evaluation or None
        The evaluator's verdict, drawn as coverage; None draws the route alone.
    report : str or Path, optional
        The HTML report to write.
    plot : str or Path, optional
        The folder for the PNG figures.
    progress : Progress, optional
        Reports the drawing stages.
    simulation : Simulation, optional
        A simulated reconstruction to show.
    title : str, optional
        The report's title; the route file's name when None.
    check : Check, optional
        A check of real photos to show.

    Returns
    -------
    list of Path
        The files written.
    """
    progress = progress or Progress()
    written = []
    if report:
        with progress.stage("HTML report"):
            written.append(write_html_report(route, scene, report, evaluation=evaluation, title=title,
                                             simulation=simulation, check=check))
    if plot:
        with progress.stage("PNG figures"):
            written += write_figures(route, scene, plot, evaluation=evaluation, simulation=simulation)
    return written


def run_job(scene, camera, out, *, formats=(), export_options: dict | None = None, evaluated: bool = True,
            report=None, plot=None, title: str | None = None, start=None, progress: Progress | None = None,
            **plan_options) -> JobResult:
    """Plan ``scene`` and write the route file ``out`` (.json), its report, figures and exports.

    Parameters
    ----------
    scene : Scene
        The scene to plan.
    camera : Camera
        The camera flown.
    out : str or Path
        The route file; exports are named after it without ``.json`` (``export_route``).
    formats : sequence of str
        Export formats (``io.writer_names()``). Withheld when the evaluator finds the route unsafe.
    export_options : dict, optional
        Keyword arguments of the writers (``export_route``).
    evaluated : bool
        Run the evaluator (always when a report or figures are asked).
    report : str or Path, optional
        The HTML report to write.
    plot : str or Path, optional
        The folder for the PNG figures.
    title : str, optional
        The report's title.
    start : (3,) float, optional
        The take-off point in the local frame; the planner picks one when None.
    progress : Progress, optional
        Reports the long stages.
    **plan_options
        ``plan``'s keyword arguments (PlanSettings fields, ``drone``, ``flight_model``), and
        ``keep_out`` / ``keep_in``: zone files, read in the scene's frame (io/zones.py).

    Returns
    -------
    JobResult
        The route, its evaluation and the files written.
    """
    progress = progress or Progress()
    out = Path(out)
    keep_out, keep_in = plan_options.pop("keep_out", ()), plan_options.pop("keep_in", ())
    if keep_out or keep_in:
        plan_options["zones"] = read_zones(keep_out, keep_in, scene)
    route = plan(scene, camera, start=start, progress=progress, **plan_options)
    ev = None
    if evaluated or report or plot:
        with progress.stage("evaluate"):
            ev = evaluate(route, scene)
        route.metrics["evaluation"] = ev.metrics
    route.save(out, force=True)
    written = [out] + write_pictures(route, scene, ev, report, plot, progress, title=title)
    withheld = ev is not None and not ev.safe and bool(formats)
    if not withheld:  # never hand a pilot a mission the evaluator found unsafe
        stem = str(out)[:-5] if str(out).lower().endswith(".json") else str(out)
        written += export_route(route, stem, list(formats), **(export_options or {}))
    return JobResult(route, ev, written, withheld)
