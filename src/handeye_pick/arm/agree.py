"""The connect-time checks that ``robot.model`` is the arm on the controller: the dashboard's
robot model where the controller has it, and the model's TCP against the controller's.

Frames and units: ``T_base_tcp`` and ``T_flange_tcp`` float64 4x4 in metres; joints radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from handeye_pick.arm.kinematics import tcp_poses
from handeye_pick.arm.models import ArmModel
from handeye_pick.errors import SafetyRefusal
from handeye_pick.geometry import Transform, rotation_angle_between

TCP_AGREEMENT_M = 0.005
"""The model's TCP (its forward kinematics of the controller's joints with the configured TCP
offset) and the controller's own may differ by this much (m) ..."""
TCP_AGREEMENT_DEG = 0.5
"""... and this much (deg): a real arm carries its own kinematic calibration (millimetres from
the published DH table), which the controller uses and the model does not."""


class ArmModelMismatch(SafetyRefusal):
    """``robot.model`` is not the arm the controller drives, or the TCP offsets differ: nothing
    moved."""


def dashboard_name(model: ArmModel) -> str:
    """How a controller's dashboard names the arm: ``UR5`` for a UR5 and a UR5e alike."""
    return model.name.upper().removesuffix("E")


def check_dashboard_model(
    model: ArmModel, answer: str, version: tuple[int, ...] | None, host: str
) -> None:
    """Refuse when the dashboard's ``get robot model`` answer (``UR5``) or the PolyScope
    ``version`` (3: CB3, 5: e-Series) says the arm is not ``model``."""
    said = answer.strip().upper().removesuffix("E")
    series = None if version is None else version[0]
    wrong_series = (series == 3 and model.e_series) or (series == 5 and not model.e_series)
    if said != dashboard_name(model) or wrong_series:
        controller = "a CB3" if series == 3 else "an e-Series" if series == 5 else "a"
        raise ArmModelMismatch(
            f"robot.model is {model.name}, but the controller at {host} drives {controller} "
            f"{answer.strip()} (dashboard 'get robot model'): set robot.model to the arm on "
            "the controller"
        )


def check_tcp_agrees(
    model: ArmModel,
    q_rad: Sequence[float],
    T_base_tcp: Transform,
    T_flange_tcp: Transform,
    host: str,
) -> None:
    """Refuse when the model's TCP at the controller's joints ``q_rad`` (with the configured
    ``T_flange_tcp``) lies farther than ``TCP_AGREEMENT_M`` / ``TCP_AGREEMENT_DEG`` from the
    controller's actual TCP ``T_base_tcp``."""
    T_model = tcp_poses(model, np.asarray(q_rad, dtype=np.float64), T_flange_tcp)[0]
    off_mm = 1000.0 * float(np.linalg.norm(T_model[:3, 3] - T_base_tcp[:3, 3]))
    off_deg = math.degrees(rotation_angle_between(T_model[:3, :3], T_base_tcp[:3, :3]))
    if off_mm > TCP_AGREEMENT_M * 1000.0 or off_deg > TCP_AGREEMENT_DEG:
        raise ArmModelMismatch(
            f"the {model.name} model puts the TCP {off_mm:.1f} mm and {off_deg:.2f} deg from "
            f"where the controller at {host} has it (at most {TCP_AGREEMENT_M * 1000:.0f} mm "
            f"and {TCP_AGREEMENT_DEG} deg): check robot.model, and that robot.tcp_offset is the "
            "TCP offset active on the pendant"
        )
