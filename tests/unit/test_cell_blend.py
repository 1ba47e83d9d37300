"""Blended corners (cell/blend.py) and blended sequences against the scripted arm: the radius
rules, the disc a corner sweeps, the paths a pick and its place are sent as, and their endings.
The simulated controller's side of a path is tested in tests/integration."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from handeye_pick.cell.blend import (
    BLEND_SHARE,
    COLLINEAR_SINE,
    corner_extent_m,
    corners,
    with_blends,
)
from handeye_pick.cell.plan import check_steps
from handeye_pick.cell.sequence import path_at
from handeye_pick.config.load import load_config
from handeye_pick.errors import ConfigError, RobotFault
from handeye_pick.geometry import Transform, make_transform
from handeye_pick.safety import PreflightRefusal
from handeye_pick.steps import Grip, JointMove, Move, Step
from tests.unit.test_cell_session import PLACE, ScriptedArm, _cell, _config, _detection, _records

GRIPPER = "  gripper: {bank: tool, index: 1, close_value: true, settle_s: 0}"
DOWN = np.diag([1.0, -1.0, -1.0])  # tool z straight down


def _at(x: float, y: float, z: float) -> Transform:
    return make_transform(DOWN, [x, y, z])


def _blended_config(tmp_path: Path, blend_mm: float, extra: str = PLACE, straight: str = ""):  # type: ignore[no-untyped-def]
    """The scripted cell with ``motion.blend_mm`` (and ``grasp.straight_mm``) set, every
    stretch of corners sent as a path (``blend_always``: these tests are about paths)."""
    config = _config(tmp_path, gripper=GRIPPER, extra=extra)
    text = config.path.read_text()
    text = text.replace(
        "  grasp_speed_mps: 0.05\n",
        f"  grasp_speed_mps: 0.05\n  blend_mm: {blend_mm}\n  blend_always: true\n",
    )
    text = text.replace("  retreat_mm: 80\n", f"  retreat_mm: 80\n{straight}", 1)
    config.path.write_text(text)
    return load_config(config.path)


# --- the radius rules -------------------------------------------------------------------------

_coordinate = st.floats(-0.5, 0.5, allow_nan=False)
_point = st.tuples(_coordinate, _coordinate, _coordinate)


@st.composite
def _sequences(draw: st.DrawFn) -> list[Step]:
    """Moves to random points, some of them slow (a descent) and followed by a gripper action,
    now and then a moveJ between them."""
    steps: list[Step] = []
    for index, point in enumerate(draw(st.lists(_point, min_size=1, max_size=7))):
        kind = draw(st.sampled_from(["move", "move", "slow", "joint"]))
        if kind == "joint":
            steps.append(JointMove(f"joint {index}", (0.0, -1.57, 1.57, -1.57, -1.57, 0.0)))
            continue
        steps.append(Move(f"move {index}", _at(*point), slow=kind == "slow"))
        if kind == "slow" and draw(st.booleans()):
            steps.append(Grip(close=draw(st.booleans())))
    return steps


@given(
    steps=_sequences(),
    start=_point,
    blend_m=st.floats(0.0, 0.3),
    straight_m=st.floats(0.0, 0.1),
)
def test_every_corner_keeps_to_the_radius_rules(
    steps: list[Step], start: tuple[float, float, float], blend_m: float, straight_m: float
) -> None:
    rounded = with_blends(steps, _at(*start), blend_m, straight_m)
    assert [type(s) for s in rounded] == [type(s) for s in steps]
    position = np.array(start)
    previous: Move | None = None
    for index, step in enumerate(rounded):
        if not isinstance(step, Move):
            if isinstance(step, JointMove):
                position, previous = None, None  # type: ignore[assignment]
            continue
        following = rounded[index + 1] if index + 1 < len(rounded) else None
        here = step.T_base_tcp[:3, 3]
        radius = step.blend_m
        if radius > 0.0:
            assert isinstance(following, Move), "a corner needs a moveL after it"
            assert not step.slow, "the end of a descent is a stop"
            assert position is not None, "the corner after a moveJ is a stop"
            incoming = float(np.linalg.norm(here - position))
            outgoing = float(np.linalg.norm(following.T_base_tcp[:3, 3] - here))
            assert radius <= blend_m
            assert radius <= BLEND_SHARE * incoming + 1e-12
            assert radius <= BLEND_SHARE * outgoing + 1e-12
            if previous is not None and previous.slow:  # the ascent keeps its first straight_m
                assert incoming - radius >= straight_m - 1e-12
            if following.slow:  # the descent keeps its last straight_m
                assert outgoing - radius >= straight_m - 1e-12
        position, previous = here, step


def test_blend_zero_leaves_every_target_a_stop() -> None:
    steps: list[Step] = [
        Move("a", _at(0, 0, 0.3)),
        Move("b", _at(0.3, 0, 0.3)),
        Move("c", _at(0.3, 0, 0.1), slow=True),
    ]
    assert with_blends(steps, _at(0, 0, 0.5), 0.0, 0.02) == steps


def test_a_corner_gets_the_smallest_of_its_limits() -> None:
    # From 300 mm away to an approach 100 mm above the grasp: 45 % of 100 mm is 45 mm; with
    # fingers (40 mm straight) and a 60 mm approach, 20 mm of the descent is left to round.
    start = _at(-0.3, 0.0, 0.2)
    steps: list[Step] = [Move("approach", _at(0, 0, 0.2)), Move("grasp", _at(0, 0, 0.1), slow=True)]
    assert with_blends(steps, start, 0.05, 0.02)[0].blend_m == pytest.approx(0.045)  # type: ignore[union-attr]
    assert with_blends(steps, start, 0.03, 0.02)[0].blend_m == pytest.approx(0.03)  # type: ignore[union-attr]
    short: list[Step] = [
        Move("approach", _at(0, 0, 0.16)),
        Move("grasp", _at(0, 0, 0.1), slow=True),
    ]
    assert with_blends(short, start, 0.05, 0.04)[0].blend_m == pytest.approx(0.02)  # type: ignore[union-attr]
    # A straight part as long as the descent leaves nothing to round: a stop.
    assert with_blends(short, start, 0.05, 0.06)[0].blend_m == 0.0  # type: ignore[union-attr]


def test_the_ascent_from_a_grasp_keeps_its_first_straight_mm_straight() -> None:
    # A 30 mm lift-off, then over: 45 % of it would be 13.5 mm, but 20 mm of it stay straight
    # along the tool axis: 10 mm are left to round.
    steps: list[Step] = [
        Move("grasp", _at(0, 0, 0.1), slow=True),
        Grip(close=True),
        Move("retreat", _at(0, 0, 0.13)),
        Move("over", _at(0.3, 0, 0.13)),
    ]
    rounded = with_blends(steps, _at(0, 0, 0.2), 0.02, 0.02)
    assert rounded[2].blend_m == pytest.approx(0.01)  # type: ignore[union-attr]


@pytest.mark.parametrize(
    ("blend_mm", "radius_mm"),
    [(0.5, 0.5), (0.4, 0.0)],
    ids=["half a millimetre rounds", "less is a stop"],
)
def test_a_corner_under_half_a_millimetre_is_a_stop(blend_mm: float, radius_mm: float) -> None:
    steps: list[Step] = [Move("a", _at(0.3, 0, 0.3)), Move("b", _at(0.3, 0.3, 0.3))]
    rounded = with_blends(steps, _at(0, 0, 0.3), blend_mm / 1000.0, 0.02)
    assert rounded[0].blend_m == radius_mm / 1000.0  # type: ignore[union-attr]


def test_corners_after_a_movej_are_blended_too() -> None:
    # Where the moveJ ends is not known, so the first moveL after it is a stop; the next is a
    # corner like any other.
    steps: list[Step] = [
        JointMove("home", (0.0, -1.57, 1.57, -1.57, -1.57, 0.0)),
        Move("a", _at(0, 0, 0.3)),
        Move("b", _at(0.3, 0, 0.3)),
        Move("c", _at(0.3, 0.3, 0.3)),
    ]
    rounded = with_blends(steps, _at(0, 0, 0.5), 0.02, 0.02)
    assert [getattr(s, "blend_m", None) for s in rounded] == [None, 0.0, 0.02, 0.0]


# --- the room a corner needs ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("incoming", "outgoing", "extent"),
    [
        ([1, 0, 0], [0, 1, 0], [1, 1, 0]),  # a corner in the horizontal plane
        ([1, 0, 0], [0, 0, -1], [1, 0, 1]),  # over and down: the vertical x-z plane
        ([1, 0, 0], [2, 0, 0], [1, 1, 1]),  # in one line: no plane, the whole ball
        ([1, 0, 0], [-1, 0, 0], [1, 1, 1]),  # straight back
        ([0.1, 0, 0], [0.1, -1e-6, 0], [1, 1, 0]),  # 0.0006 degrees off a line: a plane still
        # In one line however short (their product's threshold underflows to 0): the ball.
        ([0, 0, 2e-160], [0, 0, 2e-160], [1, 1, 1]),
    ],
)
def test_a_corner_sweeps_the_disc_of_its_plane(
    incoming: list[float], outgoing: list[float], extent: list[float]
) -> None:
    got = corner_extent_m(np.array(incoming, float), np.array(outgoing, float), 0.05)
    np.testing.assert_allclose(got, 0.05 * np.array(extent, float), atol=1e-12)


@given(a=_point, b=_point, angle=st.floats(0.0, 2.0 * math.pi))
def test_every_point_of_the_disc_lies_within_the_extent(
    a: tuple[float, float, float], b: tuple[float, float, float], angle: float
) -> None:
    incoming, outgoing = np.array(a), np.array(b)
    normal = np.cross(incoming, outgoing)
    scale = np.linalg.norm(incoming) * np.linalg.norm(outgoing)
    if scale == 0.0 or np.linalg.norm(normal) <= COLLINEAR_SINE * scale:
        return  # in one line: the whole ball, above
    u = incoming / np.linalg.norm(incoming)
    v = np.cross(normal / np.linalg.norm(normal), u)
    point = 0.05 * (math.cos(angle) * u + math.sin(angle) * v)
    assert np.all(np.abs(point) <= corner_extent_m(incoming, outgoing, 0.05) + 1e-9)


def test_a_corner_reaching_out_of_the_workspace_is_refused_though_its_targets_are_inside(
    tmp_path: Path,
) -> None:
    config = _blended_config(tmp_path, 50)
    config = dataclasses.replace(
        config, workspace=dataclasses.replace(config.workspace, max_mm=(800.0, 800.0, 320.0))
    )
    arm = ScriptedArm(config.audit.file)
    start = _at(-0.3, 0.0, 0.3)
    # Over and on sideways at z = 300 mm: the disc lies in that plane, 20 mm below the box's top.
    sideways = with_blends(
        [Move("over", _at(0.0, 0.0, 0.3)), Move("on", _at(0.0, 0.3, 0.3))], start, 0.05, 0.02
    )
    (corner,) = corners(sideways, start)
    assert corner.radius_m == pytest.approx(0.05)
    check_steps(config, sideways, arm, {}, start)
    # Over and down: the disc stands in the x-z plane and reaches 50 mm above the corner.
    down = with_blends(
        [Move("over", _at(0.0, 0.0, 0.3)), Move("down", _at(0.0, 0.0, 0.0))], start, 0.05, 0.0
    )
    check_steps(config, down, arm, {})  # without the start no corner is known: targets only
    with pytest.raises(PreflightRefusal, match=r"over corner_workspace: .* z 350\.0 mm above max"):
        check_steps(config, down, arm, {}, start)


# --- what is driven as one path ---------------------------------------------------------------


def test_a_path_runs_to_the_first_stop_and_no_farther_than_the_last_move() -> None:
    steps: list[Step] = [
        Move("a", _at(0, 0, 0.3), blend_m=0.01),
        Move("b", _at(0.1, 0, 0.3), blend_m=0.01),
        Move("c", _at(0.2, 0, 0.3)),
        Grip(close=True),
        Move("d", _at(0.2, 0, 0.4), blend_m=0.01),
        JointMove("e", (0.0,) * 6),
    ]
    assert [m.name for m in path_at(steps, 0, None)] == ["a", "b", "c"]
    assert [m.name for m in path_at(steps, 0, "b")] == ["a", "b"]  # a missed grasp's retreat
    assert path_at(steps, 3, None) == []  # a gripper action is no move
    assert [m.name for m in path_at(steps, 4, None)] == ["d"]  # a moveJ ends the path


# --- blended sequences through the Cell -------------------------------------------------------


def test_a_blended_pick_and_place_is_three_paths_stopping_only_to_grip(tmp_path: Path) -> None:
    config = _blended_config(tmp_path, 50)
    arm = ScriptedArm(config.audit.file)
    result = _cell(config, arm).pick(_detection())
    assert result.status == "placed"
    down, transfer = arm.paths()
    # The approach: 45 % of its 100 mm descent (20 mm straight would leave 80); the grasp a stop.
    assert [round(w.blend_m, 6) for w in down] == [0.045, 0.0]
    # Retreat (80 mm up, 20 mm straight: 45 % of 80 mm = 36 mm) and the place approach (60 mm
    # above the place, 20 mm straight: 40 mm; 45 %: 27 mm) rounded; the place a stop.
    assert [round(w.blend_m, 6) for w in transfer] == [0.036, 0.027, 0.0]
    assert [w.speed_mps for w in down + transfer] == [0.25, 0.05, 0.25, 0.25, 0.05]
    assert len(arm.moves()) == 1  # the place retreat: the end of the sequence, alone
    plan, outcome = _records(config.audit.file)
    assert plan["blends_mm"] == {"approach": 45.0, "retreat": 36.0, "place-approach": 27.0}
    assert set(outcome["reached"]) == {"grasp", "place", "place-retreat"}  # type: ignore[arg-type]
    assert set(outcome["errors"]) == {"grasp", "place", "place-retreat"}  # type: ignore[arg-type]


def test_blend_zero_sends_todays_single_moves(tmp_path: Path) -> None:
    config = _blended_config(tmp_path, 0)
    arm = ScriptedArm(config.audit.file)
    assert _cell(config, arm).pick(_detection()).status == "placed"
    assert arm.paths() == []
    assert len(arm.moves()) == 6
    assert "blends_mm" not in _records(config.audit.file)[0]


def test_a_fault_mid_path_names_the_step_the_arm_was_heading_for_and_halts(
    tmp_path: Path,
) -> None:
    config = _blended_config(tmp_path, 50)
    arm = ScriptedArm(config.audit.file)
    arm.fail_on_waypoint = 1
    cell = _cell(config, arm)
    with pytest.raises(RobotFault):
        cell.pick(_detection())
    outcome = _records(config.audit.file)[-1]
    assert (outcome["status"], outcome["step"]) == ("fault", "grasp")
    assert outcome["reached"] == {}
    assert cell.status().halted


def test_via_poses_are_passed_through_on_the_way_to_the_place(tmp_path: Path) -> None:
    extra = PLACE.replace("  retreat_mm: 70\n", "  retreat_mm: 70\n  via: [over]\n").replace(
        "\nposes:\n", "\nposes:\n  over: {tcp_pose: [-0.35, 0.0, 0.35, 3.14159265, 0, 0]}\n"
    )
    config = _blended_config(tmp_path, 50, extra=extra)
    arm = ScriptedArm(config.audit.file)
    assert _cell(config, arm).pick(_detection()).status == "placed"
    _, transfer = arm.paths()
    np.testing.assert_allclose(transfer[1].T_base_tcp[:3, 3], [-0.35, 0.0, 0.35])
    assert transfer[1].blend_m == pytest.approx(0.05)
    assert "via over" in _records(config.audit.file)[0]["targets"]  # type: ignore[operator]


def test_capture_via_poses_lead_to_the_capture_pose_as_one_blended_path(
    tmp_path: Path,
) -> None:
    extra = PLACE.replace("  pose: home\n", "  pose: clear\n  via: [over]\n").replace(
        "\nposes:\n", "\nposes:\n  over: {tcp_pose: [-0.35, 0.15, 0.35, 3.14159265, 0, 0]}\n"
    )
    config = _blended_config(tmp_path, 50, extra=extra)
    assert [pose.name for pose in config.capture.via] == ["over"]
    arm = ScriptedArm(config.audit.file)
    cell = _cell(config, arm)
    cell.capture()
    (path,) = arm.paths()
    np.testing.assert_allclose(path[0].T_base_tcp[:3, 3], [-0.35, 0.15, 0.35])
    np.testing.assert_allclose(path[1].T_base_tcp[:3, 3], [-0.30, 0.0, 0.40])  # the pose
    assert path[0].blend_m > 0.0
    assert path[1].blend_m == 0.0  # the camera needs the arm at rest there
    plan = _records(config.audit.file)[0]
    assert list(plan["targets"]) == ["via over", "clear"]  # type: ignore[call-overload]
    arm.calls.clear()
    cell.capture("home")  # another pose: no via
    assert arm.paths() == []


def test_capture_via_needs_a_capture_pose(tmp_path: Path) -> None:
    extra = PLACE.replace("  pose: home\n", "  via: [clear]\n")
    with pytest.raises(ConfigError, match=r"capture\.via: via poses lead to the capture pose"):
        _blended_config(tmp_path, 50, extra=extra)


def test_a_via_pose_must_be_a_known_tcp_pose(tmp_path: Path) -> None:
    joint = PLACE.replace("  retreat_mm: 70\n", "  retreat_mm: 70\n  via: [home]\n")
    with pytest.raises(ConfigError, match=r"place\.via: pose 'home' is a joint pose"):
        _blended_config(tmp_path, 50, extra=joint)
    unknown = PLACE.replace("  retreat_mm: 70\n", "  retreat_mm: 70\n  via: [nowhere]\n")
    with pytest.raises(ConfigError, match="no pose named 'nowhere'"):
        _blended_config(tmp_path, 50, extra=unknown)


def test_straight_mm_defaults_by_gripper_and_blend_mm_is_bounded(tmp_path: Path) -> None:
    assert _blended_config(tmp_path, 50).grasp.straight_mm == 20.0
    fingers = _config(
        tmp_path,
        gripper="  gripper:\n    type: robotiq-2f\n    expected_width_mm: [38, 42]",
    )
    assert fingers.grasp.straight_mm == 40.0
    given_straight = _blended_config(tmp_path, 50, straight="  straight_mm: 35\n")
    assert given_straight.grasp.straight_mm == 35.0
    with pytest.raises(ConfigError, match=r"motion\.blend_mm"):
        _blended_config(tmp_path, 301)
