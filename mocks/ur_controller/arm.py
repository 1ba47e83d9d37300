"""The simulated arm: joints, active TCP offset, payload and the motion in progress.

Frames: `base` is the controller's base frame, `flange` the tool flange, `tcp` the flange moved by
the active TCP offset (T_flange_tcp, set on the pendant or by setTcp). Poses are UR vectors
[x, y, z, rx, ry, rz] (m, rad); joints q are 6 angles (rad).

Target and actual: `q` is the target (the trajectory the controller commands), `actual_q` what the
encoders report. Without `tracking` they are the same array. With it the actual joints follow the
target TRACKING_LAG_CYCLES control cycles late and carry Gaussian measurement noise of
JOINT_NOISE_RAD (standard deviation), see README.md for the magnitudes and their sources.
The fault `jitter:SECONDS` shakes the actual joints for a while (`Arm.jitter`).

moveL moves the TCP on a straight line (orientation by slerp) with a trapezoidal profile over the
translation (over the rotation angle, in rad, for a pure rotation), joints through IK nearest the
previous joints each cycle. moveJ interpolates joints with a trapezoidal profile over the largest
joint travel. The speed slider scales motion time as on the pendant (0 holds the arm).
stopL/stopJ/speedStop brake along the path at their deceleration; protective stops, program
stops and a new move replacing a running one halt the arm at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mocks.ur_controller import kinematics as kin
from mocks.ur_controller.blend import BlendedPath

Vector = NDArray[np.float64]

# The TCP must move at least this far (m) for moveL's speed to mean m/s; below it, rad/s.
_MIN_TRANSLATION_M = 1e-6

TRACKING_LAG_CYCLES = 3
"""With tracking, the actual joints are where the target was this many control cycles ago."""
JOINT_NOISE_RAD = 1e-5
"""With tracking, standard deviation of the measurement noise on each actual joint angle (about
0.01 mm at the TCP of an 0.85 m arm, a third of the UR5e's published +-0.03 mm repeatability)."""
STEADY_CYCLES = 2
"""is_steady(): the target has not moved for this many cycles and the actual joints caught up."""
JITTER_RAD = 0.005
"""While jittering, the actual base joint stands this far off the target (about 2.5 mm at the
flange of a UR5e at its home pose)."""
JITTER_SPEED_RPS = 0.05
"""While jittering, the actual base joint's speed on every cycle but the turning points."""
JITTER_PERIOD_CYCLES = 25
"""While jittering, one cycle in this many is a turning point: the actual speeds read zero."""


class UnreachableError(Exception):
    """A motion target or a point on the way has no joint solution within the limits."""


@dataclass
class Motion:
    """One move in progress. `index` counts motion commands from 1 (for move:K faults).

    Path quantities are in the motion's units: m for a linear move, rad for a pure rotation or
    a joint move (largest joint travel). A stop sets the `stop_*` fields: from `stop_at_s` on,
    the path speed falls from `stop_speed` at `stop_decel` until the arm is still. A blended
    path (`path`, command 45) is one motion: its own profile replaces the trapezoid, and
    `reached_s` collects the controller time each waypoint's move was done.
    """

    index: int
    kind: str  # the command that started it: moveL, moveJ, moveL_FK, moveJ_IK, movePath
    started_s: float  # controller time
    linear: bool
    distance: float
    speed: float
    accel: float
    duration_s: float
    q_start: Vector
    q_target: Vector
    T_base_tcp_start: Vector
    T_base_tcp_target: Vector
    elapsed_s: float = 0.0  # motion time (wall time x speed factor x speed slider)
    stop_at_s: float | None = None
    stop_from: float = 0.0  # path fraction where the stop began
    stop_speed: float = 0.0
    stop_decel: float = 0.0
    path: BlendedPath | None = None
    reached_s: list[float] = field(default_factory=list)

    @property
    def fraction(self) -> float:
        """Fraction of the move's planned duration elapsed, 0..1 (for move:K:FRACTION)."""
        return 1.0 if self.duration_s <= 0.0 else min(1.0, self.elapsed_s / self.duration_s)

    def planned(self, t: float) -> tuple[float, float]:
        """(path fraction, path speed) of the unstopped trapezoid at motion time t."""
        if t >= self.duration_s:
            return 1.0, 0.0
        if self.path is not None:
            covered, speed = self.path.profile.at(t)
            return covered / self.distance, speed
        peak = min(self.speed, math.sqrt(self.distance * self.accel))
        speed = max(0.0, min(peak, self.accel * t, self.accel * (self.duration_s - t)))
        return kin.trapezoid_fraction(t, self.distance, self.speed, self.accel), speed

    @property
    def braking(self) -> bool:
        """A stop has begun (its braking starts at motion time stop_at_s)."""
        return self.stop_at_s is not None and self.elapsed_s > self.stop_at_s

    def path_fraction(self) -> float:
        """Fraction of the path covered at elapsed_s, 0..1."""
        if self.stop_at_s is None or self.elapsed_s <= self.stop_at_s:
            return self.planned(self.elapsed_s)[0]
        t = min(self.elapsed_s - self.stop_at_s, self.stop_speed / self.stop_decel)
        covered = self.stop_speed * t - 0.5 * self.stop_decel * t * t
        return min(1.0, self.stop_from + covered / self.distance)

    def path_speed(self) -> float:
        """Speed along the path at elapsed_s (motion units per second of motion time)."""
        if self.stop_at_s is None or self.elapsed_s <= self.stop_at_s:
            return self.planned(self.elapsed_s)[1]
        return max(0.0, self.stop_speed - self.stop_decel * (self.elapsed_s - self.stop_at_s))

    def stop(self, at_s: float, decel: float) -> None:
        """Brake at `decel` from motion time `at_s` on (which may lie a cycle ahead)."""
        self.stop_from, self.stop_speed = self.planned(at_s)
        self.stop_decel = decel
        self.stop_at_s = at_s

    def end_time(self) -> float:
        """Motion time at which the arm comes to rest: the trapezoid's end, or a stop's."""
        if self.stop_at_s is None:
            return self.duration_s
        v, a = self.stop_speed, self.stop_decel
        remaining = (1.0 - self.stop_from) * self.distance
        if v * v / (2.0 * a) <= remaining:
            return self.stop_at_s + v / a
        return self.stop_at_s + (v - math.sqrt(v * v - 2.0 * a * remaining)) / a  # target first

    @property
    def finished(self) -> bool:
        return self.elapsed_s >= self.end_time()


@dataclass(frozen=True)
class MotionEnd:
    """How and when (controller time) a motion ended: `reason` is "reached" (at its target),
    "stopped" (braked to rest by stopL/stopJ/speedStop) or why it was halted at once."""

    motion: Motion
    end_s: float
    reason: str
    detail: dict[str, float] | None = None  # watchdog stops: last update time, minimum frequency


class Tracking:
    """Actual joints: the target TRACKING_LAG_CYCLES cycles late, plus measurement noise."""

    def __init__(self, q: Vector, seed: int):
        self._history = [q.copy() for _ in range(TRACKING_LAG_CYCLES + 1)]
        self._rng = np.random.default_rng(seed)

    def update(self, q_target: Vector) -> tuple[Vector, Vector]:
        """One cycle: returns (servo position, measured position), both in rad."""
        self._history = [*self._history[1:], q_target.copy()]
        servo = self._history[0]
        return servo, servo + self._rng.normal(0.0, JOINT_NOISE_RAD, 6)


class Arm:
    """Joint state and motion model of one simulated UR arm (see module docstring).

    The controller calls `advance` once per control cycle with the cycle's controller time; motions
    that end are queued in `ended` for the controller's motion record.
    """

    def __init__(self, model: kin.URModel, q: Vector, tcp_offset: Vector, speed_factor: float,
                 instant: bool, cycle_s: float, tracking_seed: int | None = None):
        if not kin.within_limits(model, q):
            raise ValueError(f"initial joints {q.tolist()} are outside the {model.name} limits")
        self.model = model
        self.q = q.astype(np.float64)
        self.qd = np.zeros(6)
        self.tcp_offset = tcp_offset.astype(np.float64)
        self.speed_factor = speed_factor
        self.speed_slider = 1.0  # pendant speed slider (0..1), set over RTDE by the IO interface
        self.instant = instant
        self.cycle_s = cycle_s  # control period
        self.payload_kg = 0.0
        self.payload_cog_m = np.zeros(3)
        self.payload_inertia = np.zeros(6)  # Ixx, Iyy, Izz, Ixy, Ixz, Iyz (kg m^2)
        self.motion: Motion | None = None
        self.motion_count = 0
        self.ended: list[MotionEnd] = []
        self.now_s = 0.0  # controller time of the current cycle
        self._advanced_s = 0.0  # controller time of the last advance
        self._tracking = None if tracking_seed is None else Tracking(self.q, tracking_seed)
        self._servo_q = self.q  # where the joints are, noise-free (lags the target with tracking)
        self._still_cycles = STEADY_CYCLES
        self._jitter_until_s: float | None = None  # controller time the jitter ends
        self.actual_q = self.q
        self.actual_qd = self.qd
        self._update_poses()
        self._update_actual()
        self.tcp_speed = np.zeros(6)
        self.elbow_velocity = np.zeros(3)

    # --- derived poses ---------------------------------------------------------------------

    def _update_poses(self) -> None:
        """Target poses from the target joints."""
        self.T_base_flange = kin.forward(self.model, self.q)
        self.T_base_tcp = kin.tcp_from_flange(self.T_base_flange, self.tcp_offset)
        self.flange_pose = kin.matrix_to_pose(self.T_base_flange)
        self.tcp_pose = kin.matrix_to_pose(self.T_base_tcp)

    def _update_actual(self) -> None:
        """Actual poses and elbow from the measured joints (the target's when they are the
        target's joints, i.e. without tracking or jitter)."""
        if self.actual_q is self.q:
            self.actual_flange_pose = self.flange_pose
            self.actual_tcp_pose = self.tcp_pose
        else:
            T_base_flange = kin.forward(self.model, self.actual_q)
            self.actual_flange_pose = kin.matrix_to_pose(T_base_flange)
            self.actual_tcp_pose = kin.matrix_to_pose(
                kin.tcp_from_flange(T_base_flange, self.tcp_offset))
        self.elbow_position = kin.elbow_position(self.model, self.actual_q)

    def set_tcp(self, tcp_offset: Vector) -> None:
        """Make `tcp_offset` (T_flange_tcp as a UR vector) the active TCP."""
        self.tcp_offset = tcp_offset.astype(np.float64)
        self._update_poses()
        self._update_actual()

    def tcp_from_q(self, q: Vector, tcp_offset: Vector | None = None) -> Vector:
        """T_base_tcp at joints q, with the active TCP unless one is given."""
        offset = self.tcp_offset if tcp_offset is None else tcp_offset
        return kin.tcp_from_flange(kin.forward(self.model, q), offset)

    def ik_tcp(self, tcp_pose: Vector, q_near: Vector | None = None) -> Vector | None:
        """Joints reaching a TCP pose (UR vector, active TCP) nearest q_near (default: now)."""
        T_base_flange = kin.flange_from_tcp(kin.pose_to_matrix(tcp_pose), self.tcp_offset)
        return kin.inverse(self.model, T_base_flange, self.q if q_near is None else q_near)

    def pose_within_limits(self, tcp_pose: Vector) -> bool:
        """Reachable by some IK solution inside the joint limits, with the active TCP."""
        T_base_flange = kin.flange_from_tcp(kin.pose_to_matrix(tcp_pose), self.tcp_offset)
        return kin.reachable(self.model, T_base_flange)

    @property
    def steady(self) -> bool:
        """URScript is_steady(): fully at rest, i.e. no motion, the target has not moved for
        STEADY_CYCLES cycles and the actual joints have caught up with it."""
        return (self.motion is None and self._still_cycles >= STEADY_CYCLES
                and np.array_equal(self._servo_q, self.q) and self._jitter_until_s is None)

    def jitter(self, seconds: float) -> None:
        """Fault `jitter:SECONDS`: for SECONDS of controller time from now the measured joints
        shake about where the joints really are. The base joint reads JITTER_RAD off and moving
        at JITTER_SPEED_RPS, except on one cycle in JITTER_PERIOD_CYCLES (a swing's turning
        point) where every actual speed reads zero; never two such cycles in a row, so only a
        reader that wants consecutive still samples waits the jitter out. The target, and with
        it every motion, is untouched."""
        self._jitter_until_s = self.now_s + seconds

    # --- motions ---------------------------------------------------------------------------

    def move_linear(self, tcp_pose: Vector, speed: float, accel: float, kind: str) -> Motion:
        """Start a straight-line TCP move; raises UnreachableError if the target is unreachable."""
        q_target = self.ik_tcp(tcp_pose)
        if q_target is None:
            raise UnreachableError(f"moveL target {np.round(tcp_pose, 6).tolist()} is unreachable")
        T_target = kin.pose_to_matrix(tcp_pose)
        translation = float(np.linalg.norm(T_target[:3, 3] - self.T_base_tcp[:3, 3]))
        if translation >= _MIN_TRANSLATION_M:
            distance = translation
        else:
            R_rel = self.T_base_tcp[:3, :3].T @ T_target[:3, :3]
            distance = float(np.linalg.norm(kin.matrix_to_rotvec(R_rel)))
        return self._start(kind, True, distance, speed, accel, q_target, T_target)

    def move_joint(self, q_target: Vector, speed: float, accel: float, kind: str) -> Motion:
        """Start a joint-space move; raises UnreachableError if q_target is outside the limits."""
        if not kin.within_limits(self.model, q_target):
            raise UnreachableError(f"moveJ target {np.round(q_target, 6).tolist()} is outside "
                                   f"the {self.model.name} joint limits")
        distance = float(np.max(np.abs(q_target - self.q)))
        return self._start(kind, False, distance, speed, accel, q_target,
                           self.tcp_from_q(q_target))

    def start_path(self, path: BlendedPath, q_end: Vector) -> Motion:
        """Start a blended path planned from where the arm is now (path_plan.py) as one motion
        ending at joints `q_end` (rad)."""
        first = path.waypoints[0]
        return self._start("movePath", path.linear, path.length, first.speed, first.accel, q_end,
                           self.tcp_from_q(q_end), path)

    def planned_times(self, motion: Motion) -> dict[str, float | list[float] | None]:
        """When a path is planned to be done with each waypoint and to end (controller time, s)
        if nothing stops it, at the current speed factor and slider; None when instant or with
        the slider at 0."""
        rate = self.speed_factor * self.speed_slider
        if motion.path is None or self.instant or rate <= 0.0:
            return {"planned_reached_t": None, "planned_end_t": None}
        profile = motion.path.profile
        return {
            "planned_reached_t": [motion.started_s + profile.time_at(d) / rate
                                  for d in motion.path.done_distance],
            "planned_end_t": motion.started_s + profile.duration_s / rate,
        }

    def _start(self, kind: str, linear: bool, distance: float, speed: float, accel: float,
               q_target: Vector, T_target: Vector, path: BlendedPath | None = None) -> Motion:
        if speed <= 0.0 or accel <= 0.0:
            raise UnreachableError(f"speed {speed} and acceleration {accel} must be > 0 to move")
        self.halt("replaced by a new move")
        self.motion_count += 1
        duration_s = (kin.trapezoid(distance, speed, accel) if path is None
                      else path.profile.duration_s)
        self.motion = Motion(
            index=self.motion_count, kind=kind, started_s=self.now_s, linear=linear,
            distance=distance, speed=speed, accel=accel, duration_s=duration_s,
            q_start=self.q.copy(), q_target=q_target, T_base_tcp_start=self.T_base_tcp.copy(),
            T_base_tcp_target=T_target, path=path,
        )
        return self.motion

    def halt(self, reason: str, detail: dict[str, float] | None = None,
             at_s: float | None = None) -> None:
        """Stop where the arm is now; `reason`, `detail` and the controller time the stop took
        effect (`at_s`, default now) go to the motion record."""
        if self.motion is not None:
            end_s = self.now_s if at_s is None else max(at_s, self.motion.started_s)
            self._rest(MotionEnd(self.motion, end_s, reason, detail))

    def _rest(self, end: MotionEnd) -> None:
        self.ended.append(end)
        self.motion = None
        self.qd = np.zeros(6)
        self.tcp_speed = np.zeros(6)

    def decelerate(self, decel: float) -> Motion | None:
        """Brake along the path at `decel` (the motion's units per s^2), as stopl/stopj do,
        from this cycle's controller time on.

        Returns the motion while it is still braking, None when the arm is already still.
        """
        motion = self.motion
        if motion is None:
            return None
        # The motion was last advanced to the previous cycle; the braking begins at this one.
        at_s = motion.elapsed_s + self._motion_time(self.now_s - self._advanced_s, motion)
        if self.instant or decel <= 0.0 or motion.planned(at_s)[1] <= 0.0:
            self.halt("stopped")
            return None
        motion.stop(at_s, decel)
        return motion

    def _motion_time(self, wall_s: float, motion: Motion) -> float:
        """Motion time in `wall_s` of controller time: never before the motion started."""
        wall_s = min(wall_s, self.now_s - motion.started_s)
        return max(0.0, wall_s) * self.speed_factor * self.speed_slider

    def advance(self, dt_s: float, now_s: float) -> Motion | None:
        """One control cycle of dt_s wall time ending at controller time now_s; returns the
        motion advanced (None if idle). A motion moves from the cycle after the one that
        started it.

        Raises UnreachableError (and halts) when a point on a linear path has no IK solution.
        """
        self.now_s = now_s
        motion = self.motion
        q_before = self.q
        try:
            if motion is not None:
                self._advance_motion(motion, dt_s)
        finally:
            self._advanced_s = now_s
            self._still_cycles = 0 if self.motion is not None or not np.array_equal(
                self.q, q_before) else self._still_cycles + 1
            self._track(dt_s)
            self._shake()
        return motion

    def _advance_motion(self, motion: Motion, dt_s: float) -> None:
        if self.instant:
            motion.elapsed_s += motion.duration_s / 2  # done within two cycles
        else:
            motion.elapsed_s += self._motion_time(dt_s, motion)
        s = motion.path_fraction()
        q_new = motion.q_target if s >= 1.0 else self._q_along(motion, s)
        T_tcp_before = self.T_base_tcp
        q_before = self.q
        self.q = q_new
        self._update_poses()
        if dt_s > 0.0:
            self.qd = (self.q - q_before) / dt_s
            self.tcp_speed = _twist(T_tcp_before, self.T_base_tcp, dt_s)
        if motion.path is not None:
            done = motion.path.done_distance
            while (len(motion.reached_s) < len(done)
                   and done[len(motion.reached_s)] <= s * motion.distance + 1e-12):
                t_done = motion.path.profile.time_at(done[len(motion.reached_s)])
                motion.reached_s.append(self._cycle_at_or_after(motion, t_done))
        if motion.finished:
            self._end(motion, "stopped" if motion.braking else "reached")

    def _end(self, motion: Motion, reason: str) -> None:
        """The motion came to rest this cycle: recorded at the first cycle at or after the
        exact moment (a late cycle that overshot does not lengthen it)."""
        self._rest(MotionEnd(motion, self._cycle_at_or_after(motion, motion.end_time()), reason))

    def _cycle_at_or_after(self, motion: Motion, motion_t: float) -> float:
        """Controller time of the first cycle at or after motion time `motion_t`, which this
        cycle's advance passed (this cycle's time when instant)."""
        rate = self.speed_factor * self.speed_slider
        if self.instant or rate <= 0.0:
            return self.now_s
        exact_s = self.now_s - (motion.elapsed_s - motion_t) / rate
        at_s = max(motion.started_s, math.ceil(exact_s / self.cycle_s - 1e-6) * self.cycle_s)
        return min(at_s, self.now_s)

    def _track(self, dt_s: float) -> None:
        """Measured joints, poses, elbow and speeds for this cycle."""
        servo_before = self._servo_q
        elbow_before = self.elbow_position
        if self._tracking is None:
            if self.q is servo_before:  # an idle arm: nothing to recompute (most cycles)
                self.actual_qd = self.qd
                self.elbow_velocity = np.zeros(3)
                return
            self._servo_q = self.actual_q = self.q
            self.actual_qd = self.qd
        else:
            self._servo_q, self.actual_q = self._tracking.update(self.q)
            self.actual_qd = (self._servo_q - servo_before) / dt_s if dt_s > 0 else np.zeros(6)
        self._update_actual()
        if dt_s > 0:
            self.elbow_velocity = (self.elbow_position - elbow_before) / dt_s

    def _shake(self) -> None:
        """This cycle's measured joints while jittering (see `jitter`); back to the real ones
        once it is over."""
        if self._jitter_until_s is None:
            return
        if self.now_s >= self._jitter_until_s:
            self._jitter_until_s = None
            if self._tracking is None:  # idle cycles recompute nothing: restore here
                self.actual_q, self.actual_qd = self.q, self.qd
            self._update_actual()
            return
        turning = round(self.now_s / self.cycle_s) % JITTER_PERIOD_CYCLES == 0
        self.actual_q = self._servo_q.copy()
        self.actual_q[0] += JITTER_RAD
        self.actual_qd = np.zeros(6)
        if not turning:
            self.actual_qd[0] = JITTER_SPEED_RPS
        self._update_actual()

    def _q_along(self, motion: Motion, s: float) -> Vector:
        if motion.path is not None:
            point = motion.path.point(s)
            return self._ik_along(point, s) if motion.linear else point
        if not motion.linear:
            return motion.q_start + s * (motion.q_target - motion.q_start)
        return self._ik_along(
            kin.interpolate_pose(motion.T_base_tcp_start, motion.T_base_tcp_target, s), s)

    def _ik_along(self, T_base_tcp: Vector, s: float) -> Vector:
        """Joints at a point a fraction s along a linear path, nearest the current joints."""
        T_base_flange = kin.flange_from_tcp(T_base_tcp, self.tcp_offset)
        q = kin.inverse(self.model, T_base_flange, self.q)
        if q is None:
            self.halt(f"no IK solution {s:.0%} of the way (protective stop)")
            raise UnreachableError(
                f"moveL path point {kin.matrix_to_pose(T_base_tcp).round(6).tolist()} "
                f"({s:.0%} of the way) has no IK solution within the joint limits"
            )
        return q


def _twist(T0: Vector, T1: Vector, dt_s: float) -> Vector:
    """Linear (m/s) and angular (rad/s) velocity in base between two poses dt_s apart."""
    omega = kin.matrix_to_rotvec(T1[:3, :3] @ T0[:3, :3].T) / dt_s
    return np.concatenate([(T1[:3, 3] - T0[:3, 3]) / dt_s, omega])


def default_q() -> Vector:
    """UR's elbow-up, tool-down home (ur5e: flange at [-0.49, -0.13, 0.49] m, z down)."""
    return np.array([0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0])
