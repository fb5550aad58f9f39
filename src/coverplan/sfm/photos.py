"""The photos of a real flight: where each was taken, where it looked, with which camera.

Read from the photos' own metadata with Pillow (EXIF) and lxml (the XMP packet):

- position: EXIF GPS latitude, longitude and altitude (above sea level); DJI's XMP
  ``drone-dji:AbsoluteAltitude`` and ``drone-dji:RelativeAltitude`` (above the take-off point)
  when present, the relative one preferred unless the scene's heights are above sea level;
- orientation: ``GimbalYawDegree`` (else ``FlightYawDegree``) and ``GimbalPitchDegree``
  (DJI, Autel), ``CameraYawDegree`` and ``CameraPitchDegree`` (Parrot), ``CameraOrientationNED``
  Yaw and Pitch (Skydio), degrees from true north and from level; Skydio's and Autel's XMP
  position where EXIF GPS is missing;
- RTK: DJI's ``RtkFlag`` and ``RtkStdLon/Lat/Hgt``;
- camera: the EXIF focal length with the focal-plane resolution (pixels per mm of sensor), or
  the 35 mm equivalent focal length over the image diagonal, and the image size.

``write_photo`` writes the same tags, as a DJI drone does, so tests and ``simulate`` can hand
rendered photos to ``check`` as a user would hand theirs.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree

from coverplan.equipment.lens import PINHOLE, Lens
from coverplan.errors import InputFileError
from coverplan.geometry.geo import grid_convergence, to_lonlat
from coverplan.sfm.render import PhotoCamera, ideal_renderer

PHOTO_SUFFIXES = (".jpg", ".jpeg", ".tif", ".tiff", ".png")
RTK_FIXED = 50
DJI_NS = "http://www.dji.com/drone-dji/1.0/"
FULL_FRAME_DIAGONAL_MM = float(np.hypot(36.0, 24.0))
_GPS, _EXIF = 0x8825, 0x8769
_FOCAL, _FOCAL_35, _FP_XRES, _FP_YRES, _FP_UNIT = 0x920A, 0xA405, 0xA20E, 0xA20F, 0xA210
_MM_PER_UNIT = {2: 25.4, 3: 10.0, 4: 1.0, 5: 1e-3}  # EXIF focal-plane resolution units: inch, cm, mm, um


@dataclass
class PhotoTags:
    """One photo's metadata. NaN where the photo does not say.

    Parameters
    ----------
    name : str
        The file's name.
    width, height : int
        Pixels.
    lat, lon : float
        WGS 84 degrees.
    gps_altitude_m : float
        Above sea level (EXIF).
    absolute_altitude_m : float
        Above sea level (DJI XMP).
    relative_altitude_m : float
        Above the take-off point (DJI XMP).
    heading_deg : float
        Gimbal yaw, degrees clockwise from true north.
    pitch_deg : float
        Gimbal pitch: 0 level, -90 down.
    focal_mm : float
        Focal length.
    focal_35mm : float
        35 mm equivalent focal length.
    pixels_per_mm : float
        On the sensor (EXIF focal-plane resolution).
    rtk_flag : int
        DJI RtkFlag: 0 no RTK, 16 single point, 34 float, 50 fixed; -1 not given.
    rtk_std_m : (float, float, float)
        DJI RtkStdLon, RtkStdLat, RtkStdHgt.
    camera_model : str
        EXIF Model.
    dewarp_data : str
        DJI DewarpData.
    optical_centre_x : float
        DJI CalibratedOpticalCenterX, px.
    """

    name: str
    width: int
    height: int
    lat: float = np.nan
    lon: float = np.nan
    gps_altitude_m: float = np.nan  # above sea level (EXIF)
    absolute_altitude_m: float = np.nan  # above sea level (DJI XMP)
    relative_altitude_m: float = np.nan  # above the take-off point (DJI XMP)
    heading_deg: float = np.nan  # true north, clockwise
    pitch_deg: float = np.nan  # 0 level, -90 down
    focal_mm: float = np.nan
    focal_35mm: float = np.nan
    pixels_per_mm: float = np.nan  # on the sensor (EXIF focal-plane resolution)
    rtk_flag: int = -1  # DJI RtkFlag: 0 no RTK, 16 single point, 34 float, 50 fixed; -1 not given
    rtk_std_m: tuple = (np.nan, np.nan, np.nan)  # DJI RtkStdLon, RtkStdLat, RtkStdHgt
    camera_model: str = ""  # EXIF Model
    dewarp_data: str = ""  # DJI DewarpData: the lens calibration, "date;fx,fy,cx,cy,k1,k2,p1,p2,k3"
    optical_centre_x: float = np.nan  # DJI CalibratedOpticalCenterX, px: half the calibrated width

    @property
    def rtk_fixed(self) -> bool:
        """Whether the photo was taken with an RTK fix (DJI ``RtkFlag`` 50)."""
        return self.rtk_flag == RTK_FIXED

    @property
    def has_position(self) -> bool:
        """Whether the tags give latitude, longitude and some height."""
        return bool(np.isfinite(self.lat) and np.isfinite(self.lon)
                    and (np.isfinite(self.relative_altitude_m) or np.isfinite(self.absolute_altitude_m)
                         or np.isfinite(self.gps_altitude_m)))

    @property
    def focal_px(self) -> float:
        """The focal length in pixels, from the sensor's pixel size or the 35 mm equivalent."""
        if np.isfinite(self.focal_mm) and np.isfinite(self.pixels_per_mm):
            return float(self.focal_mm * self.pixels_per_mm)
        if np.isfinite(self.focal_35mm):
            return float(self.focal_35mm * np.hypot(self.width, self.height) / FULL_FRAME_DIAGONAL_MM)
        return float("nan")


