"""The audit records of a sequence: the plan before the first motion, the outcome after it,
whatever the ending (``audited_outcome``).

Records carry UR pose vectors (m, rad) and 4x4 matrices in metres; the statuses come from the
one table in ``errors`` (``ending``).
"""

from __future__ import annotations

import logging
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, replace

from handeye_pick.audit import AuditLog
from handeye_pick.cell.plan import PickPlan, blended_stretches
from handeye_pick.config.schema import CellConfig
from handeye_pick.detection import Detection
from handeye_pick.errors import RobotFault, Terminated, ending
from handeye_pick.geometry import Transform, ur_pose_list
from handeye_pick.hand_eye.files import HandEyeCalibration
from handeye_pick.safety import PreflightRefusal
from handeye_pick.steps import Grip, Move, Step

log = logging.getLogger(__name__)


def failure_fields(exc: BaseException) -> dict[str, object]:
    """``status`` (``errors.ending``) and ``error`` of an outcome record for the exception that
    ended a sequence."""
    status = ending(exc).outcome
    if isinstance(exc, KeyboardInterrupt):
        signal_name = "SIGTERM" if isinstance(exc, Terminated) else "SIGINT"
        return {"status": status, "error": {"type": type(exc).__name__, "signal": signal_name}}
    error: dict[str, object] = {"type": type(exc).__name__, "message": str(exc)}
    if isinstance(exc, RobotFault):
        error.update(
            safety_mode=exc.safety_mode, runtime_state=exc.runtime_state, robot_mode=exc.robot_mode
        )
    if isinstance(exc, PreflightRefusal):
        error["checks"] = [asdict(check) for check in exc.results]
    return {"status": status, "error": error}


@contextmanager
def audited_outcome(audit: AuditLog, outcome: dict[str, object]) -> Iterator[dict[str, object]]:
    """Append ``outcome`` when the block ends, however it ends.

    The block fills ``outcome`` (``status`` at least) as it goes; when it raises, the failure's
    ``status`` and ``error`` are added and the record is appended before the error propagates
    (a failing append is logged and does not hide that error).
    """
    try:
        yield outcome
    except BaseException as exc:
        append_failure(audit, outcome, exc)
        raise
    audit.append(outcome)


def append_failure(audit: AuditLog, outcome: dict[str, object], exc: BaseException) -> None:
    """Append ``outcome`` with the failure's fields while ``exc`` propagates: a failing append
    is logged and must not hide ``exc``."""
    outcome.update(failure_fields(exc))
    try:
        audit.append(outcome)
    except Exception:
        log.exception("could not append the outcome to the audit log: %s", outcome)


def plan_record(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detection: Detection,
    plan: PickPlan,
    flange_pose_source: str,
) -> dict[str, object]:
    """The plan part of a pick's audit record: inputs, calibration, chain, pick targets."""
    motion = config.motion
    return {
        "config": str(config.path),
        "host": config.robot.host,
        "detection": _detection_record(detection),
        "calibration": {
            "file": str(calibration.path),
            "sha256": calibration.sha256,
            "mode": calibration.mode.value,
            "units": calibration.units,
            "inverted": calibration.inverted,
        },
        "tcp_offset": ur_pose_list(plan.T_flange_tcp),
        "flange_pose": ur_pose_list(plan.T_base_flange),
        "flange_pose_source": flange_pose_source,
        "T_base_cam": plan_matrix(plan.T_base_cam),
        "T_base_obj": plan_matrix(plan.T_base_obj),
        "motion": {
            "speed_mps": motion.speed_mps,
            "grasp_speed_mps": motion.grasp_speed_mps,
            "accel_mps2": motion.accel_mps2,
        },
    }


def _detection_record(detection: Detection) -> dict[str, object]:
    """The detection as the plan record holds it; its size and symmetry only when given."""
    record: dict[str, object] = {
        "source": detection.source,
        "position_only": detection.position_only,
        "T_cam_obj": plan_matrix(detection.T_cam_obj),
    }
    if detection.size_mm is not None:
        record["size_mm"] = list(detection.size_mm)
    if detection.symmetry is not None:
        order = detection.symmetry.order
        record["symmetry"] = {"axis": detection.symmetry.axis, "order": order or "inf"}
    return record


def steps_record(steps: Sequence[Step]) -> dict[str, object]:
    """Every move's target (UR vector, m and rad, or joints in rad) in order, for the audit."""
    return {
        step.name: ur_pose_list(step.T_base_tcp) if isinstance(step, Move) else list(step.q_rad)
        for step in steps
        if not isinstance(step, Grip)
    }


def blends_record(steps: Sequence[Step]) -> dict[str, object]:
    """``{"blends_mm": {move: radius}}`` for the blended targets of ``steps`` (mm; the moves
    between two stops are driven as one path), or nothing when every target is a stop."""
    blends = {
        step.name: round(step.blend_m * 1000.0, 3)
        for step in steps
        if isinstance(step, Move) and step.blend_m > 0.0
    }
    return {"blends_mm": blends} if blends else {}


def stretches_record(
    config: CellConfig,
    steps: Sequence[Step],
    T_base_tcp_start: Transform | None,
    path_start_s: float | None,
) -> dict[str, object]:
    """``{"stretches": [...]}``: each stretch where corners were planned, how it is sent and
    why (``stretch.Stretch.record``); nothing when no corner was planned. The choice is made
    again from the same targets, start pose and start cost as ``plan.blended`` made it."""
    if T_base_tcp_start is None or path_start_s is None or config.motion.blend_mm <= 0.0:
        return {}
    plain = [replace(step, blend_m=0.0) if isinstance(step, Move) else step for step in steps]
    _, stretches = blended_stretches(config, plain, T_base_tcp_start, path_start_s)
    return {"stretches": [s.record() for s in stretches]} if stretches else {}


def plan_matrix(T: Transform) -> list[list[float]]:
    return [[float(v) for v in row] for row in T]
