"""``status``: one screen that says whether the cell is ready to pick (exit 0) or not (exit 3,
with every reason), read without taking the controller over.

Robot poses are printed as UR vectors (m, rad).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from handeye_pick.cli.cell import add_config_arg, progress_from_args, show
from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.errors import ExitCode, Status
from handeye_pick.geometry import ur_pose_list

if TYPE_CHECKING:  # the cell's machinery loads when a command runs, not for --help
    from handeye_pick.cell.session import Cell
    from handeye_pick.cell.status import CellStatus


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the command to the top-level parser."""
    status = sub.add_parser(
        "status",
        help="is the cell ready to pick? exit 0 ready, 3 not ready (with the reasons), 4 no answer",
        description="Read the controller without taking it over (no program is started, nothing "
        "is written: it is left as found, and a running session is not disturbed) and show "
        "controller version, robot and safety mode, runtime state, the program, remote control, "
        "the active TCP offset against the config, the flange pose, T_base_cam and whether the "
        "workspace box holds the current TCP. Not ready also while a session holds the cell, a "
        "program runs that a pick would stop or cannot take over, or the camera chain fails a "
        "pick's plausibility checks (the same lines as the pick's refusal).",
    )
    add_config_arg(status)
    add_json_arg(status, "every reading, ready, the problems and the notes")
    status.set_defaults(run=run_status)


def run_status(args: argparse.Namespace) -> int:
    """Print the cell's state; exit 0 when ready to pick, 3 (ExitCode.REFUSED) with the reasons.

    Reads from outside (``Cell.inspect``): no program is started, so the controller is left as
    it was found, and no audit file is opened, so it works beside a running session."""
    from handeye_pick.cell.session import Cell

    cell = Cell(args.config, progress=progress_from_args(args))
    config = cell.config
    report: dict[str, object] = {"config": str(config.path), "host": config.robot.host}
    if config.scene is not None:
        from handeye_pick.scene.layout import describe_scene

        report["scene"] = describe_scene(config.scene, len(config.tool_shape))
    state = cell.inspect()
    report.update(_status_fields(cell, state))
    if args.json:
        args.report.update(status=Status.READY if state.ready else Status.NOT_READY, **report)
    else:
        _print_status(report, state.problems, state.notes)
    return ExitCode.OK if state.ready else ExitCode.REFUSED


def _status_fields(cell: Cell, state: CellStatus) -> dict[str, object]:
    from handeye_pick.robot.port import RobotMode, RuntimeState, SafetyMode, mode_name

    robot_config = cell.config.robot
    robot, tcp, diff = state.robot, state.T_flange_tcp, state.tcp_offset_difference
    if robot is None:
        return {"ready": False, "problems": state.problems, "notes": list(state.notes)}
    fields: dict[str, object] = {
        "ready": state.ready,
        "problems": state.problems,
        "notes": list(state.notes),
        "controller_version": robot.controller_version,
        "robot_mode": mode_name(RobotMode, robot.robot_mode),
        "safety_mode": mode_name(SafetyMode, robot.safety_mode),
        "runtime_state": mode_name(RuntimeState, robot.runtime_state),
        "program_state": state.program_state,
        "loaded_program": state.loaded_program,
        "remote_control": robot.remote_control,
    }
    if tcp is None or diff is None or state.T_base_flange is None:
        return fields
    fields |= {
        "tcp_offset": ur_pose_list(tcp),
        "tcp_offset_configured": ur_pose_list(robot_config.T_flange_tcp),
        "tcp_offset_matches": diff[0] <= robot_config.tcp_offset_tolerance_mm
        and diff[1] <= robot_config.tcp_offset_tolerance_deg,
        "tcp_offset_difference": {"mm": diff[0], "deg": diff[1]},
        "flange_pose": ur_pose_list(state.T_base_flange),
        "hand_eye_mode": cell.calibration.mode.value,
        "calibration_file": str(cell.calibration.path),
        "tcp_in_workspace": state.tcp_outside_workspace is None,
        "tcp_outside_workspace": state.tcp_outside_workspace,
    }
    if state.T_base_tcp is not None:
        fields["tcp_pose"] = ur_pose_list(state.T_base_tcp)
    if state.T_base_cam is not None:
        fields["T_base_cam"] = state.T_base_cam.tolist()
    return fields


def _print_status(report: dict[str, object], problems: list[str], notes: tuple[str, ...]) -> None:
    lines = [f"cell {report['host']} ({report['config']})"]
    labels = (
        ("controller_version", "controller"),
        ("robot_mode", "robot mode"),
        ("safety_mode", "safety mode"),
        ("runtime_state", "runtime state"),
        ("program_state", "program"),
        ("loaded_program", "loaded program"),
        ("remote_control", "remote control"),
        ("scene", "scene"),
        ("tcp_offset", "TCP offset"),
        ("tcp_offset_configured", "TCP in config"),
        ("tcp_offset_matches", "TCP matches"),
        ("flange_pose", "flange pose"),
        ("tcp_pose", "TCP pose"),
        ("hand_eye_mode", "hand-eye mode"),
        ("calibration_file", "calibration"),
        ("tcp_in_workspace", "TCP in workspace"),
    )
    for key, label in labels:
        if key in report:
            lines.append(f"  {label:<16} {show(report[key])}")
    if report.get("tcp_outside_workspace"):
        lines.append(f"  {'':<16} outside: {report['tcp_outside_workspace']}")
    rows = report.get("T_base_cam")
    if isinstance(rows, list):
        lines.append("  T_base_cam (m)")
        lines += [f"    {show(row)}" for row in rows]
    lines += [f"note: {note}" for note in notes]
    if problems:
        lines.append("NOT READY:")
        lines += [f"  - {problem}" for problem in problems]
    else:
        lines.append("READY to pick")
    print("\n".join(lines), flush=True)
