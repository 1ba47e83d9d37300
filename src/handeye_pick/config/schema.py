"""The cell configuration as the package uses it: frozen dataclasses, one per section of the cell
config file, and the plausibility bounds the parsers check them against.

Units are in the field names (``_mm``, ``_mps``, ``_deg``, ``_s``); a ``Transform`` is a 4x4
in metres named by its frames (``T_flange_tcp``). ``config/load.py`` builds a ``CellConfig``
from a file; ``config/cell.example.yaml`` documents every key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from handeye_pick.arm.models import ArmModel
from handeye_pick.config.gripper import AnyGripperConfig
from handeye_pick.config.line import LineConfig
from handeye_pick.errors import ConfigError
from handeye_pick.geometry import LengthUnit, Transform
from handeye_pick.hand_eye.files import HandEyeMode
from handeye_pick.hand_eye.plausibility import MeasuredCamera

# Plausibility bounds that catch a value typed in the wrong unit. Each is far outside what a
# real cell uses, so it only fires on a mistake.
MAX_TCP_OFFSET_M = 1.0  # a TCP offset in mm (150) typed into this m key would be 150 m
MAX_OBJECT_OFFSET_M = 0.5  # same check for grasp.object_T_tcp
MIN_STANDOFF_MM = 5.0  # approach/retreat below 5 mm: metres typed into a mm key (0.1 -> 0.1 mm)
MAX_STANDOFF_MM = 500.0  # longer approach or retreat paths are not a pick any more
# The moves of a pick and of its place, by the names the audit, the events and the config use.
PICK_MOVES = ("approach", "grasp", "retreat")
PLACE_MOVES = ("place-approach", "place", "place-retreat")
MAX_BLEND_MM = 300.0  # a corner rounded wider than 30 cm is no longer the path that was taught
# The end of a descent (the start of an ascent) that stays straight along the tool axis when
# corners are blended: a suction cup's lip and compression with room to spare, and a two-finger
# gripper's open fingers (a Robotiq 2F-85's are about 40 mm deep) around the part.
STRAIGHT_MM_DEFAULT = 20.0
STRAIGHT_MM_FINGERS = 40.0
MAX_WORKSPACE_MM = 3000.0  # no UR arm reaches farther than 1.75 m from its base
MAX_REACH_M = MAX_WORKSPACE_MM / 1000.0  # a named or place TCP pose farther out is in mm
MAX_JOINT_RAD = 2.0 * math.pi  # UR joint range is +-2*pi: a larger value is in degrees
MIN_WORKSPACE_EXTENT_MM = 10.0  # a box thinner than 1 cm is a box written in metres
MAX_PAYLOAD_KG = 35.0  # the largest UR arm (UR30) carries 30 kg: more is grams typed as kg
MAX_COG_MM = 1000.0  # no tool's centre of gravity lies a metre from its flange


@dataclass(frozen=True)
class Payload:
    """A payload as UR's ``set_payload`` takes it: mass (kg) and centre of gravity (m) in the
    tool flange frame."""

    mass_kg: float  # tool (and part) mass (kg)
    cog_flange_m: tuple[float, float, float]  # centre of gravity, flange frame (m)


@dataclass(frozen=True)
class ObjectConfig:
    """The picked part: its mass (kg) and centre of gravity in the TCP frame at grasp (m)."""

    mass_kg: float  # the part alone (kg)
    cog_tcp_m: tuple[float, float, float]  # its centre of gravity, TCP frame at grasp (m)


@dataclass(frozen=True)
class RobotConfig:
    """The arm and what the pendant must be set to."""

    host: str  # controller IP address or host name
    T_flange_tcp: Transform  # expected active TCP offset on the controller (m), checked at connect
    tcp_offset_tolerance_mm: float = 1.0  # accepted translation difference, controller vs config
    tcp_offset_tolerance_deg: float = 1.0  # accepted rotation difference, controller vs config
    gripper: AnyGripperConfig | None = None  # None: the pick moves only, no gripper is used
    watchdog_s: float = 0.2  # the controller stops the program this long after the PC goes silent
    tool_payload: Payload | None = None  # the empty tool's payload, restored after a release
    # robot.model (docs/arm-model.md): the arm's kinematics and link solids, checked against the
    # controller at connect; None: not given (then a scene must say scene.arm: unchecked)
    model: ArmModel | None = None


@dataclass(frozen=True)
class HandEyeConfig:
    """Where the hand-eye calibration result is and how to read it."""

    mode: HandEyeMode  # eye-in-hand: file holds T_flange_cam; eye-to-hand: T_base_cam
    file: Path  # absolute, resolved relative to the config file
    units: LengthUnit  # length unit of the file's translation ("mm" for Zivid)
    invert: bool = False  # the file was written the other way round (T_cam_flange / T_cam_base)
    acknowledge: tuple[str, ...] = ()  # plausibility checks this cell's unusual mount fails
    # camera_position_mm (base frame for eye-to-hand, flange frame for eye-in-hand) and its
    # tolerance: tells a file from its inverse; None when not measured
    camera_position: MeasuredCamera | None = None


@dataclass(frozen=True)
class GraspConfig:
    """Where the TCP goes relative to the detected object."""

    approach_mm: float  # approach point: grasp moved back along the grasp's tool z (mm)
    retreat_mm: float  # retreat point: grasp moved back along the grasp's tool z (mm)
    T_obj_tcp: Transform = field(default_factory=lambda: np.eye(4))  # TCP at grasp in object frame
    # The last part of every descent and the first of every ascent that no blend cuts into (mm)
    straight_mm: float = STRAIGHT_MM_DEFAULT
    # Grasp alternatives (docs/scene.md): the largest tilt of the approach towards the bin's
    # centre (deg, 0: none), the yaw step of a part symmetric about an axis by any angle (deg)
    tilt_max_deg: float = 0.0
    symmetry_step_deg: float = 15.0
    # The held part's box (mm, in the object frame) when a detection gives no size_mm
    part_size_mm: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class MotionConfig:
    """moveL parameters of the TCP."""

    speed_mps: float  # approach and retreat moves (m/s)
    accel_mps2: float  # every move (m/s^2)
    grasp_speed_mps: float  # the final move from approach to grasp (m/s)
    stop_decel_mps2: float = 10.0  # stopL deceleration on a fault or Ctrl-C (m/s^2)
    timeout_margin_s: float = 5.0  # added to a move's expected duration before it counts as hung
    joint_speed_rps: float = 0.5  # moveJ to a named joint pose: fastest joint (rad/s)
    joint_accel_rps2: float = 1.0  # moveJ to a named joint pose (rad/s^2)
    # The largest radius a corner between two moveL targets is rounded with (mm); 0: the arm
    # stops at every target, as single moveL commands do
    blend_mm: float = 0.0
    # True: every stretch of corners is sent as one path, even where a path's start costs more
    # than its corners save (docs/motion.md, "Blend only where it pays"; a comparison's setting)
    blend_always: bool = False


@dataclass(frozen=True)
class WorkspaceConfig:
    """A box in the robot base frame that every TCP target must lie in, and a tilt limit."""

    min_mm: tuple[float, float, float]  # lower corner, base frame (mm)
    max_mm: tuple[float, float, float]  # upper corner, base frame (mm)
    max_tilt_deg: float  # largest angle between tool z and straight down (base -z), degrees


@dataclass(frozen=True)
class AuditConfig:
    """Where pick records are appended."""

    file: Path  # JSON lines, absolute, resolved relative to the config file


@dataclass(frozen=True)
class NamedPose:
    """A pose the cell moves to by name (``capture``, ``home``, ``clear``): exactly one of a
    joint target (moveJ, rad) or a TCP target in the base frame (moveL, m)."""

    name: str  # the key under poses ("home"), or "pose 3" in a calibration pose list
    q_rad: tuple[float, ...] | None  # six joint positions (rad), or None
    T_base_tcp: Transform | None  # TCP pose in base (m), or None


def via_move(pose_name: str) -> str:
    """The name of the move through the via pose ``pose_name`` (``place.via``)."""
    return f"via {pose_name}"


@dataclass(frozen=True)
class PlaceConfig:
    """Where a picked part is put down: TCP poses in the base frame used in turn (a pallet)."""

    T_base_tcp: tuple[Transform, ...]  # place poses (m), the n-th place uses n % len
    approach_mm: float  # approach point: place pose moved back along its tool z (mm)
    retreat_mm: float  # retreat point after the release, the same way back (mm)
    via: tuple[NamedPose, ...] = ()  # TCP poses a transfer passes through on its way to a place

    def move_names(self) -> tuple[str, ...]:
        """The moves of a place, in order: through the via poses, then ``PLACE_MOVES``."""
        return (*(via_move(pose.name) for pose in self.via), *PLACE_MOVES)


@dataclass(frozen=True)
class CaptureConfig:
    """How a capture latches the flange pose."""

    pose: str | None = None  # named pose a capture moves to first (eye-to-hand: out of view)
    steady_timeout_s: float = 2.0  # longest wait for the arm to come to rest before latching (s)
    # eye-to-hand: the step (retreat, a "via NAME" pose, ...) past which the arm is out of the
    # camera's view; run then tells the vision client (a view-clear event)
    view_clear_at: str | None = None
    # TCP poses the move to ``pose`` passes through, blended, on its way from the last place
    via: tuple[NamedPose, ...] = ()


@dataclass(frozen=True)
class SceneBox:
    """A box obstacle: edge lengths ``size_mm`` along its own axes, its centre at ``T_base_box``
    (m). A bin's floor and walls are such boxes, named after the bin."""

    name: str  # as refusals name it: "box 'column'", "bin 'parts' wall 'east'"
    size_mm: tuple[float, float, float]
    T_base_box: Transform  # the box's centre and axes in the base frame (m)


