"""Planning: the settings of a plan and :func:`plan`, which runs the pipeline's stages."""

from coverplan.planning.planner import plan
from coverplan.planning.settings import PlanSettings

__all__ = ["PlanSettings", "plan"]
