"""Every reader on corrupted input: only the documented errors may come out.

Valid files truncated anywhere, random bytes, a few bytes flipped, and (for the JSON
formats) well-formed JSON of the wrong shape. A reader may accept what it can make sense
of; it must never raise anything but InputFileError / ParameterError (RouteFormatError for
route files).
"""

from __future__ import annotations

import gzip
import json

import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from coverplan import InputFileError, ParameterError, Route, RouteFormatError, load_scene
from tests.helpers import MESHES, box

EXAMPLES = 25


def _mesh_bytes(ext: str) -> bytes:
    mesh = box(0, 0, 0, 10, 8, 6)
    if ext in ("glb", "gltf"):
        return trimesh.Scene(mesh).export(file_type=ext if ext == "glb" else "gltf")["model.gltf"] \
            if ext == "gltf" else trimesh.Scene(mesh).export(file_type="glb")
    out = mesh.export(file_type=ext)
    return out if isinstance(out, bytes) else out.encode()


SAMPLES = {
    "obj": _mesh_bytes("obj"),
    "ply": _mesh_bytes("ply"),
    "stl": _mesh_bytes("stl"),
    "off": _mesh_bytes("off"),
    "glb": _mesh_bytes("glb"),
    "gml": gzip.decompress((MESHES / "citygml" / "lod2_buildings_v3.gml.gz").read_bytes())[:60000],
    "city.json": gzip.decompress((MESHES / "citygml" / "lod2_buildings_v2.json.gz").read_bytes()),
}
SAMPLES["gml.gz"] = gzip.compress(SAMPLES["gml"])

corruptions = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0, 1)),
    st.tuples(st.just("random"), st.binary(min_size=1, max_size=400)),
    st.tuples(st.just("flip"), st.lists(st.tuples(st.floats(0, 1), st.integers(0, 255)), min_size=1, max_size=8)),
)


def corrupt(data: bytes, how) -> bytes:
    kind, arg = how
    if kind == "truncate":
        return data[: int(len(data) * arg)] or b"x"
    if kind == "random":
        return arg
    out = bytearray(data)
    for where, value in arg:
        out[min(int(where * len(out)), len(out) - 1)] = value
    return bytes(out)


def load_quietly(path):
    try:
        load_scene(path, building="FZK_GUID_1F3E679D-E226-4535-926C-7390977FB25A" if "city" in path.name or path.name.startswith("g") else None)
    except (InputFileError, ParameterError):
        pass


@pytest.mark.parametrize("ext", sorted(SAMPLES))
@settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(how=corruptions)
def test_reader_on_corrupted_file(tmp_path, ext, how):
    path = tmp_path / f"g.{ext}"
    path.write_bytes(corrupt(SAMPLES[ext], how))
    load_quietly(path)


json_values = st.recursive(st.none() | st.booleans() | st.floats(allow_nan=True) | st.integers() | st.text(max_size=8),
                           lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4),
                           max_leaves=20)


@settings(max_examples=EXAMPLES * 2, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(objects=st.dictionaries(st.text(max_size=6), json_values, max_size=3), vertices=json_values,
       transform=json_values)
def test_cityjson_of_the_wrong_shape(tmp_path, objects, vertices, transform):
    doc = {"type": "CityJSON", "version": "2.0", "CityObjects": objects, "vertices": vertices, "transform": transform}
    path = tmp_path / "w.city.json"
    path.write_text(json.dumps(doc))
    load_quietly(path)


@settings(max_examples=EXAMPLES * 2, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(change=st.dictionaries(st.sampled_from(["format", "version", "units", "frame", "camera", "params",
                                               "waypoints", "uncovered", "metrics"]), json_values, max_size=3),
       waypoint=st.dictionaries(st.sampled_from(["position", "shot", "view_dir", "heading_deg", "gimbal_pitch_deg",
                                                 "leg"]), json_values, max_size=6))
def test_route_reader_on_wrong_types(tmp_path, change, waypoint):
    doc = {"format": "coverplan-route", "version": 1, "units": "m", "frame": {"crs": None, "origin": [0, 0, 0]},
           "camera": {"sensor_width_mm": 13.2, "sensor_height_mm": 8.8, "focal_length_mm": 8.8,
                      "image_width_px": 5472, "image_height_px": 3648},
           "params": {"gsd_m": 0.004, "security_m": 3.0},
           "waypoints": [{"position": [0, 0, 5], "shot": True, "heading_deg": 0, "gimbal_pitch_deg": 0, "leg": "coverage"},
                         waypoint]}
    doc.update(change)
    path = tmp_path / "r.json"
    path.write_text(json.dumps(doc))
    try:
        Route.load(path)
    except RouteFormatError:
        pass


@settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=300))
def test_route_reader_on_random_bytes(tmp_path, data):
    path = tmp_path / "r.json"
    path.write_bytes(data)
    try:
        Route.load(path)
    except RouteFormatError:
        pass


def test_samples_are_valid_before_corruption(tmp_path):
    for ext, data in SAMPLES.items():
        path = tmp_path / f"ok.{ext}"
        path.write_bytes(data)
        if ext.startswith("gml"):
            continue  # the GML sample is cut short on purpose (speed); it is malformed
        scene = load_scene(path, building="FZK_GUID_1F3E679D-E226-4535-926C-7390977FB25A" if "json" in ext else None)
        assert scene.targets