@dataclass(frozen=True)
class BinConfig:
    """A bin: its inner floor's centre and axes ``T_base_bin`` (m; z up out of the bin), the
    inner size and the thickness of its walls and floor (mm)."""

    name: str
    T_base_bin: Transform  # centre of the inner floor, x and y along the walls, z up (m)
    inner_mm: tuple[float, float, float]  # inner length (x), width (y) and wall height (z)
    wall_mm: float
    floor_mm: float


@dataclass(frozen=True)
class SceneConfig:
    """What the tool must keep clear of: bins, box obstacles (fixtures, columns, a conveyor)
    and the floor or table plane, and the distance kept from all of them (mm)."""

    bins: tuple[BinConfig, ...] = ()
    boxes: tuple[SceneBox, ...] = ()
    floor_z_mm: float | None = None  # the table or floor plane in the base frame; None: none
    clearance_mm: float = 5.0
    arm_checked: bool = True  # False: scene.arm: unchecked, the tool alone is checked


@dataclass(frozen=True)
class ToolShape:
    """One solid of the tool in the flange frame: a box (``size_mm``) or a cylinder
    (``radius_mm``, ``length_mm`` along its own z), centred at ``T_flange_shape`` (m)."""

    name: str  # as refusals name it: "tool 'fingers'"
    T_flange_shape: Transform  # the solid's centre and axes in the flange frame (m)
    size_mm: tuple[float, float, float] | None = None  # a box's edge lengths
    radius_mm: float | None = None  # a cylinder's radius ...
    length_mm: float | None = None  # ... and length along its z


@dataclass(frozen=True)
class CellConfig:
    """The whole cell configuration, as loaded from ``path``."""

    robot: RobotConfig
    hand_eye: HandEyeConfig
    grasp: GraspConfig
    motion: MotionConfig
    workspace: WorkspaceConfig
    audit: AuditConfig
    path: Path  # the config file itself (absolute)
    poses: tuple[NamedPose, ...] = ()  # named poses, in file order
    place: PlaceConfig | None = None  # None: a pick ends holding the part ("picked")
    capture: CaptureConfig = field(default_factory=CaptureConfig)
    object: ObjectConfig | None = None  # None: the payload is never changed
    scene: SceneConfig | None = None  # None (and no tool shape): no collision check
    tool_shape: tuple[ToolShape, ...] = ()  # the tool's solids in the flange frame
    line: LineConfig = field(default_factory=LineConfig)  # the wired handshake (docs/line.md)

    def pose(self, name: str) -> NamedPose:
        """The named pose ``name``; ConfigError naming the known ones when it is not defined."""
        for pose in self.poses:
            if pose.name == name:
                return pose
        known = ", ".join(p.name for p in self.poses) or "none"
        raise ConfigError(f"{self.path}: poses: no pose named {name!r} (defined: {known})")
