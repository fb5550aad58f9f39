"""plan(): scene + camera + detail + security distance -> one safe flight covering the target.

The stages, one module each: the settings resolved (``setup``) -> the problem: surface samples,
reachability, lanes and candidate viewpoints, visibility (``problem``) -> the shots chosen
(``selecting``) -> the gaps closed on the check samples (``gaps``) -> the flight: lattice,
Dijkstra, tour, legs, battery flights (``flying``) -> the Route (``assembly``).
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

from coverplan.equipment.camera import Camera
from coverplan.equipment.drones import DroneProfile
from coverplan.equipment.flighttime import FlightModel
from coverplan.errors import ParameterError
from coverplan.flight.route import Route
from coverplan.flight.start import start_from_latlon
from coverplan.planning.assembly import make_route
from coverplan.planning.flying import fly
from coverplan.planning.gaps import close_gaps
from coverplan.planning.guards import check_endurance
from coverplan.planning.problem import build_problem
from coverplan.planning.selecting import select_shots
from coverplan.planning.settings import PlanSettings
from coverplan.planning.setup import resolve
from coverplan.progress import Progress


def plan(scene, camera: Camera, settings: PlanSettings | None = None, *, start=None, start_latlon=None,
         drone: DroneProfile | None = None, flight_model: FlightModel | None = None,
         progress: Progress | None = None, **options) -> Route:
    """Plan one flight from ``start`` over shots covering the target and back.

    Parameters
    ----------
    scene : Scene
        Target, obstacles and ground (``load_scene``).
    camera : Camera
        The camera the photos are taken with (``get_camera``).
    settings : PlanSettings, optional
        The plan's settings; ``options`` (any PlanSettings field: ``gsd``, ``security``,
        ``rule``, ``pose_margin``, ...) replace fields of it, or make it when it is None.
    start : (3,) float, optional
        Take-off point in the scene's local frame (``scene.to_local`` moves a point of the
        input models there); None: a safe point beside the target. A start more than 5 km
        from the target is refused as a coordinate mix-up.
    start_latlon : sequence of 2 or 3 float, optional
        Or the take-off point as latitude, longitude (degrees) and optionally its height above
        the ground (m) in a georeferenced scene (``flight.start.start_from_latlon``).
    drone : DroneProfile, optional
        Gimbal range, flight-time model, usable battery minutes and pose error (the margin).
    flight_model : FlightModel, optional
        Overrides the drone's flight-time model.
    progress : Progress, optional
        Bars and stage timings.
    **options
        Fields of ``PlanSettings`` (``gsd`` in m/px, ``security`` in m, ``rule``, ...).

    Returns
    -------
    Route
        Surface no safe position can image is planned around and listed in ``route.uncovered``.

    Raises
    ------
    ParameterError
        Impossible or contradicting settings, with a one-line message.
    PlanningError
        Settings that make a plan impossible in this scene (a start inside a mesh, ...).

    Examples
    --------
    >>> import coverplan
    >>> scene = coverplan.load_scene("meshes/square_prism.obj")
    >>> route = coverplan.plan(scene, coverplan.get_camera("phantom4pro"), gsd=0.004, security=3.0)
    >>> int(route.shot.sum()) > 20, route.n_flights, bool((route.positions[0] == route.positions[-1]).all())
    (True, 1, True)
    """
    t0 = time.perf_counter()
    progress = progress or Progress()
    settings = PlanSettings(**options) if settings is None else replace(settings, **options)
    if start_latlon is not None:
        if start is not None:
            raise ParameterError("give the start point once: start or start_latlon")
        start = start_from_latlon(scene, start_latlon)
    setup = resolve(scene, camera, settings, drone, flight_model, start)
    with ThreadPoolExecutor(max_workers=1) as pool:  # work for later stages, on the other core
        problem = build_problem(scene, setup, progress, pool)
        selection = select_shots(problem, setup, progress)
        gaps = close_gaps(problem, selection, setup, progress)
        flight = fly(scene, problem, gaps, setup, progress, pool)
    check_endurance(flight.single_flight_s / 60.0, settings, setup.max_flight_min)
    return make_route(scene, setup, problem, selection, gaps, flight, progress.timings,
                      time.perf_counter() - t0)