def read_photo(path) -> PhotoTags:
    """The metadata of one photo: EXIF, and XMP in any maker's namespace.

    Parameters
    ----------
    path : str or Path
        A JPEG, TIFF or PNG.

    Returns
    -------
    PhotoTags
        What the photo carries; a tag it lacks is NaN, -1 (RtkFlag) or "" (text).

    Raises
    ------
    InputFileError
        The file is not an image Pillow can open.
    """
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    try:
        with Image.open(path) as img:
            width, height = img.size
            exif = img.getexif()
            xmp = img.info.get("xmp") or img.info.get("XML:com.adobe.xmp")
    except (UnidentifiedImageError, OSError) as exc:
        raise InputFileError(path, f"is not a readable image ({exc})") from None
    tags = PhotoTags(path.name, int(width), int(height))
    tags.camera_model = str(exif.get(0x0110, "") or "").strip("\x00 ")
    gps = exif.get_ifd(_GPS)
    if 2 in gps and 4 in gps:
        tags.lat = _degrees(gps[2], gps.get(1, "N"), "S")
        tags.lon = _degrees(gps[4], gps.get(3, "E"), "W")
    if 6 in gps:
        below = gps.get(5) in (1, b"\x01")
        tags.gps_altitude_m = -float(gps[6]) if below else float(gps[6])
    sub = exif.get_ifd(_EXIF)
    if _FOCAL in sub:
        tags.focal_mm = float(sub[_FOCAL])
    if _FOCAL_35 in sub and float(sub[_FOCAL_35]) > 0:
        tags.focal_35mm = float(sub[_FOCAL_35])
    if _FP_XRES in sub and float(sub[_FP_XRES]) > 0:
        tags.pixels_per_mm = float(sub[_FP_XRES]) / _MM_PER_UNIT.get(int(sub.get(_FP_UNIT, 2)), 25.4)
    if xmp:
        _read_xmp(tags, xmp, path)
    return tags


def _degrees(dms, ref, negative: str) -> float:
    d, m, s = (float(v) for v in dms)
    value = d + m / 60.0 + s / 3600.0
    ref = ref.decode() if isinstance(ref, bytes) else str(ref)
    return -value if ref.strip().upper() == negative else value


RDF, X_NS = "{http://www.w3.org/1999/02/22-rdf-syntax-ns#}", "{adobe:ns:meta/}"
SKYDIO_NS = "https://www.skydio.com/drone-skydio/1.0/"
PARROT_NS = "http://www.parrot.com/drone-parrot/1.0/"


