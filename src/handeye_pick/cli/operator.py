"""Operator tools around the pick: ``plan --plot``, ``status`` and ``touch-test``.

- ``plan``: the pick's planning (same chain, same targets) drawn to a PNG; moves nothing. The
  flange comes from ``--robot-pose`` / ``--robot-pose-ur`` or, without them, from the live robot.
- ``status``: one screen that says whether the cell is ready to pick (exit 0) or not (exit 3,
  with every reason), read without taking the controller over.
- ``touch-test``: a camera point driven to a stand-off above it with the pick's own sequence
  (readiness, pre-flight checks, audit, slow descent), then back up, so the operator sees
  whether the tool tip lands on the point.

Robot poses are printed as UR vectors (m, rad); points in the base frame in mm.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from handeye_pick.cli.cell import (
    add_config_arg,
    add_detection_arg,
    detection_from_args,
    plan_fields,
    print_json,
    progress_from_args,
)
from handeye_pick.cli.common import (
    add_camera_point_args,
    add_robot_pose_args,
    camera_point_mm_from_args,
    robot_pose_from_args,
)
from handeye_pick.errors import ExitCode, HandEyePickError, InputError, Status
from handeye_pick.geometry import ur_pose_list

if TYPE_CHECKING:  # the cell's machinery loads when a command runs, not for --help
    from handeye_pick.cell.plan import PickPlan
    from handeye_pick.cell.session import Cell
    from handeye_pick.cell.status import CellStatus

DEFAULT_STANDOFF_MM = 10.0


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``plan``, ``status`` and ``touch-test`` to the top-level parser."""
    plan = sub.add_parser(
        "plan",
        help="plan a pick and draw every frame to a PNG; moves nothing",
        description="The pick's planning (hand-eye chain, approach/grasp/retreat targets) "
        "drawn in the robot base frame: base, flange, TCP, camera, object, targets, TCP path, "
        "workspace box and the cloud when given. The flange pose comes from --robot-pose / "
        "--robot-pose-ur, or from the live robot in the config when neither is given.",
    )
    add_config_arg(plan)
    add_detection_arg(plan)
    add_camera_point_args(plan, required=False)
    add_robot_pose_args(plan)
    plan.add_argument(
        "--plot", required=True, type=Path, metavar="FILE.png", help="PNG file to write"
    )
    _add_json_arg(plan)
    plan.set_defaults(run=run_plan)

    status = sub.add_parser(
        "status",
        help="is the cell ready to pick? exit 0 ready, 3 not ready (with the reasons), 4 no answer",
        description="Read the controller without taking it over (no program is started, nothing "
        "is written: it is left as found, and a running session is not disturbed) and show "
        "controller version, robot and safety mode, runtime state, the program, remote control, "
        "the active TCP offset against the config, the flange pose, T_base_cam and whether the "
        "workspace box holds the current TCP.",
    )
    add_config_arg(status)
    _add_json_arg(status)
    status.set_defaults(run=run_status)

    touch = sub.add_parser(
        "touch-test",
        help="move the TCP slowly to a stand-off above a point the camera sees, then back",
        description="Check the calibration by touch: a camera point is chained into the base "
        "frame and the TCP goes to the approach point above it, descends at the grasp speed to "
        "the stand-off, and goes back up, with the pick's readiness and pre-flight checks and "
        "audit records. No gripper output is switched.",
    )
    add_config_arg(touch)
    add_camera_point_args(touch, required=True)
    touch.add_argument(
        "--standoff-mm",
        type=float,
        default=DEFAULT_STANDOFF_MM,
        metavar="MM",
        help="stop this far above the point along the tool z axis "
        f"(default {DEFAULT_STANDOFF_MM:g})",
    )
    touch.add_argument(
        "--confirm",
        action="store_true",
        help="wait for Enter at the approach point before descending",
    )
    _add_json_arg(touch)
    touch.set_defaults(run=run_touch_test)


def _add_json_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json", action="store_true", help="print one JSON object on stdout; no progress lines"
    )


# --- plan --plot --------------------------------------------------------------------------------


