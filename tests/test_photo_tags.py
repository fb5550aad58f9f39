"""Photo metadata as the makers write it, written here by a real writer (exiftool, with a config
for the makers' own XMP namespaces exiftool does not know), read back by check's reader; and
which height each photo gives, in which datum."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

from coverplan.sfm.photo_route import photo_heights
from coverplan.sfm.photos import read_photo
from tests.helpers import ROOT

EXIFTOOL = shutil.which("exiftool")
CONFIG = ROOT / "tests" / "data" / "exiftool_makers.config"
pytestmark = pytest.mark.skipif(EXIFTOOL is None, reason="exiftool is not installed (Debian: libimage-exiftool-perl)")

GPS = {"GPSLatitude": "48.7758123", "GPSLatitudeRef": "N", "GPSLongitude": "9.1829456", "GPSLongitudeRef": "E",
       "GPSAltitude": "291.4", "GPSAltitudeRef": "0"}
LENS = {"FocalLength": "8.8", "FocalPlaneXResolution": "4.85", "FocalPlaneYResolution": "4.85",
        "FocalPlaneResolutionUnit": "4"}

MAKERS = {
    "dji-phantom4pro": ({"Make": "DJI", "Model": "FC6310", **GPS, **LENS, "XMP-drone-dji:AbsoluteAltitude": "291.40",
                         "XMP-drone-dji:RelativeAltitude": "+41.20", "XMP-drone-dji:GimbalYawDegree": "-135.5",
                         "XMP-drone-dji:GimbalPitchDegree": "-30.0", "XMP-drone-dji:FlightYawDegree": "-130.0"},
                        dict(heading_deg=224.5, pitch_deg=-30.0, relative_altitude_m=41.2, absolute_altitude_m=291.4,
                             rtk_flag=-1)),
    "dji-m3e-rtk": ({"Make": "DJI", "Model": "M3E", **GPS, **LENS, "XMP-drone-dji:AbsoluteAltitude": "339.10",
                     "XMP-drone-dji:RelativeAltitude": "+40.00", "XMP-drone-dji:GimbalYawDegree": "90.0",
                     "XMP-drone-dji:GimbalPitchDegree": "-90.0", "XMP-drone-dji:RtkFlag": "50",
                     "XMP-drone-dji:RtkStdLon": "0.012", "XMP-drone-dji:RtkStdLat": "0.011",
                     "XMP-drone-dji:RtkStdHgt": "0.021"},
                    dict(heading_deg=90.0, pitch_deg=-90.0, relative_altitude_m=40.0, absolute_altitude_m=339.1,
                         rtk_flag=50, rtk_std_m=(0.012, 0.011, 0.021))),
    "dji-m350-p1-float": ({"Make": "DJI", "Model": "ZenmuseP1", **GPS, **LENS,
                           "XMP-drone-dji:AbsoluteAltitude": "339.10", "XMP-drone-dji:RelativeAltitude": "+40.00",
                           "XMP-drone-dji:GimbalYawDegree": "0.0", "XMP-drone-dji:GimbalPitchDegree": "-45.0",
                           "XMP-drone-dji:RtkFlag": "34"},
                          dict(heading_deg=0.0, pitch_deg=-45.0, rtk_flag=34)),
    "generic-exif-below-sea-level": ({"Make": "Canon", "Model": "PowerShot", "GPSLatitude": "31.5", "GPSLatitudeRef":
                                      "N", "GPSLongitude": "35.48", "GPSLongitudeRef": "E", "GPSAltitude": "412.6",
                                      "GPSAltitudeRef": "1", "FocalLength": "4.5", "FocalLengthIn35mmFormat": "25"},
                                     dict(lat=31.5, lon=35.48, gps_altitude_m=-412.6, relative_altitude_m=np.nan,
                                          rtk_flag=-1)),
    "parrot-anafi": ({"Make": "Parrot", "Model": "ANAFI", **GPS, **LENS, "XMP-drone-parrot:CameraPitchDegree": "-60.5",
                      "XMP-drone-parrot:CameraYawDegree": "-10.0"},
                     dict(heading_deg=350.0, pitch_deg=-60.5)),
    "skydio-x2": ({"Make": "Skydio", "Model": "X2", **LENS, "XMP-drone-skydio:Latitude": "48.7758123",
                   "XMP-drone-skydio:Longitude": "9.1829456", "XMP-drone-skydio:AbsoluteAltitude": "301.5",
                   "XMP-drone-skydio:CameraOrientationNEDYaw": "123.5",
                   "XMP-drone-skydio:CameraOrientationNEDPitch": "-45.0"},
                  dict(lat=48.7758123, lon=9.1829456, absolute_altitude_m=301.5, heading_deg=123.5, pitch_deg=-45.0)),
    "autel-evo2": ({"Make": "Autel Robotics", "Model": "XT701", **LENS, "XMP-drone:GpsLatitude": "48.7758123",
                    "XMP-drone:GpsLongtitude": "9.1829456", "XMP-drone:AbsoluteAltitude": "301.5",
                    "XMP-drone:RelativeAltitude": "50.2", "XMP-drone:GimbalPitchDegree": "-80.0",
                    "XMP-drone:GimbalYawDegree": "200.0"},
                   dict(lat=48.7758123, lon=9.1829456, relative_altitude_m=50.2, heading_deg=200.0, pitch_deg=-80.0)),
}


def tagged_photo(folder, name: str, tags: dict):
    """A plain JPEG, then ``tags`` written into it by exiftool."""
    from PIL import Image

    path = folder / f"{name}.jpg"
    Image.new("RGB", (400, 300), (90, 110, 130)).save(path)
    args = [EXIFTOOL, "-config", str(CONFIG), "-q", "-overwrite_original", "-n"]
    args += [f"-{k}={v}" for k, v in tags.items()]
    done = subprocess.run(args + [str(path)], capture_output=True, text=True)
    assert done.returncode == 0 and "Warning" not in done.stderr, done.stderr
    return path


@pytest.mark.parametrize("maker", list(MAKERS))
def test_each_makers_tags_read_back(tmp_path, maker):
    tags, expected = MAKERS[maker]
    got = read_photo(tagged_photo(tmp_path, maker, tags))
    assert got.has_position and (got.width, got.height) == (400, 300)
    for name, value in expected.items():
        have = getattr(got, name)
        if isinstance(value, tuple):
            assert np.allclose(have, value), (name, have)
        elif isinstance(value, float) and np.isnan(value):
            assert np.isnan(have), (name, have)
        else:
            assert have == pytest.approx(value, abs=1e-6), (name, have, value)
    if "lat" not in expected:
        assert got.lat == pytest.approx(48.7758123, abs=1e-7) and got.lon == pytest.approx(9.1829456, abs=1e-7)
    assert np.isfinite(got.focal_px) and got.focal_px > 0


def test_heights_name_their_datum(tmp_path, monkeypatch):
    plain = read_photo(tagged_photo(tmp_path, "p4p", MAKERS["dji-phantom4pro"][0]))
    rtk = read_photo(tagged_photo(tmp_path, "m3e", MAKERS["dji-m3e-rtk"][0]))
    generic = read_photo(tagged_photo(tmp_path, "canon", MAKERS["generic-exif-below-sea-level"][0]))
    # a scene without a height datum: above the take-off point wherever the photo gives it
    alt, ref, text = photo_heights([plain, rtk], absolute_heights=False)
    assert np.allclose(alt, [41.2, 40.0]) and "2 above the take-off point (DJI RelativeAltitude)" == text
    # a scene with a datum: DJI's EGM96 heights; EXIF GPSAltitude below sea level keeps its sign
    alt, ref, text = photo_heights([plain, generic], absolute_heights=True)
    assert np.allclose(alt, [291.4, -412.6])
    assert "1 above sea level, EGM96 (DJI AbsoluteAltitude)" in text and "EXIF GPSAltitude" in text
    # RTK fixed: an ellipsoidal height, brought to EGM96 through the geoid (here a geoid 47.5 m
    # above the ellipsoid) ...

    class Geoid:
        def transform(self, lon, lat, h):
            return lon, lat, np.asarray(h) - 47.5

    import coverplan.geometry.geo as geo
    monkeypatch.setattr(geo, "checked_transformer", lambda src, dst: Geoid())
    alt, ref, text = photo_heights([rtk], absolute_heights=True)
    assert alt[0] == pytest.approx(339.1 - 47.5) and "RTK fixed: WGS84 ellipsoidal" in text
    # ... and without PROJ's geoid grid, its height above the take-off point, said so
    from coverplan.errors import ParameterError

    def missing(src, dst):
        raise ParameterError("needs PROJ's grid us_nga_egm96_15.tif")

    monkeypatch.setattr(geo, "checked_transformer", missing)
    alt, ref, text = photo_heights([rtk], absolute_heights=True)
    assert alt[0] == pytest.approx(40.0) and text == "1 above the take-off point (DJI RelativeAltitude)"
