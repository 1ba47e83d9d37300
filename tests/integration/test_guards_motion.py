"""Guards on motion that a one-line change could remove unnoticed (issue 21): the steady capture,
the dashboard stop after a lost link, the fresh state check before each move, and the grasp
speed cap of the preflight and of the sequence.

Everything runs through the Cell and the real ur_rtde against the simulated controller, and is
judged on what the controller saw (its command and motion records, its snapshot). A capture
"while the arm moves" is a capture asked from inside a move's progress callback: the Cell is
single-threaded, so that is the one public moment at which the arm is really moving.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from handeye_pick import (
    Cell,
    PreflightRefusal,
    RobotConnectionError,
    RobotFault,
    SafetyRefusal,
    load_detection,
)
from handeye_pick.cell.sequence import execute
from handeye_pick.geometry import Transform, invert, ur_pose_to_matrix
from handeye_pick.limits import MAX_GRASP_SPEED_MPS, MAX_SPEED_MPS
from handeye_pick.progress import Progress
from handeye_pick.steps import Move
from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import (
    DEMO,
    TCP_OFFSET,
    audit_records,
    motion_commands,
    write_config,
)

SimFactory = Callable[..., SimulatedController]
DETECTION = DEMO / "detection.yaml"


class _DuringMove(Progress):
    """Progress that runs ``action`` once from inside the move ``step_name``, as soon as the
    move reports ``fraction`` done; what ``action`` returned is in ``result``."""

    def __init__(self, step_name: str, fraction: float, action: Callable[[], Any]) -> None:
        super().__init__(None)
        self._step_name, self._fraction, self._action = step_name, fraction, action
        self.fired = False
        self.result: Any = None

    @contextmanager
    def step(self, name: str) -> Iterator[Callable[[float], None]]:
        with super().step(name) as report:
            if name != self._step_name:
                yield report
                return

            def report_and_act(fraction: float) -> None:
                report(fraction)
                if fraction >= self._fraction and not self.fired:
                    self.fired = True
                    self.result = self._action()

            yield report_and_act


def _lowered_pose(ctl: SimulatedController, metres: float) -> list[float]:
    """The TCP pose (UR vector) ``metres`` below where the simulated arm stands now."""
    pose = list(ctl.snapshot().tcp_pose)
    pose[2] -= metres
    return pose


def _actual_flange(ctl: SimulatedController) -> Transform:
    """The flange where the (lagging) arm really is: RTDE's actual TCP without the TCP offset."""
    snapshot = ctl.snapshot()
    return ur_pose_to_matrix(list(snapshot.actual_tcp_pose)) @ invert(
        ur_pose_to_matrix(list(snapshot.tcp_offset))
    )


def _eventually(condition: Callable[[], bool], within_s: float = 5.0) -> bool:
    deadline = time.monotonic() + within_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


# --- a capture latches the flange only once the arm is steady -------------------------------------


