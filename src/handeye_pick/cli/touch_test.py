"""``touch-test``: a camera point driven to a stand-off above it with the pick's own sequence
(readiness, pre-flight checks, audit, slow descent), then back up, so the operator sees whether
the tool tip lands on the point.

Points in the base frame are printed in mm.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING

from handeye_pick.cli.cell import add_config_arg, plan_fields, progress_from_args
from handeye_pick.cli.common import (
    add_camera_point_args,
    camera_point_mm_from_args,
)
from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.errors import InputError
from handeye_pick.geometry import ur_pose_list

if TYPE_CHECKING:  # the cell's machinery loads when a command runs, not for --help
    from handeye_pick.cell.plan import PickPlan
    from handeye_pick.cli.json_report import JsonReport
    from handeye_pick.config.schema import CellConfig
    from handeye_pick.detection import Detection


DEFAULT_STANDOFF_MM = 10.0


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the command to the top-level parser."""
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
    add_json_arg(touch, "the plan, the touch point in base (mm), the reached poses")
    touch.set_defaults(run=run_touch_test)


def run_touch_test(args: argparse.Namespace) -> int:
    """Approach, descend slowly to the stand-off, go back up; exit 0 when done."""
    from handeye_pick.cell.session import Cell

    report: JsonReport = args.report
    cell = Cell(args.config, progress=progress_from_args(args))
    report.audit_from(cell)
    detection, standoff_mm = _touch_point(args, cell.config)
    report.update(standoff_mm=standoff_mm)

    def show_plan(plan: PickPlan) -> None:
        point = plan.T_base_obj[:3, 3] * 1000.0
        standoff = plan.grasp[:3, 3] * 1000.0
        report.update(**plan_fields(plan), point_base_mm=point.tolist())
        if not args.json:
            print(
                f"touch point in base: [{point[0]:.1f}, {point[1]:.1f}, {point[2]:.1f}] mm; "
                f"TCP stops {standoff_mm:g} mm short at "
                f"[{standoff[0]:.1f}, {standoff[1]:.1f}, {standoff[2]:.1f}] mm",
                flush=True,
            )

    confirm = _confirmation(standoff_mm) if args.confirm else None
    with cell:
        result = cell.touch_test(
            detection, standoff_mm / 1000.0, before_move=confirm, on_plan=show_plan
        )
    standoff_error_mm = result.errors["grasp"].position_mm
    report.update(
        reached={name: ur_pose_list(T) for name, T in result.reached.items()},
        standoff_error_mm=standoff_error_mm,
    )
    if not args.json:
        print(
            f"touch-test done: stand-off reached within {standoff_error_mm:.2f} mm, "
            f"back at the retreat point; audit records {result.pick_id} in "
            f"{cell.config.audit.file}",
            flush=True,
        )
    return 0


def _touch_point(args: argparse.Namespace, config: CellConfig) -> tuple[Detection, float]:
    """The camera point to touch and the stand-off (mm), refused before anything connects."""
    from handeye_pick.detection import detection_from_point_mm

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
    return detection_from_point_mm(point_mm, f"touch-test {source}"), standoff_mm


def _confirmation(standoff_mm: float) -> Callable[[str], None]:
    """Before the descent (the grasp move): wait for the operator's Enter on the terminal."""

    def confirm(step: str) -> None:
        if step != "grasp":
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

    return confirm
