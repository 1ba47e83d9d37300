"""The child process that owns the ur_rtde objects; the parent talks to it over a Pipe.

Run as a script, ``python .../robot/ur/worker.py FD HOST WATCHDOG_S [--io]``, by
robot/ur/child.py (WATCHDOG_S: see ``WATCHDOG_KICKS_PER_WINDOW``): FD is this end of a socket
pair used as a ``multiprocessing.connection.Connection``. As a script it imports
only the standard library and ur_rtde (importing the package would load numpy, scipy and numba,
half a second per connection), so everything it sends is plain data: dicts, lists, numbers.

Why a child process: after a lost connection ur_rtde 1.6.5 reconnects by itself, loops and can
segfault the process (docs/ur-rtde.md, "What makes the client throw or hang"). Here that can only
kill this child; the parent sees a dead pipe, reports a RobotConnectionError and stops the robot
through a fresh dashboard connection. The child ignores SIGINT so the parent can still send stopL
after Ctrl-C.

The child opens no dashboard connection of its own: the parent's one dashboard connection
(robot/ur/dashboard.py) asks the PolyScope version and Remote Control, before this process starts
and before every move. ur_rtde's control interface still connects to the dashboard server by
itself while it connects (docs/ur-rtde.md, "Dashboard server"); it is told not to ask Remote
Control there.

Protocol: the child answers ``("hello", None)`` or ``("failure", Failure fields)``
after connecting, then one reply per request ``(operation, args)``: ``("ok", result)`` or
``("failure", Failure fields)``; samples travel as ``Sample`` fields. Poses cross the pipe as UR
vectors (m, rad) in plain lists; the parent does all frame maths. ``close`` first ends the
session's control script (``_Session.end_program``), answers what became of it, and leaves.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from multiprocessing.connection import Connection
from typing import Any

FRESH_SAMPLE_TIMEOUT_S = 0.5
"""How long to wait for an RTDE sample newer than the request (250 cycles at 500 Hz)."""
FIRST_SAMPLE_TIMEOUT_S = 1.0
"""How long a new receive interface may go without data before the connection fails."""
PROGRAM_START_TIMEOUT_S = 5.0
"""The longest the control script uploaded again may take to run: a CB3 takes about 2 ms a line,
2.4 s for ur_rtde's script (docs/ur-rtde.md, "Blended paths")."""
WATCHDOG_KICKS_PER_WINDOW = 8
"""ur_rtde's controller-side watchdog (docs/field-experience.md, "A supervisor's SIGTERM, a crash,
a power cut"): the control script stops the program, and
the arm, when this process has not written its command register for WATCHDOG_S seconds. It is
kicked eight times per window (a kick is one register write, no round trip) for as long as the
parent's pipe is open, idle or busy, so the program stops about WATCHDOG_S after the parent dies
or this process does (SIGKILL, a crash, a power cut)."""
# robot/port.py's SafetyMode NORMAL and REDUCED, RobotMode RUNNING, RuntimeState PLAYING (not
# imported: see above).
SAFETY_MODES_THAT_RUN = (1, 2)
ROBOT_MODE_RUNNING = 7
RUNTIME_PLAYING = 2


@dataclass(frozen=True)
class Failure:
    """An exception raised in the child, by type name and message (ur_rtde raises RuntimeError).

    ``safety_mode`` and ``robot_mode`` are set when the control interface failed to connect
    but the receive interface had: they tell why the controller refused to run the program.
    """

    operation: str
    exception_type: str
    message: str
    safety_mode: int | None = None
    robot_mode: int | None = None


class LinkLost(Exception):
    """The RTDE stream is gone or stale; the parent ends the session on this type name."""


class _ConnectRefused(Exception):
    """The controller cannot run ur_rtde's control program; the modes read on the receive
    interface say why (protective stop, emergency stop, arm off)."""

    def __init__(self, cause: Exception, safety_mode: int, robot_mode: int) -> None:
        super().__init__(str(cause))
        self.cause = cause
        self.safety_mode = safety_mode
        self.robot_mode = robot_mode


