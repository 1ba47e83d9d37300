"""Blended paths as ur_rtde 1.6.5 sends them (moveL(path), moveJ(path)): the script re-upload
with the path injected, command 45, blends, the progress word, stops and faults mid-path.

The TCP is sampled from the RTDE stream through rtde_receive while the path runs; the geometry
checks are made here from those samples, independently of the simulator's own code.
"""

from __future__ import annotations

import itertools
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable

import numpy as np
import pytest
import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController
from mocks.ur_controller.path_script import PathSyntaxError, injected_path
from tests.mock_controller.helpers import HOME_Q, wait_for

Factory = Callable[..., SimulatedController]
Sample = tuple[np.ndarray, float, int]  # TCP position (m), TCP speed (m/s), progress

SIDE_M = 0.06
RADIUS_M = 0.02


def square_corners(start: list[float]) -> list[list[float]]:
    """Three TCP poses: +x, then +y, then back -x, at the start's height and orientation."""
    x, y, z = start[:3]
    rot = start[3:]
    return [[x + SIDE_M, y, z, *rot], [x + SIDE_M, y + SIDE_M, z, *rot], [x, y + SIDE_M, z, *rot]]


def as_path(poses: list[list[float]], radius: float) -> list[list[float]]:
    """ur_rtde path rows: pose, speed 0.25 m/s, acceleration 1.2 m/s^2, blend (last: 0)."""
    return [[*p, 0.25, 1.2, radius if i < len(poses) - 1 else 0.0] for i, p in enumerate(poses)]


def sample_until_done(c: rtde_control.RTDEControlInterface,
                      r: rtde_receive.RTDEReceiveInterface) -> list[Sample]:
    """TCP position, speed and async progress until the path's progress word says finished."""
    samples: list[Sample] = []
    seen_running = False
    while True:
        progress = c.getAsyncOperationProgress()
        samples.append((np.array(r.getActualTCPPose()[:3]),
                        float(np.linalg.norm(r.getActualTCPSpeed()[:3])), progress))
        seen_running = seen_running or progress >= 0
        if seen_running and progress < 0:
            return samples
        time.sleep(0.001)


def distance_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    u = float(np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + u * (b - a))))


def changes(values: list[int]) -> list[int]:
    return [v for i, v in enumerate(values) if i == 0 or v != values[i - 1]]


def assert_progress_runs_through(values: list[int], last: int) -> None:
    """The progress word read while a path ran: 0 first, then rising to ``last``. A poll the
    shared machine delays may miss a short middle waypoint, never the order."""
    seen = changes(values)
    assert (seen[0], seen[-1]) == (0, last), seen
    assert seen == sorted(seen), seen


def test_a_blended_corner_keeps_moving_within_its_radius(sim_controller: Factory) -> None:
    ctl = sim_controller()
    c = rtde_control.RTDEControlInterface(ctl.host)
    r = rtde_receive.RTDEReceiveInterface(ctl.host)
    try:
        start = r.getActualTCPPose()
        corners = square_corners(start)
        assert c.moveL(as_path(corners, RADIUS_M), True)
        assert not c.isSteady()
        samples = sample_until_done(c, r)
        wait_for(c.isSteady)  # steady a few cycles after the word says finished
        points = [np.array(p[:3]) for p in [start, *corners]]
        for corner in (points[1], points[2]):
            near = [(np.linalg.norm(s[0] - corner), s[1]) for s in samples
                    if np.linalg.norm(s[0] - corner) < RADIUS_M]
            assert len(near) > 10
            assert min(speed for _, speed in near) > 0.05  # it never stops in the corner
            assert min(d for d, _ in near) > 0.002  # it cuts the corner
        for position, _, _ in samples:  # on a straight segment, or inside a blend's ball
            off_line = min(distance_to_segment(position, a, b)
                           for a, b in itertools.pairwise(points))
            in_ball = min(np.linalg.norm(position - q) for q in (points[1], points[2]))
            assert off_line < 1e-6 or in_ball <= RADIUS_M + 1e-6
        assert_progress_runs_through([s[2] for s in samples if s[2] >= 0], 2)
        np.testing.assert_allclose(r.getActualTCPPose()[:3], points[3], atol=1e-6)
        command = [e for e in ctl.commands if e["kind"] == "movePath"][-1]
        assert command["radii"] == [RADIUS_M, RADIUS_M, 0.0]
        assert command["skipped_blends"] == []
        assert command["async"] is True
        motion = ctl.motions[-1]
        assert motion["kind"] == "movePath"
        assert motion["end"] == "reached"
        reached = motion["reached_t"]
        assert motion["start_t"] < reached[0] < reached[1] < reached[2] == motion["end_t"]
        # The re-uploaded script is the control script plus the path: single moves still work.
        assert c.moveL(start, 0.25, 1.2)
        wait_for(lambda: np.allclose(r.getActualTCPPose(), start, atol=1e-9))
        assert ctl.motions[-1]["kind"] == "moveL"
    finally:
        r.disconnect()
        c.disconnect()


