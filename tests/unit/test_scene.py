"""The scene and the tool's shape: the swept collision check of a pick and its place, the grasp
alternatives (symmetry, tilt), the reasons, and the config that sets them up.

The cell: a camera fixed 1 m above the base plane looking straight down (eye-to-hand), a bin
'parts' (inner 300 x 200 x 150 mm, 10 mm walls, its inner floor 50 mm above the base plane)
under it, a gripper with a narrow body, two fingers open 80 mm wide along the tool's x and a
wrist camera on the tool's +x side. Parts are 50 mm cubes, grasped at mid-height. Candidates are
chosen by ``plan.choose`` against a ``ScriptedArm`` (every target reachable).
"""

from __future__ import annotations

import json
import math
import re
import uuid
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from handeye_pick.cell.plan import Chosen, NoFeasibleCandidate, choose, pick_steps
from handeye_pick.cell.session import Cell
from handeye_pick.cli import main
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import CellConfig, SceneBox, SceneConfig, ToolShape
from handeye_pick.detection import Detection, Symmetry
from handeye_pick.errors import ConfigError
from handeye_pick.geometry import invert, make_transform, rotation_from_euler
from handeye_pick.hand_eye.files import load_hand_eye
from handeye_pick.runner import pick_reply
from handeye_pick.safety import PreflightRefusal
from handeye_pick.scene.check import SceneCheck
from handeye_pick.scene.collide import PROOF_TOLERANCE_M, Group
from handeye_pick.scene.layout import bin_boxes, describe_scene
from handeye_pick.scene.path import pieces
from handeye_pick.steps import Move
from tests.audit_schema import record_problems
from tests.unit.test_cell_session import ScriptedArm

T_BASE_CAM = np.array(
    [[1.0, 0, 0, -0.4], [0, -1.0, 0, 0], [0, 0, -1.0, 1.0], [0, 0, 0, 1.0]]
)  # 1 m above the base plane, looking down
BIN_X, BIN_Y, BIN_FLOOR_Z = -0.4, 0.0, 0.05  # the bin's inner floor centre (m)
HALF_X, HALF_Y = 0.150, 0.100  # the bin's inner half sizes (m)
PART = 0.050  # the parts' edge (m)
T_FLANGE_TCP = make_transform(np.eye(3), [0.0, 0.0, 0.15])
DOWN = np.diag([1.0, -1.0, -1.0])  # tool z down, tool x along base x
T_BASE_FLANGE = make_transform(DOWN, [-0.4, 0.0, 0.6])  # above the bin, tool down

TOOL = """
tool:
  shape:
    - name: body
      box: {size_mm: [BODY, BODY, 80], pose: [0, 0, 0.055, 0, 0, 0]}
    - name: finger +x
      box: {size_mm: [10, 20, 45], pose: [0.040, 0, 0.1275, 0, 0, 0]}
    - name: finger -x
      box: {size_mm: [10, 20, 45], pose: [-0.040, 0, 0.1275, 0, 0, 0]}
"""
CAMERA = """
    - name: camera
      cylinder: {radius_mm: 20, length_mm: 60, pose: [0.070, 0, 0.030, 0, 0, 0]}
"""
SCENE = """
scene:
  arm: unchecked
  clearance_mm: 5
  floor_z_mm: 0
  bins:
    - {name: parts, pose: [-0.4, 0, 0.05, 0, 0, 0], inner_mm: [300, 200, 150], wall_mm: 10,
       floor_mm: 10}
"""
FIXTURES = """
  boxes:
    - {name: fixture, pose: [-0.03, 0.40, 0.0075, 0, 0, 0], size_mm: [60, 200, 15]}
    - {name: column, pose: [-0.40, 0.22, 0.40, 0, 0, 0], size_mm: [60, 60, 800]}
"""
PLACE = """
place:
  poses:
    - [0.0, 0.40, 0.025, 3.14159265, 0, 0]
  approach_mm: 100
  retreat_mm: 100
"""


