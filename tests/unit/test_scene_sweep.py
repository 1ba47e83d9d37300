"""The sweep's own promises (scene/collide.py, docs/scene.md "How the sweep keeps the clearance"):
each step along a piece is the smallest of every moving solid's margin over its rate, so no solid
is stepped over a thin obstacle; the bound that screens far pairs is a lower bound (a box's half
size); margins carried from one piece to the next come from the neighbour with the same solids
and the same contact, never from the last piece for the first; a near-miss refusal names the
closest point its scan found. And the property behind them all: on random scenes, tools and
pick-and-place paths with a held part, a path the check passes keeps the clearance at every
0.5 mm and 0.5 degree along it, measured with exact distances.

Tools here are small solids in the TCP frame (the flange is the TCP), so the geometry of each
case can be read off its numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import fcl
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from handeye_pick.config.schema import BinConfig, SceneBox, SceneConfig, ToolShape
from handeye_pick.geometry import Transform, invert, make_transform, rotation_from_euler
from handeye_pick.safety import CheckResult
from handeye_pick.scene.check import SceneCheck
from handeye_pick.scene.collide import PART_CONTACT_M, PROOF_TOLERANCE_M
from handeye_pick.scene.path import Piece, pieces
from handeye_pick.scene.shapes import Solid, part_solid
from handeye_pick.steps import Grip, Move, Step

DOWN = np.diag([1.0, -1.0, -1.0])  # the tool's z pointing down
PROBE = ToolShape("probe", np.eye(4), size_mm=(10.0, 10.0, 10.0))  # a 10 mm cube at the TCP


def _at(x: float, y: float, z: float, R: np.ndarray | None = None) -> Transform:
    return make_transform(np.eye(3) if R is None else R, [x, y, z])


def _check(
    boxes: tuple[SceneBox, ...],
    tool: tuple[ToolShape, ...] = (PROBE,),
    clearance_mm: float = 0.0,
    floor_z_mm: float | None = None,
) -> SceneCheck:
    scene = SceneConfig(boxes=boxes, floor_z_mm=floor_z_mm, clearance_mm=clearance_mm)
    return SceneCheck(scene, tool, np.eye(4))


def _failed(results: list[CheckResult]) -> CheckResult:
    refused = [r for r in results if not r.passed]
    assert len(refused) == 1, results
    return refused[0]


# --- the step: the smallest margin over rate --------------------------------------------------

PLATE = SceneBox("plate", (2.0, 100.0, 100.0), _at(0.2, 0.0, 0.5))  # 2 mm thick, across x


def test_a_near_solid_is_not_stepped_over_a_thin_plate_by_a_far_one() -> None:
    """The probe crosses a 2 mm plate while a solid 0.5 m above it rides far from everything:
    the step is the probe's margin over its rate, not the far solid's (which would clear the
    whole move in one step)."""
    mast = ToolShape("mast", _at(0.0, 0.0, 0.5), size_mm=(10.0, 10.0, 10.0))
    check = _check((PLATE,), tool=(PROBE, mast))
    results = check.check_tool([Move("beyond", _at(0.4, 0.0, 0.5))], _at(0.0, 0.0, 0.5))
    refused = _failed(results)
    # At 50 % the probe's centre is in the plate's: 5 + 1 mm to push it out along x.
    assert refused.detail == (
        "tool 'probe' would come 6 mm into box 'plate' at 50 % of the move to beyond"
    )


def test_a_move_longer_than_a_metre_is_not_stepped_over_a_thin_plate() -> None:
    """A 1.6 m move runs at 1.6 m per unit of the piece: the step is the margin divided by that
    rate (a margin times it would be 2.6 times too long and jump the plate)."""
    plate = SceneBox("plate", (2.0, 100.0, 100.0), _at(0.0, 0.0, 0.5))
    check = _check((plate,))
    results = check.check_tool([Move("across", _at(0.8, 0.0, 0.5))], _at(-0.8, 0.0, 0.5))
    assert _failed(results).detail == (
        "tool 'probe' would come 6 mm into box 'plate' at 50 % of the move to across"
    )


# --- the screen: a lower bound ----------------------------------------------------------------


def test_a_target_below_the_floor_is_refused_the_floor_slab_screened_by_its_half_size() -> None:
    """The floor is a slab 1 m thick under its plane; the bound that spares far pairs an exact
    distance measures from its real faces: a probe 50 mm under the plane is in it (a bound from
    a box a third its size would put it 117 mm clear and never measure it)."""
    check = _check((), clearance_mm=5.0, floor_z_mm=0.0)
    results = check.check_tool([Move("below", _at(0.0, 0.0, -0.05))], _at(0.0, 0.0, 0.2))
    assert _failed(results).detail == "tool 'probe' would come 55 mm into the floor at 100 % " + (
        "of the move to below"
    )


# --- margins carried from one piece to the next -----------------------------------------------

FIXTURE = SceneBox("fixture", (100.0, 100.0, 100.0), _at(0.0, 0.0, 0.0))  # top face at z 50 mm


def test_the_first_move_starts_from_its_own_margins_not_the_last_moves() -> None:
    """The probe stands 3 mm above a fixture (5 mm clearance) and moves away: refused at the
    start of the first move, whatever the margins at the end of the last move (far away)."""
    check = _check((FIXTURE,), clearance_mm=5.0)
    start = _at(0.0, 0.0, 0.058)  # the probe's bottom face 3 mm above the fixture's top
    steps: list[Step] = [Move("up", _at(0.0, 0.0, 0.158)), Move("over", _at(0.3, 0.0, 0.158))]
    results = check.check_tool(steps, start)
    assert results == [
        CheckResult(
            "collision",
            "up",
            False,
            "tool 'probe' would pass 3.0 mm from box 'fixture' at 0 % of the move to up, "
            "closer than the 5 mm it must keep",
        )
    ]


PART_MM = (50.0, 50.0, 50.0)
T_BASE_OBJ = _at(0.0, 0.0, 0.05, DOWN)  # a 50 mm cube on z 0: its top face's centre, z down
LIFTED = ToolShape("body", _at(0.0, 0.0, -0.01), size_mm=(10.0, 10.0, 10.0))  # above the TCP


def _pick_and_carry(then: list[Step]) -> list[Step]:
    """Down onto the cube, close, lift it 200 mm, then ``then``."""
    return [
        Move("approach", _at(0.0, 0.0, 0.25, DOWN)),
        Move("grasp", T_BASE_OBJ, slow=True),
        Grip(close=True),
        Move("retreat", _at(0.0, 0.0, 0.25, DOWN)),
        *then,
    ]


def test_the_held_part_keeps_the_clearance_from_the_move_after_its_lift_off() -> None:
    """A post stands 3 mm beside the cube. On the lift-off the part may touch what it is lifted
    past; the move after it must keep the clearance from its first pose on: its start is
    measured with the clearance, not carried from the lift-off's end (measured with contact)."""
    post = SceneBox("post", (20.0, 20.0, 400.0), _at(0.025 + 0.003 + 0.010, 0.0, 0.2))
    check = _check((post,), tool=(LIFTED,), clearance_mm=5.0)
    steps = _pick_and_carry([Move("place-approach", _at(-0.3, 0.0, 0.25, DOWN))])
    results = check.check(steps, _at(0.0, 0.0, 0.3, DOWN), PART_MM, T_BASE_OBJ, T_BASE_OBJ)
    assert [(r.target, r.passed) for r in results] == [("place-approach", False)]
    assert results[0].detail == (
        "the held part would pass 3.0 mm from box 'post' at 0 % of the move to the "
        "place-approach, closer than the 5 mm it must keep"
    )


