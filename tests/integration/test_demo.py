"""The Quickstart's demo: examples/simulated_pick.py runs a whole pick on 127.0.0.1."""

from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _port_taken(host: str, port: int) -> bool:
    with socket.socket() as sock:
        sock.settimeout(0.5)
        return sock.connect_ex((host, port)) == 0


def test_simulated_pick_demo_runs_to_the_end(tmp_path: Path) -> None:
    if _port_taken("127.0.0.1", 30004):
        pytest.skip("a controller (or the demo) is already running on 127.0.0.1")
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "simulated_pick.py")],
        cwd=tmp_path,  # works from anywhere
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "pick picked" in result.stdout
    for step in ("approach", "grasp", "retreat"):
        assert f"{step} done in" in result.stderr
