"""A blended path planned off the control loop's thread.

Planning a path (IK at every waypoint, the blends' geometry, the speed profile along it) takes
milliseconds to tens of milliseconds of Python on a busy machine, several control cycles' worth.
Planned inside a control cycle it froze the loop, and with it the RTDE stream, at every path
start. A real controller streams at its full rate whatever its program does, so here a path is
planned on the planner's own thread from a snapshot of the arm (its joints and active TCP
offset), while the control loop goes on: the program that carries the path is planned as soon
as it arrives on the script port, and command 45 starts the path at the first control cycle at
which its plan is ready and still starts where the arm is (otherwise it is planned again from
there, and the command waits for it as for a synchronous move).

Joints in rad; movel waypoints are TCP poses in the base frame (m, rad) with the active TCP.
"""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from mocks.ur_controller import kinematics as kin
from mocks.ur_controller.arm import UnreachableError, Vector
from mocks.ur_controller.blend import BlendedPath
from mocks.ur_controller.path_script import PathSpec


@dataclass(frozen=True)
class PathPlan:
    """A path ready to run: its geometry and timing, and the joints (rad) it ends at."""

    path: BlendedPath
    q_end: Vector


def plan_path(model: kin.URModel, q_start: Vector, tcp_offset: Vector, spec: PathSpec) -> PathPlan:
    """Plan `spec` from joints `q_start` with TCP offset `tcp_offset` (T_flange_tcp, UR vector).

    Raises UnreachableError for a waypoint without IK or outside the joint limits, or a speed or
    acceleration that is not > 0 (a real controller's runtime error).
    """
    waypoints = spec.waypoints
    if any(w.speed <= 0.0 or w.accel <= 0.0 for w in waypoints):
        raise UnreachableError("every path waypoint needs speed and acceleration > 0")

    def tcp(q: Vector) -> Vector:
        return kin.tcp_from_flange(kin.forward(model, q), tcp_offset)

    q = q_start
    for w in waypoints:  # joints at each waypoint, each nearest the previous one's
        target = np.array(w.target)
        if spec.move == "movel":
            T_flange = kin.flange_from_tcp(kin.pose_to_matrix(target), tcp_offset)
            solution = kin.inverse(model, T_flange, q)
        else:
            solution = target
        if solution is None or not kin.within_limits(model, solution):
            raise UnreachableError(f"{spec.move} path waypoint {np.round(target, 6).tolist()} "
                                   f"is unreachable")
        q = solution
    start = tcp(q_start) if spec.move == "movel" else q_start
    return PathPlan(BlendedPath(spec.move, start, waypoints, lambda joints: tcp(joints)[:3, 3]), q)


class PlanRequest:
    """A plan being made on the planner's thread, from the arm as it was when asked."""

    def __init__(self, future: Future[PathPlan], q_start: Vector, tcp_offset: Vector):
        self._future = future
        self._q_start = q_start
        self._tcp_offset = tcp_offset

    def fits(self, q: Vector, tcp_offset: Vector) -> bool:
        """True when the plan starts at joints `q` with this TCP offset (the arm did not move)."""
        return bool(np.array_equal(q, self._q_start) and np.array_equal(tcp_offset,
                                                                       self._tcp_offset))

    @property
    def ready(self) -> bool:
        return self._future.done()

    def result(self) -> PathPlan:
        """The plan once ready; raises UnreachableError when the path cannot run."""
        return self._future.result()


class PathPlanner:
    """Plans paths one at a time on its own thread (see the module docstring)."""

    def __init__(self) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="path-planner")

    def request(self, model: kin.URModel, q: Vector, tcp_offset: Vector,
                spec: PathSpec) -> PlanRequest:
        """Start planning `spec` from joints `q` (rad) with `tcp_offset`; returns at once."""
        q_start, offset = q.copy(), tcp_offset.copy()
        return PlanRequest(self._pool.submit(plan_path, model, q_start, offset, spec),
                           q_start, offset)

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
