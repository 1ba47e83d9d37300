"""Every door a UR pose vector enters handeye-pick by, walked with the mistake no check of the
translation catches: the rotation typed in degrees (127.3 for the 2.2214 rad of the simulated
arm's home flange). Each door refuses it before anything is contacted, with one line that says
"degrees given?": exit 2 on the command line, a bad-request reply from ``run``.

The list is held complete from two sides: every option of every command that takes a UR vector
(six numbers, X Y Z RX RY RZ) has its door here, and the raw reader ``ur_pose_to_matrix`` is
called only where the controller's own poses are read.
"""

from __future__ import annotations

import ast
import json
from collections.abc import Callable
from pathlib import Path

import pytest

from handeye_pick.cell.session import Cell
from handeye_pick.cli import main, parser_with
from handeye_pick.runner import Runner

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "src" / "handeye_pick"
DEMO_HAND_EYE = ROOT / "config" / "demo" / "hand_eye.yaml"
EYE_TO_HAND = ROOT / "config" / "calibration" / "EyeToHandTransform.yaml"
CLOUD = ROOT / "examples" / "table_box_camera_mm.npy"
REFUSAL = "(degrees given? it must be in rad: "  # what happened, and what to do

DEG = "[0, 0, 0.05, 127.3, 127.3, 0]"  # a pose in a config or a file, its rotation in degrees
FLANGE_DEG = ["-0.4919", "-0.1333", "0.4879", "127.3", "127.3", "0"]  # the same on a flag
MOUNT_DEG = ["0", "0", "0.05", "127.3", "127.3", "0"]

# The modules that read poses from the controller (RTDE samples, its TCP offset), which alone
# may call the raw ur_pose_to_matrix.
CONTROLLER_READERS = {"robot/ur/arm.py", "robot/ur/readout.py", "record/publisher.py"}


def _config(folder: Path, extra: str = "", *, eye_to_hand: bool = False) -> Path:
    """A cell config whose robot (TEST-NET, 192.0.2.10) is never reached: every door refuses
    before connecting."""
    hand_eye = (
        f"{{mode: eye-to-hand, file: {EYE_TO_HAND}, units: mm, "
        "acknowledge: [camera-position-measured]}"
        if eye_to_hand
        else f"{{mode: eye-in-hand, file: {DEMO_HAND_EYE}, units: mm}}"
    )
    path = folder / "cell.yaml"
    path.write_text(
        "robot: {host: 192.0.2.10, tcp_offset: [0, 0, 0.12, 0, 0, 0]}\n"
        f"hand_eye: {hand_eye}\n"
        "grasp: {approach_mm: 100, retreat_mm: 100}\n"
        "motion: {speed_mps: 0.25, accel_mps2: 1.2, grasp_speed_mps: 0.05}\n"
        "workspace: {min_mm: [-800, -800, 20], max_mm: [800, 800, 700], max_tilt_deg: 90}\n"
        "audit: {file: picks.jsonl}\n" + extra
    )
    return path


def _file(folder: Path, name: str, text: str) -> str:
    (folder / name).write_text(text)
    return str(folder / name)


def _pick_with_config(extra: str, old: str = "", new: str = "") -> Callable[[Path], list[str]]:
    """A pick whose config has ``extra`` sections, and ``old`` text replaced by ``new``."""

    def argv(folder: Path) -> list[str]:
        config = _config(folder, extra)
        if old:
            text = config.read_text()
            assert old in text
            config.write_text(text.replace(old, new))
        return ["pick", "--config", str(config), "--xyz", "10", "20", "300"]

    return argv


def _pick_with_detection(text: str) -> Callable[[Path], list[str]]:
    return lambda t: [
        "pick", "--config", str(_config(t)), "--detection", _file(t, "det.yaml", text),
    ]  # fmt: skip


def _collect_with_pose_list(text: str) -> Callable[[Path], list[str]]:
    return lambda t: [
        "collect", "--config", str(_config(t)), "--poses", _file(t, "poses.yaml", text),
        "--out", str(t / "dataset"), "--capture-command", "true",
    ]  # fmt: skip


SCENE = (
    "scene:\n  clearance_mm: 5\n  bins:\n"
    "    - {name: parts, pose: POSE, inner_mm: [300, 200, 150], wall_mm: 10, floor_mm: 10}\n"
)
FIXTURE = "  boxes:\n    - {name: fixture, pose: POSE, size_mm: [60, 200, 15]}\n"
BIN = "[-0.4, 0, 0.05, 0, 0, 0]"
TOOL = "tool:\n  shape:\n    - name: body\n      SOLID\n"

