"""What a cell looks like right now, and whether it can pick: read through the session's own
robot link, or from outside (one RTDE package and a few dashboard queries, no program started).

Frames and units: poses are float64 4x4 in metres in the robot base frame; the TCP offset
difference is (mm, deg).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from handeye_pick.cell.lock import CellLock
from handeye_pick.config.schema import CellConfig
from handeye_pick.errors import RobotConnectionError, RobotFault
from handeye_pick.geometry import Transform, compose
from handeye_pick.hand_eye.files import HandEyeCalibration
from handeye_pick.progress import Progress
from handeye_pick.robot.port import RobotArm, RobotStatus
from handeye_pick.robot.ur.readout import ControllerReadout, read_controller
from handeye_pick.safety import (
    chain_checks,
    controller_problems,
    readiness_problems,
    tcp_offset_difference,
    tcp_offset_problems,
    workspace_problem,
)


@dataclass(frozen=True)
class CellStatus:
    """What the cell looks like right now, and whether it can pick."""

    ready: bool
    problems: list[str]
    halted: str | None  # why the cell is halted, or None
    robot: RobotStatus | None = None  # None when the link is gone
    T_flange_tcp: Transform | None = None  # active TCP offset (m)
    tcp_offset_difference: tuple[float, float] | None = None  # (mm, deg) controller vs config
    T_base_flange: Transform | None = None
    T_base_tcp: Transform | None = None
    T_base_cam: Transform | None = None
    tcp_outside_workspace: str | None = None
    program_state: str | None = None  # the dashboard's programState (``inspect`` only)
    loaded_program: str | None = None  # the dashboard's loaded program (``inspect`` only)
    notes: tuple[str, ...] = ()  # worth knowing, no obstacle to a pick (``inspect`` only)


def halted_problem(reason: str) -> str:
    """The readiness problem of a halted cell."""
    return f"halted ({reason}): clear the cause, then resume"


def unread(problems: list[str], halted: str | None) -> CellStatus:
    """A status with no controller state (not connected, or the controller does not answer)."""
    return CellStatus(False, problems, halted)


def session_status(
    arm: RobotArm, config: CellConfig, calibration: HandEyeCalibration, halted: str | None
) -> CellStatus:
    """The status through a connected session's own link (reads only; works while halted)."""
    robot = config.robot
    state = arm.status()
    try:
        T_flange_tcp = arm.tcp_offset()
    except RobotFault as exc:  # the control script refuses commands during a stop
        problems = readiness_problems(state, robot.T_flange_tcp, robot)
        problems.append(f"the controller does not answer getTCPOffset now ({exc})")
        return _status(problems, halted, state, None, None, config, calibration)
    problems = readiness_problems(state, T_flange_tcp, robot)
    return _status(problems, halted, state, T_flange_tcp, arm.flange_pose(), config, calibration)


def outside_status(
    config: CellConfig,
    calibration: HandEyeCalibration,
    halted: str | None,
    progress: Progress,
    *,
    own_session: bool = False,
) -> CellStatus:
    """The status read from outside (``robot.ur.readout``): no program is started and nothing
    is written, so the controller is left exactly as it was found, and it works beside another
    session that is driving the arm.

    Ready means a pick could start now: the controller checks a pick makes, the active TCP
    offset against the config, no session holding the cell (``own_session``: the caller is that
    session, which does not count), no program running that a pick would stop or could not take
    over (``_program_findings``), and the camera chain's plausibility as a pick checks it, with
    the same lines (``safety.chain_checks``, without a detection).
    """
    robot = config.robot
    with progress.step(f"reading {robot.host}"):
        readout = read_controller(robot.host)
    problems = controller_problems(readout.status)
    if readout.dashboard_problem is not None:
        problems.append(
            f"{readout.dashboard_problem}: handeye-pick needs it to run a pick (ur_rtde 1.6.5 "
            "starts its control program through it); on PolyScope 5 enable it under "
            "Settings > Security > Services"
        )
    holder = None if own_session else CellLock(robot.host).holder()
    if holder is not None:
        problems.append(
            f"cell {robot.host} is in use by {holder}: stop that session (or let it finish) "
            "before a pick; nothing to do on the pendant"
        )
    program_problems, notes = _program_findings(readout, session_holds_cell=holder is not None)
    problems.extend(program_problems)
    if readout.T_flange_tcp is None:
        problems.append(
            "this controller does not serve tcp_offset over RTDE (PolyScope 3.12.3 and "
            "5.5.1 on do), so status cannot check the active TCP offset without stopping "
            "the controller's program: update PolyScope, or check with pick --dry-run"
        )
    else:
        problems.extend(
            tcp_offset_problems(
                readout.T_flange_tcp,
                robot.T_flange_tcp,
                tolerance_mm=robot.tcp_offset_tolerance_mm,
                tolerance_deg=robot.tcp_offset_tolerance_deg,
            )
        )
    chain = chain_checks(config, calibration, None, readout.T_base_flange)
    problems.extend(check.line for check in chain if not check.passed)
    notes.extend(check.line for check in chain if check.passed)  # acknowledged by the cell
    state = _status(
        problems,
        halted,
        readout.status,
        readout.T_flange_tcp,
        readout.T_base_flange,
        config,
        calibration,
    )
    return replace(
        state,
        program_state=readout.program_state,
        loaded_program=readout.loaded_program,
        notes=tuple(notes),
    )


