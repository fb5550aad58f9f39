"""Simulated photos of a flight and Structure-from-Motion on them (``coverplan simulate``).

``render``  textured ray-cast photos along a route (Embree, no extra dependency);
``colmap``  SfM with pycolmap (the optional ``coverplan[sfm]`` extra) and its alignment;
``judge``   what the reconstruction recovered of the target surface, per surface class.
"""
