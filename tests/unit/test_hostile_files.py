"""Hostile and pathological input files and numbers: every case ends with exit 2 and one line on
stderr naming the file (and the key or the line and column), no traceback, no numpy warning,
bounded memory. Each case runs through the CLI entry point and through the loader."""

from __future__ import annotations

import re
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import pytest

from handeye_pick.cli import main
from handeye_pick.config.load import load_config
from handeye_pick.detection import load_detection
from handeye_pick.errors import InputError
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye
from handeye_pick.inputfiles import MAX_INPUT_BYTES, MAX_YAML_VALUES

ROOT = Path(__file__).resolve().parents[2]
DEMO_HAND_EYE = ROOT / "config" / "demo" / "hand_eye.yaml"
EYE_TO_HAND = ROOT / "config" / "calibration" / "EyeToHandTransform.yaml"

# numpy's overflow warnings would print lines before the error: make them fail the test instead.
pytestmark = pytest.mark.filterwarnings("error")


def _laughs(indent: str, levels: int = 8) -> list[str]:
    """YAML list items, each nine aliases of the one before: 9^levels values once expanded."""
    lines = [f"{indent}- &l0 [1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    for level in range(1, levels):
        aliases = ", ".join([f"*l{level - 1}"] * 9)
        lines.append(f"{indent}- &l{level} [{aliases}]")
    return lines


ZIVID_HEAD = "__version__: {serializer: 1, data: 1}\nFloatMatrix:\n"
ZIVID_IDENTITY_ROWS = "[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]"

CALIBRATION_CASES = {
    "laughs under FloatMatrix.Data": (
        ZIVID_HEAD + "  Data:\n" + "\n".join(_laughs("    ")) + "\n",
        "more than 10000 values once its aliases",
    ),
    "laughs as a plain sequence": ("\n".join(_laughs("")) + "\n", "more than 10000 values"),
    "laughs in an OpenCV node": (
        "%YAML:1.0\n---\nx:\n"
        + "\n".join(_laughs("  "))
        + "\nP: !!opencv-matrix {rows: 4, cols: 4, dt: d, data: *l7}\n",
        "more than 10000 values",
    ),
    "an alias inside itself": ("&a [1, *a]\n", r"an alias \(\*name\) inside the value"),
    "a python tag": (
        "!!python/object/apply:os.system ['echo hi']\n",
        "python/object/apply:os.system' at line 1, column 1",
    ),
    "a syntax error": ("a: [1, 2\nb: 3\n", "at line 2, column 2"),
    "deep nesting": ("[" * 1000 + "]" * 1000 + "\n", "nested deeper than 20 levels"),
    "deep JSON nesting": ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    "1e308 in a translation": (
        ZIVID_HEAD + f"  Data: [[1, 0, 0, 1.0e+308], {ZIVID_IDENTITY_ROWS}]\n",
        r"FloatMatrix.Data row 0 column 3: 1e\+308 is not a transform entry",
    ),
    "1e308 in a rotation": (
        ZIVID_HEAD + f"  Data: [[1.0e+308, 0, 0, 500], {ZIVID_IDENTITY_ROWS}]\n",
        r"FloatMatrix.Data row 0 column 0: 1e\+308",
    ),
    "a 5000-digit integer": (
        ZIVID_HEAD + f"  Data: [[1, 0, 0, {'1' * 5000}], {ZIVID_IDENTITY_ROWS}]\n",
        "an integer of 5000 characters at line 3, column 20",
    ),
    "a 5000-digit integer in JSON": (
        f"[[1, 0, 0, {'1' * 5000}], {ZIVID_IDENTITY_ROWS}]",
        "an integer of 5000 characters",
    ),
    "1e308 as a numeric string": (
        ZIVID_HEAD + f"  Data: [[1, 0, 0, 1e308], {ZIVID_IDENTITY_ROWS}]\n",
        r"row 0 column 3: 1e\+308",
    ),
}


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    status = main(list(argv))
    out, err = capsys.readouterr()
    assert out == ""
    return status, err


def _assert_one_line_exit_2(
    capsys: pytest.CaptureFixture[str], names: list[str], *argv: str
) -> str:
    status, err = _run(capsys, *argv)
    assert status == 2, err
    assert err.startswith("error: ")
    assert err.count("\n") == 1, err  # one line: no traceback, no warning lines
    assert len(err) < 600, err  # never the expanded value
    for name in names:
        assert name in err
    return err


def _peak_memory_mb(load: Callable[[], object]) -> float:
    tracemalloc.start()
    try:
        with pytest.raises(InputError):
            load()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("case", sorted(CALIBRATION_CASES))
def test_hostile_calibration_file(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, case: str
) -> None:
    text, message = CALIBRATION_CASES[case]
    path = tmp_path / ("cal.json" if "JSON" in case else "cal.yaml")
    path.write_text(text)
    err = _assert_one_line_exit_2(
        capsys, [str(path)],
        "point", "--mode", "eye-to-hand", "--calibration", str(path), "--xyz", "10", "20", "300",
    )  # fmt: skip
    assert re.search(message, err), err
    if "laughs" in case:  # it once took 400 MB; refused before expansion it takes a few
        assert _peak_memory_mb(lambda: load_hand_eye(path, HandEyeMode.EYE_TO_HAND)) < 50.0


def _sparse_file(path: Path, size: int) -> Path:
    """A file of ``size`` zero bytes that takes no disk space."""
    with path.open("wb") as file:
        file.truncate(size)
    return path


def test_huge_files_are_refused_from_their_size(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    huge = _sparse_file(tmp_path / "huge.yaml", 200_000_000)
    err = _assert_one_line_exit_2(
        capsys, [str(huge), "larger than 1000 kB"],
        "point", "--mode", "eye-to-hand", "--calibration", str(huge), "--xyz", "10", "20", "300",
    )  # fmt: skip
    assert "transform file" in err
    config = _config(tmp_path, "")
    _assert_one_line_exit_2(
        capsys, [str(huge), "detection file"],
        "pick", "--config", str(config), "--detection", str(huge),
    )  # fmt: skip
    _assert_one_line_exit_2(
        capsys, [str(huge), "cell config"], "pick", "--config", str(huge), "--xyz", "1", "2", "300"
    )
    for load in (
        lambda: load_detection(huge),
        lambda: load_config(huge),
        lambda: load_hand_eye(huge, HandEyeMode.EYE_TO_HAND),
    ):
        assert _peak_memory_mb(load) < 5.0  # never read


def test_a_file_just_over_the_size_bound_is_refused_and_one_under_it_is_read(
    tmp_path: Path,
) -> None:
    body = "position_mm: [10, 20, 300]\n"
    path = tmp_path / "detection.yaml"
    path.write_text("#" * (MAX_INPUT_BYTES - len(body) - 1) + "\n" + body)
    assert load_detection(path).position_only
    path.write_text("#" * (MAX_INPUT_BYTES - len(body)) + "\n" + body)
    with pytest.raises(InputError, match="larger than 1000 kB"):
        load_detection(path)


def test_many_values_are_refused_before_all_are_parsed(tmp_path: Path) -> None:
    path = tmp_path / "detection.yaml"
    path.write_text("position_mm: [" + ", ".join(["1.5"] * 20_000) + "]\n")  # 100 kB of numbers
    with pytest.raises(InputError, match=f"more than {MAX_YAML_VALUES} values at line 1"):
        load_detection(path)


def _config(tmp_path: Path, extra: str) -> Path:
    """A cell config in ``tmp_path`` (audit file there too) with ``extra`` appended."""
    path = tmp_path / "cell.yaml"
    path.write_text(
        "robot: {host: 192.0.2.10, tcp_offset: [0, 0, 0.12, 0, 0, 0]}\n"
        f"hand_eye: {{mode: eye-in-hand, file: {DEMO_HAND_EYE}, units: mm}}\n"
        "grasp: {approach_mm: 100, retreat_mm: 100}\n"
        "motion: {speed_mps: 0.25, accel_mps2: 1.2, grasp_speed_mps: 0.05}\n"
        "workspace: {min_mm: [-800, -800, 20], max_mm: [800, 800, 700], max_tilt_deg: 30}\n"
        "audit: {file: picks.jsonl}\n" + extra
    )
    return path


DETECTION_CASES = {
    "laughs as position_mm": (
        "x:\n" + "\n".join(_laughs("  ")) + "\nposition_mm: *l7\n",
        "more than 10000 values",
    ),
    "a python tag": (
        "position_mm: !!python/object/apply:os.system ['echo hi']\n",
        "line 1, column 14",
    ),
    "a syntax error": ("position_mm: [1, 2\norientation: 3\n", "line 2, column 12"),
    "a 100 kB string as position_mm": (
        f"position_mm: '{'x' * 100_000}'\n",
        "position_mm: expected a list of 3 numbers, got string 'xxx",
    ),
    "1e308 in position_mm": (
        "position_mm: [1.0e+308, 1.0e+308, 300]\n",
        "position_mm: camera point",
    ),
    "1e308 in the capture pose": (
        "position_mm: [10, 20, 300]\n"
        "capture: {flange_pose_ur: [1.0e+308, 1.0e+308, 0, 0, 0, 1.0e+308]}\n",
        "capture.flange_pose_ur: the flange pose: flange distance from the robot base is 1.4",
    ),
    "1e308 in rotvec_rad": (
        "position_mm: [10, 20, 300]\norientation: {rotvec_rad: [1.0e+308, 0, 0]}\n",
        "orientation.rotvec_rad: rotation vector is 1e+308 rad long",
    ),
    "1e308 in a quaternion": (
        "position_mm: [10, 20, 300]\norientation: {quaternion_xyzw: [1.0e+308, 1.0e+308, 0, 1]}\n",
        "orientation.quaternion_xyzw: 1e+308 is out of range",
    ),
    "1e308 in a matrix": (
        "position_mm: [10, 20, 300]\n"
        "orientation: {matrix: [[1.0e+308, 0, 0], [0, 1.0e+308, 0], [0, 0, 1]]}\n",
        "orientation.matrix: 1e+308 is out of range",
    ),
    "1e308 Euler angles": (
        "position_mm: [10, 20, 300]\n"
        "orientation: {rpy_deg: {angles: [1.0e+308, 0, 0], convention: xyz}}\n",
        "orientation.rpy_deg.angles: 1e+308 is out of range",
    ),
}


@pytest.mark.parametrize("case", sorted(DETECTION_CASES))
def test_hostile_detection_file(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, case: str
) -> None:
    text, message = DETECTION_CASES[case]
    path = tmp_path / "detection.yaml"
    path.write_text(text)
    config = _config(tmp_path, "")
    _assert_one_line_exit_2(
        capsys, [str(path), message], "pick", "--config", str(config), "--detection", str(path)
    )
    assert not (tmp_path / "picks.jsonl").exists()  # refused before anything else happened
    if "laughs" in case:
        assert _peak_memory_mb(lambda: load_detection(path)) < 50.0


CONFIG_CASES = {
    "laughs under workspace": (
        "x:\n" + "\n".join(_laughs("  ")) + "\n",
        "more than 10000 values",
    ),
    "a python tag": ("y: !!python/object/apply:os.system ['echo hi']\n", "line 7, column 4"),
    "a duplicate key": ("audit: {file: other.jsonl}\n", "key 'audit' appears twice at line 7"),
}


@pytest.mark.parametrize("case", sorted(CONFIG_CASES))
def test_hostile_cell_config(capsys: pytest.CaptureFixture[str], tmp_path: Path, case: str) -> None:
    extra, message = CONFIG_CASES[case]
    config = _config(tmp_path, extra)
    _assert_one_line_exit_2(
        capsys, [str(config), message], "pick", "--config", str(config), "--xyz", "10", "20", "300"
    )
    if "laughs" in case:
        assert _peak_memory_mb(lambda: load_config(config)) < 50.0


def test_1e308_in_a_config_pose_names_the_key(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    config = _config(tmp_path, "")
    text = config.read_text().replace("[0, 0, 0.12, 0, 0, 0]", "[1.0e+308, 1.0e+308, 0, 0, 0, 0]")
    config.write_text(text)
    _assert_one_line_exit_2(
        capsys, [str(config), "robot.tcp_offset: translation is 1.41421e+308 m long"],
        "pick", "--config", str(config), "--xyz", "10", "20", "300",
    )  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--xyz", "1e308", "1e308", "300"], "--xyz: camera point"),
        (["--xyz", "0.03777", "-0.14592", "1.2271"], "metres given as mm"),
    ],
)
def test_hostile_numbers_on_the_command_line(
    capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    _assert_one_line_exit_2(
        capsys, [message], "point", "--mode", "eye-to-hand", "--calibration", str(EYE_TO_HAND),
        *argv,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("pose", "message"),
    [
        (["1e308", "1e308", "0", "0", "3.1", "0"], "--robot-pose-ur: flange distance"),
        (["0.4", "0.1", "0.3", "1e308", "0", "0"], "--robot-pose-ur: rotation vector is 1e+308"),
        (["400", "100", "300", "0", "3.1", "0"], "(UR vectors are in m)"),
    ],
)
def test_hostile_robot_pose_vector(
    capsys: pytest.CaptureFixture[str], pose: list[str], message: str
) -> None:
    _assert_one_line_exit_2(
        capsys, [message],
        "point", "--mode", "eye-in-hand", "--calibration", str(DEMO_HAND_EYE),
        "--robot-pose-ur", *pose, "--xyz", "10", "20", "300",
    )  # fmt: skip
