"""The messages of each recorded channel, built from the cell's own objects (Foxglove schemas).

Frames: ``base`` (the robot base), ``flange``, ``tcp``, ``cam`` (eye-in-hand a child of
``flange``, eye-to-hand of ``base``), ``capture_flange`` and ``capture_cam`` (the flange and the
camera where the latest eye-in-hand image was taken). Scene entities of ``/cell/candidates``,
``/cell/plan`` (with the arm's link solids at each stop of the plan), ``/cell/reached`` and
``/cell/scene`` are in ``base``. Units: poses float64 4x4
in metres go out as metres and unit quaternions (x, y, z, w), as the viewers expect; a camera
cloud (mm) goes out in metres as float32 x, y, z. Stamps are nanoseconds since the Unix epoch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    FrameTransforms,
    LinePrimitive,
    LinePrimitiveLineType,
    PackedElementField,
    PackedElementFieldNumericType,
    Point3,
    PointCloud,
    Pose,
    Quaternion,
    SceneEntity,
    SceneEntityDeletion,
    SceneEntityDeletionType,
    SceneUpdate,
    SpherePrimitive,
    TextPrimitive,
    Timestamp,
    Vector3,
)
from numpy.typing import NDArray

from handeye_pick.arm.kinematics import link_poses
from handeye_pick.cell.plan import CandidateRefusal, PickPlan, step_error
from handeye_pick.config.schema import CellConfig
from handeye_pick.geometry import Transform, compose, make_transform, rotation_from_quaternion
from handeye_pick.scene.arm_legs import LegRefused, legs, start_joints
from handeye_pick.scene.layout import scene_boxes
from handeye_pick.steps import Move, Step

BASE, FLANGE, TCP, CAM = "base", "flange", "tcp", "cam"
CAPTURE_FLANGE, CAPTURE_CAM = "capture_flange", "capture_cam"
AXIS_LENGTH_M = 0.05
"""Length of the axes drawn at a target, a candidate or a reached pose."""
BLEND_POINTS = 8
"""Points drawn along each blended corner of a planned path."""

CHOSEN = Color(r=0.1, g=0.8, b=0.2, a=1.0)
REFUSED = Color(r=0.9, g=0.15, b=0.1, a=1.0)
UNTRIED = Color(r=0.6, g=0.6, b=0.6, a=1.0)
PATH = Color(r=0.2, g=0.5, b=1.0, a=1.0)
REACHED = Color(r=1.0, g=0.75, b=0.0, a=1.0)
WORKSPACE = Color(r=0.3, g=0.6, b=1.0, a=0.08)
OBSTACLE = Color(r=0.55, g=0.55, b=0.55, a=0.6)
ARM = Color(r=0.35, g=0.45, b=0.75, a=0.35)


def _turn(qx: float, qy: float, qz: float, qw: float) -> Transform:
    """A pure rotation (unit quaternion x, y, z, w) as a 4x4."""
    T = np.eye(4)
    T[:3, :3] = rotation_from_quaternion([qx, qy, qz, qw], "xyzw")
    return T


_HALF = math.sqrt(0.5)
_AXES = (  # an arrow points along its own x: turned onto each axis of the pose
    (Color(r=1.0, g=0.0, b=0.0, a=1.0), _turn(0.0, 0.0, 0.0, 1.0)),  # x
    (Color(r=0.0, g=1.0, b=0.0, a=1.0), _turn(0.0, 0.0, _HALF, _HALF)),  # y: +90 deg about z
    (Color(r=0.0, g=0.0, b=1.0, a=1.0), _turn(0.0, -_HALF, 0.0, _HALF)),  # z: -90 deg about y
)


def stamp(time_ns: int) -> Timestamp:
    return Timestamp(time_ns // 1_000_000_000, time_ns % 1_000_000_000)


def pose_of(T: Transform) -> Pose:
    """A 4x4 pose (m) as a Foxglove ``Pose``."""
    translation, rotation = _parts(T)
    return Pose(position=translation, orientation=rotation)


def _parts(T: Transform) -> tuple[Vector3, Quaternion]:
    """Translation and unit quaternion of a 4x4, in plain floats: a recording builds hundreds
    of these per cycle, and numpy's per-call cost on 3x3 arrays is what dominates."""
    (r00, r01, r02, px), (r10, r11, r12, py), (r20, r21, r22, pz) = T[:3].tolist()
    # Shepperd's method: divide by the largest of the four candidates (stable everywhere).
    trace = r00 + r11 + r22
    if trace >= max(r00, r11, r22):
        w = math.sqrt(max(0.0, 1.0 + trace)) / 2.0
        x, y, z = (r21 - r12) / (4 * w), (r02 - r20) / (4 * w), (r10 - r01) / (4 * w)
    elif r00 >= r11 and r00 >= r22:
        x = math.sqrt(max(0.0, 1.0 + r00 - r11 - r22)) / 2.0
        w, y, z = (r21 - r12) / (4 * x), (r01 + r10) / (4 * x), (r02 + r20) / (4 * x)
    elif r11 >= r22:
        y = math.sqrt(max(0.0, 1.0 - r00 + r11 - r22)) / 2.0
        w, x, z = (r02 - r20) / (4 * y), (r01 + r10) / (4 * y), (r12 + r21) / (4 * y)
    else:
        z = math.sqrt(max(0.0, 1.0 - r00 - r11 + r22)) / 2.0
        w, x, y = (r10 - r01) / (4 * z), (r02 + r20) / (4 * z), (r12 + r21) / (4 * z)
    return Vector3(x=px, y=py, z=pz), Quaternion(x=x, y=y, z=z, w=w)