def test_a_release_without_a_set_down_sweeps_the_tool_alone_after_it() -> None:
    """The gripper opens after a move that is no set-down (not slow): the move after it has the
    same contact (none) but other solids (the tool without the part), so it starts from margins
    of its own."""
    check = _check((FIXTURE,), tool=(LIFTED,), clearance_mm=5.0)
    part_obj = _at(0.0, 0.0, 0.10, DOWN)  # a cube on top of the fixture
    steps = [
        Move("approach", _at(0.0, 0.0, 0.35, DOWN)),
        Move("grasp", part_obj, slow=True),
        Grip(close=True),
        Move("retreat", _at(0.0, 0.0, 0.35, DOWN)),
        Move("drop", _at(0.3, 0.0, 0.35, DOWN)),
        Grip(close=False),
        Move("leave", _at(0.3, 0.0, 0.5, DOWN)),
    ]
    results = check.check(steps, _at(0.0, 0.0, 0.4, DOWN), PART_MM, part_obj, part_obj)
    assert [(r.target, r.passed) for r in results] == [
        ("approach", True),
        ("grasp", True),
        ("retreat", True),
        ("drop", True),
        ("leave", True),
    ]
    # The part rests on the fixture as it lifts off: touching, not a hair's breadth into it.
    assert results[2].detail == (
        "clear: closest the held part at least 0.0 mm from box 'fixture' (clearance 5 mm)"
    )


