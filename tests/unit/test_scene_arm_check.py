"""The whole arm's swept check (scene/arm_collide.py, docs/scene.md): a link the tool-only
check cannot see is refused by name, a moveJ is swept, the tool is checked against the arm's own
upper arm, a path through a singularity is refused by name, ``scene.arm: unchecked`` keeps the
tool-only results exactly (and says so), and the grasp alternatives are chosen with the arm.
And the property behind them: on random obstacles near the arm's path, a path the check passes
keeps the clearance at every look of a path sampled ten times as densely, by python-fcl."""

from __future__ import annotations

import tempfile
import uuid
from pathlib import Path

import fcl
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from handeye_pick.arm.kinematics import link_poses, tcp_poses
from handeye_pick.arm.models import arm_model
from handeye_pick.cell.plan import choose
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import CellConfig, SceneBox, SceneConfig, ToolShape
from handeye_pick.geometry import Transform, invert, make_transform
from handeye_pick.hand_eye.files import load_hand_eye
from handeye_pick.safety import CheckResult
from handeye_pick.scene.arm_legs import legs
from handeye_pick.scene.check import SceneCheck
from handeye_pick.steps import JointMove, Move, Step
from tests.unit.test_cell_session import ScriptedArm
from tests.unit.test_scene import T_BASE_FLANGE, TOOL, _part

MODEL = arm_model("ur5e")
T_FLANGE_TCP = make_transform(np.eye(3), [0.0, 0.0, 0.15])
Q_START = np.array([0.0, -1.63039, 1.338517, -1.278923, -1.570796, 0.0])  # config/bin.yaml
T_START = tcp_poses(MODEL, Q_START, T_FLANGE_TCP)[0]
PROBE = ToolShape("probe", invert(T_FLANGE_TCP), size_mm=(20.0, 20.0, 20.0))  # at the TCP
FAR = SceneBox("far", (10.0, 10.0, 10.0), make_transform(np.eye(3), [-2.0, -2.0, 0.0]))


def _lowered(by_m: float) -> Transform:
    T = T_START.copy()
    T[2, 3] -= by_m
    return T


DESCENT: list[Step] = [Move("approach", _lowered(0.05)), Move("grasp", _lowered(0.15), slow=True)]


def _check(
    boxes: tuple[SceneBox, ...],
    tool: tuple[ToolShape, ...] = (PROBE,),
    checked: bool = True,
) -> SceneCheck:
    scene = SceneConfig(boxes=(FAR, *boxes), clearance_mm=5.0, arm_checked=checked)
    return SceneCheck(scene, tool, T_FLANGE_TCP, MODEL)


def _refusal(results: list[CheckResult]) -> CheckResult:
    refused = [r for r in results if not r.passed]
    assert len(refused) == 1, results
    return refused[0]


def _box_at_link(link: str, q: np.ndarray, name: str, size_mm: float = 30.0) -> SceneBox:
    """A cube centred on the link's solid at the joints ``q``."""
    index = [solid.name for solid in MODEL.links].index(link)
    centre = link_poses(MODEL, q)[0, index, :3, 3]
    return SceneBox(name, (size_mm,) * 3, make_transform(np.eye(3), centre))


def _end_joints(steps: list[Step]) -> np.ndarray:
    return legs(MODEL, T_FLANGE_TCP, steps, T_START, Q_START)[-1].path.q[-1]


def test_a_forearm_against_a_post_is_refused_by_name_with_a_clear_tool() -> None:
    post = _box_at_link("forearm", _end_joints(DESCENT), "post")
    scene = SceneConfig(boxes=(FAR, post), clearance_mm=5.0)
    tool_only = SceneCheck(scene, (PROBE,), T_FLANGE_TCP)  # no model: the tool alone
    assert all(r.passed for r in tool_only.check_tool(DESCENT, T_START))
    refused = _refusal(_check((post,)).check_tool(DESCENT, T_START, tuple(Q_START)))
    # The forearm moves half as far as the TCP: it meets the post before the descent.
    assert (refused.name, refused.target) == ("arm collision", "approach")
    assert refused.detail == (
        "forearm would come 8 mm into box 'post' at 100 % of the move to the approach"
    )