def frame(parent: str, child: str, T_parent_child: Transform, time_ns: int) -> FrameTransform:
    """The pose of frame ``child`` in frame ``parent`` (m) at ``time_ns``."""
    translation, rotation = _parts(T_parent_child)
    return FrameTransform(
        timestamp=stamp(time_ns),
        parent_frame_id=parent,
        child_frame_id=child,
        translation=translation,
        rotation=rotation,
    )


def frames(transforms: Sequence[FrameTransform]) -> FrameTransforms:
    return FrameTransforms(transforms=list(transforms))


def axes(T_base: Transform, length_m: float = AXIS_LENGTH_M) -> list[ArrowPrimitive]:
    """Three arrows (x red, y green, z blue) of a pose in ``base``."""
    return [
        ArrowPrimitive(
            pose=pose_of(T_base @ turn),
            shaft_length=length_m * 0.8,
            shaft_diameter=length_m * 0.06,
            head_length=length_m * 0.2,
            head_diameter=length_m * 0.15,
            color=color,
        )
        for color, turn in _AXES
    ]


def label(T_base: Transform, text: str, color: Color) -> TextPrimitive:
    """A text beside a pose in ``base``."""
    lifted = T_base.copy()
    lifted[2, 3] += AXIS_LENGTH_M * 0.5
    return TextPrimitive(
        pose=pose_of(lifted),
        billboard=True,
        font_size=12.0,
        scale_invariant=True,
        color=color,
        text=text,
    )


def candidates_update(
    plans: Sequence[PickPlan],
    chosen: int | None,
    refused: Sequence[CandidateRefusal],
    time_ns: int,
) -> SceneUpdate:
    """Each planned candidate's object pose ``T_base_obj`` as axes with a label: the chosen one
    marked, the refused ones with their reasons; the entities of earlier picks are replaced."""
    reasons = {r.candidate: r.reasons for r in refused}
    entities = []
    for index, plan in enumerate(plans):
        if index == chosen:
            text, color = f"candidate {index}: chosen", CHOSEN
        elif index in reasons:
            text, color = f"candidate {index}: refused: " + "; ".join(reasons[index]), REFUSED
        else:
            text, color = f"candidate {index}", UNTRIED
        entities.append(
            SceneEntity(
                timestamp=stamp(time_ns),
                frame_id=BASE,
                id=f"candidate {index}",
                arrows=axes(plan.T_base_obj),
                texts=[label(plan.T_base_obj, text, color)],
            )
        )
    return SceneUpdate(deletions=[_delete_all(time_ns)], entities=entities)