def _program_findings(
    readout: ControllerReadout, *, session_holds_cell: bool
) -> tuple[list[str], list[str]]:
    """The problems and the notes about the program the controller runs, by whose it is
    (docs/field-experience.md, "A control script left playing"): an operator's (a pick would
    stop it: the pendant), ur_rtde's control script for the session that holds the cell (said
    already), for a live client elsewhere (a pick could not take over its registers), or left
    over with no client (a pick replaces it: a note, not a problem)."""
    if not readout.program_running:
        return [], []
    state = readout.program_state or "the dashboard does not name it"
    if not readout.control_script_running:
        return [
            f"a program is running on the controller ({state}): a pick would stop it; stop it "
            "on the pendant, or let it finish"
        ], []
    if session_holds_cell:
        return [], []
    if readout.command_register_held:
        return [
            f"a program is running on the controller ({state}): the control script of a live "
            "ur_rtde client (handeye-pick on another computer, or another ur_rtde program), "
            "which a pick cannot take over; stop that client or let it finish"
        ], []
    return [], [
        f"ur_rtde's control script is running ({state}) with no client left (a session that "
        "ended without stopping it, or another ur_rtde program): a pick will replace it"
    ]


def halted_without_link(
    config: CellConfig, calibration: HandEyeCalibration, halted: str, progress: Progress
) -> CellStatus:
    """A cell halted by a lost link has no session left: read it from outside, so the operator
    still sees what the pendant would show; the halt reason first either way."""
    try:
        return outside_status(config, calibration, halted, progress, own_session=True)
    except RobotConnectionError as exc:
        problems = [halted_problem(halted), f"the controller does not answer ({exc})"]
        return unread(problems, halted)


def flange_from_outside(config: CellConfig, progress: Progress) -> tuple[Transform, Transform]:
    """``(T_flange_tcp, T_base_flange)`` (m) from one RTDE package read from outside."""
    host = config.robot.host
    with progress.step(f"reading {host}"):
        readout = read_controller(host)
    if readout.T_flange_tcp is None or readout.T_base_flange is None:
        raise RobotFault(
            f"cell {host}: the controller serves no tcp_offset over RTDE (PolyScope older "
            "than 3.12.3 / 5.5.1), so the flange pose cannot be read without starting a "
            "program: give the flange pose (--robot-pose or --robot-pose-ur)"
        )
    return readout.T_flange_tcp, readout.T_base_flange


def _status(
    problems: list[str],
    halted: str | None,
    state: RobotStatus,
    T_flange_tcp: Transform | None,
    T_base_flange: Transform | None,
    config: CellConfig,
    calibration: HandEyeCalibration,
) -> CellStatus:
    if halted is not None:
        problems.insert(0, halted_problem(halted))
    if T_flange_tcp is None or T_base_flange is None:
        return CellStatus(not problems, problems, halted, state)
    T_base_tcp = compose(T_base_flange, T_flange_tcp)
    return CellStatus(
        ready=not problems,
        problems=problems,
        halted=halted,
        robot=state,
        T_flange_tcp=T_flange_tcp,
        tcp_offset_difference=tcp_offset_difference(T_flange_tcp, config.robot.T_flange_tcp),
        T_base_flange=T_base_flange,
        T_base_tcp=T_base_tcp,
        T_base_cam=calibration.T_base_cam(T_base_flange),
        tcp_outside_workspace=workspace_problem(T_base_tcp, config.workspace),
    )
