"""The payload the arm carries: the empty tool, or the tool holding a part.

UR's ``set_payload`` takes the mass (kg) and the centre of gravity (m) in the tool flange frame
of everything mounted on the flange. The part's centre of gravity is configured in the TCP frame
at grasp, ``p_flange = T_flange_tcp @ p_tcp``; the combined centre of gravity is the
mass-weighted mean of the two.
"""

from __future__ import annotations

import numpy as np

from handeye_pick.config.schema import ObjectConfig, Payload
from handeye_pick.geometry import Transform, transform_point


def held_payload(tool: Payload, part: ObjectConfig, T_flange_tcp: Transform) -> Payload:
    """The tool with ``part`` in it, for ``set_payload`` (kg; CoG in m, flange frame)."""
    mass_kg = tool.mass_kg + part.mass_kg
    cog_part = transform_point(T_flange_tcp, np.array(part.cog_tcp_m))
    if mass_kg == 0.0:  # nothing weighs anything: UR takes a zero mass with any CoG
        return Payload(0.0, tool.cog_flange_m)
    cog = (tool.mass_kg * np.array(tool.cog_flange_m) + part.mass_kg * cog_part) / mass_kg
    return Payload(mass_kg, (float(cog[0]), float(cog[1]), float(cog[2])))