def _config(
    tmp_path: Path,
    scene: str = SCENE,
    tool: str = TOOL,
    body_mm: int = 50,
    grasp: str = "",
    extra: str = "",
) -> CellConfig:
    (tmp_path / "eth.yaml").write_text(
        "[[1, 0, 0, -400], [0, -1, 0, 0], [0, 0, -1, 1000], [0, 0, 0, 1]]\n"
    )
    text = f"""
robot:
  host: scripted-{uuid.uuid4().hex}
  tcp_offset: [0, 0, 0.15, 0, 0, 0]
hand_eye:
  mode: eye-to-hand
  file: {tmp_path / "eth.yaml"}
  units: mm
  camera_position_mm: [-400, 0, 1000]
grasp:
  approach_mm: 200
  retreat_mm: 200
  object_T_tcp: [0, 0, 0.025, 0, 0, 0]
{grasp}
motion:
  speed_mps: 0.25
  accel_mps2: 1.2
  grasp_speed_mps: 0.05
workspace:
  min_mm: [-800, -800, 0]
  max_mm: [800, 800, 800]
  max_tilt_deg: 30
audit:
  file: picks.jsonl
{scene}
{tool.replace("BODY", str(body_mm))}
{extra}
"""
    path = tmp_path / "cell.yaml"
    path.write_text(text)
    return load_config(path)


def _part(
    x_m: float,
    y_m: float,
    yaw_deg: float = 0.0,
    symmetry: Symmetry | None = None,
    size: bool = True,
) -> Detection:
    """A cube lying on the bin floor at (x, y) from the bin's centre, turned yaw about base z:
    its object frame at the top face's centre, z pointing down into it."""
    R = rotation_from_euler([0.0, 0.0, yaw_deg], "xyz", "deg") @ DOWN
    T_base_obj = make_transform(R, [BIN_X + x_m, BIN_Y + y_m, BIN_FLOOR_Z + PART])
    return Detection(
        invert(T_BASE_CAM) @ T_base_obj,
        position_only=False,
        source=f"part at {x_m * 1000:.0f}, {y_m * 1000:.0f} mm",
        size_mm=(50.0, 50.0, 50.0) if size else None,
        symmetry=symmetry,
    )


def _choose(config: CellConfig, *detections: Detection, place: bool = False) -> Chosen:
    calibration = load_hand_eye(config.hand_eye.file, config.hand_eye.mode, config.hand_eye.units)
    arm = ScriptedArm(config.audit.file)
    arm.T_flange_tcp = T_FLANGE_TCP
    T_place = config.place.T_base_tcp[0] if place and config.place is not None else None
    chosen, _ = choose(
        config,
        calibration,
        list(detections),
        T_BASE_FLANGE,
        T_FLANGE_TCP,
        arm,
        {},
        T_base_tcp_place=T_place,
        grip=True,
    )
    return chosen


def _refused(config: CellConfig, *detections: Detection, place: bool = False) -> str:
    with pytest.raises((PreflightRefusal, NoFeasibleCandidate)) as refusal:
        _choose(config, *detections, place=place)
    return str(refusal.value)


SQUARE = Symmetry("z", 4)
NEAR = HALF_X - PART / 2 - 0.008  # a part's centre when it lies 8 mm from an east/west wall
NEAR_Y = HALF_Y - PART / 2 - 0.008


# --- a part against each wall and in a corner ---------------------------------------------------


@pytest.mark.parametrize(
    ("wall", "x_m", "y_m", "yaw_deg"),
    [
        ("east", NEAR, 0.0, 0.0),
        ("west", -NEAR, 0.0, 0.0),
        ("north", 0.0, NEAR_Y, 90.0),  # turned so its fingers point at the wall
        ("south", 0.0, -NEAR_Y, 90.0),
    ],
)
def test_a_part_against_a_wall_is_refused_naming_the_wall_and_picked_turned_when_symmetric(
    tmp_path: Path, wall: str, x_m: float, y_m: float, yaw_deg: float
) -> None:
    config = _config(tmp_path)
    message = _refused(config, _part(x_m, y_m, yaw_deg))
    assert f"into bin 'parts' wall '{wall}'" in message
    assert "of the grasp descent" in message
    chosen = _choose(config, _part(x_m, y_m, yaw_deg, SQUARE))
    assert chosen.alternative is not None
    assert chosen.alternative.yaw_deg in (90.0, 270.0)
    assert chosen.alternative.tilt_deg == 0.0
    refused = [o for o in chosen.others if o.yaw_deg in (0.0, 180.0)]
    assert len(refused) == 2
    assert all(f"wall '{wall}'" in " ".join(o.reasons) for o in refused)