def _xmp_values(xmp) -> dict[str, str]:
    """Every XMP property by its local name, whichever maker's namespace holds it (DJI's
    ``drone-dji``, Autel's ``drone``, Parrot's ``drone-parrot``, Skydio's ``drone-skydio``),
    written as attributes or as elements; a structure's fields as ``Struct/Field``."""
    text = xmp if isinstance(xmp, bytes) else str(xmp).encode("utf-8")
    try:
        root = etree.fromstring(text.strip(b"\x00 \n"), parser=etree.XMLParser(resolve_entities=False,
                                                                               no_network=True, recover=True))
    except etree.XMLSyntaxError:
        return {}
    if root is None:
        return {}
    values: dict[str, str] = {}

    def local(tag: str) -> str:
        return tag.rsplit("}", 1)[-1]

    for node in root.iter():
        if not isinstance(node.tag, str):
            continue
        parent = node.getparent()
        while parent is not None and isinstance(parent.tag, str) and local(parent.tag) in ("Description", "li"):
            parent = parent.getparent()  # rdf:Description and rdf:li only wrap a structure's fields
        owner = "" if parent is None or not isinstance(parent.tag, str) or parent.tag.startswith(RDF) \
            else local(parent.tag) + "/"
        own = node.tag.startswith(RDF) or node.tag.startswith(X_NS)
        prefix = owner if own else owner + local(node.tag) + "/"
        for key, value in node.attrib.items():
            if not key.startswith(RDF):
                values.setdefault(prefix + local(key), value)
        if not own and node.text and node.text.strip():
            values.setdefault(owner + local(node.tag), node.text.strip())
    return values


def _read_xmp(tags: PhotoTags, xmp, path: Path) -> None:
    values = _xmp_values(xmp)

    def number(*names):
        for name in names:
            try:
                value = float(values[name])
            except (KeyError, ValueError):
                continue
            if np.isfinite(value):
                return value
        return np.nan

    tags.relative_altitude_m = number("RelativeAltitude")
    tags.absolute_altitude_m = number("AbsoluteAltitude")
    tags.pitch_deg = number("GimbalPitchDegree", "CameraPitchDegree", "CameraOrientationNED/Pitch")
    yaw = number("GimbalYawDegree", "CameraYawDegree", "CameraOrientationNED/Yaw", "FlightYawDegree")
    tags.heading_deg = float(np.mod(yaw, 360.0)) if np.isfinite(yaw) else np.nan
    if not np.isfinite(tags.lat):
        tags.lat = number("GpsLatitude", "GPSLatitude", "Latitude")
        tags.lon = number("GpsLongitude", "GPSLongitude", "GpsLongtitude", "GPSLongtitude", "Longitude")
    tags.rtk_flag = int(number("RtkFlag")) if np.isfinite(number("RtkFlag")) else -1
    tags.rtk_std_m = (number("RtkStdLon"), number("RtkStdLat"), number("RtkStdHgt"))
    tags.dewarp_data = values.get("DewarpData", "").strip()
    tags.optical_centre_x = number("CalibratedOpticalCenterX")


