"""Shared test helpers: scene builders, sample paths and a loader for script files."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import trimesh

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT / "meshes"


def strict_json(text: str):
    """``text`` parsed as strict JSON: a NaN or Infinity (which Python writes and browsers,
    jq and other languages refuse) fails the test."""
    def refuse(constant):
        raise AssertionError(f"{constant} in JSON output")
    return json.loads(text, parse_constant=refuse)


def box(x0, y0, z0, x1, y1, z1) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=[x1 - x0, y1 - y0, z1 - z0])
    mesh.apply_translation([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
    return mesh


def gsd_for(camera, d_opt: float) -> float:
    """The GSD whose optimal distance is ``d_opt`` for this camera."""
    return float(camera.gsd_at(d_opt))


# A house near Stuttgart: a 10 x 8 x 6 m box whose corner sits at these UTM 32N coordinates.
UTM_EAST, UTM_NORTH, UTM_BASE = 512_300.0, 5_403_830.0, 250.0


def utm_house(tmp_path, base: float = UTM_BASE):
    """The box in EPSG:25832 coordinates, written as an OBJ; returns its path."""
    mesh = box(0, 0, 0, 10, 8, 6)
    mesh.apply_translation([UTM_EAST, UTM_NORTH, base])
    path = tmp_path / "house.obj"
    mesh.export(path)
    return path


def load_script(path: Path):
    """A stand-alone script (meshes/make_meshes.py) as a module, without touching sys.path."""
    spec = importlib.util.spec_from_file_location(f"_script_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def mavsdk_upload(plan_path):
    """Read a ``.plan`` with MAVSDK's own QGroundControl importer and upload its mission over
    MAVLink to a MAVSDK autopilot (``MissionRawServer``) on 127.0.0.1.

    Returns the imported data, the ground station's MissionRaw plugin (to upload more over the
    same link) and the item count the autopilot received (None when nothing arrived within
    10 s). The link lives as long as the plugin does."""
    import socket
    import threading

    import mavsdk
    from mavsdk.plugins.mission_raw import MissionRaw
    from mavsdk.plugins.mission_raw_server import MissionRawServer

    autopilot = mavsdk.Mavsdk(mavsdk.Configuration.create_with_component_type(mavsdk.ComponentType.AUTOPILOT))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:  # a free UDP port on loopback
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    assert autopilot.add_any_connection(f"udpout://127.0.0.1:{port}") == mavsdk.ConnectionResult.SUCCESS
    server = MissionRawServer(autopilot.server_component())
    arrived, done = [], threading.Event()
    server.subscribe_incoming_mission(lambda result, mission, _ud: (arrived.append(len(mission.mission_items)),
                                                                    done.set()))
    ground = mavsdk.Mavsdk(mavsdk.Configuration.create_with_component_type(mavsdk.ComponentType.GROUND_STATION))
    assert ground.add_any_connection(f"udpin://127.0.0.1:{port}") == mavsdk.ConnectionResult.SUCCESS
    system = ground.first_autopilot(10.0)
    assert system is not None
    mission = MissionRaw(system)
    mission._keep_alive = (autopilot, server, ground, system)  # the link closes with these
    data = mission.import_qgroundcontrol_mission(str(plan_path))
    mission.upload_mission(data.mission_items)
    count = arrived[0] if done.wait(10) and arrived else None
    return data, mission, count
