"""Several flights as one route: battery flights exported one file each, or routes flown one after the other."""

from __future__ import annotations

import numpy as np

from coverplan.errors import ParameterError
from coverplan.flight.route import Route


def join_flights(routes: list[Route], names: list[str] | None = None) -> Route:
    """Several flights (battery flights exported one file each, or routes flown one after the
    other) as one route, each keeping its own flights in order after the ones before.

    Parameters
    ----------
    routes : list of Route
        In the scene's one frame, with one camera; the first one's parameters are kept.
    names : list of str, optional
        The files they came from, for the error message.

    Returns
    -------
    Route
        Waypoints of all, ``flight`` numbered 1, 2, ... across them; ``extra["notes"]`` joined.

    Raises
    ------
    ParameterError
        When the routes were taken with different cameras.
    """
    if len(routes) == 1:
        return routes[0]
    names = names or [f"route {k + 1}" for k in range(len(routes))]
    first = routes[0]
    for name, r in zip(names[1:], routes[1:]):
        if r.camera != first.camera:
            raise ParameterError(f"{name} is taken with another camera ({r.camera.name or 'custom'}) than "
                                 f"{names[0]} ({first.camera.name or 'custom'}); judge them one by one")
    flights, offset = [], 0
    for r in routes:
        flights.append(r.flight + offset)
        offset += r.n_flights

    def joined(attr):
        parts = [getattr(r, attr) for r in routes]
        return None if any(p is None for p in parts) else np.concatenate(parts)

    extra = dict(first.extra)
    extra["notes"] = [n for r in routes for n in r.extra.get("notes", [])]
    return Route(np.vstack([r.positions for r in routes]), np.concatenate([r.shot for r in routes]),
                 np.concatenate([r.heading_deg for r in routes]), np.concatenate([r.pitch_deg for r in routes]),
                 [leg for r in routes for leg in r.leg], first.camera, dict(first.params),
                 view_dir=np.vstack([r.view_dir for r in routes]), frame=first.frame, metrics={}, extra=extra,
                 flight=np.concatenate(flights), ground_z=joined("ground_z"), pass_speed=joined("pass_speed"),
                 turn_damping=joined("turn_damping"))
