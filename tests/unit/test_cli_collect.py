"""``poses`` and ``collect`` refuse bad flags and files with exit 2 and one line, before they
connect to the robot (the config's controller does not exist here)."""

from __future__ import annotations

from pathlib import Path

import pytest

from handeye_pick.cli import main

ROOT = Path(__file__).resolve().parents[2]
IN_HAND = ("--look-at", "-500", "-120", "0")
BOARD_MOUNT = ("--board-mount", "0", "0.1", "0.03", "0", "0", "0")


@pytest.fixture
def cell(tmp_path: Path, loopback_host: str, request: pytest.FixtureRequest) -> Path:
    """A cell config whose controller is never started: a connection attempt would fail."""
    mode = getattr(request, "param", "eye-in-hand")
    calibration = "EyeInHandTransform.yaml" if mode == "eye-in-hand" else "EyeToHandTransform.yaml"
    path = tmp_path / "cell.yaml"
    path.write_text(
        f"robot:\n  host: {loopback_host}\n  tcp_offset: [0, 0, 0.12, 0, 0, 0]\n"
        f"hand_eye:\n  mode: {mode}\n  file: {ROOT / 'config' / 'calibration' / calibration}\n"
        "  units: mm\n"
        "grasp:\n  approach_mm: 100\n  retreat_mm: 100\n"
        "motion:\n  speed_mps: 0.25\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.1\n"
        "workspace:\n  min_mm: [-800, -800, 20]\n  max_mm: [800, 800, 700]\n  max_tilt_deg: 50\n"
        "audit:\n  file: audit.jsonl\n"
    )
    return path


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    status = main(list(argv))
    _, err = capsys.readouterr()
    assert len(err.strip().splitlines()) == 1, err  # one line, no traceback
    return status, err


@pytest.mark.parametrize(
    ("cell", "flags", "message"),
    [
        ("eye-in-hand", IN_HAND, "eye-in-hand needs --distance-mm"),
        ("eye-in-hand", (*IN_HAND, "--distance-mm", "400", *BOARD_MOUNT), "--board-mount is for"),
        ("eye-to-hand", (*IN_HAND, "--distance-mm", "400", *BOARD_MOUNT), "drop --distance-mm"),
        ("eye-to-hand", IN_HAND, "eye-to-hand needs --board-mount"),
    ],
    indirect=["cell"],
    ids=["no-distance", "board-mount-in-hand", "distance-to-hand", "no-board-mount"],
)
def test_poses_refuses_the_other_modes_flags(
    capsys: pytest.CaptureFixture[str], cell: Path, flags: tuple[str, ...], message: str
) -> None:
    out = cell.parent / "poses.yaml"
    status, err = run(capsys, "poses", "--config", str(cell), *flags, "--out", str(out))
    assert status == 2
    assert message in err
    assert not out.exists()


POSES = "tcp_offset: [0, 0, 0.12, 0, 0, 0]\nposes:\n  - tcp_pose: [-0.5, -0.1, 0.3, 3.14, 0, 0]\n"


def write_poses(folder: Path, text: str = POSES) -> Path:
    path = folder / "poses.yaml"
    path.write_text(text)
    return path


def test_collect_without_a_command_needs_a_terminal(
    capsys: pytest.CaptureFixture[str], cell: Path
) -> None:
    dataset = cell.parent / "dataset"
    status, err = run(
        capsys, "collect", "--config", str(cell), "--poses", str(write_poses(cell.parent)),
        "--out", str(dataset),
    )  # fmt: skip
    assert status == 2
    assert "standard input is not a terminal" in err
    assert not dataset.exists()


@pytest.mark.parametrize(
    ("poses_text", "command", "message"),
    [
        (POSES, "no-such-camera-program", "'no-such-camera-program' is not an executable"),
        ("poses: []\n", "true", "poses: expected a list"),
        (POSES.replace("0.12", "0.2"), "true", "its tcp_pose entries are for another TCP"),
    ],
    ids=["missing-program", "empty-list", "other-tcp"],
)
def test_collect_refuses_bad_input_before_connecting(
    capsys: pytest.CaptureFixture[str],
    cell: Path,
    poses_text: str,
    command: str,
    message: str,
) -> None:
    poses = write_poses(cell.parent, poses_text)
    dataset = cell.parent / "dataset"
    status, err = run(
        capsys, "collect", "--config", str(cell), "--poses", str(poses), "--out", str(dataset),
        "--capture-command", command,
    )  # fmt: skip
    assert status == 2
    assert message in err
    assert not dataset.exists()
