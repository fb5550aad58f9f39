"""`coverplan cameras` and `coverplan drones`: the presets."""

from __future__ import annotations

from coverplan.equipment.camera import PRESETS
from coverplan.equipment.drones import drones_table


def cmd_drones(args) -> int:
    """Run ``coverplan drones``: print the drone profiles.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
    print(drones_table())
    print("flight min: usable of rated (30 % kept in reserve); the first is the default --max-flight-min. "
          "Sources: docs/flights.md")
    return 0


def cmd_cameras(args) -> int:
    """Run ``coverplan cameras``: print the camera presets.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
    print(f"{'name':<15}{'sensor mm':>14}{'focal mm':>10}{'image px':>13}{'HFOV':>8}{'VFOV':>8}")
    for name, cam in sorted(PRESETS.items()):
        print(f"{name:<15}{cam.sensor_width_mm:>7.2f} x{cam.sensor_height_mm:>5.2f}{cam.focal_length_mm:>10.2f}"
              f"{cam.image_width_px:>7d}x{cam.image_height_px:<5d}{cam.hfov_deg:>7.1f}°{cam.vfov_deg:>7.1f}°")
    return 0


def register(sub) -> None:
    """Add the subcommands to ``sub`` (argparse subparsers).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommands.
    """
    p = sub.add_parser("cameras", help="list the camera presets")
    p.set_defaults(func=cmd_cameras)

    p = sub.add_parser("drones", help="list the drone profiles (camera, gimbal, speeds, battery, apps)")
    p.set_defaults(func=cmd_drones)