def write_photo(path, image: np.ndarray, tags: PhotoTags, quality: int = 95) -> Path:
    """Write ``image`` as a JPEG carrying ``tags`` as EXIF and DJI XMP.

    Parameters
    ----------
    path : str or Path
        The file to write.
    image : (h, w, 3) uint8
        The pixels.
    tags : PhotoTags
        Position, heights, angles, focal length and, where set, DewarpData.
    quality : int
        JPEG quality.

    Returns
    -------
    Path
        ``path``.
    """
    from PIL import Image
    from PIL.TiffImagePlugin import IFDRational

    def dms(value: float):
        value = abs(float(value))
        d = int(value)
        m = int((value - d) * 60.0)
        s = (value - d - m / 60.0) * 3600.0
        return (IFDRational(d), IFDRational(m), IFDRational(int(round(s * 1e6)), 1_000_000))

    exif = Image.Exif()
    exif[0x010F], exif[0x0110] = "coverplan", tags.camera_model or "rendered"
    gps = {}  # a photo without a fix carries no GPS position, as a camera without one writes it
    if np.isfinite(tags.lat) and np.isfinite(tags.lon):
        gps = {1: "N" if tags.lat >= 0 else "S", 2: dms(tags.lat), 3: "E" if tags.lon >= 0 else "W",
               4: dms(tags.lon)}
    if np.isfinite(tags.gps_altitude_m):
        gps[5] = b"\x00" if tags.gps_altitude_m >= 0 else b"\x01"
        gps[6] = IFDRational(int(round(abs(tags.gps_altitude_m) * 1000)), 1000)
    if gps:
        exif[_GPS] = gps
    sub = {}
    if np.isfinite(tags.focal_mm):
        sub[_FOCAL] = IFDRational(int(round(tags.focal_mm * 1000)), 1000)
    if np.isfinite(tags.pixels_per_mm):
        sub[_FP_XRES] = sub[_FP_YRES] = IFDRational(int(round(tags.pixels_per_mm * 1000)), 1000)
        sub[_FP_UNIT] = 4
    if np.isfinite(tags.focal_35mm):
        sub[_FOCAL_35] = int(round(tags.focal_35mm))
    exif[_EXIF] = sub
    attrs = {"GimbalYawDegree": tags.heading_deg, "FlightYawDegree": tags.heading_deg,
             "GimbalPitchDegree": tags.pitch_deg, "RelativeAltitude": tags.relative_altitude_m,
             "AbsoluteAltitude": tags.absolute_altitude_m}
    described = " ".join(f'drone-dji:{k}="{v:+.3f}"' for k, v in attrs.items() if np.isfinite(v))
    if tags.dewarp_data:  # as DJI writes it: the calibration, and the centre it was made about
        described += (f' drone-dji:DewarpData="{tags.dewarp_data}" drone-dji:DewarpFlag="0"'
                      f' drone-dji:CalibratedOpticalCenterX="{tags.width / 2.0:.6f}"'
                      f' drone-dji:CalibratedOpticalCenterY="{tags.height / 2.0:.6f}"')
    xmp = (f'<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">'
           f'<rdf:Description rdf:about="" xmlns:drone-dji="{DJI_NS}" {described}/></rdf:RDF></x:xmpmeta>')
    Image.fromarray(np.asarray(image, dtype=np.uint8)).save(path, exif=exif.tobytes(), xmp=xmp.encode("utf-8"),
                                                          quality=int(quality))
    return Path(path)


RAW_SUFFIXES = (".dng", ".arw", ".cr2", ".cr3", ".nef", ".orf", ".raf", ".rw2")


