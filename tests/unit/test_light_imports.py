"""Commands start light: none loads matplotlib, scipy or numba unless it draws or JIT-compiles.

Each case runs the CLI in a fresh interpreter (a module, once imported, stays in sys.modules) and
reports the heavy modules it loaded. No timing: what is imported is what costs the start-up time
(benchmarks/startup.py measures it).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("matplotlib", "scipy", "numba", "llvmlite", "cv2", "open3d")

_PROBE = """
import json, sys
from handeye_pick.cli import main
try:
    status = main(json.loads(sys.argv[1]))
except SystemExit as exc:  # --help ends through argparse
    status = exc.code
heavy = sorted(m for m in sys.modules if m.split(".")[0] in json.loads(sys.argv[2]))
print(json.dumps({"status": status, "heavy": heavy}), file=sys.stderr)
"""


def _registered_commands() -> list[str]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sorted(sub.choices)


def _heavy_modules_loaded(argv: list[str], cwd: Path) -> list[str]:
    """Run ``handeye-pick argv`` in a new interpreter; the heavy modules it imported."""
    result = subprocess.run(
        [sys.executable, "-c", _PROBE, json.dumps(argv), json.dumps(HEAVY)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    report = json.loads(result.stderr.strip().splitlines()[-1])
    assert report["status"] == 0, result.stdout + result.stderr
    heavy: list[str] = report["heavy"]
    return heavy


@pytest.mark.parametrize("command", [[], *([name] for name in _registered_commands())], ids=str)
def test_help_loads_nothing_heavy(command: list[str]) -> None:
    assert _heavy_modules_loaded([*command, "--help"], ROOT) == []


@pytest.mark.parametrize(
    "command_line",
    [
        "convert --from ur --to euler --sequence xyz --angle-unit deg 0.4 0.1 0.3 0 3.14159 0",
        "convert --from matrix --to quat-wxyz 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1",
        "point --mode eye-to-hand --calibration config/calibration/EyeToHandTransform.yaml "
        "--xyz 37.77 -145.92 1227.1",
        "point --mode eye-in-hand --calibration config/calibration/EyeInHandTransform.yaml "
        "--robot-pose-ur 0.4 0.1 0.3 0 3.14159 0 --xyz 83.95 28.84 305.7 --json",
    ],
    ids=["convert-euler", "convert-matrix", "point-eye-to-hand", "point-eye-in-hand"],
)
def test_commands_without_a_robot_load_nothing_heavy(command_line: str) -> None:
    assert _heavy_modules_loaded(command_line.split(), ROOT) == []


def test_a_small_cloud_job_does_not_load_the_jit(tmp_path: Path) -> None:
    # A one-off job in a fresh process transforms with numpy: loading numba would cost more.
    np.save(tmp_path / "camera.npy", np.ones((40, 30, 3), dtype=np.float32))
    assert _heavy_modules_loaded(_cloud_argv("camera.npy", "base.ply"), tmp_path) == []
    assert _heavy_modules_loaded(_cloud_argv("base.ply", "again.npy"), tmp_path) == []


def _cloud_argv(source: str, target: str) -> list[str]:
    calibration = ROOT / "config" / "calibration" / "EyeToHandTransform.yaml"
    return ["cloud", "--mode", "eye-to-hand", "--calibration", str(calibration), source, target]