def test_the_refusal_names_tool_wall_depth_and_where(tmp_path: Path) -> None:
    message = _refused(_config(tmp_path), _part(NEAR, 0.0))
    # The finger (35 to 45 mm beyond the part's centre) pokes through the 10 mm wall (33 to
    # 43 mm): 8 mm to push it back out, once it is below the wall's top.
    assert re.search(
        r"grasp collision: tool 'finger \+x' would come 8 mm into bin 'parts' wall 'east' at "
        r"\d+ % of the grasp descent",
        message,
    )


def test_a_part_in_a_corner_is_refused_with_every_alternative_saying_why(tmp_path: Path) -> None:
    config = _config(tmp_path)
    message = _refused(config, _part(NEAR, NEAR_Y, 0.0, SQUARE))
    for yaw in ("yaw 0 deg", "yaw 90 deg", "yaw 180 deg", "yaw 270 deg"):
        assert yaw in message
    assert "wall 'east'" in message
    assert "wall 'north'" in message


def test_a_part_at_the_bin_centre_is_picked_as_detected(tmp_path: Path) -> None:
    chosen = _choose(_config(tmp_path), _part(0.0, 0.0, 30.0, SQUARE))
    assert chosen.alternative is not None
    assert (chosen.alternative.yaw_deg, chosen.alternative.tilt_deg) == (0.0, 0.0)
    collision = [c for c in chosen.checks if c.name == "collision"]
    assert {c.target for c in collision} >= {"approach", "grasp", "retreat"}
    assert all(c.passed for c in collision)


def test_the_least_wrist_turn_wins_among_passing_alternatives(tmp_path: Path) -> None:
    # Detected turned 80 deg about base z; its z points down, so turning it 90 deg about its
    # own z turns it back to -10 deg: the wrist turns 10 deg, less than for the others.
    chosen = _choose(_config(tmp_path), _part(0.0, 0.0, 80.0, SQUARE))
    assert chosen.alternative is not None
    assert chosen.alternative.yaw_deg == 90.0
    assert chosen.alternative.wrist_turn_deg == pytest.approx(10.0, abs=1e-6)
    assert {o.yaw_deg for o in chosen.others} == {0.0, 180.0, 270.0}
    assert all("not asked of the controller" in o.reasons[0] for o in chosen.others)


# --- tilts towards the bin centre ---------------------------------------------------------------


def test_a_part_only_pickable_tilted_gets_the_smallest_tilt_that_fits(tmp_path: Path) -> None:
    # A 120 mm body, the part 60 mm from the west wall: the fingers fit, the body does not.
    part = _part(-(HALF_X - 0.060), 0.0)
    upright = _config(tmp_path, body_mm=120)
    assert "tool 'body'" in _refused(upright, part)
    assert "wall 'west'" in _refused(upright, part)
    config = _config(tmp_path, body_mm=120, grasp="  tilt_max_deg: 15")
    chosen = _choose(config, part)
    assert chosen.alternative is not None
    assert chosen.alternative.tilt_deg == 10.0  # 5 deg leaves the body 5.0 mm from the wall
    tool_z = chosen.plan.grasp[:3, 2]
    assert tool_z[0] < 0.0  # the tool's top leans towards the centre (+x): its z towards -x
    assert math.degrees(math.acos(-tool_z[2])) == pytest.approx(10.0)
    assert [o.tilt_deg for o in chosen.others] == [0.0, 5.0]


# --- the place with the part in hand, the transfer, the clearance ------------------------------


def test_a_place_that_hits_a_fixture_with_the_part_in_hand_is_refused(tmp_path: Path) -> None:
    config = _config(tmp_path, scene=SCENE + FIXTURES.split("    - {name: column")[0], extra=PLACE)
    message = _refused(config, _part(0.0, 0.0), place=True)
    assert "the held part would come" in message
    assert "into box 'fixture'" in message
    assert "of the place descent" in message
    # Without its size the part is not modelled: the tool alone clears the fixture.
    chosen = _choose(config, _part(0.0, 0.0, size=False), place=True)
    assert any(c.target == "place" and c.passed for c in chosen.checks if c.name == "collision")


