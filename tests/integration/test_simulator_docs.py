"""docs/simulator.md's command for a simulator that matches config/cell.example.yaml holds: run
as written (on its own 127.0.0.N, motions instant), a pick with the example config and the demo
detection ends placed with the grasp confirmed; with the part gone, it ends missed with the very
line the page quotes."""

from __future__ import annotations

import re
import shlex
import signal
from pathlib import Path

from mocks.ur_controller import admin
from tests.conftest import TEST_WATCHDOG_S
from tests.integration.test_pick_cli import DEMO, ROOT, run_pick
from tests.mock_controller.test_record_cli import _start_ready_cli

PAGE = ROOT / "docs" / "simulator.md"
HEADING = "### A simulator for `config/cell.example.yaml`"


def _documented_command() -> list[str]:
    """The arguments of the page's command for the example config, without its --host."""
    section = PAGE.read_text().split(HEADING, 1)[1]
    block = re.search(r"```\n(python -m mocks\.ur_controller .*)\n```", section)
    assert block is not None, f"{PAGE} has no command under {HEADING}"
    words = shlex.split(block.group(1))[3:]
    at = words.index("--host")
    assert words[at + 1] == "127.0.0.1"
    return words[:at] + words[at + 2 :]


def _quoted_miss_line() -> str:
    """The `grasp missed: ...` line the page quotes, joined from its wrapped lines."""
    section = " ".join(PAGE.read_text().split(HEADING, 1)[1].split())
    quoted = re.search(r"`(grasp missed: [^`]*)`", section)
    assert quoted is not None
    return quoted.group(1)


def _example_copy(tmp_path: Path, host: str) -> Path:
    """config/cell.example.yaml as the page says to copy it: robot.host on the simulator (and
    the calibration file found from the copy; the tests' watchdog window)."""
    text = (ROOT / "config" / "cell.example.yaml").read_text()
    for old, new in [
        ("host: 192.168.1.10", f"host: {host}"),
        ("file: calibration/", f"file: {ROOT / 'config' / 'calibration'}/"),
        ("watchdog_s: 0.2", f"watchdog_s: {TEST_WATCHDOG_S}"),
    ]:
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "cell.yaml"
    path.write_text(text)
    return path


def test_the_documented_simulator_confirms_the_example_configs_grasp(tmp_path: Path) -> None:
    host, process = _start_ready_cli(*_documented_command(), "--instant")
    try:
        config = _example_copy(tmp_path, host)
        home = admin.request(host, {"op": "snapshot"})["flange_pose"]
        pick = ["--detection", str(DEMO / "detection.yaml"), "--capture-pose-ur",
                *map(str, home)]
        placed = run_pick(config, *pick)
        assert placed.returncode == 0, placed.stderr
        assert placed.stdout.startswith("pick placed")
        assert "grasp confirmed" in placed.stderr.splitlines()
        admin.request(host, {"op": "set_part", "width_mm": None})
        missed = run_pick(config, *pick)
        assert missed.returncode == 5, missed.stderr
        assert _quoted_miss_line() in missed.stderr.splitlines()
    finally:
        process.send_signal(signal.SIGTERM)
        process.communicate(timeout=30)
