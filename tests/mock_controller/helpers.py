"""Helpers for the simulated-controller tests: a client script in a subprocess, a raw RTDE peek,
poses compared as transforms, polling for a condition."""

from __future__ import annotations

import math
import socket
import struct
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable

import numpy as np
from scipy.spatial.transform import Rotation

# ur5e joints (rad) with the tool pointing down, the arm's usual start in these tests.
HOME_Q = [0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0]


def run_client(code: str, timeout_s: float = 60.0) -> subprocess.CompletedProcess[str]:
    """Run a ur_rtde client script in its own interpreter (ur_rtde may loop reconnecting or crash
    when a connection drops); returns the finished process with its output."""
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True, text=True, timeout=timeout_s, check=False,
    )


def rtde_controller_version(host: str) -> tuple[int, int, int, int]:
    """Ask the RTDE server on host:30004 for its version with a raw `v` request."""
    with socket.create_connection((host, 30004), timeout=5.0) as sock:
        sock.sendall(struct.pack(">HBH", 5, ord("V"), 2))
        sock.recv(4)
        sock.sendall(struct.pack(">HB", 3, ord("v")))
        reply = b""
        while len(reply) < 19:
            reply += sock.recv(19 - len(reply))
    major, minor, bugfix, build = struct.unpack(">IIII", reply[3:])
    return major, minor, bugfix, build


def pose_matrix(pose: list[float] | tuple[float, ...]) -> np.ndarray:
    """UR pose vector (m, rad) -> 4x4, computed here independently of the mock's code."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(pose[3:]).as_matrix()
    T[:3, 3] = pose[:3]
    return T


def assert_same_pose(a: list[float] | tuple[float, ...], b: list[float] | tuple[float, ...],
                     tol: float = 1e-6) -> None:
    """Poses equal as transforms (rotation vectors near pi may differ in sign)."""
    np.testing.assert_allclose(pose_matrix(a), pose_matrix(b), atol=tol)


def wait_for(condition: Callable[[], bool], timeout_s: float = 5.0) -> None:
    """Poll ``condition`` until it holds; AssertionError after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met within the timeout")
        time.sleep(0.002)
