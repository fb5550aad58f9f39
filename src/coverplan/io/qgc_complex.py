"""QGroundControl's complex mission items expanded into the waypoints and photos it flies.

QGroundControl saves a Structure Scan as its settings, not as waypoints: it computes them
when it uploads the mission. The rules, as QGroundControl's Structure Scan item applies them:

- the flight polygon is the structure's outline (clockwise) offset outward by the camera
  calculation's ``DistanceToSurface``, each vertex where the offset edges meet (mitred);
- the drone enters at the flight polygon's first vertex at ``EntranceAltitude``, points its
  camera at the structure (ROI_WPNEXT_OFFSET: yaw 90 deg right of the way to the next
  waypoint, gimbal at ``GimbalPitch``), and flies ``Layers`` layers, each once round the
  polygon from the first vertex back to it; the first layer is half a frame
  (``AdjustedFootprintFrontal`` / 2) above ``ScanBottomAlt``, or below ``StructureHeight``
  with ``StartFromTop``, and each next one a frame higher (lower);
- along each layer the camera triggers by distance, every ``AdjustedFootprintSide`` metres,
  starting at the first vertex; the flight leaves at the first vertex at the entrance
  altitude. Altitudes are above the take-off point (home).

The expansion yields MAVLink items (command, frame, params) that the plain-item reader walks,
with a waypoint at every photo (where the distance trigger fires) so that each photo has its
position and heading.

Surveys and corridor scans (QGroundControl's transect-style items) are saved with the mission
items QGroundControl generated for them (``TransectStyleComplexItem.Items``), which it loads
back as they are rather than computing them again: those items are the expansion. Their
photos come from the camera's distance trigger (MAV_CMD_DO_SET_CAM_TRIGG_DIST), which the
plain-item reader follows along the legs, or from hover-and-capture photos. A survey that
sets no gimbal pitch is taken with the camera straight down, as QGroundControl's survey
camera assumes. Other complex items are refused by name.
"""

from __future__ import annotations

import numpy as np

from coverplan.errors import InputFileError
from coverplan.geometry import geo

STRUCTURE_SCAN = "StructureScan"
TRANSECT_STYLE = {"survey": "Survey", "CorridorScan": "Corridor Scan"}  # saved with their generated items
_FRAME_MISSION, _FRAME_GLOBAL_RELATIVE_ALT = 2, 3
_NAV_WAYPOINT, _DO_GIMBAL_MANAGER_PITCHYAW, _IMAGE_START_CAPTURE = 16, 1000, 2000
_DO_MOUNT_CONTROL = 205
NAN = float("nan")


def expand_complex_item(item: dict, n: int, path) -> list[tuple[int, int, list[float]]]:
    """The MAVLink items QGroundControl flies for complex item ``n`` of a ``.plan``.

    Parameters
    ----------
    item : dict
        The complex item.
    n : int
        Its index in the plan, for errors.
    path : str or Path
        The plan, for errors.

    Returns
    -------
    list of (int, int, list of float)
        Command, frame and params.

    Raises
    ------
    InputFileError
        For a complex item of another kind, or one whose settings do not hold.
    """
    kind = item.get("complexItemType", "complex")
    if kind in TRANSECT_STYLE:
        return transect_items(item, n, path)
    if kind != STRUCTURE_SCAN:
        raise InputFileError(path, f"mission item {n} is a {kind} item, which coverplan does not expand yet "
                                   "(Structure Scan, Survey and Corridor Scan items are); save it from "
                                   "QGroundControl as plain waypoints")
    return structure_scan_items(item, n, path)


def transect_items(item: dict, n: int, path) -> list[tuple[int, int, list[float]]]:
    """A Survey or Corridor Scan item as the mission items QGroundControl generated and saved
    with it; the camera straight down unless they set a gimbal pitch.

    Parameters
    ----------
    item : dict
        The complex item.
    n : int
        Its index in the plan.
    path : str or Path
        The plan.

    Returns
    -------
    list of (int, int, list of float)
        Command, frame and params.
    """
    name = TRANSECT_STYLE[item["complexItemType"]]
    inner = item.get("TransectStyleComplexItem")
    saved = inner.get("Items") if isinstance(inner, dict) else None
    if not isinstance(saved, list) or not saved:
        raise InputFileError(path, f"mission item {n} ({name}) holds no generated mission items "
                                   "(TransectStyleComplexItem.Items); open and save it again in QGroundControl")
    out = []
    for k, sub in enumerate(saved, start=1):
        params = sub.get("params") if isinstance(sub, dict) else None
        if not isinstance(params, list) or not isinstance(sub.get("command"), int):
            raise InputFileError(path, f"mission item {n} ({name}), generated item {k} has no command and params")
        out.append((sub["command"], int(sub.get("frame", _FRAME_GLOBAL_RELATIVE_ALT)), params))
    if not any(c in (_DO_GIMBAL_MANAGER_PITCHYAW, _DO_MOUNT_CONTROL) for c, _f, _p in out):
        out.insert(0, (_DO_GIMBAL_MANAGER_PITCHYAW, _FRAME_MISSION, [-90.0, 0.0, NAN, NAN, 0.0, 0.0, 0.0]))
    return out