def test_a_transfer_crossing_a_fixture_between_clear_targets_is_refused(tmp_path: Path) -> None:
    config = _config(tmp_path, scene=SCENE + FIXTURES.split("\n    - {name: fixture")[0] + """
    - {name: column, pose: [-0.20, 0.20, 0.40, 0, 0, 0], size_mm: [60, 60, 800]}
""", extra=PLACE)
    message = _refused(config, _part(0.0, 0.0, size=False), place=True)
    assert "into box 'column'" in message
    assert "of the move to the place-approach" in message
    # The targets themselves are clear: every end pose passed the static look.
    assert "at 100 %" not in message


def test_the_clearance_is_kept_and_only_just_refuses(tmp_path: Path) -> None:
    # The finger's outer face 45 mm beyond the part's centre, the wall's face at 150 mm.
    clear = 0.150 - 0.045 - 0.006  # 6 mm from the wall: passes
    close = 0.150 - 0.045 - 0.004  # 4 mm: inside the 5 mm clearance
    config = _config(tmp_path)
    chosen = _choose(config, _part(clear, 0.0))
    grasp = next(c for c in chosen.checks if c.name == "collision" and c.target == "grasp")
    assert "6.0 mm from bin 'parts' wall 'east'" in grasp.detail
    message = _refused(config, _part(close, 0.0))
    assert "would pass 4.0 mm from bin 'parts' wall 'east'" in message
    assert "closer than the 5 mm it must keep" in message


def test_blended_corners_are_swept_along_their_curve() -> None:
    # A 10 mm probe at the TCP turns a corner at B, rounded with 100 mm: the curve passes
    # through a small box the straight path misses by 15 mm (no clearance asked).
    A, B, C = (np.array(p) for p in ([0.0, 0.0, 0.5], [0.3, 0.0, 0.5], [0.3, 0.0, 0.2]))
    box = SceneBox("corner", (10.0, 10.0, 10.0), make_transform(np.eye(3), [0.275, 0.0, 0.475]))
    probe = ToolShape("probe", np.eye(4), size_mm=(10.0, 10.0, 10.0))
    check = SceneCheck(SceneConfig(boxes=(box,), clearance_mm=0.0), (probe,), np.eye(4))
    start = make_transform(DOWN, A)

    def steps(blend_m: float) -> list[Move]:
        return [
            Move("approach", make_transform(DOWN, B), blend_m=blend_m),
            Move("grasp", make_transform(DOWN, C), slow=True),
        ]

    assert all(r.passed for r in check.check(steps(0.0), start, None, start, start))
    results = check.check(steps(0.1), start, None, start, start)
    assert not results[-1].passed
    assert "tool 'probe' would come" in results[-1].detail
    assert "into box 'corner'" in results[-1].detail
    assert "of the blend at the approach" in results[-1].detail


@pytest.fixture(scope="module")
def module_config(tmp_path_factory: pytest.TempPathFactory) -> CellConfig:
    return _config(tmp_path_factory.mktemp("scene"), tool=TOOL + CAMERA)


@settings(max_examples=15, deadline=None)
@given(
    st.floats(-0.12, 0.12),
    st.floats(-0.07, 0.07),
    st.floats(-90.0, 90.0),
    st.floats(0.0, 40.0),
)
def test_a_passing_sweep_keeps_the_clearance_at_every_pose_between(
    module_config: CellConfig, x_m: float, y_m: float, yaw_deg: float, tilt_deg: float
) -> None:
    """Property: whatever the check passes keeps the clearance at every one of 60 poses along
    each piece, measured with exact distances; whatever it refuses comes within the clearance
    (plus the proof tolerance) somewhere."""
    scene = module_config.scene or pytest.fail("no scene")
    check = SceneCheck(scene, module_config.tool_shape, T_FLANGE_TCP)
    R = rotation_from_euler([tilt_deg, 0.0, yaw_deg], "xyz", "deg") @ DOWN
    grasp = make_transform(R, [BIN_X + x_m, BIN_Y + y_m, BIN_FLOOR_Z + 0.03])
    approach = make_transform(R, grasp[:3, 3] + [0.0, 0.0, 0.25])
    steps = [Move("approach", approach), Move("grasp", grasp, slow=True)]
    start = T_BASE_FLANGE @ T_FLANGE_TCP
    tool = Group(check.tool, scene.clearance_mm / 1000.0, near_m=np.inf)  # exact distances
    passed = all(r.passed for r in check.check(steps, start, None, grasp, grasp))
    worst = min(
        check.sweep.margins(piece, tool, piece.pose(float(s)))[1].margin_m
        for piece in pieces(steps, start)
        for s in np.linspace(0.0, 1.0, 60)
    )
    if passed:
        assert worst >= -1e-9
    else:
        assert worst < PROOF_TOLERANCE_M + 0.002  # refused: it came close somewhere near


