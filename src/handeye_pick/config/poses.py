"""The TCP poses a cell config gives: named poses (``poses``), the grasp relative to the object
(``grasp``), the place poses (``place``) and the pose a capture starts from (``capture``).

Poses are UR pose vectors [x, y, z, rx, ry, rz] in metres and radians; approach and retreat
standoffs are millimetres along the tool z. Each is checked for a unit mix-up.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from handeye_pick.config.reader import Fields, Number, describe, part_size_mm
from handeye_pick.config.schema import (
    MAX_JOINT_RAD,
    MAX_OBJECT_OFFSET_M,
    MAX_REACH_M,
    MAX_STANDOFF_MM,
    MIN_STANDOFF_MM,
    CaptureConfig,
    GraspConfig,
    NamedPose,
    PlaceConfig,
)
from handeye_pick.errors import ConfigError, TransformError
from handeye_pick.geometry import Transform, checked_ur_pose

NAMED_POSE_KEYS = ("joints_rad", "tcp_pose")  # a named pose: one of the two

_STANDOFF = Number("mm", minimum=MIN_STANDOFF_MM, maximum=MAX_STANDOFF_MM)
_STANDOFFS = {"approach_mm": _STANDOFF, "retreat_mm": _STANDOFF}  # of the grasp and the place
_STRAIGHT = Number("mm", minimum=0.0, maximum=MAX_STANDOFF_MM)
_ALTERNATIVES = {
    "tilt_max_deg": Number("deg", minimum=0.0, maximum=45.0, default=GraspConfig.tilt_max_deg),
    # At least 5 deg: with the largest tilt, at most 72 turns x 10 tilts = 720 alternatives
    "symmetry_step_deg": Number(
        "deg", minimum=5.0, maximum=180.0, default=GraspConfig.symmetry_step_deg
    ),
}
_CAPTURE_NUMBERS = {
    "steady_timeout_s": Number(
        "s", above=0.0, maximum=30.0, default=CaptureConfig.steady_timeout_s
    ),
}


def pose_vector(fields: Fields, key: str, max_translation_m: float) -> Transform:
    """A UR pose vector [x, y, z, rx, ry, rz] in m and rad at ``key``, read with
    ``geometry.checked_ur_pose`` (no longer than ``max_translation_m``, no rotation vector in
    degrees); errors name the file and the key."""
    pose = fields.vector(key, 6)
    try:
        return checked_ur_pose(pose, max_m=max_translation_m)
    except TransformError as exc:
        fields.fail(key, str(exc))


def read_poses(top: Fields) -> tuple[NamedPose, ...]:
    """``poses``: a mapping of names to named poses, in file order."""
    data = top.raw("poses")
    if not isinstance(data, dict) or not data:
        top.fail("poses", f"expected a mapping of pose names, got {describe(data)}")
    poses = []
    for name in data:
        if not isinstance(name, str) or not name.strip():
            top.fail("poses", f"pose names must be non-empty strings, got {name!r}")
        pose = top.section("poses", data.keys()).section(name, NAMED_POSE_KEYS)
        poses.append(named_pose(pose, name))
    return tuple(poses)


def named_pose(pose: Fields, name: str) -> NamedPose:
    """One pose entry, opened with ``NAMED_POSE_KEYS``: exactly one of ``joints_rad`` (six
    joints, rad, moveJ) or ``tcp_pose`` (``T_base_tcp`` as a UR vector, m and rad, moveL), each
    checked for a unit mix-up. The calibration pose list (``pose_list``) reads its entries so."""
    if pose.has("joints_rad") == pose.has("tcp_pose"):
        pose.fail("", "give exactly one of joints_rad (6 joints, rad) or tcp_pose (m, rad)")
    if pose.has("joints_rad"):
        q = pose.vector("joints_rad", 6)
        if np.any(np.abs(q) > MAX_JOINT_RAD):
            pose.fail(
                "joints_rad",
                f"joint positions must lie within +-2*pi rad, got {q.tolist()} (degrees given?)",
            )
        return NamedPose(name, tuple(float(v) for v in q), None)
    return NamedPose(name, None, pose_vector(pose, "tcp_pose", MAX_REACH_M))


def read_grasp(top: Fields, default_straight_mm: float) -> GraspConfig:
    """``grasp``: the approach and retreat standoffs (mm), ``object_T_tcp`` (m, rad),
    ``straight_mm`` (mm; ``default_straight_mm`` when absent, set by the kind of gripper), and
    for a cell with a scene the grasp alternatives and the held part's size (docs/scene.md)."""
    grasp = top.section(
        "grasp", (*_STANDOFFS, "object_T_tcp", "straight_mm", "part_size_mm", *_ALTERNATIVES)
    )
    straight = {"straight_mm": replace(_STRAIGHT, default=default_straight_mm)}
    return GraspConfig(
        approach_mm=grasp.number("approach_mm", _STANDOFFS),
        retreat_mm=grasp.number("retreat_mm", _STANDOFFS),
        T_obj_tcp=(
            pose_vector(grasp, "object_T_tcp", MAX_OBJECT_OFFSET_M)
            if grasp.has("object_T_tcp")
            else np.eye(4)
        ),
        straight_mm=grasp.number("straight_mm", straight),
        tilt_max_deg=grasp.number("tilt_max_deg", _ALTERNATIVES),
        symmetry_step_deg=grasp.number("symmetry_step_deg", _ALTERNATIVES),
        part_size_mm=part_size_mm(grasp, "part_size_mm") if grasp.has("part_size_mm") else None,
    )