def run_plan(args: argparse.Namespace) -> int:
    """Plan like a pick and write the PNG; exit 0. Nothing is sent to the robot but reads."""
    from handeye_pick.cell.session import Cell
    from handeye_pick.cloud.files import read_cloud
    from handeye_pick.geometry import compose
    from handeye_pick.plot import Scene, cloud_to_base_m, render_scene

    cell = Cell(args.config, progress=progress_from_args(args))
    config, calibration = cell.config, cell.calibration
    detection = detection_from_args(args)
    T_base_flange = robot_pose_from_args(args)
    if T_base_flange is None:
        plan = cell.plan(detection)  # read from outside: no program started, no audit
        flange_source = f"live robot {config.robot.host}"
    else:
        # Offline: the TCP the config expects on the pendant.
        plan = cell.plan(detection, T_base_flange)
        flange_source = "--robot-pose" if args.robot_pose is not None else "--robot-pose-ur"
    cloud_base_m = None
    if args.cloud is not None:
        cloud_base_m = cloud_to_base_m(read_cloud(args.cloud).xyz, plan.T_base_cam)
    inverted = ", inverted on load" if calibration.inverted else ""
    scene = Scene(
        mode=f"plan: {calibration.mode.value}{inverted}, flange from {flange_source}",
        calibration_file=_relative_to_cwd(calibration.path),
        T_base_flange=plan.T_base_flange,
        T_base_tcp=compose(plan.T_base_flange, plan.T_flange_tcp),
        T_base_cam=plan.T_base_cam,
        T_base_obj=plan.T_base_obj,
        tcp_path=tuple(plan.targets().items()),
        workspace_min_m=_mm_to_m(config.workspace.min_mm),
        workspace_max_m=_mm_to_m(config.workspace.max_mm),
        cloud_base_m=cloud_base_m,
    )
    render_scene(scene, args.plot)
    outside = cell.outside_workspace(plan)
    if args.json:
        print_json(
            {
                "plot": str(args.plot),
                "flange_source": flange_source,
                **plan_fields(plan),
                "outside_workspace": outside,
            }
        )
    else:
        lines = [f"plan drawn to {args.plot} (flange from {flange_source}; nothing moved)"]
        lines += _plan_lines(plan)
        lines += [
            f"  warning: {name} outside the workspace: {why}" for name, why in outside.items()
        ]
        print("\n".join(lines), flush=True)
    return 0


def _relative_to_cwd(path: Path) -> Path:
    """``path`` as the operator typed it, roughly: relative when it lies below the working
    directory, so a picture does not carry one machine's absolute paths."""
    try:
        return path.relative_to(Path.cwd())
    except ValueError:
        return path


def _mm_to_m(values_mm: tuple[float, float, float]) -> tuple[float, float, float]:
    return (values_mm[0] / 1000.0, values_mm[1] / 1000.0, values_mm[2] / 1000.0)


# --- status -------------------------------------------------------------------------------------


def run_status(args: argparse.Namespace) -> int:
    """Print the cell's state; exit 0 when ready to pick, 3 (ExitCode.REFUSED) with the reasons.

    Reads from outside (``Cell.inspect``): no program is started, so the controller is left as
    it was found, and no audit file is opened, so it works beside a running session."""
    from handeye_pick.cell.session import Cell

    cell = Cell(args.config, progress=progress_from_args(args))
    config = cell.config
    report: dict[str, object] = {"config": str(config.path), "host": config.robot.host}
    state = cell.inspect()
    report.update(_status_fields(cell, state))
    _print_status(report, state.problems, args.json)
    return ExitCode.OK if state.ready else ExitCode.REFUSED