def test_a_capture_while_the_arm_moves_waits_and_latches_the_settled_flange_pose(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards URRtdeArm.steady_flange_pose (robot/ur/arm.py, ``steady = fastest_rps <=
    STEADY_JOINT_SPEED_RPS`` / ``if steady and steady_before``): the pose is latched only from
    samples of an arm at rest. Real-time motion with the simulator's tracking lag: the capture
    is asked a tenth of the way down a 150 mm move, and must come back with the pose the arm
    settled at, not one on the way.

    Held under load (issue 32: it failed twice while two other runs shared the 2 cores): the
    move runs at 50 mm/s (3 s) rather than 250 mm/s (0.8 s), so a client descheduled for a
    second or two still asks while the arm moves and far from where it settles, and the
    capture may wait up to 10 s for the arm to settle instead of the default 2 s."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, tracking=True, seed=5, speed_factor=1.0)
    poses = f"  down: {{tcp_pose: {_lowered_pose(ctl, 0.15)}}}\n"
    config = write_config(
        tmp_path,
        ctl.host,
        poses=poses,
        motion="  speed_mps: 0.05\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.05\n",
        capture="  steady_timeout_s: 10\n",
    )
    cell: Cell

    def capture_now() -> tuple[Any, Any]:
        return ctl.snapshot(), cell.capture()

    progress = _DuringMove("down", 0.1, capture_now)
    with Cell(config, progress=progress) as cell:
        cell.move_to("down")
        assert cell.halted is None
    at_request, capture = progress.result
    assert at_request.moving  # the capture really was asked while the arm moved
    settled = _actual_flange(ctl)
    assert ctl.snapshot().steady
    np.testing.assert_allclose(capture.T_base_flange[:3, 3], settled[:3, 3], atol=1e-4)
    np.testing.assert_allclose(capture.T_base_flange[:3, :3], settled[:3, :3], atol=1e-3)
    moving_from = ur_pose_to_matrix(list(at_request.flange_pose))
    assert np.linalg.norm(moving_from[:3, 3] - settled[:3, 3]) > 0.05  # far from where it was
    (record,) = [r for r in audit_records(tmp_path) if r["event"] == "capture"]
    np.testing.assert_allclose(
        ur_pose_to_matrix(record["flange_pose"]), capture.T_base_flange, atol=1e-9
    )


def test_a_capture_that_does_not_settle_within_its_timeout_is_a_fault(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards the timeout of URRtdeArm.steady_flange_pose (robot/ur/arm.py, ``if
    time.monotonic() > deadline: raise self._fault(...)``): an arm that is still moving when
    ``capture.steady_timeout_s`` runs out is a RobotFault, never a wait for as long as it
    takes. The move (150 mm at 50 mm/s, 3 s) outlasts the 0.3 s timeout by far; the fault from
    inside the move stops it."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=1.0)
    poses = f"  down: {{tcp_pose: {_lowered_pose(ctl, 0.15)}}}\n"
    config = write_config(
        tmp_path,
        ctl.host,
        poses=poses,
        motion="  speed_mps: 0.05\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.05\n",
        capture="  steady_timeout_s: 0.3\n",
    )
    cell: Cell
    progress = _DuringMove("down", 0.05, lambda: cell.capture())
    with Cell(config, progress=progress) as cell:
        with pytest.raises(RobotFault, match=r"not at rest after 0\.3 s"):
            cell.move_to("down")
        assert cell.halted is not None
    assert progress.fired
    assert [c["kind"] for c in ctl.commands] == ["moveL", "stopL"]
    assert ctl.motions[0]["end"] == "stopped"  # braked on the way, not reached
    assert [r for r in audit_records(tmp_path) if r["event"] == "capture"] == []


# --- a lost link mid-move: the dashboard stops the arm --------------------------------------------


def test_a_link_lost_mid_move_is_braked_by_a_dashboard_stop(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards URRtdeArm._move's ``except RobotConnectionError: self._stop_by_dashboard()``
    (robot/ur/arm.py): when the RTDE link drops (the controller's program still runs), the arm
    is stopped through a fresh dashboard connection at once, not left to the watchdog (whose
    stop the motion record would name) or to the end of the move. The watchdog window is the
    config's largest, 2 s."""
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, speed_factor=1.0, inject=("drop-connection@move:1:0.1",)
    )
    poses = f"  down: {{tcp_pose: {_lowered_pose(ctl, 0.15)}}}\n"
    config = write_config(
        tmp_path,
        ctl.host,
        poses=poses,
        watchdog_s="2.0",
        motion="  speed_mps: 0.05\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.05\n",
    )
    with Cell(config) as cell:
        with pytest.raises(RobotConnectionError):
            cell.move_to("down")
        assert cell.halted is not None
    assert _eventually(lambda: len(ctl.motions) == 1)
    (motion,) = ctl.motions
    assert motion["end"] == "program stopped: dashboard stop", motion
    assert "watchdog_last_update_t" not in motion
    assert [c["kind"] for c in motion_commands(ctl)] == ["moveL"]


# --- before each move: a fresh sample, no stop ----------------------------------------------------


def _touch_test_stopped_before_the_grasp(
    ctl: SimulatedController,
    tmp_path: Path,
    before_grasp: Callable[[Cell], None],
    expected: type[Exception],
) -> Exception:
    """A touch test (approach, grasp, retreat) whose ``before_grasp`` runs between the approach
    and the grasp move; the error that ended it, which must be ``expected``."""
    cell: Cell

    def before_move(name: str) -> None:
        if name == "grasp":
            before_grasp(cell)

    with Cell(write_config(tmp_path, ctl.host)) as cell:
        with pytest.raises(expected) as caught:
            cell.touch_test(load_detection(DETECTION), 0.02, before_move=before_move)
        assert cell.halted is not None
    return caught.value


def test_a_move_right_after_a_protective_stop_never_reaches_movel(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards ``self._check_motion_sample(start, kind.name)`` before the move is sent in
    URRtdeArm._move (robot/ur/arm.py): a protective stop that came after the sequence's
    readiness check (here: between its approach and its grasp) refuses the grasp before
    ur_rtde's moveL is called. Without it, ur_rtde's moveL is called and refuses client-side
    ("was refused"): the same record, but the stop is no longer what the operator is told."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)

    def protective_stop(cell: Cell) -> None:
        ctl.inject("protective-stop")
        assert _eventually(lambda: cell.arm.status().protective_stopped)

    error = _touch_test_stopped_before_the_grasp(ctl, tmp_path, protective_stop, RobotFault)
    assert "protective stop active" in str(error)
    assert "refused" not in str(error)
    assert [c["kind"] for c in motion_commands(ctl)] == ["moveL"]  # the approach only
    outcome = audit_records(tmp_path)[-1]
    assert (outcome["status"], outcome["step"]) == ("fault", "grasp")


def test_a_move_with_a_frozen_rtde_stream_never_reaches_movel(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards ``start = self._sample("fresh_sample")`` in URRtdeArm._move (robot/ur/arm.py):
    the state checked before a move comes from an RTDE sample newer than the request. While the
    stream is frozen (``stall``), the latest cached sample still reads connected and normal;
    checked on it, the grasp's moveL went out and the arm moved on data 0.5 s old."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    error = _touch_test_stopped_before_the_grasp(
        ctl, tmp_path, lambda cell: ctl.inject("stall:1.5"), RobotConnectionError
    )
    assert "no RTDE sample newer" in str(error)
    assert [c["kind"] for c in motion_commands(ctl)] == ["moveL"]  # the approach only
    outcome = audit_records(tmp_path)[-1]
    assert (outcome["status"], outcome["step"]) == ("fault", "grasp")


# --- the descent onto a part is capped by the grasp speed limit -----------------------------------

# Above the grasp cap, below the general one: only the grasp cap refuses it.
GRASP_TOO_FAST_MPS = 0.3
assert MAX_GRASP_SPEED_MPS < GRASP_TOO_FAST_MPS < MAX_SPEED_MPS


def _grasp_too_fast(config_path: Path) -> Any:
    """The cell config of ``config_path`` built again directly, past the config loader's
    checks: the general speed at its cap, the grasp speed above its own."""
    loaded = Cell(config_path).config
    motion = dataclasses.replace(
        loaded.motion, speed_mps=MAX_SPEED_MPS, grasp_speed_mps=GRASP_TOO_FAST_MPS
    )
    return dataclasses.replace(loaded, motion=motion)


def test_the_preflight_refuses_a_grasp_speed_above_the_grasp_cap(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards the ``grasp_speed`` check of the preflight (safety.py ``_motion_checks``, the
    grasp speed against ``MAX_GRASP_SPEED_MPS``): a config that never went through the loader
    is refused before anything moves, by name."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = _grasp_too_fast(write_config(tmp_path, ctl.host))
    with Cell(config) as cell, pytest.raises(PreflightRefusal) as caught:
        cell.pick(load_detection(DETECTION))
    failed = [(r.target, r.name) for r in caught.value.results if not r.passed]
    assert failed == [("motion", "grasp_speed")]
    assert motion_commands(ctl) == []


def test_the_sequence_caps_the_descent_at_the_grasp_speed_limit(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards the cap the sequence applies to each slow (grasp or place) move right before it
    is sent (cell/sequence.py ``_linear``: ``(motion.grasp_speed_mps, MAX_GRASP_SPEED_MPS)`` and
    ``check_motion_command``): run directly, without the preflight, the descent is refused and
    never sent, though its speed is within the general cap."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = _grasp_too_fast(write_config(tmp_path, ctl.host))
    with Cell(config) as cell:
        T_grasp = cell.arm.tcp_pose()
        T_grasp[2, 3] -= 0.01
        refused = r"motion command refused, nothing sent: speed 0\.3"
        with pytest.raises(SafetyRefusal, match=refused):
            execute(config, [Move("grasp", T_grasp, slow=True)], cell.arm, Progress.quiet(), {})
    assert motion_commands(ctl) == []