# --- no scene: today's behaviour ----------------------------------------------------------------


def test_without_a_scene_the_checks_are_exactly_todays(tmp_path: Path) -> None:
    config = _config(tmp_path, scene="", tool="")
    assert config.scene is None
    assert config.tool_shape == ()
    chosen = _choose(config, _part(NEAR, 0.0, 0.0, SQUARE))  # fingers in the wall: nobody knows
    assert chosen.alternative is None
    assert chosen.others == []
    assert chosen.alternative_record() == {}
    assert not any(c.name == "collision" for c in chosen.checks)
    assert [m.name for m in pick_steps(chosen.plan, grip=True) if isinstance(m, Move)] == [
        "approach",
        "grasp",
        "retreat",
    ]


# --- the bin's solids ---------------------------------------------------------------------------


def test_a_bin_is_a_floor_and_four_walls_named_by_their_side(tmp_path: Path) -> None:
    config = _config(tmp_path)
    scene = config.scene or pytest.fail("no scene")
    boxes = {name: (size, T) for name, size, T in bin_boxes(scene.bins[0])}
    assert set(boxes) == {"floor", "east", "west", "north", "south"}
    assert boxes["east"][1][0, 3] > BIN_X > boxes["west"][1][0, 3]
    assert boxes["north"][1][1, 3] > BIN_Y > boxes["south"][1][1, 3]
    assert boxes["floor"][1][2, 3] < BIN_FLOOR_Z < boxes["east"][1][2, 3]
    # East and west span the outer width: the corners are closed.
    assert boxes["east"][0][1] == pytest.approx(0.220)


# --- bad scene and tool config: one line, exit 2 ------------------------------------------------