def test_a_wrist_against_a_wall_is_refused_with_the_tool_clear() -> None:
    """A plate beside the wrist at the end of the descent: the probe passes 100 mm from it."""
    q = _end_joints(DESCENT)
    index = [solid.name for solid in MODEL.links].index("wrist 1")
    wrist = link_poses(MODEL, q)[0, index, :3, 3]
    tcp = tcp_poses(MODEL, q, T_FLANGE_TCP)[0, :3, 3]
    assert wrist[2] - tcp[2] > 0.1  # the wrist rides well above the probe
    wall = SceneBox("wall", (300.0, 300.0, 20.0), make_transform(np.eye(3), wrist))
    results = _check((wall,)).check_tool(DESCENT, T_START, tuple(Q_START))
    assert [r.name for r in results if r.passed] == ["collision", "collision"]
    assert _refusal(results).detail.startswith("wrist")
    assert "into box 'wall'" in _refusal(results).detail


def test_a_move_j_through_a_fixture_is_refused() -> None:
    """Joint 1 turns 1 rad: the elbow sweeps an arc through a fixture standing at its middle,
    clear of the arm at both ends (a moveJ's TCP path is no line: only the arm check sees it)."""
    q_to = Q_START + np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    fixture = _box_at_link("elbow", Q_START + np.array([0.5, 0, 0, 0, 0, 0]), "fixture", 40.0)
    check = _check((fixture,))
    steps: list[Step] = [JointMove("home", tuple(q_to))]
    refused = _refusal(check.check_tool(steps, T_START, tuple(Q_START)))
    assert (refused.name, refused.target) == ("arm collision", "home")
    assert refused.detail == "elbow would come 80 mm into box 'fixture' at 47 % of the move to home"


def test_the_tool_against_the_arms_own_upper_arm_is_refused() -> None:
    """A hose clamped to the tool reaches back to where the upper arm is."""
    F6 = tcp_poses(MODEL, Q_START, np.eye(4))[0]
    index = [solid.name for solid in MODEL.links].index("upper arm")
    T_base_upper = link_poses(MODEL, Q_START)[0, index]
    hose = ToolShape("hose", invert(F6) @ T_base_upper, size_mm=(30.0, 30.0, 30.0))
    refused = _refusal(_check((), tool=(PROBE, hose)).check_tool(DESCENT, T_START, Q_START))
    assert refused.detail.startswith("tool 'hose' would come ")
    assert "into the arm's upper arm at 0 % of the move to the approach" in refused.detail


def test_a_path_through_the_wrist_singularity_is_refused_by_name() -> None:
    q_from = np.array([0.3, -1.2, 1.2, -1.5, 0.1, 0.2])
    q_to = q_from + np.array([0, 0, 0, 0, -0.2, 0])
    T_from, T_to = (tcp_poses(MODEL, q, T_FLANGE_TCP)[0] for q in (q_from, q_to))
    results = _check(()).check_tool([Move("place", T_to, slow=True)], T_from, tuple(q_from))
    refused = _refusal(results)
    assert (refused.name, refused.target) == ("joint path", "place")
    assert refused.detail == (
        "the arm cannot follow the place descent at 33 %: wrist 2 comes within 2 deg of lining "
        "up joints 4 and 6 (the wrist singularity)"
    )


def test_unchecked_keeps_the_tool_only_results_exactly_and_says_so() -> None:
    post = _box_at_link("forearm", _end_joints(DESCENT), "post")
    boxes = (FAR, post)
    tool_only = SceneCheck(SceneConfig(boxes=boxes, clearance_mm=5.0), (PROBE,), T_FLANGE_TCP)
    unchecked = _check((post,), checked=False)
    expected = tool_only.check_tool(DESCENT, T_START)
    note, *results = unchecked.check_tool(DESCENT, T_START, tuple(Q_START))
    assert results == expected
    assert note == CheckResult(
        "arm collision",
        "path",
        True,
        "the arm is not checked (scene.arm: unchecked): only the tool and the held part are",
    )


# --- the alternatives -------------------------------------------------------------------------


def _bin_config(folder: Path, arm: str) -> CellConfig:
    """A deep bin (400 x 400 x 240 mm inside) whose east wall stands in the way of wrist 1 for
    a straight grasp of a part 70 mm from it; tilts up to 30 deg."""
    (folder / "eth.yaml").write_text(
        "[[1, 0, 0, -400], [0, -1, 0, 0], [0, 0, -1, 1000], [0, 0, 0, 1]]\n"
    )
    (folder / "cell.yaml").write_text(
        f"""
robot: {{host: scripted-{uuid.uuid4().hex}, tcp_offset: [0, 0, 0.15, 0, 0, 0], model: ur5e}}
hand_eye:
  {{mode: eye-to-hand, file: {folder / "eth.yaml"}, units: mm, camera_position_mm: [-400, 0, 1000]}}
grasp: {{approach_mm: 100, retreat_mm: 100, object_T_tcp: [0, 0, 0.025, 0, 0, 0], tilt_max_deg: 30}}
motion: {{speed_mps: 0.25, accel_mps2: 1.2, grasp_speed_mps: 0.05}}
workspace: {{min_mm: [-800, -800, 0], max_mm: [800, 800, 800], max_tilt_deg: 45}}
audit: {{file: picks.jsonl}}
scene:
  arm: {arm}
  clearance_mm: 5
  floor_z_mm: 0
  bins:
    - {{name: parts, pose: [-0.4, 0, 0.05, 0, 0, 0], inner_mm: [400, 400, 240], wall_mm: 10,
       floor_mm: 10}}
{TOOL.replace("BODY", "50")}
"""
    )
    return load_config(folder / "cell.yaml")


