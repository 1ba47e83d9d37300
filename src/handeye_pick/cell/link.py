"""A cell session's connections: the robot's lock, the audit file, the robot session and the
gripper, opened in that order and closed in the reverse.

The lock comes first (one session per robot: ``CellInUse`` names the holder, and nothing is
opened or sent); the audit file is open before anything is sent to the robot, so a failure to
connect is on disk too.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from handeye_pick.arm.agree import check_tcp_agrees
from handeye_pick.audit import AuditLog, open_audit
from handeye_pick.cell.lock import CellLock
from handeye_pick.cell.records import append_failure
from handeye_pick.config.gripper import GripperConfig
from handeye_pick.config.schema import CellConfig
from handeye_pick.errors import RobotConnectionError
from handeye_pick.gripper import Gripper, connect_gripper
from handeye_pick.progress import Progress
from handeye_pick.robot.port import RobotArm, SampleListener

log = logging.getLogger(__name__)

ArmFactory = Callable[[CellConfig], RobotArm]


def connect_ur_rtde(config: CellConfig, on_sample: SampleListener | None = None) -> RobotArm:
    """The ur_rtde session for a cell (IO only when a gripper output or a line output is
    configured); ``on_sample`` hears every RTDE sample it reads. With ``line.io``, the session
    also serves the line's wired handshake (``robot.ur.line_io``)."""
    from handeye_pick.robot.ur.arm import URRtdeArm
    from handeye_pick.robot.ur.line_io import LineIoArm

    return (URRtdeArm if config.line.io is None else LineIoArm)(
        config.robot.host,
        with_io=isinstance(config.robot.gripper, GripperConfig)
        or (config.line.io is not None and bool(config.line.io.outputs)),
        stop_decel_mps2=config.motion.stop_decel_mps2,
        watchdog_s=config.robot.watchdog_s,
        on_sample=on_sample,
        model=config.robot.model,
    )


class Link:
    """The connections of one cell session. ``connect`` makes the robot session (ur_rtde by
    default); ``on_audit`` hears every audit line written (the observer)."""

    def __init__(
        self,
        config: CellConfig,
        connect: ArmFactory,
        progress: Progress,
        on_audit: Callable[[str], None] | None,
    ) -> None:
        self._config = config
        self._connect_arm = connect
        self._progress = progress
        self._on_audit = on_audit
        self._lock = CellLock(config.robot.host)
        self._audit: AuditLog | None = None
        self._arm: RobotArm | None = None
        self.gripper: Gripper | None = None

    def open_audit(self) -> None:
        """Take the robot's lock, then open the audit file (``audit.open_audit``: appendable,
        locked, unfinished picks of a killed process closed as abandoned)."""
        self._lock.acquire()
        if self._audit is None:
            self._audit, warnings = open_audit(self._config.audit.file)
            for warning in warnings:
                log.warning("%s", warning)
            self._audit.on_append = self._on_audit

    def connect_robot(self, audit: AuditLog, request_id: str | None) -> None:
        """The robot session (with ``robot.model``: refused when the model's TCP disagrees with the
        controller's, ``arm/agree.py``) and the gripper; a failure is audited in ``audit`` (step
        ``connect``), everything opened so far is closed, and the error raised."""
        outcome: dict[str, object] = {"event": "outcome", "step": "connect", "reached": {}}
        if request_id is not None:
            outcome["request_id"] = request_id
        try:
            with self._progress.step(f"connecting to {self._config.robot.host}"):
                self._arm = self._connect_arm(self._config)
                robot = self._config.robot
                if robot.model is not None:
                    T_base_tcp = self._arm.tcp_pose()
                    q = self._arm.joint_positions()  # the same sample or a newer one
                    check_tcp_agrees(robot.model, q, T_base_tcp, robot.T_flange_tcp, robot.host)
                if self._config.motion.blend_mm > 0:
                    # Corners are sent only where they save more than a path's start costs on
                    # this controller (cell/stretch.py): measured now, the arm at rest.
                    self._arm.measure_path_start()
                self.gripper = connect_gripper(
                    robot.gripper, robot.host, self._arm, self._progress.say
                )
        except BaseException as exc:
            append_failure(audit, outcome, exc)
            self.close_robot()
            raise

    def close(self) -> None:
        """Close the robot session, then release the lock and the audit file; safe twice."""
        self.close_robot()
        self._lock.release()
        if self._audit is not None:
            self._audit.close()
            self._audit = None

    def close_robot(self) -> None:
        """Close the gripper's and the robot's connections (a resume opens fresh ones)."""
        if self.gripper is not None:
            self.gripper.close_connection()
            self.gripper = None
        if self._arm is not None:
            self._arm.close()
            self._arm = None

    def next_audit(self) -> AuditLog:
        """The audit log of the session's next record group (a new pick id, the session's
        lock)."""
        if self._audit is None:
            raise RobotConnectionError(
                f"cell {self._config.robot.host}: not connected (use the Cell as a context "
                "manager)"
            )
        return self._audit.next_pick()

    @property
    def connected(self) -> bool:
        """Whether a robot session is open."""
        return self._arm is not None

    @property
    def arm(self) -> RobotArm:
        """The connected robot; RobotConnectionError when the session is closed or lost."""
        if self._arm is None:
            raise RobotConnectionError(
                f"cell {self._config.robot.host}: not connected (use the Cell as a context "
                "manager, or resume after a lost link)"
            )
        return self._arm
