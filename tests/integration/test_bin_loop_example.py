"""examples/bin_loop.py end to end: the simulated camera and controller, `handeye-pick run`
through a pipe with the scene (a deep bin, a fixture beside the place) and the tool's shape of
config/bin.yaml, the arm checked with its links: the cubes against the east and west walls,
whose fingers fit but whose last wrist would come into the wall's top, refused by the arm's
check (grasps the tool-only check would have passed, counted), the corner cube refused with every
alternative's reason, and the driven TCP poses and joints replayed by mocks/contact_check.py
with the tool, the cube in the fingers and the arm's links against the bin and the fixture: no
contact."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.integration.test_vision_loop_example import example_config

ROOT = Path(__file__).resolve().parents[2]


def test_the_bin_is_emptied_of_what_the_arm_can_reach_and_nothing_touches_it(
    tmp_path: Path,
) -> None:
    config = example_config(tmp_path, "bin.yaml")
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "bin_loop.py"),
         "--config", str(config), "--speed-factor", "8"],
        cwd=tmp_path, capture_output=True, text=True, timeout=180, check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "3 of 6 cubes picked" in result.stdout
    assert "left: corner, east, west; every check passed" in result.stdout
    (replay,) = [line for line in result.stdout.splitlines() if line.startswith("contact check")]
    assert ", 0 touch a bin; 0 with an arm's link, 0 with the held part (" in replay
    assert int(replay.split("(")[1].split()[0]) > 0  # cycles replayed with a cube in the fingers
    (counted,) = [line for line in result.stdout.splitlines() if "tool-only check" in line]
    assert int(counted.split()[0]) > 0
    refused = [line for line in result.stdout.splitlines() if line.startswith("refused ")]
    assert len(refused) == 3
    corner = refused[0]
    for yaw in (0, 90, 180, 270):
        assert f"yaw {yaw} deg, tilt 0 deg) collision: tool 'finger" in corner
    assert "wall 'east'" in corner
    assert "wall 'north'" in corner
    for wall in ("east", "west"):  # the fingers fit along the wall, the last wrist does not
        assert any(
            f"tilt 0 deg) arm collision: wrist 3 would come 12 mm into bin 'parts' wall '{wall}'"
            in line
            for line in refused[1:]
        )
    records = [json.loads(line) for line in (tmp_path / "picks.jsonl").read_text().splitlines()]
    plans = [r for r in records if r.get("event") == "plan" and "alternative" in r]
    assert len(plans) == 3  # each pick's plan says which grasp it took and why not the others