# --- a near miss: where its scan found the closest point --------------------------------------


@pytest.mark.parametrize(
    ("gap_m", "passed", "detail"),
    [
        (
            0.003,
            False,
            "tool 'probe' would pass 3.0 mm from box 'post' at 50 % of the move to pass, "
            "closer than the 5 mm it must keep",
        ),
        (
            0.0053,
            False,
            "tool 'probe' would pass 5.3 mm from box 'post' at 50 % of the move to "
            "pass, less than 0.5 mm beyond the 5 mm it must keep",
        ),
        (
            0.0064,
            True,
            "clear: closest tool 'probe' at least 6.4 mm from box 'post' (clearance 5 mm)",
        ),
    ],
    ids=["within the clearance", "within its last half millimetre", "clear"],
)
def test_a_near_miss_refusal_gives_the_closest_point_its_scan_found(
    gap_m: float, passed: bool, detail: str
) -> None:
    """The probe passes a post turned 45 degrees whose edge comes ``gap_m`` from it at mid-move.
    Within the clearance (or its last 0.5 mm, where the sweep cannot prove it kept it) the sweep
    stops where the probe first comes that close, before mid-move; the refusal scans the move
    and says where it came closest and how close. Farther, the move passes and says how close
    it came."""
    corner_y = 0.005 + gap_m  # the probe's side face at y 5 mm, the post's edge gap_m beyond
    turned = rotation_from_euler([0.0, 0.0, 45.0], "xyz", "deg")
    post = SceneBox(
        "post", (20.0, 20.0, 200.0), _at(0.0, corner_y + 0.01 * math.sqrt(2), 0.5, turned)
    )
    check = _check((post,), clearance_mm=5.0)
    results = check.check_tool([Move("pass", _at(0.1, 0.0, 0.5))], _at(-0.1, 0.0, 0.5))
    assert results == [CheckResult("collision", "pass", passed, detail)]


def test_the_first_look_at_a_grasp_says_it_is_at_the_end_of_the_descent() -> None:
    """An alternative's first look stands the tool at its grasp: a refusal there is at 100 %
    of the grasp descent."""
    check = _check((FIXTURE,), clearance_mm=5.0)
    refusal = check.descent_refusal(_at(0.0, 0.0, 0.3), _at(0.0, 0.0, 0.045))
    assert refusal == CheckResult(
        "collision",
        "grasp",
        False,
        "tool 'probe' would come 10 mm into box 'fixture' at 100 % of the grasp descent",
    )


# --- the property: what passes keeps the clearance between any two samples ---------------------

SAMPLE_M = 0.0005  # dense sampling: every 0.5 mm of the TCP's travel ...
SAMPLE_RAD = math.radians(0.5)  # ... and every 0.5 degree of its turn
EXACT_M = 1e-5  # what python-fcl's distances may be off by
_REQUEST = fcl.DistanceRequest(enable_signed_distance=True)


def _rotation(draw: st.DrawFn, max_deg: float) -> np.ndarray:
    angles = [draw(st.floats(-max_deg, max_deg)) for _ in range(3)]
    return rotation_from_euler(angles, "xyz", "deg")


