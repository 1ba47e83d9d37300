"""``collect``: visit the poses of a list, latch the flange pose at each and capture the board's
pose, writing a dataset of numbered pairs for ``calibrate`` (``calibration.collect``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from handeye_pick.cli.cell import add_config_arg, progress_from_args
from handeye_pick.cli.common import UNITS
from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.errors import HandEyePickError, InputError
from handeye_pick.hand_eye.files import HandEyeMode

if TYPE_CHECKING:  # the cell's machinery loads when a command runs, not for --help
    from handeye_pick.calibration.collect import Collection
    from handeye_pick.cli.json_report import JsonReport

DEFAULT_CAPTURE_TIMEOUT_S = 60.0  # a 3D capture and a board detection take seconds


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the command to the top-level parser."""
    collect = sub.add_parser(
        "collect",
        help="move through a pose list and capture a hand-eye dataset",
        description="For each pose of --poses, in order: move there (readiness, pre-flight "
        "checks and audit records as for a pick), wait until the arm is steady and latch the "
        "flange pose, then capture: --capture-command runs once per pose, or, without it, the "
        "operator captures and presses Enter. The capture writes T_cam_obj to the file in "
        "$HANDEYE_OBJECT_POSE_FILE; once it reads as a pose, the pair N is kept as "
        "object_pose_N.yaml and robot_pose_N.yaml (T_base_flange, Zivid format). A failed "
        "capture or a pose the pre-flight refuses is skipped with the reason and the run goes "
        "on. Ctrl-C or SIGTERM stops the arm; the pairs written stay.",
    )
    add_config_arg(collect)
    collect.add_argument(
        "--poses", required=True, type=Path, metavar="FILE", help="pose list (from poses)"
    )
    collect.add_argument(
        "--out",
        required=True,
        type=Path,
        metavar="DATASET",
        help="dataset folder (created when missing; pairs numbered from 0)",
    )
    collect.add_argument(
        "--append",
        action="store_true",
        help="DATASET already holds pairs: check them and number the new ones after the highest",
    )
    collect.add_argument(
        "--capture-command",
        metavar="CMD",
        help="program run once per pose, split like a shell line but run without a shell; it "
        "gets HANDEYE_POSE_INDEX (the pair number N) and HANDEYE_OBJECT_POSE_FILE (where to write "
        "T_cam_obj, Zivid YAML) in its environment, and must exit 0. Without it, collect waits "
        "for Enter on the terminal at each pose",
    )
    collect.add_argument(
        "--capture-timeout-s",
        type=float,
        default=DEFAULT_CAPTURE_TIMEOUT_S,
        metavar="S",
        help="the capture command is killed (with its children) after this long and the pose "
        f"skipped (default {DEFAULT_CAPTURE_TIMEOUT_S:g})",
    )
    collect.add_argument(
        "--units",
        choices=UNITS,
        default="mm",
        help="translation unit of T_cam_obj as the capture writes it; robot poses are written "
        "in the same unit (default: mm, Zivid's)",
    )
    add_json_arg(collect, "the dataset, its pairs and the poses skipped, also when it ends early")
    collect.set_defaults(run=run_collect)


def run_collect(args: argparse.Namespace) -> int:
    """Collect the dataset; exit 0 when every pose was visited (skipped ones are listed)."""
    from handeye_pick.calibration.collect import (
        CaptureStep,
        Collection,
        CommandCapture,
        EnterCapture,
        check_pose_list_tcp,
        collect_pairs,
        first_pair_number,
    )
    from handeye_pick.calibration.pose_list import read_pose_list
    from handeye_pick.cell.session import Cell

    cell = Cell(args.config, progress=progress_from_args(args))
    args.report.audit_from(cell)
    pose_list = read_pose_list(args.poses)
    check_pose_list_tcp(pose_list, cell.config)
    capture: CaptureStep
    if args.capture_command is not None:
        capture = CommandCapture.parse(args.capture_command, args.capture_timeout_s)
    elif not sys.stdin.isatty():
        raise InputError(
            "collect without --capture-command waits for Enter at each pose, but standard input "
            "is not a terminal: run it from a terminal, or give --capture-command"
        )
    else:
        capture = EnterCapture(args.units)
    first = first_pair_number(args.out, args.append, args.units)
    collection = Collection(args.out)
    mode = cell.calibration.mode
    try:
        with cell:
            collect_pairs(cell, pose_list, capture, first, args.units, collection)
    except (HandEyePickError, KeyboardInterrupt) as exc:
        _report_collection(args, mode, collection, exc)
        raise
    _report_collection(args, mode, collection, None)
    return 0


def _report_collection(
    args: argparse.Namespace,
    mode: HandEyeMode,
    collection: Collection,
    error: BaseException | None,
) -> None:
    """What was collected (also when the run ended early), and what to run next."""
    units = "" if args.units == "mm" else f" --units {args.units}"
    next_command = f"handeye-pick calibrate --mode {mode.value}{units} {collection.dataset}"
    if args.json:
        report: JsonReport = args.report
        report.update(
            dataset=str(collection.dataset),
            mode=mode.value,
            pairs=collection.pairs,
            skipped=[{"pose": s.pose, "reason": s.reason} for s in collection.skipped],
        )
        return
    pairs = ", ".join(str(n) for n in collection.pairs) or "none"
    lines = [f"collected {len(collection.pairs)} pairs in {collection.dataset} (N: {pairs})"]
    lines += [f"  skipped {s.pose}: {s.reason}" for s in collection.skipped]
    if error is not None:
        lines.append("the run ended early; the pairs above are kept (--append continues)")
    lines.append(f"next: {next_command}")
    print("\n".join(lines), flush=True)
