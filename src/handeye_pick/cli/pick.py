"""``handeye-pick pick``: one checked, audited pick on a live UR arm.

Inputs are read and validated before the robot is contacted (bad input: exit 2, nothing sent).
Then: connect, check the cell, plan, pre-flight (exit 3, nothing moved), audit, move (exit 4 on a
robot fault, 130 on Ctrl-C after stopL). ``--json`` prints one JSON object on stdout whatever
the ending: the plan (UR pose vectors, m and rad) as far as it got, the status and the error.
"""

from __future__ import annotations

import argparse
from dataclasses import asdict

from handeye_pick.audit import AuditLog
from handeye_pick.calibration import HandEyeCalibration
from handeye_pick.cli.cell import (
    add_config_arg,
    add_detection_arg,
    calibration_from_config,
    detection_from_args,
    plan_fields,
    print_json,
    progress_from_args,
)
from handeye_pick.cli.common import add_camera_point_args
from handeye_pick.config import CellConfig, load_config
from handeye_pick.detection import Detection
from handeye_pick.errors import HandEyePickError, RobotError, SafetyRefusal
from handeye_pick.geometry import Transform, matrix_to_ur_pose, ur_pose_list
from handeye_pick.pick import (
    STEPS,
    PickPlan,
    PickResult,
    connect_audited,
    run_pick,
    target_of,
)
from handeye_pick.progress import Progress
from handeye_pick.robot.ur_rtde_arm import URRtdeArm
from handeye_pick.safety import PreflightRefusal


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``pick`` to the top-level parser."""
    parser = sub.add_parser(
        "pick",
        help="pick one detected object: live flange pose, hand-eye chain, checked moveL",
        description="Read the live flange pose over RTDE, chain it with the hand-eye "
        "calibration and the camera-frame detection, check every target, append the plan to the "
        "audit file, then moveL approach, grasp (gripper output if configured) and retreat. "
        "Exit status: 0 done, 2 bad input or config, 3 refused by a check (nothing moved), "
        "4 robot fault, 130 interrupted.",
    )
    add_config_arg(parser)
    add_detection_arg(parser)
    add_camera_point_args(parser, required=False)
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="connect, read, compute and check, append the plan to the audit file; move nothing",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object (plan, targets, status) on stdout; no progress lines",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Exit 0 when the pick (or dry run) is done; typed errors propagate to the dispatcher,
    after the JSON report is printed."""
    report: dict[str, object] = {"status": "starting"}
    try:
        config = load_config(args.config)
        report.update(
            config=str(config.path), host=config.robot.host, audit_file=str(config.audit.file)
        )
        detection = detection_from_args(args)
        calibration = calibration_from_config(config)
        audit = AuditLog(config.audit.file)
        report["pick_id"] = audit.pick_id
        progress = progress_from_args(args)
        result = _connect_and_pick(config, calibration, detection, audit, args, progress, report)
    except (HandEyePickError, KeyboardInterrupt) as exc:
        report.update(_failure_fields(exc))
        if args.json:
            print_json(report)
        raise
    status = "dry-run" if args.dry_run else "done"
    report["status"] = status
    report["checks"] = [asdict(check) for check in result.checks]
    report["errors"] = {name: asdict(error) for name, error in result.errors().items()}
    if args.json:
        print_json(report)
    else:
        _print_summary(result, status, audit)
    return 0


def _connect_and_pick(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detection: Detection,
    audit: AuditLog,
    args: argparse.Namespace,
    progress: Progress,
    report: dict[str, object],
) -> PickResult:
    def keep_plan(plan: PickPlan) -> None:
        report.update(plan_fields(plan))

    def connect() -> URRtdeArm:
        with progress.step(f"connecting to {config.robot.host}"):
            return URRtdeArm(
                config.robot.host,
                with_io=config.robot.gripper is not None,
                stop_decel_mps2=config.motion.stop_decel_mps2,
            )

    arm = connect_audited(audit, connect, dry_run=args.dry_run)
    with arm:
        report["controller_version"] = arm.controller_version
        result = run_pick(
            config,
            calibration,
            detection,
            arm,
            audit,
            dry_run=args.dry_run,
            progress=progress,
            on_plan=keep_plan,
        )
    report["reached"] = {name: ur_pose_list(T) for name, T in result.reached.items()}
    return result


def _failure_fields(exc: BaseException) -> dict[str, object]:
    if isinstance(exc, KeyboardInterrupt):
        return {"status": "interrupted", "error": "interrupted (Ctrl-C): stopL sent"}
    fields: dict[str, object] = {"error": str(exc), "error_type": type(exc).__name__}
    if isinstance(exc, SafetyRefusal):
        fields["status"] = "refused"
    elif isinstance(exc, RobotError):
        fields["status"] = "fault"
    else:
        fields["status"] = "bad-input"
    if isinstance(exc, PreflightRefusal):
        fields["checks"] = [asdict(check) for check in exc.results]
    return fields


def _print_summary(result: PickResult, status: str, audit: AuditLog) -> None:
    """The plan and the result for a person, on stdout (UR pose vectors, m and rad)."""
    plan, errors = result.plan, result.errors()
    lines = [
        f"pick {status}: audit records {audit.pick_id} in {audit.path}",
        f"  flange pose  {_fmt(plan.T_base_flange)}",
        f"  object       {_fmt(plan.T_base_obj)}",
    ]
    for name in STEPS:
        line = f"  {name:<12} {_fmt(target_of(plan.targets, name))}"
        if name in errors:
            error = errors[name]
            line += f"  reached within {error.position_mm:.2f} mm, {error.rotation_deg:.2f} deg"
        lines.append(line)
    print("\n".join(lines), flush=True)


def _fmt(T: Transform) -> str:
    return "[" + ", ".join(f"{v:8.4f}" for v in matrix_to_ur_pose(T)) + "]"
