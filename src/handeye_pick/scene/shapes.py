"""The solids of a cell as python-fcl objects: the obstacles of ``scene`` (``layout``'s boxes
and the floor) and the tool's solids of ``tool.shape``, and the held part.

Frames and units: obstacle poses ``T_base_*`` and tool solid poses ``T_tcp_*`` are float64 4x4
in metres; config sizes are millimetres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import fcl
import numpy as np
from numpy.typing import NDArray

from handeye_pick.config.schema import SceneConfig, ToolShape
from handeye_pick.geometry import Transform, compose, invert, make_transform
from handeye_pick.scene.layout import scene_boxes

FLOOR_HALF_SIZE_M = 10.0  # the floor plane as a box 20 m wide: wider than any cell
FLOOR_THICKNESS_M = 1.0


@dataclass(frozen=True)
class Obstacle:
    """One fixed box of the scene: what refusals call it, its size (m) and pose in base (m)."""

    label: str  # "bin 'parts' wall 'east'", "box 'column'", "the floor"
    size_m: NDArray[np.float64]  # edge lengths along its own axes
    T_base_box: Transform  # centre and axes in the base frame
    geometry: fcl.CollisionObject


@dataclass(frozen=True)
class Solid:
    """One moving solid: a tool solid or the held part, fixed in the TCP frame."""

    label: str  # "tool 'fingers'", "the held part"
    T_tcp_solid: Transform  # centre and axes in the TCP frame (m)
    reach_m: float  # farthest point of the solid from the TCP (m): bounds its speed in a turn
    radius_m: float  # farthest point of the solid from its own centre (m)
    geometry: fcl.CollisionObject
    part: bool = False  # the held part (it may touch what it rests on, docs/scene.md)


def _box_obstacle(label: str, size_m: NDArray[np.float64], T_base_box: Transform) -> Obstacle:
    box = fcl.Box(*size_m.tolist())
    transform = fcl.Transform(T_base_box[:3, :3], T_base_box[:3, 3])
    return Obstacle(label, size_m, T_base_box, fcl.CollisionObject(box, transform))


def obstacles(scene: SceneConfig) -> list[Obstacle]:
    """Every obstacle of ``scene``: its boxes (``layout.scene_boxes``) and the floor plane."""
    out = [_box_obstacle(label, size, T) for label, size, T in scene_boxes(scene)]
    if scene.floor_z_mm is not None:
        size = np.array([2.0 * FLOOR_HALF_SIZE_M, 2.0 * FLOOR_HALF_SIZE_M, FLOOR_THICKNESS_M])
        centre = np.array([0.0, 0.0, scene.floor_z_mm / 1000.0 - FLOOR_THICKNESS_M / 2.0])
        out.append(_box_obstacle("the floor", size, make_transform(np.eye(3), centre)))
    return out


def _solid(
    label: str,
    geometry: fcl.CollisionGeometry,
    radius_m: float,
    T_tcp_solid: Transform,
    part: bool = False,
) -> Solid:
    reach = float(np.linalg.norm(T_tcp_solid[:3, 3])) + radius_m
    return Solid(label, T_tcp_solid, reach, radius_m, fcl.CollisionObject(geometry), part)


def tool_solids(shape: tuple[ToolShape, ...], T_flange_tcp: Transform) -> list[Solid]:
    """The tool's solids in the TCP frame of the active TCP offset ``T_flange_tcp`` (m)."""
    T_tcp_flange = invert(T_flange_tcp)
    solids = []
    for solid in shape:
        T_tcp_solid = compose(T_tcp_flange, solid.T_flange_shape)
        if solid.size_mm is not None:
            size = np.array(solid.size_mm) / 1000.0
            geometry: fcl.CollisionGeometry = fcl.Box(*size.tolist())
            radius = float(np.linalg.norm(size)) / 2.0
        else:  # the config loader gives a cylinder both numbers
            r, length = (solid.radius_mm or 0.0) / 1000.0, (solid.length_mm or 0.0) / 1000.0
            geometry = fcl.Cylinder(r, length)
            radius = math.hypot(r, length / 2.0)
        solids.append(_solid(f"tool '{solid.name}'", geometry, radius, T_tcp_solid))
    return solids


def part_solid(size_mm: tuple[float, float, float], T_tcp_obj: Transform) -> Solid:
    """The held part: a box of ``size_mm`` in the object frame (x, y centred, 0 to z along +z),
    with the object at ``T_tcp_obj`` in the TCP frame at grasp (m)."""
    size = np.array(size_mm) / 1000.0
    T_tcp_solid = compose(T_tcp_obj, make_transform(np.eye(3), [0.0, 0.0, size[2] / 2.0]))
    radius = float(np.linalg.norm(size)) / 2.0
    return _solid("the held part", fcl.Box(*size.tolist()), radius, T_tcp_solid, part=True)
