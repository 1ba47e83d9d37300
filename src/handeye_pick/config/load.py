"""``load_config``: one cell config file, read with PyYAML's safe loader, into a frozen
``CellConfig``.

Every key is checked where it is read: an unknown key, a wrong type or a value out of range is a
``ConfigError`` naming the file and the key path (``motion.speed_mps``). Units are in the key
names (``_mm``, ``_mps``, ``_deg``, ``_s``); inside the package everything is metres and radians.
``config/cell.example.yaml`` documents every key.
"""

from __future__ import annotations

from pathlib import Path

from handeye_pick.arm.models import MODEL_NAMES
from handeye_pick.config.gripper import Robotiq2FConfig
from handeye_pick.config.hand_eye import read_hand_eye
from handeye_pick.config.line import LineConfig, read_line
from handeye_pick.config.motion import read_motion, read_workspace
from handeye_pick.config.payload import read_object
from handeye_pick.config.poses import read_capture, read_grasp, read_place, read_poses
from handeye_pick.config.reader import Fields, read_yaml_mapping
from handeye_pick.config.robot import read_robot
from handeye_pick.config.scene import read_scene, read_tool_shape
from handeye_pick.config.schema import (
    PICK_MOVES,
    STRAIGHT_MM_DEFAULT,
    STRAIGHT_MM_FINGERS,
    AuditConfig,
    CaptureConfig,
    CellConfig,
    PlaceConfig,
    RobotConfig,
)
from handeye_pick.errors import ConfigError
from handeye_pick.hand_eye.files import HandEyeMode

_SECTIONS = (
    "robot",
    "hand_eye",
    "grasp",
    "motion",
    "workspace",
    "audit",
    "poses",
    "place",
    "capture",
    "object",
    "scene",
    "tool",
    "line",
)


def load_config(path: Path) -> CellConfig:
    """Read and validate a cell config; file paths in it are resolved relative to its folder."""
    path = Path(path).resolve()
    top = Fields(
        read_yaml_mapping(path, ConfigError, "cell config"),
        source=str(path),
        prefix="",
        allowed=_SECTIONS,
        error=ConfigError,
    )
    poses = read_poses(top) if top.has("poses") else ()
    robot = read_robot(top)
    hand_eye = read_hand_eye(top, path.parent)
    place = read_place(top, poses) if top.has("place") else None
    capture = (
        read_capture(top, poses, _move_names(place)) if top.has("capture") else CaptureConfig()
    )
    if capture.view_clear_at is not None and hand_eye.mode is not HandEyeMode.EYE_TO_HAND:
        top.fail(
            "capture",
            "view_clear_at is for a fixed camera (eye-to-hand): a camera on the flange rides "
            "with the arm and is never in its own way",
        )
    part = read_object(top) if top.has("object") else None
    if part is not None and robot.tool_payload is None:
        top.fail(
            "object",
            "a part's payload needs the empty tool's too: set robot.tool_payload "
            "{mass_kg, cog_mm} (as on the pendant's payload screen), restored after each release",
        )
    scene = read_scene(top) if top.has("scene") else None
    tool_shape = read_tool_shape(top) if top.has("tool") else ()
    if (scene is None) != (not tool_shape):
        top.fail(
            "scene" if scene is None else "tool",
            "the collision check needs both scene (what to keep clear of) and tool.shape "
            "(what moves): give both, or neither",
        )
    if scene is not None and scene.arm_checked and robot.model is None:
        top.fail(
            "robot.model",
            "missing: a scene checks the arm's links as well as the tool; add robot.model (the "
            f"arm on the controller: {', '.join(MODEL_NAMES)}), or scene.arm: unchecked to check "
            "the tool alone",
        )
    return CellConfig(
        robot=robot,
        hand_eye=hand_eye,
        grasp=read_grasp(top, _default_straight_mm(robot)),
        motion=read_motion(top),
        workspace=read_workspace(top),
        audit=_audit(top, path.parent),
        path=path,
        poses=poses,
        place=place,
        capture=capture,
        object=part,
        scene=scene,
        tool_shape=tool_shape,
        line=read_line(top, robot.gripper) if top.has("line") else LineConfig(),
    )


def _move_names(place: PlaceConfig | None) -> tuple[str, ...]:
    """The moves of a pick and, with a place, of its place."""
    return PICK_MOVES if place is None else (*PICK_MOVES, *place.move_names())


def _default_straight_mm(robot: RobotConfig) -> float:
    """How much of a descent stays straight when nothing says: more for fingers than a cup."""
    if isinstance(robot.gripper, Robotiq2FConfig):
        return STRAIGHT_MM_FINGERS
    return STRAIGHT_MM_DEFAULT


def _audit(top: Fields, folder: Path) -> AuditConfig:
    """``audit``: the one key, a file resolved relative to ``folder`` in an existing folder."""
    audit = top.section("audit", ("file",))
    path = (folder / audit.string("file")).resolve()
    if not path.parent.is_dir():
        audit.fail("file", f"folder does not exist: {path.parent}")
    return AuditConfig(file=path)