def structure_scan_items(item: dict, n: int, path) -> list[tuple[int, int, list[float]]]:
    """A Structure Scan item as the waypoints, gimbal pitches and photos QGroundControl flies.

    Parameters
    ----------
    item : dict
        The complex item.
    n : int
        Its index in the plan.
    path : str or Path
        The plan.

    Returns
    -------
    list of (int, int, list of float)
        Command, frame and params.
    """
    scan = StructureScanSpec.from_item(item, n, path)
    lat0, lon0 = scan.polygon_latlon[0]
    frame = {"geodetic_origin": [lat0, lon0, 0.0]}  # a tangent plane at the first vertex, as QGC's NED
    ll = scan.polygon_latlon
    outline = geo.from_lonlat(frame, ll[:, 1], ll[:, 0], np.zeros(len(ll)))[:, :2]
    ring = flight_polygon(outline, scan.distance)
    out = [_waypoint(frame, ring[0], scan.entrance_alt, NAN)]
    out.append((_DO_GIMBAL_MANAGER_PITCHYAW, _FRAME_MISSION, [scan.gimbal_pitch, 0.0, NAN, NAN, 0.0, 0.0, 0.0]))
    for altitude in scan.layer_altitudes():
        loop = np.vstack([ring, ring[:1]])
        for point, heading, photo in layer_stops(loop, scan.trigger_distance):
            out.append(_waypoint(frame, point, altitude, heading))
            if photo:
                out.append((_IMAGE_START_CAPTURE, _FRAME_MISSION, [0.0, 0.0, 1.0, 0.0, NAN, NAN, NAN]))
    out.append(_waypoint(frame, ring[0], scan.entrance_alt, NAN))
    return out


class StructureScanSpec:
    """The settings of one Structure Scan item, checked.

    Parameters
    ----------
    polygon_latlon : (k, 2) float
        The structure's outline, degrees.
    distance : float
        Scan distance from the structure, metres.
    frontal : float
        The photo's height on the structure, metres (layer spacing).
    side : float
        The trigger distance along a layer, metres.
    bottom, height : float
        The scanned band's lowest and highest altitude above home, metres.
    layers : int
        The number of layers.
    entrance_alt : float
        The altitude of the entrance and exit, metres.
    gimbal_pitch : float
        Degrees.
    from_top : bool
        Fly the highest layer first.
    """

    def __init__(self, polygon_latlon, distance, frontal, side, bottom, height, layers, entrance_alt,
                 gimbal_pitch, from_top):
        self.polygon_latlon = polygon_latlon
        self.distance, self.frontal, self.trigger_distance = distance, frontal, side
        self.bottom, self.height, self.layers = bottom, height, layers
        self.entrance_alt, self.gimbal_pitch, self.from_top = entrance_alt, gimbal_pitch, from_top

    @classmethod
    def from_item(cls, item: dict, n: int, path) -> StructureScanSpec:
        """Read and check a Structure Scan item's settings.

        Parameters
        ----------
        item : dict
            The complex item.
        n : int
            Its index in the plan.
        path : str or Path
            The plan.

        Returns
        -------
        StructureScanSpec
            The settings.

        Raises
        ------
        InputFileError
            Naming the setting that is missing or out of range.
        """
        def number(obj, key, where="Structure Scan"):
            try:
                value = float(obj[key])
            except (KeyError, TypeError, ValueError):
                raise InputFileError(path, f"mission item {n} ({where}) has no number {key!r}") from None
            if not np.isfinite(value):
                raise InputFileError(path, f"mission item {n} ({where}) has {key} {value!r}")
            return value

        polygon = np.asarray(item.get("polygon") or [], dtype=float)
        if polygon.ndim != 2 or polygon.shape[0] < 3 or polygon.shape[1] < 2:
            raise InputFileError(path, f"mission item {n} (Structure Scan) has no polygon of 3 or more vertices")
        polygon = polygon[:, :2]
        calc = item.get("CameraCalc")
        if not isinstance(calc, dict):
            raise InputFileError(path, f"mission item {n} (Structure Scan) has no CameraCalc")
        distance = number(calc, "DistanceToSurface", "its CameraCalc")
        frontal = number(calc, "AdjustedFootprintFrontal", "its CameraCalc")
        side = number(calc, "AdjustedFootprintSide", "its CameraCalc")
        if distance <= 0 or frontal <= 0 or side <= 0:
            raise InputFileError(path, f"mission item {n} (Structure Scan): distance to surface and footprints must "
                                       f"be positive, got {distance:g}, {frontal:g}, {side:g} m")
        bottom, height = number(item, "ScanBottomAlt"), number(item, "StructureHeight")
        # QGroundControl recounts the layers from the heights and the frame when it loads the item.
        layers = max(int(np.ceil(max(height - bottom, 0.0) / frontal - 1e-9)), 1)
        return cls(polygon, distance, frontal, side, bottom, height, layers, number(item, "EntranceAltitude"),
                   float(item.get("GimbalPitch") or 0.0), bool(item.get("StartFromTop")))

    def layer_altitudes(self) -> np.ndarray:
        """Each layer's altitude above home, in the order flown.

        Returns
        -------
        (layers,) float
            Metres.
        """
        steps = self.frontal * (np.arange(self.layers) + 0.5)
        return self.height - steps if self.from_top else self.bottom + steps


