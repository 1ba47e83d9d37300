"""The start-up and cloud-job benchmarks keep running: tiny inputs, one round, figures not read.

Their figures are for people (docs/benchmarks.md); these tests only keep the scripts from rotting
when a command's options change. No timing is asserted.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("script", "options", "expected"),
    [
        ("startup.py", ["--repeats", "1"], "handeye-pick point:"),
        ("cloud_job.py", ["--repeats", "1", "--rows", "4", "--cols", "5"], "PLY -> PLY:"),
    ],
)
def test_benchmark_script_runs(script: str, options: list[str], expected: str) -> None:
    result = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / script), *options],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert expected in result.stdout