@dataclass(frozen=True)
class Sample:
    """One read of the receive and control interfaces' cached RTDE state (no controller call).

    ``tcp_pose`` is ``actual_TCP_pose`` as a UR vector (m, rad) in the base frame.
    """

    timestamp_s: float
    tcp_pose: list[float]
    q: list[float]  # actual_q, joint positions (rad)
    qd: list[float]  # actual_qd, joint speeds (rad/s)
    robot_mode: int
    safety_mode: int
    runtime_state: int
    protective_stopped: bool
    emergency_stopped: bool
    async_running: bool
    async_operation_id: int
    async_progress: int  # a path's waypoint in progress (0 for a single move)
    receive_connected: bool
    control_connected: bool
    speed_scaling: float  # speed slider x controller speed scaling, 0..1
    digital_output_bits: int  # standard outputs bits 0-7, configurable 8-15, tool 16-17
    digital_input_bits: int  # the inputs, in the same layout


class _Session:
    """The ur_rtde interfaces of one connection; methods are the operations the parent calls."""

    def __init__(self, host: str, with_io: bool, watchdog_s: float) -> None:
        # Imported here: the parent process never loads ur_rtde.
        import rtde_control
        import rtde_io
        import rtde_receive

        self._receive: Any = rtde_receive.RTDEReceiveInterface(host)
        self._wait_for_data()
        safety_mode, robot_mode = (
            int(self._receive.getSafetyMode()),
            int(self._receive.getRobotMode()),
        )
        if safety_mode not in SAFETY_MODES_THAT_RUN or robot_mode != ROBOT_MODE_RUNNING:
            # The control script could not start; ur_rtde would try for 5 s before saying so.
            raise _ConnectRefused(
                RuntimeError("the controller cannot run a program in this state"),
                safety_mode,
                robot_mode,
            )
        try:
            # The parent asked Remote Control before starting this process, on its own
            # dashboard connection; ur_rtde would ask again on its own.
            flags = (
                rtde_control.RTDEControlInterface.FLAG_UPLOAD_SCRIPT
                | rtde_control.RTDEControlInterface.FLAG_DISABLE_REMOTE_CONTROL_CHECK
            )
            self._control: Any = rtde_control.RTDEControlInterface(host, -1.0, flags)
        except RuntimeError as exc:  # e.g. the program cannot start during a protective stop
            raise _ConnectRefused(
                exc, int(self._receive.getSafetyMode()), int(self._receive.getRobotMode())
            ) from exc
        self._watchdog_hz = 1.0 / watchdog_s
        self._arm_watchdog()
        self.kick_period_s = watchdog_s / WATCHDOG_KICKS_PER_WINDOW
        self._last_kick_s = time.monotonic()
        self._io: Any = rtde_io.RTDEIOInterface(host) if with_io else None
        # A refused RTDE start leaves the receive interface constructed but dead, its getters
        # returning zeros (docs/ur-rtde.md, "What makes the client throw or hang"): refuse it.
        if not self._receive.isConnected() or not self._control.isConnected():
            raise RuntimeError(
                "the controller did not start the RTDE data stream (receive connected: "
                f"{self._receive.isConnected()}, control connected: {self._control.isConnected()})"
            )

    def _arm_watchdog(self) -> None:
        if not self._control.setWatchdog(self._watchdog_hz):
            raise RuntimeError(f"the control script refused setWatchdog({self._watchdog_hz} Hz)")

    def _wait_for_data(self) -> None:
        """Until the first RTDE sample is in: after a refused start the receive interface comes
        back without data, its getters returning zeros (docs/ur-rtde.md, "What makes the client
        throw or hang")."""
        deadline = time.monotonic() + FIRST_SAMPLE_TIMEOUT_S
        while float(self._receive.getTimestamp()) <= 0.0:
            if time.monotonic() > deadline:
                raise RuntimeError(
                    f"the controller sent no RTDE data within {FIRST_SAMPLE_TIMEOUT_S} s "
                    "(RTDE synchronization not started)"
                )
            time.sleep(0.01)

    def sample(self) -> Sample:
        r, c = self._receive, self._control
        async_status = c.getAsyncOperationProgressEx()
        return Sample(
            timestamp_s=float(r.getTimestamp()),
            tcp_pose=list(r.getActualTCPPose()),
            q=list(r.getActualQ()),
            qd=list(r.getActualQd()),
            robot_mode=int(r.getRobotMode()),
            safety_mode=int(r.getSafetyMode()),
            runtime_state=int(r.getRuntimeState()),
            protective_stopped=bool(r.isProtectiveStopped()),
            emergency_stopped=bool(r.isEmergencyStopped()),
            async_running=bool(async_status.isAsyncOperationRunning()),
            async_operation_id=int(async_status.operationId()),
            async_progress=int(async_status.progress()),
            receive_connected=bool(r.isConnected()),
            control_connected=bool(c.isConnected()),
            speed_scaling=float(r.getSpeedScalingCombined()),
            digital_output_bits=int(r.getActualDigitalOutputBits()),
            digital_input_bits=int(r.getActualDigitalInputBits()),
        )

    def fresh_sample(self) -> Sample:
        """A sample received after this call started (the timestamp advanced)."""
        r = self._receive
        start = float(r.getTimestamp())
        deadline = time.monotonic() + FRESH_SAMPLE_TIMEOUT_S
        while float(r.getTimestamp()) <= start:
            if not r.isConnected() or time.monotonic() > deadline:
                raise LinkLost(
                    f"no RTDE sample newer than controller time {start:.3f} s within "
                    f"{FRESH_SAMPLE_TIMEOUT_S} s (receive connected: {r.isConnected()})"
                )
            time.sleep(0.0002)
        return self.sample()

    def kick_watchdog_if_due(self) -> None:
        """Feed the controller's watchdog when ``kick_period_s`` has passed since the last kick.
        A refused kick (program already stopped) is not an error here: the next command says."""
        now = time.monotonic()
        if now - self._last_kick_s >= self.kick_period_s:
            self._control.kickWatchdog()
            self._last_kick_s = now

    def require_link(self) -> None:
        """Refuse any controller call once the receive stream died: the control interface may
        have reconnected by itself since, and nothing may be sent through such a link. The
        receive interface never reconnects, so its state tells whether the link ever broke."""
        if not self._receive.isConnected():
            raise LinkLost("the RTDE connection was lost")

    def tcp_offset(self) -> list[float]:
        return list(self._control.getTCPOffset())

    def is_pose_within_safety_limits(self, pose: list[float]) -> bool:
        return bool(self._control.isPoseWithinSafetyLimits(pose))

    def has_ik_solution(self, pose: list[float]) -> bool:
        return bool(self._control.getInverseKinematicsHasSolution(pose))

    def move_l_async(self, pose: list[float], speed_mps: float, accel_mps2: float) -> bool:
        return bool(self._control.moveL(pose, speed_mps, accel_mps2, True))

    def move_l_path_async(self, path: list[list[float]]) -> bool:
        """ur_rtde's moveL(path): it stops the control script, uploads it again with the path
        in it and starts the path; the new script has no watchdog until it is set again."""
        started = bool(self._control.moveL(path, True))
        self._arm_watchdog()
        return started

    def restart_script(self) -> float:
        """Stop the control script, upload it again and wait until the controller runs it
        (ur_rtde's reuploadScript returns before that); the seconds it took. As after a path,
        the new script has no watchdog until it is set again, which this does."""
        started = time.monotonic()
        if not self._control.reuploadScript():
            raise RuntimeError("the controller did not take the control script again")
        deadline = started + PROGRAM_START_TIMEOUT_S
        while not self._control.isProgramRunning():
            if time.monotonic() > deadline:
                raise RuntimeError(
                    f"the control script uploaded again did not run within "
                    f"{PROGRAM_START_TIMEOUT_S} s"
                )
            time.sleep(0.001)
        seconds = time.monotonic() - started
        self._arm_watchdog()
        return seconds

    def stop_l(self, decel_mps2: float) -> None:
        self._control.stopL(decel_mps2, False)

    def is_joints_within_safety_limits(self, q: list[float]) -> bool:
        return bool(self._control.isJointsWithinSafetyLimits(q))

    def move_j_async(self, q: list[float], speed_rps: float, accel_rps2: float) -> bool:
        return bool(self._control.moveJ(q, speed_rps, accel_rps2, True))

    def stop_j(self, decel_rps2: float) -> None:
        self._control.stopJ(decel_rps2, False)

    def end_program(self) -> str:
        """End of the session: stop ur_rtde's control script, so the controller is left with no
        program instead of this session's until its watchdog stops it (docs/ur-rtde.md, "The
        script's loop"). Only while the script plays with no stop active: otherwise nothing is
        sent and the reason comes back.

        ``stopScript()`` writes 255 to the command register this session holds, which only
        ur_rtde's control script reads as a command: unlike a dashboard ``stop`` it cannot end a
        program that is not ours (a pendant program started since). It then waits up to 300 s
        for the program to stop, which such a program never does: the parent's bound on the
        ``close`` call (``call_timeout_s``, robot/ur/child.py) ends this process first.
        """
        r = self._receive
        runtime_state, safety_mode = int(r.getRuntimeState()), int(r.getSafetyMode())
        if runtime_state != RUNTIME_PLAYING or safety_mode not in SAFETY_MODES_THAT_RUN:
            return f"not sent: runtime state {runtime_state}, safety mode {safety_mode}"
        self._control.stopScript()
        return f"sent: runtime state {int(r.getRuntimeState())} after it"

    def set_payload(self, mass_kg: float, cog_m: list[float]) -> bool:
        return bool(self._control.setPayload(mass_kg, cog_m))

    def set_standard_digital_out(self, index: int, value: bool) -> bool:
        return bool(self._require_io().setStandardDigitalOut(index, value))

    def set_tool_digital_out(self, index: int, value: bool) -> bool:
        return bool(self._require_io().setToolDigitalOut(index, value))

    def _require_io(self) -> Any:
        if self._io is None:
            raise RuntimeError("the IO interface was not opened (no gripper output configured)")
        return self._io


