"""What the session's failures mean for the operator, as typed errors that say what to do.

ur_rtde reports every failure as a RuntimeError with an English text; the child process
(robot/ur/worker.py) sends it over as a ``Failure``. The session's own dashboard connection
(robot/ur/dashboard.py) fails with an ``OSError``. These functions turn either into the error the
session raises: ``SafetyRefusal`` when the cell is not in a state to run (Local mode, a stop, the
arm off), ``RobotConnectionError`` when the link cannot be made or is lost, ``RobotFault`` when
the controller refused one command (docs/ur-rtde.md, "What makes the client throw or hang").
"""

from __future__ import annotations

from handeye_pick.arm.agree import ArmModelMismatch, check_dashboard_model
from handeye_pick.arm.models import ArmModel
from handeye_pick.errors import RobotConnectionError, RobotError, RobotFault, SafetyRefusal
from handeye_pick.robot.port import RobotMode, SafetyMode, mode_name
from handeye_pick.robot.ur.dashboard import DASHBOARD_PORT, Dashboard
from handeye_pick.robot.ur.worker import Failure, LinkLost

# Parts of ur_rtde's RuntimeError texts (1.6.5) and what to tell the operator instead.
_CONNECT_ERROR_HINTS: tuple[tuple[str, str], ...] = (
    (
        "already in use",
        "the RTDE input registers are held by another RTDE client (a URCap such as External "
        "Control, a ROS driver, another script, or an EtherNet/IP, PROFINET or MODBUS adapter "
        "enabled on the robot): stop or disable it, then retry",
    ),
    (
        "dashboard server",
        "the controller's dashboard server (port 29999) does not answer. PolyScope X has none, "
        "and ur_rtde 1.6.5 needs it to run its control script, so handeye-pick cannot drive a "
        "PolyScope X controller; on PolyScope 5 check that the dashboard server is enabled "
        "(Settings > Security > Services)",
    ),
    (
        "Could not connect",
        "nothing answers on port 30004: check the address, the network cable and that the "
        "controller is booted",
    ),
    (
        "control script",
        "the controller did not start ur_rtde's control script: check on the pendant that the "
        "robot is powered on, brakes released, no protective stop or popup is pending",
    ),
)

# Why a controller refuses to start a program, and what the operator does about it.
_STOP_ADVICE: dict[int, str] = {
    SafetyMode.PROTECTIVE_STOP: "a protective stop is active: remove its cause, then press "
    "'Enable robot' on the pendant (nothing unlocks it automatically)",
    SafetyMode.ROBOT_EMERGENCY_STOP: "an emergency stop is active: make the cell safe, release "
    "the emergency stop button, then power on and release the brakes",
    SafetyMode.SYSTEM_EMERGENCY_STOP: "a system emergency stop is active: make the cell safe, "
    "reset it, then power on and release the brakes",
    SafetyMode.SAFEGUARD_STOP: "a safeguard stop is active: close and reset the safeguard",
}


def connect_error(host: str, failure: Failure) -> RobotError | SafetyRefusal:
    """The error for a session that could not connect to ``host``.

    The controller's modes come first (read on the receive interface when the control interface
    was refused): a stop or an arm that is off is a ``SafetyRefusal`` with the pendant steps.
    Then ur_rtde's text, as a ``RobotConnectionError``.
    """
    if failure.safety_mode is not None and failure.robot_mode is not None:
        advice = _STOP_ADVICE.get(failure.safety_mode)
        if advice is None and failure.robot_mode != RobotMode.RUNNING:
            advice = (
                f"the arm is not running (robot mode "
                f"{mode_name(RobotMode, failure.robot_mode)}): power it on and release the "
                "brakes on the pendant"
            )
        if advice is not None:
            return SafetyRefusal(
                f"connect to {host}: the controller cannot run ur_rtde's control "
                f"program: {advice} (ur_rtde: {failure.message})"
            )
    for fragment, hint in _CONNECT_ERROR_HINTS:
        if fragment in failure.message:
            return RobotConnectionError(f"connect to {host}: {hint} (ur_rtde: {failure.message})")
    return RobotConnectionError(f"connect to {host}: {failure.exception_type}: {failure.message}")


def call_error(host: str, failure: Failure) -> RobotError:
    """The error for one failed call on a connected session: ``RobotConnectionError`` when the
    child found the RTDE stream stale or gone (``LinkLost``: the session is over), otherwise
    ``RobotFault`` (the controller refused, "did not succeed", or an argument was bad)."""
    text = f"{failure.operation} on {host}: {failure.exception_type}: {failure.message}"
    if failure.exception_type == LinkLost.__name__:
        return RobotConnectionError(text)
    return RobotFault(text)


def local_mode_refusal(host: str) -> SafetyRefusal:
    """A session refused at connect because the pendant is in Local mode (nothing was sent)."""
    return SafetyRefusal(
        f"connect to {host} refused, nothing sent: the robot is in Local mode: switch the teach "
        "pendant to Remote Control (enable it under Settings > System > Remote Control first), "
        "then retry"
    )


def dashboard_connect_error(host: str, exc: OSError) -> RobotConnectionError:
    """The dashboard server could not be reached or asked when a session connects: the first
    thing a session does, so also what a wrong address or a controller that is off gives."""
    return RobotConnectionError(
        f"connect to {host}: the dashboard server (port {DASHBOARD_PORT}) does not answer "
        f"({exc or type(exc).__name__}): check the address, the network cable and that the "
        "controller is booted, and on PolyScope 5 that the dashboard server is enabled "
        "(Settings > Security > Services); PolyScope X has none, so handeye-pick cannot drive it"
    )


def dashboard_lost_error(host: str, operation: str, exc: OSError) -> RobotConnectionError:
    """The session's dashboard connection failed mid-session; the session has stopped the arm
    and ended."""
    return RobotConnectionError(
        f"{operation} on {host}: the dashboard server (port {DASHBOARD_PORT}) stopped answering "
        f"({exc or type(exc).__name__}): the session is over (the arm stopped through RTDE and "
        "the watchdog); check the controller and the network, then start a new session"
    )


def connect_dashboard(
    host: str, timeout_s: float, model: ArmModel | None = None
) -> tuple[Dashboard, tuple[int, ...] | None]:
    """A session's dashboard connection and PolyScope's version, the first thing a session
    opens; each failure as the error the operator reads. A controller in Local mode is refused
    here, before ur_rtde connects (its connection would stop the running program), and so is
    one whose dashboard names another arm than ``model`` (``robot.model``, arm/agree.py)."""
    try:
        dashboard = Dashboard(host, timeout_s)
    except OSError as exc:
        raise dashboard_connect_error(host, exc) from None
    try:
        version = dashboard.polyscope_version()
        remote = dashboard.in_remote_control(version)
        said = None if model is None else dashboard.robot_model(version)
    except BaseException as exc:
        dashboard.close()
        if isinstance(exc, OSError):
            raise dashboard_connect_error(host, exc) from None
        raise
    if not remote:
        dashboard.close()
        raise local_mode_refusal(host)
    if model is not None and said is not None:
        try:
            check_dashboard_model(model, said, version, host)
        except ArmModelMismatch:
            dashboard.close()
            raise
    return dashboard, version
