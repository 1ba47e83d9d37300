"""``robot.model`` and ``robot.links`` (the arm's model: docs/arm-model.md) and ``scene.arm``
(whether the scene's check includes the arm's links).

``robot.links`` overrides link radii in millimetres, by link name with underscores
(``wrist_1``); inside the package the model is in metres (``handeye_pick.arm.models``).
"""

from __future__ import annotations

from handeye_pick.arm.models import LINK_NAMES, MODEL_NAMES, ArmModel, arm_model
from handeye_pick.config.reader import Fields, Number

ARM_CHOICES = ("checked", "unchecked")
_LINK_KEYS = {name.replace(" ", "_"): name for name in LINK_NAMES}
_RADIUS = {"radius_mm": Number("mm", minimum=10.0, maximum=300.0)}


def read_arm_model(robot: Fields) -> ArmModel | None:
    """``robot.model`` (one of ``MODEL_NAMES``) with the radii ``robot.links`` overrides; None
    without a model (``robot.links`` then refused: it would change nothing)."""
    if not robot.has("model"):
        if robot.has("links"):
            robot.fail("links", "link radii need robot.model (the arm they belong to)")
        return None
    name = robot.string("model", choices=MODEL_NAMES)
    radii_m: dict[str, float] = {}
    if robot.has("links"):
        links = robot.section("links", tuple(_LINK_KEYS))
        for key, link in _LINK_KEYS.items():
            if links.has(key):
                radius_mm = links.section(key, tuple(_RADIUS)).number("radius_mm", _RADIUS)
                radii_m[link] = radius_mm / 1000.0
    return arm_model(name, radii_m)


def read_arm_checked(scene: Fields) -> bool:
    """``scene.arm``: ``checked`` (the default) or ``unchecked`` (the tool alone is checked)."""
    if not scene.has("arm"):
        return True
    return scene.string("arm", choices=ARM_CHOICES) == "checked"