def plan_update(
    steps: Sequence[Step],
    T_base_tcp_start: Transform | None,
    time_ns: int,
    arm: Sequence[SceneEntity] = (),
) -> SceneUpdate:
    """Every moveL target of a sequence as labelled axes, and the planned TCP path as a line
    from ``T_base_tcp_start`` (when known) through them, blended corners drawn round; ``arm``:
    the arm at its stops (``arm_entities``)."""
    moves = [step for step in steps if isinstance(step, Move)]
    entities = [
        SceneEntity(
            timestamp=stamp(time_ns),
            frame_id=BASE,
            id=f"target {index} {move.name}",
            arrows=axes(move.T_base_tcp),
            texts=[label(move.T_base_tcp, move.name, PATH)],
        )
        for index, move in enumerate(moves)
    ]
    points = path_points(moves, T_base_tcp_start)
    if len(points) >= 2:
        line = LinePrimitive(
            type=LinePrimitiveLineType.LineStrip,
            thickness=2.0,
            scale_invariant=True,
            points=[Point3(x=float(p[0]), y=float(p[1]), z=float(p[2])) for p in points],
            color=PATH,
        )
        entities.append(
            SceneEntity(timestamp=stamp(time_ns), frame_id=BASE, id="path", lines=[line])
        )
    return SceneUpdate(deletions=[_delete_all(time_ns)], entities=[*entities, *arm])


def arm_entities(
    config: CellConfig,
    steps: Sequence[Step],
    T_base_tcp_start: Transform,
    q_actual: Sequence[float],
    time_ns: int,
) -> list[SceneEntity]:
    """The arm's link solids (capsules as a cylinder and two spheres, cylinders) at the start
    and at the end of every move of ``steps``, at the joints the scene check follows from the
    controller's actual joints ``q_actual`` (rad); none without ``robot.model`` or where the
    arm cannot follow the sequence (the check refused it)."""
    model = config.robot.model
    if model is None:
        return []
    T_flange_tcp = config.robot.T_flange_tcp
    q_start = start_joints(model, T_flange_tcp, T_base_tcp_start, q_actual)
    try:
        driven = legs(model, T_flange_tcp, steps, T_base_tcp_start, q_start)
    except LegRefused:
        return []
    ends = {leg.move: leg.path.q[-1] for leg in driven}  # a move's last piece ends at its target
    stops = [("start", q_start), *ends.items()]
    poses = link_poses(model, np.array([q for _, q in stops]))
    entities = []
    for (name, _), at_stop in zip(stops, poses, strict=True):
        cylinders, spheres = [], []
        for link, T in zip(model.links, at_stop, strict=True):
            diameter = 2.0 * link.radius_m
            size = Vector3(x=diameter, y=diameter, z=link.length_m)
            cylinders.append(CylinderPrimitive(
                pose=pose_of(T), size=size, bottom_scale=1.0, top_scale=1.0, color=ARM
            ))
            if link.kind == "capsule":
                ball = Vector3(x=diameter, y=diameter, z=diameter)
                spheres += [
                    SpherePrimitive(
                        pose=pose_of(compose(T, make_transform(np.eye(3), [0, 0, end]))),
                        size=ball,
                        color=ARM,
                    )
                    for end in (-link.length_m / 2.0, link.length_m / 2.0)
                ]
        entities.append(SceneEntity(
            timestamp=stamp(time_ns), frame_id=BASE, id=f"arm at {name}",
            cylinders=cylinders, spheres=spheres,
        ))
    return entities


def path_points(
    moves: Sequence[Move], T_base_tcp_start: Transform | None
) -> list[NDArray[np.float64]]:
    """The TCP path (base frame, m): straight between targets; at a target with a blend
    radius r the corner is cut from r before it to r after it along a quadratic curve, the
    shape the controller's blend takes within the radius."""
    corners = [m.T_base_tcp[:3, 3] for m in moves]
    if T_base_tcp_start is not None:
        corners.insert(0, T_base_tcp_start[:3, 3])
    blends = ([0.0] if T_base_tcp_start is not None else []) + [m.blend_m for m in moves]
    points: list[NDArray[np.float64]] = []
    for i, corner in enumerate(corners):
        radius = blends[i]
        if radius <= 0.0 or i == 0 or i == len(corners) - 1:
            points.append(corner)
            continue
        before = _toward(corner, corners[i - 1], radius)
        after = _toward(corner, corners[i + 1], radius)
        for k in range(BLEND_POINTS + 1):
            s = k / BLEND_POINTS
            points.append((1 - s) ** 2 * before + 2 * (1 - s) * s * corner + s**2 * after)
    return points


