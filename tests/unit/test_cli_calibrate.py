"""The ``calibrate`` command on dataset files: result and residual files, table, JSON, suspects,
exclusion, exit statuses and one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from handeye_pick.cli import main
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye
from mocks.handeye_scene import Noise, Scene, make_scene, measure, wrong_pair
from tests.unit.handeye_helpers import MODES, NUMBERS, errors, write_dataset


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def dataset(
    tmp_path: Path, mode: HandEyeMode, count: int = 12, seed: int = 1
) -> tuple[Path, Scene]:
    rng = np.random.default_rng(seed)
    scene = make_scene(rng, mode.value, count)
    return write_dataset(tmp_path / "dataset", measure(scene, rng, Noise())), scene


@pytest.mark.parametrize("mode", MODES)
def test_calibrate_writes_the_result_and_the_residuals(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], mode: HandEyeMode
) -> None:
    folder, scene = dataset(tmp_path, mode)
    status, out, err = run(capsys, "calibrate", "--mode", mode.value, str(folder))
    assert (status, err) == (0, "")
    # The result reads back through the same loader a pick uses, in the mode's direction.
    calibration = load_hand_eye(folder / "hand_eye_transform.yaml", mode)
    distance_mm, angle_deg = errors(calibration.T_cal, scene.T_cal)
    assert distance_mm < 0.5
    assert angle_deg < 0.05
    record = yaml.safe_load((folder / "hand_eye_residuals.yaml").read_text())
    assert record["mode"] == mode.value
    assert (
        record["transform_name"]
        == {"eye-in-hand": "T_flange_cam", "eye-to-hand": "T_base_cam"}[mode.value]
    )
    assert [r["pair"] for r in record["residuals"]] == list(NUMBERS[:12])
    assert record["translation_max_mm"] == max(r["translation_mm"] for r in record["residuals"])
    assert record["suspects"] == []
    assert record["noise"]["camera_depth_mm"] == 0.3
    # The table: a row per pair number, mean and max, Zivid's bands.
    for number in NUMBERS[:12]:
        assert f"\n  {number:>6}  " in out
    assert "    mean  " in out
    assert "     max  " in out
    assert "sub-millimetre range for a smaller robot" in out
    assert f"wrote {folder / 'hand_eye_transform.yaml'}" in out


def test_json_output_and_out_path(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder, scene = dataset(tmp_path, HandEyeMode.EYE_TO_HAND)
    out_file = tmp_path / "results" / "cell_a.yaml"
    out_file.parent.mkdir()
    status, out, err = run(
        capsys, "calibrate", "--mode", "eye-to-hand", str(folder), "--out", str(out_file), "--json"
    )
    assert (status, err) == (0, "")
    report: dict[str, Any] = json.loads(out)
    assert errors(np.array(report["transform_m"]), scene.T_cal)[0] < 0.5
    assert report["transform_name"] == "T_base_cam"
    assert report["start_method"] in ("TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS")
    assert report["suspects"] == []
    assert report["without_suspects"] is None
    assert report["out"] == str(out_file)
    assert report["residuals_file"] == str(out_file.parent / "hand_eye_residuals.yaml")
    assert out_file.exists()
    assert (out_file.parent / "hand_eye_residuals.yaml").exists()
    assert not (folder / "hand_eye_transform.yaml").exists()


def test_a_suspect_is_named_and_can_be_excluded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(3)
    scene = make_scene(rng, "eye-in-hand", 12)
    folder = write_dataset(tmp_path / "dataset", wrong_pair(scene, rng, Noise(), 4))
    bad = NUMBERS[4]
    status, out, _ = run(capsys, "calibrate", "--mode", "eye-in-hand", str(folder))
    assert status == 0
    assert f"\n  {bad:>6}  " in out
    assert f"suspects: pair {bad} stands out" in out
    assert f"excluding them (--exclude {bad}) would move the result by" in out
    record = yaml.safe_load((folder / "hand_eye_residuals.yaml").read_text())
    assert record["suspects"] == [bad]
    assert record["without_suspects"]["translation_max_mm"] < 2.0
    # Nothing is excluded silently: the result written still uses the wrong pair.
    written = load_hand_eye(folder / "hand_eye_transform.yaml", HandEyeMode.EYE_IN_HAND)
    assert errors(written.T_cal, scene.T_cal)[0] > 5.0

    status, out, _ = run(
        capsys, "calibrate", "--mode", "eye-in-hand", str(folder), "--exclude", f"{bad}", "--json"
    )
    report = json.loads(out)
    assert status == 0
    assert report["excluded"] == [bad]
    assert report["suspects"] == []
    assert bad not in report["pairs_used"]
    assert errors(np.array(report["transform_m"]), scene.T_cal)[0] < 0.5


def test_few_pairs_warn_on_stderr(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder, _ = dataset(tmp_path, HandEyeMode.EYE_IN_HAND, count=6)
    status, _, err = run(capsys, "calibrate", "--mode", "eye-in-hand", str(folder))
    assert status == 0
    assert "WARNING: only 6 pairs" in err
    status, _, err = run(capsys, "calibrate", "--mode", "eye-in-hand", str(folder), "--quiet")
    assert (status, err) == (0, "")


def assert_bad_input(capsys: pytest.CaptureFixture[str], message: str, *argv: str) -> None:
    status, out, err = run(capsys, *argv)
    assert status == 2
    assert out == ""
    assert err.startswith("error: ")
    assert err.count("\n") == 1, err  # one line, never a traceback
    assert message in err


def test_bad_input_exits_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder, _ = dataset(tmp_path, HandEyeMode.EYE_IN_HAND, count=5)
    args = ("calibrate", "--mode", "eye-in-hand", str(folder))
    assert_bad_input(capsys, "--exclude takes pair numbers", *args, "--exclude", "3;7")
    assert_bad_input(capsys, "cannot exclude pair(s) 4", *args, "--exclude", "4")
    assert_bad_input(
        capsys, "at least 4 pairs, 3 left after excluding 2", *args, "--exclude", "3,7"
    )
    assert_bad_input(
        capsys, "noise camera_lateral_mm must be > 0", *args, "--camera-noise", "0", "1", "1"
    )
    (folder / f"object_pose_{NUMBERS[2]}.yaml").unlink()
    assert_bad_input(capsys, f"robot_pose_{NUMBERS[2]}.yaml has no object_pose_{NUMBERS[2]}", *args)
    assert not (folder / "hand_eye_transform.yaml").exists()  # nothing written on a refusal


def test_degenerate_data_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # The same view from every pose: no rotation between them at all.
    rng = np.random.default_rng(5)
    scene = make_scene(rng, "eye-in-hand", 1)
    captures = measure(scene, rng, Noise(), [scene.T_cam_obj[0]] * 6)
    folder = write_dataset(tmp_path / "dataset", captures)
    assert_bad_input(
        capsys, "rotations too small", "calibrate", "--mode", "eye-in-hand", str(folder)
    )


def test_the_cli_starts_without_opencv_or_scipy_optimize() -> None:
    code = (
        "import sys; from handeye_pick.cli import parser_with; parser_with(); "
        "print(sorted(m for m in ('cv2', 'scipy.optimize') if m in sys.modules))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == "[]"