def test_radius_zero_stops_at_each_waypoint(sim_controller: Factory) -> None:
    ctl = sim_controller(speed_factor=2.0)
    c = rtde_control.RTDEControlInterface(ctl.host)
    r = rtde_receive.RTDEReceiveInterface(ctl.host)
    try:
        start = r.getActualTCPPose()
        corners = square_corners(start)
        assert c.moveL(as_path(corners, 0.0), True)
        samples = sample_until_done(c, r)
        points = [np.array(p[:3]) for p in [start, *corners]]
        for position, _, _ in samples:  # never leaves the polyline: no corner is cut
            assert min(distance_to_segment(position, a, b)
                       for a, b in itertools.pairwise(points)) < 1e-6
        stopped = ctl.motions[-1]["moving_s"]
        assert c.moveL(start, 0.5, 1.2)
        assert c.moveL(as_path(corners, RADIUS_M), False)  # synchronous this time
        assert ctl.motions[-1]["moving_s"] < stopped  # blending saves time
        # A synchronous path leaves the word at its last waypoint, running: the script writes
        # "finished" only from the async move thread.
        assert c.getAsyncOperationProgress() == 2
    finally:
        r.disconnect()
        c.disconnect()


def test_stopl_mid_path_brakes_the_arm(sim_controller: Factory) -> None:
    ctl = sim_controller()
    c = rtde_control.RTDEControlInterface(ctl.host)
    r = rtde_receive.RTDEReceiveInterface(ctl.host)
    try:
        corners = square_corners(r.getActualTCPPose())
        assert c.moveL(as_path(corners, RADIUS_M), True)
        wait_for(lambda: c.getAsyncOperationProgress() == 1)
        c.stopL(2.0)
        assert c.getAsyncOperationProgress() < 0
        wait_for(lambda: ctl.snapshot().steady)
        motion = ctl.motions[-1]
        assert motion["kind"] == "movePath"
        assert motion["end"] == "stopped"
        assert len(motion["reached_t"]) == 1
        far = np.array(corners[2][:3])
        assert np.linalg.norm(np.array(r.getActualTCPPose()[:3]) - far) > 0.01
        assert [e["kind"] for e in ctl.commands][-2:] == ["movePath", "stopL"]
    finally:
        r.disconnect()
        c.disconnect()


def test_protective_stop_mid_path(sim_controller: Factory) -> None:
    ctl = sim_controller(speed_factor=2.0, inject=("protective-stop@move:1:0.5",))
    c = rtde_control.RTDEControlInterface(ctl.host)
    r = rtde_receive.RTDEReceiveInterface(ctl.host)
    try:
        corners = square_corners(r.getActualTCPPose())
        assert not c.moveL(as_path(corners, RADIUS_M), False)
        # The control interface saw the stop first; the receive stream says so a sample or a
        # few later (a loaded machine delays its thread).
        wait_for(r.isProtectiveStopped)
        motion = ctl.motions[-1]
        assert motion["motion"] == 1
        assert motion["kind"] == "movePath"
        assert motion["end"] == "protective stop: injected fault"
        assert len(motion["reached_t"]) < 3
    finally:
        r.disconnect()
        c.disconnect()


def test_a_movej_path_blends_in_joint_space(sim_controller: Factory) -> None:
    ctl = sim_controller()
    c = rtde_control.RTDEControlInterface(ctl.host)
    r = rtde_receive.RTDEReceiveInterface(ctl.host)
    try:
        # Waypoints written with 6 significant digits, as ur_rtde prints them into the script.
        q1 = [0.3, -1.5708, 1.5708, -1.5708, -1.5708, 0.0]
        q2 = [0.3, -1.2708, 1.2708, -1.5708, -1.5708, 0.0]
        q3 = [0.0, -1.2708, 1.2708, -1.5708, -1.5708, 0.0]
        assert c.moveJ([[*q1, 1.05, 1.4, 0.05], [*q2, 1.05, 1.4, 0.05], [*q3, 1.05, 1.4, 0.0]],
                       True)
        progress: list[int] = []
        joint_speeds: list[tuple[np.ndarray, float]] = []
        while not progress or progress[-1] >= 0 or len(progress) < 3:
            progress.append(c.getAsyncOperationProgress())
            q = np.array(r.getActualQ())
            joint_speeds.append((q, float(np.linalg.norm(r.getActualQd()))))
            time.sleep(0.001)
        assert_progress_runs_through([p for p in progress if p >= 0], 2)
        np.testing.assert_allclose(r.getActualQ(), q3, atol=1e-9)
        gaps = [float(np.max(np.abs(q - np.array(q1)))) for q, _ in joint_speeds]
        near = [speed for gap, (_, speed) in zip(gaps, joint_speeds, strict=True) if gap < 0.1]
        assert len(near) > 10
        assert min(near) > 0.05
        assert min(gaps) > 0.001  # and cut: the joints never reach q1
        command = [e for e in ctl.commands if e["kind"] == "movePath"][-1]
        assert command["move"] == "movej"
        assert command["waypoints"][1] == q2
        assert ctl.motions[-1]["end"] == "reached"
    finally:
        r.disconnect()
        c.disconnect()