def _chosen_tilt(arm: str) -> tuple[float, list[str]]:
    with tempfile.TemporaryDirectory() as folder:
        config = _bin_config(Path(folder), arm)
        calibration = load_hand_eye(
            config.hand_eye.file, config.hand_eye.mode, config.hand_eye.units
        )
        chosen, _ = choose(
            config,
            calibration,
            [_part(0.13, 0.0, 90.0)],
            T_BASE_FLANGE,
            T_FLANGE_TCP,
            ScriptedArm(Path(folder) / "picks.jsonl"),
            {},
            T_base_tcp_place=None,
            grip=True,
        )
    assert chosen.alternative is not None
    return chosen.alternative.tilt_deg, [r for o in chosen.others for r in o.reasons]


def test_a_tilted_grasp_is_chosen_because_the_straight_ones_wrist_hits() -> None:
    tilt, reasons = _chosen_tilt("checked")
    assert tilt > 0.0
    assert reasons[0].startswith("grasp arm collision: wrist 1 would come ")
    assert "into bin 'parts' wall 'east' at 100 % of the grasp descent" in reasons[0]
    assert _chosen_tilt("unchecked")[0] == 0.0  # the tool alone sees nothing in the way


# --- the property -----------------------------------------------------------------------------

_REQUEST = fcl.DistanceRequest(enable_signed_distance=True)
_DENSE = 10  # looks per step of the check's own path


def _dense_distance(boxes: tuple[SceneBox, ...], steps: list[Step]) -> float:
    """The smallest distance (m) of any link from the upper arm on to any box, at ten looks per
    step of every move's joint path (each on the path: the model's IK)."""
    objects = [
        fcl.CollisionObject(fcl.Box(*(np.array(b.size_mm) / 1000.0)), fcl.Transform(
            b.T_base_box[:3, :3], b.T_base_box[:3, 3]))
        for b in boxes
    ]
    links = [
        fcl.CollisionObject(
            fcl.Capsule(link.radius_m, link.length_m)
            if link.kind == "capsule"
            else fcl.Cylinder(link.radius_m, link.length_m)
        )
        for link in MODEL.links
    ]
    nearest = np.inf
    for leg in legs(MODEL, T_FLANGE_TCP, steps, T_START, Q_START):
        q, s = leg.path.q, leg.path.s
        t = np.linspace(0.0, 1.0, _DENSE, endpoint=False)
        s_dense = (s[:-1, None] + t * np.diff(s)[:, None]).ravel()
        q0 = np.repeat(q[:-1], _DENSE, axis=0)
        q1 = np.repeat(q[1:], _DENSE, axis=0)
        dense = leg.between(MODEL, T_FLANGE_TCP, s_dense, q0, q1)
        for poses in link_poses(MODEL, dense):
            for index, link in enumerate(links[1:], start=1):  # not the shoulder
                link.setRotation(poses[index, :3, :3])
                link.setTranslation(poses[index, :3, 3])
                for obstacle in objects:
                    nearest = min(
                        nearest, fcl.distance(link, obstacle, _REQUEST, fcl.DistanceResult())
                    )
    return nearest


@settings(max_examples=25, deadline=None)
@given(
    link=st.sampled_from(["forearm", "wrist 1", "wrist 2", "elbow"]),
    offset=st.tuples(*[st.floats(-0.15, 0.15)] * 3),
    size_mm=st.floats(10.0, 80.0),
)
def test_a_path_the_check_passes_keeps_the_clearance_at_dense_looks(
    link: str, offset: tuple[float, float, float], size_mm: float
) -> None:
    """Boxes near where a link ends the descent: never clear where a denser look collides."""
    box = _box_at_link(link, _end_joints(DESCENT), "box", size_mm)
    box = SceneBox("box", box.size_mm, make_transform(np.eye(3), box.T_base_box[:3, 3] + offset))
    results = _check((box,)).check_tool(DESCENT, T_START, tuple(Q_START))
    if all(r.passed for r in results):
        assert _dense_distance((box,), DESCENT) >= 0.005 - 1e-6