def photo_files(folder) -> list[Path]:
    """The photos in ``folder`` and its subfolders (a DJI card's 100MEDIA, 101MEDIA, ... or
    one folder per battery flight), sorted by their path; hidden folders are left out.

    Parameters
    ----------
    folder : str or Path
        The card or folder.

    Returns
    -------
    list of Path
        JPEG, TIFF and PNG files.

    Raises
    ------
    InputFileError
        No such folder, or one without photos.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputFileError(folder, "no such folder" if not folder.exists() else "is not a folder of photos")
    files = sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in PHOTO_SUFFIXES
                   and not any(part.startswith(".") for part in p.relative_to(folder).parts))
    if not files:
        raise InputFileError(folder, f"holds no photos ({', '.join(PHOTO_SUFFIXES)})")
    return files


def raw_files(folder) -> list[tuple[str, str]]:
    """The raw files in ``folder`` (as (name, why) rows of what is left out): COLMAP reads JPEG,
    TIFF and PNG; a raw file beside its JPEG is the same photo.

    Parameters
    ----------
    folder : str or Path
        The card or folder.

    Returns
    -------
    list of (str, str)
        Each raw file's path inside ``folder`` and why it is left out.
    """
    folder = Path(folder)
    out = []
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.suffix.lower() in RAW_SUFFIXES:
            twin = any(p.with_suffix(s).exists() or p.with_suffix(s.upper()).exists() for s in PHOTO_SUFFIXES)
            out.append((p.relative_to(folder).as_posix(), "a raw file; the JPEG beside it is used" if twin else
                        "a raw file, which COLMAP does not read: export it as JPEG"))
    return out


def whole_image(path) -> bool:
    """False for a JPEG cut short (no end-of-image marker and Pillow cannot decode it all).

    Parameters
    ----------
    path : str or Path
        A photo; other formats than JPEG count as whole.

    Returns
    -------
    bool
    """
    from PIL import Image

    path = Path(path)
    if path.suffix.lower() not in (".jpg", ".jpeg"):
        return True
    with open(path, "rb") as f:
        f.seek(max(path.stat().st_size - 64, 0))
        if b"\xff\xd9" in f.read():
            return True
    try:
        with Image.open(path) as img:
            img.load()
        return True
    except OSError:
        return False


def write_flight_photos(route, scene, folder, width: int = 1024, seed: int = 0, shots=None,
                        progress=None, lens: Lens = PINHOLE, dewarp_data: bool = True) -> list[Path]:
    """Render the route's photos (``simulate``'s ideal renderer, same seed: the same pictures)
    and write them as JPEGs tagged as a DJI drone tags its own: GPS position, altitude above
    the take-off point and above sea level, gimbal yaw and pitch, focal length and the
    sensor's pixel size. ``shots``: indices into ``route.shots`` to write (default all).
    ``lens``: the photos are drawn through it and, with ``dewarp_data``, carry its calibration
    as DJI's DewarpData tag (in the written photo's pixels).

    Parameters
    ----------
    route : Route
        The flight; its scene frame is placed by ``scene``'s geodetic origin.
    scene : Scene
        Rendered, and the origin of the GPS tags.
    folder : str or Path
        Made if missing; photos are named DJI_0001.JPG, ... in the order they are taken.
    width : int
        Photo width, px (the height follows the camera's aspect).
    seed : int
        The renderer's seed.
    shots : (k,) int, optional
        Indices into ``route.shots``.
    progress : callable, optional
        Called with 1 after each photo.
    lens : Lens
        The distortion the photos are drawn through.
    dewarp_data : bool
        Tag a distorted photo with its calibration.

    Returns
    -------
    list of Path
        The written photos.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    photo = PhotoCamera.of(route.camera, width, lens)
    dewarp = lens.dewarp_data(photo.fx, photo.fy) if dewarp_data and not lens.is_pinhole else ""
    renderer = ideal_renderer(scene, photo, route.d_opt, route.security, seed=seed)
    rows = route.shots if shots is None else route.shots[np.asarray(shots, dtype=np.int64)]
    p = route.positions[rows]
    lon, lat, h = to_lonlat(route.frame, p)
    absolute = bool(route.frame.get("vertical_crs") or route.frame.get("geodetic_origin"))
    heading = np.mod(route.heading_deg[rows] + grid_convergence(route.frame, p), 360.0)
    scale = photo.width / route.camera.image_width_px  # the sensor's pixels at the rendered width
    pixels_per_mm = route.camera.image_width_px / route.camera.sensor_width_mm * scale
    written = []
    for k, row in enumerate(rows):
        image = renderer.render(route.positions[row], route.heading_deg[row], route.pitch_deg[row])
        tags = PhotoTags(f"DJI_{k + 1:04d}.JPG", photo.width, photo.height, float(lat[k]), float(lon[k]),
                         gps_altitude_m=float(h[k]) if absolute else np.nan,
                         absolute_altitude_m=float(h[k]) if absolute else np.nan,
                         relative_altitude_m=float(p[k, 2] - route.takeoff_z), heading_deg=float(heading[k]),
                         pitch_deg=float(route.pitch_deg[row]), focal_mm=route.camera.focal_length_mm,
                         pixels_per_mm=pixels_per_mm, dewarp_data=dewarp)
        written.append(write_photo(folder / tags.name, image, tags))
        if progress is not None:
            progress(1)
    return written
