"""coverplan: safe drone photo flights that image every part of a building at least twice.

The facade: ``load_scene``, ``Camera``/``get_camera``, ``plan``, ``evaluate``, ``Route``.
"""

__version__ = "0.1.0"

from .camera import PRESETS, Camera, get_camera  # noqa: E402
from .errors import CoverplanError, InputFileError, ParameterError, PlanningError, RouteFormatError  # noqa: E402
from .evaluate import Evaluation, evaluate  # noqa: E402
from .planner import plan  # noqa: E402
from .route import Route  # noqa: E402
from .scene import Scene, load_scene  # noqa: E402

__all__ = ["Camera", "PRESETS", "get_camera", "Scene", "load_scene", "Route", "plan", "evaluate", "Evaluation",
           "CoverplanError", "InputFileError", "ParameterError", "PlanningError", "RouteFormatError"]
