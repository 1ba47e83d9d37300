"""A simulated cell for the calibration commands: the truth the simulated camera uses, a cell
config whose hand-eye file holds a rough mount (as before a calibration) and the camera's
position taped to the centimetre, the capture command.

Eye-in-hand: a camera on the flange (``CAMERA_IN_HAND``, T_flange_cam), a board on the table in
front of the UR5e (``BOARD_IN_CELL``, T_base_board, face up). Eye-to-hand: a camera 1 m above
the base plane looking down (``CAMERA_TO_HAND``, T_base_cam), a board on a bracket beside the
flange, face away from the tool (``BOARD_ON_FLANGE``, T_flange_board). All UR vectors (m, rad).
"""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handeye_pick.geometry import ur_pose_to_matrix
from handeye_pick.hand_eye.files import write_zivid_transform
from tests.conftest import TEST_WATCHDOG_S

ROOT = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-c", "import sys; from handeye_pick.cli import main; sys.exit(main())"]
TCP_OFFSET = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)

CAMERA_IN_HAND = (0.0, -0.075, 0.055, 0.0, 0.0, 1.5708)
BOARD_IN_CELL = (-0.5, -0.12, 0.0, np.pi, 0.0, 0.0)
LOOK_AT_IN_HAND_MM = ("-500", "-120", "0")  # the board's centre
CAMERA_TO_HAND = (-0.45, 0.1, 1.0, np.pi, 0.0, 0.0)
BOARD_ON_FLANGE = (0.0, 0.1, 0.03, 0.0, 0.0, 0.0)
LOOK_AT_TO_HAND_MM = ("-450", "100", "350")  # where the robot holds the board's centre
# What the integrator knows before calibrating (a drawing, a tape measure): a few mm and about
# a degree off the truth.
ROUGH_ERROR = np.array([0.004, -0.003, 0.005, 0.012, -0.01, 0.008])

TRUE_CAMERA = {"eye-in-hand": CAMERA_IN_HAND, "eye-to-hand": CAMERA_TO_HAND}
BOARD = {"eye-in-hand": BOARD_IN_CELL, "eye-to-hand": BOARD_ON_FLANGE}


def write_cell(tmp_path: Path, host: str, mode: str, *, max_tilt_deg: float = 50.0) -> Path:
    """A cell config for the simulated controller at ``host``; its hand-eye file is the rough
    mount. The workspace box holds every pose the proposals use; tool tilts reach 40 degrees
    plus the mount's."""
    rough = np.array(TRUE_CAMERA[mode]) + ROUGH_ERROR
    write_zivid_transform(tmp_path / "hand_eye.yaml", ur_pose_to_matrix(rough), "mm")
    taped_mm = [round(v * 1000.0, -1) for v in TRUE_CAMERA[mode][:3]]  # to the centimetre
    path = tmp_path / "cell.yaml"
    path.write_text(
        f"robot:\n  host: {host}\n  tcp_offset: {list(TCP_OFFSET)}\n"
        f"  watchdog_s: {TEST_WATCHDOG_S}\n"
        f"hand_eye:\n  mode: {mode}\n  file: hand_eye.yaml\n  units: mm\n"
        f"  camera_position_mm: {taped_mm}\n"
        "grasp:\n  approach_mm: 100\n  retreat_mm: 100\n"
        "motion:\n  speed_mps: 0.25\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.1\n"
        "workspace:\n  min_mm: [-900, -800, 20]\n  max_mm: [800, 800, 900]\n"
        f"  max_tilt_deg: {max_tilt_deg}\n"
        "audit:\n  file: audit.jsonl\n"
    )
    return path


def capture_command(host: str, mode: str) -> str:
    """The simulated camera's object-pose program for ``--capture-command`` (default noise:
    0.1 mm across the view, 0.3 mm along the optical axis, 0.02 deg)."""
    argv = [
        sys.executable,
        "-m",
        "mocks.camera",
        "object-pose",
        "--host",
        host,
        "--mode",
        mode,
        "--camera",
        *map(str, TRUE_CAMERA[mode]),
        "--board",
        *map(str, BOARD[mode]),
    ]
    return shlex.join(argv)


def poses_args(mode: str) -> list[str]:
    """``poses`` flags that aim at the board in ``mode``."""
    if mode == "eye-in-hand":
        return ["--look-at", *LOOK_AT_IN_HAND_MM, "--distance-mm", "400"]
    return ["--look-at", *LOOK_AT_TO_HAND_MM, "--board-mount", *map(str, BOARD_ON_FLANGE)]


def cli(*args: str, timeout_s: float = 120.0) -> subprocess.CompletedProcess[str]:
    """``handeye-pick ARGS`` in a subprocess from the repository root (the capture command
    imports ``mocks``), standard input closed."""
    return subprocess.run(
        [*CLI, *args],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )


def ur_rtde_child_pid(host: str) -> int:
    """The process id of this process's ur_rtde child (robot/ur/worker.py) connected to
    ``host``, found in /proc as the operator's tools would find it; a test freezes or kills it
    to make the client fall silent."""
    me = os.getpid()
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            argv = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:  # gone meanwhile
            continue
        parent = int(stat.rpartition(")")[2].split()[1])
        words = [a.decode(errors="replace") for a in argv]
        if parent == me and any(w.endswith("worker.py") for w in words) and host in words:
            found.append(int(entry.name))
    if len(found) != 1:
        raise RuntimeError(f"expected one ur_rtde child for {host}, found {found}")
    return found[0]


def wait_until(condition: Callable[[], bool], within_s: float = 10.0) -> bool:
    """Poll ``condition`` every 5 ms until it holds (True) or ``within_s`` ran out (False): a
    bound on waiting for the simulator, never a timing assertion."""
    deadline = time.monotonic() + within_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True
