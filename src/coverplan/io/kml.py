"""KML for Google Earth: the flight as a 3D line and one placemark per shot whose camera looks
where the shot does (heading, tilt = 90 + gimbal pitch)."""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from coverplan.files import write_atomic
from coverplan.geometry import geo
from coverplan.io.geoflight import geo_flight, geo_zones
from coverplan.io.registry import register_writer

KML_NS = "http://www.opengis.net/kml/2.2"


def _coord(lon, lat, alt) -> str:
    return f"{lon:.8f},{lat:.8f},{alt:.2f}"


def _zone_placemark(zone, rings) -> str:
    """A zone's polygon on the ground, its outline closed as KML wants it."""
    def ring(r):
        r = np.vstack([r, r[:1]])
        return " ".join(_coord(a, b, 0.0) for a, b in r)
    holes = "".join(f"<innerBoundaryIs><LinearRing><coordinates>{ring(h)}</coordinates></LinearRing></innerBoundaryIs>"
                    for h in rings[1:])
    return f"""  <Placemark>
   <name>{escape(zone.kind)} zone {escape(zone.name)}</name>
   <styleUrl>#{zone.kind}</styleUrl>
   <Polygon><altitudeMode>clampToGround</altitudeMode><outerBoundaryIs><LinearRing><coordinates>{ring(rings[0])}</coordinates></LinearRing></outerBoundaryIs>{holes}</Polygon>
  </Placemark>
"""


@register_writer("kml", ".kml")
def write_kml(route, path, name: str | None = None, **_ignored) -> list[Path]:
    """Write the route as KML: the path and a placemark per photo.

    Parameters
    ----------
    route : Route
        The route (one battery flight).
    path : str or Path
        The file.
    name : str, optional
        The document's name; the file's stem when None.
    **_ignored
        Options of other writers.

    Returns
    -------
    list of Path
        The file written.
    """
    f = geo_flight(route)
    absolute = f.alt_abs is not None
    mode = "absolute" if absolute else "relativeToGround"
    alt = f.alt_abs if absolute else f.alt_rel
    title = escape(name or Path(path).stem)
    line = " ".join(_coord(f.lon[k], f.lat[k], alt[k]) for k in range(len(f)))
    shots = []
    number = 0
    for k in range(len(f)):
        if not f.shot[k]:
            continue
        number += 1
        shots.append(f"""   <Placemark>
    <name>shot {number}</name>
    <Camera><longitude>{f.lon[k]:.8f}</longitude><latitude>{f.lat[k]:.8f}</latitude><altitude>{alt[k]:.2f}</altitude><heading>{f.heading_true[k]:.2f}</heading><tilt>{90.0 + f.pitch[k]:.2f}</tilt><roll>0</roll><altitudeMode>{mode}</altitudeMode></Camera>
    <styleUrl>#shot</styleUrl>
    <ExtendedData><Data name="waypoint"><value>{k}</value></Data><Data name="heading_deg"><value>{f.heading_true[k]:.2f}</value></Data><Data name="gimbal_pitch_deg"><value>{f.pitch[k]:.2f}</value></Data><Data name="altitude_above_takeoff_m"><value>{f.alt_rel[k]:.2f}</value></Data></ExtendedData>
    <Point><altitudeMode>{mode}</altitudeMode><coordinates>{_coord(f.lon[k], f.lat[k], alt[k])}</coordinates></Point>
   </Placemark>""")
    outline = ""
    if route.extra.get("target_outline"):
        ring = np.asarray(route.extra["target_outline"], dtype=float)
        lon, lat, h = geo.to_lonlat(route.frame, ring)
        ring_alt = h if absolute else np.zeros(len(ring))
        coords = " ".join(_coord(a, b, c) for a, b, c in zip(lon, lat, ring_alt))
        outline = f"""  <Placemark>
   <name>target footprint</name>
   <styleUrl>#target</styleUrl>
   <Polygon><altitudeMode>{"absolute" if absolute else "clampToGround"}</altitudeMode><outerBoundaryIs><LinearRing><coordinates>{coords}</coordinates></LinearRing></outerBoundaryIs></Polygon>
  </Placemark>
"""
    zones = "".join(_zone_placemark(zone, rings) for zone in geo_zones(route) for rings in zone.polygons)
    text = f"""<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="{KML_NS}">
 <Document>
  <name>{title}</name>
  <Style id="path"><LineStyle><color>ff2080ff</color><width>3</width></LineStyle></Style>
  <Style id="shot"><IconStyle><scale>0.6</scale></IconStyle><LabelStyle><scale>0</scale></LabelStyle></Style>
  <Style id="target"><LineStyle><color>ff404040</color><width>2</width></LineStyle><PolyStyle><color>66a0a0a0</color></PolyStyle></Style>
  <Style id="keep-out"><LineStyle><color>ff2020e0</color><width>2</width></LineStyle><PolyStyle><color>502020e0</color></PolyStyle></Style>
  <Style id="keep-in"><LineStyle><color>ff20b020</color><width>2</width></LineStyle><PolyStyle><color>2020b020</color></PolyStyle></Style>
{outline}{zones}  <Placemark>
   <name>flight ({int(f.shot.sum())} shots)</name>
   <styleUrl>#path</styleUrl>
   <LineString><altitudeMode>{mode}</altitudeMode><coordinates>{line}</coordinates></LineString>
  </Placemark>
  <Folder>
   <name>shots</name>
{chr(10).join(shots)}
  </Folder>
 </Document>
</kml>
"""
    return [write_atomic(path, text)]
