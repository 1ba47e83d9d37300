"""The pieces of ``collect`` that need no robot: where numbering starts, the pose list's TCP,
and the capture command (environment, failures, timeout, no process left behind)."""

from __future__ import annotations

import os
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.calibration.collect import (
    CaptureFailed,
    CommandCapture,
    check_pose_list_tcp,
    first_pair_number,
)
from handeye_pick.calibration.pose_list import PoseList
from handeye_pick.config.load import load_config
from handeye_pick.errors import CalibrationError, InputError
from handeye_pick.geometry import make_transform, ur_pose_to_matrix
from handeye_pick.hand_eye.files import write_zivid_transform

ROOT = Path(__file__).resolve().parents[2]
POSE = make_transform(np.eye(3), [0.3, 0.1, 0.4])


def write_pair(folder: Path, number: int, *, halves: tuple[str, ...] = ("robot", "object")) -> None:
    folder.mkdir(exist_ok=True)
    for kind in halves:
        write_zivid_transform(folder / f"{kind}_pose_{number}.yaml", POSE, "mm")


# --- numbering ----------------------------------------------------------------------------------


def test_a_new_folder_is_created_and_starts_at_0(tmp_path: Path) -> None:
    dataset = tmp_path / "a" / "dataset"
    assert first_pair_number(dataset, append=False, units="mm") == 0
    assert dataset.is_dir()


def test_other_files_do_not_make_a_dataset(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("board A3, 30 mm squares\n")
    assert first_pair_number(tmp_path, append=False, units="mm") == 0


def test_pairs_are_refused_without_append(tmp_path: Path) -> None:
    write_pair(tmp_path, 0)
    with pytest.raises(InputError, match="--append"):
        first_pair_number(tmp_path, append=False, units="mm")


def test_append_continues_after_the_highest_number(tmp_path: Path) -> None:
    for number in (2, 7, 3):
        write_pair(tmp_path, number)
    assert first_pair_number(tmp_path, append=True, units="mm") == 8


def test_append_checks_the_pairs_first(tmp_path: Path) -> None:
    write_pair(tmp_path, 0)
    write_pair(tmp_path, 1, halves=("object",))
    with pytest.raises(CalibrationError, match=r"object_pose_1\.yaml has no robot_pose_1\.yaml"):
        first_pair_number(tmp_path, append=True, units="mm")


def test_a_file_is_not_a_dataset(tmp_path: Path) -> None:
    (tmp_path / "dataset").write_text("")
    with pytest.raises(InputError, match="is a file"):
        first_pair_number(tmp_path / "dataset", append=True, units="mm")


# --- the pose list's TCP ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("tcp_offset", "refused"),
    [(None, False), ((0, 0, 0.1205, 0, 0, 0), False), ((0, 0, 0.2, 0, 0, 0), True)],
    ids=["none", "within-tolerance", "other-tcp"],
)
def test_a_pose_list_for_another_tcp_is_refused(
    tcp_offset: tuple[float, ...] | None, refused: bool
) -> None:
    config = load_config(ROOT / "config" / "demo.yaml")  # robot.tcp_offset [0, 0, 0.12, 0, 0, 0]
    T = None if tcp_offset is None else ur_pose_to_matrix(list(tcp_offset))
    pose_list = PoseList(Path("poses.yaml"), (), T)
    if refused:
        with pytest.raises(InputError, match=r"poses\.yaml: tcp_offset differs .* by 80\.0 mm"):
            check_pose_list_tcp(pose_list, config)
    else:
        check_pose_list_tcp(pose_list, config)


# --- the capture command ------------------------------------------------------------------------


def python_command(code: str, timeout_s: float = 30.0) -> CommandCapture:
    return CommandCapture.parse(shlex.join([sys.executable, "-c", code]), timeout_s)


@pytest.mark.parametrize(
    ("command", "message"),
    [
        ("", "empty"),
        ("camera 'unbalanced", "No closing quotation"),
        ("no-such-capture-program --pose", "'no-such-capture-program' is not an executable"),
    ],
)
def test_a_bad_command_is_refused_before_anything_runs(command: str, message: str) -> None:
    with pytest.raises(InputError, match=message):
        CommandCapture.parse(command, 10.0)


def test_a_timeout_must_be_positive() -> None:
    with pytest.raises(InputError, match="--capture-timeout-s"):
        CommandCapture.parse(sys.executable, 0.0)


def test_the_command_gets_the_pair_number_and_the_file_without_a_shell(tmp_path: Path) -> None:
    out = tmp_path / "pending_object_pose_4.yaml"
    code = (
        "import os, sys; "
        "open(os.environ['HANDEYE_OBJECT_POSE_FILE'], 'w').write("
        "os.environ['HANDEYE_POSE_INDEX'] + ' ' + sys.argv[1])"
    )
    capture = CommandCapture.parse(shlex.join([sys.executable, "-c", code, "$HOME; *"]), 30.0)
    capture(4, out)
    assert out.read_text() == "4 $HOME; *"  # argv as given: no expansion, no globbing


def test_a_failing_command_says_why(tmp_path: Path) -> None:
    capture = python_command("import sys; print('x'); sys.exit('board not found\\n\\n')")
    with pytest.raises(CaptureFailed, match=r"exited with status 1: board not found$"):
        capture(0, tmp_path / "out.yaml")


def test_a_command_past_its_timeout_is_killed_with_its_children(tmp_path: Path) -> None:
    pids = tmp_path / "pids"
    code = (
        "import os, subprocess, sys, time; "
        "child = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)']); "
        f"open({str(pids)!r}, 'w').write(f'{{os.getpid()}} {{child.pid}}'); "
        "time.sleep(60)"
    )
    capture = python_command(code, timeout_s=4.0)
    with pytest.raises(CaptureFailed, match="did not finish within 4 s"):
        capture(0, tmp_path / "out.yaml")
    for pid in map(int, pids.read_text().split()):
        assert not alive(pid), pid


def alive(pid: int) -> bool:
    """True while ``pid`` runs; a killed grandchild may need a moment to be reaped by init."""
    for _ in range(100):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        if _zombie(pid):
            return False
        time.sleep(0.05)
    return True


def _zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] == "Z"
    except OSError:
        return False
