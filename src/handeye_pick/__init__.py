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

# Public name -> the module that defines it. A new export (e.g. "Cell": "handeye_pick.cell") is a
# line here, its name in __all__ and its import under TYPE_CHECKING.
_EXPORTS = {
    "transform_points": "handeye_pick.cloud",
}

__all__ = ["__version__", "transform_points"]

if TYPE_CHECKING:  # what type checkers and IDEs see; at run time __getattr__ imports these
    from handeye_pick.cloud import transform_points


def __getattr__(name: str) -> Any:
    """Import a public name's module on first access (PEP 562)."""
    if name not in _EXPORTS:
        raise AttributeError(f"module 'handeye_pick' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    globals()[name] = value  # later accesses find it without calling __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
