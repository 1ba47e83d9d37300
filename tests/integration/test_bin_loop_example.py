"""examples/bin_loop.py end to end: the simulated camera and controller, `handeye-pick run`
through a pipe with the scene and the tool's shape of config/bin.yaml, the bin emptied but for
the cube in the corner (refused with every alternative's reason), and the driven TCP poses
replayed by mocks/contact_check.py against the bin: no contact."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.integration.test_vision_loop_example import example_config

ROOT = Path(__file__).resolve().parents[2]


def test_the_bin_is_emptied_but_the_corner_cube_and_nothing_touches_the_bin(
    tmp_path: Path,
) -> None:
    config = example_config(tmp_path, "bin.yaml")
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "bin_loop.py"),
         "--config", str(config), "--speed-factor", "8"],
        cwd=tmp_path, capture_output=True, text=True, timeout=180, check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "5 of 6 cubes picked" in result.stdout
    assert "left: corner; every check passed" in result.stdout
    assert ", 0 touch a bin;" in result.stdout
    refused = [line for line in result.stdout.splitlines() if line.startswith("refused ")]
    assert len(refused) == 1
    for yaw in (0, 90, 180, 270):
        assert f"yaw {yaw} deg, tilt 0 deg) collision: tool 'finger" in refused[0]
    assert "wall 'east'" in refused[0]
    assert "wall 'north'" in refused[0]
    records = [json.loads(line) for line in (tmp_path / "picks.jsonl").read_text().splitlines()]
    plans = [r for r in records if r.get("event") == "plan" and "alternative" in r]
    assert len(plans) == 5  # each pick's plan says which grasp it took and why not the others
    assert all(r["alternative"]["tilt_deg"] == 0 for r in plans)