@pytest.mark.parametrize(
    ("scene", "tool", "expected"),
    [
        (SCENE, "", "tool: the collision check needs both scene"),
        ("", TOOL, "scene: the collision check needs both scene"),
        (SCENE.replace("clearance_mm: 5", "clearance_mm: -1"), TOOL, "scene.clearance_mm"),
        (SCENE.replace("[300, 200, 150]", "[0.3, 0.2, 0.15]"), TOOL, "scene.bins[0].inner_mm"),
        (SCENE.replace("wall_mm: 10", "walls_mm: 10"), TOOL, "scene.bins[0].walls_mm: unknown key"),
        (SCENE.replace("name: parts", "name: ''"), TOOL, "scene.bins[0].name"),
        ("scene: {}", TOOL, "give at least one of bins, boxes or floor_z_mm"),
        (SCENE + "  boxes: 3", TOOL, "scene.boxes: expected a list"),
        (SCENE, TOOL.replace("box: {size_mm: [10, 20, 45]", "blob: {size_mm: [10, 20, 45]", 1),
         "tool.shape[1].blob: unknown key"),
        (SCENE, TOOL.replace("finger -x", "finger +x"), "tool.shape: the name 'finger +x'"),
        (SCENE, "tool:\n  shape: []", "tool.shape: expected at least one solid"),
        (SCENE, TOOL.replace("[0, 0, 0.055, 0, 0, 0]", "[0, 0, 55, 0, 0, 0]"),
         "tool.shape[0].box.pose: translation is 55 m long"),
        (SCENE, TOOL + "    - name: cable\n      cylinder: {radius_mm: 5, pose: [0, 0, 0, 0, 0, 0]"
         "}",
         "tool.shape[3].cylinder.length_mm: missing"),
        (SCENE, TOOL + "    - name: both\n      box: {size_mm: [1, 1, 1], pose: [0, 0, 0, 0, 0, 0]}"
         "\n      cylinder: {radius_mm: 5, length_mm: 5, pose: [0, 0, 0, 0, 0, 0]}",
         "tool.shape[3]: give exactly one of box"),
    ],
)
def test_bad_scene_and_tool_config_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], scene: str, tool: str, expected: str
) -> None:
    with pytest.raises(ConfigError) as error:
        _config(tmp_path, scene=scene, tool=tool)
    message = str(error.value)
    assert expected in message
    assert "\n" not in message
    assert main(["status", "--config", str(tmp_path / "cell.yaml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert expected in err[0]


@pytest.mark.parametrize(
    ("grasp", "expected"),
    [
        ("  tilt_max_deg: 60", "grasp.tilt_max_deg: must be at most 45"),
        ("  part_size_mm: [0.05, 0.05, 0]", "grasp.part_size_mm"),
        ("  symmetry_step_deg: 0", "grasp.symmetry_step_deg"),
    ],
)
def test_bad_grasp_alternative_keys_are_one_line(tmp_path: Path, grasp: str, expected: str) -> None:
    with pytest.raises(ConfigError, match=expected.replace("[", r"\[")):
        _config(tmp_path, grasp=grasp)


# --- the reply, the --json report and the audit say which alternative ---------------------------


def test_the_reply_and_the_audit_say_which_alternative_and_why_not_the_others(
    tmp_path: Path,
) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.T_flange_tcp, arm.T_base_flange = T_FLANGE_TCP, T_BASE_FLANGE.copy()
    cell = Cell(config, connect=lambda _config: arm)
    cell.connect()
    result = cell.pick(_part(NEAR, 0.0, 0.0, SQUARE))
    reply = pick_reply(result)
    alternative = reply["alternative"]
    assert isinstance(alternative, dict)
    assert alternative["yaw_deg"] == 90.0
    assert alternative["tilt_deg"] == 0.0
    others = {o["yaw_deg"]: o["reasons"] for o in alternative["others"]}
    assert "wall 'east'" in others[0.0][0]
    records = [json.loads(line) for line in config.audit.file.read_text().splitlines()]
    plan = next(r for r in records if r["event"] == "plan")
    assert plan["alternative"] == alternative
    assert plan["detection"]["symmetry"] == {"axis": "z", "order": 4}
    assert plan["detection"]["size_mm"] == [50.0, 50.0, 50.0]
    assert record_problems(plan) == []
    # The moves went to the turned grasp: the tool's x now along base y.
    grasp = result.plan.grasp
    assert abs(grasp[1, 0]) == pytest.approx(1.0)
    assert arm.moves() or arm.paths()


def test_status_describes_the_scene_in_one_line(tmp_path: Path) -> None:
    config = _config(tmp_path, scene=SCENE + FIXTURES)
    scene = config.scene or pytest.fail("no scene")
    line = describe_scene(scene, len(config.tool_shape))
    assert line == (
        "bin 'parts' (300 x 200 x 150 mm inside), box 'fixture', box 'column', floor at z 0 mm; "
        "clearance 5 mm; tool of 3 solids; the arm is not checked (scene.arm: unchecked): only "
        "the tool and the held part are"
    )


def test_a_move_to_a_named_pose_is_swept_too(tmp_path: Path) -> None:
    poses = """
poses:
  beyond: {tcp_pose: [-0.40, 0.40, 0.45, 3.14159265, 0, 0]}
  beside: {tcp_pose: [-0.10, 0.00, 0.45, 3.14159265, 0, 0]}
"""
    config = _config(tmp_path, scene=SCENE + FIXTURES, extra=poses)
    arm = ScriptedArm(config.audit.file)
    arm.T_flange_tcp, arm.T_base_flange = T_FLANGE_TCP, T_BASE_FLANGE.copy()
    cell = Cell(config, connect=lambda _config: arm)
    cell.connect()
    with pytest.raises(PreflightRefusal, match=r"beyond collision: tool '.+' would come .* into "
                                               r"box 'column' at \d+ % of the move to beyond"):
        cell.move_to("beyond")
    assert not arm.moves()
    cell.move_to("beside")  # clear of the column: it moves
    assert len(arm.moves()) == 1
