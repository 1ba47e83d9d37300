"""``handeye-pick pick``: one checked, audited pick on a live UR arm (a one-cycle ``Cell``).

Inputs are read and validated before the robot is contacted (bad input: exit 2, nothing sent).
Then: connect, check the cell, plan, pre-flight (exit 3, nothing moved), audit, move (exit 4 on a
robot fault, 130 on Ctrl-C and 143 on SIGTERM after stopL). ``--json`` prints one JSON report on
stdout whatever the ending (``cli.json_report``): the plan (UR pose vectors, m and rad) as far as
it got, the status, the pick id of its audit records and the error.
"""

from __future__ import annotations

import argparse
import contextlib
from dataclasses import asdict
from typing import TYPE_CHECKING

from handeye_pick.cli.cell import (
    add_capture_pose_args,
    add_config_arg,
    add_detection_arg,
    add_record_arg,
    capture_pose_from_args,
    detection_from_args,
    plan_fields,
    progress_from_args,
    publisher_from_args,
)
from handeye_pick.cli.common import add_camera_point_args
from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.errors import ExitCode, Status
from handeye_pick.geometry import Transform, matrix_to_ur_pose, ur_pose_list

if TYPE_CHECKING:  # the cell's machinery loads when a command runs, not for --help
    from handeye_pick.cell.pick import PickResult
    from handeye_pick.cell.plan import StepError
    from handeye_pick.cli.json_report import JsonReport


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``pick`` to the top-level parser."""
    parser = sub.add_parser(
        "pick",
        help="pick one detected object: flange pose at capture, hand-eye chain, checked moveL",
        description="Chain the camera-frame detection with the hand-eye calibration and the "
        "flange pose at image acquisition (from --capture-pose/--capture-pose-ur or the "
        "detection file's capture section; otherwise the live pose, read only while the arm is "
        "steady), check every target, append the plan to the audit file, then moveL approach, "
        "grasp (gripper output if configured), retreat, and place when the config has a place "
        "section. Exit status: 0 done, 2 bad input or config, 3 refused by a check (nothing "
        "moved), 4 robot fault (a dropped part or a gripper fault included), 5 missed (the "
        "gripper closed on nothing, opened and retreated), 130 interrupted, 143 terminated "
        "(SIGTERM).",
    )
    add_config_arg(parser)
    add_detection_arg(parser)
    add_camera_point_args(parser, required=False)
    add_capture_pose_args(parser)
    add_record_arg(parser)
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="connect, read, compute and check, append the plan to the audit file; move nothing",
    )
    add_json_arg(parser, "the plan, targets, checks, reached poses and place")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Exit 0 when the pick (or dry run) is done, 5 when it missed; typed errors propagate to
    the dispatcher, which ends the JSON report."""
    from handeye_pick.cell.session import Cell
    from handeye_pick.config.load import load_config

    report: JsonReport = args.report
    config = load_config(args.config)
    report.update(
        config=str(config.path), host=config.robot.host, audit_file=str(config.audit.file)
    )
    detection = detection_from_args(args)
    given = capture_pose_from_args(args, detection)
    progress = progress_from_args(args)
    with contextlib.ExitStack() as stack:
        publisher = publisher_from_args(args, config)
        if publisher is not None:  # closed after the cell: its last records are recorded
            stack.enter_context(publisher)
            if publisher.files is not None:
                progress.say(publisher.files.describe())
        cell = Cell(config, progress=progress, observer=publisher)
        report.audit_from(cell)
        capture = cell.given_capture(*given) if given is not None else None
        with cell:
            if args.cloud is not None:
                cell.note_cloud(args.cloud, capture)
            result = cell.pick(
                detection,
                capture,
                dry_run=args.dry_run,
                on_plan=lambda plan: report.update(**plan_fields(plan)),
            )
    report.update(**plan_fields(result.plan))  # a grasp alternative has targets of its own
    report.update(
        status=result.status,
        flange_pose_source=result.capture.source,
        checks=[asdict(check) for check in result.checks],
        reached={name: ur_pose_list(T) for name, T in result.reached.items()},
        errors={name: asdict(error) for name, error in result.errors.items()},
    )
    if result.alternative is not None:
        report.update(alternative=result.alternative)
    if result.T_base_tcp_place is not None:
        report.update(
            place={"index": result.place_index, "pose": ur_pose_list(result.T_base_tcp_place)}
        )
    if not args.json:
        _print_summary(result, str(config.audit.file))
    return ExitCode.MISSED if result.status is Status.MISSED else ExitCode.OK


def _print_summary(result: PickResult, audit_file: str) -> None:
    """The plan and the result for a person, on stdout (UR pose vectors, m and rad)."""
    plan = result.plan
    lines = [
        f"pick {result.status}: audit records {result.pick_id} in {audit_file}",
        f"  flange pose  {_fmt(plan.T_base_flange)} ({result.capture.source})",
        f"  object       {_fmt(plan.T_base_obj)}",
    ]
    if result.alternative is not None:
        lines.append(
            f"  grasp        turned {result.alternative['yaw_deg']} deg about the part's "
            f"symmetry axis, tilted {result.alternative['tilt_deg']} deg (docs/scene.md)"
        )
    for name, T_target in plan.targets().items():
        lines.append(_step_line(name, T_target, result.errors))
    if result.T_base_tcp_place is not None:
        lines.append(_step_line("place", result.T_base_tcp_place, result.errors))
    print("\n".join(lines), flush=True)


def _step_line(name: str, T_target: Transform, errors: dict[str, StepError]) -> str:
    line = f"  {name:<12} {_fmt(T_target)}"
    error = errors.get(name)
    if error is not None:
        line += f"  reached within {error.position_mm:.2f} mm, {error.rotation_deg:.2f} deg"
    return line


def _fmt(T: Transform) -> str:
    return "[" + ", ".join(f"{v:8.4f}" for v in matrix_to_ur_pose(T)) + "]"
