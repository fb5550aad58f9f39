"""coverplan: safe drone photo flights whose photos rebuild every part of a building.

The facade: ``load_scene``, ``Camera``/``get_camera``, ``plan``, ``evaluate``, ``simulate``,
``check``, ``Route``. The subpackages are the pipeline's stages, each importing only earlier ones:
``geometry`` -> ``equipment`` -> ``world`` -> ``shots`` -> ``flight`` -> ``planning`` /
``evaluation`` -> ``io`` -> ``sfm`` -> ``report`` -> ``job`` -> ``batch`` -> ``cli``.
"""

__version__ = "0.1.0"

from coverplan.equipment.camera import PRESETS, Camera, get_camera  # noqa: E402
from coverplan.errors import CoverplanError, InputFileError, ParameterError, PlanningError, RouteFormatError  # noqa: E402,E501
from coverplan.evaluation import evaluate
from coverplan.evaluation.result import Evaluation
from coverplan.flight.route import Route  # noqa: E402
from coverplan.io.load import load_scene  # noqa: E402
from coverplan.planning import PlanSettings, plan  # noqa: E402
from coverplan.sfm.check import Check, check  # noqa: E402
from coverplan.sfm.simulate import simulate
from coverplan.sfm.simulation import Simulation
from coverplan.world.scene import Scene  # noqa: E402

__all__ = ["Camera", "PRESETS", "get_camera", "Scene", "load_scene", "Route", "plan", "PlanSettings", "evaluate",
           "Evaluation", "simulate", "Simulation", "check", "Check", "CoverplanError", "InputFileError",
           "ParameterError", "PlanningError", "RouteFormatError"]
