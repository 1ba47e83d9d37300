"""Guards on blended paths a one-line change could remove unnoticed (issue 32, items 1, 3, 4 and
5): a missed grasp or a dropped part ends a blended sequence where it must, a move that needs
the operator's confirmation never runs inside a path, the watchdog is armed again after ur_rtde
uploads a path's program, and the radii the controller receives (the last one 0, none under
``MIN_BLEND_M``, the first one clamped to the room left from where the arm stands).

Everything runs through the Cell (or its arm, for the adapter's own rule) and the real ur_rtde
against the simulated controller, and is judged on what the controller saw and did: the rows
of each ``movePath`` it received (its command record), how each motion ended (its motion
record), where the arm stands (its snapshot), and the reply and the audit.
"""

from __future__ import annotations

import json
import os
import signal
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rtde_control

from handeye_pick import Cell, RobotConnectionError, load_detection
from handeye_pick.cell.blend import BLEND_SHARE, MIN_BLEND_M
from handeye_pick.cell.sequence import execute
from handeye_pick.config.schema import NamedPose
from handeye_pick.geometry import Transform, make_transform, ur_pose_to_matrix
from handeye_pick.progress import Progress
from handeye_pick.robot.port import Waypoint
from handeye_pick.runner import Runner
from handeye_pick.steps import Move
from mocks.ur_controller import SimulatedController
from tests.conftest import TEST_WATCHDOG_S
from tests.integration.handeye_cell import ur_rtde_child_pid, wait_until
from tests.integration.test_gripper_pick import (
    PART_MM,
    PLACE,
    robotiq_config,
)
from tests.integration.test_guards_motion import _DuringMove
from tests.integration.test_pick_cli import (
    DEMO,
    TCP_OFFSET,
    audit_records,
    motion_commands,
    write_config,
)

SimFactory = Callable[..., SimulatedController]
DETECTION = DEMO / "detection.yaml"
BLEND_MM = 20.0
BLENDED = (
    f"  speed_mps: 0.25\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.1\n  blend_mm: {BLEND_MM}\n"
    "  blend_always: true\n"  # paths whatever a path start costs
)


def _paths(ctl: SimulatedController) -> list[dict[str, Any]]:
    """Every movePath the controller ran (its command record): the rows it received."""
    return [c for c in ctl.commands if c["kind"] == "movePath"]


def _targets(tmp_path: Path) -> dict[str, np.ndarray]:
    """The TCP targets of the last plan record (UR vectors), by move name, as positions (m)."""
    plan = [r for r in audit_records(tmp_path) if r["event"] == "plan"][-1]
    return {name: np.array(pose[:3]) for name, pose in plan["targets"].items()}


def _pick_request(runner: Runner, request_id: str) -> dict[str, Any]:
    """Capture where the arm stands and pick the demo detection seen from there, as the run
    loop's client asks it; the reply."""
    captured = runner.handle(json.dumps({"id": f"{request_id}-capture", "op": "capture"}))
    assert captured["ok"], captured
    position_mm = load_detection(DETECTION).T_cam_obj[:3, 3] * 1000.0
    request = {
        "id": request_id,
        "op": "pick",
        "capture_id": captured["capture_id"],
        "candidates": [{"position_mm": position_mm.tolist()}],
    }
    return runner.handle(json.dumps(request))


def _sent_positions(ctl: SimulatedController) -> list[np.ndarray]:
    """Every TCP position the controller was told to go to: moveL targets, path waypoints."""
    sent = [np.array(c["target"][:3]) for c in ctl.commands if c["kind"] == "moveL"]
    return sent + [np.array(w[:3]) for c in _paths(ctl) for w in c["waypoints"]]


# --- item 1: a missed grasp, a dropped part ---------------------------------------------------