@st.composite
def _tool(draw: st.DrawFn) -> tuple[ToolShape, ...]:
    """Two to four boxes and cylinders within 40 mm of the TCP's axis, 30 to 150 mm above it."""
    solids = []
    for i in range(draw(st.integers(2, 4))):
        x, y = draw(st.floats(-0.04, 0.04)), draw(st.floats(-0.04, 0.04))
        T = make_transform(_rotation(draw, 30.0), [x, y, -draw(st.floats(0.03, 0.15))])
        if draw(st.booleans()):
            size = tuple(draw(st.floats(5.0, 40.0)) for _ in range(3))
            solids.append(ToolShape(f"box {i}", T, size_mm=size))
        else:
            radius, length = draw(st.floats(5.0, 20.0)), draw(st.floats(10.0, 60.0))
            solids.append(ToolShape(f"cylinder {i}", T, radius_mm=radius, length_mm=length))
    return tuple(solids)


@dataclass(frozen=True)
class _Case:
    scene: SceneConfig
    tool: tuple[ToolShape, ...]
    steps: list[Step]
    start: Transform  # where the TCP stands before the first move
    part_mm: tuple[float, float, float]
    T_base_obj: Transform
    T_base_tcp_grasp: Transform


@st.composite
def _pick_and_place(draw: st.DrawFn) -> _Case:
    """A bin with thin walls around the origin, a part in it, a place 0.4 to 1.6 m away (turned
    and tilted, so the transfer may run faster than 1 m per unit of its piece), and thin plates
    and posts near the transfer between them; blended corners or stops."""
    part_mm = (
        draw(st.floats(20.0, 60.0)),
        draw(st.floats(20.0, 60.0)),
        draw(st.floats(20.0, 60.0)),
    )
    yaw = draw(st.floats(-180.0, 180.0))
    R_obj = rotation_from_euler([0.0, 0.0, yaw], "xyz", "deg") @ DOWN
    floor_z = 0.05
    T_base_obj = make_transform(
        R_obj,
        [draw(st.floats(-0.08, 0.08)), draw(st.floats(-0.04, 0.04)), floor_z + part_mm[2] / 1000],
    )
    grasp = T_base_obj @ _at(0.0, 0.0, draw(st.floats(0.0, part_mm[2] / 2000.0)))
    up = np.array([0.0, 0.0, 1.0])
    approach = make_transform(grasp[:3, :3], grasp[:3, 3] + 0.2 * up)
    retreat = make_transform(grasp[:3, :3], grasp[:3, 3] + draw(st.floats(0.22, 0.3)) * up)
    place_at = [draw(st.floats(0.4, 1.5)), draw(st.floats(-0.6, 0.6)), draw(st.floats(0.1, 0.3))]
    place = make_transform(_rotation(draw, 30.0) @ grasp[:3, :3], place_at)
    place_approach = make_transform(place[:3, :3], place[:3, 3] + draw(st.floats(0.1, 0.25)) * up)
    place_retreat = make_transform(place[:3, :3], place[:3, 3] + 0.15 * up)
    wall = draw(st.floats(2.0, 10.0))
    bin_ = BinConfig("parts", _at(0.0, 0.0, floor_z), (300.0, 200.0, 150.0), wall, wall)
    boxes = []
    for i in range(draw(st.integers(0, 3))):
        along = draw(st.floats(0.0, 1.0))
        centre = (1 - along) * retreat[:3, 3] + along * place_approach[:3, 3]
        centre += np.array([0.0, draw(st.floats(-0.15, 0.15)), draw(st.floats(-0.15, 0.1))])
        if draw(st.booleans()):  # a plate 1 to 3 mm thick
            size = (
                draw(st.floats(1.0, 3.0)),
                draw(st.floats(40.0, 300.0)),
                draw(st.floats(40.0, 300.0)),
            )
        else:  # a post
            size = (
                draw(st.floats(5.0, 20.0)),
                draw(st.floats(5.0, 20.0)),
                draw(st.floats(100.0, 500.0)),
            )
        boxes.append(SceneBox(f"obstacle {i}", size, make_transform(_rotation(draw, 90.0), centre)))
    blend = st.sampled_from([0.0, 0.02, 0.05])
    steps: list[Step] = [
        Move("approach", approach, blend_m=draw(blend)),
        Move("grasp", grasp, slow=True),
        Grip(close=True),
        Move("retreat", retreat, blend_m=draw(blend)),
        Move("place-approach", place_approach, blend_m=draw(blend)),
        Move("place", place, slow=True),
        Grip(close=False),
        Move("place-retreat", place_retreat),
    ]
    start = make_transform(
        grasp[:3, :3], [draw(st.floats(-0.2, 0.2)), draw(st.floats(-0.2, 0.2)), 0.5]
    )
    scene = SceneConfig(bins=(bin_,), boxes=tuple(boxes), clearance_mm=draw(st.floats(0.0, 8.0)))
    return _Case(scene, draw(_tool()), steps, start, part_mm, T_base_obj, grasp)


