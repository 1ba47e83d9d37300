"""Moves to configured targets: a named pose, the place of a held part, the capture pose through
its via poses. Each is planned (corners rounded as ``motion.blend_mm`` allows, swept against the
scene when the config has one), checked and audited through ``run_operation``; a carried part is
watched on every move.

Frames and units: ``T_base_tcp`` float64 4x4 in metres in the robot base frame; joints radians.
"""

from __future__ import annotations

from handeye_pick.cell.operation import Planned, run_operation
from handeye_pick.cell.plan import blended, check_steps, place_steps, with_scene_checks
from handeye_pick.cell.sequence import Executed
from handeye_pick.cell.state import CellState
from handeye_pick.config.schema import NamedPose, via_move
from handeye_pick.errors import ConfigError, Status
from handeye_pick.geometry import Transform
from handeye_pick.steps import JointMove, Move, Step


def move_to(state: CellState, pose: str | NamedPose, request_id: str | None) -> Transform:
    """To a named pose of the config, or a ``NamedPose`` given directly (moveJ for joints,
    moveL for a TCP pose); the reached ``T_base_tcp``."""
    state.ensure_not_halted()
    target = state.config.pose(pose) if isinstance(pose, str) else pose
    reached = run_fixed(
        state, [named_move(target)], f"move {target.name}", request_id, {"pose": target.name}
    )
    return reached[target.name]


def move_to_capture(state: CellState, name: str, request_id: str | None) -> None:
    """To the capture pose ``name``; to ``capture.pose`` through ``capture.via``."""
    capture = state.config.capture
    via = capture.via if name == capture.pose else ()
    steps: list[Step] = [
        Move(via_move(pose.name), pose.T_base_tcp, fixed=True)
        for pose in via
        if pose.T_base_tcp is not None  # the config loader takes only TCP poses as via
    ]
    steps.append(named_move(state.config.pose(name)))
    run_fixed(state, steps, f"move {name}", request_id, {"pose": name})


def place(state: CellState, request_id: str | None) -> Transform:
    """Put a held part down at the next place pose (approach, place, release, retreat);
    returns that place pose ``T_base_tcp``. ConfigError when no place is configured."""
    config = state.config.place
    if config is None:
        raise ConfigError(f"{state.config.path}: no place section: nowhere to put a part")
    T_place = state.next_place_pose(config)
    steps = place_steps(T_place, config, grip=True)
    run_fixed(state, steps, "place", request_id, {"place_index": state.place_index})
    state.holding = None
    state.place_index += 1
    return T_place


def run_fixed(
    state: CellState,
    steps: list[Step],
    what: str,
    request_id: str | None,
    record: dict[str, object],
) -> dict[str, Transform]:
    """A sequence of configured targets through ``run_operation``; the reached ``T_base_tcp``
    by step name."""
    config = state.config
    reached: dict[str, Transform] = {}

    def prepare(
        T_flange_tcp: Transform, context: dict[str, object], outcome: dict[str, object]
    ) -> Planned:
        arm = state.link.arm
        # Where the arm stands is read only when corners are rounded (blend_mm > 0) or the
        # path is swept against a scene.
        swept = config.scene is not None
        T_base_tcp_start = arm.tcp_pose() if config.motion.blend_mm > 0 or swept else None
        path_start_s = state.path_start_s()
        rounded = (
            blended(config, steps, T_base_tcp_start, path_start_s)
            if T_base_tcp_start is not None
            else steps
        )
        checks = check_steps(config, rounded, arm, state.fixed_verdicts, T_base_tcp_start)
        if T_base_tcp_start is not None:
            checks = with_scene_checks(
                config, rounded, T_base_tcp_start, T_flange_tcp, checks, arm.joint_positions()
            )
        plan = {"operation": what, "config": str(config.path)}
        return Planned(
            rounded, checks, {**plan, "host": state.host}, T_base_tcp_start, path_start_s
        )

    def finish(done: Executed | None) -> dict[str, object]:
        if done is not None:
            reached.update(done.reached)
        return {"status": Status.DONE}

    run_operation(
        state,
        {"cycle": state.cycle, "request_id": request_id, **record},
        prepare,
        finish,
        outcome_fields={"operation": what},
        holding=state.holding,
    )
    return reached


def named_move(pose: NamedPose) -> Step:
    """The step to a named pose: a moveJ for joints, a moveL (a fixed target) for a TCP pose."""
    if pose.q_rad is not None:
        return JointMove(pose.name, pose.q_rad)
    if pose.T_base_tcp is None:  # the config loader allows exactly one of the two
        raise ConfigError(f"pose {pose.name!r} has neither joints nor a TCP pose")
    return Move(pose.name, pose.T_base_tcp, fixed=True)