# Door ("command where", where: the flag, or the file's key the refusal names) -> the command
# line that walks through it with a rotation in degrees, its files in a given folder.
CLI_DOORS: dict[str, Callable[[Path], list[str]]] = {
    "pick --capture-pose-ur": lambda t: [
        "pick", "--config", str(_config(t)), "--xyz", "10", "20", "300", "--dry-run",
        "--capture-pose-ur", *FLANGE_DEG,
    ],
    "plan --robot-pose-ur": lambda t: [
        "plan", "--config", str(_config(t)), "--xyz", "10", "20", "300",
        "--robot-pose-ur", *FLANGE_DEG, "--plot", str(t / "plan.png"),
    ],
    "point --robot-pose-ur": lambda t: [
        "point", "--mode", "eye-in-hand", "--calibration", str(DEMO_HAND_EYE),
        "--robot-pose-ur", *FLANGE_DEG, "--xyz", "10", "20", "300",
    ],
    "cloud --robot-pose-ur": lambda t: [
        "cloud", "--mode", "eye-in-hand", "--calibration", str(DEMO_HAND_EYE),
        "--robot-pose-ur", *FLANGE_DEG, str(CLOUD), str(t / "out.npy"),
    ],
    "poses --mount": lambda t: [
        "poses", "--config", str(_config(t)), "--look-at", "-500", "-100", "0",
        "--distance-mm", "400", "--out", str(t / "poses.yaml"), "--mount", *MOUNT_DEG,
    ],
    "poses --board-mount": lambda t: [
        "poses", "--config", str(_config(t, eye_to_hand=True)), "--look-at", "-500", "-100", "0",
        "--out", str(t / "poses.yaml"), "--board-mount", *MOUNT_DEG,
    ],
    "convert --from ur": lambda t: [
        "convert", "--from", "ur", "--to", "matrix", "0.4", "0.1", "0.3", "0", "180", "0",
    ],
    "pick det.yaml capture.flange_pose_ur": _pick_with_detection(
        "position_mm: [10, 20, 300]\n"
        "capture: {flange_pose_ur: [-0.4919, -0.1333, 0.4879, 127.3, 127.3, 0]}\n"
    ),
    "pick det.yaml orientation.rotvec_rad": _pick_with_detection(
        "position_mm: [10, 20, 300]\norientation: {rotvec_rad: [0, 0, 28.6]}\n"
    ),
    "collect poses.yaml poses.0.tcp_pose": _collect_with_pose_list(
        f"poses:\n  - tcp_pose: {DEG}\n"
    ),
    "collect poses.yaml tcp_offset": _collect_with_pose_list(
        f"tcp_offset: [0, 0, 0.12, 0, 0, 180]\nposes:\n  - tcp_pose: {BIN}\n"
    ),
    "pick cell.yaml robot.tcp_offset": _pick_with_config(
        "", "tcp_offset: [0, 0, 0.12, 0, 0, 0]", "tcp_offset: [0, 0, 0.12, 0, 0, 180]"
    ),
    "pick cell.yaml poses.home.tcp_pose": _pick_with_config(
        f"poses:\n  home: {{tcp_pose: {DEG}}}\n"
    ),
    "pick cell.yaml grasp.object_T_tcp": _pick_with_config(
        "", "retreat_mm: 100}", "retreat_mm: 100, object_T_tcp: [0, 0, 0, 180, 0, 0]}"
    ),
    "pick cell.yaml place.poses.0": _pick_with_config(
        f"place: {{poses: [{DEG}], approach_mm: 100, retreat_mm: 100}}\n"
    ),
    "pick cell.yaml scene.bins[0].pose": _pick_with_config(SCENE.replace("POSE", DEG)),
    "pick cell.yaml scene.boxes[0].pose": _pick_with_config(
        SCENE.replace("POSE", BIN) + FIXTURE.replace("POSE", DEG)
    ),
    "pick cell.yaml tool.shape[0].box.pose": _pick_with_config(
        SCENE.replace("POSE", BIN)
        + TOOL.replace("SOLID", f"box: {{size_mm: [60, 60, 80], pose: {DEG}}}")
    ),
    "pick cell.yaml tool.shape[0].cylinder.pose": _pick_with_config(
        SCENE.replace("POSE", BIN)
        + TOOL.replace("SOLID", f"cylinder: {{radius_mm: 30, length_mm: 80, pose: {DEG}}}")
    ),
}  # fmt: skip


@pytest.mark.parametrize("door", sorted(CLI_DOORS))
def test_a_rotation_in_degrees_is_refused_at_every_command_line_door(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, door: str
) -> None:
    status = main(CLI_DOORS[door](tmp_path))
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.startswith("error: "), err
    assert err.count("\n") == 1, err  # one line: no traceback
    assert REFUSAL in err, err
    assert f" {door.split()[-1]}: " in err, err  # refused at this door, not another
    assert not (tmp_path / "picks.jsonl").exists()  # refused before anything was audited


def test_a_rotation_in_degrees_is_refused_at_the_run_door(tmp_path: Path) -> None:
    runner = Runner(Cell(_config(tmp_path)))  # never connected: a bad request reaches no robot
    candidate = {"position_mm": [10, 20, 300], "orientation": {"rotvec_rad": [0, 0, 28.6]}}
    reply = runner.handle(json.dumps({"id": "p", "op": "pick", "candidates": [candidate]}))
    assert reply["ok"] is False, reply
    assert reply["status"] == "bad-request", reply
    assert REFUSAL in str(reply["error"]), reply
    assert "candidate 0" in str(reply["error"]), reply


def test_the_list_of_doors_is_complete() -> None:
    # Every option that takes a UR vector (metavar X Y Z RX RY RZ) of every command is a door...
    options = set()
    for command, command_parser in parser_with().commands.items():
        for action in command_parser._actions:
            metavar = action.metavar
            if isinstance(metavar, tuple) and metavar[-3:] == ("RX", "RY", "RZ"):
                options.update(f"{command} {flag}" for flag in action.option_strings)
    assert options, "no UR vector options found: the metavar convention changed"
    assert options <= set(CLI_DOORS), sorted(options - set(CLI_DOORS))
    # ...and no pose from outside can pass by the checked reader: the raw one reads only the
    # controller's poses.
    callers = set()
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "ur_pose_to_matrix":
                callers.add(path.relative_to(PACKAGE).as_posix())
    assert callers <= CONTROLLER_READERS, sorted(callers - CONTROLLER_READERS)
