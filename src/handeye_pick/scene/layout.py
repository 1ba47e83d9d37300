"""The boxes a scene is made of, without python-fcl (the plot draws them too): each bin as its
floor and four walls, and the box obstacles.

A bin's frame has its origin at the centre of the inner floor and z up out of the bin; its
walls are named by the side they stand on: east +x, west -x, north +y, south -y of the bin's
frame. Sizes and poses in metres in the base frame.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from handeye_pick.config.schema import BinConfig, SceneConfig
from handeye_pick.geometry import Transform, compose, make_transform

Box = tuple[str, NDArray[np.float64], Transform]
"""A box as (label, edge lengths m, ``T_base_box``: its centre and axes in base)."""


def bin_boxes(bin_: BinConfig) -> list[tuple[str, NDArray[np.float64], Transform]]:
    """A bin's floor and four walls as (name, size m, ``T_base_box``): the floor reaches under
    the walls, the east and west walls span the whole outer width, north and south fit between
    them, so the corners are closed."""
    x, y, z = (v / 1000.0 for v in bin_.inner_mm)
    wall, floor = bin_.wall_mm / 1000.0, bin_.floor_mm / 1000.0
    outer_y = y + 2.0 * wall
    parts = {
        "floor": ((x + 2.0 * wall, outer_y, floor), (0.0, 0.0, -floor / 2.0)),
        "east": ((wall, outer_y, z), ((x + wall) / 2.0, 0.0, z / 2.0)),
        "west": ((wall, outer_y, z), (-(x + wall) / 2.0, 0.0, z / 2.0)),
        "north": ((x, wall, z), (0.0, (y + wall) / 2.0, z / 2.0)),
        "south": ((x, wall, z), (0.0, -(y + wall) / 2.0, z / 2.0)),
    }
    return [
        (name, np.array(size), compose(bin_.T_base_bin, make_transform(np.eye(3), centre)))
        for name, (size, centre) in parts.items()
    ]


def scene_boxes(scene: SceneConfig) -> list[Box]:
    """Every box of ``scene`` with the label refusals give it: ``bin 'parts' floor``,
    ``bin 'parts' wall 'east'``, ``box 'column'``."""
    out: list[Box] = []
    for bin_ in scene.bins:
        for name, size_m, T_base_box in bin_boxes(bin_):
            where = "floor" if name == "floor" else f"wall '{name}'"
            out.append((f"bin '{bin_.name}' {where}", size_m, T_base_box))
    for box in scene.boxes:
        out.append((f"box '{box.name}'", np.array(box.size_mm) / 1000.0, box.T_base_box))
    return out


def arm_not_checked(scene: SceneConfig) -> str | None:
    """Why the arm's links are not checked (None: they are), as the checks of a plan, its
    record, ``plan`` and ``status`` say it."""
    if scene.arm_checked:
        return None
    return "the arm is not checked (scene.arm: unchecked): only the tool and the held part are"


def describe_scene(scene: SceneConfig, tool_solids: int) -> str:
    """One line for ``status``: the bins, the boxes, the floor, the clearance, the tool, and
    whether the arm's links are checked (``scene.arm``)."""
    parts = [
        f"bin '{b.name}' ({' x '.join(f'{v:g}' for v in b.inner_mm)} mm inside)"
        for b in scene.bins
    ]
    parts += [f"box '{b.name}'" for b in scene.boxes]
    if scene.floor_z_mm is not None:
        parts.append(f"floor at z {scene.floor_z_mm:g} mm")
    arm = arm_not_checked(scene) or "the arm's links checked too"
    return (
        f"{', '.join(parts)}; clearance {scene.clearance_mm:g} mm; tool of {tool_solids} "
        f"solids; {arm}"
    )