def test_a_missed_grasp_under_blending_ends_at_the_retreat_and_never_heads_for_the_place(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards ``path_at(steps, index, run.last_move)`` in cell/sequence.py ``execute`` (and the
    ``last_move`` break of ``path_at``): blended, the retreat is a corner of the transfer path
    (retreat -> place-approach -> place); after a miss it must be where the sequence ends. With
    ``None`` for the missed grasp's last move the arm drove on to the place, gripper empty."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)  # no part: the gripper misses
    config = robotiq_config(tmp_path, ctl.host, place=PLACE, motion=BLENDED)
    with Cell(config) as cell:
        reply = _pick_request(Runner(cell), "p")
        assert cell.halted is None
    assert (reply["ok"], reply["status"]) == (False, "missed"), reply
    targets = _targets(tmp_path)
    plan = [r for r in audit_records(tmp_path) if r["event"] == "plan"][-1]
    assert "retreat" in plan["blends_mm"]  # the retreat was planned as a corner, not a stop
    # The arm stands at the retreat, at rest, and was never sent towards the place.
    snapshot = ctl.snapshot()
    assert not snapshot.moving
    np.testing.assert_allclose(snapshot.tcp_pose[:3], targets["retreat"], atol=1e-5)
    for sent in _sent_positions(ctl):
        for name in ("place-approach", "place", "place-retreat"):
            assert np.linalg.norm(sent - targets[name]) > 0.05, (name, sent)
    kinds = [c["kind"] for c in ctl.commands]
    assert kinds == ["movePath", "setPayload", "moveL"], kinds  # down, empty tool, retreat
    outcome = audit_records(tmp_path)[-1]
    assert outcome["status"] == "missed"
    assert list(outcome["reached"]) == ["grasp", "retreat"]
    np.testing.assert_allclose(outcome["reached"]["retreat"][:3], targets["retreat"], atol=1e-5)


def test_a_part_dropped_along_the_blended_transfer_stops_the_arm_short_of_the_place(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards the watch over a carried part along a blended path (cell/sequence.py ``_drive``:
    ``watched = self.gripper if self.grasp is GraspState.CONFIRMED``, and ``_watching``): the
    part slips out a fifth of the way along the transfer path (motion 2: retreat ->
    place-approach -> place, about 0.6 m); the arm brakes there, the reply and the audit say
    dropped, and nothing heads for the place afterwards. Real-time motion (no ``instant``)."""
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, part_width_mm=PART_MM, inject=("gripper-drop@move:2:0.2",)
    )
    config = robotiq_config(tmp_path, ctl.host, place=PLACE, motion=BLENDED)
    with Cell(config) as cell:
        reply = _pick_request(Runner(cell), "p")
        assert cell.halted is not None
    assert (reply["ok"], reply["status"]) == (False, "dropped"), reply
    targets = _targets(tmp_path)
    assert wait_until(lambda: len(ctl.motions) == 2)
    transfer = ctl.motions[1]
    assert (transfer["kind"], transfer["end"]) == ("movePath", "stopped"), transfer
    assert [c["kind"] for c in ctl.commands][-3:] == ["movePath", "stopL", "setPayload"]
    stopped_at = np.array(ctl.snapshot().tcp_pose[:3])
    # Braked on the way: far from the place approach (the path's second corner, 0.51 m from the
    # retreat), nowhere near the place.
    assert np.linalg.norm(stopped_at - targets["place-approach"]) > 0.2, stopped_at
    outcome = audit_records(tmp_path)[-1]
    assert outcome["status"] == "dropped"
    assert outcome["step"] in ("retreat", "place-approach"), outcome
    assert "place-approach" not in outcome["reached"]
    assert ctl.snapshot().payload_kg == 1.0  # the empty tool's again


# --- item 3: a confirmed move is never part of a path ------------------------------------------


def test_a_touch_test_in_a_blended_cell_confirms_every_move_before_it_is_sent(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards ``blend=pick.touch is None`` (cell/pick.py) and ``path_at(...) if before_move is
    None else []`` (cell/sequence.py): a touch test asks the operator before each move, so even
    in a cell with ``blend_mm`` set each move is planned as a stop, confirmed, then sent as its
    own moveL: the controller has every earlier move and not this one when the operator is
    asked. (No other test had blends and confirmations together.)"""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host, motion=BLENDED)
    asked: list[tuple[str, int]] = []

    def before_move(name: str) -> None:
        asked.append((name, len(motion_commands(ctl))))

    with Cell(config) as cell:
        result = cell.touch_test(load_detection(DETECTION), 0.02, before_move=before_move)
        assert cell.halted is None
    assert [name for name, _ in asked] == list(result.reached)
    assert [sent for _, sent in asked] == list(range(len(asked)))
    assert len(asked) == 3
    assert [c["kind"] for c in ctl.commands] == ["moveL"] * 3
    plan = [r for r in audit_records(tmp_path) if r["event"] == "plan"][-1]
    assert "blends_mm" not in plan  # every target a stop


def test_a_sequence_with_confirmations_runs_blended_moves_one_by_one(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards ``path_at(...) if before_move is None else []`` in cell/sequence.py ``execute``
    on its own: moves that do carry radii, run with ``before_move``, are each confirmed and
    sent as a single moveL; built as one path they ran without a single confirmation."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host, motion=BLENDED)
    asked: list[tuple[str, int]] = []
    with Cell(config) as cell:
        T_start = cell.arm.tcp_pose()
        over = T_start.copy()
        over[:3, 3] += [0.05, 0.05, 0.0]
        down = over.copy()
        down[2, 3] -= 0.05
        steps = [
            _move("over", over, blend_m=0.01),
            _move("down", down, blend_m=0.01),
            _move("back", T_start),
        ]
        execute(
            cell.config,
            steps,
            cell.arm,
            Progress.quiet(),
            {},
            before_move=lambda name: asked.append((name, len(motion_commands(ctl)))),
        )
    assert asked == [("over", 0), ("down", 1), ("back", 2)]
    assert [c["kind"] for c in ctl.commands] == ["moveL"] * 3


def _move(name: str, T: Transform, blend_m: float = 0.0) -> Move:
    return Move(name, T, blend_m=blend_m)


# --- item 4: the watchdog after a path's upload -----------------------------------------------


def test_a_client_that_goes_silent_mid_path_is_stopped_by_the_watchdog(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards ``self._arm_watchdog()`` after ``moveL(path)`` in robot/ur/worker.py
    ``move_l_path_async``: ur_rtde stops the control script and uploads it again with the
    path, and the new program has no watchdog until one is set (the simulator models that).
    The ur_rtde process is frozen (SIGSTOP) a twentieth of the way along the path down to the
    grasp; the controller must stop the program within the watchdog window, with the arm far
    short of the grasp. Without the re-arm the path runs on to its end. The path runs at half
    speed (about 4 s) so the window (1 s) ends well inside it on a loaded machine too."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=0.5)
    config = write_config(tmp_path, ctl.host, motion=BLENDED)
    frozen: dict[str, Any] = {}

    def freeze_the_client() -> None:
        pid = ur_rtde_child_pid(ctl.host)
        os.kill(pid, signal.SIGSTOP)
        frozen["at"] = ctl.snapshot()
        # The parent waits here (its own calls would only time out on a frozen child) until the
        # path's motion has ended, whatever ended it, then kills the frozen child.
        ended = wait_until(lambda: len(ctl.motions) >= 1, within_s=30.0)
        frozen["motion"] = ctl.motions[0] if ended else None
        os.kill(pid, signal.SIGKILL)

    progress = _DuringMove("approach -> grasp", 0.05, freeze_the_client)
    with Cell(config, progress=progress) as cell:
        with pytest.raises(RobotConnectionError):
            cell.pick(load_detection(DETECTION))
        assert cell.halted is not None
    assert progress.fired
    motion = frozen["motion"]
    assert motion is not None
    assert motion["kind"] == "movePath"
    assert motion["end"].startswith("program stopped: RTDE watchdog"), motion
    assert motion["watchdog_min_frequency_hz"] == pytest.approx(1.0 / TEST_WATCHDOG_S)
    assert motion["end_t"] - motion["watchdog_last_update_t"] <= TEST_WATCHDOG_S + 0.005
    # Where it stopped: no farther from where it was when the client froze than the path's top
    # speed covers until the stop (a program stop halts at once: no braking distance), a stop
    # within the window of the client's last write (asserted above; a simulator running late
    # stamps that write by its arrival, a few cycles after the frozen snapshot's time), and far
    # from the grasp at the path's end.
    at = np.array(frozen["at"].tcp_pose[:3])
    stopped = np.array(ctl.snapshot().tcp_pose[:3])
    top_speed_mps = 0.25 * 0.5  # the config's speed at the simulator's speed factor
    moving_s = motion["end_t"] - frozen["at"].time_s
    assert moving_s <= TEST_WATCHDOG_S + 0.1, moving_s
    assert np.linalg.norm(stopped - at) <= top_speed_mps * (moving_s + 0.002) + 0.002
    grasp = _targets(tmp_path)["grasp"]
    assert np.linalg.norm(stopped - grasp) > 0.05, stopped


# --- item 5: the radii the controller receives --------------------------------------------------


def test_a_paths_last_radius_reaches_the_controller_as_zero(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards ``rows[-1][8] = 0.0`` in robot/ur/arm.py ``move_path``: whatever the last
    waypoint says, the controller receives 0 there, and the arm ends at rest on it."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with Cell(write_config(tmp_path, ctl.host)) as cell:
        T_start = cell.arm.tcp_pose()
        first, last = T_start.copy(), T_start.copy()
        first[:3, 3] += [0.06, 0.0, 0.0]
        last[:3, 3] += [0.06, 0.06, 0.0]
        reached = cell.arm.move_path(
            [Waypoint(first, 0.25, 1.2, 0.01), Waypoint(last, 0.25, 1.2, 0.01)], 30.0
        )
    (path,) = _paths(ctl)
    assert path["radii"] == [0.01, 0.0]
    assert ctl.motions[-1]["end"] == "reached"
    np.testing.assert_allclose(reached[:3, 3], last[:3, 3], atol=1e-5)


def test_a_corner_with_less_room_than_min_blend_is_sent_as_a_stop(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards ``radius if radius >= MIN_BLEND_M else 0.0`` in cell/blend.py ``corner_radius``:
    the retreat rises only 0.3 mm beyond the straight part of the ascent, so its corner would
    be 0.3 mm; it must reach the controller as a stop (the retreat its own moveL), and no path
    the controller receives has a radius between 0 and ``MIN_BLEND_M``."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    grasp = "  approach_mm: 100\n  retreat_mm: 20.3\n  straight_mm: 20\n"
    config = write_config(tmp_path, ctl.host, grasp=grasp, place=PLACE, motion=BLENDED)
    with Cell(config) as cell:
        assert cell.pick(load_detection(DETECTION)).status == "placed"
    radii = [r for path in _paths(ctl) for r in path["radii"]]
    assert all(r == 0.0 or r >= MIN_BLEND_M for r in radii), radii
    assert radii == [0.02, 0.0, 0.02, 0.0], radii  # approach; place-approach
    targets = _targets(tmp_path)
    moves = [np.array(c["target"][:3]) for c in ctl.commands if c["kind"] == "moveL"]
    np.testing.assert_allclose(moves[0], targets["retreat"], atol=1e-6)  # a stop of its own
    plan = [r for r in audit_records(tmp_path) if r["event"] == "plan"][-1]
    assert set(plan["blends_mm"]) == {"approach", "place-approach"}


@pytest.mark.parametrize("away_mm", [8.0, 0.8], ids=["clamped", "too-close-a-stop"])
def test_the_first_corner_takes_no_more_than_its_share_of_the_room_left(
    sim_controller: SimFactory, tmp_path: Path, away_mm: float
) -> None:
    """Guards ``_first_corner`` (cell/sequence.py): a pick planned from the capture pose gives
    its approach a 20 mm corner; the arm then moved to ``away_mm`` beside the approach point
    before the pick ran. The radius sent is ``BLEND_SHARE`` of that room (3.6 mm), or 0 (a stop)
    when that share is under ``MIN_BLEND_M`` (0.8 mm: 0.36 mm)."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with Cell(write_config(tmp_path, ctl.host, motion=BLENDED)) as cell:
        capture = cell.capture()
        detection = load_detection(DETECTION)
        approach = cell.plan(detection, capture.T_base_flange).approach
        beside = make_transform(approach[:3, :3], approach[:3, 3] + [away_mm / 1000.0, 0, 0])
        cell.move_to(NamedPose("beside", None, beside))
        assert cell.pick(detection, capture).status == "picked"
    plan = [r for r in audit_records(tmp_path) if r["event"] == "plan"][-1]
    assert plan["blends_mm"]["approach"] == BLEND_MM  # as planned from the capture pose
    first = _paths(ctl)[0]
    room_m = BLEND_SHARE * away_mm / 1000.0
    expected = room_m if room_m >= MIN_BLEND_M else 0.0
    assert first["radii"][0] == pytest.approx(expected, abs=1e-6), first["radii"]
    np.testing.assert_allclose(
        ur_pose_to_matrix(first["waypoints"][0])[:3, 3], approach[:3, 3], atol=1e-5
    )


def test_the_simulator_drops_the_watchdog_with_a_path_upload_until_it_is_set_again(
    sim_controller: SimFactory,
) -> None:
    """What the test above relies on, seen from ur_rtde itself (no handeye_pick): a watchdog
    armed before ``moveL(path)`` does not survive the path's upload, so a client silent for
    three windows leaves the path running to its end; armed again on the new program, the
    same silence stops it."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET)  # real-time motion
    control = rtde_control.RTDEControlInterface(ctl.host)
    try:
        assert control.setWatchdog(10.0)  # a 0.1 s window
        start = list(ctl.snapshot().tcp_pose)
        path = []
        for dx, dy in ((0.1, 0.0), (0.1, 0.1)):
            pose = [start[0] + dx, start[1] + dy, *start[2:]]
            path.append([*pose, 0.25, 1.2, 0.02 if not path else 0.0])
        assert control.moveL(path, True)  # about 1 s of motion; then the client is silent
        time.sleep(0.3)
        assert ctl.snapshot().program_running
        assert wait_until(lambda: len(ctl.motions) == 1)
        assert ctl.motions[0]["end"] == "reached"
        back = [[*start, 0.25, 1.2, 0.0]]
        assert control.moveL(back, True)  # a new upload; this time armed again
        assert control.setWatchdog(10.0)
        assert wait_until(lambda: not ctl.snapshot().program_running)
        assert wait_until(lambda: len(ctl.motions) == 2)
        assert ctl.motions[1]["end"].startswith("program stopped: RTDE watchdog")
    finally:
        control.disconnect()