def test_an_overlapping_blend_is_skipped(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    c = rtde_control.RTDEControlInterface(ctl.host)
    r = rtde_receive.RTDEReceiveInterface(ctl.host)
    try:
        corners = square_corners(r.getActualTCPPose())
        # 0.04 + 0.04 > the 0.06 side between the first two corners: the second blend overlaps.
        path = as_path(corners, 0.04)
        assert c.moveL(path, False)
        command = [e for e in ctl.commands if e["kind"] == "movePath"][-1]
        assert command["skipped_blends"] == [1]
    finally:
        r.disconnect()
        c.disconnect()


def test_a_path_that_does_not_compile_is_refused(sim_controller: Factory) -> None:
    ctl = sim_controller(instant=True)
    # ur_rtde checks speed, acceleration and blend, not the pose: an infinite coordinate is
    # printed as `inf`, which URScript does not know. ur_rtde then waits for the program to run,
    # for ever, so the client runs in its own process and is ended here.
    code = f"""
        import rtde_control
        c = rtde_control.RTDEControlInterface("{ctl.host}")
        c.moveL([[float("inf"), -0.13, 0.49, 2.22, 2.22, 0.0, 0.25, 1.2, 0.0]], True)
    """
    client = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: any(e["kind"] == "compileError" for e in ctl.commands), 30.0)
        assert ctl.snapshot().runtime_state == 1  # stopped: the program did not start
        assert not any(e["kind"] == "movePath" for e in ctl.commands)
    finally:
        client.kill()
        client.wait()
    error = next(e for e in ctl.commands if e["kind"] == "compileError")["error"]
    assert "inf" in error
    c = rtde_control.RTDEControlInterface(ctl.host)  # a fresh upload runs again
    try:
        assert c.moveJ(HOME_Q, 1.05, 1.4)
    finally:
        c.disconnect()


PATH_TEXT = """def rtde_control():
    def exec_move_path():
        textmsg("exec_move_path")
        # inject move path
\tsignal_async_progress(0)
\tmovel(p[-0.479554,-0.1333,0.4879,2.22144,2.22144,-1.36024e-16],a=1.2,v=0.25,r=0.01)
\tsignal_async_progress(1)
\tmovel(p[-0.4419,-0.1333,0.4879,2.22144,2.22144,0],a=1.2,v=0.25,r=0)
    end
end
"""


def test_the_injected_path_is_read_as_ur_rtde_prints_it() -> None:
    path = injected_path(PATH_TEXT)
    assert path is not None
    assert path.move == "movel"
    assert [w.blend for w in path.waypoints] == [0.01, 0.0]
    assert path.waypoints[0].target[5] == -1.36024e-16
    assert (path.waypoints[1].accel, path.waypoints[1].speed) == (1.2, 0.25)
    assert injected_path(PATH_TEXT.replace(PATH_TEXT[PATH_TEXT.index("\tsignal"):
                                                     PATH_TEXT.index("    end")], "")) is None


@pytest.mark.parametrize("broken", [
    ("signal_async_progress(1)\n\tmovel(p[-0.4419", "signal_async_progress(2)\n\tmovel(p[-0.4419"),
    ("r=0.01)", "r=0.01"),
    ("-0.1333,0.4879,2.22144,2.22144,0]", "-0.1333,0.4879,2.22144,0]"),
    ("p[-0.4419", "[-0.4419"),
    ("movel(p[-0.4419", "movej(p[-0.4419"),
    ("-0.479554", "inf"),
])
def test_a_malformed_line_is_a_compile_error(broken: tuple[str, str]) -> None:
    with pytest.raises(PathSyntaxError):
        injected_path(PATH_TEXT.replace(*broken))
