"""The cameras COLMAP reconstructs photos with: one per lens, focal setting and image size.

A rendered flight's camera is known exactly (``simulate`` drew the photos through it): a
pinhole, or COLMAP's FULL_OPENCV with the drawn lens, never refined. A real flight's camera is
a starting point that bundle adjustment refines: DJI's ``DewarpData`` calibration where the
photos carry it (OPENCV: k1, k2, p1, p2 refined, its k3 left to them), else the EXIF focal
length with the distortion terms of ``lens_model`` starting at zero (``LENS_MODELS``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coverplan.equipment.lens import parse_dewarp_data
from coverplan.errors import InputFileError, ParameterError
from coverplan.sfm.render import PhotoCamera

# A lens the photos do not describe: COLMAP's model, and its distortion terms (all start at zero).
LENS_MODELS = {
    "simple_radial": ("SIMPLE_RADIAL", 1),  # f, cx, cy, k: COLMAP's default for an unknown camera
    "radial": ("RADIAL", 2),  # f, cx, cy, k1, k2
    "opencv": ("OPENCV", 4),  # fx, fy, cx, cy, k1, k2, p1, p2
}
LENS_MODEL = "radial"


def check_lens_model(name: str) -> str:
    """``name`` if it is one of ``LENS_MODELS``.

    Parameters
    ----------
    name : str
        "simple_radial", "radial" or "opencv".

    Returns
    -------
    str
        ``name``.

    Raises
    ------
    ParameterError
        Any other name.
    """
    if name not in LENS_MODELS:
        raise ParameterError(f"lens model must be one of {', '.join(LENS_MODELS)}, got {name!r}")
    return name


@dataclass
class CameraGroup:
    """Photos taken with one camera, and the camera as COLMAP is given it.

    Parameters
    ----------
    photo : PhotoCamera
        Size and focal length (and, for rendered photos, the lens drawn through).
    names : list of str
        The photos, as COLMAP names them.
    model : str
        COLMAP's camera model.
    params : tuple of float
        Its parameters, in COLMAP's order.
    refine : bool
        Bundle adjustment refines focal length and distortion.
    label : str
        What the camera is, for the user.
    """

    photo: PhotoCamera  # size and focal length (and, for rendered photos, the lens drawn through)
    names: list  # the photos, as COLMAP names them
    model: str  # COLMAP's camera model
    params: tuple  # its parameters, in COLMAP's order
    refine: bool  # bundle adjustment refines focal length and distortion
    label: str = ""  # what the camera is, for the user

    @classmethod
    def known(cls, photo: PhotoCamera, names: list) -> "CameraGroup":
        """The camera that drew ``photo``'s rendered photos, exactly, not refined.

        Parameters
        ----------
        photo : PhotoCamera
            The renderer's camera and lens.
        names : list of str
            The photos it drew.

        Returns
        -------
        CameraGroup
        """
        centre = (photo.fx, photo.fy, photo.cx, photo.cy)
        if photo.lens.is_pinhole:
            return cls(photo, list(names), "PINHOLE", centre, False, "pinhole")
        return cls(photo, list(names), "FULL_OPENCV", centre + photo.lens.opencv + (0.0, 0.0, 0.0), False,
                   f"lens k1 {photo.lens.k1:+.3f}")

    @property
    def colmap_params(self) -> str:
        """The parameters as COLMAP's comma-separated text."""
        return ",".join(f"{float(v):.12g}" for v in self.params)


def photo_groups(tags: list, folder, lens_model: str = LENS_MODEL) -> list[CameraGroup]:
    """The photos of a real flight (``tags``: PhotoTags) grouped by camera: EXIF model, image
    size, focal length and lens calibration; the largest group first. A camera without DJI
    ``DewarpData`` is given ``lens_model``'s distortion terms, starting at zero.

    Parameters
    ----------
    tags : list of PhotoTags
        The photos' metadata (sfm/photos.py).
    folder : Path
        Their folder (the names in a group are relative to it).
    lens_model : str
        See ``LENS_MODELS``.

    Returns
    -------
    list of CameraGroup
        One per camera, each refined in bundle adjustment.

    Raises
    ------
    InputFileError
        No photo of a group gives a focal length.
    """
    colmap_model, terms = LENS_MODELS[check_lens_model(lens_model)]
    groups: dict[tuple, list] = {}
    for t in tags:
        focal = round(float(t.focal_mm), 2) if np.isfinite(t.focal_mm) else None
        groups.setdefault((t.camera_model, t.width, t.height, focal, t.dewarp_data), []).append(t)
    out = []
    for (model, width, height, _focal, dewarp_text), members in groups.items():
        focal_px = np.array([t.focal_px for t in members])
        if not np.isfinite(focal_px).any():
            raise InputFileError(folder, f"its photos ({model or 'camera'} {width}x{height}, e.g. {members[0].name}) "
                                         "give no focal length (EXIF FocalLength with FocalPlaneXResolution, or "
                                         "FocalLengthIn35mmFilm)")
        fx = float(np.median(focal_px[np.isfinite(focal_px)]))
        names = [t.name for t in members]
        dewarp = parse_dewarp_data(dewarp_text)
        label = f"{model or 'camera'} {width}x{height}"
        if dewarp is not None:
            centre_x = members[0].optical_centre_x
            scale = width / (2.0 * centre_x) if np.isfinite(centre_x) and centre_x > 0 else 1.0
            photo = PhotoCamera(width, height, dewarp.fx * scale, dewarp.fy * scale, dewarp.lens)
            # OPENCV, not FULL_OPENCV: refined from the tag, FULL_OPENCV's rational terms k4-k6
            # trade off against k1 (a Phantom 4 Pro lens came back with k1 -0.45 for -0.27).
            params = (photo.fx, photo.fy, width / 2.0 + dewarp.dx * scale, height / 2.0 + dewarp.dy * scale) \
                + dewarp.lens.opencv[:4]
            out.append(CameraGroup(photo, names, "OPENCV", params, True, label + f", {photo.fx:.0f} px focal and lens from DJI DewarpData"))
        else:
            photo = PhotoCamera(width, height, fx, fx)
            focal = (fx, fx) if colmap_model == "OPENCV" else (fx,)
            out.append(CameraGroup(photo, names, colmap_model, focal + (width / 2.0, height / 2.0) + (0.0,) * terms,
                                   True, label + f", {fx:.0f} px focal from EXIF, lens distortion estimated "
                                                 f"({colmap_model})"))
    out.sort(key=lambda g: -len(g.names))
    return out
