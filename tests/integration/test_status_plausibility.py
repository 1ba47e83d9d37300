"""``status`` runs a pick's plausibility checks of the camera chain (issue 30, item 3): a
calibration file in the wrong mode is not ready, with the lines the pick's refusal gives and its
exit status, before any pick is tried. The example files in config/calibration; the CLI in a
subprocess against the simulated UR."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from mocks.ur_controller import SimulatedController
from tests.integration.test_operator_cli import cli_json
from tests.integration.test_pick_cli import DEMO, ROOT, TCP_OFFSET, run_json, write_config

SimFactory = Callable[..., SimulatedController]
CALIBRATION = ROOT / "config" / "calibration"


def _hand_eye(mode: str, file: str, extra: str = "") -> str:
    return f"  mode: {mode}\n  file: {CALIBRATION / file}\n  units: mm\n{extra}"


@pytest.mark.parametrize(
    ("mode", "file"),
    [("eye-in-hand", "EyeToHandTransform.yaml"), ("eye-to-hand", "EyeInHandTransform.yaml")],
)
def test_a_calibration_in_the_wrong_mode_is_not_ready_with_the_picks_lines(
    sim_controller: SimFactory, tmp_path: Path, mode: str, file: str
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host, hand_eye=_hand_eye(mode, file))
    status, report = cli_json("status", "--config", str(config))
    pick_status, pick = run_json(config, "--detection", str(DEMO / "detection.yaml"), "--dry-run")
    assert (pick_status, pick["status"]) == (3, "refused"), pick
    assert (status, report["status"], report["ready"]) == (pick_status, "not-ready", False), report
    refused = [check for check in pick["checks"] if not check["passed"]]
    camera = [check for check in refused if check["target"] == "chain"]
    assert camera == refused  # the pick refused the chain and nothing else
    assert report["problems"] == [
        f"{check['target']} {check['name']}: {check['detail']}"
        for check in camera
        if not check["name"].startswith("plausible object-")  # the detection's own checks
    ]
    assert report["problems"], report
    assert all(problem in pick["error"] for problem in report["problems"])
    assert ctl.commands == []


def test_a_check_the_cell_acknowledges_is_a_note_not_a_problem(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    checks = "  acknowledge: [camera-near-flange, camera-looks-along-tool]\n"
    hand_eye = _hand_eye("eye-in-hand", "EyeToHandTransform.yaml", checks)
    config = write_config(tmp_path, ctl.host, hand_eye=hand_eye)
    status, report = cli_json("status", "--config", str(config))
    assert (status, report["problems"]) == (0, []), report
    assert [note.split(":")[0] for note in report["notes"]] == [
        "chain plausible camera-near-flange",
        "chain plausible camera-looks-along-tool",
    ]
    assert all("acknowledged in hand_eye.acknowledge" in note for note in report["notes"])