def flight_polygon(outline: np.ndarray, distance: float) -> np.ndarray:
    """The outline (n, 2; local east, north) made clockwise and offset outward by
    ``distance``, each vertex where the two offset edges meet.

    Parameters
    ----------
    outline : (n, 2) float
    distance : float

    Returns
    -------
    (n, 2) float
        The flight polygon, vertex k from the outline's vertex k.
    """
    p = np.asarray(outline, dtype=float)
    x, y = p[:, 0], p[:, 1]
    if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0:  # counter-clockwise: QGC keeps outlines clockwise
        p = p[::-1]
        p = np.roll(p, 1, axis=0)  # vertex 0 stays vertex 0
    edge = np.roll(p, -1, axis=0) - p
    edge /= np.linalg.norm(edge, axis=1, keepdims=True)
    normal = np.column_stack([-edge[:, 1], edge[:, 0]])  # left of a clockwise edge: outward
    before, after = np.roll(normal, 1, axis=0), normal
    mitre = (before + after) / (1.0 + np.einsum("ij,ij->i", before, after))[:, None]
    return p + distance * mitre


def layer_stops(loop: np.ndarray, trigger: float):
    """(point, heading, photo) along the closed ``loop`` ((m, 2), first point repeated last):
    its vertices and the points every ``trigger`` m of path where the camera fires, the
    first at the start. Heading: 90 deg right of the way the drone flies (degrees from grid
    north, clockwise); at the last vertex the last edge's.

    Parameters
    ----------
    loop : (m, 2) float
        The closed loop, metres.
    trigger : float
        Metres of path between photos.

    Returns
    -------
    list of ((2,) float, float, bool)
        Point, heading and whether a photo is taken.
    """
    seg = np.diff(loop, axis=0)
    length = np.linalg.norm(seg, axis=1)
    along = np.concatenate([[0.0], np.cumsum(length)])
    shots = np.arange(0.0, along[-1] + 1e-9, trigger)
    travel = np.degrees(np.arctan2(seg[:, 0], seg[:, 1]))
    camera = np.mod(travel + 90.0, 360.0)
    stops = [(along[k], loop[k], camera[min(k, len(seg) - 1)], False) for k in range(len(loop))]
    for s in shots:
        k = min(int(np.searchsorted(along, s, side="right") - 1), len(seg) - 1)
        point = loop[k] + seg[k] * ((s - along[k]) / max(length[k], 1e-12))
        stops.append((s, point, camera[k], True))
    stops.sort(key=lambda t: (t[0], not t[3]))
    out, last = [], None
    for s, point, heading, photo in stops:
        if last is not None and abs(s - last[0]) < 1e-6:  # a photo at a vertex: one waypoint
            if photo:
                out[-1] = (out[-1][0], heading, True)
            continue
        out.append((point, heading, photo))
        last = (s,)
    return out


def _waypoint(frame: dict, xy, altitude: float, heading_grid: float):
    lon, lat, _h = geo.to_lonlat(frame, [[xy[0], xy[1], 0.0]])
    # In a tangent plane at the scan, grid north is true north to well below a degree.
    return (_NAV_WAYPOINT, _FRAME_GLOBAL_RELATIVE_ALT,
            [0.0, 0.0, 0.0, heading_grid, float(lat[0]), float(lon[0]), float(altitude)])