def serve(conn: Connection, host: str, with_io: bool, watchdog_s: float) -> None:
    """Connect, announce, answer requests until ``close`` or EOF (the parent is gone)."""
    # Only the parent decides when to stop the robot; its own session keeps a terminal's Ctrl-C
    # away already, this keeps away one sent to the process group.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        session = _Session(host, with_io, watchdog_s)
    except _ConnectRefused as exc:
        failure = Failure(
            "connect", type(exc.cause).__name__, str(exc), exc.safety_mode, exc.robot_mode
        )
        _answer(conn, ("failure", asdict(failure)))
        os._exit(0)
    except Exception as exc:  # every failure goes back to the parent, typed there
        _answer(conn, ("failure", asdict(Failure("connect", type(exc).__name__, str(exc)))))
        os._exit(0)
    _answer(conn, ("hello", None))
    operations: dict[str, Callable[..., object]] = {
        "sample": session.sample,
        "fresh_sample": session.fresh_sample,
        "tcp_offset": session.tcp_offset,
        "is_pose_within_safety_limits": session.is_pose_within_safety_limits,
        "has_ik_solution": session.has_ik_solution,
        "move_l_async": session.move_l_async,
        "move_l_path_async": session.move_l_path_async,
        "restart_script": session.restart_script,
        "stop_l": session.stop_l,
        "is_joints_within_safety_limits": session.is_joints_within_safety_limits,
        "move_j_async": session.move_j_async,
        "stop_j": session.stop_j,
        "set_payload": session.set_payload,
        "set_standard_digital_out": session.set_standard_digital_out,
        "set_tool_digital_out": session.set_tool_digital_out,
    }
    while True:
        # Idle or busy, the watchdog is fed between requests while the parent is alive.
        session.kick_watchdog_if_due()
        if not conn.poll(session.kick_period_s):
            continue
        try:
            operation, args = conn.recv()
        except (EOFError, OSError):  # parent gone: leave; the starved watchdog stops the program
            os._exit(0)
        if operation == "close":
            _answer(conn, ("ok", _end_program(session)))
            os._exit(0)
        try:
            if operation != "sample":
                session.require_link()
            result = operations[operation](*args)
            reply: tuple[str, object] = (
                "ok",
                asdict(result) if isinstance(result, Sample) else result,
            )
        except Exception as exc:
            reply = ("failure", asdict(Failure(operation, type(exc).__name__, str(exc))))
        _answer(conn, reply)


def _end_program(session: _Session) -> str:
    """What became of the session's control script at close (``_Session.end_program``); a
    failure is reported, not raised: the process leaves either way, and the watchdog stops the
    script that is left."""
    try:
        session.require_link()
        return session.end_program()
    except Exception as exc:
        return f"not ended ({type(exc).__name__}: {exc}): the watchdog stops it"


def _answer(conn: Connection, reply: tuple[str, object]) -> None:
    """Send ``reply``; a parent gone mid-request (killed) ends this process at once, as at end of
    file. Exiting closes every socket, which is all ur_rtde's disconnect() does on the wire (no
    STOP_SCRIPT, no RTDE pause); an exception would exit through its destructors instead, 0.5 s
    of sleep each, holding the controller's RTDE input registers against a restarted session."""
    try:
        conn.send(reply)
    except OSError:
        os._exit(0)


def main() -> None:
    conn = Connection(int(sys.argv[1]))
    serve(conn, sys.argv[2], with_io="--io" in sys.argv[4:], watchdog_s=float(sys.argv[3]))


if __name__ == "__main__":
    main()
