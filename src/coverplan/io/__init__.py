"""Readers and writers: scene files, city models, missions and exports, behind one registry
(:mod:`coverplan.io.registry`), looked up by :mod:`coverplan.io.formats`; ``load_scene``
(:mod:`coverplan.io.load`) builds a scene from them."""

from coverplan.io.formats import (
                                  GEOGRAPHIC_FORMATS,
                                  export_route,
                                  mission_extensions,
                                  parse_formats,
                                  read_city_model,
                                  read_file,
                                  read_mission,
                                  supported_extensions,
                                  writer,
                                  writer_names,
)
from coverplan.io.registry import MeshSource

__all__ = ["GEOGRAPHIC_FORMATS", "MeshSource", "export_route", "mission_extensions", "parse_formats",
           "read_city_model", "read_file", "read_mission", "supported_extensions", "writer", "writer_names"]
