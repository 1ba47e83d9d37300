"""examples/vision_loop.py end to end: the simulated camera and controller, `handeye-pick run`
through a pipe, five capture/pick/place cycles, every grasp within 1 mm of the true box centre."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.conftest import next_loopback_host

ROOT = Path(__file__).resolve().parents[2]


def _free_host() -> str:
    """A 127.0.0.N on which nothing listens on RTDE's port (another session may hold one)."""
    for _ in range(20):
        host = next_loopback_host()
        with socket.socket() as sock:
            sock.settimeout(0.5)
            if sock.connect_ex((host, 30004)) != 0:
                return host
    raise RuntimeError("no free 127.0.0.N address after 20 tries")


def example_config(tmp_path: Path, config_name: str) -> Path:
    """A copy of config/``config_name`` in ``tmp_path`` for a test: a free 127.0.0.N for the
    simulated controller (never 127.0.0.1, the example's own), the hand-eye file's absolute
    path, the audit file in ``tmp_path``."""
    config = ROOT / "config" / config_name
    doc = yaml.safe_load(config.read_text())
    doc["robot"]["host"] = _free_host()
    doc["hand_eye"]["file"] = str(config.parent / doc["hand_eye"]["file"])
    doc["audit"]["file"] = str(tmp_path / "picks.jsonl")
    copy = tmp_path / config_name
    copy.write_text(yaml.safe_dump(doc))
    return copy


@pytest.mark.parametrize("config_name", ["loop.yaml", "loop-eye-to-hand.yaml"])
def test_five_cycles_place_every_box_with_every_grasp_within_a_millimetre(
    tmp_path: Path, config_name: str
) -> None:
    config = example_config(tmp_path, config_name)
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "vision_loop.py"), "--config", str(config)],
        cwd=tmp_path, capture_output=True, text=True, timeout=180, check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "5 of 5 cycles, every check passed" in result.stdout
    cycles = [line for line in result.stdout.splitlines() if line.startswith("cycle ")]
    assert [line.split(":")[0] for line in cycles] == [f"cycle {n}" for n in range(1, 6)]
    assert sorted(line.split("picked box ")[1][0] for line in cycles) == list("abcde")
    assert all("vision hidden" in line for line in cycles), cycles
    records = [json.loads(line) for line in (tmp_path / "picks.jsonl").read_text().splitlines()]
    placed = [r["cycle"] for r in records if r.get("status") == "placed"]
    # Every cycle's outcome is on disk. Eye-to-hand, each pick starts its own cycle: the
    # capture that only took the arm aside for the first image counted one.
    first = 1 if config_name == "loop.yaml" else 2
    assert placed == list(range(first, first + 5))
