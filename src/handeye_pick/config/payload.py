"""The payloads the cell config gives: the empty tool's (``robot.tool_payload``, restored after
each release) and the picked part's (``object``, added while it is held).

Both are a mass in kg and a centre of gravity given in mm and kept in metres: in the flange frame
for the tool, in the TCP frame at grasp for the part.
"""

from __future__ import annotations

import numpy as np

from handeye_pick.config.reader import Fields, Number
from handeye_pick.config.schema import MAX_COG_MM, MAX_PAYLOAD_KG, ObjectConfig, Payload

_KEYS = ("mass_kg", "cog_mm")
_NUMBERS = {"mass_kg": Number("kg", minimum=0.0, maximum=MAX_PAYLOAD_KG)}


def read_tool_payload(robot: Fields) -> Payload:
    """``robot.tool_payload``: the empty tool, centre of gravity in the flange frame."""
    mass_kg, cog_m = _mass_and_cog(robot.section("tool_payload", _KEYS))
    return Payload(mass_kg, cog_m)


def read_object(top: Fields) -> ObjectConfig:
    """``object``: the part alone, centre of gravity in the TCP frame at grasp."""
    mass_kg, cog_m = _mass_and_cog(top.section("object", _KEYS))
    return ObjectConfig(mass_kg, cog_m)


def _mass_and_cog(fields: Fields) -> tuple[float, tuple[float, float, float]]:
    """``mass_kg`` and ``cog_mm`` (converted to m), checked for unit mix-ups."""
    mass_kg = fields.number("mass_kg", _NUMBERS)
    cog_m = fields.vector("cog_mm", 3) / 1000.0
    if float(np.linalg.norm(cog_m)) * 1000.0 > MAX_COG_MM:
        fields.fail("cog_mm", f"more than {MAX_COG_MM:g} mm from the origin (metres typed?)")
    return mass_kg, (float(cog_m[0]), float(cog_m[1]), float(cog_m[2]))