def _toward(
    corner: NDArray[np.float64], other: NDArray[np.float64], radius: float
) -> NDArray[np.float64]:
    offset = other - corner
    length = float(np.linalg.norm(offset))
    return corner + offset * min(1.0, radius / length) if length > 0.0 else corner


def reached_update(
    name: str, T_target: Transform | None, T_reached: Transform, time_ns: int
) -> SceneUpdate:
    """The pose reached at a stop, as axes labelled with its error against the target (a moveJ
    has no TCP target: no error)."""
    text = f"reached {name}"
    if T_target is not None:
        error = step_error(T_target, T_reached)
        text += f": {error.position_mm:.2f} mm, {error.rotation_deg:.2f} deg"
    entity = SceneEntity(
        timestamp=stamp(time_ns),
        frame_id=BASE,
        id=f"reached {name}",
        arrows=axes(T_reached, AXIS_LENGTH_M * 0.6),
        texts=[label(T_reached, text, REACHED)],
    )
    return SceneUpdate(entities=[entity])


def scene_entities(config: CellConfig, time_ns: int) -> list[SceneEntity]:
    """What stands in the cell, in ``base``: the workspace box every target must lie in, and
    the scene's bins (floor and walls) and boxes, labelled as the collision check names them."""
    return _workspace_entities(config, time_ns) + _obstacle_entities(config, time_ns)


def _obstacle_entities(config: CellConfig, time_ns: int) -> list[SceneEntity]:
    if config.scene is None:
        return []
    return [
        SceneEntity(
            timestamp=stamp(time_ns),
            frame_id=BASE,
            id=name,
            cubes=[
                CubePrimitive(
                    pose=pose_of(T_base_box),
                    size=Vector3(x=float(size[0]), y=float(size[1]), z=float(size[2])),
                    color=OBSTACLE,
                )
            ],
            texts=[label(T_base_box, name, UNTRIED)],
        )
        for name, size, T_base_box in scene_boxes(config.scene)
    ]


def _workspace_entities(config: CellConfig, time_ns: int) -> list[SceneEntity]:
    box = config.workspace
    low = np.asarray(box.min_mm, dtype=np.float64) / 1000.0
    high = np.asarray(box.max_mm, dtype=np.float64) / 1000.0
    centre, size = (low + high) / 2.0, high - low
    T_centre = np.eye(4)
    T_centre[:3, 3] = centre
    cube = CubePrimitive(
        pose=pose_of(T_centre),
        size=Vector3(x=float(size[0]), y=float(size[1]), z=float(size[2])),
        color=WORKSPACE,
    )
    return [
        SceneEntity(
            timestamp=stamp(time_ns),
            frame_id=BASE,
            id="workspace",
            cubes=[cube],
            texts=[label(T_centre, "workspace", PATH)],
        )
    ]


def scene_update(config: CellConfig, time_ns: int) -> SceneUpdate:
    return SceneUpdate(entities=scene_entities(config, time_ns))


def cloud_message(points_mm: NDArray[np.floating], frame_id: str, time_ns: int) -> PointCloud:
    """N x 3 camera-frame points (mm) as a cloud in ``frame_id`` (float32 x, y, z in m)."""
    data = (np.asarray(points_mm, dtype=np.float32) / np.float32(1000.0)).astype("<f4")
    fields = [
        PackedElementField(name=axis, offset=4 * i, type=PackedElementFieldNumericType.Float32)
        for i, axis in enumerate("xyz")
    ]
    return PointCloud(
        timestamp=stamp(time_ns),
        frame_id=frame_id,
        pose=pose_of(np.eye(4)),
        point_stride=12,
        fields=fields,
        data=data.tobytes(),
    )


def _delete_all(time_ns: int) -> SceneEntityDeletion:
    return SceneEntityDeletion(timestamp=stamp(time_ns), type=SceneEntityDeletionType.All)
