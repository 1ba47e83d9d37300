"""Commands start light: none loads matplotlib, scipy or numba unless it draws or JIT-compiles,
and a command imports no other command's module.

Each case runs the CLI in a fresh interpreter (a module, once imported, stays in sys.modules) and
reports the modules it loaded. No timing: what is imported is what costs the start-up time
(benchmarks/startup.py measures it).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.cli import COMMANDS, MODULES, parser_with

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("matplotlib", "scipy", "numba", "llvmlite", "cv2", "open3d")

_PROBE = """
import json, sys
from handeye_pick.cli import main
try:
    status = main(json.loads(sys.argv[1]))
except SystemExit as exc:  # --help ends through argparse
    status = exc.code
print(json.dumps({"status": status, "modules": sorted(sys.modules)}), file=sys.stderr)
"""


def _modules_loaded(argv: list[str], cwd: Path) -> list[str]:
    """Run ``handeye-pick argv`` in a new interpreter; every module it imported."""
    result = subprocess.run(
        [sys.executable, "-c", _PROBE, json.dumps(argv)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    report = json.loads(result.stderr.strip().splitlines()[-1])
    assert report["status"] == 0, result.stdout + result.stderr
    modules: list[str] = report["modules"]
    return modules


def _heavy(modules: list[str]) -> list[str]:
    return [m for m in modules if m.split(".")[0] in HEAVY]


def test_top_level_help_imports_no_command_module() -> None:
    loaded = _modules_loaded(["--help"], ROOT)
    assert _heavy(loaded) == []
    assert [m for m in loaded if m.startswith("handeye_pick.cli.")] == []


@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_commands_help_loads_nothing_heavy(command: str) -> None:
    loaded = _modules_loaded([command, "--help"], ROOT)
    assert f"handeye_pick.cli.{COMMANDS[command][0]}" in loaded
    assert _heavy(loaded) == []


def test_summaries_listed_without_the_modules_match_the_modules_own() -> None:
    # The top-level --help, built from COMMANDS alone, is the one the complete parser prints:
    # every command of every module is in COMMANDS, with its sub-parser's own help line.
    assert parser_with(()).format_help() == parser_with().format_help()


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
def test_commands_without_a_robot_load_nothing_heavy_and_no_other_command(
    command_line: str,
) -> None:
    argv = command_line.split()
    loaded = _modules_loaded(argv, ROOT)
    assert _heavy(loaded) == []
    own = f"handeye_pick.cli.{COMMANDS[argv[0]][0]}"
    assert own in loaded
    other_commands = {f"handeye_pick.cli.{module}" for module in MODULES} - {own}
    assert other_commands.isdisjoint(loaded)


def test_a_small_cloud_job_does_not_load_the_jit(tmp_path: Path) -> None:
    # A one-off job in a fresh process transforms with numpy: loading numba would cost more.
    np.save(tmp_path / "camera.npy", np.ones((40, 30, 3), dtype=np.float32))
    assert _heavy(_modules_loaded(_cloud_argv("camera.npy", "base.ply"), tmp_path)) == []
    assert _heavy(_modules_loaded(_cloud_argv("base.ply", "again.npy"), tmp_path)) == []


def _cloud_argv(source: str, target: str) -> list[str]:
    calibration = ROOT / "config" / "calibration" / "EyeToHandTransform.yaml"
    return ["cloud", "--mode", "eye-to-hand", "--calibration", str(calibration), source, target]


def test_every_public_name_is_exported_and_importable() -> None:
    import handeye_pick

    assert set(handeye_pick.__all__) == {"__version__", *handeye_pick._EXPORTS}
    for name in handeye_pick.__all__:
        assert getattr(handeye_pick, name) is not None


def test_each_command_has_its_own_module_named_after_it() -> None:
    for command, (module, _) in COMMANDS.items():
        assert module == command.replace("-", "_"), command
    assert len(MODULES) == len(COMMANDS)


def test_a_report_without_a_plot_loads_nothing_heavy(tmp_path: Path) -> None:
    # matplotlib only for --plot: a report for the terminal or a script starts light.
    record = {"schema": 2, "timestamp": "2026-12-02T06:00:00+00:00", "pick_id": "p"}
    outcome = {**record, "event": "outcome", "status": "placed", "request_id": None}
    (tmp_path / "free-audit.jsonl").write_text(json.dumps(outcome) + "\n")
    loaded = _modules_loaded(["report", "free-audit.jsonl", "--json"], tmp_path)
    assert "handeye_pick.report.shift" in loaded
    assert _heavy(loaded) == []
    other_commands = {f"handeye_pick.cli.{module}" for module in MODULES} - {
        "handeye_pick.cli.report"
    }
    assert other_commands.isdisjoint(loaded)