def read_place(top: Fields, poses: tuple[NamedPose, ...]) -> PlaceConfig:
    """``place``: a list of ``T_base_tcp`` poses (m, rad), the standoffs (mm) and ``via``, the
    names of TCP poses under ``poses`` a transfer passes through, in order."""
    place = top.section("place", ("poses", "via", *_STANDOFFS))
    listed = place.raw("poses")
    if not isinstance(listed, list) or not listed:
        place.fail("poses", f"expected a list of TCP poses (m, rad), got {describe(listed)}")
    indexed = Fields(
        {str(i): v for i, v in enumerate(listed)},
        source=place.source,
        prefix=place.path("poses"),
        allowed=[str(i) for i in range(len(listed))],
        error=ConfigError,
    )
    return PlaceConfig(
        T_base_tcp=tuple(pose_vector(indexed, str(i), MAX_REACH_M) for i in range(len(listed))),
        approach_mm=place.number("approach_mm", _STANDOFFS),
        retreat_mm=place.number("retreat_mm", _STANDOFFS),
        via=_via(place, poses) if place.has("via") else (),
    )


def _via(fields: Fields, poses: tuple[NamedPose, ...]) -> tuple[NamedPose, ...]:
    """``via``: a list of names of TCP poses (a moveL passes through them; a joint pose would
    make the transfer a moveJ, whose corners a TCP radius does not describe)."""
    names = fields.raw("via")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        fields.fail("via", f"expected a list of pose names, got {describe(names)}")
    by_name = {pose.name: pose for pose in poses}
    via = []
    for name in names:
        if name not in by_name:
            known = ", ".join(by_name) or "none"
            fields.fail("via", f"no pose named {name!r} under poses (defined: {known})")
        if by_name[name].T_base_tcp is None:
            fields.fail("via", f"pose {name!r} is a joint pose: a via pose must be a tcp_pose")
        via.append(by_name[name])
    return tuple(via)


def read_capture(
    top: Fields, poses: tuple[NamedPose, ...], steps: tuple[str, ...]
) -> CaptureConfig:
    """``capture``: the named pose a capture moves to first, how long it waits for rest, and
    ``view_clear_at``, one of ``steps`` (the moves of a pick and its place), and ``via``, the
    names of TCP poses the move to ``pose`` passes through."""
    capture = top.section("capture", ("pose", "view_clear_at", "via", *_CAPTURE_NUMBERS))
    name = capture.string("pose") if capture.has("pose") else None
    if name is not None and name not in {pose.name for pose in poses}:
        known = ", ".join(pose.name for pose in poses) or "none"
        capture.fail("pose", f"no pose named {name!r} under poses (defined: {known})")
    view_clear_at = (
        capture.string("view_clear_at", choices=steps) if capture.has("view_clear_at") else None
    )
    if capture.has("via") and name is None:
        capture.fail("via", "via poses lead to the capture pose: set capture.pose too")
    return CaptureConfig(
        pose=name,
        steady_timeout_s=capture.number("steady_timeout_s", _CAPTURE_NUMBERS),
        view_clear_at=view_clear_at,
        via=_via(capture, poses) if capture.has("via") else (),
    )
