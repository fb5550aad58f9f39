"""The thesis's voxel planner, reproduced as a baseline to compare the mesh planner with."""

from coverplan.voxel.grid import FREE, OBSTACLE, TARGET, SceneGrid, grid_from_polygons, grid_from_scene
from coverplan.voxel.planner import Flight, VoxelPlan, plan_2d, plan_3d, thesis_camera
from coverplan.voxel.view import Viewpoints, view_plan

__all__ = ["SceneGrid", "grid_from_polygons", "grid_from_scene", "FREE", "TARGET", "OBSTACLE",
           "plan_2d", "plan_3d", "thesis_camera", "VoxelPlan", "Flight", "view_plan", "Viewpoints"]
