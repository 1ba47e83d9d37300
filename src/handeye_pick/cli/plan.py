"""``plan``: the pick's planning (same chain, same targets) drawn to a PNG; moves nothing.

The flange comes from ``--robot-pose`` / ``--robot-pose-ur`` or, without them, from the live
robot read from outside (no program started). Robot poses are printed as UR vectors (m, rad).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from handeye_pick.cli.cell import (
    add_config_arg,
    add_detection_arg,
    detection_from_args,
    plan_fields,
    progress_from_args,
    show,
)
from handeye_pick.cli.common import (
    add_camera_point_args,
    add_robot_pose_args,
    robot_pose_from_args,
)
from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.geometry import ur_pose_list

if TYPE_CHECKING:  # the cell's machinery loads when a command runs, not for --help
    from handeye_pick.cell.plan import PickPlan


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the command to the top-level parser."""
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
    add_json_arg(plan, "the plan, targets and any outside the workspace")
    plan.set_defaults(run=run_plan)


def run_plan(args: argparse.Namespace) -> int:
    """Plan like a pick and write the PNG; exit 0. Nothing is sent to the robot but reads."""
    import numpy as np

    from handeye_pick.cell.session import Cell
    from handeye_pick.cloud.files import read_cloud
    from handeye_pick.geometry import compose, invert
    from handeye_pick.plot import Scene, arm_at, cloud_to_base_m, render_scene
    from handeye_pick.scene.layout import arm_not_checked, scene_boxes

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
    # The arm at the flange now and at every target, from the model's IK: the plan does not
    # read the controller's joints.
    stops = [plan.T_base_flange] + [
        compose(T, invert(plan.T_flange_tcp)) for T in plan.targets().values()
    ]
    model = config.robot.model
    arm = arm_at(model, np.stack(stops)) if model is not None else ()
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
        obstacles=tuple(scene_boxes(config.scene)) if config.scene is not None else (),
        arm=arm,
        arm_source=f"drawn from our {model.name} IK (elbow up, wrist down)" if model else "",
    )
    render_scene(scene, args.plot)
    outside = cell.outside_workspace(plan)
    unchecked = arm_not_checked(config.scene) if config.scene is not None else None
    if args.json:
        args.report.update(
            plot=str(args.plot),
            flange_source=flange_source,
            **plan_fields(plan),
            outside_workspace=outside,
            **({"arm": unchecked} if unchecked is not None else {}),
        )
    else:
        lines = [f"plan drawn to {args.plot} (flange from {flange_source}; nothing moved)"]
        lines += _plan_lines(plan)
        lines += [f"  scene: {unchecked}"] if unchecked is not None else []
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


def _plan_lines(plan: PickPlan) -> list[str]:
    rows = [
        ("flange pose", plan.T_base_flange),
        ("camera", plan.T_base_cam),
        ("object", plan.T_base_obj),
    ]
    rows += list(plan.targets().items())
    return [f"  {label:<12} {show(ur_pose_list(T))}" for label, T in rows]