def _status_fields(cell: Cell, state: CellStatus) -> dict[str, object]:
    from handeye_pick.robot.port import RobotMode, RuntimeState, SafetyMode, mode_name

    robot_config = cell.config.robot
    robot, tcp, diff = state.robot, state.T_flange_tcp, state.tcp_offset_difference
    if robot is None:
        return {"ready": False, "problems": state.problems}
    fields: dict[str, object] = {
        "ready": state.ready,
        "problems": state.problems,
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


def _print_status(report: dict[str, object], problems: list[str], as_json: bool) -> None:
    if as_json:
        print_json(report)
        return
    lines = [f"cell {report['host']} ({report['config']})"]
    labels = (
        ("controller_version", "controller"),
        ("robot_mode", "robot mode"),
        ("safety_mode", "safety mode"),
        ("runtime_state", "runtime state"),
        ("program_state", "program"),
        ("loaded_program", "loaded program"),
        ("remote_control", "remote control"),
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
            lines.append(f"  {label:<16} {_show(report[key])}")
    if report.get("tcp_outside_workspace"):
        lines.append(f"  {'':<16} outside: {report['tcp_outside_workspace']}")
    rows = report.get("T_base_cam")
    if isinstance(rows, list):
        lines.append("  T_base_cam (m)")
        lines += [f"    {_show(row)}" for row in rows]
    if problems:
        lines.append("NOT READY:")
        lines += [f"  - {problem}" for problem in problems]
    else:
        lines.append("READY to pick")
    print("\n".join(lines), flush=True)


def _show(value: object) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(f"{v:.4f}" for v in value) + "]"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    return "-" if value is None else str(value)


# --- touch-test ---------------------------------------------------------------------------------


def run_touch_test(args: argparse.Namespace) -> int:
    """Approach, descend slowly to the stand-off, go back up; exit 0 when done."""
    from handeye_pick.cell.session import Cell
    from handeye_pick.detection import detection_from_point_mm

    cell = Cell(args.config, progress=progress_from_args(args))
    config = cell.config
    point_mm = camera_point_mm_from_args(args)
    if point_mm is None:  # argparse already requires --xyz or --cloud
        raise InputError("touch-test: give --xyz X Y Z or --cloud FILE --pixel COL ROW")
    standoff_mm = float(args.standoff_mm)
    approach_mm = config.grasp.approach_mm
    if not 0.0 <= standoff_mm < min(approach_mm, config.grasp.retreat_mm):
        raise InputError(
            f"touch-test: --standoff-mm must be at least 0 and less than the config's "
            f"grasp.approach_mm and grasp.retreat_mm ({approach_mm:g}, "
            f"{config.grasp.retreat_mm:g}), got {standoff_mm:g}"
        )
    if args.confirm and not sys.stdin.isatty():
        raise InputError(
            "touch-test --confirm waits for Enter at the approach point, but standard input is "
            "not a terminal: run it from a terminal, or drop --confirm"
        )
    source = "--xyz" if args.cloud is None else f"{args.cloud} pixel {args.pixel}"
    detection = detection_from_point_mm(point_mm, f"touch-test {source}")
    report: dict[str, object] = {"standoff_mm": standoff_mm}

    def show_plan(plan: PickPlan) -> None:
        report.update(plan_fields(plan))
        point = plan.T_base_obj[:3, 3] * 1000.0
        standoff = plan.grasp[:3, 3] * 1000.0
        report["point_base_mm"] = point.tolist()
        if not args.json:
            print(
                f"touch point in base: [{point[0]:.1f}, {point[1]:.1f}, {point[2]:.1f}] mm; "
                f"TCP stops {standoff_mm:g} mm short at "
                f"[{standoff[0]:.1f}, {standoff[1]:.1f}, {standoff[2]:.1f}] mm",
                flush=True,
            )

    def confirm(step: str) -> None:
        if step != "grasp" or not args.confirm:
            return
        # The prompt goes to stderr so that stdout stays one JSON object with --json.
        print(
            f"at the approach point: press Enter to descend to the {standoff_mm:g} mm stand-off "
            "(Ctrl-C aborts) ",
            end="",
            file=sys.stderr,
            flush=True,
        )
        if not sys.stdin.readline():
            raise KeyboardInterrupt  # stdin closed: nobody confirmed, so do not descend

    try:
        with cell:
            result = cell.touch_test(
                detection, standoff_mm / 1000.0, before_move=confirm, on_plan=show_plan
            )
    except (HandEyePickError, KeyboardInterrupt) as exc:
        if args.json:  # the operator's record even when it ends early; the dispatcher reports
            report.update(status="failed", error=str(exc) or type(exc).__name__)
            print_json(report)
        raise
    report["pick_id"] = result.pick_id
    report["reached"] = {name: ur_pose_list(T) for name, T in result.reached.items()}
    standoff_error_mm = result.errors["grasp"].position_mm
    if args.json:
        report["status"] = Status.DONE
        report["standoff_error_mm"] = standoff_error_mm
        print_json(report)
    else:
        print(
            f"touch-test done: stand-off reached within {standoff_error_mm:.2f} mm, "
            f"back at the retreat point; audit records {result.pick_id} in {config.audit.file}",
            flush=True,
        )
    return 0


# --- shared output ------------------------------------------------------------------------------


def _plan_lines(plan: PickPlan) -> list[str]:
    rows = [
        ("flange pose", plan.T_base_flange),
        ("camera", plan.T_base_cam),
        ("object", plan.T_base_obj),
    ]
    rows += list(plan.targets().items())
    return [f"  {label:<12} {_show(ur_pose_list(T))}" for label, T in rows]