def _worst_margin(check: SceneCheck, path: list[Piece], part: Solid) -> float:
    """The smallest exact distance less what must be kept, of any solid to any obstacle, at
    every 0.5 mm and 0.5 degree along ``path``. Pairs whose bound (the solid's centre to the
    box, less its radius; computed here, not by the sweep) is more than 5 mm beyond what they
    must keep are far enough for any verdict and not measured."""
    obstacles = check.sweep.obstacles
    worst = math.inf
    for piece in path:
        travel, turn = piece.rate_m(0.0), piece.rate_m(1.0) - piece.rate_m(0.0)
        samples = max(math.ceil(travel / SAMPLE_M), math.ceil(turn / SAMPLE_RAD), 1) + 1
        poses = np.array([piece.pose(s) for s in np.linspace(0.0, 1.0, samples)])
        solids = [*check.tool, part] if piece.held else check.tool
        for solid in solids:
            contact = solid.part and piece.contact
            keep = -PART_CONTACT_M if contact else check.sweep.clearance_m
            T_base_solid = poses @ solid.T_tcp_solid
            centres = T_base_solid[:, :3, 3]
            for obstacle in obstacles:
                local = (centres - obstacle.T_base_box[:3, 3]) @ obstacle.T_base_box[:3, :3]
                outside = np.maximum(np.abs(local) - obstacle.size_m / 2.0, 0.0)
                bound = np.linalg.norm(outside, axis=1) - solid.radius_m
                for i in np.flatnonzero(bound < keep + 0.005).tolist():
                    solid.geometry.setRotation(T_base_solid[i, :3, :3])
                    solid.geometry.setTranslation(T_base_solid[i, :3, 3])
                    distance = fcl.distance(
                        solid.geometry, obstacle.geometry, _REQUEST, fcl.DistanceResult()
                    )
                    worst = min(worst, distance - keep)
    return worst


@settings(max_examples=100, deadline=None)
@given(_pick_and_place())
def test_a_passing_path_keeps_the_clearance_at_every_half_millimetre_and_half_degree(
    case: _Case,
) -> None:
    """Property: on random scenes (a bin with thin walls, thin plates, posts), tools of several
    solids and pick-and-place paths with a grasp, a lift-off and a set-down of the held part, a
    path the check passes comes within the clearance at no sample every 0.5 mm and 0.5 degree
    (the part within 2 mm into anything on its lift-off and set-down); one it refuses comes
    within the proof tolerance of it somewhere (the samples' spacing added)."""
    check = SceneCheck(case.scene, case.tool, np.eye(4))
    results = check.check(
        case.steps, case.start, case.part_mm, case.T_base_obj, case.T_base_tcp_grasp
    )
    passed = all(r.passed for r in results)
    part = part_solid(case.part_mm, invert(case.T_base_tcp_grasp) @ case.T_base_obj)
    worst = _worst_margin(check, pieces(case.steps, case.start), part)
    if passed:
        assert worst >= -EXACT_M
    else:
        reach = max(solid.reach_m for solid in [*check.tool, part])
        assert worst < PROOF_TOLERANCE_M + SAMPLE_M + SAMPLE_RAD * reach + EXACT_M
