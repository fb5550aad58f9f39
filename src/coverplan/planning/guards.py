"""Guards against unit slips: a GSD, security distance or altitude that would make an absurd
flight (metres typed where millimetres were meant, feet for metres) is refused with one line
that names the value and what it would mean, unless the settings say it is meant (``force``).
"""

from __future__ import annotations

import numpy as np

from coverplan.equipment.drones import DRONES
from coverplan.errors import ParameterError

MAX_GSD_M = 0.05  # coarser than 5 cm/px shows no façade detail: photogrammetry of buildings asks mm to cm
MAX_STANDOFF_M = 150.0  # farther than this, and farther than STANDOFF_SIZES target sizes, is not a building survey
STANDOFF_SIZES = 5.0
MAX_SECURITY_M = 30.0  # above this, and above the target's size, the distance is not a clearance
MAX_FLOOR_M = 300.0  # a lowest flight height above every drone's legal ceiling
BATTERIES = 3.0  # a single flight as long as this many of the longest battery: a slip, not a big building

FORCE = "pass --force if it is meant"


def target_size(scene) -> float:
    """The target's largest extent, m.

    Parameters
    ----------
    scene : Scene
        The scene.

    Returns
    -------
    float
        Metres.
    """
    lo, hi = scene.bounds("target")
    return float(np.max(np.asarray(hi) - np.asarray(lo)))


def check_unit_slips(scene, settings, d_opt: float) -> None:
    """Refuse settings that look like a unit slip (``settings.force``: plan them all the same).

    Parameters
    ----------
    scene : Scene
        The scene.
    settings : PlanSettings
        The settings asked.
    d_opt : float
        The camera distance of the GSD asked, metres.

    Raises
    ------
    ParameterError
        Naming the value, what it would mean for the flight and the value likely meant.
    """
    if settings.force:
        return
    gsd, size = settings.gsd, target_size(scene)
    if gsd > MAX_GSD_M:
        raise ParameterError(f"--gsd {gsd:g} is {gsd * 1000:g} mm per pixel, coarser than {MAX_GSD_M * 100:g} cm/px: "
                             f"a unit slip? The GSD is in metres per pixel: {gsd:g} mm/px is --gsd {gsd / 1000:g}, "
                             f"{gsd:g} cm/px is --gsd {gsd / 100:g}; {FORCE}")
    if d_opt > max(MAX_STANDOFF_M, STANDOFF_SIZES * size):
        raise ParameterError(f"--gsd {gsd:g} m/px puts the camera {d_opt:,.0f} m from the surface, "
                             f"{d_opt / size:.0f} times the target's {size:.0f} m size: a unit slip (the GSD is in "
                             f"metres per pixel)? {FORCE}")
    if settings.security > max(MAX_SECURITY_M, size):
        raise ParameterError(f"--security {settings.security:g} m is more than the target's {size:.0f} m size: a unit "
                             f"slip (the security distance is in metres)? {FORCE}")
    if settings.min_altitude is not None and settings.min_altitude > MAX_FLOOR_M:
        raise ParameterError(f"--min-altitude {settings.min_altitude:g} m above the ground is above every drone's "
                             f"legal ceiling: a unit slip (the altitude is in metres)? {FORCE}")


def check_endurance(minutes: float, settings, max_flight_min: float | None) -> None:
    """Refuse a single flight longer than ``BATTERIES`` of the longest any drone profile flies on
    one when nothing splits it (no drone, no ``max_flight_min``): the GSD or security distance is
    likely a slip.

    Parameters
    ----------
    minutes : float
        The tour's time as one flight.
    settings : PlanSettings
        The settings asked (``force`` plans it anyway).
    max_flight_min : float or None
        The longest flight asked for.

    Raises
    ------
    ParameterError
        Naming the minutes and the settings that likely caused them.
    """
    if settings.force or max_flight_min is not None:
        return
    longest = max(DRONES.values(), key=lambda d: d.usable_flight_min)
    if minutes > BATTERIES * longest.usable_flight_min:
        raise ParameterError(f"the flight takes {minutes:.0f} min in one go, over {BATTERIES:g} times as long as any "
                             f"drone flies on a battery (the {longest.label}: {longest.usable_flight_min:g} min): "
                             f"a unit slip in --gsd or --security? Give --drone or --max-flight-min to split it into "
                             f"battery flights, or {FORCE}")


__all__ = ["check_unit_slips", "check_endurance", "target_size"]
