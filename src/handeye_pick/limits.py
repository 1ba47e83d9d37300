"""Speed and acceleration caps: the one place both the config loader and the pre-flight read.

TCP speeds are m/s and accelerations m/s^2 (moveL); joint speeds rad/s and accelerations rad/s^2
(moveJ to a named joint pose). Pure data and one pure check, no imports of the package, so every
module can depend on it without an import circle.
"""

from __future__ import annotations

# ur_rtde refuses a moveL/stopL or moveJ/stopJ outside these (its own argument check).
UR_MAX_SPEED_MPS = 3.0
UR_MAX_ACCEL_MPS2 = 150.0
UR_MAX_JOINT_SPEED_RPS = 3.14
UR_MAX_JOINT_ACCEL_RPS2 = 40.0

# Stricter caps for a camera-guided pick: the target is only as good as the calibration and the
# detection, so the arm moves slowly enough for an operator to hit the stop in time.
MAX_SPEED_MPS = 1.0  # approach, retreat and place moves
MAX_GRASP_SPEED_MPS = 0.25  # the final move onto the object (UR's default moveL speed)
MAX_ACCEL_MPS2 = 4.0  # every linear move; UR's default moveL acceleration is 1.2 m/s^2
MAX_JOINT_SPEED_RPS = 1.05  # moveJ to a named pose: UR's default moveJ speed
MAX_JOINT_ACCEL_RPS2 = 1.4  # moveJ to a named pose: UR's default moveJ acceleration
JOINT_STOP_DECEL_RPS2 = 4.0  # stopJ after a fault or a signal: faster than any moveJ start


def stop_decel_problem(stop_decel_mps2: float, accel_mps2: float) -> str | None:
    """None when the stopL deceleration is at least the moves' acceleration and within ur_rtde's
    limit: stopping after a fault must never be gentler than starting."""
    if accel_mps2 <= stop_decel_mps2 <= UR_MAX_ACCEL_MPS2:
        return None
    return (
        f"stop deceleration {stop_decel_mps2:g} m/s^2 outside [{accel_mps2:g} (the move "
        f"acceleration), {UR_MAX_ACCEL_MPS2:g}] m/s^2"
    )
