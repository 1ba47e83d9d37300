"""handeye-pick: camera-guided picks on Universal Robots arms.

The public names are imported on first use (a module-level ``__getattr__``), so ``import
handeye_pick``, which every command and ``python -m handeye_pick.cli`` runs first, loads nothing
but this file. The modules behind the names keep their own heavy imports (numba, matplotlib) inside
the functions that need them.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

# Public name -> the module that defines it. A new export (e.g. "Cell":
# "handeye_pick.cell.session") is a line here, its name in __all__ and its import under
# TYPE_CHECKING.
_EXPORTS = {
    "Cell": "handeye_pick.cell.session",
    "Capture": "handeye_pick.cell.captures",
    "CellStatus": "handeye_pick.cell.status",
    "PickResult": "handeye_pick.cell.pick",
    "NoFeasibleCandidate": "handeye_pick.cell.plan",
    "PreflightRefusal": "handeye_pick.safety",
    "load_config": "handeye_pick.config.load",
    "load_detection": "handeye_pick.detection",
    "detection_from_point_mm": "handeye_pick.detection",
    "Detection": "handeye_pick.detection",
    "HandEyePickError": "handeye_pick.errors",
    "InputError": "handeye_pick.errors",
    "SafetyRefusal": "handeye_pick.errors",
    "CellHalted": "handeye_pick.errors",
    "RobotError": "handeye_pick.errors",
    "RobotFault": "handeye_pick.errors",
    "RobotConnectionError": "handeye_pick.errors",
    "transform_points": "handeye_pick.cloud.transform",
}

__all__ = [  # the same names as _EXPORTS (tests/unit/test_light_imports.py checks)
    "Capture",
    "Cell",
    "CellHalted",
    "CellStatus",
    "Detection",
    "HandEyePickError",
    "InputError",
    "NoFeasibleCandidate",
    "PickResult",
    "PreflightRefusal",
    "RobotConnectionError",
    "RobotError",
    "RobotFault",
    "SafetyRefusal",
    "__version__",
    "detection_from_point_mm",
    "load_config",
    "load_detection",
    "transform_points",
]

if TYPE_CHECKING:  # what type checkers and IDEs see; at run time __getattr__ imports these
    from handeye_pick.cell.captures import Capture
    from handeye_pick.cell.pick import PickResult
    from handeye_pick.cell.plan import NoFeasibleCandidate
    from handeye_pick.cell.session import Cell
    from handeye_pick.cell.status import CellStatus
    from handeye_pick.cloud.transform import transform_points
    from handeye_pick.config.load import load_config
    from handeye_pick.detection import Detection, detection_from_point_mm, load_detection
    from handeye_pick.errors import (
        CellHalted,
        HandEyePickError,
        InputError,
        RobotConnectionError,
        RobotError,
        RobotFault,
        SafetyRefusal,
    )
    from handeye_pick.safety import PreflightRefusal


def __getattr__(name: str) -> Any:
    """Import a public name's module on first access (PEP 562)."""
    if name not in _EXPORTS:
        raise AttributeError(f"module 'handeye_pick' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    globals()[name] = value  # later accesses find it without calling __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
